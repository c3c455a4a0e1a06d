//! The `f64` effect model of the analysis: the core's 9-parameter multi-position model
//! plus optional effect terms, fitted together by Levenberg–Marquardt over static-window means.
//!
//! Per window `i` with mean `m` (raw units), centre time `t` and mean temperature `θ`, in the
//! normalised frame `y = (m − c)/s` (the same centring and scaling the core uses, so that raw
//! counts in the tens of thousands lose no precision):
//!
//! ```text
//! e   = y − b − d·τ − d₂·τ² − β·ϑ       τ = (t − t̄)/T,  ϑ = (θ − θ̄)/Θ   (dimensionless)
//! v   = K·e                             K upper triangular (normalised units → g)
//! u_j = v_j·(1 + σ_j·ϑ)
//! a_j = u_j + q_j·u_j² + c_j·u_j³
//! r   = ‖a‖ − 1                          (g)
//! ```
//!
//! This is the correction of [`wiical_core::Effects`] (bias drift `d`, bias temperature
//! coefficient `β`, scale temperature coefficient `σ`, quadratic `q`, cubic `c`) in
//! normalised units, computed by the core's own generic functions, the ones
//! `CalibrationT::correct` runs in `f32` on the device: the bias removal
//! ([`wiical_core::model::remove_bias`], with the drift's curvature `d₂`, a diagnostic the
//! core's calibration cannot hold, as its further time term), `K·e`
//! ([`wiical_core::model::linear`]), the temperature scale
//! ([`wiical_core::model::temperature_scale`]) and the per-axis polynomial
//! ([`wiical_core::model::axis_polynomial`]). The open slots ([`Slot`]) act around them: bias
//! terms subtracted from `e`, scale terms multiplying `1 + σ_j·ϑ`, cross terms added to `a`. A
//! test checks that the core's `CalibrationT<f64>::correct` with these parameters
//! (normalised frame) gives this model's `a` bit for bit; [`Normalisation::to_calibration_f64`]
//! maps the parameters back to raw units, seconds and °C, whose correction reproduces the
//! model to `f64` rounding. The gradient below is the model's own. Only the three
//! non-orthogonality entries above the diagonal of `K` are free, so the sensor frame is fixed
//! by the same convention as the core's fit (x kept, y in the x–y plane): per-axis effect
//! terms refer to the axes of that frame.
//!
//! All 27 parameters (9 base + six effect blocks of 3) always exist; a mask says which are
//! free. The Jacobian is analytic (derivatives written out below). The fit is the core's
//! Levenberg–Marquardt ([`wiical_core::lm`], the same code as the device's `f32`
//! multi-position fit, instantiated in `f64`), so there is one solver in the project.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::report::effect_names as names;
use crate::report::effect_table::Effect;
use nalgebra::SVector;
use wiical_core::lm::{self, LmFit, LmSettings, Problem};
use wiical_core::model::{axis_polynomial, linear, remove_bias, temperature_scale};
use wiical_core::{Calibration, CalibrationT, EffectsT, Real};

/// Number of open slots: single terms of the open basis ([`Slot`]), appended to the 27
/// parameters of the fixed blocks; the open-basis stage fills at most this many.
pub const OPEN_SLOTS: usize = 4;
/// Total number of parameters (9 base + 6 effect blocks of 3 + [`OPEN_SLOTS`] open slots).
pub const NP: usize = 27 + OPEN_SLOTS;
/// A full parameter vector.
pub type Params = [f64; NP];

/// Index of the first parameter of each block.
pub const BIAS: usize = 0;
/// `K` entries k00 k01 k02 k11 k12 k22.
pub const KMAT: usize = 3;
/// Bias drift `d`.
pub const DRIFT: usize = 9;
/// Bias temperature coefficient `β`.
pub const BTEMP: usize = 12;
/// Scale temperature coefficient `σ`.
pub const STEMP: usize = 15;
/// Quadratic `q`.
pub const QUAD: usize = 18;
/// Cubic `c`.
pub const CUBIC: usize = 21;
/// Curvature of the bias drift in time `d₂` (diagnostic only: `Effects` has no such term).
pub const DRIFT2: usize = 24;
/// First open slot's coefficient ([`Slot`]: which term it is lives in the windows).
pub const OPEN: usize = 27;

/// What an open slot of the parameter vector stands for (the open basis of
/// [`crate::search::open_basis_screening`]): one coefficient `p`, acting on one output axis. The slot's
/// identity is held by every window ([`Win::slots`]) so that the forward model stays one
/// function: an empty slot costs a branch and changes nothing.
///
/// - `Bias { axis, x }`: `e_axis −= p·x`, with `x` this window's regressor (normalised units
///   per unit of `x`; e.g. `ϑ²`, a lagged temperature);
/// - `Scale { axis, x }`: `u_axis ×= 1 + p·x`;
/// - `Cross { axis, exps }`: `a_axis += p·u_x^ex·u_y^ey·u_z^ez` (`u` in g, so `p` in 1/g for a
///   monomial of degree 2, 1/g² for degree 3: the core's `Effects::cross_*`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum Slot {
    /// Unused: the coefficient is fixed at zero and does nothing.
    #[default]
    Empty,
    /// Bias on `axis` proportional to the window regressor `x`.
    Bias {
        /// Output axis (0, 1, 2).
        axis: u8,
        /// The window's regressor.
        x: f64,
    },
    /// Relative scale on `axis` proportional to the window regressor `x`.
    Scale {
        /// Output axis (0, 1, 2).
        axis: u8,
        /// The window's regressor.
        x: f64,
    },
    /// Monomial of `u` added to output axis `axis`.
    Cross {
        /// Output axis (0, 1, 2).
        axis: u8,
        /// Exponents of `(u_x, u_y, u_z)`.
        exps: [u8; 3],
    },
}

