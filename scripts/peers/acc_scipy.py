#!/usr/bin/env python3
"""Peer 1: f64 SciPy reference of wiical's 9-parameter multi-position accelerometer fit.

Two ways to get the static-window means:

* ``--means-json FIT.json``: the ``windows[].mean`` of ``wiical fit --json`` (both tools then
  solve exactly the same least-squares problem: this is the accuracy reference);
* ``--detect RECORDING``: load the recording and detect static windows in Python
  (``common.detect_static``), i.e. the whole job ``wiical fit`` does, end to end.

Prints one JSON object: bias (counts), matrix K (raw → g), per-window residuals, in-sample RMS
(mg), optionally the leave-one-window-out RMS (mg), and the in-process times (s) of loading,
detection, the fit and the LOWO refits.
"""
import argparse
import json
import sys
import time

T0 = time.perf_counter()
import numpy as np  # noqa: E402

import common  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--means-json")
    g.add_argument("--detect")
    ap.add_argument("--init-s", type=float, default=2.0)
    ap.add_argument("--window-s", type=float, default=1.0)
    ap.add_argument("--threshold", type=float, default=6.0)
    ap.add_argument("--min-static-s", type=float, default=2.0)
    ap.add_argument("--lowo", action="store_true")
    a = ap.parse_args()
    import scipy.optimize  # noqa: F401  (imported here so the import is in the end-to-end time)

    out = {"import_s": time.perf_counter() - T0}
    t = time.perf_counter()
    if a.means_json:
        with open(a.means_json, encoding="utf-8") as f:
            means = np.array([w["mean"] for w in json.load(f)["windows"]], dtype=np.float64)
        out["load_s"] = time.perf_counter() - t
        out["source"] = "wiical fit windows"
    else:
        tt, xyz, meta = common.load_recording(a.detect)
        fs = common.sample_rate(tt, meta)
        out["load_s"] = time.perf_counter() - t
        t = time.perf_counter()
        runs = common.detect_static(xyz, fs, a.window_s, a.init_s, a.threshold, a.min_static_s)
        means = np.array([xyz[s:e].mean(axis=0) for s, e in runs])
        out["detect_s"] = time.perf_counter() - t
        ts = common.times_of(tt, len(xyz), fs)
        out["windows"] = [
            {"t_start": float(ts[s]), "t_end": float(ts[e - 1]), "samples": e - s} for s, e in runs
        ]
        out["source"] = "python detector"
    if len(means) < 9:
        print(json.dumps({"error": f"{len(means)} static windows: fewer than 9 parameters"}))
        return 1
    t = time.perf_counter()
    bias, K, _ = common.scipy_fit(means)
    out["solve_s"] = time.perf_counter() - t
    r = common.acc_residuals(bias, K, means)
    out.update(
        static_windows=len(means),
        means=means,
        bias=bias,
        matrix=K,
        residual_mg=r * 1e3,
        rms_mg=common.rms(r) * 1e3,
    )
    if a.lowo:
        t = time.perf_counter()
        lo = common.scipy_lowo(means)
        out["lowo_s"] = time.perf_counter() - t
        out["cv_residual_mg"] = lo * 1e3
        out["cv_rms_mg"] = common.rms(lo) * 1e3
    print(common.dump(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
