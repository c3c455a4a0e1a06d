#!/usr/bin/env python3
"""Peer reference numbers for the three protocol recordings of issue 47.

Computed the way a user of the usual tools would, independently of wiical, on the files in
``$WIICAL_DATA`` (default ``../shared/data`` from the repository root):

1. ``imucal_nilspod_ferraris``: imucal's ``FerrarisCalibration`` (PyPI, pinned in
   requirements.txt) on the authors' own hand annotation ``sections.json``, fs = 102.4 Hz,
   imucal's defaults (grav = 9.81 m/s², expected_angle = −360°: clockwise turns, the gyro
   reads negative), input units m/s² and deg/s as in imucal's example on this very data.
2. ``freeimucal_gearvr/gyro_turntable.csv``: freeIMUCal's method (an ellipsoid fitted by
   linear least squares to the angular-rate vectors of one turntable speed, scaled so that
   the calibrated |ω| is the known rate), written here from its description in numpy: per
   rate and jointly (both rates, known radii 200 and 270 °/s), with the bias from the rest part
   or fitted; plus freeIMUCal's own axis-aligned variant with its own sample selection.
3. ``apophis_bmi160_table/tumble.csv``: the seed's six-position method
   (../shared/seeds/six_position_wiimote_it.txt): M = T̂·Â, T̂ = M·Â⁺, Â⁺ = Âᵀ(ÂÂᵀ)⁻¹,
   D = gLT = T̂[:, :3], b = T̂[:, 3], correction a = D⁻¹(m − b); rests found by a moving
   standard deviation of the accelerometer.
4. ``apophis_bmi160_table/rate_table.csv``: the same homogeneous least squares for the gyro,
   with columns [±25·eᵢ; 1] for the constant-rate segments and [0; 1] for the rests.

Prints one JSON object and writes it to ``target/peers/protocols.json``. Deterministic (no
random numbers, fixed thresholds), a few seconds.

    /work/peers-venv/bin/python scripts/peers/protocols.py
"""

from __future__ import annotations

import json
import math
import os
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("WIICAL_DATA") or (ROOT / ".." / "shared" / "data")).resolve()

RPM33_DEG_S = 100.0 / 3.0 * 6.0  # 33⅓ rev/min = 200 °/s
RPM45_DEG_S = 45.0 * 6.0  # 45 rev/min = 270 °/s


# ------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------

def read_csv(path: Path):
    """A headed numeric CSV as {column: float64 array}."""
    with open(path, encoding="utf-8") as f:
        header = [h.strip() for h in f.readline().split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, i] for i, h in enumerate(header)}


def cols(d, names):
    return np.column_stack([d[n] for n in names])


def moving_std(x: np.ndarray, w: int) -> np.ndarray:
    """Largest per-axis standard deviation over the ``w`` samples centred on each sample
    (``inf`` where the window does not fit)."""
    out = np.full(len(x), np.inf)
    if len(x) < w:
        return out
    var = np.maximum(common.window_var(x, w), 0.0)
    h = w // 2
    out[h : h + len(var)] = np.sqrt(var.max(axis=1))
    return out


runs_of = common.runs_of
rms = common.rms


def sym_sqrt(M: np.ndarray) -> np.ndarray:
    """The symmetric positive square root of a symmetric positive definite matrix."""
    M = (M + M.T) / 2
    lam, V = np.linalg.eigh(M)
    if lam.min() <= 0:
        raise ValueError(f"matrix not positive definite (eigenvalues {lam})")
    return (V * np.sqrt(lam)) @ V.T


def sym_from6(p):
    a, b, c, d, e, f = p
    return np.array([[a, d, e], [d, b, f], [e, f, c]], dtype=np.float64)


def r(x, nd=6):
    """Rounded copy for the JSON (floats and nested lists)."""
    a = np.round(np.asarray(x, dtype=np.float64), nd) + 0.0  # + 0.0: no "-0.0" in the JSON
    return float(a) if a.ndim == 0 else a.tolist()


# ------------------------------------------------------------------------------------------
# 1. imucal FerrarisCalibration on its own example session
# ------------------------------------------------------------------------------------------

