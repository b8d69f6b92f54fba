"""imunoise: stochastic calibration of inertial sensors from Python.

The same library as the ``imunoise`` command (one Rust pipeline, two faces): the Allan
variance with confidence intervals, GMWM noise-model fits, the whole-log analysis, model
theory and simulation, and the command's file readers. numpy is the only dependency.

Units, everywhere:

* ``rate`` is the sampling rate in Hz; ``tau`` is the averaging time in s (``tau = m / rate``
  for a cluster of ``m`` samples);
* Allan variances (``avar``, ``lo``, ``hi``) are in the input's units squared (e.g. (deg/s)^2
  for a gyro in deg/s), Allan deviations (``adev``) in the input's units;
* model parameters are per sample (dt = 1/rate) in the channel's unit ``u``: WN ``sigma2``
  [u^2], RW ``gamma2`` [u^2 per sample], QN ``q2`` [u^2], DR ``omega`` [u per sample], AR1
  ``phi`` [-] and ``sigma2`` [u^2]; the IEEE 952 values (N, B, K, ...) are in the usual units.

Arrays: a 1-D array is one channel; a 2-D array holds samples in rows and channels in
columns. ``avar`` reads a C-contiguous 1-D float64 array, and the columns of a
Fortran-ordered 2-D float64 array, without copying them; anything else (another dtype, a
strided view, a C-ordered 2-D array) is converted first, and the result's ``copied`` says so.
``fit`` and ``analyze`` on arrays copy the samples once into the pipeline's table.

Errors are :class:`ImunoiseError` (a ``ValueError``) subclasses carrying the library's
message: :class:`InputError`, :class:`UsageError`, :class:`ModelError`,
:class:`EstimationError` (bad samples in an array), :class:`OutputError`. The GIL is released while Rust computes.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _imunoise
from ._imunoise import (
    EstimationError,
    ImunoiseError,
    InputError,
    ModelError,
    OutputError,
    UsageError,
)

# the plotting code (matplotlib imported only when plotting); the function `plot` below
# takes the name `imunoise.plot` back from the submodule
from .plot import plot as _plot_impl  # noqa: E402

__version__ = _imunoise.__version__

__all__ = [
    "AvarResult",
    "EstimationError",
    "FitResult",
    "ImunoiseError",
    "InputError",
    "Model",
    "ModelError",
    "Online",
    "OutputError",
    "Recording",
    "TheoryResult",
    "UsageError",
    "analyze",
    "avar",
    "fit",
    "plot",
    "read",
    "simulate",
    "theory",
    "to_dict",
]

DEFAULT_MODEL = "QN+WN+RW+AR1"


def _nan(v: Optional[float]) -> float:
    return math.nan if v is None else float(v)


def _scales_text(scales: Union[str, Sequence[int]]) -> str:
    if isinstance(scales, str):
        return scales
    return ",".join(str(int(m)) for m in scales)


class AvarResult:
    """One channel's Allan variance: numpy arrays over the cluster sizes.

    Attributes: ``name``; ``rate_hz`` (Hz); ``n`` (samples); ``estimator``; ``m`` (cluster
    sizes, samples, int64); ``tau`` (s); ``avar`` (input units squared); ``adev`` (input
    units); ``lo``, ``hi`` (CI bounds of the AV, NaN without a CI); ``edf`` (equivalent
    degrees of freedom, NaN without a chi-square CI); ``n_terms`` (squared differences, int64);
    ``copied`` (True when the samples had to be converted before reading).
    ``to_dict()`` gives the channel entry of ``imunoise avar --format json``.

    >>> import numpy as np, imunoise
    >>> x = (-1.0) ** np.arange(4096)            # +1, -1, +1, ...: a known AV
    >>> r = imunoise.avar(x, rate=100.0, scales=[1, 2, 3])
    >>> r.n, len(r), r.m.tolist(), r.copied     # a C-contiguous float64 array: read in place
    (4096, 3, [1, 2, 3], False)
    >>> bool(np.allclose(r.tau, r.m / 100.0) and np.allclose(r.adev, np.sqrt(r.avar)))
    True
    >>> # cluster means are +-1/m for odd m and 0 for even m; neighbours differ by 2/m or 0,
    >>> # so AV(m) = (2/m)^2 / 2 = 2/m^2 (odd m) and 0 (even m)
    >>> bool(np.allclose(r.avar, [2.0, 0.0, 2.0 / 9.0], rtol=1e-12, atol=1e-15))
    True
    >>> r.n_terms.tolist()                       # N - 2m + 1 overlapping differences
    [4095, 4093, 4091]
    """

    def __init__(self, curve: Any, copied: bool) -> None:
        self._curve = curve
        self._dict: Dict[str, Any] = json.loads(curve.to_json())
        d = self._dict
        pts = d["points"]
        self.name: str = d["name"]
        self.rate_hz: float = d["rate_hz"]
        self.n: int = d["n"]
        self.estimator: str = d["estimator"]
        self.copied: bool = copied
        self.m = np.array([p["m"] for p in pts], dtype=np.int64)
        self.tau = np.array([p["tau"] for p in pts], dtype=np.float64)
        self.avar = np.array([p["avar"] for p in pts], dtype=np.float64)
        self.adev = np.array([p["adev"] for p in pts], dtype=np.float64)
        self.lo = np.array([_nan(p["avar_lo"]) for p in pts], dtype=np.float64)
        self.hi = np.array([_nan(p["avar_hi"]) for p in pts], dtype=np.float64)
        self.edf = np.array([_nan(p["edf"]) for p in pts], dtype=np.float64)
        self.n_terms = np.array([p["n_terms"] for p in pts], dtype=np.int64)

    def to_dict(self) -> Dict[str, Any]:
        """The channel entry of ``imunoise avar --format json`` (a fresh copy).

        >>> import numpy as np, imunoise
        >>> r = imunoise.avar(np.random.default_rng(1).normal(size=4096), rate=100.0)
        >>> d = r.to_dict()
        >>> list(d)
        ['name', 'rate_hz', 'n', 'estimator', 'points']
        >>> sorted(d["points"][0])
        ['adev', 'avar', 'avar_hi', 'avar_lo', 'edf', 'm', 'n_terms', 'tau']
        >>> [p["avar"] for p in d["points"]] == r.avar.tolist() and d["n"] == r.n == 4096
        True
        >>> d["points"].clear()                  # a fresh copy: the result is unchanged
        >>> len(r.to_dict()["points"]) == len(r)
        True
        """
        return json.loads(json.dumps(self._dict))

    def __len__(self) -> int:
        return len(self.m)

    def __repr__(self) -> str:
        return (
            f"AvarResult(name={self.name!r}, rate_hz={self.rate_hz}, n={self.n}, "
            f"points={len(self.m)}, estimator={self.estimator!r})"
        )


class FitResult:
    """One channel's fitted noise model.

    Attributes: ``name``, ``method``, ``model`` (the fitted model with values, per-sample
    parameters), ``parameters`` (``{"WN.sigma2": (value, ci_lo, ci_hi), ...}``, per sample in
    the channel's unit, CI bounds NaN when absent), ``ieee`` (``{"N": (value, lo, hi, unit),
    ...}``), ``noise_terms`` (``{"N": {...}, "K": {...}, "B": {...}}``: value, CI, unit and
    ``source``, ``"model"``, ``"read_off"`` or ``"upper_bound"``: the values the report and
    the configs use), ``adequate`` (does the model describe the Allan variance inside its
    CIs at >= 90 % of the scales; None without CIs) with ``adequacy`` (its reasons, the τ
    ranges not explained and each scale's residual), ``converged``, ``warnings``.
    ``to_dict()`` gives the channel entry of ``imunoise fit --format json``.

    >>> import math, imunoise
    >>> x = imunoise.simulate("WN(sigma2=1e-4)", 4096, 100.0, seed=1)
    >>> f = imunoise.fit(x, 100.0, model="WN", unit="deg/s")
    >>> f.method, list(f.parameters), "N" in f.ieee
    ('gmwm', ['WN.sigma2'], True)
    >>> f.noise_terms["N"]["source"], f.noise_terms["N"]["value"] == f.ieee["N"][0]
    ('model', True)
    >>> f.adequate == (f.adequacy["inside_fraction"] >= 0.9)
    True
    >>> v, lo, hi = f.parameters["WN.sigma2"]
    >>> # the estimate's relative SE is about sqrt(2/4096) = 2.2 %: 10 % is 4.5 SE
    >>> bool(lo < v < hi and abs(v / 1e-4 - 1) < 0.1)
    True
    >>> # N = sqrt(sigma2 / rate) deg/s/sqrt(Hz) = deg/sqrt(s), times 60 for deg/sqrt(h)
    >>> n, n_lo, n_hi, unit = f.ieee["N"]
    >>> bool(math.isclose(n, math.sqrt(v / 100.0) * 60, rel_tol=1e-9)), unit
    (True, '°/√h')
    """

    def __init__(self, d: Dict[str, Any]) -> None:
        self._dict = d
        self.name: str = d["name"]
        self.method: str = d["method"]
        self.model: str = d["model"]
        self.converged: bool = d["converged"]
        self.warnings: List[str] = list(d.get("warnings", []))
        self.parameters: Dict[str, tuple] = {}
        for p in d["parameters"]:
            key = f"{p['process']}.{p['name']}"
            k, i = key, 2
            while k in self.parameters:  # 2*AR1: AR1.phi, AR1#2.phi
                k = f"{p['process']}#{i}.{p['name']}"
                i += 1
            self.parameters[k] = (p["value"], _nan(p["ci_lo"]), _nan(p["ci_hi"]))
        self.ieee: Dict[str, tuple] = {
            k: (v["value"], _nan(v.get("ci_lo")), _nan(v.get("ci_hi")), v.get("unit"))
            for k, v in d.get("ieee", {}).items()
        }
        terms = d.get("noise_terms") or {}
        self.noise_terms: Dict[str, Dict[str, Any]] = {
            k.upper(): dict(v) for k, v in terms.items()
        }
        self.adequacy: Optional[Dict[str, Any]] = d.get("adequacy")
        self.adequate: Optional[bool] = (
            None if self.adequacy is None else bool(self.adequacy["adequate"])
        )

    def to_dict(self) -> Dict[str, Any]:
        """The channel entry of ``imunoise fit --format json`` (a fresh copy).

        >>> import imunoise
        >>> x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0, seed=1)
        >>> f = imunoise.fit(x, 100.0, model="WN+RW")
        >>> d = f.to_dict()
        >>> d["model"] == f.model and d["converged"] == f.converged
        True
        >>> [(p["process"], p["name"]) for p in d["parameters"]]
        [('WN', 'sigma2'), ('RW', 'gamma2')]
        >>> [p["value"] for p in d["parameters"]] == [v[0] for v in f.parameters.values()]
        True
        """
        return json.loads(json.dumps(self._dict))

    def __repr__(self) -> str:
        return f"FitResult(name={self.name!r}, model={self.model!r})"


class TheoryResult:
    """A model's theoretical Allan variance: ``m``, ``tau`` (s), ``avar`` (u^2), ``adev`` (u),
    ``components`` (``{name: adev array}``), ``psd_f`` (Hz), ``psd`` (two-sided, u^2/Hz).
    ``to_dict()`` gives ``imunoise theory --format json``.

    >>> import numpy as np, imunoise
    >>> t = imunoise.theory("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 100.0)
    >>> t.model, list(t.components)
    ('WN(sigma2=0.0001) + RW(gamma2=1e-9)', ['WN(sigma2=0.0001)', 'RW(gamma2=1e-9)'])
    >>> bool(np.allclose(t.tau, t.m / 100.0) and np.allclose(t.adev, np.sqrt(t.avar)))
    True
    >>> # independent components: their Allan variances add up to the model's
    >>> bool(np.allclose(t.avar, sum(a ** 2 for a in t.components.values()), rtol=1e-12))
    True
    >>> bool(len(t.psd_f) == len(t.psd) > 0 and np.all(t.psd > 0))
    True
    """

    def __init__(self, d: Dict[str, Any]) -> None:
        self._dict = d
        self.model: str = d["model"]
        self.rate_hz: float = d["rate_hz"]
        pts = d["points"]
        self.m = np.array([p["m"] for p in pts], dtype=np.int64)
        self.tau = np.array([p["tau"] for p in pts], dtype=np.float64)
        self.avar = np.array([p["avar"] for p in pts], dtype=np.float64)
        self.adev = np.array([p["adev"] for p in pts], dtype=np.float64)
        self.components = {
            c["name"]: np.array([p["adev"] for p in c["points"]], dtype=np.float64)
            for c in d["components"]
        }
        self.psd_f = np.array([p["f"] for p in d["psd"]], dtype=np.float64)
        self.psd = np.array([p["psd"] for p in d["psd"]], dtype=np.float64)

    def to_dict(self) -> Dict[str, Any]:
        """``imunoise theory --format json`` (a fresh copy).

        >>> import imunoise
        >>> t = imunoise.theory("WN(sigma2=1e-4)", 100.0, scales=[1, 2, 4])
        >>> d = t.to_dict()
        >>> list(d), [p["m"] for p in d["points"]]
        (['model', 'rate_hz', 'points', 'components', 'psd'], [1, 2, 4])
        >>> [p["avar"] for p in d["points"]] == t.avar.tolist() and d["model"] == t.model
        True
        """
        return json.loads(json.dumps(self._dict))

    def __repr__(self) -> str:
        return f"TheoryResult(model={self.model!r}, points={len(self.m)})"


class Model:
    """A noise model, e.g. ``Model("WN(sigma2=1e-4) + RW(gamma2=1e-9) + AR1")``.

    ``str(model)`` is its canonical text; ``components`` lists each component as text;
    ``n_params`` counts its parameters; ``complete`` says whether every value is given (so
    that it can be simulated). Parameters are per sample (see the package docstring).
    Raises :class:`ModelError` for bad text.

    >>> import imunoise
    >>> m = imunoise.Model("WN(sigma2=1e-4) + RW + 2*AR1")
    >>> m
    Model('WN(sigma2=0.0001) + RW + 2*AR1')
    >>> m.components, m.n_params, m.complete   # 1 + 1 + 2 * (phi, sigma2); RW, AR1 open
    (['WN(sigma2=0.0001)', 'RW', 'AR1', 'AR1'], 6, False)
    >>> imunoise.Model(str(m)) == m             # the canonical text parses back
    True
    >>> imunoise.Model("WN(1e-4) + RW(1e-9)").complete
    True
    >>> try:
    ...     imunoise.Model("WN + XX")
    ... except imunoise.ModelError:
    ...     print("ModelError")
    ModelError
    """

    def __init__(self, text: Union[str, "Model"]) -> None:
        self._m = _imunoise.NativeModel(str(text))

    @property
    def components(self) -> List[str]:
        return self._m.components()

    @property
    def n_params(self) -> int:
        return self._m.n_params()

    @property
    def complete(self) -> bool:
        return self._m.is_complete()

    def __str__(self) -> str:
        return str(self._m)

    def __repr__(self) -> str:
        return f"Model({str(self._m)!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Model) and self._m == other._m

    def __hash__(self) -> int:
        return hash(str(self._m))


class Recording:
    """A file read through the command's readers.

    ``data``: float64 (n, channels) array (Fortran order, so ``avar(rec.data)`` reads its
    columns without copying); ``names``; ``units`` (one per channel, from ``unit=`` or the
    names' suffixes); ``rate_hz`` (Hz, from ``rate=`` or the time stamps; None for unstamped
    data read without a rate); ``t`` (s: the uniform grid ``t0 + i / rate`` the analysis
    assumes, from the first stamp when there are stamps, else from 0); ``topic``; ``timing``
    (what the stamps said: dict or None); ``file``.

    >>> import os, tempfile, numpy as np, imunoise
    >>> t = 1000.0 + np.arange(4096) / 200.0    # time stamps: 200 Hz from t = 1000 s
    >>> y = np.random.default_rng(2).normal(size=4096)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "imu.csv")
    ...     np.savetxt(p, np.column_stack([t, y]), delimiter=",", fmt="%.17g",
    ...                header="t,acc_z_mps2", comments="")
    ...     rec = imunoise.read(p, time_column="t")
    >>> rec.names, rec.units, rec.data.shape, rec.data.flags.f_contiguous
    (['acc_z_mps2'], ['m/s^2'], (4096, 1), True)
    >>> bool(np.array_equal(rec.data[:, 0], y))  # 17 significant digits read back exactly
    True
    >>> # the rate from the stamps, and t on the grid t0 + i / rate from the first stamp
    >>> # (the stamps are exact to about 1e-13 s: tolerances far above that)
    >>> bool(abs(rec.rate_hz - 200.0) < 1e-6 and np.allclose(rec.t, t, rtol=0, atol=1e-6))
    True
    """

    def __init__(self, raw: tuple) -> None:
        data, names, units, rate, topic, timing, file = raw
        self.data: np.ndarray = data
        self.names: List[str] = list(names)
        self.units: List[str] = list(units)
        self.rate_hz: Optional[float] = rate
        self.topic: Optional[str] = topic
        self.timing: Optional[Dict[str, Any]] = json.loads(timing) if timing else None
        self.file: str = file

    @property
    def t(self) -> Optional[np.ndarray]:
        if self.rate_hz is None:
            return None
        t0 = self.timing["span_s"][0] if self.timing else 0.0
        return t0 + np.arange(self.data.shape[0], dtype=np.float64) / self.rate_hz

    def __repr__(self) -> str:
        return (
            f"Recording(file={self.file!r}, channels={self.names}, "
            f"n={self.data.shape[0]}, rate_hz={self.rate_hz})"
        )


def _as_channels(x: Any) -> "tuple[np.ndarray, bool]":
    """``x`` as a float64 array the native side reads without copying, and whether a
    conversion was needed."""
    a = np.asarray(x)
    made = a is not x  # a list, a memoryview, ...: numpy made a new array from it
    if a.ndim not in (1, 2):
        raise UsageError(f"expected a 1-D or 2-D array, got {a.ndim} dimensions")
    if a.dtype == np.float64:
        if a.ndim == 1 and a.flags.c_contiguous:
            return a, made
        if a.ndim == 2 and (a.flags.f_contiguous or a.flags.c_contiguous):
            # C-ordered 2-D: the native side copies the columns and reports it
            return a, made
    if a.ndim == 1:
        return np.ascontiguousarray(a, dtype=np.float64), True
    return np.asfortranarray(a, dtype=np.float64), True


def avar(
    x: Any,
    rate: Optional[float] = None,
    scales: Union[str, Sequence[int]] = "dyadic",
    ci: str = "chi2",
    alpha: float = 0.05,
    input: str = "rate",
    estimator: str = "overlapping",
    names: Optional[Sequence[str]] = None,
    **read_options: Any,
) -> Union[AvarResult, List[AvarResult]]:
    """The Allan variance of samples ``x`` taken at ``rate`` Hz, with confidence intervals.

    ``x``: 1-D (one channel) or 2-D (samples in rows, one result per column) array-like; or
    a file (a path), read as :func:`read` reads it with ``rate`` and ``read_options``
    (``binary``, ``channels``, ``scale``, ``columns``, ``topic``, ``unit``,
    ``time_column``, ``time_unit``, ``gaps``) and estimated as ``imunoise avar FILE``: a raw
    binary file is streamed (used in place, or decoded a group of channels at a time; never
    loaded whole), so it can be larger than memory. A file of one channel gives one result,
    several give a list.
    ``scales``: ``"dyadic"`` (m = 2^j, the default), ``"dyadic1"``, ``"octave"``,
    ``"decade"``, ``"all"``, ``"logN"`` or a list of cluster sizes m (samples; tau = m/rate s).
    ``ci``: ``"chi2"`` (EDF), ``"gaussian"`` or ``"none"``, at level 1 - ``alpha``.
    ``input``: ``"rate"`` samples (gyro in deg/s, ...) or integrated ``"angle"`` samples.
    ``estimator``: ``"overlapping"`` (maximum overlap) or ``"non_overlapping"``.
    The AV is in the units of ``x`` squared. Exactly the numbers of ``imunoise avar``.

    >>> import numpy as np, imunoise
    >>> r = imunoise.avar(np.random.default_rng(1).normal(size=4096), rate=100.0)
    >>> bool(abs(r.avar[0] * 2 - 1) < 0.2)   # white noise: AV(m) = sigma^2 / m, m = 2
    True
    """
    if isinstance(x, (str, bytes)) or hasattr(x, "__fspath__"):
        if names is not None and not isinstance(names, str):
            names = ",".join(str(n) for n in names)
        curves = _imunoise.avar_file(
            os.fsdecode(x), _scales_text(scales), ci, float(alpha), input, estimator,
            rate=None if rate is None else float(rate), names=names, **read_options,
        )
        res = [AvarResult(c, False) for c in curves]
        return res[0] if len(res) == 1 else res
    if rate is None:
        raise UsageError("avar: rate (Hz) is required for samples")
    if read_options:
        raise UsageError(f"avar: {sorted(read_options)} apply to files only")
    a, conv = _as_channels(x)
    k = 1 if a.ndim == 1 else a.shape[1]
    curves, copied = _imunoise.avar(
        a,
        float(rate),
        _scales_text(scales),
        ci,
        float(alpha),
        input,
        estimator,
        None if names is None else [str(n) for n in names],
    )
    res = [AvarResult(c, conv or copied) for c in curves]
    if a.ndim == 1:
        return res[0]
    assert len(res) == k
    return res


class Online:
    """An Allan variance that is updated as samples arrive (calibrating while recording).

    ``Online(rate, channels=1, tau_max=1000.0, scales="dyadic", ci="chi2", alpha=0.05,
    names=None)``: ``rate`` in Hz; ``tau_max`` the largest averaging time tracked, in s
    (memory: 32 bytes per sample of ``tau_max * rate`` and channel, whatever the number of
    samples fed); ``scales`` the grid of :func:`avar` (up to ``tau_max``); ``ci`` ``"chi2"``
    or ``"none"`` at level 1 - ``alpha``. ``update(x)`` adds samples (1-D for one channel, 2-D
    with samples in rows), in any chunk sizes; ``snapshot()`` gives the :class:`AvarResult`
    (a list for several channels) of everything fed so far: the numbers of :func:`avar` on
    the concatenated samples (the AV to ~1e-12 relative) at its scales up to ``tau_max``.

    >>> import numpy as np, imunoise
    >>> x = np.random.default_rng(2).normal(size=20000)
    >>> on = imunoise.Online(rate=100.0)
    >>> for chunk in np.array_split(x, 7):
    ...     on.update(chunk)
    >>> live, batch = on.snapshot(), imunoise.avar(x, rate=100.0)
    >>> on.n, live.m.tolist() == batch.m.tolist()
    (20000, True)
    >>> bool(np.allclose(live.avar, batch.avar, rtol=1e-12, atol=0.0))
    True
    """

    def __init__(
        self,
        rate: float,
        channels: int = 1,
        tau_max: float = 1000.0,
        scales: Union[str, Sequence[int]] = "dyadic",
        ci: str = "chi2",
        alpha: float = 0.05,
        names: Optional[Sequence[str]] = None,
    ) -> None:
        self._channels = int(channels)
        self._native = _imunoise.NativeOnline(
            self._channels,
            float(rate),
            float(tau_max),
            _scales_text(scales),
            ci,
            float(alpha),
            None if names is None else [str(n) for n in names],
        )

    def update(self, x: Any) -> None:
        """Adds the next samples (input units; 1-D for one channel, 2-D with samples in rows
        and one column per channel). A chunk with a NaN or an infinity is rejected whole
        (:class:`EstimationError`) and changes nothing."""
        a, _ = _as_channels(x)
        if a.ndim == 1 and self._channels > 1:
            raise UsageError(f"update: a 1-D array for {self._channels} channels")
        self._native.update(a)

    def snapshot(self) -> Union[AvarResult, List[AvarResult]]:
        """The Allan variance of all samples so far (see the class docs)."""
        res = [AvarResult(c, False) for c in self._native.snapshot()]
        return res[0] if self._channels == 1 else res

    @property
    def n(self) -> int:
        """Samples fed so far, per channel."""
        return int(self._native.n)

    def heap_bytes(self) -> int:
        """Bytes held by the accumulators: set by ``tau_max * rate``, not by ``n``."""
        return int(self._native.heap_bytes())

    def __repr__(self) -> str:
        return f"Online(channels={self._channels}, n={self.n})"


def _template_text(model: Union[str, "Model"]) -> str:
    """The model's text for a fit; warns (``UserWarning``) when it gives parameter values,
    which the fit does not use (it estimates every parameter), as the command notes it."""
    text = str(model)
    try:
        given = any("(" in c for c in Model(text).components)
    except Exception:  # a bad model: the native call raises the ModelError
        return text
    if given:
        warnings.warn(
            f"model {text} gives parameter values; the fit estimates every parameter and "
            "does not use them",
            stacklevel=3,
        )
    return text


def fit(
    x_or_avar_result: Any,
    rate: Optional[float] = None,
    model: Union[str, Model] = DEFAULT_MODEL,
    method: str = "gmwm",
    select: bool = False,
    bootstrap: int = 0,
    weighting: str = "diagonal",
    seed: int = 1,
    alpha: float = 0.05,
    robust: bool = False,
    efficiency: float = 0.6,
    names: Optional[Sequence[str]] = None,
    unit: Optional[str] = None,
    tau_min: Optional[float] = None,
    tau_max: Optional[float] = None,
) -> Union[FitResult, List[FitResult]]:
    """Fits the noise ``model`` to samples (as ``imunoise fit`` does) or to ``avar`` results.

    ``x_or_avar_result``: samples at ``rate`` Hz (1-D or 2-D as in :func:`avar`; the Allan
    variance is then taken on the dyadic scales with chi-square CIs and the data-quality
    findings join the warnings), or an :class:`AvarResult` (or a list of them; ``rate`` is
    then not needed). ``method``: ``"gmwm"``, ``"avlr"`` or ``"ieee952"``; ``select``: the
    best sub-model by WIC; ``bootstrap``: parametric bootstrap replicates for the CIs;
    ``robust``: fit the robust AV at Gaussian ``efficiency``. ``unit``: the channels' unit
    (e.g. ``"deg/s"``), else from the names' suffixes. ``tau_min``/``tau_max`` (s): fit only
    the scales in that range (as ``--tau-min``/``--tau-max``; the others are listed in the
    result's ``to_dict()["excluded_taus"]``). Parameters come per sample in that
    unit (see the package docstring). One result per channel; a list for 2-D input.

    >>> import numpy as np, imunoise
    >>> x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0, seed=2,
    ...                       channels=2)
    >>> fs = imunoise.fit(x, 100.0, model="WN+RW", names=["gyro_x", "gyro_y"])
    >>> [f.name for f in fs], list(fs[0].parameters)
    (['gyro_x', 'gyro_y'], ['WN.sigma2', 'RW.gamma2'])
    >>> # fitting the avar() results gives the same fit as fitting the samples
    >>> a = imunoise.fit(imunoise.avar(x[:, 0], 100.0), model="WN+RW")
    >>> a.parameters == fs[0].parameters
    True
    >>> # the scales below 0.1 s left out of the fit
    >>> f = imunoise.fit(x[:, 0], 100.0, model="WN+RW", tau_min=0.1)
    >>> f.to_dict()["excluded_taus"], f.to_dict()["fitted"][0]["m"]
    ([0.02, 0.04, 0.08], 16)
    """
    model = _template_text(model)
    if isinstance(x_or_avar_result, (AvarResult, list, tuple)) and (
        isinstance(x_or_avar_result, AvarResult)
        or (len(x_or_avar_result) > 0 and all(isinstance(r, AvarResult) for r in x_or_avar_result))
    ):
        single = isinstance(x_or_avar_result, AvarResult)
        rs = [x_or_avar_result] if single else list(x_or_avar_result)
        doc = _imunoise.fit_curves(
            [r._curve for r in rs], model, method, bool(select), int(bootstrap), weighting,
            int(seed), float(alpha), unit, tau_min=tau_min, tau_max=tau_max,
        )
    else:
        if rate is None:
            raise UsageError("fit: rate (Hz) is required for samples")
        a, _ = _as_channels(x_or_avar_result)
        single = a.ndim == 1
        doc = _imunoise.fit_array(
            a, float(rate), model, method, bool(select), int(bootstrap), weighting,
            int(seed), float(alpha), bool(robust), float(efficiency),
            None if names is None else [str(n) for n in names], unit,
            tau_min=tau_min, tau_max=tau_max,
        )
    fits = [FitResult(c) for c in json.loads(doc)["channels"]]
    return fits[0] if single else fits


def simulate(
    model: Union[str, Model], n: int, rate: float, seed: int = 1, channels: int = 1
) -> np.ndarray:
    """``n`` samples of ``model`` (every parameter given, per sample) at ``rate`` Hz.

    Channel k is stream k of ``seed``: the same numbers as ``imunoise simulate``. Returns a
    1-D array for one channel, else an (n, channels) Fortran-ordered array.

    >>> import numpy as np, imunoise
    >>> a = imunoise.simulate("WN(sigma2=1)", 4096, 100.0, seed=3, channels=2)
    >>> a.shape, a.flags.f_contiguous
    ((4096, 2), True)
    >>> one = imunoise.simulate("WN(sigma2=1)", 4096, 100.0, seed=3)
    >>> one.shape, bool(np.array_equal(one, a[:, 0]))    # channel 0 is stream 0 of seed 3
    ((4096,), True)
    >>> # unit-variance white noise: the sample variance of 8192 draws is 1 to an SE of
    >>> # sqrt(2/8192) = 0.016; 0.08 is 5 SE
    >>> bool(abs(a.var() - 1) < 0.08)
    True
    """
    a = _imunoise.simulate_array(str(model), int(n), float(rate), int(seed), int(channels))
    return a[:, 0] if channels == 1 else a


def theory(
    model: Union[str, Model],
    rate: float,
    scales: Union[str, Sequence[int]] = "dyadic",
    n: int = 1_000_000,
) -> TheoryResult:
    """The theoretical Allan variance of ``model`` (every parameter given) at ``rate`` Hz,
    per component too, and its PSD: as ``imunoise theory``. A named scale grid is made for a
    record of ``n`` samples.

    >>> import numpy as np, imunoise
    >>> t = imunoise.theory("WN(sigma2=2e-4)", 50.0, scales=[1, 2, 8, 100])
    >>> bool(np.allclose(t.avar, 2e-4 / t.m, rtol=1e-12))   # white noise: AV = sigma2 / m
    True
    >>> bool(np.allclose(t.tau, [0.02, 0.04, 0.16, 2.0], rtol=1e-15))  # tau = m / rate
    True
    >>> bool(np.allclose(t.psd, 2e-4 / 50.0, rtol=1e-12))   # two-sided PSD: sigma2 / rate
    True
    """
    return TheoryResult(
        json.loads(_imunoise.theory_json(str(model), float(rate), _scales_text(scales), int(n)))
    )


def read(
    path: Any,
    topic: Optional[str] = None,
    rate: Optional[float] = None,
    columns: Optional[str] = None,
    binary: Optional[str] = None,
    channels: Optional[int] = None,
    scale: Optional[float] = None,
    names: Optional[str] = None,
    unit: Optional[str] = None,
    time_column: Optional[str] = None,
    time_unit: str = "s",
    gaps: str = "refuse",
) -> Recording:
    """Reads an IMU file through the command's readers: CSV/TSV/text (gzip too), raw binary
    (``binary="f64"|"f32"|"i16"|"i32"`` with ``channels``), ROS 1 ``.bag``, ROS 2 ``.mcap`` or
    ``.db3``, PX4 ``.ulg``, ArduPilot ``.bin``. Arguments are the command's input flags:
    ``rate`` in Hz (needed without time stamps), ``columns`` (``"gyro_x,acc_z"`` or
    ``"1-3"``), ``scale`` (a factor), ``names``/``unit`` (comma lists), ``time_column`` and
    ``time_unit`` (s, ms, us, ns), ``gaps`` (refuse, fill, longest).

    >>> import os, tempfile, numpy as np, imunoise
    >>> x = np.random.default_rng(1).normal(size=(4096, 4))
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "log.f64")
    ...     x.astype("<f8").tofile(p)
    ...     rec = imunoise.read(p, rate=100.0, binary="f64", channels=4, columns="2-3",
    ...                         scale=2.0)
    >>> rec.data.shape, rec.rate_hz, rec.timing
    ((4096, 2), 100.0, None)
    >>> # columns 2 and 3 (1-based), times 2 (a power of two: exact)
    >>> bool(np.array_equal(rec.data, 2.0 * x[:, 1:3]))
    True
    """
    return Recording(
        _imunoise.read_file(
            str(path), rate, None if topic is None else [topic], columns, binary, channels,
            scale, names, unit, time_column, time_unit, gaps,
        )
    )


def analyze(
    path_or_array: Any,
    rate: Optional[float] = None,
    out: Any = None,
    model: Union[str, Model] = DEFAULT_MODEL,
    method: str = "gmwm",
    select: bool = True,
    bootstrap: int = 0,
    weighting: str = "diagonal",
    seed: int = 1,
    alpha: float = 0.05,
    robust: bool = False,
    efficiency: float = 0.6,
    record_halfwidth: float = 0.1,
    names: Optional[Sequence[str]] = None,
    unit: Optional[str] = None,
    tau_min: Optional[float] = None,
    tau_max: Optional[float] = None,
    **read_options: Any,
) -> Dict[str, Any]:
    """Everything for one recording, as ``imunoise analyze``: each channel's Allan variance
    with CIs, the data-quality findings, the best sub-model of QN+WN+RW+2*AR1 by WIC fitted
    with CIs (``select=False`` fits ``model`` as it is), N, B, K in IEEE units, the
    contamination check and "how long to record". Returns the ``results.json`` document as a
    dict; with ``out`` (a folder) the report is written there as well.

    ``path_or_array``: a file (read as :func:`read` with ``rate`` and ``read_options``) or
    samples at ``rate`` Hz (1-D or 2-D; ``names`` and ``unit`` name them).

    >>> import json, os, tempfile, imunoise
    >>> x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0, seed=1,
    ...                       channels=2)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     doc = imunoise.analyze(x, rate=100.0, out=d, names=["gyro_x", "gyro_y"],
    ...                            unit="deg/s")
    ...     with open(os.path.join(d, "results.json")) as f:
    ...         on_disk = json.load(f)
    ...     has_report = os.path.exists(os.path.join(d, "report.html"))
    >>> sorted(doc), doc["source"], [ch["name"] for ch in doc["channels"]]
    (['channels', 'rate_hz', 'source'], '<array>', ['gyro_x', 'gyro_y'])
    >>> on_disk == doc, has_report              # the report folder holds the same document
    (True, True)
    >>> ch = doc["channels"][0]
    >>> ch["unit"], "N" in ch["fit"]["ieee"]
    ('deg/s', True)
    >>> # its Allan variance is avar()'s (dyadic scales, chi-square CIs)
    >>> ch["avar"] == imunoise.avar(x[:, 0], rate=100.0).to_dict()["points"]
    True
    """
    common = (
        _template_text(model), method, bool(select), int(bootstrap), weighting, int(seed),
        float(alpha), bool(robust), float(efficiency), float(record_halfwidth),
    )
    out_s = None if out is None else str(out)
    if isinstance(path_or_array, (str, bytes)) or hasattr(path_or_array, "__fspath__"):
        if names is not None and not isinstance(names, str):
            names = ",".join(names)
        doc = _imunoise.analyze_file(
            str(path_or_array), out_s, *common, rate=rate, names=names, unit=unit,
            tau_min=tau_min, tau_max=tau_max, **read_options,
        )
    else:
        if rate is None:
            raise UsageError("analyze: rate (Hz) is required for samples")
        if read_options:
            raise UsageError(f"analyze: {sorted(read_options)} apply to files only")
        a, _ = _as_channels(path_or_array)
        doc = _imunoise.analyze_array(
            a, float(rate), out_s, *common,
            None if names is None else [str(n) for n in names], unit,
            tau_min=tau_min, tau_max=tau_max,
        )
    return json.loads(doc)


def to_dict(result: Any) -> Dict[str, Any]:
    """The CLI's JSON document of a result: ``{"channels": [...]}`` for :func:`avar` and
    :func:`fit` results (one or a list), ``imunoise theory``'s for a :class:`TheoryResult`;
    a dict (``analyze``) is returned as it is.

    >>> import numpy as np, imunoise
    >>> rs = imunoise.avar(np.random.default_rng(1).normal(size=(4096, 2)), rate=100.0,
    ...                    names=["a", "b"])
    >>> d = imunoise.to_dict(rs)
    >>> list(d), [c["name"] for c in d["channels"]]
    (['channels'], ['a', 'b'])
    >>> imunoise.to_dict(rs[0]) == {"channels": [rs[0].to_dict()]}
    True
    >>> imunoise.to_dict(imunoise.theory("WN(1)", 1.0))["model"]
    'WN(sigma2=1)'
    >>> doc = {"channels": []}
    >>> imunoise.to_dict(doc) is doc
    True
    """
    if isinstance(result, dict):
        return result
    if isinstance(result, TheoryResult):
        return result.to_dict()
    if isinstance(result, (AvarResult, FitResult)):
        return {"channels": [result.to_dict()]}
    if isinstance(result, (list, tuple)) and all(
        isinstance(r, (AvarResult, FitResult)) for r in result
    ):
        return {"channels": [r.to_dict() for r in result]}
    raise UsageError(f"to_dict: not an imunoise result: {type(result).__name__}")


def plot(result: Any, ax: Any = None, **kwargs: Any) -> Any:
    """Log-log plot of Allan deviations with their CI bands (needs matplotlib: the ``plot``
    extra). Takes :func:`avar` results (one or a list), a :class:`TheoryResult` or an
    :func:`analyze` document; returns the matplotlib Axes.

    >>> import numpy as np, imunoise
    >>> from matplotlib.figure import Figure
    >>> ax = Figure().add_subplot()             # a figure without pyplot: no window
    >>> r = imunoise.avar(np.random.default_rng(1).normal(size=(4096, 2)), rate=100.0)
    >>> imunoise.plot(r, ax=ax) is ax, len(ax.get_lines()), ax.get_xscale()
    (True, 2, 'log')
    """
    return _plot_impl(result, ax=ax, **kwargs)

