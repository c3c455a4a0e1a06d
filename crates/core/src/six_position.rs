//! The six-position test with the constant right pseudo-inverse
//! (seed: *Calibrazione del Wiimote*, eqs. 5–7).
//!
//! The sensor is placed with each axis in turn pointing up (`+`) and down (`−`) along the
//! local vertical. With the homogeneous model
//!
//! ```text
//! M = [D | b] · [A; 1] = T̂ · Â,      A = [e_x, −e_x, e_y, −e_y, e_z, −e_z]   (3×6)
//! ```
//!
//! (columns of `M` are the six pose means, ordered `x+, x−, y+, y−, z+, z−`), the least-squares
//! solution is `T̂ = M·Â⁺` with the constant right pseudo-inverse `Â⁺ = Âᵀ(ÂÂᵀ)⁻¹` (eq. 6):
//! a 6×4 matrix of `±½` and `⅙`. So each column of `D` is half the difference of a `±` pair and
//! `b` is the mean of the six poses: no matrix inversion is needed at run time.
//!
//! The residual `M − T̂·Â` is what the linear model cannot explain. Because `Â⁺` averages each
//! `±` pair, the residual of the `+` and `−` pose of an axis are *equal*: the midpoint of the
//! pair minus the overall bias. Six poses identify 12 parameters from 18 numbers; the 6
//! remaining degrees of freedom show only whether the three pair midpoints agree (e.g. a
//! nonlinearity that is even in the input, or poses that were not exactly vertical), never an
//! odd-order effect, which is absorbed into `D`.

use crate::model::{invert3, mat3_to_rows};
use crate::{Calibration, Error, Mat3, Vec3};

/// One of the six canonical poses: which sensor axis points up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pose {
    /// +x axis up.
    XPos = 0,
    /// +x axis down.
    XNeg = 1,
    /// +y axis up.
    YPos = 2,
    /// +y axis down.
    YNeg = 3,
    /// +z axis up.
    ZPos = 4,
    /// +z axis down.
    ZNeg = 5,
}

impl Pose {
    /// All poses in the column order of the seed's `M`.
    pub const ALL: [Pose; 6] = [
        Pose::XPos,
        Pose::XNeg,
        Pose::YPos,
        Pose::YNeg,
        Pose::ZPos,
        Pose::ZNeg,
    ];

    /// Parses the labels `x+ x- y+ y- z+ z-` (case-insensitive; `−` and `_neg`/`_pos` forms too).
    pub fn from_label(s: &str) -> Option<Pose> {
        let mut buf = [0u8; 8];
        let bytes = s.trim().as_bytes();
        if bytes.is_empty() || bytes.len() > buf.len() {
            return None;
        }
        for (d, b) in buf.iter_mut().zip(bytes) {
            *d = b.to_ascii_lowercase();
        }
        match &buf[..bytes.len()] {
            b"x+" | b"+x" | b"x_pos" | b"xpos" => Some(Pose::XPos),
            b"x-" | b"-x" | b"x_neg" | b"xneg" => Some(Pose::XNeg),
            b"y+" | b"+y" | b"y_pos" | b"ypos" => Some(Pose::YPos),
            b"y-" | b"-y" | b"y_neg" | b"yneg" => Some(Pose::YNeg),
            b"z+" | b"+z" | b"z_pos" | b"zpos" => Some(Pose::ZPos),
            b"z-" | b"-z" | b"z_neg" | b"zneg" => Some(Pose::ZNeg),
            _ => None,
        }
    }

    /// The canonical label (`x+` …).
    pub fn label(self) -> &'static str {
        ["x+", "x-", "y+", "y-", "z+", "z-"][self as usize]
    }

    /// The true specific-force direction in sensor axes for this pose (column of `A`).
    pub fn direction(self) -> [f32; 3] {
        let s = if (self as usize).is_multiple_of(2) {
            1.0
        } else {
            -1.0
        };
        let mut v = [0.0; 3];
        v[self as usize / 2] = s;
        v
    }
}

/// Result of the six-position test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SixPositionFit {
    /// `T̂ = [D | b]`, 3×4, row-major (seed eq. 7).
    pub t_hat: [[f32; 4]; 3],
    /// `D = g·L·T`, the forward scale/non-orthogonality matrix (raw units per g), row-major.
    pub d: [[f32; 3]; 3],
    /// `D⁻¹`, row-major (what the seed prints under the name "D").
    pub d_inv: [[f32; 3]; 3],
    /// Bias `b`, raw units.
    pub bias: [f32; 3],
    /// Residual `M − T̂·Â`, 3×6, columns in [`Pose::ALL`] order, raw units.
    pub residual: [[f32; 6]; 3],
}