def ferraris() -> dict:
    import pandas as pd
    from imucal import FerrarisCalibration, ferraris_regions_from_section_list

    folder = DATA / "imucal_nilspod_ferraris"
    raw = read_csv(folder / "ferraris_session.csv")
    acc = cols(raw, ["ax", "ay", "az"])  # m/s²
    gyr = cols(raw, ["gx", "gy", "gz"])  # deg/s
    with open(folder / "sections.json", encoding="utf-8") as f:
        sections = json.load(f)
    fs = 102.4

    # imucal's own path from a section list (its example: read_json(...).T), columns renamed
    # back to imucal's default names.
    df = pd.DataFrame(
        np.column_stack([acc, gyr]),
        columns=["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"],
    )
    section_list = pd.DataFrame(sections).T
    regions = ferraris_regions_from_section_list(df, section_list)
    ferraris_cal = FerrarisCalibration()  # defaults: grav 9.81 m/s², expected_angle −360°
    g = ferraris_cal.grav  # "g" for the g units below: imucal's own
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = ferraris_cal.compute(regions, sampling_rate_hz=fs, from_acc_unit="m/s^2", from_gyr_unit="deg/s")
    acc_c, gyr_c = cal.calibrate(acc=acc, gyr=gyr, acc_unit="m/s^2", gyr_unit="deg/s")

    # Cross-check our reading of imucal's model against its calibrate():
    #   a = R_a⁻¹K_a⁻¹(m − b_a);  ω = R_g⁻¹K_g⁻¹(w − K_ga·a − b_g), w the raw gyro
    A = np.linalg.inv(cal.R_a) @ np.linalg.inv(cal.K_a)
    Gm = cal.K_g @ cal.R_g  # raw °/s (bias and K_ga·a removed) per true °/s
    mine_a = (acc - cal.b_a) @ A.T
    mine_g = (gyr - mine_a @ cal.K_ga.T - cal.b_g) @ np.linalg.inv(Gm).T
    self_check = max(float(np.max(np.abs(mine_a - acc_c))), float(np.max(np.abs(mine_g - gyr_c))))

    holds = {}
    for name in ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"]:
        s, e = sections[name]["start"], sections[name]["end"]
        ideal = np.zeros(3)
        ideal[ord(name[0]) - ord("x")] = 1.0 if name.endswith("_p") else -1.0
        one = {"rows": [s, e], "n": e - s}
        for tag, a in (("raw", acc[s:e]), ("imucal", acc_c[s:e])):
            mean = a.mean(axis=0) / g
            one[tag] = {
                "mean_norm_g": r(np.linalg.norm(a, axis=1).mean() / g, 7),
                "norm_of_mean_g": r(np.linalg.norm(mean), 7),
                "mean_g": r(mean, 7),
                "error_vs_ideal_mg": r(1000 * (mean - ideal), 3),
            }
        holds[name] = one

    pad = int(round(2.0 * fs))
    rotations = {}
    for name in ["x_rot", "y_rot", "z_rot"]:
        s, e = sections[name]["start"], sections[name]["end"]
        one = {"rows": [s, e], "n": e - s}
        for tag, w in (
            ("raw", gyr),
            ("raw_minus_imucal_b_g", gyr - cal.b_g),
            ("imucal", gyr_c),
        ):
            ang = w[s:e].sum(axis=0) / fs  # imucal's own rule: Σω / fs over the section
            one[tag] = {"angle_deg": r(ang, 4), "norm_deg": r(np.linalg.norm(ang), 4)}
        ang = gyr_c[s - pad : e + pad].sum(axis=0) / fs
        one["imucal_section_pm2s"] = {"angle_deg": r(ang, 4), "norm_deg": r(np.linalg.norm(ang), 4)}
        rotations[name] = one

    Ginv = np.linalg.inv(Gm)
    # imucal's example script passes sampling_rate_hz=204.8 for this session; what that would
    # give (only the gyro's K_g, R_g change: the integrated angles halve).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal2 = ferraris_cal.compute(regions, sampling_rate_hz=204.8, from_acc_unit="m/s^2", from_gyr_unit="deg/s")
    return {
        "file": "imucal_nilspod_ferraris/ferraris_session.csv + sections.json",
        "settings": {
            "sampling_rate_hz": fs,
            "grav_m_s2": g,
            "expected_angle_deg": ferraris_cal.expected_angle,
            "from_acc_unit": "m/s^2",
            "from_gyr_unit": "deg/s",
            "g_used_for_g_units_m_s2": g,
            "slices": "rows [start, end) of sections.json, as imucal's data.iloc[start:end]",
        },
        "imucal": {
            "K_a": r(cal.K_a, 9),
            "R_a": r(cal.R_a, 9),
            "b_a_m_s2": r(cal.b_a, 9),
            "K_g": r(cal.K_g, 9),
            "R_g": r(cal.R_g, 9),
            "K_ga_deg_s_per_m_s2": r(cal.K_ga, 9),
            "b_g_deg_s": r(cal.b_g, 9),
        },
        "model": "acc = R_a^-1 K_a^-1 (m - b_a) [m/s^2]; gyr = R_g^-1 K_g^-1 (w - K_ga*acc - b_g) [deg/s]",
        "acc_matrix_Ra_inv_Ka_inv": r(A, 9),
        "gyro_gain_matrix_Kg_Rg": r(Gm, 9),
        "gyro_gain_raw_per_true": r(np.diag(Gm), 7),
        "gyro_gain_raw_per_true_definition": (
            "diag(K_g R_g): raw deg/s read on axis i (after b_g and K_ga*acc are removed) per true "
            "deg/s about axis i; raw (no calibration) = 1"
        ),
        "gyro_scale_true_per_raw": r(np.diag(Ginv), 7),
        "gyro_scale_true_per_raw_definition": "diag((K_g R_g)^-1) = diag(R_g^-1 K_g^-1)",
        "gyro_bias_deg_s": r(cal.b_g, 6),
        "gyro_bias_definition": "b_g: mean gyro over all samples of the six holds (raw: 0)",
        # imucal's K_ga per g of its own 9.81 m/s^2: raw deg/s per g, the unit of wiical's
        # g_sensitivity.raw_per_g (the gyro's rest reading against the calibrated accelerometer).
        "K_ga_deg_s_per_g": r(cal.K_ga * g, 6),
        "K_ga_definition": "(mean gyro on face i+ - on face i-) / (2 g), column i (Ferraris eq. 9)",
        "raw": {"gyro_gain_raw_per_true": [1.0, 1.0, 1.0], "gyro_bias_deg_s": [0.0, 0.0, 0.0]},
        "holds": holds,
        "rotations": rotations,
        "if_sampling_rate_204_8": {
            "K_g_diag": r(np.diag(cal2.K_g), 7),
            "gyro_gain_raw_per_true": r(np.diag(cal2.K_g @ cal2.R_g), 7),
            "note": "imucal's examples/basic_ferraris.py passes 204.8 Hz; the raw turns then integrate to ~180 deg",
        },
        "self_check_max_abs_diff": self_check,
    }


