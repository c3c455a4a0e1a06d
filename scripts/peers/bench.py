#!/usr/bin/env python3
"""Runs wiical and its peers on the real recordings and writes docs/peers.md.

Called by scripts/bench-peers (which builds wiical and installs the peers into a venv); see
that script for the options. Every accuracy number is computed here, by the shared functions
in common.py, from each tool's fitted parameters, so that the metric is the same for all.
"""
from __future__ import annotations

import argparse
import importlib.metadata as md
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import common

HERE = Path(__file__).resolve().parent
PY = sys.executable

# --------------------------------------------------------------------------------------------
# Running things
# --------------------------------------------------------------------------------------------


def run_json(cmd: list[str]):
    """Runs ``cmd``; returns ``(json or None, error text or None)``."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        msg = (p.stderr.strip().splitlines() or p.stdout.strip().splitlines() or ["?"])[-1]
        return None, f"exit {p.returncode}: {msg}"
    try:
        d = json.loads(p.stdout)
    except json.JSONDecodeError as e:
        return None, f"no JSON on stdout ({e})"
    if isinstance(d, dict) and "error" in d:
        return None, d["error"]
    return d, None


def time_cmds(cmds: list[list[str]], runs: int):
    """Wall times of ``runs`` end-to-end invocations of each command (s), after one warm-up
    each (page cache, .pyc). The commands are run round-robin — one run of each, ``runs``
    times — so that a change of load on this shared machine hits every tool alike. Returns,
    per command, ``None`` if it failed, else its times and the parsed JSON of each run (for
    the in-process times the peers report)."""
    for c in cmds:
        subprocess.run(c, capture_output=True)
    res = [{"walls": [], "outs": []} for _ in cmds]
    for _ in range(runs):
        for i, c in enumerate(cmds):
            r = res[i]
            if r is None:
                continue
            t = time.perf_counter()
            p = subprocess.run(c, capture_output=True, text=True)
            r["walls"].append(time.perf_counter() - t)
            if p.returncode != 0:
                res[i] = None
                continue
            try:
                r["outs"].append(json.loads(p.stdout))
            except json.JSONDecodeError:
                r["outs"].append({})
    for r in res:
        if r is not None:
            r["median"] = statistics.median(r["walls"])
            r["min"] = min(r["walls"])
    return res


def in_process(t, key):
    if t is None:
        return None
    v = [o[key] for o in t["outs"] if isinstance(o, dict) and key in o]
    return statistics.median(v) if v else None


# --------------------------------------------------------------------------------------------
# Formatting
# --------------------------------------------------------------------------------------------


def f(x, nd=4):
    if x is None:
        return "—"
    if isinstance(x, float) and not np.isfinite(x):
        return "n/a"
    return f"{x:.{nd}f}"


def fsec(x):
    if x is None:
        return "—"
    if x >= 0.1:
        return f"{x:.3f} s"
    if x >= 1e-3:
        return f"{x * 1e3:.1f} ms"
    return f"{x * 1e6:.0f} µs"


def vec(v, nd=1):
    return "(" + ", ".join(f"{x:.{nd}f}" for x in v) + ")"


def upper_gauge(K):
    """The upper-triangular ``R`` with positive diagonal such that ``‖Ke‖ = ‖Re‖`` for all e
    (QR of K). wiical's and SciPy's K already are; imucal's is not. Lets K's be compared."""
    K = np.asarray(K, dtype=np.float64)
    _, R = np.linalg.qr(K)
    for j in range(3):
        if R[j, j] < 0:
            R[j, :] = -R[j, :]
    return R


def kfmt(K):
    R = upper_gauge(K) * 1e4
    return (
        f"{R[0,0]:.5f} {R[0,1]:+.5f} {R[0,2]:+.5f} / {R[1,1]:.5f} {R[1,2]:+.5f} / {R[2,2]:.5f}"
    )


def sym_det1(W):
    """The symmetric positive factor ``P = (WᵀW)^½`` of W, scaled to det 1: ``‖W u‖ = ‖P u‖``
    for all u, so every tool's soft-iron matrix is shown in the same form as wiical's."""
    W = np.asarray(W, dtype=np.float64)
    w, V = np.linalg.eigh(W.T @ W)
    P = V @ np.diag(np.sqrt(w)) @ V.T
    return P / abs(np.linalg.det(P)) ** (1 / 3)


def wfmt(W):
    P = sym_det1(W)
    return f"{P[0,0]:.4f} {P[0,1]:+.4f} {P[0,2]:+.4f} / {P[1,1]:.4f} {P[1,2]:+.4f} / {P[2,2]:.4f}"


DATA_SHOWN = "$WIICAL_DATA"


def rel(cmd: list[str], root: Path, data: Path) -> str:
    """The command as a reader would type it from the workspace root."""
    out = []
    for c in cmd:
        s = str(c)
        if s.startswith(str(data) + "/"):
            out.append(DATA_SHOWN + "/" + shlex.quote(s[len(str(data)) + 1 :]))
            continue
        if s.startswith(str(root) + "/"):
            s = s[len(str(root)) + 1 :]
        out.append(shlex.quote(s))
    return " ".join(out)


# --------------------------------------------------------------------------------------------
# Accelerometer
# --------------------------------------------------------------------------------------------


def authors_mpu(path: Path):
    """tomisuarez2/ImuCalibration's published result (reference_params_acc.csv):
    ``a = T·K·(m + b)`` in m/s² with ``g = 9.80665`` (their calibrate_accel_from_data default),
    ``T = [[1, −α_yz, α_zy], [0, 1, −α_zx], [0, 0, 1]]``, K diagonal, parameters
    ``[α_yz, α_zy, α_zx, k_x, k_y, k_z, b_x, b_y, b_z]`` (their apply_accel_calibration).
    Returned in wiical's convention ``a = K'(m − b')``, g: ``K' = T·K/g``, ``b' = −b``."""
    p = np.loadtxt(path, delimiter=",")
    a, k, b = p[:3], p[3:6], p[6:]
    T = np.array([[1.0, -a[0], a[1]], [0.0, 1.0, -a[2]], [0.0, 0.0, 1.0]])
    return -b, T @ np.diag(k) / 9.80665


def bench_acc(ds, W, data: Path, root: Path, work: Path, runs: int, failures: dict):
    path = data / ds["file"]
    opts = ds["opts"]
    res = {"name": ds["name"], "file": ds["file"], "opts": opts, "rows": [], "timing": [], "notes": []}
    fit_json = work / f"{ds['key']}.fit.json"
    an_json = work / f"{ds['key']}.analyze.json"
    fit_cmd = [W, "fit", str(path), "--json", *opts]
    an_cmd = [W, "analyze", str(path), "--json", *opts]
    fit, err = run_json(fit_cmd)
    if fit is None:
        raise SystemExit(f"wiical fit failed on {path}: {err}")
    fit_json.write_text(json.dumps(fit))
    an, err = run_json(an_cmd)
    if an is None:
        raise SystemExit(f"wiical analyze failed on {path}: {err}")
    an_json.write_text(json.dumps(an))
    means = np.array([w["mean"] for w in fit["windows"]])
    n = len(means)
    res["windows"] = n

    def row(tool, bias, K, own_rms, own_n, lowo, note=""):
        shared = common.rms(common.acc_residuals(bias, K, means)) * 1e3
        res["rows"].append(
            dict(tool=tool, bias=list(map(float, bias)), K=np.asarray(K).tolist(), own_rms=own_rms,
                 own_n=own_n, shared_rms=shared, lowo=lowo, note=note)
        )
        return shared

    # wiical (f32 core), LOWO from analyze (f64 refits of the same model, host side).
    w_shared = row("wiical fit (f32)", fit["bias"], fit["matrix"], fit["rms_mg"], n,
                   an["base"]["cv_rms_mg"],
                   "LOWO: `wiical analyze` base.cv_rms_mg (its refits run in f64 on its own f64 window means)")
    res["wiical_self_rms"] = fit["rms_mg"]
    res["wiical_shared_rms"] = w_shared

    # SciPy f64 on wiical's windows.
    sa, err = run_json([PY, str(HERE / "acc_scipy.py"), "--means-json", str(fit_json), "--lowo"])
    if sa is None:
        res["rows"].append(dict(tool="SciPy f64, wiical's windows", error=err))
    else:
        row("SciPy f64 least_squares, wiical's windows", sa["bias"], sa["matrix"], sa["rms_mg"], n,
            sa["cv_rms_mg"])
        res["scipy_a"] = sa
    # Same definition check: SciPy's LOWO on analyze's own (f64) window means.
    sd, err = run_json([PY, str(HERE / "acc_scipy.py"), "--means-json", str(an_json), "--lowo"])
    res["scipy_on_analyze_means"] = sd

    # SciPy f64 with the Python detector.
    det_opts = [o for o in opts]
    sb, err = run_json([PY, str(HERE / "acc_scipy.py"), "--detect", str(path), "--lowo", *det_opts])
    if sb is None:
        res["rows"].append(dict(tool="SciPy f64 + Python detector", error=err))
    else:
        row("SciPy f64 least_squares + Python detector", sb["bias"], sb["matrix"], sb["rms_mg"],
            sb["static_windows"], sb["cv_rms_mg"],
            f"its own {sb['static_windows']} windows (in-sample and LOWO over those)")
        res["scipy_b"] = sb

    # imucal.
    im_cmd = [PY, str(HERE / "acc_imucal.py"), str(path), "--windows-json", str(fit_json)]
    if ds.get("gyro"):
        im_cmd += ["--gyro", str(data / ds["gyro"])]
    if "imucal" in failures:
        res["rows"].append(dict(tool="imucal", error=f"not installed: {failures['imucal']}"))
    else:
        im, err = run_json(im_cmd)
        if im is None:
            res["rows"].append(dict(tool="imucal FerrarisCalibration", error=err))
        else:
            used = im["used_windows"]
            r_all = common.acc_residuals(im["bias"], im["matrix"], means)
            held = np.delete(r_all, used)
            worst = max(im["chosen"].items(), key=lambda kv: kv[1]["angle_deg"])
            row("imucal FerrarisCalibration (accelerometer part)", im["bias"], im["matrix"],
                common.rms(r_all[used]) * 1e3, 6, common.rms(held) * 1e3,
                f"6 holds = windows {', '.join(str(i + 1) for i in used)}; worst hold {worst[1]['angle_deg']:.1f}° "
                f"off its axis ({worst[0]}); LOWO column = RMS over the {len(held)} windows it did not use")
            res["imucal"] = im

    if ds.get("authors"):
        b, K = authors_mpu(data / ds["authors"])
        row("authors' published result (tomisuarez2/ImuCalibration)", b, K, None, None, None,
            "their own intervals; g = 9.80665 m/s² (their default)")

    # Timing.
    pairs = [
        ("wiical fit", fit_cmd, None, None),
        ("SciPy + Python detector (same job as `wiical fit`)",
         [PY, str(HERE / "acc_scipy.py"), "--detect", str(path), *det_opts], "wiical fit", "solve_s"),
        ("imucal Ferraris (windows given)", im_cmd, "wiical fit", "solve_s"),
        ("wiical analyze (fit + f64 LOWO + effect search)", an_cmd, None, None),
        ("SciPy + Python detector + LOWO", [PY, str(HERE / "acc_scipy.py"), "--detect", str(path), "--lowo", *det_opts],
         "wiical analyze (fit + f64 LOWO + effect search)", "lowo_s"),
    ]
    timing_rows(res, pairs, runs, root, data, failures)
    return res


def timing_rows(res, pairs, runs, root, data, failures):
    todo = []
    for label, cmd, ref, key in pairs:
        if "imucal" in label and "imucal" in failures or "magcal" in label and "magcal" in failures:
            res["timing"].append(dict(label=label, cmd=rel(cmd, root, data), error="not installed"))
        else:
            todo.append((label, cmd, ref, key))
    times = time_cmds([c for _, c, _, _ in todo], runs)
    base = {}
    for (label, cmd, ref, key), t in zip(todo, times):
        if t is None:
            res["timing"].append(dict(label=label, cmd=rel(cmd, root, data), error="failed"))
            continue
        base[label] = t
        d = dict(label=label, cmd=rel(cmd, root, data), median=t["median"], min=t["min"], walls=t["walls"])
        if key:
            d["in_process"] = in_process(t, key)
            d["in_process_key"] = key
            d["import"] = in_process(t, "import_s")
        if ref and ref in base:
            d["ratio"] = t["median"] / base[ref]["median"]
            d["ratio_min"] = t["min"] / base[ref]["min"]
            d["ref"] = ref
        res["timing"].append(d)


# --------------------------------------------------------------------------------------------
# Magnetometer
# --------------------------------------------------------------------------------------------


def authors_mag(path: Path):
    """tomisuarez2/MagnetometerCalibration's result: ``m_cal = A·m + B`` on the unit sphere
    → ``(c, W, R) = (−A⁻¹B, A, 1)``."""
    p = np.loadtxt(path, delimiter=",")
    A = p[:9].reshape(3, 3)
    B = p[9:]
    return -np.linalg.solve(A, B), A, 1.0


def bench_mag(ds, W, data: Path, root: Path, runs: int, failures: dict):
    path = data / ds["file"]
    _, pts, _ = common.load_recording(str(path))
    res = {"name": ds["name"], "file": ds["file"], "samples": len(pts), "rows": [], "timing": [], "notes": []}

    def row(tool, model, c, Wm, R, own=None, note=""):
        m = common.mag_metrics(pts, c, Wm, R)
        res["rows"].append(dict(tool=tool, model=model, center=list(map(float, c)),
                                W=np.asarray(Wm).tolist(), R=m["radius"], fit_pct=m["fit_error_pct"],
                                rms_rad=m["rms_radius_error"], own=own, note=note))

    pairs = []
    for model in ("sphere", "axis", "ellipsoid"):
        cmd = [W, "magfit", str(path), "--model", model, "--json"]
        d, err = run_json(cmd)
        if d is None:
            res["rows"].append(dict(tool="wiical magfit (f32)", model=model, error=err))
            continue
        row("wiical magfit (f32)", model, d["center"], d["matrix"], d["radius"],
            own=(d["fit_error_pct"], d["rms_radius_error"]))
        pairs.append((f"wiical magfit --model {model}", cmd, None, None))
    for model in ("sphere", "ellipsoid"):
        cmd = [PY, str(HERE / "mag_magcal.py"), str(path), "--method", model]
        if "magcal" in failures:
            res["rows"].append(dict(tool="magcal", model=model, error=f"not installed: {failures['magcal']}"))
            continue
        d, err = run_json(cmd)
        if d is None:
            res["rows"].append(dict(tool="magcal", model=model, error=err))
            continue
        if d.get("refused"):
            res["rows"].append(dict(tool="magcal `calibrate()`", model=model,
                                    error=f"refused: “{d['refused']}” ({len(pts)} samples)"))
            cmd = cmd + ["--force"]
            d, err = run_json(cmd)
            if d is None:
                res["rows"].append(dict(tool="magcal fit function", model=model, error=err))
                continue
            tool = f"magcal `{model}_fit()` called directly (bypassing the check)"
            forced = True
        else:
            tool = "magcal `calibrate()`"
            forced = False
        row(tool, model, d["center"], d["matrix"], d["radius"])
        pairs.append((f"magcal {model}" + (" (`--force`: fit function)" if forced else ""), cmd,
                      f"wiical magfit --model {model}", "solve_s"))
    # f64 geometric reference: the accelerometer's cost Σ(‖K(m − c)‖ − 1)² is the radial
    # least-squares ellipsoid (K upper triangular: the 9-parameter rotated ellipsoid).
    c, K, _ = common.scipy_fit(pts)
    row("SciPy f64 geometric ellipsoid (reference, not a tool)", "ellipsoid", c, K, 1.0,
        note="minimises the radial residual Σ(‖K(m − c)‖ − 1)² (`common.scipy_fit`, the accelerometer "
             "reference's code) — about the smallest fit error this 9-parameter model can reach; "
             "wiical's and the others' fits are algebraic or iterative-linear")
    if ds.get("authors"):
        c, A, R = authors_mag(data / ds["authors"])
        row("authors' published result (tomisuarez2/MagnetometerCalibration)", "A·m + B (12)", c, A, R,
            note=ds.get("authors_note", ""))
    timing_rows(res, pairs, runs, root, data, failures)
    return res


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def machine():
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    vers = {}
    for p in ("numpy", "scipy", "magcal", "imucal", "pandas", "matplotlib"):
        try:
            vers[p] = md.version(p)
        except md.PackageNotFoundError:
            vers[p] = "not installed"
    return dict(cpu=cpu, nproc=os.cpu_count(), load=os.getloadavg(), python=platform.python_version(),
                versions=vers)


def timing_table(lines, res):
    lines.append("| command | median wall (s) | min (s) | in-process solve | imports | vs wiical: median (min) |")
    lines.append("|---|---|---|---|---|---|")
    for t in res["timing"]:
        if "error" in t:
            lines.append(f"| {t['label']} | {t['error']} | | | | |")
            continue
        ip = t.get("in_process")
        ip_s = f"{fsec(ip)} ({t['in_process_key']})" if ip is not None else "—"
        ratio = (f"**{t['ratio']:.1f}×** ({t['ratio_min']:.1f}×) vs {t['ref']}" if "ratio" in t
                 else "(reference)")
        lines.append(f"| {t['label']} | {t['median']:.4f} | {t['min']:.4f} | {ip_s} | {fsec(t.get('import'))} | {ratio} |")
    lines.append("")
    lines.append("<details><summary>exact commands</summary>\n")
    for t in res["timing"]:
        lines.append(f"* {t['label']}: `{t['cmd']}`")
    lines.append("\n</details>\n")


def write_report(out: Path, mach, acc, mag, runs, cmdline, goals, elapsed, commit, failures):
    L = []
    L.append("# wiical against its peers")
    L.append("")
    L.append("Generated by `scripts/bench-peers` — do not edit by hand; rerun it (the hand-written last section, "
             f"*{KEPT_SECTION[3:]}*, is kept as it is). Command: `{cmdline}` (commit `{commit}`, {elapsed:.0f} s in all).")
    L.append("")
    L.append(f"Machine: {mach['cpu']}, nproc = {mach['nproc']}, load average at the end "
             f"{mach['load'][0]:.2f} / {mach['load'][1]:.2f} / {mach['load'][2]:.2f} (1/5/15 min; other jobs share "
             f"this machine, so wall times carry their noise). Python {mach['python']}; "
             + ", ".join(f"{k} {v}" for k, v in mach["versions"].items()) + ".")
    L.append("")
    if failures:
        L.append("**Peers that could not be installed:** " + "; ".join(f"{k}: {v}" for k, v in failures.items()))
        L.append("")
    L.append("## Goals")
    L.append("")
    for g in goals:
        L.append(f"* {'✅ holds' if g['holds'] else '❌ does not hold'} — {g['text']}")
    L.append("")
    L.append("## How the numbers are made")
    L.append("")
    L.append(
        "* **Accelerometer metric** (one function, `common.acc_residuals`, for every tool): per static window, "
        "`‖K(m − b)‖ − 1` in g from the tool's own bias b (counts) and matrix K (counts → g), in f64; RMS in mg. "
        "*RMS own*: over the windows the tool fitted (its in-sample error). *RMS shared*: over `wiical fit`'s windows, "
        "the same set for every tool. *LOWO*: leave-one-window-out — each window predicted by a refit on the others, "
        "`‖K₋ᵢ(mᵢ − b₋ᵢ)‖ − 1`, RMS over the windows; `wiical analyze` (base.cv_rms_mg) and the SciPy script "
        "(`common.scipy_lowo`) use this same definition.")
    L.append(
        "* **SciPy f64 reference**: `scipy.optimize.least_squares` (MINPACK LM, analytic Jacobian, ftol = xtol = gtol "
        "= 1e-15) on Σ(‖K(mᵢ − b)‖ − 1)² with K upper triangular, window means centred and scaled first. Two inputs: "
        "the very window means `wiical fit --json` reports (`windows[].mean`, so both solve the same problem), and "
        "windows found by a Python detector (`common.detect_static`: centred moving variance, summed over axes, "
        "≤ threshold × its median over the initial rest, runs ≥ the minimum length, with the same knob values as "
        "wiical's run) — the whole job `wiical fit` does.")
    L.append(
        "* **imucal** implements Ferraris et al.'s protocol (six axis-aligned holds + three 360° single-axis turns). "
        "These recordings are free multi-position ones: for each signed axis the window pointing closest to it is "
        "given as that hold (the angle it is off is reported), and the missing turns are filled with static samples, "
        "so imucal's gyroscope result is meaningless and discarded; its accelerometer part needs only the holds. "
        "K is shown after QR (`‖Ke‖ = ‖Re‖`), in the upper-triangular gauge of the others.")
    L.append(
        "* **Magnetometer metric** (one function, `common.mag_metrics`): from each tool's centre c, soft-iron "
        "matrix W and field radius R (model `‖W(m − c)‖ = R`), with (W, R) rescaled to |det W| = 1 so that R and the "
        "radius error are in raw counts for every tool: MATLAB magcal's fit error "
        "`100·√(mean((‖W(m − c)‖² − R²)²))/(2R²)` and the RMS of `‖W(m − c)‖ − R`, over every sample of the file. "
        "W is shown as its symmetric det-1 factor `(WᵀW)^½`.")
    L.append(
        "* **magcal** (PyPI) is driven through its library (`MagnetometerCalibrator.calibrate`): its CLI's "
        "`from-file` reads only its own JSON capture format and sleeps 1.5 s for \"visual feedback\". Its ellipsoid "
        "centre is the plain sample mean (not fitted), its sphere a mean nudged by per-sample gradient steps, and "
        "`calibrate()` refuses fewer than 500 samples.")
    L.append(
        f"* **Wall time**: median (and minimum) of {runs} end-to-end runs after one warm-up, each a fresh process, "
        "the commands of a dataset run round-robin so that load changes hit every tool alike "
        "(wiical: the CLI including reading the file; Python peers: the whole script, interpreter start, imports and "
        "file loading included), started from the same Python driver; commands are shown as typed from the workspace root, with "
        "`$WIICAL_DATA` = `../shared/data` by default. *In-process solve* is what the peer script "
        "measures around the fit alone (`solve_s`; `lowo_s` for the LOWO refits), *imports* its import time. "
        "wiical has no in-process timer; its core's solve times are the Criterion numbers in BENCHMARKS.md "
        "(`multipos::fit`, 30 poses: ≈16 µs; `EllipsoidFit::push` ≈84 ns per sample).")
    L.append("")

    for r in acc:
        L.append(f"## Accelerometer — `{r['file']}`")
        L.append("")
        L.append(f"wiical options: `{' '.join(r['opts']) or '(defaults)'}`; {r['windows']} static windows.")
        L.append("")
        L.append("| tool | RMS own (mg) [windows] | RMS shared (mg) | LOWO (mg) | bias (counts) | K ×10⁴ (upper-triangular gauge, rows) |")
        L.append("|---|---|---|---|---|---|")
        for x in r["rows"]:
            if "error" in x:
                L.append(f"| {x['tool']} | {x['error']} | | | | |")
                continue
            own = f"{f(x['own_rms'])} [{x['own_n']}]" if x["own_rms"] is not None else "—"
            L.append(f"| {x['tool']} | {own} | {f(x['shared_rms'])} | {f(x['lowo'])} | {vec(x['bias'])} | {kfmt(x['K'])} |")
        L.append("")
        for x in r["rows"]:
            if x.get("note"):
                L.append(f"* {x['tool']}: {x['note']}.")
        for n in r["notes"]:
            L.append(f"* {n}")
        L.append("")
        timing_table(L, r)

    for r in mag:
        L.append(f"## Magnetometer — `{r['file']}` ({r['samples']} samples)")
        L.append("")
        L.append("| tool | model | fit error (%) | RMS radius error (counts) | R (counts) | centre (counts) | W (det 1, symmetric: row 1 / row 2 / row 3 upper) |")
        L.append("|---|---|---|---|---|---|---|")
        for x in r["rows"]:
            if "error" in x:
                L.append(f"| {x['tool']} | {x['model']} | {x['error']} | | | | |")
                continue
            L.append(f"| {x['tool']} | {x['model']} | {f(x['fit_pct'], 2)} | {f(x['rms_rad'], 1)} | {f(x['R'], 1)} | {vec(x['center'])} | {wfmt(x['W'])} |")
        L.append("")
        for x in r["rows"]:
            if x.get("note"):
                L.append(f"* {x['tool']}: {x['note']}.")
        wsph = next((x for x in r["rows"] if x["tool"].startswith("wiical") and x["model"] == "sphere"
                     and "error" not in x), None)
        for x in r["rows"]:
            if (wsph and "error" not in x and not x["tool"].startswith("wiical") and x["model"] == "sphere"
                    and x["fit_pct"] < wsph["fit_pct"] and x["rms_rad"] > wsph["rms_rad"]):
                L.append(f"* {x['tool']} sphere: a lower fit error % than wiical's sphere but a larger radius "
                         f"error in counts ({x['rms_rad']:.1f} vs {wsph['rms_rad']:.1f}): the % is relative to "
                         f"R², and its sphere is much larger (R = {x['R']:.0f} vs {wsph['R']:.0f} counts), "
                         "hugging one side of the elongated ellipsoid. Compare the counts column.")
        for x in r["rows"]:
            if "error" not in x and x.get("own"):
                m = x["own"]
                x["own_diff"] = (m[0] - x["fit_pct"], m[1] - x["rms_rad"])
        diffs = [x["own_diff"] for x in r["rows"] if "own_diff" in x]
        if diffs:
            L.append(f"* Shared metric vs wiical's own `fit_error_pct` / `rms_radius_error` (f32): largest "
                     f"differences {max(abs(d[0]) for d in diffs):.1e} % and {max(abs(d[1]) for d in diffs):.1e} "
                     "counts.")
        for n in r["notes"]:
            L.append(f"* {n}")
        L.append("")
        timing_table(L, r)
    kept = kept_section(out)
    if kept:
        L.append(kept)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(L) + "\n", encoding="utf-8")


