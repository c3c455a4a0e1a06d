#!/usr/bin/env python3
"""Peer 3: magcal (PyPI, lundeen06/magcal) on a recording file, through its library API.

magcal's own ``magcal from-file`` command reads its JSON capture format and sleeps 1.5 s for
"visual feedback", so the benchmark drives ``MagnetometerCalibrator`` directly: load the CSV
with numpy (as a user would), set ``raw_data``, call ``calibrate(method)``. Its stdout chatter
is sent to stderr so this script prints one JSON object.

magcal's model (magcal/core.py): ``calibrated = transform_matrix · (m − center)``.
* ``ellipsoid``: ``center`` = the plain mean of the samples (not fitted), then a 6-term
  quadratic form fitted to ``(m − center)ᵀA(m − center) = 1``; ``transform = A^½``, so the
  calibrated field has radius 1 → ``(c, W, R) = (center, transform, 1)``.
* ``sphere``: the mean, nudged by 10 passes of a per-sample gradient step; ``transform = I``,
  ``radius`` = mean distance → ``(center, I, radius)``.
``calibrate()`` refuses fewer than 500 samples; ``--force`` then calls the fit function itself
(``ellipsoid_fit`` / ``sphere_fit``), bypassing that check, and says so in the output.

``solve_s`` times the fit function alone (``sphere_fit``/``ellipsoid_fit``, the most favourable
reading for magcal); ``calibrate_s`` times ``calibrate()``, which also evaluates its quality
metric sample by sample.
"""
import argparse
import contextlib
import sys
import time

T0 = time.perf_counter()
import numpy as np  # noqa: E402
from magcal.core import MagnetometerCalibrator  # noqa: E402

import common  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("recording")
    ap.add_argument("--method", choices=["sphere", "ellipsoid"], default="ellipsoid")
    ap.add_argument("--force", action="store_true", help="bypass calibrate()'s 500-sample minimum")
    a = ap.parse_args()
    out = {"import_s": time.perf_counter() - T0, "method": a.method}
    t = time.perf_counter()
    _, xyz, _ = common.load_recording(a.recording)
    out["load_s"] = time.perf_counter() - t
    out["samples"] = len(xyz)
    cal = MagnetometerCalibrator()
    cal.raw_data = xyz.tolist()
    fit_fn = cal.sphere_fit if a.method == "sphere" else cal.ellipsoid_fit
    with contextlib.redirect_stdout(sys.stderr):
        t = time.perf_counter()
        params = fit_fn(np.array(cal.raw_data))
        out["solve_s"] = time.perf_counter() - t
        try:
            t = time.perf_counter()
            params = cal.calibrate(method=a.method)
            out["calibrate_s"] = time.perf_counter() - t
            out["refused"] = None
        except Exception as e:  # magcal raises a bare Exception for < 500 samples
            out["refused"] = str(e)
    if out["refused"] and not a.force:
        print(common.dump(out))
        return 0
    center = np.asarray(params["center"], dtype=np.float64)
    W = np.asarray(params["transform_matrix"], dtype=np.float64)
    R = float(params["radius"]) if a.method == "sphere" else 1.0
    out.update(center=center, matrix=W, radius=R)
    print(common.dump(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
