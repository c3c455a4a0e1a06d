//! Levenberg–Marquardt for small fixed-size least-squares problems, generic over the float
//! type: `f32` on the device, `f64` in the host's analysis.
//!
//! The same solver serves the 9-parameter multi-position fit (`multipos`, `f32`,
//! bit-identical to the hand-written loop it replaced) and any larger model built on it, e.g.
//! the residual analysis's 27-parameter effect model in `f64`. Like ahrs-rs's
//! `Madgwick<N: RealField>`, everything is generic over nalgebra's [`RealField`] (`+ Copy`);
//! for `f32` every operation is the same IEEE operation as a hand-written `f32` loop (`sqrt`
//! goes to `libm::sqrtf`, correctly rounded like the FPU's `vsqrt`), so no private float
//! trait is needed. Constants are written as `f64` and converted with [`lit`]; a unit test
//! checks that each converts to exactly the `f32` literal the old code used.
//!
//! ## The problem
//! A [`Problem`] has `observations()` scalar residuals `r_i(p)` over a parameter vector
//! `p ∈ Tᴺ` (`N` a const generic) and gives each residual with its gradient `∂r_i/∂p`. The
//! solver minimises `Σ_i w_i r_i²` with optional non-negative weights `w_i` (0 drops an
//! observation) over the parameters marked free in a mask (`[bool; N]`); fixed parameters keep
//! their starting value. No allocation: observations are indexed, the normal equations are an
//! `N×N` matrix on the stack.
//!
//! ## The schedule
//! Per iteration: normal equations `JᵀWJ`, `JᵀWr` (fixed parameters pinned: zero row and
//! column, unit diagonal); stop if `max|JᵀWr| ≤ gradient_tol`; then up to `max_inner` trials of
//! `(JᵀWJ + λ·diag(max(JᵀWJ_ii, diagonal_floor)))·δ = −JᵀWr` (Cholesky): a failed
//! factorisation multiplies `λ` by `damping_up_singular`, a step that raises the cost by
//! `damping_up`; an accepted step multiplies `λ` by `damping_down` (not below `min_damping`)
//! and ends the fit when the step or the cost gain is below tolerance ([`StepTest`],
//! `gain_tol`). When no trial lowers the cost the fit is at its minimum to within the float
//! type's resolution ([`LmSettings::stall_limit`]). All of these are named fields of
//! [`LmSettings`]; [`LmSettings::multipos_f32`] is the multi-position fit's schedule.
//!
//! ## What a fit gives besides the minimum
//! [`normal_equations`] (the Gauss–Newton matrix `JᵀWJ` at the solution), [`standard_errors`]
//! (`σ̂²·(JᵀWJ)⁻¹`, `σ̂² = RSS/(n − k)`), [`leverage`] (`gᵢᵀ(JᵀWJ)⁻¹gᵢ` of one observation) and
//! [`loo_residuals`] (leave-one-out residuals by refitting without each observation).
//!
//! ## Plugging in a model
//! Implement [`Problem`] for a type holding the observations (borrowed slices; for the
//! analysis's effect model: the normalised window means, times and temperatures) with
//! `N` = the number of parameters of the full model (27 for the 9 base parameters plus six
//! effect blocks of 3); choose the free ones with the mask. What the hand-written `f64` solver
//! of the analysis did maps as follows:
//!
//! | analysis | here |
//! |---|---|
//! | `fit_weighted(p0, mask, wins, used)` | [`minimize`] with `Some(weights)` and [`LmSettings::default`], then [`factor_normal`]`(&`[`normal_equations`]`(..).0, mask, REL_PIVOT_F64)` to refuse a singular minimum |
//! | `fit(p0, mask, wins, used: &[bool])` | the same with weights 1.0 / 0.0 |
//! | `standard_errors` | [`standard_errors`] |
//! | `leverage(p, mask, wins, used, i)` | [`leverage`] |
//! | `loo` | [`loo_residuals`] (the caller provides the output slice) |
//!
//! [`LmSettings::default`] is that solver's schedule (its one difference: the cost-gain test
//! is relative to the cost before the step, not after, which only matters for gains within
//! `1e-30` of the cost). A 12-parameter example (the multi-position model plus a per-axis
//! quadratic) checked against an independent solver is in `crates/core/tests/lm_model.rs`;
//! the smallest possible one follows.
//!
//! ```
//! use nalgebra::SVector;
//! use wiical_core::lm::{self, LmSettings, Problem};
//!
//! /// Fit y = a·exp(b·x) to points (x, y).
//! struct Exp<'a>(&'a [(f64, f64)]);
//! impl Problem<f64, 2> for Exp<'_> {
//!     fn observations(&self) -> usize {
//!         self.0.len()
//!     }
//!     fn residual_and_gradient(&self, p: &SVector<f64, 2>, i: usize) -> (f64, SVector<f64, 2>) {
//!         let (x, y) = self.0[i];
//!         let e = (p[1] * x).exp();
//!         (p[0] * e - y, SVector::<f64, 2>::new(e, p[0] * x * e))
//!     }
//! }
//! let pts: Vec<(f64, f64)> = (0..10).map(|i| (i as f64 * 0.1, 2.0 * (0.5 * i as f64 * 0.1).exp())).collect();
//! let p0 = SVector::<f64, 2>::new(1.0, 0.0);
//! let fit = lm::minimize(&Exp(&pts), p0, &[true; 2], None, &LmSettings::default())
//!     .unwrap();
//! assert!((fit.params[0] - 2.0).abs() < 1e-9 && (fit.params[1] - 0.5).abs() < 1e-9);
//! ```

