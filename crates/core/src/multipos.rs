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

use crate::lm::{self, lit, LmSettings, Problem};
use crate::{Calibration, Error};
use nalgebra::{RealField, SMatrix, SVector};

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

/// Solver settings in any float type, for [`fit_generic`] (the `f32` [`MultiPosConfig`]
/// converts into it losslessly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiPosSettings<T> {
    /// Which parameters to fit.
    pub model: MultiPosModel,
    /// Magnitude the corrected vectors should have (1.0: output in g).
    pub reference_magnitude: T,
    /// Iteration budget for Levenberg–Marquardt.
    pub max_iterations: u32,
}

impl From<&MultiPosConfig> for MultiPosSettings<f32> {
    fn from(c: &MultiPosConfig) -> Self {
        Self {
            model: c.model,
            reference_magnitude: c.reference_magnitude,
            max_iterations: c.max_iterations,
        }
    }
}

/// Result of [`fit_generic`]: the fit in the float type it was computed in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenericFit<T> {
    /// Bias `b`, raw units.
    pub bias: [T; 3],
    /// Upper-triangular `K` (row-major), reference units per raw unit.
    pub matrix: [[T; 3]; 3],
    /// Weighted RMS of `‖K(m_i − b)‖ − g`, reference units.
    pub rms: T,
    /// Largest `|‖K(m_i − b)‖ − g|` over poses of positive weight, reference units.
    pub max_abs_residual: T,
    /// Levenberg–Marquardt iterations used.
    pub iterations: u32,
    /// Smallest eigenvalue of the unit-diagonal normal matrix at the solution.
    pub identifiability: T,
}

/// Affine normalisation `y = (m − centre) / scale`.
#[derive(Clone, Copy)]
struct Frame<T> {
    centre: [T; 3],
    scale: T,
}

impl<T: RealField + Copy> Frame<T> {
    fn of(poses: &[[T; 3]]) -> Result<Self, Error> {
        let n: T = lit(poses.len() as f64);
        let mut centre = [T::zero(); 3];
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
        let mut ss = T::zero();
        for p in poses {
            for a in 0..3 {
                let d = p[a] - centre[a];
                ss += d * d;
            }
        }
        let scale = (ss / n).sqrt();
        if !(scale.is_finite() && scale > T::zero()) {
            return Err(Error::DegenerateGeometry);
        }
        Ok(Self { centre, scale })
    }

    #[inline]
    fn apply(&self, m: &[T; 3]) -> [T; 3] {
        [
            (m[0] - self.centre[0]) / self.scale,
            (m[1] - self.centre[1]) / self.scale,
            (m[2] - self.centre[2]) / self.scale,
        ]
    }
}

/// Algebraic sphere fit `|y|² = 2c·y + e` on normalised points: the initial guess.
/// Returns (centre, radius).
fn sphere_init<T: RealField + Copy, I: Iterator<Item = ([T; 3], T)>>(
    pts: I,
) -> Result<([T; 3], T), Error> {
    let two: T = lit(2.0);
    let mut ata = SMatrix::<T, 4, 4>::zeros();
    let mut atb = SVector::<T, 4>::zeros();
    for (y, w) in pts {
        let row = SVector::<T, 4>::new(two * y[0], two * y[1], two * y[2], T::one());
        let rhs = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        ata += row * row.transpose() * w;
        atb += row * (rhs * w);
    }
    // Coplanar points leave the sphere's centre free along the plane normal: the normal
    // matrix is then singular. Check its conditioning with a relative pivot threshold.
    let diag_max = (0..4).map(|i| ata[(i, i)]).fold(T::zero(), T::max);
    let chol = nalgebra::Cholesky::new(ata).ok_or(Error::DegenerateGeometry)?;
    let l = chol.l();
    let tol: T = lit(1e-4);
    for i in 0..4 {
        let pivot = l[(i, i)] * l[(i, i)];
        #[allow(clippy::eq_op)] // `x != x`: NaN test without a float-specific trait.
        if pivot != pivot || pivot <= tol * diag_max {
            return Err(Error::DegenerateGeometry);
        }
    }
    let x = chol.solve(&atb);
    let c = [x[0], x[1], x[2]];
    let r2 = x[3] + c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    if !(r2.is_finite() && r2 > T::zero()) {
        return Err(Error::DegenerateGeometry);
    }
    Ok((c, r2.sqrt()))
}