/// `u_x^ex·u_y^ey·u_z^ez` and its gradient in `u`.
#[inline]
pub fn monomial(u: &[f64; 3], exps: [u8; 3]) -> (f64, [f64; 3]) {
    let pw = |x: f64, e: u8| match e {
        0 => 1.0,
        1 => x,
        2 => x * x,
        _ => x * x * x,
    };
    let dpw = |x: f64, e: u8| match e {
        0 => 0.0,
        1 => 1.0,
        2 => 2.0 * x,
        _ => 3.0 * x * x,
    };
    let f = [0, 1, 2].map(|j| pw(u[j], exps[j]));
    let d = [0, 1, 2].map(|j| dpw(u[j], exps[j]));
    (
        f[0] * f[1] * f[2],
        [d[0] * f[1] * f[2], f[0] * d[1] * f[2], f[0] * f[1] * d[2]],
    )
}

/// Entries of the flat vector fixed in the diagonal model: the off-diagonal `k01 k02 k12`.
pub const K_OFF_DIAGONAL: [usize; 3] = [KMAT + 1, KMAT + 2, KMAT + 4];

/// The parameter vector as named blocks (normalised units, see the module docs). The solver
/// works on the flat [`Params`] ([`Blocks::flat`], offsets [`BIAS`], [`KMAT`], …); everything
/// else reads and writes blocks.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Blocks {
    /// Bias `b`.
    pub bias: [f64; 3],
    /// Upper triangle of `K`: `k00 k01 k02 k11 k12 k22`.
    pub k: [f64; 6],
    /// Bias drift `d`.
    pub drift: [f64; 3],
    /// Bias temperature coefficient `β`.
    pub bias_temp: [f64; 3],
    /// Scale temperature coefficient `σ`.
    pub scale_temp: [f64; 3],
    /// Quadratic `q`.
    pub quadratic: [f64; 3],
    /// Cubic `c`.
    pub cubic: [f64; 3],
    /// Drift curvature `d₂` (diagnostic only).
    pub drift2: [f64; 3],
    /// Coefficients of the open slots ([`Slot`]).
    pub open: [f64; OPEN_SLOTS],
}

impl Blocks {
    /// The named view of a flat vector.
    pub fn of(p: &Params) -> Self {
        let b3 = |o: usize| [p[o], p[o + 1], p[o + 2]];
        Blocks {
            bias: b3(BIAS),
            k: std::array::from_fn(|i| p[KMAT + i]),
            drift: b3(DRIFT),
            bias_temp: b3(BTEMP),
            scale_temp: b3(STEMP),
            quadratic: b3(QUAD),
            cubic: b3(CUBIC),
            drift2: b3(DRIFT2),
            open: std::array::from_fn(|i| p[OPEN + i]),
        }
    }

    /// The flat vector the solver works on.
    pub fn flat(&self) -> Params {
        let mut p = [0.0; NP];
        p[BIAS..BIAS + 3].copy_from_slice(&self.bias);
        p[KMAT..KMAT + 6].copy_from_slice(&self.k);
        for t in [
            Term::Drift,
            Term::BiasTemp,
            Term::ScaleTemp,
            Term::Quadratic,
            Term::Cubic,
            Term::Drift2,
        ] {
            p[t.offset()..t.offset() + 3].copy_from_slice(&self.term(t));
        }
        p[OPEN..OPEN + OPEN_SLOTS].copy_from_slice(&self.open);
        p
    }

    /// The block of an effect term.
    pub fn term(&self, t: Term) -> [f64; 3] {
        match t {
            Term::Drift => self.drift,
            Term::BiasTemp => self.bias_temp,
            Term::ScaleTemp => self.scale_temp,
            Term::Quadratic => self.quadratic,
            Term::Cubic => self.cubic,
            Term::Drift2 => self.drift2,
        }
    }
}

/// A parametric effect block (3 parameters, one per axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Term {
    /// Bias linear in the window time.
    Drift,
    /// Bias linear in the window temperature.
    BiasTemp,
    /// Scale linear in the window temperature.
    ScaleTemp,
    /// Per-axis even nonlinearity.
    Quadratic,
    /// Per-axis odd nonlinearity.
    Cubic,
    /// Bias quadratic in the window time (curved drift, e.g. a warm-up). Diagnostic only: the
    /// core's `Effects` cannot store it, so it is never added to the calibration.
    Drift2,
}

impl Term {
    /// All terms.
    pub const ALL: [Term; 5] = [
        Term::Quadratic,
        Term::Cubic,
        Term::Drift,
        Term::BiasTemp,
        Term::ScaleTemp,
    ];

    /// First parameter index of the block.
    pub fn offset(self) -> usize {
        match self {
            Term::Drift => DRIFT,
            Term::BiasTemp => BTEMP,
            Term::ScaleTemp => STEMP,
            Term::Quadratic => QUAD,
            Term::Cubic => CUBIC,
            Term::Drift2 => DRIFT2,
        }
    }

    /// The candidate that adds this single parameter block.
    pub fn effect(self) -> Effect {
        match self {
            Term::Drift => Effect::BiasDrift,
            Term::BiasTemp => Effect::Temperature,
            Term::ScaleTemp => Effect::TemperatureScale,
            Term::Quadratic => Effect::Quadratic,
            Term::Cubic => Effect::Cubic,
            Term::Drift2 => Effect::BiasDriftCurved,
        }
    }

    /// Name used in reports (the `effects[].name` of the JSON contract): its effect's.
    pub fn name(self) -> &'static str {
        self.effect().name()
    }

    /// True for the terms whose single axes are candidates too ([`Part::axis`]): the per-axis
    /// nonlinearities, a property of each axis's transfer curve, which one axis can have
    /// alone. The bias terms (drift, temperature) move the bias along one direction the three
    /// axes fix together, and the temperature scale follows the temperature as they do: split
    /// into axes they would add six one-parameter tests on time or temperature per step, and
    /// a first version that did named `temperature (z)` for a 2 mg bias drift (time and
    /// temperature correlate in these recordings) where the block search names nothing.
    pub fn splits_by_axis(self) -> bool {
        matches!(self, Term::Quadratic | Term::Cubic)
    }

    /// True for terms needing a temperature column (their effect's row says so).
    pub fn needs_temperature(self) -> bool {
        self.effect().needs_temperature()
    }
}

