"""imunoise.fleet.analyze_many: serial and on a 2-worker distributed.LocalCluster, bit for
bit the same; one row per unit; the robust z-score flags the odd unit."""

import json
import math

import numpy as np
import pytest

import imunoise
from imunoise import fleet

RATE = 100.0
UNITS = 7


@pytest.fixture(scope="module")
def fleet_files(tmp_path_factory):
    """Seven 3-axis gyro logs of the same model; unit u07's white noise is 100x larger
    (its N 10x): the one the summary must flag."""
    d = tmp_path_factory.mktemp("fleet")
    paths = []
    for u in range(1, UNITS + 1):
        wn = 1e-2 if u == UNITS else 1e-4
        x = imunoise.simulate(f"WN(sigma2={wn}) + RW(gamma2=1e-9)", 1 << 14, RATE, seed=u,
                              channels=3)
        p = d / f"u{u:02d}.csv"
        np.savetxt(p, x, delimiter=",", fmt="%.17g",
                   header="gyro_x_dps,gyro_y_dps,gyro_z_dps", comments="")
        paths.append(p)
    return paths


# The fleet summary's rule is under test here, not the default model class: the sub-models of
# QN+WN+RW+2*AR1 (the class before BI and SIN joined it), whose selection on these 2^14-sample
# WN + RW records keeps a white noise on every axis. (With the larger default class a few of
# the 21 axes are fitted with QN + SIN + an AR1 in place of WN, which moves their N by up to
# 6 %: a known weakness of selecting from the larger class on short records.)
CLASS = "QN+WN+RW+2*AR1"


@pytest.fixture(scope="module")
def serial(fleet_files):
    return fleet.analyze_many(fleet_files, rate=RATE, model=CLASS)


def test_rows_one_per_unit(serial, fleet_files):
    assert [r["unit"] for r in serial.rows] == [f"u{u:02d}" for u in range(1, UNITS + 1)]
    axis = serial.rows[0]["axes"]["gyro_x_dps"]
    assert set(axis) >= {"model", "parameters", "N", "B", "K", "unit", "n"}
    n = axis["N"]
    assert n["ci_lo"] <= n["value"] <= n["ci_hi"] and "h" in n["unit"]
    # the row is the results.json of that file
    one = imunoise.analyze(fleet_files[0], rate=RATE, model=CLASS)
    assert json.dumps(one) == json.dumps(serial.results[0])


def test_summary_flags_the_noisy_unit(serial):
    # N (white noise) is pinned down to about 1 % by 2^14 samples: exactly u07 is flagged,
    # on each axis. (K from 2^14 samples has CIs of a factor 2 and is left out here: a
    # chance flag on it would be the rule working as stated, not an error.)
    flagged_n = {(f["unit"], f["axis"]) for f in serial.flagged if f["term"] == "N"}
    assert flagged_n == {("u07", a) for a in ("gyro_x_dps", "gyro_y_dps", "gyro_z_dps")}
    e = serial.summary["terms"]["gyro_x_dps.N"]
    assert e["units"] == UNITS
    # the robust z of the odd unit: log10 of a 10x larger N is 1 above the median, against a
    # spread (1.4826 MAD) of a few 0.01 among equal units: far beyond 3.5
    assert e["z"]["u07"] > 3.5
    assert "u07" in serial.report()


def test_robust_z_by_hand():
    rows = [{"unit": f"u{i}", "axes": {"x": {"N": {"value": v}}}}
            for i, v in enumerate([1.0, 1.1, 0.9, 1.05, 0.95, 5.0])]
    s = fleet.fleet_summary(rows)
    logs = np.log10([1.0, 1.1, 0.9, 1.05, 0.95, 5.0])
    med = np.median(logs)
    mad = np.median(np.abs(logs - med))
    assert s["terms"]["x.N"]["z"]["u5"] == pytest.approx((logs[5] - med) / (1.4826 * mad))
    assert [f["unit"] for f in s["flagged"]] == ["u5"]
    # too few units: nothing is judged
    assert fleet.fleet_summary(rows[:4])["flagged"] == []


@pytest.mark.parametrize("processes", [False, True])
def test_dask_localcluster_identical_to_serial(fleet_files, serial, processes):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=processes,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        par = fleet.analyze_many(fleet_files, client=client, rate=RATE, model=CLASS)
    assert json.dumps(par.results) == json.dumps(serial.results)  # bit for bit (repr of floats)
    assert par.rows == serial.rows
    assert par.summary == serial.summary


def test_options_pass_through(fleet_files):
    r = fleet.analyze_many(fleet_files[:2], rate=RATE, select=False, model="WN+RW")
    assert all(ch["fit"]["model"].startswith("WN(") for res in r.results for ch in res["channels"])
    with pytest.raises(TypeError):
        fleet.analyze_many(fleet_files[:1], rate=RATE, out="x")
    assert not math.isnan(r.rows[0]["axes"]["gyro_x_dps"]["N"]["value"])
