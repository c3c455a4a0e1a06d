//! Fitting the gyroscope calibration to the motions between static windows (the method is
//! explained in [`crate::gyro`]).
//!
//! The cost is `Σ_motions ‖ĝ₁ − g₁‖²`, minimised by Levenberg–Marquardt over the free
//! parameters of the chosen [`GyroModel`]. Every evaluation integrates every motion again;
//! nothing but the 12×12 normal equations is kept between motions, so memory does not grow
//! with the recording (the samples stay wherever the caller keeps them).
//!
//! The solver takes the steps of the crate's generic [`crate::lm`] with the multi-position
//! schedule, on [`GyroProblem`] (each motion contributes three scalar observations, the
//! components of `ĝ₁ − g₁`), but integrates every trial point with its sensitivities in one
//! pass: an accepted trial's Jacobian is the next iteration's, so an iteration costs one pass
//! over the motions instead of a pass with sensitivities and a pass without, and the last pass
//! is at the fit ([`fit_keeping`] keeps each motion's residual and Jacobian there for
//! [`leave_one_out_one_step`]). [`GyroProblem`] still serves the generic solver (a test
//! checks both take the same steps).

use crate::gyro::{Adjustment, GyroCalibration, MotionIntegrator, MotionResidual, NPARAM};
use crate::lm::{self, LmSettings, Problem};
use crate::static_detect::StaticInterval;
use crate::{Calibration, Error};
use core::cell::RefCell;
use nalgebra::{RealField, SMatrix, SVector, Vector3};

type M12<T> = SMatrix<T, NPARAM, NPARAM>;
type V12<T> = SVector<T, NPARAM>;

/// One motion between two static windows.
#[derive(Debug, Clone, Copy)]
pub struct Motion<'a, T: RealField + Copy> {
    /// Raw gyro samples, evenly spaced, from the last sample of the window before to the
    /// first sample of the window after.
    pub samples: &'a [[T; 3]],
    /// Gravity direction (any length, not zero) in the window before, sensor frame, from the
    /// calibrated accelerometer.
    pub g_start: Vector3<T>,
    /// Gravity direction in the window after.
    pub g_end: Vector3<T>,
}

/// Where a motion lies in the recording: sample indices `start..end` (the last sample of the
/// static window before through the first sample of the window after) and the calibrated
/// gravity directions of the two windows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSpan {
    /// First sample index (inclusive).
    pub start: u32,
    /// One past the last sample index.
    pub end: u32,
    /// Calibrated accelerometer mean of the window before (specific force, reference units).
    pub g_start: [f32; 3],
    /// Calibrated accelerometer mean of the window after.
    pub g_end: [f32; 3],
}

/// The motions between consecutive static windows (as found by
/// [`crate::static_detect::StaticDetector`] on the accelerometer), with gravity directions
/// from the accelerometer calibration `accel`. Windows must be in time order and not overlap
/// ([`Error::InvalidParameter`] otherwise).
pub fn motion_spans<'a>(
    windows: &'a [StaticInterval],
    accel: &'a Calibration,
) -> impl Iterator<Item = Result<MotionSpan, Error>> + 'a {
    windows.windows(2).map(move |pair| {
        let (a, b) = (&pair[0], &pair[1]);
        if a.end == 0 || a.end > b.start || a.start >= a.end {
            return Err(Error::InvalidParameter);
        }
        Ok(MotionSpan {
            start: a.end - 1,
            end: b.start + 1,
            g_start: accel.correct_linear(a.mean),
            g_end: accel.correct_linear(b.mean),
        })
    })
}

/// Which gyro parameters are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroModel {
    /// Nothing from the motions: the nominal scale with the bias from rest (unless
    /// [`GyroFitConfig::fit_bias`]).
    BiasOnly,
    /// One scale per axis (the diagonal of `P`): 3 parameters.
    Scale,
    /// Scale and misalignment (all of `P`): 9 parameters.
    Full,
}

