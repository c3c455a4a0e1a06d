//! Multi-position accelerometer calibration in arbitrary orientations.
//!
//! The method of IMU-TK (Tedaldi, Pretto, Menegatti, ICRA 2014) and ArduPilot's
//! `AccelCalibrator`: at rest, a calibrated accelerometer reads a vector of magnitude `g`
//! whatever the orientation. Given the means `m_i` of `n` static poses, find the bias `b` and an
//! upper-triangular correction matrix `K` minimising
//!
//! ```text
//! Σ_i w_i (‖K·(m_i − b)‖ − g)²          (9 parameters: b, and K's 6 upper-triangular entries)
//! ```
//!
//! `K` upper triangular loses no generality: any correction `K'` is `R·K` for a rotation `R`
//! (QR decomposition), and a rotation does not change the norm, so the sensor frame is fixed by
//! convention (x axis kept, y in the sensor's x–y plane). `K` is then directly the
//! [`Calibration`] matrix `D⁻¹`.
//!
//! Solver: Levenberg–Marquardt in `f32` on the stack (9×9 normal equations, Cholesky), on data
//! centred and scaled to unit size first so that raw counts in the tens of thousands cost no
//! precision. The initial guess is an algebraic sphere fit (linear, 4 parameters), which is
//! also where geometry is checked: poses that all lie in one plane cannot determine a sphere,
//! let alone the full model, and give [`Error::DegenerateGeometry`]. A final check on the
//! scaled normal matrix catches the subtler cases (too little spread for 9 parameters).

use crate::{Calibration, Error};
use nalgebra::{SMatrix, SVector};

type M9 = SMatrix<f32, 9, 9>;
type V9 = SVector<f32, 9>;

/// Which parameters to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MultiPosModel {
    /// Bias, per-axis scale and non-orthogonality: 9 parameters, at least 9 poses.
    Full,
    /// Bias and per-axis scale only (K diagonal): 6 parameters, at least 6 poses.
    Diagonal,
}

impl MultiPosModel {
    /// Number of free parameters.
    pub fn params(self) -> u32 {
        match self {
            MultiPosModel::Full => 9,
            MultiPosModel::Diagonal => 6,
        }
    }

    fn free(self, i: usize) -> bool {
        // Parameter order: b0 b1 b2 k00 k01 k02 k11 k12 k22.
        !(self == MultiPosModel::Diagonal && matches!(i, 4 | 5 | 7))
    }
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiPosConfig {
    /// Which parameters to fit.
    pub model: MultiPosModel,
    /// Magnitude the corrected vectors should have (1.0: output in g).
    pub reference_magnitude: f32,
    /// Iteration budget for Levenberg–Marquardt.
    pub max_iterations: u32,
}

impl Default for MultiPosConfig {
    fn default() -> Self {
        Self {
            model: MultiPosModel::Full,
            reference_magnitude: 1.0,
            max_iterations: 200,
        }
    }
}

/// Result of a multi-position fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiPosFit {
    /// The calibration: `matrix` = upper-triangular `K`, `bias` = `b` (raw units).
    pub calibration: Calibration,
    /// Weighted RMS of `‖K(m_i − b)‖ − g` over the poses, in reference units.
    pub rms: f32,
    /// Largest `|‖K(m_i − b)‖ − g|`, in reference units.
    pub max_abs_residual: f32,
    /// Levenberg–Marquardt iterations used.
    pub iterations: u32,
    /// Smallest eigenvalue of the scaled (unit-diagonal) normal matrix at the solution: near 0
    /// means some parameter combination is barely determined by the poses.
    pub identifiability: f32,
}

/// Smallest acceptable [`MultiPosFit::identifiability`].
pub const MIN_IDENTIFIABILITY: f32 = 1e-5;

/// Fits with equal weights; see [`fit_weighted`].
pub fn fit(poses: &[[f32; 3]], cfg: &MultiPosConfig) -> Result<MultiPosFit, Error> {
    fit_weighted(poses, None, cfg)
}

