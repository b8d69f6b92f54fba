#!/usr/bin/env python3
"""The verdict on held-out sensors: `imunoise fit --curve` of the Allan variance curves the R
package avar publishes for four more IMUs (../shared/data/sensor_curves/avar_curves.csv: IMAR,
KVH1750, LN200, NavChip; the ADIS16405 there is the recording the tests use), each channel's
model selected from a class by WIC, the CIs from the record length (the curves' own are avar's
Gaussian ones). Prints per channel the scales inside the 95 % CI and the verdict, and the count
of adequate channels.

    python3 scripts/heldout_curves.py [IMUNOISE_BIN] [--model CLASS]

Standard library only; the curve files are written to a temporary folder.
"""
import collections
import csv
import json
import os
import subprocess
import sys
import tempfile

SENSORS = {1: "IMAR", 2: "KVH1750", 3: "LN200", 4: "NavChip"}
CHANNELS = ["gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]


def main(argv):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    model = "QN+WN+RW+BI+2*SIN+2*AR1"
    args = list(argv)
    if "--model" in args:
        i = args.index("--model")
        model = args[i + 1]
        del args[i : i + 2]
    binary = args[0] if args else os.path.join(root, "target", "release", "imunoise")
    src = os.path.join(root, "..", "shared", "data", "sensor_curves", "avar_curves.csv")
    if not os.path.exists(src):
        print(f"skipping: {src} not found")
        return 0
    rows = collections.defaultdict(list)
    with open(src) as f:
        for r in csv.DictReader(f):
            rows[int(float(r["sensor_idx"]))].append(r)
    total = adequate = 0
    with tempfile.TemporaryDirectory() as d:
        for s, name in SENSORS.items():
            rs = rows[s]
            path = os.path.join(d, f"{name}.csv")
            with open(path, "w") as f:
                f.write("channel,tau,avar\n")
                for r in rs:
                    ch = CHANNELS[int(float(r["channel_idx"]))]
                    f.write(f"{ch},{r['tau_s']},{r['avar']}\n")
            rate, n = rs[0]["freq_hz"], str(int(float(rs[0]["n"])))
            out = subprocess.run(
                [binary, "fit", "--curve", path, "--rate", rate, "--samples", n, "--select",
                 "--model", model, "-f", "json", "-q"],
                capture_output=True, text=True, check=True,
            )
            for c in json.loads(out.stdout)["channels"]:
                a = c["adequacy"]
                total += 1
                adequate += a["adequate"]
                verdict = "adequate" if a["adequate"] else "NOT adequate"
                print(f"{name:8} {c['name']:7} {a['n_inside']:2}/{a['n_scales']:2} {verdict}")
    print(f"{adequate} of {total} channels adequate with {model}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