/// An effect block restricted to some of its axes: the whole block, or a single axis (a
/// quadratic on z alone: one parameter instead of three, so a recording with few poses can
/// still test it). The parameters of the other axes stay fixed at zero, so the calibration
/// stores a single-axis effect in the same `Effects` field with the other axes zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Part {
    /// The block.
    pub term: Term,
    /// Which of its axes are free (x, y, z of the fitted frame).
    pub axes: [bool; 3],
}

impl Part {
    /// The whole block.
    pub fn block(term: Term) -> Self {
        Self {
            term,
            axes: [true; 3],
        }
    }

    /// Axis `axis` (0, 1, 2 = x, y, z) of the block alone.
    pub fn axis(term: Term, axis: usize) -> Self {
        let mut axes = [false; 3];
        axes[axis] = true;
        Self { term, axes }
    }

    /// Number of parameters (free axes).
    pub fn count(self) -> usize {
        self.axes.iter().filter(|a| **a).count()
    }

    /// The report name: the block's (`quadratic`) when every axis is free, else the block's
    /// with its axes (`quadratic (z)`, `quadratic (x, y)`).
    pub fn name(self) -> String {
        if self.axes == [true; 3] {
            return self.term.name().to_string();
        }
        let axes: Vec<&str> = (0..3)
            .filter(|a| self.axes[*a])
            .map(|a| names::AXES[a])
            .collect();
        format!("{} ({})", self.term.name(), axes.join(", "))
    }
}

/// Mask of the 9 base parameters plus the given parts (each block only on its free axes).
pub fn mask_of_parts(parts: &[Part]) -> Mask {
    let mut m = mask_of(&[]);
    for p in parts {
        for a in 0..3 {
            if p.axes[a] {
                m[p.term.offset() + a] = true;
            }
        }
    }
    m
}

/// A static window reduced to what the model needs (normalised units).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Win {
    /// Normalised mean `y = (m − c)/s`.
    pub y: [f64; 3],
    /// Normalised time `τ = (t − t̄)/T`.
    pub tau: f64,
    /// Normalised temperature `ϑ = (θ − θ̄)/Θ` (0 without a temperature column).
    pub theta: f64,
    /// What the open slots stand for in this window (the same identity in every window,
    /// with this window's regressor for a bias or scale slot).
    pub slots: [Slot; OPEN_SLOTS],
}

/// Which parameters are free.
pub type Mask = [bool; NP];

/// Mask of the 9 base parameters plus the given terms.
pub fn mask_of(terms: &[Term]) -> Mask {
    let mut m = [false; NP];
    for x in m.iter_mut().take(9) {
        *x = true;
    }
    for t in terms {
        for x in m.iter_mut().skip(t.offset()).take(3) {
            *x = true;
        }
    }
    m
}

/// One window through the forward model (module docs): the bias-corrected mean `e`, `v = K·e`,
/// the temperature-scaled `u`, the corrected `a`, the temperature scale factor `1 + σ_j·ϑ` and
/// the open slots' scale factor `1 + Σ p·x` per axis.
struct Fwd {
    e: [f64; 3],
    v: [f64; 3],
    u: [f64; 3],
    a: [f64; 3],
    st: [f64; 3],
    extra: [f64; 3],
}

/// The forward model of one window (module docs), open slots included ([`Slot`]). One
/// function for [`residual`] and [`residual_and_grad`], so both compute `r` with the same
/// operations; with every slot empty it performs exactly the operations of the 27-parameter
/// model (a factor 1.0 is exact), so the fixed blocks' numbers do not move.
#[inline(always)]
fn forward(b: &Blocks, w: &Win) -> Fwd {
    let (tau, th) = (w.tau, w.theta);
    let tau2 = tau * tau;
    // The core's bias removal, with the drift's curvature (a diagnostic the core's
    // calibration cannot hold) as its further time term; the open slots' bias terms are
    // subtracted after it, their scale terms multiply the core's temperature scale.
    let curvature = b.drift2.map(|d2| d2 * tau2);
    let mut e = remove_bias(
        &w.y,
        &b.bias,
        &b.drift,
        tau,
        &curvature,
        &b.bias_temp,
        Some(th),
    );
    let mut extra = [1.0; 3];
    for (s, c) in w.slots.iter().zip(&b.open) {
        match *s {
            Slot::Bias { axis, x } => e[axis as usize] -= c * x,
            Slot::Scale { axis, x } => extra[axis as usize] += c * x,
            _ => {}
        }
    }
    let k = &b.k;
    let v = linear(
        &[[k[0], k[1], k[2]], [0.0, k[3], k[4]], [0.0, 0.0, k[5]]],
        &e,
    );
    let mut u = [0.0; 3];
    let mut a = [0.0; 3];
    let mut st = [0.0; 3];
    for j in 0..3 {
        st[j] = temperature_scale(b.scale_temp[j], th);
        let uj = v[j] * (st[j] * extra[j]);
        u[j] = uj;
        a[j] = axis_polynomial(uj, b.quadratic[j], b.cubic[j]);
    }
    for (s, c) in w.slots.iter().zip(&b.open) {
        if let Slot::Cross { axis, exps } = *s {
            a[axis as usize] += c * monomial(&u, exps).0;
        }
    }
    Fwd {
        e,
        v,
        u,
        a,
        st,
        extra,
    }
}

