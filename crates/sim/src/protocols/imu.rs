//! The simulated IMU: an accelerometer and a gyroscope, each a linear three-axis sensor with
//! its own scale errors, axis misalignment (relative to the fixture) and bias, read as raw
//! counts with white noise; the gyro also feels the specific force (g-sensitivity).
//!
//! Conventions (the same as the rest of the simulator): for the accelerometer
//! `m = D·a + b` (`a` in g, fixture frame; `m`, `b` in counts; `K = D⁻¹`), as in
//! [`crate::Truth`]; for the gyro `m = K⁻¹·(ω + G·a) + b` (`ω` in rad/s, fixture
//! frame; `G` rad/s per g; `K` raw → rad/s), as in [`crate::gyro::GyroTruth`], so
//! that `ω = K·(m − b) − G·a` (`wiical_core::gyro_correct`'s correction).

use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::geometry::random_unit;

/// One three-axis sensor's linear truth, `m = D·x + b`.
#[derive(Debug, Clone, Serialize)]
pub struct AxesTruth {
    /// The physical unit of `x`: `g` (accelerometer) or `rad/s` (gyro).
    pub unit: &'static str,
    /// The nominal sensitivity, counts per unit (16 384 counts/g; 16.4 counts per °/s is
    /// 939.6 counts per rad/s).
    pub nominal_counts_per_unit: f64,
    /// `D`, counts per unit, row = sensor axis, column = fixture axis: each row is the sensor
    /// axis' direction in the fixture frame times its sensitivity.
    pub forward_matrix: [[f64; 3]; 3],
    /// `K = D⁻¹`, unit per count: the calibration `x = K·(m − b)` in the fixture's frame
    /// (what a six-position, Ferraris or rate-table method can measure).
    pub matrix: [[f64; 3]; 3],
    /// `b`, counts.
    pub bias: [f64; 3],
    /// `D = U·Q` with `U` upper triangular (positive diagonal) and `Q` a rotation: `U`, the
    /// forward matrix in a frame of the sensor's own (z along the sensor's z axis, the
    /// sensor's y axis in the y–z plane), the convention of the free-pose fit, which cannot
    /// see the fixture.
    pub forward_matrix_triangular: [[f64; 3]; 3],
    /// `U⁻¹`, unit per count.
    pub matrix_triangular: [[f64; 3]; 3],
    /// Each axis' sensitivity relative to the nominal, minus one (`|row i of D|/nominal − 1`).
    pub scale_error: [f64; 3],
    /// Each sensor axis' angle from the fixture's axis of the same name, degrees.
    pub misalignment_deg: [f64; 3],
    /// Per-sample white-noise standard deviation, counts (before rounding to whole counts).
    pub noise_std_counts: f64,
}

impl AxesTruth {
    /// The noiseless reading of `x` (unit of the sensor, fixture frame), counts: `D·x + b`.
    pub fn reading(&self, x: [f64; 3]) -> [f64; 3] {
        let d = rows(&self.forward_matrix);
        (d * Vector3::from(x) + Vector3::from(self.bias)).into()
    }

    /// The calibrated value of reading `m` (counts): `K·(m − b)`.
    pub fn correct(&self, m: [f64; 3]) -> [f64; 3] {
        let k = rows(&self.matrix);
        (k * (Vector3::from(m) - Vector3::from(self.bias))).into()
    }
}

/// How one sensor is drawn.
pub(super) struct AxesDraw {
    pub(super) unit: &'static str,
    pub(super) counts_per_unit: f64,
    /// Range of `|scale error|` (fraction), each axis' sign drawn.
    pub(super) scale: (f64, f64),
    /// Range of each axis' misalignment, degrees.
    pub(super) misalign_deg: (f64, f64),
    /// Range of `|bias|`, counts, each axis' sign drawn.
    pub(super) bias: (f64, f64),
    pub(super) noise_counts: f64,
}

/// A matrix from rows.
pub(super) fn rows(m: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| m[r][c])
}

/// Rows of a matrix (a zero written `0.0`, never `-0.0`).
pub(super) fn to_rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)] + 0.0))
}

/// A value drawn uniformly in `range` (its lower end when the range is empty).
pub(super) fn uniform(rng: &mut ChaCha8Rng, range: (f64, f64)) -> f64 {
    if range.1 > range.0 {
        rng.random_range(range.0..range.1)
    } else {
        range.0
    }
}

