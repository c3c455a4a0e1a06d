"""Type stubs of the compiled module (python/src/lib.rs). Use the functions of the `wiical`
package: these take the samples as float64 numpy arrays (read in place) and return JSON text
or numpy arrays."""

from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

__version__: str

class WiicalError(ValueError):
    """An input wiical cannot use, with the sentence the command line prints."""

_Source = Union[str, Tuple[np.ndarray, Optional[np.ndarray], Optional[np.ndarray]]]
_Progress = Optional[Callable[[str, int, int], None]]

def fit(
    source: _Source,
    detect: Dict[str, Any],
    columns: Optional[List[str]] = None,
    windows: bool = False,
    model: str = "full",
    progress: _Progress = None,
    stream_from_bytes: Optional[int] = None,
) -> str: ...
def analyze(
    source: _Source,
    detect: Dict[str, Any],
    columns: Optional[List[str]] = None,
    windows: bool = False,
    alpha: Optional[float] = None,
    cv_factor: Optional[float] = None,
    candidates: Optional[List[str]] = None,
    progress: _Progress = None,
    stream_from_bytes: Optional[int] = None,
) -> str: ...
def magfit(source: _Source, model: str = "ellipsoid", columns: Optional[List[str]] = None) -> str: ...
def gyrofit(
    path: str,
    detect: Dict[str, Any],
    gyro_path: Optional[str] = None,
    gyro_columns: Optional[List[str]] = None,
    scale: Optional[List[float]] = None,
    counts_per_dps: Optional[List[float]] = None,
) -> str: ...
def six_position(path: str, estimator: str = "mean") -> str: ...
def calibrate(
    path: str, table_rate: Optional[List[float]] = None, rotation_deg: float = 360.0
) -> str: ...
def decode_cal(device: str, hex: str) -> Tuple[str, bool]: ...
def noise(
    source: _Source,
    rate_hz: float = 100.0,
    columns: Optional[List[str]] = None,
    stream_from_bytes: Optional[int] = None,
) -> str: ...
def tempcal(
    source: _Source,
    tref: float,
    segments: int,
    block_s: float,
    pose_deg: float,
    rate_hz: float = 100.0,
    columns: Optional[List[str]] = None,
) -> str: ...
def correct(
    calibration: str,
    source: _Source,
    rate_hz: float = 100.0,
    columns: Optional[List[str]] = None,
) -> Tuple[np.ndarray, np.ndarray, List[str]]: ...
def read(
    path: str,
    columns: Optional[List[str]] = None,
    sensor: Optional[str] = None,
    progress: _Progress = None,
    dtype: str = "float64",
    times: str = "full",
) -> Tuple[
    np.ndarray,
    Optional[np.ndarray],
    Optional[np.ndarray],
    Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]],
    str,
]: ...
def span_times(start_s: np.ndarray, dur_s: np.ndarray, rows: np.ndarray) -> np.ndarray: ...