impl GyroModel {
    /// Whether parameter `k` (order of [`crate::gyro::NPARAM`]) is free.
    fn free(self, k: usize, fit_bias: bool) -> bool {
        match k {
            0..=8 => match self {
                GyroModel::BiasOnly => false,
                GyroModel::Scale => matches!(k, 0 | 4 | 8),
                GyroModel::Full => true,
            },
            _ => fit_bias,
        }
    }

    /// The free-parameter mask.
    pub fn mask(self, fit_bias: bool) -> [bool; NPARAM] {
        core::array::from_fn(|k| self.free(k, fit_bias))
    }
}

/// Fit settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroFitConfig<T: RealField + Copy> {
    /// Which parameters to fit.
    pub model: GyroModel,
    /// Also fit a bias correction (3 more parameters) instead of trusting the bias from rest.
    pub fit_bias: bool,
    /// Sample period, s.
    pub dt: T,
    /// Iteration budget of Levenberg–Marquardt.
    pub max_iterations: u32,
}

/// Result of a gyro fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroFit<T: RealField + Copy> {
    /// The fitted calibration (raw → rad/s).
    pub calibration: GyroCalibration<T>,
    /// The fitted adjustment of the nominal calibration.
    pub adjustment: Adjustment<T>,
    /// RMS over the fitted motions of the gravity angle error with the nominal calibration, rad.
    pub rms_before: T,
    /// The same with the fitted calibration, rad.
    pub rms_after: T,
    /// Motions used.
    pub motions: u32,
    /// LM iterations.
    pub iterations: u32,
    /// Smallest eigenvalue of the unit-diagonal normal matrix of the free parameters (1 for
    /// independent parameters, near 0 when the motions barely determine some combination);
    /// 1 when nothing is fitted.
    pub identifiability: T,
    /// `JᵀJ` of the motions used, at the fit (all 12 parameters; rows and columns of the fixed
    /// ones are zero): with [`GyroFit::gradient`] what [`leave_one_out_one_step`] starts from.
    pub normal: M12<T>,
    /// `Jᵀr` at the fit (zero for the fixed parameters).
    pub gradient: V12<T>,
}

/// The gyro fit as an [`lm::Problem`]: observation `3k + c` is component `c` of the gravity
/// residual of the `k`-th motion used (all but `exclude`).
pub struct GyroProblem<'m, 'a, T: RealField + Copy> {
    motions: &'m [Motion<'a, T>],
    nominal: GyroCalibration<T>,
    dt: T,
    /// Parameters whose sensitivities are integrated (the free ones).
    tracked: [bool; NPARAM],
    exclude: Option<usize>,
    /// The last motion integrated: its index, the parameters, whether with sensitivities.
    cache: RefCell<Option<Cached<T>>>,
}

/// One integrated motion: its index, the parameters, whether with sensitivities, the result.
type Cached<T> = (usize, V12<T>, bool, MotionResidual<T>);