/// A value drawn uniformly in `range` with a random sign.
fn signed(rng: &mut ChaCha8Rng, range: (f64, f64)) -> f64 {
    let v = uniform(rng, range);
    if rng.random_bool(0.5) {
        v
    } else {
        -v
    }
}

/// The upper-triangular `U` (positive diagonal) with `U·Uᵀ = D·Dᵀ`, so that `D = U·Q` with
/// `Q = U⁻¹·D` orthogonal: Cholesky of the index-reversed Gram matrix, reversed back.
pub(super) fn triangular(d: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let p = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let l = (p * d * d.transpose() * p).cholesky()?.l();
    Some(p * l * p)
}

/// Draws one sensor.
pub(super) fn draw_axes(rng: &mut ChaCha8Rng, w: &AxesDraw) -> AxesTruth {
    let mut d = Matrix3::zeros();
    let mut scale_error = [0.0; 3];
    let mut misalignment_deg = [0.0; 3];
    for i in 0..3 {
        let e = Vector3::ith(i, 1.0);
        // A direction perpendicular to the axis, uniform in angle.
        let r = Vector3::from(random_unit(rng));
        let p = (r - e * r.dot(&e))
            .try_normalize(1e-9)
            .unwrap_or(Vector3::ith((i + 1) % 3, 1.0));
        let ang = uniform(rng, w.misalign_deg).to_radians();
        let axis = e * ang.cos() + p * ang.sin();
        scale_error[i] = signed(rng, w.scale);
        misalignment_deg[i] = ang.to_degrees();
        d.set_row(
            i,
            &(axis * w.counts_per_unit * (1.0 + scale_error[i])).transpose(),
        );
    }
    let bias = std::array::from_fn(|_| signed(rng, w.bias));
    // D is within a few % of a multiple of the identity: invertible, Gram positive definite.
    let k = d.try_inverse().unwrap_or_else(Matrix3::identity);
    let u = triangular(&d).unwrap_or(d);
    let u_inv = u.try_inverse().unwrap_or_else(Matrix3::identity);
    AxesTruth {
        unit: w.unit,
        nominal_counts_per_unit: w.counts_per_unit,
        forward_matrix: to_rows(&d),
        matrix: to_rows(&k),
        bias,
        forward_matrix_triangular: to_rows(&u),
        matrix_triangular: to_rows(&u_inv),
        scale_error,
        misalignment_deg,
        noise_std_counts: w.noise_counts,
    }
}

/// A g-sensitivity matrix, rad/s per g, each element uniform in `±max_dps_per_g` (°/s per g).
pub(super) fn draw_g_sensitivity(rng: &mut ChaCha8Rng, max_dps_per_g: f64) -> [[f64; 3]; 3] {
    if max_dps_per_g <= 0.0 {
        return [[0.0; 3]; 3];
    }
    std::array::from_fn(|_| {
        std::array::from_fn(|_| rng.random_range(-max_dps_per_g..max_dps_per_g).to_radians())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn drawn_sensor_has_what_was_asked_and_its_triangular_form() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let w = AxesDraw {
            unit: "g",
            counts_per_unit: 16384.0,
            scale: (0.01, 0.03),
            misalign_deg: (0.5, 1.0),
            bias: (20.0, 300.0),
            noise_counts: 20.0,
        };
        let t = draw_axes(&mut rng, &w);
        let d = rows(&t.forward_matrix);
        for i in 0..3 {
            let row = d.row(i).transpose();
            let s = row.norm() / 16384.0 - 1.0;
            assert!((s - t.scale_error[i]).abs() < 1e-12);
            assert!((0.01..0.03).contains(&s.abs()));
            let ang = (row[i] / row.norm()).acos().to_degrees();
            assert!((ang - t.misalignment_deg[i]).abs() < 1e-9 && (0.5..1.0).contains(&ang));
            assert!((20.0..300.0).contains(&t.bias[i].abs()));
        }
        let u = rows(&t.forward_matrix_triangular);
        assert!(u[(1, 0)] == 0.0 && u[(2, 0)] == 0.0 && u[(2, 1)] == 0.0);
        let q = u.try_inverse().unwrap() * d;
        assert!((q * q.transpose() - Matrix3::identity()).abs().max() < 1e-12);
        assert!(q.determinant() > 0.0);
        let x = [0.3, -0.5, 0.8];
        let back = t.correct(t.reading(x));
        assert!((0..3).all(|j| (back[j] - x[j]).abs() < 1e-12));
    }
}