impl SixPositionFit {
    /// The calibration (`K = D⁻¹`, `b`) for correcting samples.
    pub fn calibration(&self) -> Calibration {
        Calibration {
            bias: self.bias,
            matrix: self.d_inv,
            effects: Default::default(),
        }
    }
}

/// The constant right pseudo-inverse `Â⁺` of the seed's eq. 6 (6×4, row-major).
pub const A_HAT_PINV: [[f32; 4]; 6] = [
    [0.5, 0.0, 0.0, 1.0 / 6.0],
    [-0.5, 0.0, 0.0, 1.0 / 6.0],
    [0.0, 0.5, 0.0, 1.0 / 6.0],
    [0.0, -0.5, 0.0, 1.0 / 6.0],
    [0.0, 0.0, 0.5, 1.0 / 6.0],
    [0.0, 0.0, -0.5, 1.0 / 6.0],
];

/// Solves the six-position test from the six pose means, in [`Pose::ALL`] order
/// (`x+, x−, y+, y−, z+, z−`), each `[m_x, m_y, m_z]` in raw units.
pub fn solve(means: &[[f32; 3]; 6]) -> Result<SixPositionFit, Error> {
    if !means.iter().all(|m| crate::all_finite(m)) {
        return Err(Error::NonFinite);
    }
    // T̂ = M · Â⁺ (3×6 · 6×4), written as the constant product it is.
    let mut t_hat = [[0.0f32; 4]; 3];
    for (r, row) in t_hat.iter_mut().enumerate() {
        for (c, out) in row.iter_mut().enumerate() {
            *out = (0..6).map(|k| means[k][r] * A_HAT_PINV[k][c]).sum();
        }
    }
    let d = Mat3::from_fn(|r, c| t_hat[r][c]);
    let b = Vec3::new(t_hat[0][3], t_hat[1][3], t_hat[2][3]);
    // A pose set whose ± pairs do not differ (sensor not turned) leaves D singular.
    let k = invert3(&d).map_err(|e| match e {
        Error::Singular => Error::DegenerateGeometry,
        other => other,
    })?;
    let mut residual = [[0.0f32; 6]; 3];
    for (p, pose) in Pose::ALL.iter().enumerate() {
        let a = pose.direction();
        for r in 0..3 {
            let model = t_hat[r][0] * a[0] + t_hat[r][1] * a[1] + t_hat[r][2] * a[2] + t_hat[r][3];
            residual[r][p] = means[p][r] - model;
        }
    }
    Ok(SixPositionFit {
        t_hat,
        d: mat3_to_rows(&d),
        d_inv: mat3_to_rows(&k),
        bias: [b.x, b.y, b.z],
        residual,
    })
}

