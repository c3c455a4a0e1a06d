"""`wiical magfit`'s fit error beside an independent ellipsoid fit on every real magnetometer
recording that fits (docs/magnetometer.md's peer column).

No magnetometer-calibration peer installs from PyPI (MotionCal is a desktop program, MATLAB's
`magcal` is not free), so the peer is written here with numpy: the general quadric
`xᵀAx + 2bᵀx = 1` by linear least squares (the algebraic fit MotionCal and `magcal` start from),
then the centre `c = −A⁻¹b` and the shape `M = A/(1 + cᵀAc)`, so that `(m − c)ᵀM(m − c) = 1` on
the ellipsoid. With `W = M^½` scaled to det 1 and `R` the matching radius, magcal's fit error
`100·√mean((‖W(m − c)‖² − R²)²)/(2R²)` is `50·RMS((m − c)ᵀM(m − c) − 1)`.

Run: `pytest python/tests/test_magfit_peer.py -s` (prints the table) with the CLI built."""

from __future__ import annotations

import pathlib
import sys

import numpy as np
import pytest

import wiical

# The CLI helpers of the parity tests (a sibling module: under pytest's importlib mode the
# tests directory is not on the path by itself).
sys.path.insert(0, str(pathlib.Path(__file__).parent))
from test_cli_parity import cli_json, data  # noqa: E402

# (folder, file, extra CLI arguments / read columns)
FILES = [
    ("qmc5883l_mag_tomisuarez", "noisy_raw_data.csv", None),
    ("qmc5883l_mag_tomisuarez", "filtered_raw_data.csv", None),
    ("mag_ellipsoid_fit_python", "mag_out.txt", None),
    ("acc_mag_ck_explorer", "acc_mag_log.csv", "mx,my,mz"),
    ("mpu6050_hmc5883l_sunsided_set2", "full-sphere_hmc5883l.csv", None),
    ("mpu6050_hmc5883l_sunsided_set2", "roll-and-tilt-at-45-90_hmc5883l.csv", None),
]


def quadric_fit_error(m: np.ndarray) -> float:
    """magcal's fit error (%) of the algebraic ellipsoid fit of the points `m` (n × 3)."""
    shift = m.mean(axis=0)
    scale = np.abs(m - shift).max()
    x = (m - shift) / scale  # conditioning only: the error is invariant to it
    d = np.column_stack(
        [
            x[:, 0] ** 2,
            x[:, 1] ** 2,
            x[:, 2] ** 2,
            2 * x[:, 1] * x[:, 2],
            2 * x[:, 0] * x[:, 2],
            2 * x[:, 0] * x[:, 1],
            2 * x[:, 0],
            2 * x[:, 1],
            2 * x[:, 2],
        ]
    )
    p, *_ = np.linalg.lstsq(d, np.ones(len(x)), rcond=None)
    a = np.array([[p[0], p[5], p[4]], [p[5], p[1], p[3]], [p[4], p[3], p[2]]])
    b = p[6:9]
    c = -np.linalg.solve(a, b)
    shape = a / (1.0 + c @ a @ c)
    q = np.einsum("ij,jk,ik->i", x - c, shape, x - c)
    return 50.0 * float(np.sqrt(np.mean((q - 1.0) ** 2)))


@pytest.mark.parametrize("folder,name,columns", FILES)
def test_fit_error_beside_an_independent_ellipsoid_fit(folder, name, columns):
    path = data(folder, name)
    rec = wiical.read(path, columns=columns.split(",")) if columns else wiical.read(path)
    peer = quadric_fit_error(np.asarray(rec.xyz, dtype=float))
    args = ["magfit", path] + (["--columns", columns] if columns else [])
    ours = cli_json(*args)["fit_error_pct"]
    print(f"| {folder}/{name} | {ours:.3f} | {peer:.3f} |")
    # Both minimise nearly the same algebraic residual: the errors agree to a few per cent
    # (wiical's is the core's f32 streaming fit).
    assert abs(ours - peer) <= 0.05 * peer, (ours, peer)
