"""Shared fixtures: the `imunoise` binary (for equality with the command's JSON), a small
simulated two-channel gyro CSV, and a JSON comparison to a relative 1e-15."""

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import imunoise

ROOT = Path(os.environ.get("IMUNOISE_ROOT", Path(__file__).resolve().parents[2]))
MODEL = "WN(sigma2=1e-4) + RW(gamma2=1e-9) + AR1(phi=0.99,sigma2=1e-7)"
RATE = 100.0


def _binary():
    b = os.environ.get("IMUNOISE_BIN")
    if b and Path(b).exists():
        return b
    for p in (ROOT / "target/debug/imunoise", ROOT / "target/release/imunoise"):
        if p.exists():
            return str(p)
    return shutil.which("imunoise")


@pytest.fixture(scope="session")
def cli():
    """Runs the `imunoise` command and returns its stdout parsed as JSON (or text)."""
    b = _binary()
    if b is None:
        pytest.skip("the imunoise binary is not built (scripts/test-python.sh builds it)")

    def run(*args, parse=True):
        r = subprocess.run([b, *map(str, args), "--quiet"], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout) if parse else r.stdout

    return run


@pytest.fixture(scope="session")
def gyro(tmp_path_factory):
    """Two gyro channels in deg/s at 100 Hz, 2^15 samples each, as a CSV with a header line
    (values written with 17 significant digits: they read back exactly)."""
    x = imunoise.simulate(MODEL, 1 << 15, RATE, seed=11, channels=2)
    path = tmp_path_factory.mktemp("gyro") / "unit01.csv"
    np.savetxt(path, x, delimiter=",", fmt="%.17g", header="gyro_x_dps,gyro_y_dps", comments="")
    return path, np.ascontiguousarray(x), ["gyro_x_dps", "gyro_y_dps"]


def assert_json_close(a, b, rel=1e-15, path="$"):
    """Equal JSON documents, numbers to a relative `rel` (ints exactly)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), f"{path}: keys {set(a) ^ set(b)}"
        for k in a:
            assert_json_close(a[k], b[k], rel, f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: lengths differ"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_json_close(x, y, rel, f"{path}[{i}]")
    elif isinstance(a, bool) or a is None or isinstance(a, str):
        assert a == b, f"{path}: {a!r} != {b!r}"
    elif isinstance(a, int) and isinstance(b, int):
        assert a == b, f"{path}: {a} != {b}"
    else:
        a, b = float(a), float(b)
        if math.isnan(a):
            assert math.isnan(b), path
        else:
            assert abs(a - b) <= rel * max(abs(a), abs(b)), f"{path}: {a!r} != {b!r}"