/// Solves from labelled pose means in any order. Every pose must appear exactly once.
pub fn solve_labelled(poses: &[(Pose, [f32; 3])]) -> Result<SixPositionFit, Error> {
    let mut slots: [Option<[f32; 3]>; 6] = [None; 6];
    for (pose, m) in poses {
        let slot = &mut slots[*pose as usize];
        if slot.is_some() {
            return Err(Error::DuplicatePose);
        }
        *slot = Some(*m);
    }
    let mut means = [[0.0f32; 3]; 6];
    for (out, slot) in means.iter_mut().zip(slots.iter()) {
        *out = slot.ok_or(Error::MissingPose)?;
    }
    solve(&means)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::*;

    /// The seed's measurement matrix M (Kalman-filtered pose means, 8-bit counts), by pose.
    const SEED_M: [[f32; 3]; 6] = [
        [153.329, 127.181, 129.991],
        [102.978, 127.989, 129.991],
        [128.072, 153.248, 129.586],
        [127.989, 101.200, 128.992],
        [127.989, 127.989, 154.179],
        [127.989, 127.183, 105.012],
    ];

    #[test]
    fn pinv_is_a_right_inverse_of_a_hat() {
        // Â·Â⁺ = I₄ (the defining property quoted in the seed).
        for r in 0..4 {
            for c in 0..4 {
                let mut s = 0.0;
                for (k, pose) in Pose::ALL.iter().enumerate() {
                    let a = pose.direction();
                    let ahat = if r < 3 { a[r] } else { 1.0 };
                    s += ahat * A_HAT_PINV[k][c];
                }
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((s - want).abs() < 1e-6, "({r},{c}) = {s}");
            }
        }
    }

    /// The seed prints M and T̂ with 3 decimals. Each T̂ entry is a half-difference or a mean of
    /// M entries, so rounding M moves it by at most 0.0005, and rounding T̂ for print by another
    /// 0.0005: the printed T̂ must agree within 0.001.
    #[test]
    fn reproduces_seed_t_hat() {
        let fit = solve(&SEED_M).unwrap();
        let want = [
            [25.175, 0.041, 0.0, 128.058],
            [-0.403, 26.023, 0.402, 127.465],
            [0.0, 0.297, 24.583, 129.625],
        ];
        for r in 0..3 {
            for c in 0..4 {
                assert!(
                    (fit.t_hat[r][c] - want[r][c]).abs() <= 0.001 + 2e-5,
                    "T̂[{r}][{c}] = {} vs {}",
                    fit.t_hat[r][c],
                    want[r][c]
                );
            }
        }
    }

    /// The seed's "D" is numerically D⁻¹, printed to 6 decimals (or 7 significant digits).
    /// First-order perturbation: |Δ(D⁻¹)ᵢⱼ| ≤ Σₖₗ |D⁻¹ᵢₖ|·|ΔDₖₗ|·|D⁻¹ₗⱼ| with |ΔDₖₗ| ≤ 0.0005
    /// (rounding of M), plus the seed's own print rounding (0.5e-6).
    #[test]
    fn reproduces_seed_d_inverse() {
        let fit = solve(&SEED_M).unwrap();
        let want = [
            [0.039719, -6.372846e-05, 1.044176e-06],
            [0.000616, 0.038432, -0.000629],
            [-7.448896e-06, -0.000464, 0.040684],
        ];
        let k = fit.d_inv;
        for i in 0..3 {
            for j in 0..3 {
                let row: f32 = (0..3).map(|c| k[i][c].abs()).sum();
                let col: f32 = (0..3).map(|r| k[r][j].abs()).sum();
                let tol = 0.0005 * row * col + 0.5e-6 + 1e-8;
                assert!(
                    (k[i][j] - want[i][j]).abs() <= tol,
                    "D⁻¹[{i}][{j}] = {:e} vs {:e} (tol {tol:e})",
                    k[i][j],
                    want[i][j]
                );
            }
        }
        // b is T̂'s last column: 128.0581, 127.4656, 129.6256 in the seed (4 decimals). The
        // printed M gives 127.4650 for y: 0.0006 off, slightly more than rounding M allows
        // (0.0005), so the seed computed b from marginally different means; 0.001 as for T̂.
        let b_seed = [128.0581, 127.4656, 129.6256];
        for i in 0..3 {
            assert!((fit.bias[i] - b_seed[i]).abs() <= 0.001 + 2e-5);
        }
    }

    /// With the constant pseudo-inverse the residuals of the + and − pose of an axis are equal.
    #[test]
    fn residual_pairs_are_equal_and_model_is_exact_on_linear_data() {
        let fit = solve(&SEED_M).unwrap();
        for r in 0..3 {
            for pair in 0..3 {
                let (p, n) = (fit.residual[r][2 * pair], fit.residual[r][2 * pair + 1]);
                assert!((p - n).abs() < 1e-4, "row {r} pair {pair}: {p} vs {n}");
            }
        }
        // Data generated exactly by m = D·a + b gives zero residual and returns D, b.
        let d = Mat3::new(25.0, 0.5, -0.2, 0.1, 26.0, 0.3, -0.4, 0.2, 24.0);
        let b = Vec3::new(128.0, 127.0, 130.0);
        let means: [[f32; 3]; 6] = core::array::from_fn(|i| {
            let a = Pose::ALL[i].direction();
            let m = d * Vec3::new(a[0], a[1], a[2]) + b;
            [m.x, m.y, m.z]
        });
        let fit = solve(&means).unwrap();
        for r in 0..3 {
            assert!((fit.bias[r] - b[r]).abs() < 1e-4);
            for c in 0..3 {
                assert!((fit.d[r][c] - d[(r, c)]).abs() < 1e-4);
            }
            for p in 0..6 {
                assert!(fit.residual[r][p].abs() < 1e-4);
            }
        }
    }

    #[test]
    fn labels_round_trip_and_reject_junk() {
        for p in Pose::ALL {
            assert_eq!(Pose::from_label(p.label()), Some(p));
        }
        assert_eq!(Pose::from_label("X+"), Some(Pose::XPos));
        assert_eq!(Pose::from_label("w+"), None);
        assert_eq!(Pose::from_label(""), None);
        assert_eq!(Pose::from_label("a very long label"), None);
    }

    #[test]
    fn duplicate_missing_and_degenerate_are_errors() {
        let mut v: [(Pose, [f32; 3]); 6] = core::array::from_fn(|i| (Pose::ALL[i], SEED_M[i]));
        assert!(solve_labelled(&v).is_ok());
        v[5].0 = Pose::XPos;
        assert_eq!(solve_labelled(&v), Err(Error::DuplicatePose));
        assert_eq!(solve_labelled(&v[..5]), Err(Error::MissingPose));
        assert_eq!(solve(&[[128.0; 3]; 6]), Err(Error::DegenerateGeometry));
        let mut m = SEED_M;
        m[2][1] = f32::NAN;
        assert_eq!(solve(&m), Err(Error::NonFinite));
    }
}
