"""Type stubs of the compiled module (python/src/lib.rs). Use the functions of the `wiical`
package: these take the samples as float64 bytes and return JSON text."""

from typing import Any, Dict, List, Optional, Tuple, Union

__version__: str

class WiicalError(ValueError):
    """An input wiical cannot use, with the sentence the command line prints."""

_Source = Union[str, Tuple[bytes, Optional[bytes], Optional[bytes]]]

def fit(
    source: _Source,
    detect: Dict[str, Any],
    columns: Optional[List[str]] = None,
    windows: bool = False,
    model: str = "full",
) -> str: ...
def analyze(
    source: _Source,
    detect: Dict[str, Any],
    columns: Optional[List[str]] = None,
    windows: bool = False,
    alpha: Optional[float] = None,
    cv_factor: Optional[float] = None,
    candidates: Optional[List[str]] = None,
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
def decode_cal(device: str, hex: str) -> Tuple[str, bool]: ...
def read(
    path: str, columns: Optional[List[str]] = None, sensor: Optional[str] = None
) -> Tuple[bytes, Optional[bytes], Optional[bytes], str]: ...
