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

import json as _json
import os as _os
import typing as _t

import numpy as _np

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
    "calibrate",
    "decode_cal",
    "noise",
    "tempcal",
    "correct",
    "read",
    "span_times",
    "Recording",
]

_PathLike = _t.Union[str, bytes, "_os.PathLike[str]"]
_Samples = _t.Union[_PathLike, _np.ndarray, _t.Sequence[_t.Sequence[float]]]
_Progress = _t.Optional[_t.Callable[[str, int, int], None]]


def __dir__() -> _t.List[str]:
    """Only the package's own names (not the modules it imports)."""
    return sorted(__all__ + ["__version__"])


def _path(p: _t.Any, name: str) -> str:
    """A path as str: ``str``, ``os.PathLike`` or ``bytes`` (decoded as the file system
    does, so a non-UTF-8 name still names its file); anything else is a TypeError naming
    the argument."""
    if isinstance(p, (str, bytes, _os.PathLike)):
        return _os.fsdecode(p)
    raise TypeError(f"{name} must be a path (str, bytes or os.PathLike), got {type(p).__name__}")


def _names(v: _t.Any, name: str, example: str) -> _t.Optional[_t.List[str]]:
    """A list of names; a single string is refused (``list("ax")`` would be its letters)."""
    if v is None:
        return None
    if isinstance(v, (str, bytes)):
        raise TypeError(f"{name} takes a list of names, e.g. {example}, not the string {v!r}")
    try:
        names = list(v)
    except TypeError:
        raise TypeError(
            f"{name} takes a list of names, e.g. {example}, got {type(v).__name__}"
        ) from None
    bad = [x for x in names if not isinstance(x, str)]
    if bad:
        raise TypeError(f"{name} takes names (str), got {bad[0]!r}")
    return names


def _number(v: _t.Any, name: str) -> float:
    """A real number (int, float, numpy scalar); a bool or a string is a TypeError naming the
    argument. Its range is checked by the engine, as the CLI's flag is."""
    if isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float, _np.number)):
        raise TypeError(f"{name} must be a number, got {type(v).__name__} {v!r}")
    return float(v)


def _opt_bytes(v: _t.Any, name: str) -> _t.Optional[int]:
    """A byte count (an int ≥ 0) or None."""
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, _np.integer)) or v < 0:
        raise TypeError(f"{name} must be a whole number of bytes ≥ 0, got {type(v).__name__} {v!r}")
    return int(v)


def _opt_number(v: _t.Any, name: str) -> _t.Optional[float]:
    return None if v is None else _number(v, name)


