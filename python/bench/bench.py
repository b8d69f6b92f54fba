"""Speed of the Python package, every ratio taken within one run (the machine is shared).

    bash python/bench/run.sh            # builds/installs as scripts/test-python.sh, then this

1. ``imunoise.avar`` on a 10^7 numpy array against the Rust kernel ``avar::allan_variance``
   on the same memory, timed inside Rust by the same compiled module (target: within 1.1x).
2. ``imunoise.avar`` against allantools ``oadev`` (octave tau, rate data) at 10^7, side by
   side (target: >= 50x faster). allantools computes no confidence intervals (only
   dev/sqrt(n)), so the fair pair is ``ci="none"``; ``ci="chi2"`` (the default, with the
   noise identification and EDF per scale) is shown too.
3. ``imunoise.fleet.analyze_many`` on 64 logs of 10^6 x 6 samples (raw f64 files, written once
   under target/bench-fleet) on a 2-worker LocalCluster against the serial loop (target:
   >= 1.7x). The serial loop is itself parallel: ``analyze`` spreads a log's channels over
   both cores with rayon. So the serial loop is also timed with one rayon thread
   (RAYON_NUM_THREADS=1, in a subprocess), and the cluster is run with 1 and with 2 rayon
   threads per worker.

Times are the best of ``--repeats`` runs (fleet: one run each, it takes minutes).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import imunoise
from imunoise import _imunoise, fleet

RATE = 100.0


def best(f, repeats):
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def load():
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def bench_binding(x, repeats):
    out = {}
    for ci in ("none", "chi2"):
        kern = min(_imunoise.kernel_seconds(x, RATE, "dyadic", ci, repeats))
        py = best(lambda: imunoise.avar(x, RATE, ci=ci), repeats)
        out[ci] = (py, kern, py / kern)
        print(f"avar 1e7 dyadic ci={ci}: imunoise.avar {py * 1e3:.1f} ms, Rust kernel "
              f"{kern * 1e3:.1f} ms: {py / kern:.3f}x the kernel (target <= 1.1)", flush=True)
    return out


def bench_allantools(x, repeats):
    import allantools

    at = best(lambda: allantools.oadev(x, rate=RATE, data_type="freq", taus="octave"),
              max(1, repeats // 2))
    ta, da, _, _ = allantools.oadev(x, rate=RATE, data_type="freq", taus="octave")[:4]
    out = {"allantools": at}
    for ci in ("none", "chi2"):
        t = best(lambda: imunoise.avar(x, RATE, scales="octave", ci=ci), repeats)
        out[ci] = (t, at / t)
        print(f"oadev 1e7 octave: allantools {at * 1e3:.0f} ms, imunoise.avar ci={ci} "
              f"{t * 1e3:.1f} ms: {at / t:.1f}x faster (target >= 50)", flush=True)
    r = imunoise.avar(x, RATE, scales="octave", ci="none")
    common = min(len(ta), len(r.tau))
    rel = np.max(np.abs(r.adev[:common] / da[:common] - 1))
    assert np.allclose(r.tau[:common], ta[:common]), "tau grids differ"
    print(f"  same octave taus ({common}); ADEV agrees with allantools to {rel:.1e}", flush=True)
    out["max_rel_diff"] = float(rel)
    return out


def fleet_files(n_logs, n, channels):
    d = Path(os.environ.get("IMUNOISE_ROOT", ".")) / "target" / "bench-fleet"
    d.mkdir(parents=True, exist_ok=True)
    model = "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.999,sigma2=1e-8)"
    paths = []
    for u in range(n_logs):
        p = d / f"unit{u:03d}_{n}x{channels}.f64"
        if not p.exists() or p.stat().st_size != 8 * n * channels:
            x = imunoise.simulate(model, n, RATE, seed=1000 + u, channels=channels)
            np.ascontiguousarray(x).astype("<f8").tofile(p)  # row-major, as --binary f64
        paths.append(p)
    return paths


def serial_one_thread(paths, options):
    """The serial loop in a fresh interpreter with one rayon thread; returns its seconds."""
    code = (
        "import json,sys,time\nfrom imunoise import fleet\n"
        "paths,options=json.loads(sys.argv[1]),json.loads(sys.argv[2])\n"
        "t=time.perf_counter();fleet.analyze_many(paths,**options)\n"
        "print(time.perf_counter()-t)"
    )
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    r = subprocess.run([sys.executable, "-c", code, json.dumps([str(p) for p in paths]),
                        json.dumps(options)], env=env, capture_output=True, text=True, check=True)
    return float(r.stdout.strip().splitlines()[-1])


def bench_fleet(n_logs, n, channels):
    import distributed

    paths = fleet_files(n_logs, n, channels)
    options = {"rate": RATE, "binary": "f64", "channels": channels}
    t = time.perf_counter()
    serial = fleet.analyze_many(paths, **options)
    ts = time.perf_counter() - t
    print(f"fleet {n_logs} logs of {n}x{channels}: serial loop {ts:.1f} s (rayon over "
          f"{os.cpu_count()} cores inside each analysis; load {load()})", flush=True)
    out = {"serial": ts}
    ts1 = serial_one_thread(paths, options)
    out["serial_1thread"] = ts1
    print(f"  serial loop, one rayon thread: {ts1:.1f} s", flush=True)
    for threads in ("1", "2"):
        old = os.environ.get("RAYON_NUM_THREADS")
        os.environ["RAYON_NUM_THREADS"] = threads  # read by the worker processes at start
        try:
            with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                          dashboard_address=None) as c, \
                    distributed.Client(c) as client:
                client.run(lambda: None)
                t = time.perf_counter()
                par = fleet.analyze_many(paths, client=client, **options)
                td = time.perf_counter() - t
        finally:
            if old is None:
                del os.environ["RAYON_NUM_THREADS"]
            else:
                os.environ["RAYON_NUM_THREADS"] = old
        same = json.dumps(par.results) == json.dumps(serial.results)
        out[f"dask_rayon{threads}"] = (td, ts / td, ts1 / td, same)
        print(f"  LocalCluster 2 worker processes x {threads} rayon thread(s): {td:.1f} s = "
              f"{ts / td:.2f}x the serial loop ({ts1 / td:.2f}x the one-thread loop; target "
              f">= 1.7); identical to serial: {same}; load {load()}", flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--logs", type=int, default=64)
    ap.add_argument("--log-samples", type=int, default=1_000_000)
    ap.add_argument("--skip", default="", help="comma list of: binding,allantools,fleet")
    a = ap.parse_args()
    skip = set(a.skip.split(",")) - {""}
    print(f"imunoise {imunoise.__version__}, {os.cpu_count()} cores, load {load()}", flush=True)
    x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-10)", a.n, RATE, seed=1)
    assert x.flags.c_contiguous and x.dtype == np.float64
    res = {}
    if "binding" not in skip:
        res["binding"] = bench_binding(x, a.repeats)
    if "allantools" not in skip:
        res["allantools"] = bench_allantools(x, a.repeats)
    if "fleet" not in skip:
        res["fleet"] = bench_fleet(a.logs, a.log_samples, 6)
    print(f"load at the end {load()}")
    print(json.dumps(res))


if __name__ == "__main__":
    main()
