"""Many logs at once: :func:`imunoise.analyze` mapped over files, on Dask when given a client.

A fleet (a production line characterising units, a robot fleet checking its IMUs) is many
logs with one analysis each. :func:`analyze_many` runs them serially, or on a
``dask.distributed`` cluster (the ``imunoise[dask]`` extra) when given a ``Client``: each
file is one task calling the same :func:`imunoise.analyze`, so the results are the serial
loop's, bit for bit, in the order of ``paths``.

The fleet summary flags units whose noise terms lie outside the fleet's spread, per axis
(channel) and term (N, B, K from the fitted model, in IEEE units), with a robust z-score on
the log10 scale (noise amplitudes spread multiplicatively)::

    z = (log10 x - median) / (1.4826 * MAD)

where median and MAD (median absolute deviation) are taken over the fleet; a unit is flagged
when ``|z| > z_limit`` (3.5 by default, Iglewicz and Hoaglin's outlier rule) and, when the
term has a confidence interval, the fleet median lies outside the unit's interval (a term
that the unit's own record cannot pin down, such as K from a short log, is not flagged for
its scatter alone). 1.4826 * MAD estimates the standard deviation of Gaussian data, so z
reads as "standard deviations". With fewer than ``min_units`` (5) units, or MAD = 0, no z is
computed and nothing is flagged.
"""

from __future__ import annotations

import math
import os
from typing import Any, Dict, List, Optional, Sequence

from . import analyze

__all__ = ["FleetResult", "analyze_many", "unit_row", "fleet_summary", "IEEE_TERMS"]

#: The IEEE 952 terms the rows and the summary report (when the fitted model has them):
#: N (angle/velocity random walk), B (bias instability), K (rate random walk).
IEEE_TERMS = ("N", "B", "K")


def _unit_name(path: Any) -> str:
    base = os.path.basename(os.fspath(path).rstrip("/"))
    for ext in (".gz",):
        if base.endswith(ext):
            base = base[: -len(ext)]
    return os.path.splitext(base)[0] or base


def _analyze_one(path: Any, options: Dict[str, Any]) -> Dict[str, Any]:
    return analyze(os.fspath(path), **options)


def unit_row(unit: str, path: Any, results: Dict[str, Any]) -> Dict[str, Any]:
    """One unit's row from its ``results.json``: per axis (channel) the fitted model, its
    per-sample parameters with CIs, and N, B, K (value, ci_lo, ci_hi, unit; None when the
    model has no such term).

    >>> import imunoise
    >>> from imunoise import fleet
    >>> x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0)
    >>> doc = imunoise.analyze(x, rate=100.0, select=False, model="WN+RW", names=["gyro_x"],
    ...                        unit="deg/s")
    >>> row = fleet.unit_row("u01", "u01.csv", doc)
    >>> row["unit"], row["file"], row["rate_hz"], list(row["axes"])
    ('u01', 'u01.csv', 100.0, ['gyro_x'])
    >>> a = row["axes"]["gyro_x"]
    >>> a["n"], a["unit"], [p["process"] for p in a["parameters"]]
    (4096, 'deg/s', ['WN', 'RW'])
    >>> # WN gives N and RW gives K; the model has no bias-instability term B
    >>> a["N"]["value"] == doc["channels"][0]["fit"]["ieee"]["N"]["value"], a["B"]
    (True, None)
    """
    axes: Dict[str, Any] = {}
    for ch in results["channels"]:
        f = ch["fit"]
        ieee = f.get("ieee", {})
        axis: Dict[str, Any] = {
            "n": ch["n"],
            "unit": ch["unit"],
            "model": f["model"],
            "parameters": [
                {k: p[k] for k in ("process", "name", "value", "ci_lo", "ci_hi")}
                for p in f["parameters"]
            ],
        }
        for t in IEEE_TERMS:
            v = ieee.get(t)
            axis[t] = (
                None
                if v is None
                else {"value": v["value"], "ci_lo": v.get("ci_lo"), "ci_hi": v.get("ci_hi"),
                      "unit": v.get("unit")}
            )
        axes[ch["name"]] = axis
    return {"unit": unit, "file": os.fspath(path), "rate_hz": results["rate_hz"], "axes": axes}