impl<'m, 'a, T: RealField + Copy> GyroProblem<'m, 'a, T> {
    /// The problem over `motions` (but `exclude`), sensitivities for the `tracked` parameters.
    /// Checks the input once, so that evaluations cannot fail on data: every sample finite,
    /// every gravity direction finite and non-zero, `dt > 0`, `nominal` invertible.
    pub fn new(
        motions: &'m [Motion<'a, T>],
        nominal: GyroCalibration<T>,
        dt: T,
        tracked: [bool; NPARAM],
        exclude: Option<usize>,
    ) -> Result<Self, Error> {
        nominal.validate()?;
        if !(dt.is_finite() && dt > T::zero()) {
            return Err(Error::InvalidParameter);
        }
        for m in motions {
            let finite = |v: &Vector3<T>| v.iter().all(|x| x.is_finite());
            if !m.samples.iter().all(|s| s.iter().all(|x| x.is_finite()))
                || !finite(&m.g_start)
                || !finite(&m.g_end)
            {
                return Err(Error::NonFinite);
            }
            if m.g_start.norm() == T::zero() || m.g_end.norm() == T::zero() {
                return Err(Error::InvalidParameter);
            }
        }
        Ok(Self {
            motions,
            nominal,
            dt,
            tracked,
            exclude,
            cache: RefCell::new(None),
        })
    }

    /// Motion index of the `k`-th motion used.
    fn motion_index(&self, k: usize) -> usize {
        match self.exclude {
            Some(e) if k >= e => k + 1,
            _ => k,
        }
    }

    /// The residual of motion `index` at `p` (from the cache when possible). A failure (only
    /// possible for non-finite parameters, the input was checked) gives NaN, which the solver
    /// treats as a rejected step.
    fn motion(&self, index: usize, p: &V12<T>, with_jacobian: bool) -> MotionResidual<T> {
        if let Some((i, q, j, out)) = self.cache.borrow().as_ref() {
            if *i == index && q == p && (*j || !with_jacobian) {
                return *out;
            }
        }
        let tracked = if with_jacobian {
            self.tracked
        } else {
            [false; NPARAM]
        };
        let out = self.integrate(index, p, tracked).unwrap_or_else(|_| {
            let nan = T::zero() / T::zero();
            MotionResidual {
                residual: Vector3::repeat(nan),
                jacobian: SMatrix::repeat(nan),
                angle: nan,
                rotation: nalgebra::Vector4::repeat(nan),
            }
        });
        *self.cache.borrow_mut() = Some((index, *p, with_jacobian, out));
        out
    }

    fn integrate(
        &self,
        index: usize,
        p: &V12<T>,
        tracked: [bool; NPARAM],
    ) -> Result<MotionResidual<T>, Error> {
        let m = self.motions.get(index).ok_or(Error::InvalidParameter)?;
        let adj = Adjustment::from_params(p);
        let mut integ = MotionIntegrator::new(self.nominal, adj, self.dt, tracked)?;
        for s in m.samples {
            integ.push(s)?;
        }
        integ.finish(&m.g_start, &m.g_end)
    }
}

impl<T: RealField + Copy> Problem<T, NPARAM> for GyroProblem<'_, '_, T> {
    fn observations(&self) -> usize {
        let n = self.motions.len();
        3 * match self.exclude {
            Some(e) if e < n => n - 1,
            _ => n,
        }
    }

    fn residual_and_gradient(&self, p: &V12<T>, i: usize) -> (T, V12<T>) {
        let out = self.motion(self.motion_index(i / 3), p, true);
        (out.residual[i % 3], out.jacobian.row(i % 3).transpose())
    }

    fn residual(&self, p: &V12<T>, i: usize) -> T {
        self.motion(self.motion_index(i / 3), p, false).residual[i % 3]
    }
}

/// Angle error of one motion under calibration `cal`, rad.
pub fn motion_angle<T: RealField + Copy>(
    motion: &Motion<'_, T>,
    cal: &GyroCalibration<T>,
    dt: T,
) -> Result<T, Error> {
    let mut integ = MotionIntegrator::for_calibration(*cal, dt)?;
    for m in motion.samples {
        integ.push(m)?;
    }
    Ok(integ.finish(&motion.g_start, &motion.g_end)?.angle)
}

/// RMS angle error over the motions (all but `exclude`), rad.
pub fn rms_angle<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    cal: &GyroCalibration<T>,
    dt: T,
    exclude: Option<usize>,
) -> Result<T, Error> {
    let mut sum = T::zero();
    let mut n = 0u32;
    for (i, motion) in motions.iter().enumerate() {
        if Some(i) != exclude {
            let a = motion_angle(motion, cal, dt)?;
            sum += a * a;
            n += 1;
        }
    }
    if n == 0 {
        return Err(Error::TooFewPoses { needed: 2, got: 0 });
    }
    Ok((sum / nalgebra::convert(f64::from(n))).sqrt())
}