/// `‖a‖` of the corrected window.
#[inline(always)]
fn norm(a: &[f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Residual `r = ‖a‖ − 1` (g) of one window and its gradient with respect to all parameters.
#[inline]
pub fn residual_and_grad(p: &Params, w: &Win) -> (f64, Params) {
    let b = Blocks::of(p);
    let (tau, th) = (w.tau, w.theta);
    let tau2 = tau * tau;
    let Fwd {
        e,
        v,
        u,
        a,
        st,
        extra,
    } = forward(&b, w);
    let k = &b.k;
    let n = norm(&a);
    let inv = if n > 0.0 { 1.0 / n } else { 0.0 };
    let g = [a[0] * inv, a[1] * inv, a[2] * inv];
    let mut grad = [0.0; NP];
    // ∂r/∂u_j: the per-axis polynomial's g_j·h_j plus what the cross slots add.
    let mut du: [f64; 3] = std::array::from_fn(|j| {
        let (q, c) = (b.quadratic[j], b.cubic[j]);
        g[j] * (1.0 + 2.0 * q * u[j] + 3.0 * c * u[j] * u[j])
    });
    for (s, (slot, c)) in w.slots.iter().zip(&b.open).enumerate() {
        if let Slot::Cross { axis, exps } = *slot {
            let (m, dm) = monomial(&u, exps);
            let gi = g[axis as usize];
            grad[OPEN + s] = gi * m;
            for j in 0..3 {
                du[j] += gi * c * dm[j];
            }
        }
    }
    // ∂r/∂v_j = ∂r/∂u_j·(1 + σ_j ϑ)·(1 + Σ p·x) =: z_j.
    let mut z = [0.0; 3];
    for j in 0..3 {
        z[j] = du[j] * (st[j] * extra[j]);
        grad[STEMP + j] = du[j] * v[j] * th * extra[j];
        grad[QUAD + j] = g[j] * u[j] * u[j];
        grad[CUBIC + j] = g[j] * u[j] * u[j] * u[j];
    }
    // ∂r/∂K_jk = z_j e_k (upper triangle).
    grad[KMAT] = z[0] * e[0];
    grad[KMAT + 1] = z[0] * e[1];
    grad[KMAT + 2] = z[0] * e[2];
    grad[KMAT + 3] = z[1] * e[1];
    grad[KMAT + 4] = z[1] * e[2];
    grad[KMAT + 5] = z[2] * e[2];
    // ∂r/∂e = Kᵀz; e depends on b, d, β with coefficients −1, −τ, −ϑ.
    let kt = [
        k[0] * z[0],
        k[1] * z[0] + k[3] * z[1],
        k[2] * z[0] + k[4] * z[1] + k[5] * z[2],
    ];
    for j in 0..3 {
        grad[BIAS + j] = -kt[j];
        grad[DRIFT + j] = -kt[j] * tau;
        grad[DRIFT2 + j] = -kt[j] * tau2;
        grad[BTEMP + j] = -kt[j] * th;
    }
    for (s, slot) in w.slots.iter().enumerate() {
        match *slot {
            Slot::Bias { axis, x } => grad[OPEN + s] = -kt[axis as usize] * x,
            Slot::Scale { axis, x } => {
                let j = axis as usize;
                grad[OPEN + s] = du[j] * v[j] * st[j] * x;
            }
            _ => {}
        }
    }
    (n - 1.0, grad)
}

/// Residual only: the same value as [`residual_and_grad`]'s, without the gradient (the
/// solver's cost evaluations, two thirds of the model evaluations of an analysis).
#[inline]
pub fn residual(p: &Params, w: &Win) -> f64 {
    norm(&forward(&Blocks::of(p), w).a) - 1.0
}

/// The corrected acceleration `a` of one window (g), the direction the first-order patterns
/// of the open basis are evaluated at.
pub fn corrected(p: &Params, w: &Win) -> [f64; 3] {
    forward(&Blocks::of(p), w).a
}

/// `mask` with the open slots the windows use set free (a slot is used when the first window
/// names a term for it: every window holds the same identities).
pub fn with_open(mut mask: Mask, wins: &[Win]) -> Mask {
    if let Some(w) = wins.first() {
        for (s, slot) in w.slots.iter().enumerate() {
            mask[OPEN + s] = *slot != Slot::Empty;
        }
    }
    mask
}

/// Result of a least-squares fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Parameters at the minimum.
    pub p: Params,
    /// Residual sum of squares over the windows used, g².
    pub rss: f64,
    /// Number of windows used.
    pub n: usize,
    /// Number of free parameters.
    pub k: usize,
    /// Iterations.
    pub iterations: u32,
}

impl Fit {
    /// In-sample RMS, g.
    pub fn rms(&self) -> f64 {
        (self.rss / self.n.max(1) as f64).sqrt()
    }
}

/// The windows as a least-squares problem for the core's generic solver
/// ([`wiical_core::lm`], instantiated in `f64`): one residual `‖a‖ − 1` per window, over the
/// `K` free parameters only (`idx` says which; the fixed ones keep their value in `base`).
/// Solving in the free parameters rather than masking all 27 keeps the normal equations
/// `K×K`: a 12-parameter candidate costs a fifth of the masked 27×27 system, and the
/// leave-one-window-out cross-validation refits every candidate once per window.
struct Reduced<'a, const K: usize> {
    wins: &'a [Win],
    base: Params,
    idx: [usize; K],
}

impl<const K: usize> Reduced<'_, K> {
    fn expand(&self, q: &SVector<f64, K>) -> Params {
        let mut p = self.base;
        for (a, &i) in self.idx.iter().enumerate() {
            p[i] = q[a];
        }
        p
    }

    fn reduce(&self, p: &Params) -> SVector<f64, K> {
        SVector::from_fn(|a, _| p[self.idx[a]])
    }
}