def _median(v: List[float]) -> float:
    s = sorted(v)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def fleet_summary(
    rows: Sequence[Dict[str, Any]], z_limit: float = 3.5, min_units: int = 5
) -> Dict[str, Any]:
    """Per axis and term: the fleet's median, MAD (both of log10 values), the number of units,
    each unit's robust z and the flagged units (see the module docstring).

    >>> from imunoise import fleet
    >>> # six units; log10 N = 0, 0, 0.1, -0.1, 0 and 2 (u5: 100 times the others)
    >>> rows = [{"unit": f"u{i}", "axes": {"x": {"N": {"value": 10.0 ** e}}}}
    ...         for i, e in enumerate([0, 0, 0.1, -0.1, 0, 2])]
    >>> s = fleet.fleet_summary(rows)
    >>> e = s["terms"]["x.N"]
    >>> e["units"], e["median"]                  # median of log10: 0, so 10^0
    (6, 1.0)
    >>> # |deviations| 0, 0, 0.1, 0.1, 0, 2: MAD = (0 + 0.1) / 2 = 0.05
    >>> abs(e["mad_log10"] - 0.05) < 1e-12
    True
    >>> abs(e["z"]["u5"] - 2 / (1.4826 * 0.05)) < 1e-9   # z = 27, beyond 3.5
    True
    >>> [(f["unit"], f["term"]) for f in s["flagged"]]   # the others: |z| <= 1.35
    [('u5', 'N')]
    >>> fleet.fleet_summary(rows[:4])["flagged"]        # fewer than 5 units: no judgement
    []
    """
    terms: Dict[str, Dict[str, Any]] = {}
    flagged: List[Dict[str, Any]] = []
    keys = []
    for r in rows:
        for axis, a in r["axes"].items():
            for t in IEEE_TERMS:
                if a.get(t) is not None and (axis, t) not in keys:
                    keys.append((axis, t))
    for axis, t in keys:
        vals = []
        for r in rows:
            a = r["axes"].get(axis)
            e = None if a is None else a.get(t)
            v = None if e is None else e["value"]
            if v is not None and v > 0 and math.isfinite(v):
                vals.append((r["unit"], v, e.get("ci_lo"), e.get("ci_hi")))
        entry: Dict[str, Any] = {"units": len(vals), "median": None, "mad": None, "z": {}}
        if vals:
            logs = [math.log10(v[1]) for v in vals]
            med = _median(logs)
            mad = _median([abs(x - med) for x in logs])
            entry["median"] = 10.0**med
            entry["mad_log10"] = mad
            if len(vals) >= min_units and mad > 0:
                for (u, v, lo, hi), x in zip(vals, logs):
                    z = (x - med) / (1.4826 * mad)
                    entry["z"][u] = z
                    inside_ci = lo is not None and hi is not None and lo <= 10.0**med <= hi
                    if abs(z) > z_limit and not inside_ci:
                        flagged.append({"unit": u, "axis": axis, "term": t, "value": v,
                                        "fleet_median": 10.0**med, "z": z})
        terms[f"{axis}.{t}"] = entry
    return {"z_limit": z_limit, "min_units": min_units, "terms": terms, "flagged": flagged}