use nalgebra::{Cholesky, Const, RealField, SMatrix, SVector};

use crate::Error;

/// A least-squares problem: `observations()` scalar residuals over `N` parameters.
pub trait Problem<T: RealField + Copy, const N: usize> {
    /// Number of observations (residuals).
    fn observations(&self) -> usize;

    /// Residual `r_i(p)` of observation `i < observations()` and its gradient `∂r_i/∂p`.
    fn residual_and_gradient(&self, p: &SVector<T, N>, i: usize) -> (T, SVector<T, N>);

    /// Residual only; by default the first half of [`Problem::residual_and_gradient`].
    #[inline]
    fn residual(&self, p: &SVector<T, N>, i: usize) -> T {
        self.residual_and_gradient(p, i).0
    }
}

/// Converts an `f64` constant to `T` (exact for `f64`; for `f32` the nearest `f32`, which for
/// every constant of this crate equals the `f32` literal — a unit test checks it).
#[inline]
pub fn lit<T: RealField + Copy>(x: f64) -> T {
    nalgebra::convert(x)
}

/// When an accepted step is small enough to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepTest<T> {
    /// `max_j |δ_j| ≤ rel · (max_j |p_j| + rel)` over all parameters (the multi-position fit).
    MaxNorm {
        /// Relative tolerance.
        rel: T,
    },
    /// `|δ_j| ≤ rel · (1 + |p_j|)` for every free parameter.
    PerParameter {
        /// Relative tolerance.
        rel: T,
    },
}

/// The damping schedule and stopping rules (see the module docs for how they are used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmSettings<T> {
    /// Starting damping `λ`.
    pub initial_damping: T,
    /// Factor on `λ` after a step that raised the cost.
    pub damping_up: T,
    /// Factor on `λ` when the damped matrix could not be factored.
    pub damping_up_singular: T,
    /// Factor on `λ` after an accepted step.
    pub damping_down: T,
    /// Lower bound of `λ` after an accepted step.
    pub min_damping: T,
    /// Floor of the diagonal entries the damping is proportional to (a parameter with no
    /// sensitivity still gets some damping).
    pub diagonal_floor: T,
    /// Stop (converged) when `max|JᵀWr| ≤ gradient_tol`; `None` skips the test.
    pub gradient_tol: Option<T>,
    /// Stop after an accepted step this small.
    pub step_test: StepTest<T>,
    /// Stop after an accepted step whose cost gain is `≤ gain_tol · cost_before + gain_abs`.
    pub gain_tol: T,
    /// Absolute part of the gain test.
    pub gain_abs: T,
    /// Outer iterations before [`Error::NotConverged`].
    pub max_iterations: u32,
    /// Damping trials per iteration.
    pub max_inner: u32,
    /// When no trial lowers the cost: `None` means converged (at the minimum within the float
    /// resolution); `Some(x)` means converged only if `λ < x`, else [`Error::NotConverged`]
    /// (the damped system was never solvable).
    pub stall_limit: Option<T>,
    /// Stop with [`Error::Diverged`] as soon as an accepted step leaves some free parameter
    /// with `|p_j| > bound` (a problem whose cost keeps falling towards infinity); `None`: no
    /// bound.
    pub param_bound: Option<T>,
}