/// Affine normalisation `y = (m − centre) / scale`.
#[derive(Clone, Copy)]
struct Frame {
    centre: [f32; 3],
    scale: f32,
}

impl Frame {
    fn of(poses: &[[f32; 3]]) -> Result<Self, Error> {
        let n = poses.len() as f32;
        let mut centre = [0.0f32; 3];
        // Two-pass mean, shifted by the first pose for precision.
        let first = poses
            .first()
            .ok_or(Error::TooFewPoses { needed: 1, got: 0 })?;
        for p in poses {
            for a in 0..3 {
                centre[a] += (p[a] - first[a]) / n;
            }
        }
        for a in 0..3 {
            centre[a] += first[a];
        }
        let mut ss = 0.0f32;
        for p in poses {
            for a in 0..3 {
                let d = p[a] - centre[a];
                ss += d * d;
            }
        }
        let scale = libm::sqrtf(ss / n);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Error::DegenerateGeometry);
        }
        Ok(Self { centre, scale })
    }

    fn apply(&self, m: &[f32; 3]) -> [f32; 3] {
        [
            (m[0] - self.centre[0]) / self.scale,
            (m[1] - self.centre[1]) / self.scale,
            (m[2] - self.centre[2]) / self.scale,
        ]
    }
}

/// Algebraic sphere fit `|y|² = 2c·y + e` on normalised points: the initial guess.
/// Returns (centre, radius).
fn sphere_init<I: Iterator<Item = ([f32; 3], f32)>>(pts: I) -> Result<([f32; 3], f32), Error> {
    let mut ata = SMatrix::<f32, 4, 4>::zeros();
    let mut atb = SVector::<f32, 4>::zeros();
    for (y, w) in pts {
        let row = SVector::<f32, 4>::new(2.0 * y[0], 2.0 * y[1], 2.0 * y[2], 1.0);
        let rhs = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        ata += row * row.transpose() * w;
        atb += row * (rhs * w);
    }
    // Coplanar points leave the sphere's centre free along the plane normal: the normal
    // matrix is then singular. Check its conditioning with a relative pivot threshold.
    let diag_max = (0..4).map(|i| ata[(i, i)]).fold(0.0f32, f32::max);
    let chol = nalgebra::Cholesky::new(ata).ok_or(Error::DegenerateGeometry)?;
    let l = chol.l();
    for i in 0..4 {
        let pivot = l[(i, i)] * l[(i, i)];
        if pivot.is_nan() || pivot <= 1e-4 * diag_max {
            return Err(Error::DegenerateGeometry);
        }
    }
    let x = chol.solve(&atb);
    let c = [x[0], x[1], x[2]];
    let r2 = x[3] + c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    if !(r2.is_finite() && r2 > 0.0) {
        return Err(Error::DegenerateGeometry);
    }
    Ok((c, libm::sqrtf(r2)))
}

/// Residual and gradient of one pose: r = ‖K(y − b)‖ − 1 and ∂r/∂p (normalised units).
#[inline]
fn residual_and_jacobian(p: &V9, y: &[f32; 3]) -> (f32, V9) {
    let d = [y[0] - p[0], y[1] - p[1], y[2] - p[2]];
    let u = [
        p[3] * d[0] + p[4] * d[1] + p[5] * d[2],
        p[6] * d[1] + p[7] * d[2],
        p[8] * d[2],
    ];
    let n = libm::sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    let inv = if n > 0.0 { 1.0 / n } else { 0.0 };
    let g = [u[0] * inv, u[1] * inv, u[2] * inv];
    // ∂r/∂b = −Kᵀ g ; ∂r/∂K_jk = g_j d_k.
    let jb = [
        -(p[3] * g[0]),
        -(p[4] * g[0] + p[6] * g[1]),
        -(p[5] * g[0] + p[7] * g[1] + p[8] * g[2]),
    ];
    let j = V9::from([
        jb[0],
        jb[1],
        jb[2],
        g[0] * d[0],
        g[0] * d[1],
        g[0] * d[2],
        g[1] * d[1],
        g[1] * d[2],
        g[2] * d[2],
    ]);
    (n - 1.0, j)
}