# ------------------------------------------------------------------------------------------
# 2. freeIMUCal's turntable method on the Gear VR gyro
# ------------------------------------------------------------------------------------------

def ellipsoid_general(x: np.ndarray):
    """Algebraic fit of a general ellipsoid (freeIMUCal's "option 0" equation):
    Ax² + By² + Cz² + 2Dxy + 2Exz + 2Fyz + 2Gx + 2Hy + 2Iz = 1, linear least squares.
    Returns (centre c, W symmetric) with ‖W(x − c)‖ = 1 on the surface."""
    X, Y, Z = x.T
    Dm = np.column_stack([X * X, Y * Y, Z * Z, 2 * X * Y, 2 * X * Z, 2 * Y * Z, 2 * X, 2 * Y, 2 * Z])
    v = np.linalg.lstsq(Dm, np.ones(len(x)), rcond=None)[0]
    Q = sym_from6([v[0], v[1], v[2], v[3], v[4], v[5]])
    c = -np.linalg.solve(Q, v[6:9])
    k = 1.0 + c @ Q @ c
    return c, sym_sqrt(Q / k)


def ellipsoid_axis(x: np.ndarray):
    """Axis-aligned algebraic fit (freeIMUCal's "option 1", its default):
    Ax² + By² + Cz² + 2Gx + 2Hy + 2Iz = 1. Returns (centre, radii)."""
    X, Y, Z = x.T
    Dm = np.column_stack([X * X, Y * Y, Z * Z, 2 * X, 2 * Y, 2 * Z])
    v = np.linalg.lstsq(Dm, np.ones(len(x)), rcond=None)[0]
    c = -v[3:6] / v[0:3]
    k = 1.0 + np.sum(v[3:6] ** 2 / v[0:3])
    return c, np.sqrt(k / v[0:3])