/// Parameter bound of the multi-position schedule, in its normalised units: a bias 100 pose
/// spreads away from the poses' centre (a sphere whose radius is ~100× the poses' spread, i.e.
/// poses within ~1° of each other as seen from its centre) is a fit running off to
/// infinity, not a sensor.
pub const MULTIPOS_PARAM_BOUND: f64 = 1e2;

/// When the iteration budget runs out with a free parameter beyond `param_bound / 10`, the
/// error is [`Error::Diverged`] rather than [`Error::NotConverged`].
const RUNAWAY_FRACTION_INV: f64 = 10.0;

impl LmSettings<f32> {
    /// The multi-position fit's schedule (`multipos::fit` since the first release):
    /// `λ₀ = 1e-3`, ×4 on a rejected step, ×10 on a failed factorisation, ×0.3 (≥ 1e-9) on an
    /// accepted one, gradient 1e-12, step 1e-7 (max-norm), gain 1e-9, 30 trials.
    pub fn multipos_f32(max_iterations: u32) -> Self {
        LmSettings::multipos(max_iterations)
    }
}

impl<T: RealField + Copy> LmSettings<T> {
    /// The multi-position fit's schedule in any float type (see [`LmSettings::multipos_f32`]).
    pub fn multipos(max_iterations: u32) -> Self {
        Self {
            initial_damping: lit(1e-3),
            damping_up: lit(4.0),
            damping_up_singular: lit(10.0),
            damping_down: lit(0.3),
            min_damping: lit(1e-9),
            diagonal_floor: lit(1e-12),
            gradient_tol: Some(lit(1e-12)),
            step_test: StepTest::MaxNorm { rel: lit(1e-7) },
            gain_tol: lit(1e-9),
            gain_abs: T::zero(),
            max_iterations,
            max_inner: 30,
            stall_limit: None,
            param_bound: Some(lit(MULTIPOS_PARAM_BOUND)),
        }
    }
}

impl Default for LmSettings<f64> {
    /// A tight `f64` schedule (the analysis's): `λ₀ = 1e-4`, ×4 / ×10 up, ×0.2 (≥ 1e-12) down,
    /// per-parameter step 1e-12, gain 1e-15, 200 iterations of 40 trials, and a stall counts as
    /// converged only while `λ < 1e20`.
    fn default() -> Self {
        Self {
            initial_damping: 1e-4,
            damping_up: 4.0,
            damping_up_singular: 10.0,
            damping_down: 0.2,
            min_damping: 1e-12,
            diagonal_floor: 1e-300,
            gradient_tol: None,
            step_test: StepTest::PerParameter { rel: 1e-12 },
            gain_tol: 1e-15,
            gain_abs: 1e-300,
            max_iterations: 200,
            max_inner: 40,
            stall_limit: Some(1e20),
            param_bound: None,
        }
    }
}

/// Result of [`minimize`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmFit<T: RealField + Copy, const N: usize> {
    /// Parameters at the minimum.
    pub params: SVector<T, N>,
    /// Weighted residual sum of squares `Σ w_i r_i²` at the minimum.
    pub cost: T,
    /// Outer iterations used.
    pub iterations: u32,
    /// Observations with positive weight.
    pub used: usize,
    /// Free parameters.
    pub free: usize,
}

/// Weight of observation `i`: 1 without weights, 0 for the skipped one.
#[inline]
fn weight_of<T: RealField + Copy>(weights: Option<&[T]>, skip: Option<usize>, i: usize) -> T {
    if skip == Some(i) {
        return T::zero();
    }
    weights.map_or(T::one(), |w| w[i])
}

/// Weighted cost `Σ w_i r_i²` (observations with zero weight are not evaluated).
pub fn cost<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p: &SVector<T, N>,
    weights: Option<&[T]>,
) -> T {
    cost_skipping(problem, p, weights, None)
}

