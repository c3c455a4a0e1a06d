//! The gyro's g-sensitivity from its rests, as the Ferraris method fits it (Ferraris et al.
//! 1995, eq. 9; imucal's `K_ga`).
//!
//! At rest a gyro reads its bias plus a bias proportional to the specific force on it:
//! `m = b + H·a` (`m` raw, `a` the accelerometer's calibrated reading in g, `H` raw per g). A
//! Ferraris session rests on all six faces, so `a` takes six (or more) directions and each
//! gyro axis's `[b_r, H_r·]` is a least-squares line through the rests' means: four unknowns
//! per axis, one equation per rest. imucal takes `H`'s columns from each face pair's
//! half-difference and `b` from the mean of the six faces; with one rest per face that is
//! the same least squares, and repeats and the rests between turns add equations here.
//!
//! The correction's `G` (rad/s per g, [`wiical_core::gyro_correct`]) is `K·H`: the forward
//! model `K·(m − b) = ω + G·a`. Standard errors from the rests' scatter about the line
//! (`rss/dof`), never below what the rests' own sample noise allows (`var/n`, averaged), so a
//! lucky small scatter does not overstate the precision.

use nalgebra::{Matrix4, Vector4};
use serde::Serialize;

/// One rest of the gyro.
#[derive(Debug, Clone, Copy)]
pub struct GyroRest {
    /// The gyro's mean over the rest, raw.
    pub mean: [f64; 3],
    /// Per-axis variance of the rest's samples, raw² (the mean's noise is `var/samples`).
    pub var: [f64; 3],
    /// Independent samples averaged.
    pub samples: usize,
    /// The accelerometer's calibrated reading over the rest, g.
    pub specific_force_g: [f64; 3],
}

/// The g-sensitivity and the bias at zero specific force.
#[derive(Debug, Clone, Serialize)]
pub struct GSensitivityFit {
    /// `b`, raw: the gyro's reading at zero rate and zero specific force.
    pub bias: [f64; 3],
    /// Standard error of `b`, raw.
    pub bias_std_error: [f64; 3],
    /// `H`, raw per g: row = gyro axis, column = specific-force component.
    pub raw_per_g: [[f64; 3]; 3],
    /// Standard error of each element of `H`, raw per g.
    pub raw_per_g_std_error: [[f64; 3]; 3],
    /// `G = K·H`, °/s per g (the cal file holds it in rad/s per g); `None` before `K` is known.
    pub dps_per_g: Option<[[f64; 3]; 3]>,
    /// Standard error of `G`'s elements, °/s per g (`K` taken as exact: its own error moves
    /// `G` by `G` times a scale error, a per-mille of an already small number).
    pub dps_per_g_std_error: Option<[[f64; 3]; 3]>,
    /// Rests in the fit.
    pub rests: usize,
    /// Degrees of freedom of the scatter (rests − 4).
    pub dof: usize,
}

/// Why the rests give no g-sensitivity.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GSensitivityError {
    /// Fewer than five rests: four unknowns per axis and nothing left to judge them.
    #[error(
        "{rests} rest(s): the g-sensitivity needs at least 5 (four unknowns per gyro axis and \
         one to judge them): rest on each of the six faces"
    )]
    TooFewRests {
        /// Rests found.
        rests: usize,
    },
    /// The rests' specific forces do not span three directions.
    #[error(
        "the rests' gravity directions do not span three axes (smallest spread {spread:.3} g²): \
         the g-sensitivity of some direction cannot be told from the bias; rest on each of the \
         six faces"
    )]
    Degenerate {
        /// Smallest eigenvalue of the specific forces' scatter about their mean, g² per rest.
        spread: f64,
    },
}

/// Least smallest eigenvalue of the rests' specific-force scatter (g² per rest) for a fit: six
/// faces give 1/3; rests all within ~15° of one plane give under 0.02.
const MIN_SPREAD: f64 = 0.02;

/// Fits `m = b + H·a` to the rests.
pub fn fit_g_sensitivity(rests: &[GyroRest]) -> Result<GSensitivityFit, GSensitivityError> {
    let n = rests.len();
    if n < 5 {
        return Err(GSensitivityError::TooFewRests { rests: n });
    }
    let spread = smallest_spread(rests);
    if spread.is_nan() || spread < MIN_SPREAD {
        return Err(GSensitivityError::Degenerate { spread });
    }
    let row = |r: &GyroRest| {
        let a = r.specific_force_g;
        Vector4::new(1.0, a[0], a[1], a[2])
    };
    let xtx: Matrix4<f64> = rests.iter().map(|r| row(r) * row(r).transpose()).sum();
    let inv = xtx
        .try_inverse()
        .ok_or(GSensitivityError::Degenerate { spread })?;
    let dof = n - 4;
    let mut bias = [0.0; 3];
    let mut bias_se = [0.0; 3];
    let mut h = [[0.0; 3]; 3];
    let mut h_se = [[0.0; 3]; 3];
    for axis in 0..3 {
        let xty: Vector4<f64> = rests.iter().map(|r| row(r) * r.mean[axis]).sum();
        let beta = inv * xty;
        let rss: f64 = rests
            .iter()
            .map(|r| (r.mean[axis] - row(r).dot(&beta)).powi(2))
            .sum();
        // The rests' own noise: the mean variance of a rest's mean.
        let own = rests
            .iter()
            .map(|r| r.var[axis] / r.samples.max(1) as f64)
            .sum::<f64>()
            / n as f64;
        let s2 = (rss / dof as f64).max(own);
        bias[axis] = beta[0];
        bias_se[axis] = (s2 * inv[(0, 0)]).sqrt();
        for c in 0..3 {
            h[axis][c] = beta[c + 1];
            h_se[axis][c] = (s2 * inv[(c + 1, c + 1)]).sqrt();
        }
    }
    Ok(GSensitivityFit {
        bias,
        bias_std_error: bias_se,
        raw_per_g: h,
        raw_per_g_std_error: h_se,
        dps_per_g: None,
        dps_per_g_std_error: None,
        rests: n,
        dof,
    })
}