impl<const K: usize> Problem<f64, K> for Reduced<'_, K> {
    fn observations(&self) -> usize {
        self.wins.len()
    }

    fn residual_and_gradient(&self, q: &SVector<f64, K>, i: usize) -> (f64, SVector<f64, K>) {
        let (r, g) = residual_and_grad(&self.expand(q), &self.wins[i]);
        (r, SVector::from_fn(|a, _| g[self.idx[a]]))
    }

    fn residual(&self, q: &SVector<f64, K>, i: usize) -> f64 {
        residual(&self.expand(q), &self.wins[i])
    }
}

/// Calls `$f::<K>(args…)` with `K` the number of free parameters (`$k`): base 6 or 9 plus 1
/// to 3 per effect block ([`Part`]: single axes too), so anything from 6 to 27 (`None`
/// otherwise).
macro_rules! with_free_count {
    ($k:expr, $f:ident($($arg:expr),*)) => {
        match $k {
            6 => $f::<6>($($arg),*),
            7 => $f::<7>($($arg),*),
            8 => $f::<8>($($arg),*),
            9 => $f::<9>($($arg),*),
            10 => $f::<10>($($arg),*),
            11 => $f::<11>($($arg),*),
            12 => $f::<12>($($arg),*),
            13 => $f::<13>($($arg),*),
            14 => $f::<14>($($arg),*),
            15 => $f::<15>($($arg),*),
            16 => $f::<16>($($arg),*),
            17 => $f::<17>($($arg),*),
            18 => $f::<18>($($arg),*),
            19 => $f::<19>($($arg),*),
            20 => $f::<20>($($arg),*),
            21 => $f::<21>($($arg),*),
            22 => $f::<22>($($arg),*),
            23 => $f::<23>($($arg),*),
            24 => $f::<24>($($arg),*),
            25 => $f::<25>($($arg),*),
            26 => $f::<26>($($arg),*),
            27 => $f::<27>($($arg),*),
            28 => $f::<28>($($arg),*),
            29 => $f::<29>($($arg),*),
            30 => $f::<30>($($arg),*),
            31 => $f::<31>($($arg),*),
            _ => None,
        }
    };
}

fn reduced<'a, const K: usize>(p: &Params, mask: &Mask, wins: &'a [Win]) -> Reduced<'a, K> {
    let free: Vec<usize> = (0..NP).filter(|i| mask[*i]).collect();
    Reduced {
        wins,
        base: *p,
        idx: std::array::from_fn(|a| free[a]),
    }
}

fn free_count(mask: &Mask) -> usize {
    mask.iter().filter(|m| **m).count()
}

fn weights_of(used: &[bool]) -> Vec<f64> {
    used.iter().map(|u| if *u { 1.0 } else { 0.0 }).collect()
}

/// Levenberg–Marquardt from `p0` over the windows with `used[i]`, freeing the parameters in
/// `mask`. `None` when the problem is singular (too few windows, collinear regressors) or the
/// solver does not converge.
pub fn fit(p0: &Params, mask: &Mask, wins: &[Win], used: &[bool]) -> Option<Fit> {
    fit_weighted(p0, mask, wins, &weights_of(used))
}

/// [`fit`] with non-negative per-window weights (0 excludes a window); `rss` is then the
/// weighted sum and `n` the number of windows with positive weight. The core's solver with
/// its `f64` schedule ([`LmSettings::default`]); a minimum whose normal matrix is singular
/// (some free combination undetermined) is refused.
pub fn fit_weighted(p0: &Params, mask: &Mask, wins: &[Win], used: &[f64]) -> Option<Fit> {
    if wins.len() != used.len() {
        return None;
    }
    with_free_count!(free_count(mask), fit_k(p0, mask, wins, used))
}

fn fit_k<const K: usize>(p0: &Params, mask: &Mask, wins: &[Win], used: &[f64]) -> Option<Fit> {
    let problem = reduced::<K>(p0, mask, wins);
    let all = [true; K];
    let f = lm::minimize(
        &problem,
        problem.reduce(p0),
        &all,
        Some(used),
        &LmSettings::default(),
    )
    .ok()?;
    let (jtj, _) = lm::normal_equations(&problem, &f.params, Some(used));
    lm::factor_normal(&jtj, &all, lm::REL_PIVOT_F64)?;
    Some(Fit {
        p: problem.expand(&f.params),
        rss: f.cost,
        n: f.used,
        k: f.free,
        iterations: f.iterations,
    })
}

/// Standard errors of the free parameters (`σ̂²·(JᵀJ)⁻¹`, σ̂² = RSS/(n − k)), in the order of
/// the full parameter vector (0 for fixed parameters, and all 0 without residual degrees of
/// freedom or with a singular normal matrix).
pub fn standard_errors(f: &Fit, mask: &Mask, wins: &[Win], used: &[bool]) -> Params {
    let w = weights_of(used);
    with_free_count!(free_count(mask), standard_errors_k(f, mask, wins, &w)).unwrap_or([0.0; NP])
}

fn standard_errors_k<const K: usize>(
    f: &Fit,
    mask: &Mask,
    wins: &[Win],
    w: &[f64],
) -> Option<Params> {
    let problem = reduced::<K>(&f.p, mask, wins);
    let lm_fit = LmFit {
        params: problem.reduce(&f.p),
        cost: f.rss,
        iterations: f.iterations,
        used: f.n,
        free: K,
    };
    let se = lm::standard_errors(&problem, &lm_fit, &[true; K], Some(w), lm::REL_PIVOT_F64)?;
    let mut out = [0.0; NP];
    for (a, &i) in problem.idx.iter().enumerate() {
        out[i] = se[a];
    }
    Some(out)
}

/// Leverage of window `i` with respect to the windows `used` at parameters `p`:
/// `h = gᵢᵀ(JᵀJ)⁻¹gᵢ`, so that the prediction error of a window outside the fit has variance
/// `σ²·(1 + h)`. `None` when the normal matrix is singular.
pub fn leverage(p: &Params, mask: &Mask, wins: &[Win], used: &[bool], i: usize) -> Option<f64> {
    let w = weights_of(used);
    with_free_count!(free_count(mask), leverage_k(p, mask, wins, &w, i))
}

