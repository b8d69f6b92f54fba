"""Checks the first screen of an imunoise report as the browser rendered it.

Usage: python3 check_first_screen.py DOM.html results.json

DOM.html is Chromium's --dump-dom of report.html (the page after the browser parsed and laid
it out); results.json is the analysis the report was written from. For every channel, the
summary table's row must show N, K and B exactly as `processes::number::sig(value, 4)`
formats the values in results.json (`fit.noise_terms`), and the verdict that `fit.adequacy`
gives. Exits 1 with a message naming the first mismatch.
"""
import json
import sys
from html.parser import HTMLParser


def sig(x: float, d: int = 4) -> str:
    """The Rust formatter processes::number::sig, in Python (plain for 1e-3 <= |x| < 1e5)."""
    if x != x or x in (float("inf"), float("-inf")):
        return {True: "NaN"}.get(x != x, "inf" if x > 0 else "-inf")
    if x == 0:
        return "0"
    s = f"{x:.{d - 1}e}"
    mant, exp = s.split("e")
    e = int(exp)
    if -3 <= e < 5:
        decimals = max(d - 1 - e, 0)
        t = f"{x:.{decimals}f}"
        return t.rstrip("0").rstrip(".") if "." in t else t
    mant = mant.rstrip("0").rstrip(".") if "." in mant else mant
    return f"{mant}e{e}"


class Rows(HTMLParser):
    """The cells' text of the table that follows the 'Summary' heading."""

    def __init__(self):
        super().__init__()
        self.in_summary = False
        self.heading = None
        self.rows, self.row, self.cell = [], None, None

    def handle_starttag(self, tag, attrs):
        if tag == "h2":
            self.heading = ""
        elif tag == "table" and self.in_summary and not self.rows:
            self.rows = []
        elif tag == "tr" and self.in_summary:
            self.row = []
        elif tag in ("td", "th") and self.row is not None:
            self.cell = ""
        elif tag == "br" and self.cell is not None:
            self.cell += " "

    def handle_endtag(self, tag):
        if tag == "h2" and self.heading is not None:
            self.in_summary = self.heading.startswith("Summary")
            self.heading = None
        elif tag in ("td", "th") and self.cell is not None:
            self.row.append(self.cell.strip())
            self.cell = None
        elif tag == "tr" and self.row is not None:
            self.rows.append(self.row)
            self.row = None
        elif tag == "table" and self.in_summary:
            self.in_summary = False

    def handle_data(self, data):
        if self.heading is not None:
            self.heading += data
        if self.cell is not None:
            self.cell += data


def main() -> int:
    dom = open(sys.argv[1], encoding="utf-8").read()
    res = json.load(open(sys.argv[2], encoding="utf-8"))
    p = Rows()
    p.feed(dom)
    header, rows = p.rows[0], p.rows[1:]
    col = {name: i for i, name in enumerate(header)}
    channels = res["channels"]
    if len(rows) != len(channels):
        print(f"first screen: {len(rows)} rows for {len(channels)} channels")
        return 1
    for row, ch in zip(rows, channels):
        fit = ch["fit"]
        if row[col["channel"]] != ch["name"]:
            print(f"first screen: row {row[0]!r} for channel {ch['name']!r}")
            return 1
        for sym, head in (("n", "N (ARW/VRW)"), ("k", "K (RRW)"), ("b", "B (bias instability)")):
            t = fit["noise_terms"][sym]
            want = sig(t["value"])
            cell = row[col[head]]
            if not cell.split(" ")[0 if t["source"] != "upper_bound" else 1] == want:
                print(f"first screen: {ch['name']} {sym.upper()}: {cell!r}, results.json {want}")
                return 1
            if t["unit"] not in cell:
                print(f"first screen: {ch['name']} {sym.upper()}: no unit {t['unit']!r} in {cell!r}")
                return 1
        adequate = fit["adequacy"]["adequate"]
        verdict = row[col["verdict"]]
        if verdict.startswith("adequate") != adequate:
            print(f"first screen: {ch['name']}: verdict {verdict!r}, results.json adequate={adequate}")
            return 1
    print(f"first screen: {len(rows)} channels' N, K, B and verdicts equal results.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