def shape_fixed_centre(u: np.ndarray, radii: np.ndarray):
    """uᵀMu = r² with the centre already removed (u = x − b): linear in the 6 entries of M;
    each row divided by r² (relative residuals). Returns S = M^½ (symmetric)."""
    U, V, W = u.T
    Dm = np.column_stack([U * U, V * V, W * W, 2 * U * V, 2 * U * W, 2 * V * W]) / (radii**2)[:, None]
    p = np.linalg.lstsq(Dm, np.ones(len(u)), rcond=None)[0]
    return sym_sqrt(sym_from6(p))


def shape_free_centre(x: np.ndarray, radii: np.ndarray):
    """xᵀMx − 2hᵀx + d = r² (h = Mc, d free): linear in 10 unknowns, rows divided by r².
    Known radii of two shells fix the scale. Returns (c, S = M^½)."""
    X, Y, Z = x.T
    Dm = np.column_stack(
        [X * X, Y * Y, Z * Z, 2 * X * Y, 2 * X * Z, 2 * Y * Z, -2 * X, -2 * Y, -2 * Z, np.ones(len(x))]
    ) / (radii**2)[:, None]
    p = np.linalg.lstsq(Dm, np.ones(len(x)), rcond=None)[0]
    M = sym_from6(p[:6])
    c = np.linalg.solve(M, p[6:9])
    return c, sym_sqrt(M)


def geometric_refine(x: np.ndarray, radii: np.ndarray, c0, S0):
    """min Σ(‖S(x − c)‖ − r)² over c and symmetric S (9 parameters), SciPy LM from (c0, S0)."""
    from scipy.optimize import least_squares

    iu = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]

    def unpack(p):
        return p[:3], sym_from6(p[3:])

    def res(p):
        c, S = unpack(p)
        return np.linalg.norm((x - c) @ S.T, axis=1) - radii

    p0 = np.concatenate([c0, [S0[i, j] for i, j in iu]])
    sol = least_squares(res, p0, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=5000)
    return unpack(sol.x)