fn leverage_k<const K: usize>(
    p: &Params,
    mask: &Mask,
    wins: &[Win],
    w: &[f64],
    i: usize,
) -> Option<f64> {
    let problem = reduced::<K>(p, mask, wins);
    lm::leverage(
        &problem,
        &problem.reduce(p),
        &[true; K],
        Some(w),
        i,
        lm::REL_PIVOT_F64,
    )
}

/// Leave-one-window-out cross-validation: for each used window, refit without it (warm start
/// from the full fit) and return its held-out residual (g), in window order (`None` for unused
/// windows). `None` overall when any refit fails.
pub fn loo(full: &Fit, mask: &Mask, wins: &[Win], used: &[bool]) -> Option<Vec<Option<f64>>> {
    let mut out = vec![None; wins.len()];
    let mut u = used.to_vec();
    for i in 0..wins.len() {
        if !used[i] {
            continue;
        }
        u[i] = false;
        let f = fit(&full.p, mask, wins, &u)?;
        u[i] = true;
        out[i] = Some(residual(&f.p, &wins[i]));
    }
    Some(out)
}

/// Centring and scaling of the raw window data, and the map back to a [`Calibration`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalisation {
    /// Centre of the window means, raw units.
    pub centre: [f64; 3],
    /// RMS spread of the window means about the centre, raw units.
    pub scale: f64,
    /// Mean window time `t̄`, s since the first sample.
    pub t_mean: f64,
    /// Time scale `T`, s.
    pub t_scale: f64,
    /// Mean window temperature `θ̄`, °C (the calibration's `temp_ref_c`).
    pub temp_mean: f64,
    /// Temperature scale `Θ`, °C.
    pub temp_scale: f64,
}

impl Normalisation {
    /// From raw window means, times (s since the first sample) and temperatures.
    pub fn of(means: &[[f64; 3]], times: &[f64], temps: Option<&[f64]>) -> Self {
        let n = means.len().max(1) as f64;
        let mut c = [0.0; 3];
        for m in means {
            for a in 0..3 {
                c[a] += m[a] / n;
            }
        }
        let ss: f64 = means
            .iter()
            .map(|m| (0..3).map(|a| (m[a] - c[a]).powi(2)).sum::<f64>())
            .sum();
        let scale = (ss / n).sqrt();
        let spread = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64).sqrt();
            (m, if s > 0.0 { s } else { 1.0 })
        };
        let (t_mean, t_scale) = spread(times);
        let (temp_mean, temp_scale) = temps.map_or((0.0, 1.0), spread);
        Self {
            centre: c,
            scale: if scale > 0.0 { scale } else { 1.0 },
            t_mean,
            t_scale,
            temp_mean,
            temp_scale,
        }
    }

    /// The model's view of one window.
    pub fn window(&self, mean: &[f64; 3], time: f64, temp: Option<f64>) -> Win {
        Win {
            y: [
                (mean[0] - self.centre[0]) / self.scale,
                (mean[1] - self.centre[1]) / self.scale,
                (mean[2] - self.centre[2]) / self.scale,
            ],
            tau: (time - self.t_mean) / self.t_scale,
            theta: temp.map_or(0.0, |t| (t - self.temp_mean) / self.temp_scale),
            slots: [Slot::Empty; OPEN_SLOTS],
        }
    }

    /// Initial parameters from a raw-unit calibration (effects zero).
    pub fn params_from(&self, cal: &Calibration) -> Params {
        let k = cal.matrix;
        let s = self.scale;
        Blocks {
            bias: std::array::from_fn(|a| (cal.bias[a] as f64 - self.centre[a]) / self.scale),
            k: [k[0][0], k[0][1], k[0][2], k[1][1], k[1][2], k[2][2]].map(|x| x as f64 * s),
            ..Blocks::default()
        }
        .flat()
    }

    /// The parameters as raw-unit effect values (f64): bias at t = 0 (raw), K (g/raw),
    /// drift (raw/s), bias_temp (raw/°C), scale_temp (1/°C), quadratic, cubic.
    pub fn raw(&self, p: &Params) -> RawParams {
        let s = self.scale;
        let b = Blocks::of(p);
        let mut r = RawParams::default();
        for a in 0..3 {
            let d = b.drift[a];
            // b_eff(t) = c + s·(b + d·(t − t̄)/T + …): at t = 0 the bias is c + s·(b − d·t̄/T).
            r.bias[a] = self.centre[a] + s * (b.bias[a] - d * self.t_mean / self.t_scale);
            r.drift[a] = s * d / self.t_scale;
            r.bias_temp[a] = s * b.bias_temp[a] / self.temp_scale;
            r.scale_temp[a] = b.scale_temp[a] / self.temp_scale;
            r.quadratic[a] = b.quadratic[a];
            r.cubic[a] = b.cubic[a];
        }
        let k = &b.k;
        r.matrix = [
            [k[0] / s, k[1] / s, k[2] / s],
            [0.0, k[3] / s, k[4] / s],
            [0.0, 0.0, k[5] / s],
        ];
        r.temp_ref_c = self.temp_mean;
        r
    }

    /// The core's calibration in `f64` reproducing the model (the diagnostic `d₂` must be
    /// zero): [`CalibrationT::correct`]`(m, cond)` with `cond.time_s` = seconds since the first
    /// sample and `cond.temperature_c` the temperature is the model's `a` in raw units.
    pub fn to_calibration_f64(self, p: &Params) -> CalibrationT<f64> {
        let r = self.raw(p);
        CalibrationT {
            bias: r.bias,
            matrix: r.matrix,
            effects: EffectsT {
                quadratic: r.quadratic,
                cubic: r.cubic,
                bias_drift: r.drift,
                temp_ref_c: r.temp_ref_c,
                bias_temp: r.bias_temp,
                scale_temp: r.scale_temp,
                ..EffectsT::default()
            },
        }
    }

    /// [`Self::to_calibration_f64`] rounded to the device's `f32`, parameter by parameter.
    pub fn to_calibration(self, p: &Params) -> Calibration {
        self.to_calibration_f64(p).cast(Real::to_f32)
    }
}