/// Weighted cost Σ w r² and, optionally, the normal equations.
fn evaluate(
    p: &V9,
    frame: &Frame,
    poses: &[[f32; 3]],
    weights: Option<&[f32]>,
    normal: Option<(&mut M9, &mut V9)>,
) -> f32 {
    let mut cost = 0.0f32;
    let mut acc = normal;
    for (i, m) in poses.iter().enumerate() {
        let w = weights.map_or(1.0, |w| w[i]);
        let y = frame.apply(m);
        let (r, j) = residual_and_jacobian(p, &y);
        cost += w * r * r;
        if let Some((jtj, jtr)) = acc.as_mut() {
            // Symmetric rank-1 update, upper triangle then mirrored by the caller.
            for a in 0..9 {
                let wa = w * j[a];
                jtr[a] += wa * r;
                for b in a..9 {
                    jtj[(a, b)] += wa * j[b];
                }
            }
        }
    }
    cost
}

fn mirror(m: &mut M9) {
    for a in 0..9 {
        for b in 0..a {
            m[(a, b)] = m[(b, a)];
        }
    }
}

/// Fits bias and upper-triangular `K` to static pose means `poses` (raw units), with optional
/// non-negative per-pose weights (e.g. 0 to exclude a pose, or robust-loss weights).
pub fn fit_weighted(
    poses: &[[f32; 3]],
    weights: Option<&[f32]>,
    cfg: &MultiPosConfig,
) -> Result<MultiPosFit, Error> {
    if !(cfg.reference_magnitude.is_finite() && cfg.reference_magnitude > 0.0)
        || cfg.max_iterations == 0
    {
        return Err(Error::InvalidParameter);
    }
    if !poses.iter().all(|p| crate::all_finite(p)) {
        return Err(Error::NonFinite);
    }
    if let Some(w) = weights {
        if w.len() != poses.len() || !w.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(Error::InvalidParameter);
        }
    }
    let npar = cfg.model.params();
    let effective = match weights {
        Some(w) => w.iter().filter(|x| **x > 0.0).count(),
        None => poses.len(),
    } as u32;
    if effective < npar {
        return Err(Error::TooFewPoses {
            needed: npar,
            got: effective,
        });
    }
    let frame = Frame::of(poses)?;
    let w_of = |i: usize| weights.map_or(1.0, |w| w[i]);
    let (c, r) = sphere_init(
        poses
            .iter()
            .enumerate()
            .map(|(i, m)| (frame.apply(m), w_of(i))),
    )?;
    let mut p = V9::from([c[0], c[1], c[2], 1.0 / r, 0.0, 0.0, 1.0 / r, 0.0, 1.0 / r]);

    let mut lambda = 1e-3f32;
    let mut cost = evaluate(&p, &frame, poses, weights, None);
    let mut iterations = 0;
    let mut converged = false;
    while iterations < cfg.max_iterations {
        iterations += 1;
        let mut jtj = M9::zeros();
        let mut jtr = V9::zeros();
        evaluate(&p, &frame, poses, weights, Some((&mut jtj, &mut jtr)));
        mirror(&mut jtj);
        for i in 0..9 {
            if !cfg.model.free(i) {
                for k in 0..9 {
                    jtj[(i, k)] = 0.0;
                    jtj[(k, i)] = 0.0;
                }
                jtj[(i, i)] = 1.0;
                jtr[i] = 0.0;
            }
        }
        let grad_max = jtr.amax();
        if grad_max <= 1e-12 {
            converged = true;
            break;
        }
        // Inner loop: raise λ until the step lowers the cost.
        let mut accepted = false;
        for _ in 0..30 {
            let mut a = jtj;
            for i in 0..9 {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(chol) = nalgebra::Cholesky::new(a) else {
                lambda *= 10.0;
                continue;
            };
            let step = chol.solve(&(-jtr));
            let candidate = p + step;
            let new_cost = evaluate(&candidate, &frame, poses, weights, None);
            if new_cost.is_finite() && new_cost <= cost {
                let small_step = step.amax() <= 1e-7 * (p.amax() + 1e-7);
                let small_gain = cost - new_cost <= 1e-9 * cost;
                p = candidate;
                cost = new_cost;
                lambda = (lambda * 0.3).max(1e-9);
                accepted = true;
                if small_step || small_gain {
                    converged = true;
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            // No step lowers the cost within f32 resolution: we are at the minimum.
            converged = true;
        }
        if converged {
            break;
        }
    }
    if !converged {
        return Err(Error::NotConverged);
    }

    // Identifiability: eigenvalues of the unit-diagonal normal matrix at the solution.
    let mut jtj = M9::zeros();
    let mut jtr = V9::zeros();
    evaluate(&p, &frame, poses, weights, Some((&mut jtj, &mut jtr)));
    mirror(&mut jtj);
    let mut scaled = M9::identity();
    let free: heapless::Vec<usize, 9> = (0..9).filter(|i| cfg.model.free(*i)).collect();
    for &a in &free {
        for &b in &free {
            let da = libm::sqrtf(jtj[(a, a)]);
            let db = libm::sqrtf(jtj[(b, b)]);
            // A parameter with no sensitivity at all keeps a zero row: eigenvalue 0 below.
            scaled[(a, b)] = if da > 0.0 && db > 0.0 {
                jtj[(a, b)] / (da * db)
            } else {
                0.0
            };
        }
    }
    let identifiability = nalgebra::SymmetricEigen::new(scaled).eigenvalues.min();
    if identifiability.is_nan() || identifiability < MIN_IDENTIFIABILITY {
        return Err(Error::DegenerateGeometry);
    }

    // Residual statistics and the map back to raw units: K = K'/(scale·g), b = c + scale·b'.
    let mut sum_w = 0.0f32;
    let mut sum_wr2 = 0.0f32;
    let mut max_abs = 0.0f32;
    for (i, m) in poses.iter().enumerate() {
        let (r, _) = residual_and_jacobian(&p, &frame.apply(m));
        let w = w_of(i);
        sum_w += w;
        sum_wr2 += w * r * r;
        if w > 0.0 {
            max_abs = max_abs.max(libm::fabsf(r));
        }
    }
    let g = cfg.reference_magnitude;
    let ks = g / frame.scale;
    let calibration = Calibration {
        bias: [
            frame.centre[0] + frame.scale * p[0],
            frame.centre[1] + frame.scale * p[1],
            frame.centre[2] + frame.scale * p[2],
        ],
        matrix: [
            [p[3] * ks, p[4] * ks, p[5] * ks],
            [0.0, p[6] * ks, p[7] * ks],
            [0.0, 0.0, p[8] * ks],
        ],
        effects: Default::default(),
    };
    if !calibration.matrix.iter().all(|r| crate::all_finite(r)) || calibration.validate().is_err() {
        return Err(Error::Singular);
    }
    Ok(MultiPosFit {
        calibration,
        rms: g * libm::sqrtf(sum_wr2 / sum_w),
        max_abs_residual: g * max_abs,
        iterations,
        identifiability,
    })
}

/// Residual `‖a‖ − g` of a corrected pose mean, in reference units.
pub fn norm_residual(cal: &Calibration, m: [f32; 3], g: f32) -> f32 {
    let a = cal.correct_linear(m);
    libm::sqrtf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) - g
}