fn cost_skipping<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p: &SVector<T, N>,
    weights: Option<&[T]>,
    skip: Option<usize>,
) -> T {
    let mut cost = T::zero();
    let filtered = weights.is_some() || skip.is_some();
    for i in 0..problem.observations() {
        let w = weight_of(weights, skip, i);
        if filtered && w == T::zero() {
            continue;
        }
        let r = problem.residual(p, i);
        cost += w * r * r;
    }
    cost
}

/// Normal equations `JᵀWJ` (full symmetric matrix) and `JᵀWr` over all `N` parameters at `p`.
pub fn normal_equations<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p: &SVector<T, N>,
    weights: Option<&[T]>,
) -> (SMatrix<T, N, N>, SVector<T, N>) {
    normal_skipping(problem, p, weights, None)
}

fn normal_skipping<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p: &SVector<T, N>,
    weights: Option<&[T]>,
    skip: Option<usize>,
) -> (SMatrix<T, N, N>, SVector<T, N>) {
    let mut jtj = SMatrix::<T, N, N>::zeros();
    let mut jtr = SVector::<T, N>::zeros();
    let filtered = weights.is_some() || skip.is_some();
    for i in 0..problem.observations() {
        let w = weight_of(weights, skip, i);
        if filtered && w == T::zero() {
            continue;
        }
        let (r, j) = problem.residual_and_gradient(p, i);
        // Symmetric rank-1 update of the upper triangle, mirrored below.
        for a in 0..N {
            let wa = w * j[a];
            jtr[a] += wa * r;
            for b in a..N {
                jtj[(a, b)] += wa * j[b];
            }
        }
    }
    for a in 0..N {
        for b in 0..a {
            jtj[(a, b)] = jtj[(b, a)];
        }
    }
    (jtj, jtr)
}

/// Pins the fixed parameters: zero row and column, unit diagonal, zero gradient (what
/// [`minimize`] does to the normal equations before solving).
pub fn pin_fixed<T: RealField + Copy, const N: usize>(
    jtj: &mut SMatrix<T, N, N>,
    jtr: &mut SVector<T, N>,
    mask: &[bool; N],
) {
    for i in 0..N {
        if !mask[i] {
            for k in 0..N {
                jtj[(i, k)] = T::zero();
                jtj[(k, i)] = T::zero();
            }
            jtj[(i, i)] = T::one();
            jtr[i] = T::zero();
        }
    }
}

fn check_inputs<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    mask: &[bool; N],
    weights: Option<&[T]>,
) -> Result<(usize, usize), Error> {
    let n = problem.observations();
    if let Some(w) = weights {
        if w.len() != n || !w.iter().all(|x| x.is_finite() && *x >= T::zero()) {
            return Err(Error::InvalidParameter);
        }
    }
    let used = weights.map_or(n, |w| w.iter().filter(|x| **x > T::zero()).count());
    let free = mask.iter().filter(|m| **m).count();
    Ok((used, free))
}

/// Levenberg–Marquardt from `p0`, freeing the parameters with `mask[j]`, with optional
/// non-negative per-observation weights.
///
/// Errors: [`Error::InvalidParameter`] (weights of the wrong length, negative or non-finite;
/// a zero iteration budget), [`Error::TooFewPoses`] (fewer used observations than free
/// parameters), [`Error::NonFinite`] (the cost at `p0` is not finite),
/// [`Error::NotConverged`] (iteration budget spent, or `stall_limit` exceeded),
/// [`Error::Diverged`] (a free parameter beyond `param_bound`, or beyond a tenth of it when
/// the budget runs out).
pub fn minimize<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p0: SVector<T, N>,
    mask: &[bool; N],
    weights: Option<&[T]>,
    settings: &LmSettings<T>,
) -> Result<LmFit<T, N>, Error> {
    minimize_skipping(problem, p0, mask, weights, None, settings)
}