impl Normalisation {
    /// [`Normalisation::to_calibration`] with the open slots' cross terms stored in
    /// `Effects::cross_quadratic` / `cross_cubic` (the model's `u` is in g, so the slot's
    /// coefficient is already in 1/g or 1/g²). Bias and scale slots (time and temperature
    /// terms) are host terms the core's `Effects` has no field for: they are not stored here.
    pub fn to_calibration_open(self, p: &Params, slots: &[Slot; OPEN_SLOTS]) -> Calibration {
        use wiical_core::model::{CROSS2, CROSS3, DEGREE2, DEGREE3};
        let mut cal = self.to_calibration(p);
        for (s, c) in slots.iter().zip(&p[OPEN..]) {
            let Slot::Cross { axis, exps } = *s else {
                continue;
            };
            let i = axis as usize;
            let c = *c as f32;
            if let Some(k) = DEGREE2.iter().position(|m| *m == exps) {
                if let Some(j) = CROSS2[i].iter().position(|x| *x == k) {
                    cal.effects.cross_quadratic[i][j] += c;
                }
            } else if let Some(k) = DEGREE3.iter().position(|m| *m == exps) {
                if let Some(j) = CROSS3[i].iter().position(|x| *x == k) {
                    cal.effects.cross_cubic[i][j] += c;
                }
            }
        }
        cal
    }
}

