"""Shared pieces of the peer benchmark (scripts/bench-peers).

Everything that turns a tool's output into a number lives here, once, so that every tool is
scored by the same code:

* ``acc_residuals(bias, K, means)``: per window ``‖K(m − b)‖ − 1`` in g, for any 3×3 ``K``
  (wiical's upper-triangular K, SciPy's, imucal's ``R_a⁻¹K_a⁻¹``).
* ``mag_metrics(points, center, W, R)``: MATLAB ``magcal`` fit error in percent and the RMS
  radius error in raw units, after rescaling ``(W, R)`` to ``|det W| = 1`` so that "raw units"
  mean the same for every tool (wiical already uses ``det W = 1``).
* the f64 SciPy reference of the 9-parameter multi-position fit and its leave-one-window-out
  cross-validation, and a small static-window detector written independently of wiical's.

Loaders only use numpy, so that importing this module costs what numpy costs.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np


# --------------------------------------------------------------------------------------------
# Loaders
# --------------------------------------------------------------------------------------------

def load_recording(path: str, columns: tuple[str, str, str] | None = None):
    """Reads a recording as wiical does for these files.

    Returns ``(t, xyz, meta)``: ``t`` in seconds (``None`` when the file has no time column),
    ``xyz`` an (N, 3) float64 array of raw counts, ``meta`` the ``key,value`` lines (e.g.
    ``Fs``) read before a CSV header. Two layouts occur in ../shared/data:

    * header-less whitespace numbers ``x y z`` or ``t x y z`` (IMU-TK, ellipsoid_fit_python);
    * ``key,value`` metadata lines, then a CSV header (tomisuarez2's MPU-6050 / QMC5883L).
    """
    meta: dict[str, str] = {}
    with open(path, "r", encoding="utf-8") as f:
        head = [f.readline() for _ in range(16)]
    skip = 0
    header = None
    for line in head:
        s = line.strip()
        if not s:
            skip += 1
            continue
        if re.match(r"^[-+0-9.eE\s,]+$", s):
            break  # first data row
        parts = [p.strip() for p in s.split(",")]
        if len(parts) == 2 and _is_number(parts[1]):
            meta[parts[0]] = parts[1]
            skip += 1
            continue
        header = parts
        skip += 1
        break
    if header is None:
        data = np.loadtxt(path, skiprows=skip, ndmin=2)
        if data.shape[1] == 3:
            return None, data, meta
        if data.shape[1] >= 4:
            return data[:, 0], data[:, 1:4], meta
        raise ValueError(f"{path}: expected 3 or 4 columns, got {data.shape[1]}")
    names = [h.lower() for h in header]
    if columns is None:
        for cand in (("ax", "ay", "az"), ("mx", "my", "mz"), ("x", "y", "z")):
            if all(c in names for c in cand):
                columns = cand
                break
    if columns is None:
        raise ValueError(f"{path}: no x,y,z columns in header {header}")
    idx = [names.index(c) for c in columns]
    data = np.loadtxt(path, delimiter=",", skiprows=skip, ndmin=2)
    t = data[:, names.index("t")] if "t" in names else None
    return t, data[:, idx], meta


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def sample_rate(t, meta, default_hz: float = 100.0) -> float:
    """Sample rate: ``Fs`` metadata, else the median time step, else ``default_hz``."""
    if "Fs" in meta:
        return float(meta["Fs"])
    if t is not None and len(t) > 1:
        return 1.0 / float(np.median(np.diff(t)))
    return default_hz


def times_of(t, n: int, fs: float):
    """Sample times: the file's own, else ``i / fs`` (wiical's convention for files without
    a time column: the first sample at 0 s)."""
    return t if t is not None else np.arange(n) / fs


# --------------------------------------------------------------------------------------------
# Accelerometer: metric, f64 reference fit, LOWO
# --------------------------------------------------------------------------------------------

def acc_residuals(bias, K, means) -> np.ndarray:
    """``‖K(m − b)‖ − 1`` per window, g (f64). ``K`` maps raw counts to g."""
    b = np.asarray(bias, dtype=np.float64)
    K = np.asarray(K, dtype=np.float64)
    m = np.asarray(means, dtype=np.float64)
    return np.linalg.norm((m - b) @ K.T, axis=1) - 1.0


def rms(x) -> float:
    x = np.asarray(x, dtype=np.float64)
    return float(math.sqrt(float(np.mean(x * x)))) if x.size else float("nan")


def _normalisation(means: np.ndarray):
    c = means.mean(axis=0)
    s = math.sqrt(float(np.mean(np.sum((means - c) ** 2, axis=1))))
    return c, s


_TRI = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]


def _unpack(p):
    b = p[:3]
    K = np.zeros((3, 3))
    for v, (j, k) in zip(p[3:], _TRI):
        K[j, k] = v
    return b, K


def _res_jac(p, y):
    b, K = _unpack(p)
    e = y - b
    v = e @ K.T
    n = np.linalg.norm(v, axis=1)
    r = n - 1.0
    u = v / n[:, None]  # ∂r/∂v
    J = np.empty((len(y), 9))
    J[:, :3] = -(u @ K)  # ∂r/∂b = −uᵀK
    for col, (j, k) in enumerate(_TRI):
        J[:, 3 + col] = u[:, j] * e[:, k]  # ∂r/∂K_jk = u_j e_k
    return r, J


def scipy_fit(means, p0=None):
    """f64 reference of the 9-parameter multi-position fit:
    minimise Σ(‖K(m_i − b)‖ − 1)² over b and upper-triangular K with SciPy's
    ``least_squares`` (MINPACK Levenberg–Marquardt, analytic Jacobian, tolerances at f64's
    limit). The means are centred and scaled (``y = (m − c)/s``) before fitting, as any careful
    f64 implementation would; the result is mapped back to raw counts.

    Returns ``(bias_raw, K_raw, p)`` (``p``: the normalised parameters, for warm starts).
    """
    from scipy.optimize import least_squares

    m = np.asarray(means, dtype=np.float64)
    c, s = _normalisation(m)
    y = (m - c) / s
    if p0 is None:
        p0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    sol = least_squares(
        lambda p: _res_jac(p, y)[0],
        p0,
        jac=lambda p: _res_jac(p, y)[1],
        method="lm",
        ftol=1e-15,
        xtol=1e-15,
        gtol=1e-15,
        max_nfev=2000,
    )
    b, K = _unpack(sol.x)
    # Gauge: ‖K e‖ is unchanged by flipping the sign of a row of K; keep the diagonal positive.
    for j in range(3):
        if K[j, j] < 0:
            K[j, :] = -K[j, :]
    p = np.concatenate([b, [K[j, k] for (j, k) in _TRI]])
    return c + s * b, K / s, p


def scipy_lowo(means):
    """Leave-one-window-out CV, the same definition as ``wiical analyze`` (base.cv_rms_mg):
    for each window i, refit on the others (from the same neutral start as the full fit) and
    take window i's residual ``‖K₋ᵢ(mᵢ − b₋ᵢ)‖ − 1``. Returns the held-out residuals (g), in
    window order.

    The normalisation (c, s) of each refit is that of the remaining windows; the result in
    raw units does not depend on it (the fit is invariant to it up to rounding).
    """
    m = np.asarray(means, dtype=np.float64)
    out = np.empty(len(m))
    for i in range(len(m)):
        keep = np.ones(len(m), dtype=bool)
        keep[i] = False
        b, K, _ = scipy_fit(m[keep])
        out[i] = acc_residuals(b, K, m[i : i + 1])[0]
    return out


# --------------------------------------------------------------------------------------------
# Accelerometer: static-window detector (independent of wiical's)
# --------------------------------------------------------------------------------------------

def detect_static(xyz, fs, window_s=1.0, init_s=2.0, threshold=6.0, min_static_s=2.0):
    """Static windows by a centred moving variance (batch, f64, cumulative sums).

    A sample is *still* when the sum of the three per-axis variances over the ``window_s``
    window centred on it is ≤ ``threshold`` × the median of that same quantity over the first
    ``init_s`` seconds (the initial rest). Runs of still samples at least ``min_static_s`` long
    are the static windows (a still sample's whole window is still, so each run stops half a
    window short of the motion on either side). Same knobs as ``wiical fit``
    (``--window-s --init-s --threshold --min-static-s``) with the same defaults, but a
    different implementation (wiical's is a streaming detector in f32).

    Returns a list of ``(start, end)`` sample ranges (end exclusive).
    """
    x = np.asarray(xyz, dtype=np.float64)
    n = len(x)
    w = max(3, int(round(window_s * fs)))
    if n < w + 1:
        return []
    tot = window_var(x, w).sum(axis=1)  # window starting at j, j = 0..n−w
    half = w // 2
    score = np.full(n, np.inf)
    score[half : half + len(tot)] = tot  # centre sample of each window
    n_init = max(w, int(round(init_s * fs)))
    ref = float(np.median(tot[: max(1, n_init - w + 1)]))
    still = score <= threshold * ref
    return runs_of(still, int(round(min_static_s * fs)))


def window_var(x, w: int) -> np.ndarray:
    """Per-axis sample variance (ddof 1) of every ``w``-sample window of ``x`` (N, k): row j is
    the window starting at sample j, j = 0..N−w. Cumulative sums of the mean-removed data, f64."""
    x = np.asarray(x, dtype=np.float64)
    x0 = x - x.mean(axis=0)
    zero = np.zeros((1, x.shape[1]))
    c1 = np.vstack([zero, np.cumsum(x0, axis=0)])
    c2 = np.vstack([zero, np.cumsum(x0 * x0, axis=0)])
    s1 = c1[w:] - c1[:-w]
    s2 = c2[w:] - c2[:-w]
    return (s2 - s1 * s1 / w) / (w - 1)


def runs_of(mask, min_len: int):
    """``(start, end)`` of the runs of True in ``mask`` at least ``min_len`` long (end exclusive)."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(m[1:] != m[:-1])
    return [(int(s), int(e)) for s, e in zip(edges[::2], edges[1::2]) if e - s >= min_len]


# --------------------------------------------------------------------------------------------
# Magnetometer: one metric for every tool
# --------------------------------------------------------------------------------------------

def mag_metrics(points, center, W, R):
    """MATLAB ``magcal`` fit error and RMS radius error of a hard/soft-iron model.

    The model says ``‖W(m − c)‖ = R`` for every sample. ``(W, R)`` are first rescaled by
    ``|det W|^(−1/3)`` (the model is unchanged), so that ``R`` and the radius error are in raw
    sensor units for every tool — wiical's convention (``det W = 1``); magcal's ellipsoid maps
    to ``R = 1`` and the authors' ``A`` to the unit sphere, and would otherwise report their
    errors in those units.

    Returns ``{"fit_error_pct": 100·√(mean((‖u‖² − R²)²))/(2R²),
    "rms_radius_error": √(mean((‖u‖ − R)²)), "radius": R}`` with ``u = W(m − c)``, all f64.
    """
    p = np.asarray(points, dtype=np.float64)
    c = np.asarray(center, dtype=np.float64)
    W = np.asarray(W, dtype=np.float64)
    d = abs(float(np.linalg.det(W)))
    f = d ** (-1.0 / 3.0)
    Wn, Rn = W * f, float(R) * f
    u = (p - c) @ Wn.T
    n2 = np.sum(u * u, axis=1)
    fit_pct = 100.0 * math.sqrt(float(np.mean((n2 - Rn**2) ** 2))) / (2.0 * Rn**2)
    rad = math.sqrt(float(np.mean((np.sqrt(n2) - Rn) ** 2)))
    return {"fit_error_pct": fit_pct, "rms_radius_error": rad, "radius": Rn, "matrix_det1": Wn.tolist()}


def dump(obj) -> str:
    def conv(o):
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(type(o))

    return json.dumps(obj, default=conv)