fn minimize_skipping<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p0: SVector<T, N>,
    mask: &[bool; N],
    weights: Option<&[T]>,
    skip: Option<usize>,
    s: &LmSettings<T>,
) -> Result<LmFit<T, N>, Error> {
    let (used, free) = check_budget(problem, mask, weights, skip, s)?;
    let cost = cost_skipping(problem, &p0, weights, skip);
    if !cost.is_finite() {
        return Err(Error::NonFinite);
    }
    let mut walk = Walk {
        p: p0,
        cost,
        lambda: s.initial_damping,
    };
    let mut iterations = 0;
    let mut converged = false;
    while iterations < s.max_iterations {
        iterations += 1;
        let (mut jtj, mut jtr) = normal_skipping(problem, &walk.p, weights, skip);
        pin_fixed(&mut jtj, &mut jtr, mask);
        if let Some(tol) = s.gradient_tol {
            if jtr.amax() <= tol {
                converged = true;
                break;
            }
        }
        converged = match damped_step(problem, (weights, skip), &mut walk, (&jtj, &jtr), mask, s)? {
            Some(small) => small,
            None => s.stall_limit.is_none_or(|limit| walk.lambda < limit),
        };
        if converged {
            break;
        }
    }
    if !converged {
        return Err(out_of_budget(&walk.p, mask, s));
    }
    Ok(LmFit {
        params: walk.p,
        cost: walk.cost,
        iterations,
        used,
        free,
    })
}

/// Where the walk stands between iterations: the parameters, their cost and the damping.
/// One value, so that the damping search ([`damped_step`]) moves all three together.
struct Walk<T: RealField + Copy, const N: usize> {
    p: SVector<T, N>,
    cost: T,
    lambda: T,
}

/// The used and free counts of a fit that may start: the inputs pass [`check_inputs`] (one
/// observation fewer when the skipped one has weight), the iteration budget is not zero, and
/// there are at least as many used observations as free parameters. Apart from the loop so
/// that [`minimize_skipping`] reads as the schedule of the module's docs.
fn check_budget<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    mask: &[bool; N],
    weights: Option<&[T]>,
    skip: Option<usize>,
    s: &LmSettings<T>,
) -> Result<(usize, usize), Error> {
    let (mut used, free) = check_inputs(problem, mask, weights)?;
    if let Some(i) = skip {
        if weight_of(weights, None, i) > T::zero() {
            used -= 1;
        }
    }
    if s.max_iterations == 0 {
        return Err(Error::InvalidParameter);
    }
    if used < free {
        return Err(Error::TooFewPoses {
            needed: free as u32,
            got: used as u32,
        });
    }
    Ok((used, free))
}

/// One iteration's damping search on the pinned normal equations `(jtj, jtr)`: up to
/// `max_inner` trials of the damped step, raising `λ` after a failed factorisation or a step
/// that raises the cost. `Some(small)` when a step was taken (`walk` moved to it, `λ`
/// lowered; `small` when its size or cost gain says the fit has converged), `None` when no
/// trial lowered the cost (the caller applies `stall_limit`); [`Error::Diverged`] when the
/// step took a free parameter beyond `param_bound`. The expressions are those of the loop it
/// came from, in the same order: the `f32` fit stays bit-identical.
fn damped_step<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    (weights, skip): (Option<&[T]>, Option<usize>),
    walk: &mut Walk<T, N>,
    (jtj, jtr): (&SMatrix<T, N, N>, &SVector<T, N>),
    mask: &[bool; N],
    s: &LmSettings<T>,
) -> Result<Option<bool>, Error> {
    for _ in 0..s.max_inner {
        let mut a = *jtj;
        for i in 0..N {
            a[(i, i)] += walk.lambda * jtj[(i, i)].max(s.diagonal_floor);
        }
        let Some(chol) = Cholesky::new(a) else {
            walk.lambda *= s.damping_up_singular;
            continue;
        };
        let step = chol.solve(&(-*jtr));
        let candidate = walk.p + step;
        let new_cost = cost_skipping(problem, &candidate, weights, skip);
        if new_cost.is_finite() && new_cost <= walk.cost {
            let small_step = step_is_small(&s.step_test, &step, &walk.p, mask);
            let small_gain = walk.cost - new_cost <= s.gain_tol * walk.cost + s.gain_abs;
            walk.p = candidate;
            walk.cost = new_cost;
            walk.lambda = (walk.lambda * s.damping_down).max(s.min_damping);
            if let Some(bound) = s.param_bound {
                if (0..N).any(|j| mask[j] && walk.p[j].abs() > bound) {
                    return Err(Error::Diverged);
                }
            }
            return Ok(Some(small_step || small_gain));
        }
        walk.lambda *= s.damping_up;
    }
    Ok(None)
}

