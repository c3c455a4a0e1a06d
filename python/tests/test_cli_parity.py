"""Every function of the Python package against the command line's --json on the real
recordings in $WIICAL_DATA (default ../shared/data): the same dictionary, key for key and
value for value (one contract, from the same Rust types), and the same sentence on errors.

The CLI binary is $WIICAL_BIN, else target/debug/wiical or target/release/wiical of the
repository (scripts/test builds it before running pytest)."""

from __future__ import annotations

import csv
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import wiical

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("WIICAL_DATA", ROOT.parent / "shared" / "data"))


def _cli() -> str:
    env = os.environ.get("WIICAL_BIN")
    if env:
        return env
    for profile in ("debug", "release"):
        p = ROOT / "target" / profile / "wiical"
        if p.exists():
            return str(p)
    pytest.fail("no wiical binary: build it (cargo build -p wiical) or set WIICAL_BIN")


def cli_json(*args: str) -> dict:
    out = subprocess.run([_cli(), *args, "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def cli_error(*args: str) -> str:
    out = subprocess.run([_cli(), *args], capture_output=True, text=True)
    assert out.returncode != 0
    return out.stderr.strip()


def data(*parts: str) -> str:
    p = DATA.joinpath(*parts)
    if not p.exists():
        pytest.fail(f"{p} is missing: set WIICAL_DATA to the shared data folder")
    return str(p)


ACCEL_FILES = [
    ("imu_tk_xsens", "xsens_acc.mat"),
    ("mpu9150_mikoff_5units", "imu0.csv"),
    ("mpu9150_mikoff_5units", "imu3.csv"),
    ("mpu6050_multipos_tomisuarez", "example_data_calibration.csv"),
    ("acc_mag_ck_explorer", "acc_log.csv"),
    ("mpu6050_hmc5883l_sunsided_set2", "full-sphere_mpu6050.csv"),
    ("ggir_wrist_sphere_temp", "spheredata.csv"),
    ("seed_six_position", "wiimote_M.csv"),
]


@pytest.mark.parametrize("folder,name", ACCEL_FILES)
def test_fit_equals_cli(folder: str, name: str) -> None:
    path = data(folder, name)
    if name == "wiimote_M.csv":
        # A pose table: fit refuses it and says what to use; so must the package.
        with pytest.raises(wiical.WiicalError) as e:
            wiical.fit(path)
        assert str(e.value) in cli_error("fit", path)
        return
    assert wiical.fit(path) == cli_json("fit", path)


@pytest.mark.parametrize("folder,name", ACCEL_FILES)
def test_analyze_equals_cli(folder: str, name: str) -> None:
    path = data(folder, name)
    assert wiical.analyze(path) == cli_json("analyze", path)


def test_fit_of_arrays_equals_fit_of_the_file() -> None:
    path = data("imu_tk_xsens", "xsens_acc.mat")
    rec = wiical.read(path)
    assert rec.xyz.shape == (51175, 3)
    assert rec.columns == ["x", "y", "z"]
    from_arrays = wiical.fit(rec.xyz, t=rec.t)
    assert from_arrays == cli_json("fit", path)


def test_fit_options_follow_the_flags() -> None:
    path = data("imu_tk_xsens", "xsens_acc.mat")
    got = wiical.fit(path, model="diagonal", window_s=1.0, init_s=2.0)
    assert got == cli_json("fit", path, "--model", "diagonal", "--window-s", "1", "--init-s", "2")


@pytest.mark.parametrize(
    "folder,name,model",
    [
        ("mag_ellipsoid_fit_python", "mag_out.txt", "ellipsoid"),
        ("mag_ellipsoid_fit_python", "mag_out.txt", "sphere"),
        ("qmc5883l_mag_tomisuarez", "filtered_raw_data.csv", "ellipsoid"),
        ("mpu6050_hmc5883l_sunsided_set2", "full-sphere_hmc5883l.csv", "axis"),
    ],
)
def test_magfit_equals_cli(folder: str, name: str, model: str) -> None:
    path = data(folder, name)
    got = wiical.magfit(path, model=model)
    cli = cli_json("magfit", path, "--model", model)
    # The fit's keys and the residual loop's (verdict, steps, ...), as the CLI gives them.
    assert got == cli


def test_gyrofit_equals_cli() -> None:
    sunsided = data("mpu6050_hmc5883l_sunsided_set2", "full-sphere_mpu6050.csv")
    assert wiical.gyrofit(sunsided) == cli_json("gyrofit", sunsided)
    acc, gyro = data("imu_tk_xsens", "xsens_acc.mat"), data("imu_tk_xsens", "xsens_gyro.mat")
    got = wiical.gyrofit(acc, gyro, scale=1.598e-4)
    assert got == cli_json("gyrofit", acc, gyro, "--scale", "1.598e-4")
    unit = data("mpu9150_mikoff_5units", "imu2.csv")
    got = wiical.gyrofit(unit, counts_per_dps=16.384)
    assert got == cli_json("gyrofit", unit, "--counts-per-dps", "16.384")


# The residual loop's keys (verdict, candidates with their detection limits, noise floors, the
# motions' loop and the open bases), checked by name as well as by equality with the CLI.
LOOP_KEYS = {"verdict", "reasons", "effects", "steps", "base", "final", "diagnostics"}


def test_gyrofit_returns_the_loop_equal_to_the_cli() -> None:
    acc, gyro = data("imu_tk_xsens", "xsens_acc.mat"), data("imu_tk_xsens", "xsens_gyro.mat")
    got = wiical.gyrofit(acc, gyro)
    cli = cli_json("gyrofit", acc, gyro)
    assert LOOP_KEYS | {"quality", "noise_floor_deg", "noise_floor_rate_dps",
                        "noise_floor_window_dps", "motion_loop", "open_basis"} <= set(got)
    # Every candidate row carries its detection limit (null when accepted).
    rows = [c for s in got["steps"] for c in s["candidates"]]
    assert rows and all("detection_limit" in c for c in rows)
    assert any(c["detection_limit"] is not None for c in rows)
    motion = got["motion_loop"]
    assert {"base", "effects", "final", "steps", "open_basis"} <= set(motion)
    assert all("detection_limit" in c for s in motion["steps"] for c in s["candidates"])
    assert got["effects"][0]["name"] == "g-sensitivity"
    assert got == cli


def test_magfit_returns_the_loop_equal_to_the_cli() -> None:
    path = data("qmc5883l_mag_tomisuarez", "filtered_raw_data.csv")
    got = wiical.magfit(path)
    cli = cli_json("magfit", path)
    assert LOOP_KEYS | {"noise_floor", "noise_floor_axes", "center", "matrix", "radius"} <= set(got)
    assert got["verdict"] in ("good", "unexplained-residual", "not-usable")
    rows = [c for s in got["steps"] for c in s["candidates"]]
    assert rows and all("detection_limit" in c for c in rows)
    assert got == cli


@pytest.mark.parametrize("estimator", ["mean", "kalman"])
def test_six_position_equals_cli(estimator: str) -> None:
    path = data("seed_six_position", "wiimote_M.csv")
    got = wiical.six_position(path, estimator=estimator)
    assert got == cli_json("six-position", path, "--estimator", estimator)


def test_decode_cal_equals_cli_on_the_real_blocks() -> None:
    path = data("wii_calibration_bytes", "calibration_blocks.csv")
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(line for line in f if not line.startswith("#"))]
    assert rows
    for r in rows:
        got = wiical.decode_cal(r["device"], r["bytes_hex"])
        args = ["decode-cal", "--device", r["device"], *r["bytes_hex"].split()]
        out = subprocess.run([_cli(), *args, "--json"], capture_output=True, text=True)
        assert json.loads(out.stdout) == got, r
        # The CLI exits 1 on a bad checksum; the package says it in the dictionary.
        assert got["checksum_ok"] == (r["checksum_ok"] == "yes") == (out.returncode == 0), r


def test_read_gives_the_loaders_columns_and_rate() -> None:
    rec = wiical.read(data("mpu6050_hmc5883l_sunsided_set2", "full-sphere_mpu6050.csv"))
    assert rec.columns == ["acc_x_g", "acc_y_g", "acc_z_g"]
    assert rec.t is not None and len(rec.t) == len(rec.xyz)
    gyro = wiical.read(
        data("mpu6050_hmc5883l_sunsided_set2", "full-sphere_mpu6050.csv"), sensor="gyroscope"
    )
    assert gyro.columns == ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"]
    assert not np.array_equal(gyro.xyz, rec.xyz)


def test_errors_are_the_engines_sentences() -> None:
    with pytest.raises(wiical.WiicalError) as e:
        wiical.analyze(data("mpu6050_hmc5883l_sunsided_set2", "roll-and-tilt-at-45-90_mpu6050.csv"))
    cli = cli_error("analyze", data("mpu6050_hmc5883l_sunsided_set2", "roll-and-tilt-at-45-90_mpu6050.csv"))
    assert "needs free poses or all six faces" in str(e.value)
    assert str(e.value).split(":")[0] in cli
    with pytest.raises(wiical.WiicalError, match="no hex bytes"):
        wiical.decode_cal("wiimote", " ")
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        wiical.fit(np.zeros((10, 2)))


def test_the_gil_is_released_during_an_analysis() -> None:
    """Two analyses in two threads finish; a third thread counts while they run (it could
    not if the GIL were held for the whole analysis)."""
    import threading
    import time

    path = data("imu_tk_xsens", "xsens_acc.mat")
    ticks = []
    done = threading.Event()

    def count() -> None:
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    counter = threading.Thread(target=count)
    counter.start()
    t0 = time.perf_counter()
    wiical.analyze(path)
    t1 = time.perf_counter()
    done.set()
    counter.join()
    during = [t for t in ticks if t0 < t < t1]
    # At 1 ms per tick the counter runs many times during an analysis of ~0.1 s or more.
    assert len(during) >= 5, (len(during), t1 - t0)
