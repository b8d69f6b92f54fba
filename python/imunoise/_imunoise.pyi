"""Type stubs of the native module (pyo3). Use the package's functions (imunoise.avar, ...):
these are their thin native halves, returning the command's JSON documents as strings."""

from typing import List, Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

class ImunoiseError(ValueError): ...
class InputError(ImunoiseError): ...
class UsageError(ImunoiseError): ...
class ModelError(ImunoiseError): ...
class EstimationError(ImunoiseError): ...
class OutputError(ImunoiseError): ...

class Curve:
    @property
    def name(self) -> str: ...
    def to_json(self) -> str: ...

class NativeModel:
    def __init__(self, text: str) -> None: ...
    def components(self) -> List[str]: ...
    def n_params(self) -> int: ...
    def is_complete(self) -> bool: ...

class NativeOnline:
    def __init__(
        self, channels: int, rate: float, tau_max: float, scales: str, ci: str, alpha: float,
        names: Optional[List[str]] = ...,
    ) -> None: ...
    def update(self, x: npt.NDArray[np.float64]) -> None: ...
    def snapshot(self) -> List[Curve]: ...
    @property
    def n(self) -> int: ...
    def heap_bytes(self) -> int: ...

def avar(
    x: npt.NDArray[np.float64], rate: float, scales: str, ci: str, alpha: float, input: str,
    estimator: str, names: Optional[List[str]] = None,
) -> Tuple[List[Curve], bool]: ...
def avar_file(
    path: str, scales: str, ci: str, alpha: float, input: str, estimator: str,
    rate: Optional[float] = None, topic: Optional[str] = None, columns: Optional[str] = None,
    binary: Optional[str] = None, channels: Optional[int] = None, scale: Optional[float] = None,
    names: Optional[str] = None, unit: Optional[str] = None, time_column: Optional[str] = None,
    time_unit: str = "s", gaps: str = "refuse",
) -> List[Curve]: ...
def fit_array(
    x: npt.NDArray[np.float64], rate: float, model: str, method: str, select: bool,
    bootstrap: int, weighting: str, seed: int, alpha: float, robust: bool, efficiency: float,
    names: Optional[List[str]] = None, unit: Optional[str] = None,
    tau_min: Optional[float] = None, tau_max: Optional[float] = None,
) -> str: ...
def fit_curves(
    curves: List[Curve], model: str, method: str, select: bool, bootstrap: int,
    weighting: str, seed: int, alpha: float, unit: Optional[str] = None,
    tau_min: Optional[float] = None, tau_max: Optional[float] = None,
) -> str: ...
def simulate_array(
    model: str, n: int, rate: float, seed: int, channels: int
) -> npt.NDArray[np.float64]: ...
def theory_json(model: str, rate: float, scales: str, n: int) -> str: ...
def read_file(
    path: str, rate: Optional[float] = None, topic: Optional[List[str]] = None,
    columns: Optional[str] = None, binary: Optional[str] = None,
    channels: Optional[int] = None, scale: Optional[float] = None,
    names: Optional[str] = None, unit: Optional[str] = None,
    time_column: Optional[str] = None, time_unit: str = "s", gaps: str = "refuse",
) -> Tuple[npt.NDArray[np.float64], List[str], List[str], Optional[float], Optional[str],
           Optional[str], str]: ...
def analyze_file(
    path: str, out: Optional[str], model: str, method: str, select: bool, bootstrap: int,
    weighting: str, seed: int, alpha: float, robust: bool, efficiency: float,
    record_halfwidth: float, rate: Optional[float] = None, topic: Optional[str] = None,
    columns: Optional[str] = None, binary: Optional[str] = None,
    channels: Optional[int] = None, scale: Optional[float] = None,
    names: Optional[str] = None, unit: Optional[str] = None,
    time_column: Optional[str] = None, time_unit: str = "s", gaps: str = "refuse",
    tau_min: Optional[float] = None, tau_max: Optional[float] = None,
) -> str: ...
def analyze_array(
    x: npt.NDArray[np.float64], rate: float, out: Optional[str], model: str, method: str,
    select: bool, bootstrap: int, weighting: str, seed: int, alpha: float, robust: bool,
    efficiency: float, record_halfwidth: float, names: Optional[List[str]] = None,
    unit: Optional[str] = None, tau_min: Optional[float] = None,
    tau_max: Optional[float] = None,
) -> str: ...
def kernel_seconds(
    x: npt.NDArray[np.float64], rate: float, scales: str, ci: str, repeats: int
) -> List[float]: ...