/// The error of a fit whose iteration budget ran out at `p`: out of budget while far out
/// (a free parameter beyond a tenth of `param_bound`) and still moving is reported as the
/// run-away it is ([`Error::Diverged`]), not as the budget ([`Error::NotConverged`]).
fn out_of_budget<T: RealField + Copy, const N: usize>(
    p: &SVector<T, N>,
    mask: &[bool; N],
    s: &LmSettings<T>,
) -> Error {
    let far = s.param_bound.is_some_and(|bound| {
        let limit = bound / lit(RUNAWAY_FRACTION_INV);
        (0..N).any(|j| mask[j] && p[j].abs() > limit)
    });
    if far {
        Error::Diverged
    } else {
        Error::NotConverged
    }
}

#[inline]
fn step_is_small<T: RealField + Copy, const N: usize>(
    test: &StepTest<T>,
    step: &SVector<T, N>,
    p: &SVector<T, N>,
    mask: &[bool; N],
) -> bool {
    match *test {
        StepTest::MaxNorm { rel } => step.amax() <= rel * (p.amax() + rel),
        StepTest::PerParameter { rel } => {
            (0..N).all(|j| !mask[j] || step[j].abs() <= rel * (T::one() + p[j].abs()))
        }
    }
}

/// Cholesky factor of the free block of `JᵀWJ` (fixed parameters pinned to a unit diagonal),
/// refusing pivots `L_jj² ≤ rel_pivot · A_jj`: the normal matrix of a fit whose free
/// parameters are not all determined by the data.
pub fn factor_normal<T: RealField + Copy, const N: usize>(
    jtj: &SMatrix<T, N, N>,
    mask: &[bool; N],
    rel_pivot: T,
) -> Option<Cholesky<T, Const<N>>> {
    let mut a = *jtj;
    let mut zero = SVector::<T, N>::zeros();
    pin_fixed(&mut a, &mut zero, mask);
    crate::linalg::cholesky_checked(&a, rel_pivot)
}

/// Default relative pivot threshold of [`factor_normal`] for `f64` work.
pub const REL_PIVOT_F64: f64 = 1e-13;

/// Standard errors of the free parameters at a fit: `sqrt(σ̂²·[(JᵀWJ)⁻¹]_jj)` with
/// `σ̂² = cost/(used − free)`; 0 for fixed parameters. `None` when the normal matrix is
/// singular or there are no degrees of freedom left.
pub fn standard_errors<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    fit: &LmFit<T, N>,
    mask: &[bool; N],
    weights: Option<&[T]>,
    rel_pivot: T,
) -> Option<SVector<T, N>> {
    let dof = fit.used.checked_sub(fit.free).filter(|d| *d > 0)?;
    let s2 = fit.cost / lit::<T>(dof as f64);
    let (jtj, _) = normal_equations(problem, &fit.params, weights);
    let chol = factor_normal(&jtj, mask, rel_pivot)?;
    let mut out = SVector::<T, N>::zeros();
    for a in 0..N {
        if !mask[a] {
            continue;
        }
        let mut e = SVector::<T, N>::zeros();
        e[a] = T::one();
        chol.solve_mut(&mut e);
        out[a] = (s2 * e[a]).max(T::zero()).sqrt();
    }
    Some(out)
}

/// Leverage of observation `i` (used in the fit or not) with respect to the observations of
/// positive weight at `p`: `h = gᵢᵀ(JᵀWJ)⁻¹gᵢ` over the free parameters, so that a new
/// observation's prediction error has variance `σ²·(1 + h)`, and a used one's residual
/// `σ²·(1 − w_i h)`. `None` when the normal matrix is singular or `i` is out of range.
pub fn leverage<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    p: &SVector<T, N>,
    mask: &[bool; N],
    weights: Option<&[T]>,
    i: usize,
    rel_pivot: T,
) -> Option<T> {
    if i >= problem.observations() {
        return None;
    }
    let (jtj, _) = normal_equations(problem, p, weights);
    let chol = factor_normal(&jtj, mask, rel_pivot)?;
    let (_, mut g) = problem.residual_and_gradient(p, i);
    for j in 0..N {
        if !mask[j] {
            g[j] = T::zero();
        }
    }
    let x = chol.solve(&g);
    Some(g.dot(&x))
}

