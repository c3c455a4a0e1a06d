"""The Dask example on a local cluster of 2 worker processes: every file gives the row that
the package gives in this process (the cluster adds distribution, not different answers)."""

from __future__ import annotations

import importlib.util
import os
import pathlib

import pytest

import wiical

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("WIICAL_DATA", ROOT.parent / "shared" / "data"))


def _example():
    spec = importlib.util.spec_from_file_location(
        "dask_batch", ROOT / "python" / "examples" / "dask_batch.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_dask_example_on_a_local_cluster_of_two_workers() -> None:
    pytest.importorskip("dask.distributed", reason="scripts/setup installs dask[distributed]")
    ex = _example()
    files = [
        str(DATA / "imu_tk_xsens" / "xsens_acc.mat"),
        *(str(DATA / "mpu9150_mikoff_5units" / f"imu{i}.csv") for i in range(5)),
        str(DATA / "mpu6050_hmc5883l_sunsided_set2" / "roll-and-tilt-at-45-90_mpu6050.csv"),
    ]
    for f in files:
        assert os.path.exists(f), f"{f} missing: set WIICAL_DATA"
    rows = ex.run(files, workers=2)
    assert [r["file"] for r in rows] == files
    assert rows == [ex.summarise(f) for f in files]
    assert rows[0]["ok"] and rows[0]["windows"] == 38
    assert all(r["ok"] and r["windows"] == 22 for r in rows[1:6])
    assert not rows[6]["ok"] and "all six faces" in rows[6]["error"]