def turntable() -> dict:
    path = DATA / "freeimucal_gearvr" / "gyro_turntable.csv"
    w = cols(read_csv(path), ["gx", "gy", "gz"])  # rad/s
    parts = {"rest": (0, 5300), "rpm33": (5300, 14300), "rpm45": (14300, 27900)}
    rate = {"rpm33": math.radians(RPM33_DEG_S), "rpm45": math.radians(RPM45_DEG_S)}
    WIN, STEADY_REST, STEADY_ROT, BAND = 31, math.radians(0.5), math.radians(1.0), 0.05

    # Rest bias: inside rows 0–5,299, samples whose 31-row centred moving std (largest axis)
    # is < 0.5 °/s and whose |ω| is < 0.1 rad/s (freeIMUCal's own rest band).
    s, e = parts["rest"]
    xr = w[s:e]
    keep = (moving_std(xr, WIN) < STEADY_REST) & (np.linalg.norm(xr, axis=1) < 0.1)
    bias = xr[keep].mean(axis=0)
    rest = {"n": int(keep.sum()), "of": e - s, "bias_rad_s": r(bias, 8), "bias_deg_s": r(np.degrees(bias), 5)}

    # Steady rotation: 31-row moving std < 1 °/s (the vector is constant while the platter
    # turns at a constant speed with the sensor fixed on it: spin-up, spin-down, re-orienting
    # and pauses fail this), and |ω − bias| within ±5 % of the nominal rate.
    sel, xs = {}, {}
    for k in ("rpm33", "rpm45"):
        s, e = parts[k]
        x = w[s:e]
        n = np.linalg.norm(x - bias, axis=1)
        ok = (moving_std(x, WIN) < STEADY_ROT) & (np.abs(n - rate[k]) < BAND * rate[k])
        xs[k] = x[ok]
        runs = runs_of(ok, 1)
        sel[k] = {
            "n": int(ok.sum()),
            "of": e - s,
            "runs": len(runs),
            "raw_norm_minus_bias_deg_s": {
                "mean": r(np.degrees(n[ok].mean()), 4),
                "min": r(np.degrees(n[ok].min()), 4),
                "max": r(np.degrees(n[ok].max()), 4),
            },
        }

    def evaluate(c, S):
        out = {}
        for k in ("rpm33", "rpm45"):
            nn = np.linalg.norm((xs[k] - c) @ S.T, axis=1)
            out[k] = {
                "residual_rms_deg_s": r(np.degrees(rms(nn - rate[k])), 5),
                "mean_cal_rate_deg_s": r(np.degrees(nn.mean()), 5),
            }
        return out

    def describe(c, S, **extra):
        Sinv = np.linalg.inv(S)
        d = {
            "center_rad_s": r(c, 8),
            "center_deg_s": r(np.degrees(c), 5),
            "S": r(S, 8),
            "gain_raw_per_true": r(np.diag(Sinv), 7),
            "scale_true_per_raw": r(np.diag(S), 7),
            "eval": evaluate(c, S),
        }
        d.update(extra)
        return d

    fits = {}
    fits["bias_only"] = describe(bias, np.eye(3), note="rest bias removed, no scale (for comparison)")
    for k in ("rpm33", "rpm45"):
        c, Wm = ellipsoid_general(xs[k])
        fits[f"{k}_general_free_center"] = describe(
            c, rate[k] * Wm, n=len(xs[k]),
            note="algebraic general ellipsoid on this rate's samples; centre fitted; S = rate*W",
        )
        S = shape_fixed_centre(xs[k] - bias, np.full(len(xs[k]), rate[k]))
        fits[f"{k}_general_rest_bias"] = describe(
            bias, S, n=len(xs[k]), note="centre = rest bias; S symmetric, linear LS on (x-b)'S^2(x-b) = rate^2"
        )
    xa = np.vstack([xs["rpm33"], xs["rpm45"]])
    ra = np.concatenate([np.full(len(xs["rpm33"]), rate["rpm33"]), np.full(len(xs["rpm45"]), rate["rpm45"])])
    S = shape_fixed_centre(xa - bias, ra)
    fits["joint_rest_bias"] = describe(
        bias, S, n=len(xa), note="both rates, known radii 200 and 270 deg/s, centre = rest bias, linear LS"
    )
    c, S = shape_free_centre(xa, ra)
    fits["joint_free_center_linear"] = describe(
        c, S, n=len(xa), note="both rates, known radii, centre fitted: linear LS in (M, Mc, d), rows / r^2"
    )
    c, S = geometric_refine(xa, ra, c, S)
    fits["joint_free_center_geometric"] = describe(
        c, S, n=len(xa), note="both rates, known radii, centre fitted: SciPy LM on |S(x-c)| - r from the linear fit"
    )

    # freeIMUCal's own recipe (its calibrateGyr example), re-implemented: rest = |ω| < 0.1
    # rad/s then three passes of "keep |ω| within mean ± 3σ", offset = mean; per rate the
    # |ω| band 2–5 rad/s (33⅓) or 4.5–5.5 rad/s (45) and the same three passes, offset removed,
    # axis-aligned ellipsoid, correction diag(rate / radius_i); the two averaged.
    def clean(x, lo, hi):
        n = np.linalg.norm(x, axis=1)
        x = x[(n >= lo) & (n < hi)]
        for _ in range(3):
            n = np.linalg.norm(x, axis=1)
            m, sd = n.mean(), n.std()
            x = x[(n >= m - 3 * sd) & (n < m + 3 * sd)]
        return x

    s, e = parts["rest"]
    off = clean(w[s:e], 0.0, 0.1).mean(axis=0)
    fi = {"offset_rad_s": r(off, 8), "offset_deg_s": r(np.degrees(off), 5), "n_rest": len(clean(w[s:e], 0.0, 0.1))}
    corr = []
    for k, (lo, hi) in (("rpm33", (2.0, 5.0)), ("rpm45", (4.5, 5.5))):
        s, e = parts[k]
        x = clean(w[s:e], lo, hi) - off
        cc, radii = ellipsoid_axis(x)
        C = np.diag(rate[k] / radii)
        corr.append(C)
        fi[k] = {
            "n": len(x),
            "fit_center_deg_s": r(np.degrees(cc), 5),
            "radii_deg_s": r(np.degrees(radii), 4),
            "correction_diag": r(np.diag(C), 7),
            "gain_raw_per_true": r(radii / rate[k], 7),
        }
    Cm = (corr[0] + corr[1]) / 2
    fi["averaged_correction_diag"] = r(np.diag(Cm), 7)
    fi["eval_on_steady_samples"] = evaluate(off, Cm)
    fi["authors_published"] = {
        "source": "uutzinger/freeIMUCal 33Corr.json and 45Corr.json at commit 67f3a82 (offset rad/s, cMat diagonal)",
        "offset_rad_s": [-0.013355785700059969, -0.010484230432184367, 0.03801639115714058],
        "rpm33_diag": [1.0143556141594972, 0.9880922950872297, 0.99925771424932],
        "rpm45_diag": [1.0131765248362716, 0.9886845958428079, 0.9988270668175625],
    }
    fits["freeimucal_axis_aligned_recipe"] = fi

    return {
        "file": "freeimucal_gearvr/gyro_turntable.csv (rad/s, rows 0-5299 rest, 5300-14299 33 1/3 RPM, 14300-27899 45 RPM)",
        "model": "w_true = S (w_raw - center); |w_true| = known rate; gain_raw_per_true = diag(S^-1), scale_true_per_raw = diag(S)",
        "rates_deg_s": {"rpm33": RPM33_DEG_S, "rpm45": RPM45_DEG_S},
        "selection": (
            f"rest: rows 0-5299 with {WIN}-row centred moving std (largest axis) < 0.5 deg/s and |w| < 0.1 rad/s; "
            f"rotation: {WIN}-row moving std < 1 deg/s and | |w - rest bias| - rate | < 5 % of the rate"
        ),
        "rest": rest,
        "selected": sel,
        "fits": fits,
    }