/// Model parameters in raw units (see [`Normalisation::raw`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RawParams {
    /// Bias at t = 0, raw units.
    pub bias: [f64; 3],
    /// K = D⁻¹ (upper triangular), g per raw unit.
    pub matrix: [[f64; 3]; 3],
    /// Bias drift, raw units per second.
    pub drift: [f64; 3],
    /// Bias temperature coefficient, raw units per °C.
    pub bias_temp: [f64; 3],
    /// Relative scale temperature coefficient, 1/°C.
    pub scale_temp: [f64; 3],
    /// Quadratic k2, 1/g.
    pub quadratic: [f64; 3],
    /// Cubic k3, 1/g².
    pub cubic: [f64; 3],
    /// Reference temperature, °C.
    pub temp_ref_c: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_params() -> Params {
        let mut p = [0.0; NP];
        p[..9].copy_from_slice(&[0.01, -0.02, 0.03, 0.98, 0.01, -0.02, 1.01, 0.015, 0.99]);
        for (i, x) in p.iter_mut().enumerate().skip(9) {
            *x = 0.01 * ((i * 7 % 5) as f64 - 2.0);
        }
        p
    }

    /// Open slots of every kind (the gradient and residual tests run with them filled).
    const SLOTS: [Slot; OPEN_SLOTS] = [
        Slot::Bias { axis: 0, x: 0.7 },
        Slot::Scale { axis: 2, x: -0.4 },
        Slot::Cross {
            axis: 2,
            exps: [1, 1, 0],
        },
        Slot::Cross {
            axis: 0,
            exps: [0, 1, 2],
        },
    ];

    /// The named blocks and the flat vector are two views of the same numbers.
    #[test]
    fn blocks_round_trip_and_name_the_offsets() {
        let p = sample_params();
        let b = Blocks::of(&p);
        assert_eq!(b.flat(), p);
        assert_eq!(b.bias, [p[BIAS], p[BIAS + 1], p[BIAS + 2]]);
        assert_eq!(b.k[4], p[KMAT + 4]);
        for t in Term::ALL.into_iter().chain([Term::Drift2]) {
            assert_eq!(
                b.term(t),
                [p[t.offset()], p[t.offset() + 1], p[t.offset() + 2]]
            );
        }
        assert_eq!(K_OFF_DIAGONAL.map(|i| p[i]), [b.k[1], b.k[2], b.k[4]]);
    }

    /// The residual-only path gives exactly (bit for bit) the residual of the gradient path.
    #[test]
    fn residual_is_the_gradient_paths_residual() {
        let p = sample_params();
        for i in 0..50 {
            let x = i as f64 * 0.37;
            let w = Win {
                y: [x.sin(), (1.3 * x).cos(), (0.7 * x).sin() - 0.2],
                tau: (0.3 * x).cos(),
                theta: (0.11 * x).sin() * 2.0,
                slots: SLOTS,
            };
            assert_eq!(
                residual(&p, &w).to_bits(),
                residual_and_grad(&p, &w).0.to_bits()
            );
        }
    }

    /// The analytic gradient against central differences.
    #[test]
    fn gradient_matches_finite_differences() {
        let p = sample_params();
        let w = Win {
            y: [0.3, -0.7, 0.6],
            tau: 0.8,
            theta: -1.2,
            slots: SLOTS,
        };
        let (_, g) = residual_and_grad(&p, &w);
        for i in 0..NP {
            let h = 1e-6;
            let (mut a, mut b) = (p, p);
            a[i] += h;
            b[i] -= h;
            let num = (residual(&a, &w) - residual(&b, &w)) / (2.0 * h);
            assert!((num - g[i]).abs() < 1e-7, "param {i}: {num} vs {}", g[i]);
        }
    }

    /// The f32 calibration reproduces the f64 model through `Calibration::correct`.
    #[test]
    fn calibration_reproduces_model() {
        let means = [
            [520.0, 500.0, 610.0],
            [410.0, 505.0, 515.0],
            [515.0, 400.0, 505.0],
        ];
        let times = [10.0, 50.0, 90.0];
        let temps = [25.0, 28.0, 30.0];
        let nrm = Normalisation::of(&means, &times, Some(&temps));
        let mut p = sample_params();
        p[..9].copy_from_slice(&[0.0, 0.0, 0.0, 0.9, 0.01, 0.0, 0.95, -0.01, 0.97]);
        p[DRIFT2..DRIFT2 + 3].copy_from_slice(&[0.0; 3]);
        let cal = nrm.to_calibration(&p);
        for i in 0..3 {
            let w = nrm.window(&means[i], times[i], Some(temps[i]));
            let want = residual(&p, &w);
            let a = cal.correct(
                means[i].map(|x| x as f32),
                &wiical_core::Conditions {
                    time_s: times[i] as f32,
                    temperature_c: Some(temps[i] as f32),
                },
            );
            let got = (a.iter().map(|x| (*x as f64).powi(2)).sum::<f64>()).sqrt() - 1.0;
            assert!((got - want).abs() < 2e-5, "{got} vs {want}");
        }
    }

    /// The model is the core's correction in `f64`: the core's generic `correct`, instantiated
    /// in `f64` on the model's parameters mapped to raw units, gives the model's residual to
    /// `f64` rounding (the `f32` test above allows for the device's rounding).
    #[test]
    fn the_core_f64_correction_is_the_model() {
        let means = [
            [520.0, 500.0, 610.0],
            [410.0, 505.0, 515.0],
            [515.0, 400.0, 505.0],
        ];
        let times = [10.0, 50.0, 90.0];
        let temps = [25.0, 28.0, 30.0];
        let nrm = Normalisation::of(&means, &times, Some(&temps));
        let mut p = sample_params();
        p[..9].copy_from_slice(&[0.0, 0.0, 0.0, 0.9, 0.01, 0.0, 0.95, -0.01, 0.97]);
        p[DRIFT2..DRIFT2 + 3].copy_from_slice(&[0.0; 3]);
        p[OPEN..].copy_from_slice(&[0.0; OPEN_SLOTS]);
        let cal = nrm.to_calibration_f64(&p);
        for i in 0..3 {
            let w = nrm.window(&means[i], times[i], Some(temps[i]));
            let cond = wiical_core::ConditionsT {
                time_s: times[i],
                temperature_c: Some(temps[i]),
            };
            let a = cal.correct(means[i], &cond);
            let got = norm(&a) - 1.0;
            let want = residual(&p, &w);
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
    }

    /// The model is the core's correction: `CalibrationT<f64>::correct` with the parameters
    /// as they are (normalised frame: `K` upper triangular, `θ₀ = 0`, the window's `τ` and
    /// `ϑ` as time and temperature) gives the model's corrected `a` bit for bit.
    #[test]
    fn the_model_is_the_core_correction_bit_for_bit() {
        let mut p = sample_params();
        p[DRIFT2..DRIFT2 + 3].copy_from_slice(&[0.0; 3]);
        let b = Blocks::of(&p);
        let k = b.k;
        let cal = CalibrationT::<f64> {
            bias: b.bias,
            matrix: [[k[0], k[1], k[2]], [0.0, k[3], k[4]], [0.0, 0.0, k[5]]],
            effects: EffectsT {
                bias_drift: b.drift,
                bias_temp: b.bias_temp,
                scale_temp: b.scale_temp,
                quadratic: b.quadratic,
                cubic: b.cubic,
                ..EffectsT::default()
            },
        };
        for (y, tau, theta) in [
            ([0.31, -0.72, 0.55], 0.4, -0.3),
            ([-0.9, 0.05, 0.41], -1.2, 0.8),
            ([0.02, 0.99, -0.11], 0.0, 0.0),
        ] {
            let w = Win {
                y,
                tau,
                theta,
                slots: [Slot::Empty; OPEN_SLOTS],
            };
            let cond = wiical_core::ConditionsT {
                time_s: tau,
                temperature_c: Some(theta),
            };
            let want = cal.correct(y, &cond).map(f64::to_bits);
            assert_eq!(corrected(&p, &w).map(f64::to_bits), want, "{y:?}");
        }
    }

    /// The open slots' cross terms land in the core's `Effects::cross_*` at the index its
    /// tables give, so `Calibration::correct` reproduces the model with them.
    #[test]
    fn calibration_carries_the_cross_slots() {
        let means = [
            [520.0, 500.0, 610.0],
            [410.0, 505.0, 515.0],
            [515.0, 400.0, 505.0],
            [600.0, 590.0, 420.0],
        ];
        let times = [10.0, 50.0, 90.0, 120.0];
        let nrm = Normalisation::of(&means, &times, None);
        let mut p = [0.0; NP];
        p[..9].copy_from_slice(&[0.0, 0.0, 0.0, 0.9, 0.01, 0.0, 0.95, -0.01, 0.97]);
        p[OPEN + 2] = 0.015;
        p[OPEN + 3] = -0.02;
        let slots = [Slot::Empty, Slot::Empty, SLOTS[2], SLOTS[3]];
        let cal = nrm.to_calibration_open(&p, &slots);
        // z: x·y is DEGREE2[3] = CROSS2[2][2]; x: y·z² is DEGREE3[8] = CROSS3[0][7].
        assert_eq!(cal.effects.cross_quadratic[2][2], 0.015);
        assert_eq!(cal.effects.cross_cubic[0][7], -0.02);
        for i in 0..means.len() {
            let mut w = nrm.window(&means[i], times[i], None);
            w.slots = slots;
            let want = residual(&p, &w);
            let a = cal.correct(
                means[i].map(|x| x as f32),
                &wiical_core::Conditions::default(),
            );
            let got = (a.iter().map(|x| (*x as f64).powi(2)).sum::<f64>()).sqrt() - 1.0;
            assert!((got - want).abs() < 2e-5, "{got} vs {want}");
        }
    }
}
