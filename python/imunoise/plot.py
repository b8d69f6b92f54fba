"""Matplotlib plots of imunoise results (the ``plot`` extra): Allan deviation against tau on
log-log axes, tau in s and the deviation in the input's units, with the CI band."""

from __future__ import annotations

from typing import Any

import numpy as np


def _axes(ax: Any) -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - exercised only without matplotlib
        raise ImportError(
            "imunoise.plot needs matplotlib: pip install 'imunoise[plot]'"
        ) from e
    if ax is None:
        _, ax = plt.subplots()
    return ax


def _curve(ax: Any, tau: Any, adev: Any, lo: Any, hi: Any, label: str) -> None:
    (line,) = ax.loglog(tau, adev, marker="o", ms=3, label=label)
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    ok = np.isfinite(lo) & np.isfinite(hi) & (lo > 0)
    if ok.any():
        ax.fill_between(np.asarray(tau)[ok], np.sqrt(lo[ok]), np.sqrt(hi[ok]),
                        color=line.get_color(), alpha=0.2, lw=0)


def plot(result: Any, ax: Any = None, title: Any = None) -> Any:
    """Plots ``avar`` results (one or a list), a ``TheoryResult`` (with its components) or an
    ``analyze`` document (each channel's Allan deviation and fitted model). Returns the Axes.

    >>> import numpy as np, imunoise
    >>> from imunoise.plot import plot
    >>> from matplotlib.figure import Figure   # a figure without pyplot: no window
    >>> t = imunoise.theory("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 100.0)
    >>> ax = plot(t, ax=Figure().add_subplot(), title="gyro")
    >>> len(ax.get_lines()), ax.get_title()      # the model and its two components
    (3, 'gyro')
    >>> x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0, channels=2)
    >>> doc = imunoise.analyze(x, rate=100.0, select=False, model="WN+RW")
    >>> ax = plot(doc, ax=Figure().add_subplot())
    >>> len(ax.get_lines())                      # per channel: its AD and its fitted model
    4
    >>> ax.get_xscale(), ax.get_yscale()
    ('log', 'log')
    >>> plot(42, ax=Figure().add_subplot())
    Traceback (most recent call last):
        ...
    TypeError: imunoise.plot: cannot plot int
    """
    from . import AvarResult, TheoryResult

    ax = _axes(ax)
    items = result if isinstance(result, (list, tuple)) else [result]
    for r in items:
        if isinstance(r, AvarResult):
            _curve(ax, r.tau, r.adev, r.lo, r.hi, r.name)
        elif isinstance(r, TheoryResult):
            ax.loglog(r.tau, r.adev, lw=2, label=r.model)
            for name, adev in r.components.items():
                ax.loglog(r.tau, adev, ls="--", lw=1, label=name)
        elif isinstance(r, dict) and "channels" in r:
            rate = r.get("rate_hz")
            for ch in r["channels"]:
                pts = ch["avar"]
                tau = np.array([p["tau"] for p in pts])
                nan = float("nan")
                lo = [nan if p["avar_lo"] is None else p["avar_lo"] for p in pts]
                hi = [nan if p["avar_hi"] is None else p["avar_hi"] for p in pts]
                _curve(ax, tau, [p["adev"] for p in pts], lo, hi, ch["name"])
                fitted = ch.get("fit", {}).get("fitted", [])
                if fitted and rate:
                    ax.loglog([f["m"] / rate for f in fitted],
                              [np.sqrt(f["avar"]) for f in fitted], "k:", lw=1)
        else:
            raise TypeError(f"imunoise.plot: cannot plot {type(r).__name__}")
    ax.set_xlabel("tau [s]")
    ax.set_ylabel("Allan deviation [input unit]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    if title:
        ax.set_title(title)
    return ax