/// Residual and gradient of one normalised pose: r = ‖K(y − b)‖ − 1 and ∂r/∂p, parameters
/// `b0 b1 b2 k00 k01 k02 k11 k12 k22`.
#[inline]
pub fn residual_and_gradient<T: RealField + Copy>(
    p: &SVector<T, 9>,
    y: &[T; 3],
) -> (T, SVector<T, 9>) {
    let d = [y[0] - p[0], y[1] - p[1], y[2] - p[2]];
    let u = [
        p[3] * d[0] + p[4] * d[1] + p[5] * d[2],
        p[6] * d[1] + p[7] * d[2],
        p[8] * d[2],
    ];
    let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let inv = if n > T::zero() {
        T::one() / n
    } else {
        T::zero()
    };
    let g = [u[0] * inv, u[1] * inv, u[2] * inv];
    // ∂r/∂b = −Kᵀ g ; ∂r/∂K_jk = g_j d_k.
    let jb = [
        -(p[3] * g[0]),
        -(p[4] * g[0] + p[6] * g[1]),
        -(p[5] * g[0] + p[7] * g[1] + p[8] * g[2]),
    ];
    let j = SVector::<T, 9>::from([
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
    (n - T::one(), j)
}

/// The 9-parameter multi-position problem on normalised poses, as an [`lm::Problem`].
struct Poses<'a, T> {
    frame: Frame<T>,
    poses: &'a [[T; 3]],
}

impl<T: RealField + Copy> Problem<T, 9> for Poses<'_, T> {
    #[inline]
    fn observations(&self) -> usize {
        self.poses.len()
    }

    #[inline]
    fn residual_and_gradient(&self, p: &SVector<T, 9>, i: usize) -> (T, SVector<T, 9>) {
        residual_and_gradient(p, &self.frame.apply(&self.poses[i]))
    }

    /// The residual without the gradient: the same operations as the first half of
    /// [`residual_and_gradient`], so the value is bit-identical, at a third of the cost.
    #[inline]
    fn residual(&self, p: &SVector<T, 9>, i: usize) -> T {
        let y = self.frame.apply(&self.poses[i]);
        let d = [y[0] - p[0], y[1] - p[1], y[2] - p[2]];
        let u = [
            p[3] * d[0] + p[4] * d[1] + p[5] * d[2],
            p[6] * d[1] + p[7] * d[2],
            p[8] * d[2],
        ];
        (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt() - T::one()
    }
}

/// Fits with equal weights; see [`fit_weighted`].
pub fn fit(poses: &[[f32; 3]], cfg: &MultiPosConfig) -> Result<MultiPosFit, Error> {
    fit_weighted(poses, None, cfg)
}

/// Fits bias and upper-triangular `K` to static pose means `poses` (raw units), with optional
/// non-negative per-pose weights (e.g. 0 to exclude a pose, or robust-loss weights).
///
/// This is [`fit_generic`] in `f32`, plus the conversion to a [`Calibration`] (which must be
/// finite and invertible, else [`Error::Singular`]).
pub fn fit_weighted(
    poses: &[[f32; 3]],
    weights: Option<&[f32]>,
    cfg: &MultiPosConfig,
) -> Result<MultiPosFit, Error> {
    let f = fit_generic::<f32>(poses, weights, &cfg.into())?;
    let calibration = Calibration {
        bias: f.bias,
        matrix: f.matrix,
        effects: Default::default(),
    };
    if !calibration.matrix.iter().all(|r| crate::all_finite(r)) || calibration.validate().is_err() {
        return Err(Error::Singular);
    }
    Ok(MultiPosFit {
        calibration,
        rms: f.rms,
        max_abs_residual: f.max_abs_residual,
        iterations: f.iterations,
        identifiability: f.identifiability,
    })
}

/// The multi-position fit in any float type: `f32` on the device ([`fit_weighted`] is this
/// with `T = f32`, bit for bit), `f64` on the host (`fit_generic::<f64>`).
///
/// Same model, normalisation, initial guess, Levenberg–Marquardt schedule
/// ([`LmSettings::multipos`]) and geometry checks as [`fit_weighted`]; the identifiability
/// threshold is [`MIN_IDENTIFIABILITY`] in both types.
///
/// When the solver started from the algebraic sphere does not converge, it is restarted once
/// from the neutral point (bias at the poses' centre, `K` = identity in the normalised frame).
/// Errors: [`Error::Diverged`] when the parameters run off to infinity from both starts (no
/// finite solution: too few orientations, or windows that are not static),
/// [`Error::NotConverged`] when the budget runs out otherwise, [`Error::DegenerateGeometry`]
/// when the minimum is not identifiable.
pub fn fit_generic<T: RealField + Copy>(
    poses: &[[T; 3]],
    weights: Option<&[T]>,
    cfg: &MultiPosSettings<T>,
) -> Result<GenericFit<T>, Error> {
    if !(cfg.reference_magnitude.is_finite() && cfg.reference_magnitude > T::zero())
        || cfg.max_iterations == 0
    {
        return Err(Error::InvalidParameter);
    }
    if !poses.iter().all(|p| p.iter().all(|x| x.is_finite())) {
        return Err(Error::NonFinite);
    }
    if let Some(w) = weights {
        if w.len() != poses.len() || !w.iter().all(|x| x.is_finite() && *x >= T::zero()) {
            return Err(Error::InvalidParameter);
        }
    }
    let npar = cfg.model.params();
    let effective = match weights {
        Some(w) => w.iter().filter(|x| **x > T::zero()).count(),
        None => poses.len(),
    } as u32;
    if effective < npar {
        return Err(Error::TooFewPoses {
            needed: npar,
            got: effective,
        });
    }
    let frame = Frame::of(poses)?;
    let w_of = |i: usize| weights.map_or(T::one(), |w| w[i]);
    let (c, r) = sphere_init(
        poses
            .iter()
            .enumerate()
            .map(|(i, m)| (frame.apply(m), w_of(i))),
    )?;
    let k0 = T::one() / r;
    let (z, one) = (T::zero(), T::one());
    let from_sphere = SVector::<T, 9>::from([c[0], c[1], c[2], k0, z, z, k0, z, k0]);
    // Restart point: bias at the poses' centre, K = identity in the normalised frame (a sphere
    // through the poses' spread). An algebraic sphere through poses that cover a small part of
    // the sphere can start the solver in a valley that falls towards infinity while a finite
    // minimum exists elsewhere; from here the solver finds that minimum (as SciPy does from
    // the same start).
    let neutral = SVector::<T, 9>::from([z, z, z, one, z, z, one, z, one]);
    let mask: [bool; 9] = core::array::from_fn(|i| cfg.model.free(i));
    let problem = Poses { frame, poses };
    let settings = LmSettings::multipos(cfg.max_iterations);
    let sol = match lm::minimize(&problem, from_sphere, &mask, weights, &settings) {
        Err(first @ (Error::NotConverged | Error::Diverged)) => {
            lm::minimize(&problem, neutral, &mask, weights, &settings).map_err(|e| match e {
                // Report divergence when either start diverged: the more telling reason.
                Error::NotConverged if first == Error::Diverged => Error::Diverged,
                e => e,
            })?
        }
        other => other?,
    };
    let p = sol.params;
    let identifiability = identifiability(&problem, &p, weights, &mask);
    #[allow(clippy::eq_op)] // `x != x`: NaN test.
    if identifiability != identifiability || identifiability < lit(MIN_IDENTIFIABILITY as f64) {
        return Err(Error::DegenerateGeometry);
    }
    Ok(finish(
        &problem,
        &p,
        weights,
        cfg,
        sol.iterations,
        identifiability,
    ))
}

/// Smallest eigenvalue of the unit-diagonal normal matrix of the free parameters at `p`.
fn identifiability<T: RealField + Copy>(
    problem: &Poses<'_, T>,
    p: &SVector<T, 9>,
    weights: Option<&[T]>,
    mask: &[bool; 9],
) -> T {
    let (jtj, _) = lm::normal_equations(problem, p, weights);
    let mut scaled = SMatrix::<T, 9, 9>::identity();
    for a in (0..9).filter(|i| mask[*i]) {
        for b in (0..9).filter(|i| mask[*i]) {
            let da = jtj[(a, a)].sqrt();
            let db = jtj[(b, b)].sqrt();
            // A parameter with no sensitivity at all keeps a zero row: eigenvalue 0 below.
            scaled[(a, b)] = if da > T::zero() && db > T::zero() {
                jtj[(a, b)] / (da * db)
            } else {
                T::zero()
            };
        }
    }
    nalgebra::SymmetricEigen::new(scaled).eigenvalues.min()
}

/// Residual statistics and the map back to raw units: K = K'/(scale·g), b = c + scale·b'.
fn finish<T: RealField + Copy>(
    problem: &Poses<'_, T>,
    p: &SVector<T, 9>,
    weights: Option<&[T]>,
    cfg: &MultiPosSettings<T>,
    iterations: u32,
    identifiability: T,
) -> GenericFit<T> {
    let mut sum_w = T::zero();
    let mut sum_wr2 = T::zero();
    let mut max_abs = T::zero();
    for (i, m) in problem.poses.iter().enumerate() {
        let (r, _) = residual_and_gradient(p, &problem.frame.apply(m));
        let w = weights.map_or(T::one(), |w| w[i]);
        sum_w += w;
        sum_wr2 += w * r * r;
        if w > T::zero() {
            max_abs = max_abs.max(r.abs());
        }
    }
    let frame = &problem.frame;
    let g = cfg.reference_magnitude;
    let ks = g / frame.scale;
    let z = T::zero();
    GenericFit {
        bias: [
            frame.centre[0] + frame.scale * p[0],
            frame.centre[1] + frame.scale * p[1],
            frame.centre[2] + frame.scale * p[2],
        ],
        matrix: [
            [p[3] * ks, p[4] * ks, p[5] * ks],
            [z, p[6] * ks, p[7] * ks],
            [z, z, p[8] * ks],
        ],
        rms: g * (sum_wr2 / sum_w).sqrt(),
        max_abs_residual: g * max_abs,
        iterations,
        identifiability,
    }
}

/// Residual `‖a‖ − g` of a corrected pose mean, in reference units.
pub fn norm_residual(cal: &Calibration, m: [f32; 3], g: f32) -> f32 {
    let a = cal.correct_linear(m);
    libm::sqrtf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) - g
}