/// The smallest eigenvalue of the rests' specific forces' scatter about their mean, g² per
/// rest: how well the rests' directions span three axes.
fn smallest_spread(rests: &[GyroRest]) -> f64 {
    let n = rests.len() as f64;
    let mean: [f64; 3] =
        std::array::from_fn(|a| rests.iter().map(|r| r.specific_force_g[a]).sum::<f64>() / n);
    let scatter = nalgebra::Matrix3::from_fn(|i, j| {
        rests
            .iter()
            .map(|r| (r.specific_force_g[i] - mean[i]) * (r.specific_force_g[j] - mean[j]))
            .sum::<f64>()
            / n
    });
    scatter.symmetric_eigenvalues().min()
}

impl GSensitivityFit {
    /// Fills `G = K·H` in °/s per g (and its standard errors) from `K`, rad/s per raw unit.
    pub fn with_matrix(mut self, k: &[[f64; 3]; 3]) -> Self {
        let dps = |x: f64| x.to_degrees();
        let g = std::array::from_fn(|r| {
            std::array::from_fn(|c| dps((0..3).map(|j| k[r][j] * self.raw_per_g[j][c]).sum()))
        });
        let se = std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                dps((0..3)
                    .map(|j| (k[r][j] * self.raw_per_g_std_error[j][c]).powi(2))
                    .sum::<f64>()
                    .sqrt())
            })
        });
        self.dps_per_g = Some(g);
        self.dps_per_g_std_error = Some(se);
        self
    }

    /// `G` in rad/s per g, the gyro calibration file's unit (zero before `K` is known).
    pub fn rad_per_s_per_g(&self) -> [[f64; 3]; 3] {
        self.dps_per_g
            .map_or([[0.0; 3]; 3], |g| g.map(|row| row.map(f64::to_radians)))
    }

    /// The largest `|G|` element and its ratio to its standard error, for the note.
    pub fn largest(&self) -> Option<(f64, f64)> {
        let (g, se) = (self.dps_per_g?, self.dps_per_g_std_error?);
        (0..9)
            .map(|i| (g[i / 3][i % 3], se[i / 3][i % 3]))
            .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::*;

    fn rest(a: [f64; 3], b: [f64; 3], h: [[f64; 3]; 3], wobble: f64) -> GyroRest {
        GyroRest {
            mean: std::array::from_fn(|r| {
                b[r] + (0..3).map(|c| h[r][c] * a[c]).sum::<f64>() + wobble
            }),
            var: [1.0; 3],
            samples: 1_000_000,
            specific_force_g: a,
        }
    }

    /// Six faces and a repeat, exact data: `b` and `H` found; with no scatter the standard
    /// errors are the rests' own noise floor (`var/n` = 1e-6 raw²), not zero. One face plane
    /// alone, and four rests, are refused.
    #[test]
    fn six_faces_give_the_bias_and_the_g_sensitivity() {
        let b = [3.0, -2.0, 0.5];
        let h = [[0.2, -0.1, 0.05], [0.0, 0.3, -0.2], [0.1, 0.1, -0.4]];
        let faces = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
        ];
        let rests: Vec<GyroRest> = faces.iter().map(|a| rest(*a, b, h, 0.0)).collect();
        let fit = fit_g_sensitivity(&rests).unwrap();
        assert_eq!((fit.rests, fit.dof), (7, 3));
        for r in 0..3 {
            assert!((fit.bias[r] - b[r]).abs() < 1e-9);
            assert!(fit.bias_std_error[r] > 1e-4 && fit.bias_std_error[r] < 1e-3);
            for c in 0..3 {
                assert!((fit.raw_per_g[r][c] - h[r][c]).abs() < 1e-9, "{r}{c}");
                // A ± pair's half-difference of means with SE 1e-3: ≈ 0.7e-3.
                let se = fit.raw_per_g_std_error[r][c];
                assert!(se > 3e-4 && se < 1e-3, "{r}{c}: {se}");
            }
        }
        // K = 2·I: G = 2·H, in °/s per g when K is in rad/s per raw.
        let k = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]];
        let g = fit.with_matrix(&k);
        let want = (2.0 * g.raw_per_g[1][2]).to_degrees();
        assert!((g.dps_per_g.unwrap()[1][2] - want).abs() < 1e-12);
        assert!((g.rad_per_s_per_g()[1][2] - 2.0 * g.raw_per_g[1][2]).abs() < 1e-12);
        let flat: Vec<GyroRest> = [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
            .iter()
            .cycle()
            .take(6)
            .map(|a| rest(*a, b, h, 0.0))
            .collect();
        assert!(matches!(
            fit_g_sensitivity(&flat),
            Err(GSensitivityError::Degenerate { .. })
        ));
        assert_eq!(
            fit_g_sensitivity(&rests[..4]).unwrap_err(),
            GSensitivityError::TooFewRests { rests: 4 }
        );
    }
}