/// Smallest eigenvalue of the unit-diagonal normal matrix restricted to the free parameters.
fn identifiability<T: RealField + Copy>(jtj: &M12<T>, free: &[bool; NPARAM]) -> T {
    let mut scaled = M12::<T>::identity();
    for a in (0..NPARAM).filter(|k| free[*k]) {
        for b in (0..NPARAM).filter(|k| free[*k]) {
            let d = (jtj[(a, a)] * jtj[(b, b)]).sqrt();
            scaled[(a, b)] = if d > T::zero() {
                jtj[(a, b)] / d
            } else {
                T::zero()
            };
        }
    }
    nalgebra::SymmetricEigen::new(scaled).eigenvalues.min()
}

/// Fits the gyro calibration starting from the nominal one (see [`fit_from`]).
pub fn fit<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    cfg: &GyroFitConfig<T>,
    exclude: Option<usize>,
) -> Result<GyroFit<T>, Error> {
    fit_from(motions, nominal, &Adjustment::identity(), cfg, exclude)
}

/// Fits the free parameters of `cfg.model`, starting from `start` (e.g. the all-motion fit
/// when holding one motion out), using every motion but `exclude`.
///
/// Errors: [`Error::TooFewPoses`] when the motions give fewer independent equations (2 per
/// motion: the residual is tangent to the unit sphere) than free parameters;
/// [`Error::NonFinite`] / [`Error::InvalidParameter`] on bad input; [`Error::NotConverged`].
pub fn fit_from<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    start: &Adjustment<T>,
    cfg: &GyroFitConfig<T>,
    exclude: Option<usize>,
) -> Result<GyroFit<T>, Error> {
    fit_inner(motions, nominal, start, cfg, exclude, None, None)
}

/// [`fit_from`] on every motion that also leaves each motion's residual, Jacobian and angle at
/// the fit in `kept` (one entry per motion, `kept.len() == motions.len()`), as
/// [`leave_one_out_one_step`] needs them.
pub fn fit_keeping<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    start: &Adjustment<T>,
    cfg: &GyroFitConfig<T>,
    kept: &mut [MotionResidual<T>],
) -> Result<GyroFit<T>, Error> {
    if kept.len() != motions.len() {
        return Err(Error::InvalidParameter);
    }
    fit_inner(motions, nominal, start, cfg, None, Some(kept), None)
}

/// The motions integrated once at the nominal calibration (identity adjustment) with all 12
/// sensitivities. Every model's fit from the nominal starts with this evaluation restricted to
/// its free parameters, bit for bit (a parameter's sensitivity sums do not depend on which
/// others are tracked), so candidate models can share one pass
/// ([`fit_keeping_from_nominal`]) instead of integrating the same start once each.
#[derive(Debug, Clone, Copy)]
pub struct NominalPass<T: RealField + Copy> {
    nominal: GyroCalibration<T>,
    dt: T,
    ev: Evaluation<T>,
}

/// [`NominalPass`] of `motions`, each motion's residual and Jacobian (all 12 columns) left in
/// `kept` (`kept.len() == motions.len()`).
pub fn nominal_pass<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    dt: T,
    kept: &mut [MotionResidual<T>],
) -> Result<NominalPass<T>, Error> {
    if kept.len() != motions.len() {
        return Err(Error::InvalidParameter);
    }
    let problem = GyroProblem::new(motions, *nominal, dt, [true; NPARAM], None)?;
    let ev = evaluate(&problem, &Adjustment::identity().to_params(), Some(kept));
    if !ev.cost.is_finite() {
        return Err(Error::NonFinite);
    }
    Ok(NominalPass {
        nominal: *nominal,
        dt,
        ev,
    })
}

