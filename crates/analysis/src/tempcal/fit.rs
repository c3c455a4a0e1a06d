//! The per-axis least-squares fit of [`super`]: pose constants plus a polynomial without
//! constant in `ΔT = T − T_ref`, and its leave-one-segment-out error.
//!
//! How: the pose constants are eliminated by centring the values and the polynomial's
//! columns within each pose (Frisch–Waugh–Lovell: the slope estimates and their covariance
//! are those of the full regression with one constant per pose; the residual degrees of
//! freedom lose one per pose). The polynomial is fitted in `u = (T − T_mid)/h`, the
//! temperature scaled to ±1 over the record, where its powers are far less collinear than
//! powers of `ΔT` about a reference outside the record (35 °C against a 15–25 °C warm-up),
//! then re-expanded about `T_ref`; the covariance goes through the same linear map.

use nalgebra::{DMatrix, DVector};

/// One axis's data.
pub struct AxisData<'a> {
    /// Block temperatures, °C.
    pub temp_c: &'a [f64],
    /// Block means of the axis.
    pub y: &'a [f64],
    /// Pose index of each block, `0..poses`.
    pub pose: &'a [usize],
    /// Number of poses.
    pub poses: usize,
    /// Reference temperature, °C.
    pub t_ref_c: f64,
}

/// A fit of one order.
#[derive(Debug, Clone)]
pub struct PolyFit {
    /// `c_1..c_K` about `T_ref` (file units per °C^k).
    pub coef: Vec<f64>,
    /// Their standard errors (NaN when there are no residual degrees of freedom).
    pub se: Vec<f64>,
    /// Residual sum of squares over the blocks used.
    pub rss: f64,
    /// Each pose's constant (its value at `T_ref`); `None` for a pose with no block used.
    pub offsets: Vec<Option<f64>>,
}

impl PolyFit {
    /// The predicted value of a block of pose `pose` at `temp_c`, if the pose was fitted.
    pub fn predict(&self, temp_c: f64, t_ref_c: f64, pose: usize) -> Option<f64> {
        let dt = temp_c - t_ref_c;
        let poly: f64 = self
            .coef
            .iter()
            .enumerate()
            .map(|(k, c)| c * dt.powi(k as i32 + 1))
            .sum();
        self.offsets.get(pose).copied().flatten().map(|o| o + poly)
    }
}

/// Segment (0..k) of each of `n` blocks in time order: `k` contiguous runs of equal count.
pub fn segment_of(n: usize, k: usize) -> Vec<usize> {
    (0..n).map(|i| i * k / n.max(1)).collect()
}

/// Fits order `order` to the blocks with `used[i]`; `None` when the normal matrix is singular
/// or too few blocks are used.
pub fn fit_axis(d: &AxisData, used: &[bool], order: usize) -> Option<PolyFit> {
    let (lo, hi) = d
        .temp_c
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, z), t| {
            (a.min(*t), z.max(*t))
        });
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(1e-9);
    let powers = |t: f64| -> Vec<f64> {
        let u = (t - mid) / half;
        (1..=order).map(|k| u.powi(k as i32)).collect()
    };
    let (count, ybar, ubar) = pose_means(d, used, order, &powers);
    let mut xtx = DMatrix::<f64>::zeros(order, order);
    let mut xty = DVector::<f64>::zeros(order);
    let mut n_used = 0usize;
    for i in (0..d.y.len()).filter(|i| used[*i]) {
        let p = d.pose[i];
        let x: Vec<f64> = powers(d.temp_c[i])
            .iter()
            .zip(&ubar[p])
            .map(|(v, m)| v - m)
            .collect();
        let yc = d.y[i] - ybar[p];
        for r in 0..order {
            xty[r] += x[r] * yc;
            for c in 0..order {
                xtx[(r, c)] += x[r] * x[c];
            }
        }
        n_used += 1;
    }
    let a_cov = solve_scaled(&xtx)?;
    let a = &a_cov * &xty;
    let poses_used = count.iter().filter(|c| **c > 0).count();
    let rss = residual_ss(d, used, &a, &ybar, &ubar, &powers);
    let dof = n_used.checked_sub(poses_used + order).filter(|d| *d > 0);
    let sigma2 = dof.map_or(f64::NAN, |dof| rss / dof as f64);
    let j = reexpand(order, mid - d.t_ref_c, half);
    let coef = &j * &a;
    let cov = &j * (a_cov * sigma2) * j.transpose();
    // The constant the re-expansion moves into the pose constants.
    let c0: f64 = (1..=order)
        .map(|k| a[k - 1] * ((d.t_ref_c - mid) / half).powi(k as i32))
        .sum();
    let offsets = (0..d.poses)
        .map(|p| {
            (count[p] > 0).then(|| {
                ybar[p]
                    - ubar[p]
                        .iter()
                        .zip(a.iter())
                        .map(|(m, c)| m * c)
                        .sum::<f64>()
                    + c0
            })
        })
        .collect();
    Some(PolyFit {
        coef: coef.iter().copied().collect(),
        se: (0..order).map(|k| cov[(k, k)].max(0.0).sqrt()).collect(),
        rss,
        offsets,
    })
}

