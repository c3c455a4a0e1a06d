#!/usr/bin/env python3
"""Peer 2: imucal (PyPI, mad-lab-fau) Ferraris calibration, accelerometer part.

imucal implements Ferraris et al.'s protocol: six static holds with each axis pointing up and
down (x_p x_a y_p y_a z_p z_a) plus three 360° turns about single axes for the gyroscope, each
section annotated by the user. Our recordings are free multi-position recordings: no turns,
and the holds are wherever the hand put the sensor. What can be done honestly:

* the six holds: for each signed axis, the static window (from ``wiical fit --json``: the
  annotation imucal leaves to the user) whose mean points closest to that axis, the direction
  taken about the mid-range of the window means (no tool's bias is used). The angle between
  the chosen mean and its axis is reported: Ferraris assumes 0°.
* the three turns do not exist; imucal's ``compute`` refuses empty sections, so they are filled
  with the gyro samples of the x_p / y_p / z_p holds. The gyroscope calibration that comes out
  is meaningless and is discarded; the accelerometer part does not use the turns at all.

``grav = 1`` so that the calibrated output is in g. Prints JSON: ``bias = b_a`` (counts),
``matrix = R_a⁻¹·K_a⁻¹`` (raw → g, imucal's own correction ``a = R_a⁻¹K_a⁻¹(m − b_a)``), the
chosen windows and their angles, and the in-process times.
"""
import argparse
import json
import sys
import time
import warnings

T0 = time.perf_counter()
import numpy as np  # noqa: E402
from imucal import FerrarisCalibration  # noqa: E402
from imucal.ferraris_calibration import FerrarisSignalRegions  # noqa: E402

import common  # noqa: E402

POSES = ["x_p", "x_a", "y_p", "y_a", "z_p", "z_a"]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("recording")
    ap.add_argument("--windows-json", required=True, help="wiical fit --json output")
    ap.add_argument("--gyro", help="gyro recording with the same rows (IMU-TK keeps it apart)")
    a = ap.parse_args()
    out = {"import_s": time.perf_counter() - T0}
    t = time.perf_counter()
    tt, acc, meta = common.load_recording(a.recording)
    fs = common.sample_rate(tt, meta)
    if a.gyro:
        _, gyr, _ = common.load_recording(a.gyro)
    else:
        _, gyr, _ = common.load_recording(a.recording, columns=("gx", "gy", "gz"))
    with open(a.windows_json, encoding="utf-8") as f:
        wins = json.load(f)["windows"]
    ts = common.times_of(tt, len(acc), fs)
    ranges = []
    for w in wins:
        s = int(np.searchsorted(ts, w["t_start"] - 1e-9))
        e = int(np.searchsorted(ts, w["t_end"] + 1e-9))
        ranges.append((s, e))
    out["load_s"] = time.perf_counter() - t

    t = time.perf_counter()
    means = np.array([acc[s:e].mean(axis=0) for s, e in ranges])
    mid = (means.max(axis=0) + means.min(axis=0)) / 2
    dirs = means - mid
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    chosen, angles = {}, {}
    for k, pose in enumerate(POSES):
        axis = np.zeros(3)
        axis[k // 2] = 1.0 if pose.endswith("_p") else -1.0
        cos = dirs @ axis
        i = int(np.argmax(cos))
        chosen[pose] = i
        angles[pose] = float(np.degrees(np.arccos(np.clip(cos[i], -1, 1))))
    if len(set(chosen.values())) < 6:
        print(json.dumps({"error": "the six holds are not six distinct windows", "chosen": chosen}))
        return 1
    reg = {}
    for pose, i in chosen.items():
        s, e = ranges[i]
        reg[f"acc_{pose}"] = acc[s:e]
        reg[f"gyr_{pose}"] = gyr[s:e]
    for ax in "xyz":  # no single-axis turns in these recordings: see the module docs
        reg[f"acc_{ax}_rot"] = reg[f"acc_{ax}_p"]
        reg[f"gyr_{ax}_rot"] = reg[f"gyr_{ax}_p"]
    regions = FerrarisSignalRegions(**reg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = FerrarisCalibration(grav=1.0).compute(
            regions, sampling_rate_hz=fs, from_acc_unit="a.u.", from_gyr_unit="a.u."
        )
    out["solve_s"] = time.perf_counter() - t
    K = np.linalg.inv(cal.R_a) @ np.linalg.inv(cal.K_a)
    # Cross-check our reading of imucal's model against its own public calibrate().
    own, _ = cal.calibrate(acc=means, gyr=np.zeros_like(means), acc_unit="a.u.", gyr_unit="a.u.")
    mine = (means - cal.b_a) @ K.T
    out.update(
        bias=np.asarray(cal.b_a),
        matrix=K,
        chosen={p: {"window": i + 1, "angle_deg": angles[p]} for p, i in chosen.items()},
        used_windows=sorted(i for i in chosen.values()),
        self_check=float(np.max(np.abs(own - mine))),
    )
    print(common.dump(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