# ------------------------------------------------------------------------------------------
# 3. The seed's six-position method on the BMI160 tumble
# ------------------------------------------------------------------------------------------

def homogeneous(M: np.ndarray, A: np.ndarray):
    """The seed's eq. 5–7: T̂ = M·Â⁺ with Â = [A; 1] and Â⁺ = Âᵀ(ÂÂᵀ)⁻¹."""
    Ah = np.vstack([A, np.ones((1, A.shape[1]))])
    Ap = Ah.T @ np.linalg.inv(Ah @ Ah.T)
    T = M @ Ap
    return T, Ah, Ap


def face_label(m):
    i = int(np.argmax(np.abs(m)))
    return ("+" if m[i] > 0 else "-") + "xyz"[i]


def seed_report(means: list, labels: list, scale: float, unit_res: float, res_unit: str):
    """T̂, D, D⁻¹, b for the given pose means (columns) and their ideal values (labels ±axis,
    or "0" for a rest); each pose corrected, its norm and its residual vs the ideal."""
    M = np.column_stack(means)
    A = np.zeros((3, len(labels)))
    for j, lab in enumerate(labels):
        if lab != "0":
            A["xyz".index(lab[1]), j] = scale * (1.0 if lab[0] == "+" else -1.0)
    T, Ah, Ap = homogeneous(M, A)
    D, b = T[:, :3], T[:, 3]
    Dinv = np.linalg.inv(D)
    poses = []
    for j, lab in enumerate(labels):
        a = Dinv @ (M[:, j] - b)
        poses.append(
            {
                "pose": lab,
                "mean": r(M[:, j], 7),
                "norm_raw": r(np.linalg.norm(M[:, j]), 7),
                "corrected": r(a, 7),
                "norm_corrected": r(np.linalg.norm(a), 7),
                f"residual_{res_unit}": r(unit_res * (a - A[:, j]), 4),
                f"residual_norm_{res_unit}": r(unit_res * np.linalg.norm(a - A[:, j]), 4),
            }
        )
    fit_res = M - T @ Ah
    return {
        "T_hat": r(T, 8),
        "D": r(D, 8),
        "D_inv": r(Dinv, 8),
        "b": r(b, 8),
        "poses": poses,
        f"model_residual_M_minus_That_Ahat_rms_{res_unit}": r(unit_res * rms(fit_res), 4),
    }