/// [`fit_keeping`] from the nominal calibration, its first evaluation taken from `pass`:
/// `kept` must hold what [`nominal_pass`] left (a copy per model); the result is identical to
/// [`fit_keeping`] from [`Adjustment::identity`]. [`Error::InvalidParameter`] when `pass` was
/// made with another nominal or sample period.
pub fn fit_keeping_from_nominal<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    cfg: &GyroFitConfig<T>,
    pass: &NominalPass<T>,
    kept: &mut [MotionResidual<T>],
) -> Result<GyroFit<T>, Error> {
    if kept.len() != motions.len() || pass.dt != cfg.dt {
        return Err(Error::InvalidParameter);
    }
    let free = cfg.model.mask(cfg.fit_bias);
    for k in kept.iter_mut() {
        for c in (0..NPARAM).filter(|c| !free[*c]) {
            k.jacobian.column_mut(c).fill(T::zero());
        }
    }
    let mut first = pass.ev;
    for a in 0..NPARAM {
        for b in 0..NPARAM {
            if !(free[a] && free[b]) {
                first.jtj[(a, b)] = T::zero();
            }
        }
        if !free[a] {
            first.jtr[a] = T::zero();
        }
    }
    let start = Adjustment::identity();
    fit_inner(
        motions,
        &pass.nominal,
        &start,
        cfg,
        None,
        Some(kept),
        Some(first),
    )
}

/// All motions (but `exclude`) integrated at `p` with the sensitivities of `tracked`.
#[derive(Debug, Clone, Copy)]
struct Evaluation<T: RealField + Copy> {
    jtj: M12<T>,
    jtr: V12<T>,
    /// `Σ‖r‖²` (NaN when an integration failed: only for non-finite parameters).
    cost: T,
    /// `Σ angle²`, rad².
    angle_sq: T,
}

fn evaluate<T: RealField + Copy>(
    problem: &GyroProblem<'_, '_, T>,
    p: &V12<T>,
    mut kept: Option<&mut [MotionResidual<T>]>,
) -> Evaluation<T> {
    let mut ev = Evaluation {
        jtj: M12::zeros(),
        jtr: V12::zeros(),
        cost: T::zero(),
        angle_sq: T::zero(),
    };
    for i in (0..problem.motions.len()).filter(|i| Some(*i) != problem.exclude) {
        let Ok(out) = problem.integrate(i, p, problem.tracked) else {
            ev.cost = T::zero() / T::zero();
            return ev;
        };
        let jt = out.jacobian.transpose();
        ev.jtj += jt * out.jacobian;
        ev.jtr += jt * out.residual;
        ev.cost += out.residual.norm_squared();
        ev.angle_sq += out.angle * out.angle;
        if let Some(k) = kept.as_deref_mut() {
            k[i] = out;
        }
    }
    ev
}

/// Levenberg–Marquardt with the multi-position schedule ([`LmSettings::multipos`]; the same
/// steps as [`lm::minimize`] on [`GyroProblem`]), except that every trial point is integrated
/// with its sensitivities at once: an accepted trial's Jacobian is the next iteration's, so
/// each iteration costs one pass over the motions instead of a pass with sensitivities and a
/// pass without, and the last pass is at the fit (for the identifiability and `kept`).
fn fit_inner<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    start: &Adjustment<T>,
    cfg: &GyroFitConfig<T>,
    exclude: Option<usize>,
    mut kept: Option<&mut [MotionResidual<T>]>,
    shared_first: Option<Evaluation<T>>,
) -> Result<GyroFit<T>, Error> {
    nominal.validate()?;
    let free = cfg.model.mask(cfg.fit_bias);
    let nfree = free.iter().filter(|f| **f).count() as u32;
    let used = motions
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != exclude)
        .count() as u32;
    if used == 0 || 2 * used < nfree {
        return Err(Error::TooFewPoses {
            needed: nfree.div_ceil(2).max(1),
            got: used,
        });
    }
    let identity = Adjustment::<T>::identity().to_params();
    let mut x = start.to_params();
    for k in (0..NPARAM).filter(|k| !free[*k]) {
        x[k] = identity[k];
    }
    let problem = GyroProblem::new(motions, *nominal, cfg.dt, free, exclude)?;
    let first = match shared_first {
        Some(ev) => ev,
        None => evaluate(&problem, &x, kept.as_deref_mut()),
    };
    if !first.cost.is_finite() {
        return Err(Error::NonFinite);
    }
    let n: T = nalgebra::convert(f64::from(used));
    let rms_before = if x == identity {
        (first.angle_sq / n).sqrt()
    } else {
        rms_angle(motions, nominal, cfg.dt, exclude)?
    };
    let settings = LmSettings::multipos(cfg.max_iterations);
    let (x, ev, iterations) = if nfree == 0 {
        (x, first, 0)
    } else {
        let (x, ev, iterations, stale) =
            levenberg_marquardt(&problem, x, first, &settings, &mut kept)?;
        if stale {
            // A rejected trial overwrote the kept residuals: once more at the fit.
            evaluate(&problem, &x, kept);
        }
        (x, ev, iterations)
    };
    let adjustment = Adjustment::from_params(&x);
    let identifiability = if nfree == 0 {
        T::one()
    } else {
        identifiability(&ev.jtj, &free)
    };
    Ok(GyroFit {
        calibration: adjustment.apply(nominal)?,
        adjustment,
        rms_before,
        rms_after: (ev.angle_sq / n).sqrt(),
        motions: used,
        iterations,
        identifiability,
        normal: ev.jtj,
        gradient: ev.jtr,
    })
}