/// Leave-one-out residuals: for every observation of positive weight, refit without it (warm
/// start from `fit`) and write its residual at the refit into `out[i]` (`None` for unused
/// observations). `out` must have `observations()` entries. Errors as [`minimize`] for the
/// first refit that fails.
pub fn loo_residuals<T: RealField + Copy, const N: usize, P: Problem<T, N>>(
    problem: &P,
    fit: &LmFit<T, N>,
    mask: &[bool; N],
    weights: Option<&[T]>,
    settings: &LmSettings<T>,
    out: &mut [Option<T>],
) -> Result<(), Error> {
    if out.len() != problem.observations() {
        return Err(Error::InvalidParameter);
    }
    for (i, slot) in out.iter_mut().enumerate() {
        *slot = None;
        if weight_of(weights, None, i) <= T::zero() {
            continue;
        }
        let refit = minimize_skipping(problem, fit.params, mask, weights, Some(i), settings)?;
        *slot = Some(problem.residual(&refit.params, i));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every constant converted with `lit` equals the `f32` literal the hand-written solver
    /// used, so the generic `f32` instantiation is bit-identical.
    #[test]
    fn f32_constants_convert_exactly() {
        let s = LmSettings::<f32>::multipos(200);
        assert_eq!(s.initial_damping.to_bits(), 1e-3f32.to_bits());
        assert_eq!(s.damping_down.to_bits(), 0.3f32.to_bits());
        assert_eq!(s.min_damping.to_bits(), 1e-9f32.to_bits());
        assert_eq!(s.diagonal_floor.to_bits(), 1e-12f32.to_bits());
        assert_eq!(s.gradient_tol.unwrap().to_bits(), 1e-12f32.to_bits());
        assert_eq!(s.gain_tol.to_bits(), 1e-9f32.to_bits());
        let StepTest::MaxNorm { rel } = s.step_test else {
            panic!("multipos uses the max-norm step test")
        };
        assert_eq!(rel.to_bits(), 1e-7f32.to_bits());
        for (x64, x32) in [(1e-4, 1e-4f32), (1e-5, 1e-5f32), (4.0, 4.0), (10.0, 10.0)] {
            assert_eq!(lit::<f32>(x64).to_bits(), x32.to_bits());
        }
    }

    /// Linear problem y = a + b·x: one Gauss–Newton step is exact; standard errors and leverage
    /// against the closed forms of simple linear regression.
    struct Line<'a>(&'a [(f64, f64)]);
    impl Problem<f64, 3> for Line<'_> {
        fn observations(&self) -> usize {
            self.0.len()
        }
        fn residual_and_gradient(&self, p: &SVector<f64, 3>, i: usize) -> (f64, SVector<f64, 3>) {
            let (x, y) = self.0[i];
            // Third parameter: a quadratic term, fixed at 0 by the mask in these tests.
            (
                p[0] + p[1] * x + p[2] * x * x - y,
                SVector::<f64, 3>::new(1.0, x, x * x),
            )
        }
    }

    #[test]
    fn linear_regression_closed_forms() {
        let pts: [(f64, f64); 6] = [
            (0.0, 1.1),
            (1.0, 2.9),
            (2.0, 5.2),
            (3.0, 6.8),
            (4.0, 9.1),
            (5.0, 11.0),
        ];
        let mask = [true, true, false];
        let fit = minimize(
            &Line(&pts),
            SVector::zeros(),
            &mask,
            None,
            &LmSettings::default(),
        )
        .unwrap();
        let n = pts.len() as f64;
        let xm = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let ym = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = pts.iter().map(|p| (p.0 - xm).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - xm) * (p.1 - ym)).sum();
        let b = sxy / sxx;
        let a = ym - b * xm;
        assert!((fit.params[0] - a).abs() < 1e-10 && (fit.params[1] - b).abs() < 1e-10);
        assert_eq!(fit.params[2], 0.0);
        let rss: f64 = pts.iter().map(|p| (a + b * p.0 - p.1).powi(2)).sum();
        assert!((fit.cost - rss).abs() < 1e-10);
        let s2 = rss / (n - 2.0);
        let se = standard_errors(&Line(&pts), &fit, &mask, None, REL_PIVOT_F64).unwrap();
        assert!((se[1] - (s2 / sxx).sqrt()).abs() < 1e-10);
        assert!((se[0] - (s2 * (1.0 / n + xm * xm / sxx)).sqrt()).abs() < 1e-10);
        assert_eq!(se[2], 0.0);
        let h = leverage(&Line(&pts), &fit.params, &mask, None, 5, REL_PIVOT_F64).unwrap();
        assert!((h - (1.0 / n + (5.0 - xm).powi(2) / sxx)).abs() < 1e-12);
        // PRESS identity for a linear model: LOO residual = r_i / (1 − h_i).
        let mut loo = [None; 6];
        loo_residuals(
            &Line(&pts),
            &fit,
            &mask,
            None,
            &LmSettings::default(),
            &mut loo,
        )
        .unwrap();
        for (i, p) in pts.iter().enumerate() {
            let hi = leverage(&Line(&pts), &fit.params, &mask, None, i, REL_PIVOT_F64).unwrap();
            let r = a + b * p.0 - p.1;
            assert!((loo[i].unwrap() - r / (1.0 - hi)).abs() < 1e-9);
        }
        // Weights: zero weight drops an observation exactly like leaving it out.
        let w = [1.0, 1.0, 0.0, 1.0, 1.0, 1.0];
        let fw = minimize(
            &Line(&pts),
            SVector::zeros(),
            &mask,
            Some(&w),
            &LmSettings::default(),
        )
        .unwrap();
        assert_eq!(fw.used, 5);
        assert!((Line(&pts).residual(&fw.params, 2) - loo[2].unwrap()).abs() < 1e-9);
    }

    /// r = exp(−p): the cost falls towards 0 as p → ∞, there is no finite minimum.
    struct Runaway;
    impl Problem<f64, 1> for Runaway {
        fn observations(&self) -> usize {
            2
        }
        fn residual_and_gradient(&self, p: &SVector<f64, 1>, _: usize) -> (f64, SVector<f64, 1>) {
            let e = (-p[0]).exp();
            (e, SVector::<f64, 1>::new(-e))
        }
    }

    #[test]
    fn runaway_is_reported_as_diverged() {
        let p0 = SVector::<f64, 1>::new(0.0);
        let mut s = LmSettings::multipos(200);
        s.param_bound = Some(10.0);
        assert_eq!(
            minimize(&Runaway, p0, &[true], None, &s),
            Err(Error::Diverged)
        );
        // Without a bound the same problem stops where the gain is no longer resolved
        // (a "minimum" at p ≈ 15, by the absolute gradient test), which is why the
        // multi-position schedule has one.
        s.param_bound = None;
        let f = minimize(&Runaway, p0, &[true], None, &s).unwrap();
        assert!(f.params[0] > 10.0, "{}", f.params[0]);
    }

    #[test]
    fn bad_inputs_are_refused() {
        let pts = [(0.0, 1.0), (1.0, 2.0)];
        let s = LmSettings::default();
        let p0 = SVector::zeros();
        assert_eq!(
            minimize(&Line(&pts), p0, &[true; 3], None, &s),
            Err(Error::TooFewPoses { needed: 3, got: 2 })
        );
        assert_eq!(
            minimize(&Line(&pts), p0, &[true, true, false], Some(&[1.0]), &s),
            Err(Error::InvalidParameter)
        );
        assert_eq!(
            minimize(
                &Line(&pts),
                p0,
                &[true, true, false],
                Some(&[1.0, -1.0]),
                &s
            ),
            Err(Error::InvalidParameter)
        );
        // Singular: two identical x values cannot determine a line.
        let same = [(1.0, 1.0), (1.0, 2.0)];
        let fit = minimize(&Line(&same), p0, &[true, true, false], None, &s);
        if let Ok(f) = fit {
            assert!(standard_errors(&Line(&same), &f, &[true, true, false], None, 1e-13).is_none());
        }
    }
}