def tumble() -> dict:
    path = DATA / "apophis_bmi160_table" / "tumble.csv"
    d = read_csv(path)
    acc = cols(d, ["ax", "ay", "az"])  # g
    gyr = cols(d, ["gx", "gy", "gz"])  # °/s
    WIN, TH, MIN = 25, 0.02, 100
    rests = runs_of(moving_std(acc, WIN) < TH, MIN)
    found = []
    for s, e in rests:
        m = acc[s:e].mean(axis=0)
        found.append(
            {
                "rows": [s, e],
                "n": e - s,
                "face": face_label(m),
                "mean_g": r(m, 7),
                "std_g": r(acc[s:e].std(axis=0), 6),
                "gyro_mean_deg_s": r(gyr[s:e].mean(axis=0), 5),
            }
        )
    faces = [f["face"] for f in found]
    expected = ["+z", "-x", "-z", "+x", "+y", "-y", "+z"]
    by = {}
    for f, (s, e) in zip(faces, rests):
        by.setdefault(f, []).append(acc[s:e].mean(axis=0))
    order = ["+x", "-x", "+y", "-y", "+z", "-z"]  # the seed's column order
    out = {
        "file": "apophis_bmi160_table/tumble.csv (g)",
        "detection": f"{WIN}-row centred moving std of acc (largest axis) < {TH} g, runs >= {MIN} rows; face = sign and axis of the largest mean component",
        "rests": found,
        "faces_as_expected": faces == expected,
    }
    if faces != expected:
        out["error"] = f"rests found {faces}, expected {expected}"
        return out
    # Gyro bias from the same rests, samples with |ω| < 5 °/s only: the last +z rest starts
    # while the table still turns about the vertical (−12 °/s for ~30 rows; the
    # accelerometer does not see a turn about gravity).
    gyro_rest = np.vstack([gyr[s:e] for s, e in rests])
    gyro_rest = gyro_rest[np.linalg.norm(gyro_rest, axis=1) < 5.0]
    out["gyro_bias_from_rests_deg_s"] = r(gyro_rest.mean(axis=0), 5)
    out["gyro_bias_from_rests_n"] = len(gyro_rest)
    variants = {
        "first_plus_z": [by[k][0] for k in order],
        "last_plus_z": [by[k][-1] for k in order],
        "both_plus_z_averaged": [by[k][0] if k != "+z" else (by["+z"][0] + by["+z"][1]) / 2 for k in order],
    }
    out["seed_six_position"] = {
        name: seed_report(ms, order, 1.0, 1000.0, "mg") for name, ms in variants.items()
    }
    # The seed's eq. 6: for the six faces in its order, Â⁺ is the constant ±0.5 / (1/6) matrix.
    _, _, Ap = homogeneous(np.column_stack(variants["first_plus_z"]), np.hstack([np.eye(3), -np.eye(3)])[:, [0, 3, 1, 4, 2, 5]])
    eq6 = np.zeros((6, 4))
    for j in range(6):
        eq6[j, j // 2] = 0.5 if j % 2 == 0 else -0.5
        eq6[j, 3] = 1.0 / 6.0
    out["seed_six_position"]["A_hat_pinv_equals_eq6"] = bool(np.allclose(Ap, eq6, atol=1e-12))
    out["seed_six_position"]["both_plus_z_averaged"]["note"] = "+z column = mean of the two +z rests' means (equal weight)"
    seven = [acc[s:e].mean(axis=0) for s, e in rests]
    out["seed_six_position"]["seven_columns"] = seed_report(seven, faces, 1.0, 1000.0, "mg")
    out["seed_six_position"]["seven_columns"]["note"] = "all 7 rests as columns, general A^+ = A'(AA')^-1"
    out["units"] = "T_hat, D, b in g (the seed's g = 1 g here: the file is in g); residuals in mg = 1000*(D^-1(m-b) - ideal)"
    return out


# ------------------------------------------------------------------------------------------
# 4. The rate table: constant ±25 °/s about each axis
# ------------------------------------------------------------------------------------------

def rate_table() -> dict:
    path = DATA / "apophis_bmi160_table" / "rate_table.csv"
    d = read_csv(path)
    gyr = cols(d, ["gx", "gy", "gz"])  # °/s
    RATE, WIN, TH, MIN = 25.0, 25, 2.0, 60
    segs = runs_of(moving_std(gyr, WIN) < TH, MIN)
    found, means, labels = [], [], []
    for s, e in segs:
        m = gyr[s:e].mean(axis=0)
        if np.linalg.norm(m) < 5.0:
            lab = "0"
        else:
            lab = face_label(m)
            i = "xyz".index(lab[1])
            if abs(abs(m[i]) - RATE) > 0.2 * RATE:
                lab = "?"
        found.append(
            {
                "rows": [s, e],
                "n": e - s,
                "label": lab,
                "mean_deg_s": r(m, 5),
                "std_deg_s": r(gyr[s:e].std(axis=0), 4),
            }
        )
        if lab != "?":
            means.append(m)
            labels.append(lab)
    out = {
        "file": "apophis_bmi160_table/rate_table.csv (deg/s)",
        "detection": (
            f"{WIN}-row centred moving std of gyro (largest axis) < {TH} deg/s, runs >= {MIN} rows; "
            "|mean| < 5 deg/s = rest (ideal 0), else the largest component's sign and axis "
            "with |mean| within 20 % of 25 deg/s = that signed rotation (ideal 25*sign*e_i)"
        ),
        "segments": found,
        "sign_convention": "ideal sign taken from the reading: the table's command direction is not in the file",
    }
    rest = np.vstack([gyr[s:e] for (s, e), f in zip(segs, found) if f["label"] == "0"])
    out["bias_from_rests_deg_s"] = r(rest.mean(axis=0), 5)
    out["rest_samples"] = len(rest)
    pairs = {}
    for ax in "xyz":
        p = [m for m, lab in zip(means, labels) if lab == "+" + ax]
        q = [m for m, lab in zip(means, labels) if lab == "-" + ax]
        if len(p) == 1 and len(q) == 1:
            i = "xyz".index(ax)
            pairs[ax] = {
                "half_difference_per_25": r((p[0][i] - q[0][i]) / (2 * RATE), 6),
                "midpoint_deg_s": r((p[0] + q[0]) / 2, 5),
            }
    out["pairs"] = pairs
    out["seed_style_with_rests"] = seed_report(means, labels, RATE, 1.0, "deg_s")
    rot = [(m, lab) for m, lab in zip(means, labels) if lab != "0"]
    out["seed_style_rotations_only"] = seed_report([m for m, _ in rot], [lab for _, lab in rot], RATE, 1.0, "deg_s")
    out["units"] = "T_hat = [D | b], D = raw deg/s per true deg/s, b in deg/s; correction w = D^-1 (m - b)"
    return out


def main() -> int:
    result = {
        "script": "scripts/peers/protocols.py",
        "data": str(DATA),
        "numpy": np.__version__,
    }
    try:
        import imucal
        import scipy

        result["imucal"] = getattr(imucal, "__version__", "?")
        result["scipy"] = scipy.__version__
    except ImportError as e:  # pragma: no cover
        result["import_error"] = str(e)
    result["ferraris_imucal"] = ferraris()
    result["turntable_freeimucal"] = turntable()
    result["tumble_six_position"] = tumble()
    result["rate_table"] = rate_table()
    text = common.dump(result)
    out = ROOT / "target" / "peers" / "protocols.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(json.loads(text), indent=1) + "\n", encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