/// The iterations of [`fit_inner`]: returns the parameters, their evaluation, the number of
/// iterations, and whether `kept` holds a rejected trial instead of the fit.
fn levenberg_marquardt<T: RealField + Copy>(
    problem: &GyroProblem<'_, '_, T>,
    mut x: V12<T>,
    mut ev: Evaluation<T>,
    s: &LmSettings<T>,
    kept: &mut Option<&mut [MotionResidual<T>]>,
) -> Result<(V12<T>, Evaluation<T>, u32, bool), Error> {
    let free = problem.tracked;
    let mut lambda = s.initial_damping;
    let mut stale = false;
    for iteration in 1..=s.max_iterations {
        let (mut jtj, mut jtr) = (ev.jtj, ev.jtr);
        lm::pin_fixed(&mut jtj, &mut jtr, &free);
        if s.gradient_tol.is_some_and(|tol| jtr.amax() <= tol) {
            return Ok((x, ev, iteration, stale));
        }
        let mut accepted = false;
        for _ in 0..s.max_inner {
            let mut a = jtj;
            for i in 0..NPARAM {
                a[(i, i)] += lambda * jtj[(i, i)].max(s.diagonal_floor);
            }
            let Some(chol) = nalgebra::Cholesky::new(a) else {
                lambda *= s.damping_up_singular;
                continue;
            };
            let step = chol.solve(&(-jtr));
            let candidate = x + step;
            let trial = evaluate(problem, &candidate, kept.as_deref_mut());
            if trial.cost.is_finite() && trial.cost <= ev.cost {
                let lm::StepTest::MaxNorm { rel } = s.step_test else {
                    return Err(Error::InvalidParameter);
                };
                let small_step = step.amax() <= rel * (x.amax() + rel);
                let small_gain = ev.cost - trial.cost <= s.gain_tol * ev.cost + s.gain_abs;
                (x, ev, stale) = (candidate, trial, false);
                lambda = (lambda * s.damping_down).max(s.min_damping);
                accepted = true;
                if s.param_bound
                    .is_some_and(|b| (0..NPARAM).any(|j| free[j] && x[j].abs() > b))
                {
                    return Err(Error::Diverged);
                }
                if small_step || small_gain {
                    return Ok((x, ev, iteration, stale));
                }
                break;
            }
            stale = kept.is_some();
            lambda *= s.damping_up;
        }
        if !accepted {
            // No trial lowers the cost: at the minimum within the float resolution.
            return Ok((x, ev, iteration, stale));
        }
    }
    let far = s.param_bound.is_some_and(|bound| {
        let limit = bound / nalgebra::convert(10.0);
        (0..NPARAM).any(|j| free[j] && x[j].abs() > limit)
    });
    Err(if far {
        Error::Diverged
    } else {
        Error::NotConverged
    })
}