def _real(values: _t.Any, name: str) -> _np.ndarray:
    """``values`` as a float64 array (no copy when it is one already). Anything numpy would
    turn into numbers silently — None (NaN), text ("1.5"), complex (imaginary part dropped),
    booleans (0/1) — is a TypeError naming the argument and, for a None, its place. A masked
    array with a value masked is a ValueError (numpy would give the masked values unmasked)."""
    what = f"{name} must be {'a path or ' if name == 'data' else ''}an array of numbers"
    if values is None or _np.isscalar(values):
        raise TypeError(f"{what}, got {type(values).__name__} {values!r}")
    if isinstance(values, _np.ma.MaskedArray):
        # numpy would hand over the values under the mask (the glitches it hides) unmasked.
        hidden = int(_np.ma.count_masked(values))
        if hidden:
            raise ValueError(
                f"{name} is a masked array with {hidden} masked value(s), which would be read as "
                "if unmasked: leave the masked samples out first (numpy.ma.compress_rows for "
                "the n × 3 readings, with their times and temperatures) or fill them"
            )
        values = _np.ma.getdata(values)
    try:
        raw = _np.asarray(values)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{what}: {e}") from None
    kind = raw.dtype.kind
    if kind == "O":
        for place, v in _np.ndenumerate(raw):
            if v is None or isinstance(v, (str, bytes, bool)):
                raise TypeError(f"{name}{list(place)} is {v!r}, not a number")
    elif kind in "USV":
        raise TypeError(f"{name} holds text ({raw.dtype}); give numbers (parse the text first)")
    elif kind == "c":
        raise TypeError(f"{name} holds complex numbers; give real readings")
    elif kind == "b":
        raise TypeError(f"{name} holds booleans; give the readings as numbers")
    try:
        return _np.asarray(raw, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{what}: {e}") from None


def _column(values: _t.Any, name: str) -> _t.Optional[_np.ndarray]:
    """A 1-D float64 array (no copy when it is one already)."""
    if values is None:
        return None
    a = _real(values, name)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    return a


def _source(data: _Samples, t: _t.Any = None, temp: _t.Any = None) -> _t.Any:
    """A path, or float64 arrays (no copy when ``data`` is a float64 array already: the
    engine reads it in place and checks it as the loader checks a file)."""
    if isinstance(data, (str, bytes, _os.PathLike)):
        if t is not None or temp is not None:
            raise ValueError("t and temp are given with arrays; a file brings its own columns")
        return _path(data, "data")
    return (_real(data, "data"), _column(t, "t"), _column(temp, "temp"))


def _flag(v: _t.Any, name: str) -> bool:
    """A switch: True or False (a string such as "no" would be true)."""
    if not isinstance(v, (bool, _np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(v).__name__} {v!r}")
    return bool(v)


def _text(v: _t.Any, name: str) -> str:
    if not isinstance(v, str):
        raise TypeError(f"{name} must be a str, got {type(v).__name__} {v!r}")
    return v


def _detect(
    rate_hz: _t.Any,
    window_s: _t.Any,
    init_s: _t.Any,
    min_static_s: _t.Any,
    threshold: _t.Any,
    adc_range: _t.Any,
) -> _t.Dict[str, _t.Any]:
    if adc_range is not None:
        if isinstance(adc_range, (str, bytes)) or len(adc_range) != 2:
            raise TypeError(f"adc_range takes two numbers (lo, hi), got {adc_range!r}")
        adc_range = (_number(adc_range[0], "adc_range"), _number(adc_range[1], "adc_range"))
    return {
        "rate_hz": _number(rate_hz, "rate_hz"),
        "window_s": _opt_number(window_s, "window_s"),
        "init_s": _opt_number(init_s, "init_s"),
        "min_static_s": _opt_number(min_static_s, "min_static_s"),
        "threshold": _opt_number(threshold, "threshold"),
        "adc_range": adc_range,
    }


def _progress(progress: _Progress) -> _Progress:
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable(stage, done, total), got {progress!r}")
    return progress

_COLUMNS = "['ax', 'ay', 'az']"


def fit(
    data: _Samples,
    *,
    t: _t.Any = None,
    temp: _t.Any = None,
    columns: _t.Optional[_t.Sequence[str]] = None,
    windows: bool = False,
    model: str = "full",
    rate_hz: float = 100.0,
    window_s: _t.Optional[float] = None,
    init_s: _t.Optional[float] = None,
    min_static_s: _t.Optional[float] = None,
    threshold: _t.Optional[float] = None,
    adc_range: _t.Optional[_t.Tuple[float, float]] = None,
    progress: _Progress = None,
    stream_from_bytes: _t.Optional[int] = None,
) -> _t.Dict[str, _t.Any]:
    """Static windows and the multi-position fit (bias, scale, non-orthogonality), with the
    quality verdict: ``wiical fit --json``. Any of window_s, init_s, min_static_s, threshold
    switches from the adaptive detector to IMU-TK's, as the flags do; each is refused outside
    its flag's range. ``progress(stage, done, total)`` is called as the work goes on.
    ``stream_from_bytes``: a plain text file of at least that many bytes is read in passes
    rather than held (default 128 MiB, as the CLI's ``--stream-from-bytes``)."""
    out = _wiical.fit(
        _source(data, t, temp),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        _names(columns, "columns", _COLUMNS),
        _flag(windows, "windows"),
        model,
        _progress(progress),
        _opt_bytes(stream_from_bytes, "stream_from_bytes"),
    )
    return _json.loads(out)


def analyze(
    data: _Samples,
    *,
    t: _t.Any = None,
    temp: _t.Any = None,
    columns: _t.Optional[_t.Sequence[str]] = None,
    windows: bool = False,
    alpha: _t.Optional[float] = None,
    cv_factor: _t.Optional[float] = None,
    candidates: _t.Optional[_t.Sequence[str]] = None,
    rate_hz: float = 100.0,
    window_s: _t.Optional[float] = None,
    init_s: _t.Optional[float] = None,
    min_static_s: _t.Optional[float] = None,
    threshold: _t.Optional[float] = None,
    adc_range: _t.Optional[_t.Tuple[float, float]] = None,
    progress: _Progress = None,
    stream_from_bytes: _t.Optional[int] = None,
) -> _t.Dict[str, _t.Any]:
    """The residual analysis: what the linear model leaves, which effects explain it, the
    error before and after: ``wiical analyze --json``. ``progress(stage, done, total)`` is
    called on reading, on detection, and once per candidate fitted. ``stream_from_bytes`` as
    for :func:`fit`."""
    out = _wiical.analyze(
        _source(data, t, temp),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        _names(columns, "columns", _COLUMNS),
        _flag(windows, "windows"),
        _opt_number(alpha, "alpha"),
        _opt_number(cv_factor, "cv_factor"),
        _names(candidates, "candidates", "['bias_drift', 'cubic']"),
        _progress(progress),
        _opt_bytes(stream_from_bytes, "stream_from_bytes"),
    )
    return _json.loads(out)


def magfit(
    data: _Samples, *, model: str = "ellipsoid", columns: _t.Optional[_t.Sequence[str]] = None
) -> _t.Dict[str, _t.Any]:
    """Magnetometer hard/soft-iron fit (sphere, axis or ellipsoid): ``wiical magfit --json``."""
    out = _wiical.magfit(_source(data), model, _names(columns, "columns", "['mx', 'my', 'mz']"))
    return _json.loads(out)


def _many(v: _t.Any, name: str) -> _t.Optional[_t.List[float]]:
    """One number or three (per axis)."""
    if v is None:
        return None
    if isinstance(v, (str, bytes)):
        raise TypeError(f"{name} takes one number or three, not the string {v!r}")
    if isinstance(v, (list, tuple, _np.ndarray)):
        return [_number(x, name) for x in v]
    return [_number(v, name)]


def gyrofit(
    path: _PathLike,
    gyro_path: _t.Optional[_PathLike] = None,
    *,
    gyro_columns: _t.Optional[_t.Sequence[str]] = None,
    scale: _t.Optional[_t.Union[float, _t.Sequence[float]]] = None,
    counts_per_dps: _t.Optional[_t.Union[float, _t.Sequence[float]]] = None,
    rate_hz: float = 100.0,
    window_s: _t.Optional[float] = None,
    init_s: _t.Optional[float] = None,
    min_static_s: _t.Optional[float] = None,
    threshold: _t.Optional[float] = None,
    adc_range: _t.Optional[_t.Tuple[float, float]] = None,
) -> _t.Dict[str, _t.Any]:
    """Gyro scale, misalignment and bias from the motions between fit's static windows:
    ``wiical gyrofit --json``. The nominal: ``scale`` (rad/s per count) or ``counts_per_dps``,
    else the gyro columns' unit, else estimated from the motions."""
    out = _wiical.gyrofit(
        _path(path, "path"),
        _detect(rate_hz, window_s, init_s, min_static_s, threshold, adc_range),
        None if gyro_path is None else _path(gyro_path, "gyro_path"),
        _names(gyro_columns, "gyro_columns", "['gx', 'gy', 'gz']"),
        _many(scale, "scale"),
        _many(counts_per_dps, "counts_per_dps"),
    )
    return _json.loads(out)


def _rates(v: _t.Any, name: str) -> _t.Optional[_t.List[float]]:
    """One rate or several (°/s), as ``--table-rate R[,R…]``; their range is checked by the
    engine."""
    if v is None:
        return None
    if isinstance(v, (str, bytes)):
        raise TypeError(f"{name} takes a number or a list of numbers (°/s), not the string {v!r}")
    if isinstance(v, _np.ndarray):
        v = v[()] if v.ndim == 0 else list(v)
    if isinstance(v, (list, tuple)):
        return [_number(x, name) for x in v]
    return [_number(v, name)]


def calibrate(
    path: _PathLike,
    *,
    table_rate: _t.Optional[_t.Union[float, _t.Sequence[float]]] = None,
    rotation_deg: float = 360.0,
) -> _t.Dict[str, _t.Any]:
    """Every sensor of a recording (accelerometer, gyroscope, magnetometer) with the method
    its recognised protocol calls for: ``wiical calibrate --json``. ``table_rate``: known gyro
    rates in °/s (0 for a rest); ``rotation_deg``: the angle of each full turn (Ferraris)."""
    out = _wiical.calibrate(
        _path(path, "path"),
        _rates(table_rate, "table_rate"),
        _number(rotation_deg, "rotation_deg"),
    )
    return _json.loads(out)


def six_position(path: _PathLike, *, estimator: str = "mean") -> _t.Dict[str, _t.Any]:
    """The seed's six-position test on a file with a pose column (estimator "mean" or
    "kalman"): ``wiical six-position --json``."""
    return _json.loads(_wiical.six_position(_path(path, "path"), estimator))


def decode_cal(device: str, hex: str) -> _t.Dict[str, _t.Any]:
    """A factory calibration block ("wiimote", "nunchuk" or "motionplus") given as hex text:
    ``wiical decode-cal --json``. The dictionary's ``checksum_ok`` says whether the block can
    be trusted (the command line exits 1 when it cannot)."""
    out, _ok = _wiical.decode_cal(_text(device, "device"), _text(hex, "hex"))
    return _json.loads(out)


def noise(
    data: _Samples,
    *,
    t: _t.Any = None,
    columns: _t.Optional[_t.Sequence[str]] = None,
    rate_hz: float = 100.0,
    stream_from_bytes: _t.Optional[int] = None,
) -> _t.Dict[str, _t.Any]:
    """The Allan deviation of a still recording per axis and the IEEE 952 noise terms:
    ``wiical noise --json``. A file gives every sensor it holds; arrays are one sensor.
    ``stream_from_bytes`` as for :func:`fit`."""
    out = _wiical.noise(
        _source(data, t),
        _number(rate_hz, "rate_hz"),
        _names(columns, "columns", _COLUMNS),
        _opt_bytes(stream_from_bytes, "stream_from_bytes"),
    )
    return _json.loads(out)


def tempcal(
    data: _Samples,
    *,
    t: _t.Any = None,
    temp: _t.Any = None,
    columns: _t.Optional[_t.Sequence[str]] = None,
    tref: float = 35.0,
    segments: int = 8,
    block_s: float = 1.0,
    pose_deg: float = 10.0,
    rate_hz: float = 100.0,
) -> _t.Dict[str, _t.Any]:
    """The bias of a still warm-up against temperature, per axis: ``wiical tempcal --json``.
    Arrays need ``temp`` (°C per sample)."""
    if isinstance(segments, bool) or not isinstance(segments, (int, _np.integer)):
        raise TypeError(f"segments must be an integer, got {segments!r}")
    if not 0 <= segments <= 2**31:
        raise ValueError(f"segments = {segments}: the number of segments must be from 2 to 50")
    out = _wiical.tempcal(
        _source(data, t, temp),
        _number(tref, "tref"),
        int(segments),
        _number(block_s, "block_s"),
        _number(pose_deg, "pose_deg"),
        _number(rate_hz, "rate_hz"),
        _names(columns, "columns", _COLUMNS),
    )
    return _json.loads(out)


def correct(
    calibration: _PathLike,
    data: _Samples,
    *,
    t: _t.Any = None,
    temp: _t.Any = None,
    columns: _t.Optional[_t.Sequence[str]] = None,
    rate_hz: float = 100.0,
) -> _t.Dict[str, _t.Any]:
    """Every sample corrected with a calibration file (host terms included): what ``wiical
    correct`` writes, as ``{"t": (n,), "accel": (n, 3) in g, "applied": [terms]}``."""
    times, accel, applied = _wiical.correct(
        _path(calibration, "calibration"),
        _source(data, t, temp),
        _number(rate_hz, "rate_hz"),
        _names(columns, "columns", _COLUMNS),
    )
    return {"t": times, "accel": accel, "applied": applied}


class Recording(dict):
    """What :func:`read` returns: ``xyz`` (n × 3, float64 or the ``dtype`` asked for), ``t``
    (n float64 seconds, or None), ``temp`` (n °C, as ``xyz``, or None), ``spans`` (a raw
    file's times as block spans with ``times="spans"``, else None: see :func:`span_times`),
    and the loader's metadata (``columns``, ``sample_rate_hz``, ``labels``, ``notes``,
    ``info``, ``skipped_empty_rows``). A dict, so ``rec["xyz"]`` and ``rec.xyz`` both work."""

    def __getattr__(self, name: str) -> _t.Any:
        try:
            return self[name]
        except KeyError as e:
            raise AttributeError(name) from e


_TIMES = {True: "full", False: "none", "full": "full", "none": "none", "spans": "spans"}


def read(
    path: _PathLike,
    *,
    columns: _t.Optional[_t.Sequence[str]] = None,
    sensor: _t.Optional[str] = None,
    progress: _Progress = None,
    dtype: str = "float64",
    times: _t.Union[bool, str] = True,
) -> Recording:
    """Reads any recording the command line reads, as numpy arrays (filled or taken over by
    the engine, not copied). ``sensor`` picks the triplet from a header naming several
    ("accelerometer", "gyroscope", "magnetometer").

    ``dtype="float32"`` returns ``xyz`` and ``temp`` as float32, half the memory: a raw
    ``.cwa`` file's values and temperatures are exact in float32 (counts times powers of two),
    a ``.bin`` file's and a text file's are rounded to 7 significant digits (a text file's
    after parsing, one copy). ``t`` is always float64 (seconds since 1970 need its precision);
    ``times=False`` leaves it out (``t`` is None; the notes and ``sample_rate_hz`` are the
    same). ``times="spans"`` gives a raw file's (``.cwa``, ``.bin``) times as its blocks'
    spans instead (``spans``: ``start_s``, ``dur_s``, ``rows``; a few bytes a block instead of
    8 a sample, and the read's fastest form); :func:`span_times` expands them into the array
    ``times=True`` gives, bit for bit. A text file has no blocks: its ``t`` is given whole.

    A ``.cwa`` file is mapped into memory and its blocks decoded where they lie (no copy into
    a buffer): a file that another program cuts shorter *while* it is being read kills the
    process (SIGBUS) instead of raising an error; one already cut short reads as before."""
    if dtype not in ("float64", "float32"):
        raise ValueError(f"dtype must be 'float64' or 'float32', got {dtype!r}")
    if not isinstance(times, (bool, str)) or times not in _TIMES:
        raise ValueError(f"times must be True, False or 'spans', got {times!r}")
    xyz, t, temp, spans, meta = _wiical.read(
        _path(path, "path"),
        _names(columns, "columns", _COLUMNS),
        sensor,
        _progress(progress),
        dtype,
        _TIMES[times],
    )
    rec = Recording(_json.loads(meta))
    rec["xyz"] = xyz
    rec["t"] = t
    rec["temp"] = temp
    rec["spans"] = None
    if spans is not None:
        start_s, dur_s, rows = spans
        rec["spans"] = {"start_s": start_s, "dur_s": dur_s, "rows": rows}
    return rec


def span_times(rec: _t.Mapping[str, _t.Any]) -> _np.ndarray:
    """Every sample's time (float64 s) of what :func:`read` returned: its ``t`` when it has
    one, else its block spans expanded (sample ``i`` of block ``k`` at ``start_s[k] + i ·
    dur_s[k] / n``, ``n = rows[k + 1] − rows[k]``), the values ``times=True`` gives, bit for
    bit. A ValueError when it has neither."""
    t = rec.get("t")
    if t is not None:
        return t
    spans = rec.get("spans")
    if spans is None:
        raise ValueError("the recording has no times: read it with times=True or 'spans'")
    return _wiical.span_times(
        _np.ascontiguousarray(spans["start_s"], dtype=_np.float64),
        _np.ascontiguousarray(spans["dur_s"], dtype=_np.float64),
        _np.ascontiguousarray(spans["rows"], dtype=_np.uint64),
    )
