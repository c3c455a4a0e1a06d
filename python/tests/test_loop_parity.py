"""`wiical.gyrofit` and `wiical.magfit` return the residual loop as the command line's --json
does: the keys of the verdict, the candidates with their detection limits, the noise floors,
the motions' loop and the open bases, with every value equal to the CLI's (one contract, from
the same Rust types). Real recordings from $WIICAL_DATA (default ../shared/data); the CLI is
$WIICAL_BIN, else target/debug/wiical or target/release/wiical."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess

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


def data(*parts: str) -> str:
    p = DATA.joinpath(*parts)
    if not p.exists():
        pytest.fail(f"{p} is missing: set WIICAL_DATA to the shared data folder")
    return str(p)


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