/// Blocks used, mean value and mean of each power `u^k`, per pose.
#[allow(clippy::type_complexity)]
fn pose_means(
    d: &AxisData,
    used: &[bool],
    order: usize,
    powers: &dyn Fn(f64) -> Vec<f64>,
) -> (Vec<usize>, Vec<f64>, Vec<Vec<f64>>) {
    let mut count = vec![0usize; d.poses];
    let mut ybar = vec![0.0; d.poses];
    let mut ubar = vec![vec![0.0; order]; d.poses];
    for i in (0..d.y.len()).filter(|i| used[*i]) {
        let p = d.pose[i];
        count[p] += 1;
        ybar[p] += d.y[i];
        for (m, v) in ubar[p].iter_mut().zip(powers(d.temp_c[i])) {
            *m += v;
        }
    }
    for p in 0..d.poses {
        if count[p] > 0 {
            ybar[p] /= count[p] as f64;
            ubar[p].iter_mut().for_each(|m| *m /= count[p] as f64);
        }
    }
    (count, ybar, ubar)
}

/// `(XᵀX)⁻¹` by Cholesky on the unit-diagonal scaled matrix; `None` when singular.
fn solve_scaled(xtx: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = xtx.nrows();
    let s: Vec<f64> = (0..n).map(|i| xtx[(i, i)].sqrt()).collect();
    if s.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(n, n, |r, c| xtx[(r, c)] / (s[r] * s[c]));
    let inv = nalgebra::Cholesky::new(scaled)?.inverse();
    if inv.iter().any(|v| !v.is_finite()) {
        return None;
    }
    Some(DMatrix::from_fn(n, n, |r, c| inv[(r, c)] / (s[r] * s[c])))
}

fn residual_ss(
    d: &AxisData,
    used: &[bool],
    a: &DVector<f64>,
    ybar: &[f64],
    ubar: &[Vec<f64>],
    powers: &dyn Fn(f64) -> Vec<f64>,
) -> f64 {
    (0..d.y.len())
        .filter(|i| used[*i])
        .map(|i| {
            let p = d.pose[i];
            let fit: f64 = powers(d.temp_c[i])
                .iter()
                .zip(&ubar[p])
                .zip(a.iter())
                .map(|((v, m), c)| (v - m) * c)
                .sum();
            (d.y[i] - ybar[p] - fit).powi(2)
        })
        .sum()
}

/// The matrix taking the coefficients of `Σ a_k u^k`, `u = (ΔT − shift)/half`, to those of
/// `Σ c_j ΔT^j` (j ≥ 1; the constant goes to the pose constants): binomial expansion.
fn reexpand(order: usize, shift: f64, half: f64) -> DMatrix<f64> {
    DMatrix::from_fn(order, order, |row, col| {
        let (j, k) = (row + 1, col + 1);
        if k < j {
            0.0
        } else {
            binomial(k, j) * (-shift).powi((k - j) as i32) / half.powi(k as i32)
        }
    })
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// Held-out RMS of order `order`: each segment left out in turn, predicted from the fit to the
/// others (pose constants from the pose's blocks in the other segments); `None` when no
/// left-out block could be predicted.
pub fn heldout_rms(d: &AxisData, seg: &[usize], segments: usize, order: usize) -> Option<f64> {
    let (mut ss, mut n) = (0.0, 0usize);
    for s in 0..segments {
        let used: Vec<bool> = seg.iter().map(|g| *g != s).collect();
        let Some(f) = fit_axis(d, &used, order) else {
            continue;
        };
        for i in (0..d.y.len()).filter(|i| seg[*i] == s) {
            if let Some(p) = f.predict(d.temp_c[i], d.t_ref_c, d.pose[i]) {
                ss += (d.y[i] - p).powi(2);
                n += 1;
            }
        }
    }
    (n > 0).then(|| (ss / n as f64).sqrt())
}
