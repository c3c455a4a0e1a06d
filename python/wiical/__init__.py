"""wiical: accelerometer, gyroscope and magnetometer calibration with an honest account of
what is left — the analysis engine of the `wiical` command line, as a Python package.

Every function returns the dictionary that the matching ``wiical <command> --json`` prints
(the same keys, built by the same Rust code from the same report types) and raises
:class:`WiicalError` with the engine's sentence when the input cannot be used.

Samples are given either as a path (any file the command line reads: CSV with a header,
``t x y z`` text, GRT files, window-mean tables) or as a numpy array of shape (n, 3), with
optional times ``t`` (seconds) and temperatures ``temp`` (°C) of length n. The analysis
runs with the GIL released.

>>> import wiical, numpy as np
>>> rep = wiical.fit("../shared/data/imu_tk_xsens/xsens_acc.mat")  # doctest: +SKIP
>>> rep["quality"]["verdict"]                                       # doctest: +SKIP
'good'
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _wiical
from ._wiical import WiicalError

__version__: str = _wiical.__version__
__all__ = [
    "WiicalError",
    "fit",
    "analyze",
    "magfit",
    "gyrofit",
    "six_position",
    "decode_cal",
    "read",
    "Recording",
]

PathLike = Union[str, "os.PathLike[str]"]
Samples = Union[PathLike, np.ndarray, Sequence[Sequence[float]]]


def _column(values: Any, name: str) -> Optional[bytes]:
    if values is None:
        return None
    a = np.ascontiguousarray(values, dtype="<f8")
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    return a.tobytes()


def _source(data: Samples, t: Any = None, temp: Any = None) -> Any:
    """A path, or the arrays as little-endian float64 bytes (what the Rust side reads)."""
    if isinstance(data, (str, os.PathLike)):
        if t is not None or temp is not None:
            raise ValueError("t and temp are given with arrays; a file brings its own columns")
        return os.fspath(data)
    a = np.ascontiguousarray(data, dtype="<f8")
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"samples must have shape (n, 3), got {a.shape}")
    return (a.tobytes(), _column(t, "t"), _column(temp, "temp"))


def _detect(
    rate_hz: float,
    window_s: Optional[float],
    init_s: Optional[float],
    min_static_s: Optional[float],
    threshold: Optional[float],
    adc_range: Optional[Tuple[float, float]],
) -> Dict[str, Any]:
    return {
        "rate_hz": float(rate_hz),
        "window_s": window_s,
        "init_s": init_s,
        "min_static_s": min_static_s,
        "threshold": threshold,
        "adc_range": None if adc_range is None else (float(adc_range[0]), float(adc_range[1])),
    }


def fit(
    data: Samples,
    *,
    t: Any = None,
    temp: Any = None,
    columns: Optional[Sequence[str]] = None,
    windows: bool = False,
    model: str = "full",
    rate_hz: float = 100.0,
    window_s: Optional[float] = None,
    init_s: Optional[float] = None,
    min_static_s: Optional[float] = None,
    threshold: Optional[float] = None,
    adc_range: Optional[Tuple[float, float]] = None,
) -> Dict[str, Any]:
    """Static windows and the multi-position fit (bias, scale, non-orthogonality), with the
    quality verdict: ``wiical fit --json``. Any of window_s, init_s, min_static_s, threshold
    switches from the adaptive detector to IMU-TK's, as the flags do."""
    out = _wiical.fit(
        _source(data, t, temp),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        list(columns) if columns is not None else None,
        windows,
        model,
    )
    return json.loads(out)


def analyze(
    data: Samples,
    *,
    t: Any = None,
    temp: Any = None,
    columns: Optional[Sequence[str]] = None,
    windows: bool = False,
    alpha: Optional[float] = None,
    cv_factor: Optional[float] = None,
    candidates: Optional[Sequence[str]] = None,
    rate_hz: float = 100.0,
    window_s: Optional[float] = None,
    init_s: Optional[float] = None,
    min_static_s: Optional[float] = None,
    threshold: Optional[float] = None,
    adc_range: Optional[Tuple[float, float]] = None,
) -> Dict[str, Any]:
    """The residual analysis: what the linear model leaves, which effects explain it, the
    error before and after: ``wiical analyze --json``."""
    out = _wiical.analyze(
        _source(data, t, temp),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        list(columns) if columns is not None else None,
        windows,
        alpha,
        cv_factor,
        list(candidates) if candidates is not None else None,
    )
    return json.loads(out)