/// Leave-one-motion-out by one Gauss–Newton step from the all-motion fit instead of a refit
/// per motion: with `H = JᵀJ` and `g = Jᵀr` of all motions at the fit (`fit.normal`,
/// `fit.gradient`), motion `i`'s held-out parameters are `p − (H − JᵢᵀJᵢ)⁻¹(g − Jᵢᵀrᵢ)`, and
/// its held-out angle is then integrated exactly at those parameters. The refit's objective
/// differs from the full one by one motion of 3 observations, so its minimum lies close to the
/// full fit's and one step lands on it to second order. `kept` are the motions' residuals and
/// Jacobians at the fit ([`fit_keeping`]), so the cost is one pass over the motions without
/// sensitivities, against one full Levenberg–Marquardt fit per motion for [`leave_one_out`]
/// (with nothing fitted, the held-out angles are the kept ones). A motion without which the
/// normal matrix is singular (it alone determines a parameter) falls back to the exact refit.
/// Returns the RMS of the held-out angles, rad; `per_motion(i, angle)` sees each.
pub fn leave_one_out_one_step<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    fit: &GyroFit<T>,
    cfg: &GyroFitConfig<T>,
    kept: &[MotionResidual<T>],
    per_motion: impl FnMut(usize, T),
) -> Result<T, Error> {
    let free = cfg.model.mask(cfg.fit_bias);
    let p = fit.adjustment.to_params();
    let held_out = |i: usize, motion: &Motion<'_, T>| {
        // One residual per motion, checked before the first one is held out.
        let own = kept
            .get(i)
            .filter(|_| kept.len() == motions.len())
            .ok_or(Error::InvalidParameter)?;
        if !free.iter().any(|f| *f) {
            return Ok(own.angle);
        }
        let jt = own.jacobian.transpose();
        let h = fit.normal - jt * own.jacobian;
        let mut g = fit.gradient - jt * own.residual;
        for k in (0..NPARAM).filter(|k| !free[*k]) {
            g[k] = T::zero();
        }
        // A pivot that loses all but ~3 digits: the motion alone determined a parameter.
        let rel_pivot = T::default_epsilon() * nalgebra::convert(1000.0);
        let cal = match lm::factor_normal(&h, &free, rel_pivot) {
            Some(chol) => Adjustment::from_params(&(p - chol.solve(&g))).apply(nominal)?,
            None => fit_from(motions, nominal, &fit.adjustment, cfg, Some(i))?.calibration,
        };
        motion_angle(motion, &cal, cfg.dt)
    };
    held_out_rms(motions, held_out, per_motion)
}

/// What both leave-one-out variants share: at least two motions; each motion's held-out angle
/// (`held_out(i, motion)`, rad) goes to `per_motion(i, angle)` and into the returned RMS, rad.
fn held_out_rms<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    mut held_out: impl FnMut(usize, &Motion<'_, T>) -> Result<T, Error>,
    mut per_motion: impl FnMut(usize, T),
) -> Result<T, Error> {
    if motions.len() < 2 {
        return Err(Error::TooFewPoses {
            needed: 2,
            got: motions.len() as u32,
        });
    }
    let mut sum = T::zero();
    for (i, motion) in motions.iter().enumerate() {
        let a = held_out(i, motion)?;
        per_motion(i, a);
        sum += a * a;
    }
    Ok((sum / nalgebra::convert(motions.len() as f64)).sqrt())
}

/// Leave-one-motion-out: for each motion, fit on the others (starting from `start`) and
/// measure the angle error on the one held out. Returns the RMS of the held-out angles, rad.
/// `per_motion(i, angle)` sees each held-out angle.
pub fn leave_one_out<T: RealField + Copy>(
    motions: &[Motion<'_, T>],
    nominal: &GyroCalibration<T>,
    start: &Adjustment<T>,
    cfg: &GyroFitConfig<T>,
    per_motion: impl FnMut(usize, T),
) -> Result<T, Error> {
    let held_out = |i: usize, motion: &Motion<'_, T>| {
        let refit = fit_from(motions, nominal, start, cfg, Some(i))?;
        motion_angle(motion, &refit.calibration, cfg.dt)
    };
    held_out_rms(motions, held_out, per_motion)
}