class FleetResult:
    """What :func:`analyze_many` returns: ``rows`` (one per unit, in the order of the
    paths), ``summary`` (see :func:`fleet_summary`), ``flagged`` (the summary's flagged
    units) and ``results`` (each unit's full ``results.json`` dict).

    >>> from imunoise import fleet
    >>> rows = [{"unit": f"u{i}", "axes": {"x": {"N": {"value": 10.0 ** e}}}}
    ...         for i, e in enumerate([0, 0, 0.1, -0.1, 0, 2])]
    >>> r = fleet.FleetResult(rows, [{}] * 6, fleet.fleet_summary(rows))
    >>> r
    FleetResult(units=6, flagged=1)
    >>> r.flagged is r.summary["flagged"], r.flagged[0]["unit"]
    (True, 'u5')
    """

    def __init__(self, rows: List[Dict[str, Any]], results: List[Dict[str, Any]],
                 summary: Dict[str, Any]) -> None:
        self.rows = rows
        self.results = results
        self.summary = summary
        self.flagged = summary["flagged"]

    def report(self) -> str:
        """The fleet summary as text: one line per axis and term, then the flagged units.

        >>> from imunoise import fleet
        >>> # log10 N = 0, 0, 0.1, -0.1, 0, 2: median 0, MAD 0.05, z(u5) = 2 / (1.4826 * 0.05)
        >>> rows = [{"unit": f"u{i}", "axes": {"x": {"N": {"value": 10.0 ** e}}}}
        ...         for i, e in enumerate([0, 0, 0.1, -0.1, 0, 2])]
        >>> print(fleet.FleetResult(rows, [{}] * 6, fleet.fleet_summary(rows)).report())
        fleet of 6 units; flagged when |robust z| > 3.5 (log10 scale, median/MAD)
          x.N: median 1 over 6 units
          FLAG u5 x.N = 100 (fleet median 1, z = +27.0)
        """
        lines = [f"fleet of {len(self.rows)} units; flagged when |robust z| > "
                 f"{self.summary['z_limit']} (log10 scale, median/MAD)"]
        for key, e in self.summary["terms"].items():
            med = "-" if e["median"] is None else f"{e['median']:.4g}"
            lines.append(f"  {key}: median {med} over {e['units']} units")
        if not self.flagged:
            lines.append("no unit lies outside the fleet's spread")
        for f in self.flagged:
            lines.append(f"  FLAG {f['unit']} {f['axis']}.{f['term']} = {f['value']:.4g} "
                         f"(fleet median {f['fleet_median']:.4g}, z = {f['z']:+.1f})")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"FleetResult(units={len(self.rows)}, flagged={len(self.flagged)})"


def analyze_many(
    paths: Sequence[Any],
    client: Optional[Any] = None,
    z_limit: float = 3.5,
    **options: Any,
) -> FleetResult:
    """:func:`imunoise.analyze` of every file in ``paths`` (``options`` as there: ``rate``,
    ``model``, ``select``, ``columns``, ...), serially or, with a ``dask.distributed``
    ``Client``, one task per file on its cluster. Same results either way, bit for bit.

    Returns a :class:`FleetResult`: one row per unit (named after its file) with N, B, K and
    the fitted model with CIs per axis, and the fleet summary flagging outliers.

    >>> import json, os, tempfile, numpy as np, imunoise
    >>> from imunoise import fleet
    >>> with tempfile.TemporaryDirectory() as d:
    ...     paths = []
    ...     for seed, name in enumerate(["a", "b"], start=1):
    ...         x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0,
    ...                               seed=seed, channels=2)
    ...         paths.append(os.path.join(d, name + ".csv"))
    ...         np.savetxt(paths[-1], x, delimiter=",", fmt="%.17g",
    ...                    header="gyro_x_dps,gyro_y_dps", comments="")
    ...     r = fleet.analyze_many(paths, rate=100.0, select=False, model="WN+RW")
    ...     b = imunoise.analyze(paths[1], rate=100.0, select=False, model="WN+RW")
    >>> r, [row["unit"] for row in r.rows], list(r.rows[0]["axes"])
    (FleetResult(units=2, flagged=0), ['a', 'b'], ['gyro_x_dps', 'gyro_y_dps'])
    >>> json.dumps(r.results[1]) == json.dumps(b)   # each unit's analyze(), bit for bit
    True
    """
    paths = list(paths)
    if "out" in options:
        raise TypeError("analyze_many writes no report folders: 'out' is not an option")
    if client is None:
        results = [_analyze_one(p, options) for p in paths]
    else:
        futures = client.map(_analyze_one, paths, options=options, pure=False)
        results = client.gather(futures)
    names = [_unit_name(p) for p in paths]
    seen: Dict[str, int] = {}
    for i, n in enumerate(names):
        if n in seen:
            seen[n] += 1
            names[i] = f"{n}#{seen[n]}"
        else:
            seen[n] = 1
    rows = [unit_row(n, p, r) for n, p, r in zip(names, paths, results)]
    return FleetResult(rows, results, fleet_summary(rows, z_limit=z_limit))