def magfit(
    data: Samples, *, model: str = "ellipsoid", columns: Optional[Sequence[str]] = None
) -> Dict[str, Any]:
    """Magnetometer hard/soft-iron fit (sphere, axis or ellipsoid): ``wiical magfit --json``."""
    out = _wiical.magfit(
        _source(data), model, list(columns) if columns is not None else None
    )
    return json.loads(out)


def gyrofit(
    path: PathLike,
    gyro_path: Optional[PathLike] = None,
    *,
    gyro_columns: Optional[Sequence[str]] = None,
    scale: Optional[Union[float, Sequence[float]]] = None,
    counts_per_dps: Optional[Union[float, Sequence[float]]] = None,
    rate_hz: float = 100.0,
    window_s: Optional[float] = None,
    init_s: Optional[float] = None,
    min_static_s: Optional[float] = None,
    threshold: Optional[float] = None,
    adc_range: Optional[Tuple[float, float]] = None,
) -> Dict[str, Any]:
    """Gyro scale, misalignment and bias from the motions between fit's static windows:
    ``wiical gyrofit --json``. The nominal: ``scale`` (rad/s per count) or ``counts_per_dps``,
    else the gyro columns' unit, else estimated from the motions."""

    def many(v: Any) -> Optional[list]:
        if v is None:
            return None
        return [float(x) for x in (v if isinstance(v, (list, tuple)) else [v])]

    out = _wiical.gyrofit(
        os.fspath(path),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        None if gyro_path is None else os.fspath(gyro_path),
        list(gyro_columns) if gyro_columns is not None else None,
        many(scale),
        many(counts_per_dps),
    )
    return json.loads(out)


def six_position(path: PathLike, *, estimator: str = "mean") -> Dict[str, Any]:
    """The seed's six-position test on a file with a pose column (estimator "mean" or
    "kalman"): ``wiical six-position --json``."""
    return json.loads(_wiical.six_position(os.fspath(path), estimator))


def decode_cal(device: str, hex: str) -> Dict[str, Any]:
    """A factory calibration block ("wiimote", "nunchuk" or "motionplus") given as hex text:
    ``wiical decode-cal --json``. The dictionary's ``checksum_ok`` says whether the block can
    be trusted (the command line exits 1 when it cannot)."""
    out, _ok = _wiical.decode_cal(device, hex)
    return json.loads(out)


class Recording(dict):
    """What :func:`read` returns: ``xyz`` (n × 3 float64), ``t`` and ``temp`` (n, or None),
    and the loader's metadata (``columns``, ``sample_rate_hz``, ``labels``, ``notes``,
    ``info``, ``skipped_empty_rows``). A dict, so ``rec["xyz"]`` and ``rec.xyz`` both work."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError as e:
            raise AttributeError(name) from e


def read(
    path: PathLike, *, columns: Optional[Sequence[str]] = None, sensor: Optional[str] = None
) -> Recording:
    """Reads any recording the command line reads, as numpy arrays. ``sensor`` picks the
    triplet from a header naming several ("accelerometer", "gyroscope", "magnetometer")."""
    xyz, t, temp, meta = _wiical.read(
        os.fspath(path), list(columns) if columns is not None else None, sensor
    )
    rec = Recording(json.loads(meta))
    rec["xyz"] = np.frombuffer(xyz, dtype="<f8").reshape(-1, 3)
    rec["t"] = None if t is None else np.frombuffer(t, dtype="<f8")
    rec["temp"] = None if temp is None else np.frombuffer(temp, dtype="<f8")
    return rec