# The one hand-written section of docs/peers.md (scripts/peers/protocols.py's numbers): always
# the last one; a rerun keeps it verbatim.
KEPT_SECTION = "## Protocol recordings (issue 47)"


def kept_section(out: Path) -> str:
    try:
        old = out.read_text(encoding="utf-8")
    except FileNotFoundError:
        return ""
    i = old.find("\n" + KEPT_SECTION + "\n")
    return old[i + 1 :].rstrip("\n") if i >= 0 else ""


# --------------------------------------------------------------------------------------------


ACC = [
    dict(key="xsens", name="IMU-TK Xsens", file="imu_tk_xsens/xsens_acc.mat", opts=[],
         gyro="imu_tk_xsens/xsens_gyro.mat"),
    dict(key="mpu6050", name="MPU-6050", file="mpu6050_multipos_tomisuarez/example_data_calibration.csv",
         opts=["--init-s", "36.5"], authors="mpu6050_multipos_tomisuarez/reference_params_acc.csv"),
]
MAG = [
    dict(name="QMC5883L noisy", file="qmc5883l_mag_tomisuarez/noisy_raw_data.csv",
         authors="qmc5883l_mag_tomisuarez/reference_params_mag.csv",
         authors_note="fitted by the authors on this file's samples after the first 60 s "
                      "(their test_mag_calibration.py); scored here on all samples like the others"),
    dict(name="QMC5883L filtered", file="qmc5883l_mag_tomisuarez/filtered_raw_data.csv",
         authors="qmc5883l_mag_tomisuarez/reference_params_mag.csv",
         authors_note="fitted on the *noisy* recording, not this one: a cross-recording check"),
    dict(name="ellipsoid_fit_python", file="mag_ellipsoid_fit_python/mag_out.txt"),
]


