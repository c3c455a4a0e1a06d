//! The chosen calibration as a device or a host applies it
//! ([`wiical_core::gyro_correct::GyroCorrection`], `ω = K·(m − b) − G·a`): `K` and `b` of the
//! motion fit and, when the window search accepted `g-sensitivity`, its `G` (°/s/g in the
//! report, rad/s/g here) with the final window model's constant folded into the bias, so that
//! a still sensor reads zero in every pose. Accepted effects the gyro's table of terms does
//! not hold (bias drift, temperature) are left out; `gyrofit --out` names them.

use super::effects::Search;
use nalgebra::{Matrix3, Vector3};
use wiical_core::gyro_correct::GyroCorrection;

/// The report name of the g-sensitivity candidate.
pub const G_SENSITIVITY: &str = "g-sensitivity";

/// The device correction of the chosen calibration (`bias` raw counts, `matrix` raw → rad/s)
/// with what the window search accepted of the gyro's effect terms.
pub fn correction(bias: [f64; 3], matrix: [[f64; 3]; 3], search: &Search) -> GyroCorrection<f64> {
    let mut out = GyroCorrection {
        bias,
        matrix,
        effects: Default::default(),
    };
    let Some(g) = search.effects.iter().find(|e| e.name == G_SENSITIVITY) else {
        return out;
    };
    let k = Matrix3::from_fn(|r, c| matrix[r][c]);
    let Some(k_inv) = k.try_inverse().filter(|_| g.values.len() == 9) else {
        return out;
    };
    // The windows read `c + G·a` through K (°/s): ω = K(m − b) − c − G·a = K(m − b') − G·a
    // with b' = b + K⁻¹·c.
    let c = Vector3::from(search.intercept_dps.map(f64::to_radians));
    out.bias = (Vector3::from(bias) + k_inv * c).into();
    out.effects.g_sensitivity =
        std::array::from_fn(|r| std::array::from_fn(|j| g.values[3 * r + j].to_radians()));
    out
}
