#!/usr/bin/env python3
"""Inside-CI fraction of a fit: for each channel of one or more `imunoise analyze`
results.json files, the share of scales whose fitted Allan variance lies inside the AV's CI
(avar_lo..avar_hi), and how many channels reach a threshold (default 0.9).

    python3 scripts/inside_ci.py out1/results.json out2/results.json [--threshold 0.9]

Standard library only. Prints one line per channel (file, name, inside/total, model) and
the count of channels at or above the threshold.
"""
import json
import sys


def main(argv):
    thr = 0.9
    files = []
    it = iter(argv)
    for a in it:
        if a == "--threshold":
            thr = float(next(it))
        else:
            files.append(a)
    if not files:
        print(__doc__)
        return 2
    good = total = 0
    for f in files:
        doc = json.load(open(f))
        for ch in doc["channels"]:
            fitted = {p["m"]: p["avar"] for p in ch["fit"].get("fitted", [])}
            inside = n = 0
            for p in ch["avar"]:
                lo, hi = p.get("avar_lo"), p.get("avar_hi")
                if lo is None or hi is None or p["m"] not in fitted:
                    continue
                n += 1
                inside += lo <= fitted[p["m"]] <= hi
            frac = inside / n if n else float("nan")
            total += 1
            good += frac >= thr
            print(f"{f}\t{ch['name']}\t{inside}/{n}\t{frac:.2f}\t{ch['fit'].get('model', '')}")
    print(f"channels with >= {thr:.0%} of scales inside the CI: {good} of {total}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