def goals_of(acc, mag):
    goals = []
    ok_all, parts = True, []
    for r in acc:
        sa = r.get("scipy_a")
        w = next(x for x in r["rows"] if x["tool"].startswith("wiical"))
        if sa is None:
            ok_all = False
            parts.append(f"{r['file']}: no SciPy reference")
            continue
        d_in = abs(w["own_rms"] - sa["rms_mg"]) / sa["rms_mg"]
        d_cv = abs(w["lowo"] - sa["cv_rms_mg"]) / sa["cv_rms_mg"]
        db = float(np.max(np.abs(np.array(w["bias"]) - np.array(sa["bias"]))))
        K1, K2 = np.array(w["K"]), np.array(sa["matrix"])
        dk = float(np.max(np.abs(K1 - K2)) / np.max(np.abs(K2)))
        ok = d_in <= 0.01 and d_cv <= 0.01
        ok_all &= ok
        parts.append(f"{r['file'].split('/')[0]}: in-sample {w['own_rms']:.5f} vs {sa['rms_mg']:.5f} mg "
                     f"({100 * d_in:.3f} %), LOWO {w['lowo']:.5f} vs {sa['cv_rms_mg']:.5f} mg ({100 * d_cv:.3f} %); "
                     f"parameters: max |Δbias| {db:.4f} counts, max |ΔK|/max|K| {dk:.1e}")
        sd = r.get("scipy_on_analyze_means")
        if sd:
            r["notes"].append(
                f"Same LOWO definition: the SciPy script on `wiical analyze`'s own f64 window means gives "
                f"{sd['cv_rms_mg']:.5f} mg, analyze {w['lowo']:.5f} mg; on `wiical fit`'s f32 means "
                f"{sa['cv_rms_mg']:.5f} mg.")
        r["notes"].append(f"wiical's own rms_mg {r['wiical_self_rms']:.6f} mg; the shared f64 function on its "
                          f"parameters {r['wiical_shared_rms']:.6f} mg.")
    goals.append(dict(holds=ok_all, text="wiical (f32) matches the f64 SciPy reference's error within 1 % "
                      "(in-sample RMS and LOWO, same windows): " + "; ".join(parts) + "."))
    ratios = []
    for r in acc + mag:
        for t in r["timing"]:
            if "ratio" in t:
                ratios.append((t["ratio"], f"{r['file'].split('/')[-1]}: {t['label']} {t['ratio']:.1f}×"))
    ok = bool(ratios) and all(x >= 20 for x, _ in ratios)
    low = [s for x, s in ratios if x < 20]
    txt = "wiical is ≥ 20× faster than the Python peers end to end"
    if ratios:
        txt += f": ratios {min(ratios)[0]:.1f}× … {max(ratios)[0]:.1f}×"
    if low:
        txt += "; below 20×: " + "; ".join(low)
    goals.append(dict(holds=ok, text=txt + "."))
    return goals


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--wiical", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--root", required=True)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--out", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--failures", default="")
    ap.add_argument("--cmdline", default="scripts/bench-peers")
    a = ap.parse_args()
    t0 = time.perf_counter()
    data, root, work = Path(a.data), Path(a.root), Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    failures = {}
    if a.failures and Path(a.failures).exists():
        for line in Path(a.failures).read_text().splitlines():
            if "\t" in line:
                k, v = line.split("\t", 1)
                failures[k] = v
    for ds in ACC + MAG:
        if not (data / ds["file"]).exists():
            raise SystemExit(f"missing recording {data / ds['file']} (set WIICAL_DATA)")
    acc = []
    for ds in ACC:
        print(f"accelerometer: {ds['file']}", file=sys.stderr)
        acc.append(bench_acc(ds, a.wiical, data, root, work, a.runs, failures))
    mag = []
    for ds in MAG:
        print(f"magnetometer: {ds['file']}", file=sys.stderr)
        mag.append(bench_mag(ds, a.wiical, data, root, a.runs, failures))
    goals = goals_of(acc, mag)
    commit = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty"], capture_output=True,
                            text=True).stdout.strip() or "?"
    mach = machine()
    write_report(Path(a.out), mach, acc, mag, a.runs, a.cmdline, goals, time.perf_counter() - t0, commit,
                 failures)
    (work / "results.json").write_text(common.dump(dict(machine=mach, acc=acc, mag=mag, goals=goals)))
    for g in goals:
        print(("HOLDS: " if g["holds"] else "DOES NOT HOLD: ") + g["text"], file=sys.stderr)
    print(f"wrote {a.out} and {work / 'results.json'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
