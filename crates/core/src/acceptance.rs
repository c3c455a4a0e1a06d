//! What makes a calibration acceptable: one definition shared by the host (`fit`, `analyze`,
//! `device put`) and the adapter (wire uploads, self-calibration).
//!
//! Two independent questions:
//! * **Plausibility** of the parameters ([`Acceptance::check`]): could a real sensor of this
//!   kind have them, and does the correction stay sane over everything the sensor can
//!   report? Modelled on ArduPilot's accelerometer-calibration acceptance (offsets bounded,
//!   scale-matrix diagonal within 0.8–1.2 of nominal, fit residual bounded), plus an output
//!   bound that catches absurd effect terms: the corrected output must stay within
//!   ±[`Acceptance::output_bound`] on every axis for every raw input in
//!   [`Acceptance::input_range`] at every condition in [`Acceptance::conditions`].
//! * **Coverage** of the poses a fit used ([`CoverageRule::check`]): enough directions, on
//!   both sides of every axis, not all in one plane. Used by the host's quality verdict and
//!   by the adapter's self-calibration to decide when it has enough poses.
//!
//! Both return a typed reason ([`Rejection`], [`CoverageGap`]) naming the axis and the value
//! that failed, so that a host can print it and an adapter can send it as a code.
//!
//! ## The output bound is exact
//! For fixed conditions, `u = K·(m − b_eff)` is affine in `m`, so each `u_i` takes its
//! extremes over the input box at the box's corners; over the time range `b_eff` is affine
//! in `t` (corners again), and over the temperature range `u_i` is a quadratic in `Δθ`
//! (affine bias shift times the scale factor `1 + s_i·Δθ`), whose extremes are at the ends
//! or at its vertex. The range of `u_i` is therefore an interval `[lo, hi]` computed
//! exactly from finitely many points, and the output `a_i = u + k2·u² + k3·u³` is a cubic in
//! `u` whose extremes on `[lo, hi]` are at the ends or at the roots of its derivative.
//! No sampling, so a narrow spike cannot slip between grid points.
//!
//! The orientation-dependent cross terms (`Effects::cross_quadratic`, `cross_cubic`) couple
//! the axes, so for them the bound is an upper bound instead: with `U_j` the largest `|u_j|`
//! over the ranges above, each cross monomial is at most its value at `U`, and
//! `Σ |c|·monomial(U)` is added to the per-axis extreme (triangle inequality). This may refuse
//! a calibration whose true extreme is a little below the bound, never accept one above it;
//! the cross terms of a real sensor are mg/g² to a few %/g², far from the ±16 g bound.

use crate::model::{invert3, monomials, CROSS2, CROSS3};
use crate::{Calibration, Error};

/// Operating conditions over which a calibration's effect terms are evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConditionRange {
    /// Largest time since power-up / start of recording the drift term is applied at, s
    /// (the range is `0..=max_time_s`). 0 when the user of the calibration applies no drift.
    pub max_time_s: f32,
    /// Temperature range in °C the temperature terms are applied over, or `None` when the
    /// user of the calibration has no temperature sensor (the terms are then never applied).
    pub temperature_c: Option<(f32, f32)>,
}

/// Acceptance limits for a calibration: every threshold is a named field (see the module
/// docs). Units: raw sensor units ("counts") for inputs and offsets, reference units (g for
/// an accelerometer) for outputs and residuals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acceptance {
    /// Smallest and largest raw value the sensor can report on each axis (e.g. `0..=1023`
    /// for a 10-bit ADC).
    pub input_range: (f32, f32),
    /// The corrected output must stay within `±output_bound` (reference units) on every
    /// axis over the whole input range at every condition.
    pub output_bound: f32,
    /// Conditions the effect terms are checked over.
    pub conditions: ConditionRange,
    /// Nominal raw reading at zero input (e.g. 512 counts for the Nunchuk).
    pub nominal_zero: f32,
    /// Largest allowed `|b_i − nominal_zero|`, raw units.
    pub max_offset: f32,
    /// Nominal sensitivity, raw units per reference unit (e.g. 200 counts/g).
    pub nominal_sensitivity: f32,
    /// Allowed range of `D_ii / nominal_sensitivity` (`D = K⁻¹`, the forward matrix):
    /// ArduPilot accepts 0.8–1.2.
    pub sensitivity_ratio: (f32, f32),
    /// Largest allowed cross-axis term `|D_ij| / √(D_ii·D_jj)` (i ≠ j).
    pub max_cross_axis: f32,
    /// Largest allowed fit RMS of `‖a‖ − 1` over the poses, reference units (checked only
    /// when the caller has a fit RMS).
    pub max_fit_rms: f32,
    /// Allowed reference temperature `θ₀` of the temperature terms, °C (the range a
    /// consumer or industrial part is specified over, so that an absurd `θ₀` is refused
    /// even when the terms multiplying it are zero).
    pub temp_ref_range_c: (f32, f32),
}

impl Acceptance {
    /// Limits for the Nunchuk's accelerometer (LIS3L02AL-class, 10-bit counts, ≈ 200
    /// counts/g around 512) as used by the adapter: ±16 g output bound; offsets within
    /// 0.5 g of 512; sensitivity 0.8–1.2 of 200 counts/g; cross-axis ≤ 0.2; fit RMS
    /// ≤ 30 mg (six counts: a hand-held session on a 5 mg/count sensor is far below);
    /// drift over an hour and temperatures 0–50 °C, θ₀ within −40…125 °C.
    pub const fn nunchuk() -> Self {
        Self {
            input_range: (0.0, 1023.0),
            output_bound: 16.0,
            conditions: ConditionRange {
                max_time_s: 3600.0,
                temperature_c: Some((0.0, 50.0)),
            },
            nominal_zero: 512.0,
            max_offset: 100.0,
            nominal_sensitivity: 200.0,
            sensitivity_ratio: (0.8, 1.2),
            max_cross_axis: 0.2,
            max_fit_rms: 0.03,
            temp_ref_range_c: (-40.0, 125.0),
        }
    }

    /// Accept or refuse `cal` (with the fit's RMS of `‖a‖ − 1`, if it came from a fit):
    /// the one acceptance predicate. Checks, in order: finite and invertible; limits
    /// themselves sane; offsets; forward-matrix diagonal and cross-axis terms; `θ₀`; the
    /// output bound (exact, see the module docs); the fit RMS.
    pub fn check(&self, cal: &Calibration, fit_rms: Option<f32>) -> Result<(), Rejection> {
        cal.validate().map_err(Rejection::Unusable)?;
        if !self.limits_valid() {
            return Err(Rejection::InvalidLimits);
        }
        for (axis, b) in cal.bias.iter().enumerate() {
            let offset = b - self.nominal_zero;
            if !at_most(libm::fabsf(offset), self.max_offset) {
                return Err(Rejection::Offset { axis, offset });
            }
        }
        let d = invert3(&cal.k()).map_err(Rejection::Unusable)?;
        for axis in 0..3 {
            let ratio = d[(axis, axis)] / self.nominal_sensitivity;
            let (lo, hi) = self.sensitivity_ratio;
            if !(lo..=hi).contains(&ratio) {
                return Err(Rejection::Sensitivity { axis, ratio });
            }
        }
        for row in 0..3 {
            for col in (0..3).filter(|c| *c != row) {
                let ratio = libm::fabsf(d[(row, col)]) / libm::sqrtf(d[(row, row)] * d[(col, col)]);
                if !at_most(ratio, self.max_cross_axis) {
                    return Err(Rejection::CrossAxis { row, col, ratio });
                }
            }
        }
        let t0 = cal.effects.temp_ref_c;
        if !(self.temp_ref_range_c.0..=self.temp_ref_range_c.1).contains(&t0) {
            return Err(Rejection::TemperatureReference { temp_ref_c: t0 });
        }
        for axis in 0..3 {
            let max_abs = self.output_extreme(cal, axis);
            if !at_most(max_abs, self.output_bound) {
                return Err(Rejection::OutputBound { axis, max_abs });
            }
        }
        if let Some(rms) = fit_rms {
            if !at_most(rms, self.max_fit_rms) {
                return Err(Rejection::FitRms { rms });
            }
        }
        Ok(())
    }

    /// Limits for the Wii MotionPlus's gyroscope as the adapter holds its calibration: `K`
    /// maps **slow-range counts** (14-bit, the fast range mapped onto the slow scale by the
    /// adapter's `GyroCorrector`) to rad/s along the MotionPlus's count axes (yaw, roll,
    /// pitch; positive where the counts rise), so the forward matrix's diagonal is positive.
    /// Nominal zero 8192 and 8192 counts per 440 °/s (the hid-wiimote driver's slow scale,
    /// 18.618 counts per °/s = 1066.7 counts per rad/s); sensitivity 0.75–1.3 of it (Dolphin's
    /// emulated block, 16.1 counts per °/s, is 0.865; WiiBrew's "20 per °/s" 1.074); zero
    /// within 1000 counts (≈ 54 °/s) of 8192; cross-axis ≤ 0.2 (≈ 11° of misalignment);
    /// corrected output within ±20 rad/s (≈ 1150 °/s, 2.6× the slow range) over the slow
    /// counts 0–16383. None of these was measured on a MotionPlus (there is no recording of
    /// one in the data): they are loose bounds around the documented scales that refuse a
    /// file fitted to another gyro (an MPU's zero near 0 counts, a scale off by 10×) or in
    /// the wrong frame (a negative diagonal). No time or temperature terms.
    pub const fn motionplus() -> Self {
        Self {
            input_range: (0.0, 16383.0),
            output_bound: 20.0,
            conditions: ConditionRange {
                max_time_s: 0.0,
                temperature_c: None,
            },
            nominal_zero: 8192.0,
            max_offset: 1000.0,
            nominal_sensitivity: 8192.0 / 440.0 * (180.0 / core::f32::consts::PI),
            sensitivity_ratio: (0.75, 1.3),
            max_cross_axis: 0.2,
            max_fit_rms: f32::INFINITY,
            temp_ref_range_c: (-40.0, 125.0),
        }
    }

    /// Accept or refuse a gyro calibration for a device that applies `K·(m − b)` only: usable
    /// (finite, `K` invertible, each g-sensitivity coefficient within its bound: what
    /// `GyroCorrection::validate` checks), then the linear part judged as [`Self::check`] judges
    /// an accelerometer's (offsets in counts, the forward matrix `K⁻¹`'s diagonal against
    /// [`Self::nominal_sensitivity`] in counts per rad/s, its cross-axis terms, the output
    /// bound in rad/s). The g-sensitivity is not part of what such a device applies, so it is
    /// bounded by validation alone.
    pub fn check_gyro(
        &self,
        cal: &crate::gyro_correct::GyroCorrection<f32>,
    ) -> Result<(), Rejection> {
        // `GyroCorrection::validate`'s checks, the invertibility left to `check`'s own
        // (`Calibration::validate`): one inversion code in a firmware that links both.
        if !cal.floats().iter().all(|x| x.is_finite()) {
            return Err(Rejection::Unusable(Error::NonFinite));
        }
        let bound = crate::gyro_correct::G_SENSITIVITY_MAX as f32;
        let g = &cal.effects.g_sensitivity;
        if g.as_flattened().iter().any(|x| libm::fabsf(*x) > bound) {
            return Err(Rejection::Unusable(Error::InvalidParameter));
        }
        let linear = Calibration {
            bias: cal.bias,
            matrix: cal.matrix,
            effects: Calibration::identity().effects,
        };
        self.check(&linear, None)
    }

    fn limits_valid(&self) -> bool {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let (i0, i1) = self.input_range;
        let (s0, s1) = self.sensitivity_ratio;
        let (t0, t1) = self.temp_ref_range_c;
        let temps_ok = match self.conditions.temperature_c {
            Some((a, b)) => a.is_finite() && b.is_finite() && a <= b,
            None => true,
        };
        i0.is_finite()
            && i1.is_finite()
            && i0 <= i1
            && pos(self.output_bound)
            && pos(self.nominal_sensitivity)
            && self.nominal_zero.is_finite()
            && self.max_offset.is_finite()
            && self.max_offset >= 0.0
            && s0.is_finite()
            && s1.is_finite()
            && s0 <= s1
            && self.max_cross_axis >= 0.0
            && self.max_fit_rms >= 0.0
            && self.conditions.max_time_s.is_finite()
            && self.conditions.max_time_s >= 0.0
            && temps_ok
            && t0 <= t1
    }

    /// Largest `|a_axis|` over the input box and the condition range (NaN or ∞ if the
    /// correction overflows, which then fails the bound): exact without cross terms, an
    /// upper bound with them (see the module docs).
    pub fn output_extreme(&self, cal: &Calibration, axis: usize) -> f32 {
        let own = self.own_output_extreme(cal, axis);
        if !cal.effects.has_cross_terms() {
            return own;
        }
        own + self.cross_bound(cal, axis)
    }

    /// Upper bound of `|Σ cross terms|` of output `axis`: the coefficients' magnitudes times
    /// the monomials at the largest `|u_j|` of each axis. NaN when a range is not finite.
    fn cross_bound(&self, cal: &Calibration, axis: usize) -> f32 {
        let mut umax = [0.0f32; 3];
        for (j, m) in umax.iter_mut().enumerate() {
            let (lo, hi) = self.linear_output_range(cal, j);
            if !(lo.is_finite() && hi.is_finite()) {
                return f32::NAN;
            }
            *m = libm::fabsf(lo).max(libm::fabsf(hi));
        }
        let (m2, m3) = monomials(&umax);
        let e = &cal.effects;
        let mut s = 0.0f32;
        for (c, k) in e.cross_quadratic[axis].iter().zip(CROSS2[axis]) {
            s += libm::fabsf(*c) * m2[k];
        }
        for (c, k) in e.cross_cubic[axis].iter().zip(CROSS3[axis]) {
            s += libm::fabsf(*c) * m3[k];
        }
        s
    }

    /// Exact largest `|u + k2·u² + k3·u³|` of output `axis` (the per-axis polynomial alone).
    fn own_output_extreme(&self, cal: &Calibration, axis: usize) -> f32 {
        let (lo, hi) = self.linear_output_range(cal, axis);
        let e = &cal.effects;
        let (k2, k3) = (e.quadratic[axis], e.cubic[axis]);
        let poly = |u: f32| u + k2 * u * u + k3 * u * u * u;
        let mut worst = libm::fabsf(poly(lo)).max(libm::fabsf(poly(hi)));
        if !(lo.is_finite() && hi.is_finite()) || worst.is_nan() {
            return f32::NAN;
        }
        // Critical points of the cubic: 3·k3·u² + 2·k2·u + 1 = 0.
        let mut roots = [f32::NAN; 2];
        if k3 != 0.0 {
            let disc = 4.0 * k2 * k2 - 12.0 * k3;
            if disc >= 0.0 {
                let s = libm::sqrtf(disc);
                roots = [(-2.0 * k2 - s) / (6.0 * k3), (-2.0 * k2 + s) / (6.0 * k3)];
            }
        } else if k2 != 0.0 {
            roots[0] = -1.0 / (2.0 * k2);
        }
        for r in roots {
            if r >= lo && r <= hi {
                let v = libm::fabsf(poly(r));
                if v.is_nan() {
                    return f32::NAN;
                }
                worst = worst.max(v);
            }
        }
        worst
    }

    /// Range `[lo, hi]` of the linear-plus-scale part `u_axis` (before the nonlinearity)
    /// over the input box, `t ∈ [0, max_time_s]` and the temperature range.
    fn linear_output_range(&self, cal: &Calibration, axis: usize) -> (f32, f32) {
        let e = &cal.effects;
        let k = cal.matrix[axis];
        let (i0, i1) = self.input_range;
        // Temperature deltas to try: the range's ends and the quadratic's vertex per corner.
        let temps: [Option<f32>; 2] = match self.conditions.temperature_c {
            Some((a, b)) => [Some(a - e.temp_ref_c), Some(b - e.temp_ref_c)],
            None => [None, None],
        };
        let s = e.scale_temp[axis];
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        let mut take = |v: f32| {
            if v.is_nan() {
                lo = f32::NAN;
                hi = f32::NAN;
            } else if !lo.is_nan() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        };
        for corner in 0..8u8 {
            let m = [0, 1, 2].map(|i| if corner >> i & 1 == 0 { i0 } else { i1 });
            for t in [0.0, self.conditions.max_time_s] {
                // u(Δθ) = (1 + s·Δθ)·(c0 + c1·Δθ): c0 without temperature, c1 its slope.
                let lin = |dt: f32| -> f32 {
                    (0..3)
                        .map(|j| {
                            k[j] * (m[j] - cal.bias[j] - e.bias_drift[j] * t - e.bias_temp[j] * dt)
                        })
                        .sum()
                };
                let c0 = lin(0.0);
                match temps {
                    [Some(a), Some(b)] => {
                        let c1 = lin(1.0) - c0;
                        let u = |dt: f32| (1.0 + s * dt) * (c0 + c1 * dt);
                        take(u(a));
                        take(u(b));
                        // Vertex of s·c1·Δθ² + (c0·s + c1)·Δθ + c0.
                        if s != 0.0 && c1 != 0.0 {
                            let v = -(c0 * s + c1) / (2.0 * s * c1);
                            if v > a && v < b {
                                take(u(v));
                            }
                        }
                    }
                    _ => take(c0),
                }
            }
        }
        (lo, hi)
    }
}

/// Why [`Acceptance::check`] refused a calibration. Axes are 0 = x, 1 = y, 2 = z.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// Not usable at all: non-finite parameters or a singular matrix.
    Unusable(Error),
    /// The acceptance limits themselves are invalid (NaN, reversed ranges…).
    InvalidLimits,
    /// `b_axis − nominal_zero` is beyond `max_offset` (raw units).
    Offset {
        /// Axis.
        axis: usize,
        /// `b_axis − nominal_zero`, raw units.
        offset: f32,
    },
    /// Forward-matrix diagonal outside the sensitivity range.
    Sensitivity {
        /// Axis.
        axis: usize,
        /// `D_ii / nominal_sensitivity`.
        ratio: f32,
    },
    /// Cross-axis term too large.
    CrossAxis {
        /// Row of `D`.
        row: usize,
        /// Column of `D`.
        col: usize,
        /// `|D_ij| / √(D_ii·D_jj)`.
        ratio: f32,
    },
    /// Reference temperature outside the plausible range.
    TemperatureReference {
        /// The calibration's `θ₀`, °C.
        temp_ref_c: f32,
    },
    /// The corrected output leaves `±output_bound` somewhere in the input/condition range.
    OutputBound {
        /// Axis.
        axis: usize,
        /// Largest `|a_axis|` found (NaN if the correction overflows).
        max_abs: f32,
    },
    /// The fit residual is too large.
    FitRms {
        /// RMS of `‖a‖ − 1`, reference units.
        rms: f32,
    },
}

/// A number in a message: plain below 1e6 (as `{}` prints it), scientific above (1e30 would
/// otherwise print as thirty-one digits) and for tiny non-zero values.
struct Num(f32);

impl core::fmt::Display for Num {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let a = libm::fabsf(self.0);
        if a.is_finite() && (a >= 1e6 || (a != 0.0 && a < 1e-4)) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

impl core::fmt::Display for Rejection {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        const AXES: [&str; 3] = ["x", "y", "z"];
        let ax = |i: &usize| AXES.get(*i).copied().unwrap_or("?");
        match self {
            Rejection::Unusable(e) => write!(f, "calibration unusable: {e}"),
            Rejection::InvalidLimits => f.write_str("invalid acceptance limits"),
            Rejection::Offset { axis, offset } => write!(
                f,
                "{} offset {} counts from nominal is beyond the limit",
                ax(axis),
                Num(*offset)
            ),
            Rejection::Sensitivity { axis, ratio } => write!(
                f,
                "{} sensitivity is {} × nominal, outside the accepted range",
                ax(axis),
                Num(*ratio)
            ),
            Rejection::CrossAxis { row, col, ratio } => write!(
                f,
                "cross-axis term {}{} is {} of the diagonal, beyond the limit",
                ax(row),
                ax(col),
                Num(*ratio)
            ),
            Rejection::TemperatureReference { temp_ref_c } => {
                write!(
                    f,
                    "reference temperature {} °C is implausible",
                    Num(*temp_ref_c)
                )
            }
            Rejection::OutputBound { axis, max_abs } => write!(
                f,
                "corrected {} output reaches {} (reference units) within the sensor's input range",
                ax(axis),
                Num(*max_abs)
            ),
            Rejection::FitRms { rms } => write!(f, "fit RMS {} is beyond the limit", Num(*rms)),
        }
    }
}

impl core::error::Error for Rejection {}

/// How well a set of pose directions must cover the sphere (shared by the host's quality
/// verdict and the adapter's self-calibration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoverageRule {
    /// Fewest poses (the 9-parameter model needs 9; margin against outliers beyond that).
    pub min_poses: u32,
    /// On every axis, some pose must have a unit-direction component ≥ this and some
    /// ≤ −this ("both signs on every axis", ArduPilot's six orientations generalised).
    pub min_axis_component: f32,
    /// Smallest eigenvalue of the directions' scatter matrix `Σ d·dᵀ / n` (1/3 for
    /// directions spread evenly; 0 when all lie in one plane through the origin).
    pub min_spread: f32,
}

impl Default for CoverageRule {
    /// 12 poses, both signs with components ≥ 0.5 (within 60° of every half-axis), spread
    /// ≥ 0.1.
    fn default() -> Self {
        Self {
            min_poses: 12,
            min_axis_component: 0.5,
            min_spread: 0.1,
        }
    }
}

impl CoverageRule {
    /// The six-position method's rule: its six poses (each axis up and down) are the whole
    /// design, so 6 poses suffice; the direction and spread conditions are the default's.
    /// Six poses leave no redundancy to catch a bad pose, which is why multi-position
    /// recordings are held to [`CoverageRule::default`]'s 12.
    pub fn six_position() -> Self {
        Self {
            min_poses: 6,
            ..Self::default()
        }
    }
}

/// Why a set of poses does not cover the sphere well enough.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CoverageGap {
    /// Fewer poses than the rule asks.
    TooFewPoses {
        /// Needed.
        needed: u32,
        /// Present.
        got: u32,
    },
    /// No pose points far enough along `±axis`.
    MissingDirection {
        /// Axis (0 = x).
        axis: usize,
        /// `true`: the `+axis` side is missing; `false`: `−axis`.
        positive: bool,
    },
    /// The directions are (nearly) in one plane or along one line.
    Flat {
        /// Smallest scatter eigenvalue found.
        spread: f32,
    },
    /// A direction was NaN, infinite or zero.
    BadDirection,
}

impl core::fmt::Display for CoverageGap {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CoverageGap::TooFewPoses { needed, got } => {
                write!(f, "too few poses: {got} of {needed}")
            }
            CoverageGap::MissingDirection { axis, positive } => write!(
                f,
                "no pose with the {}{} axis pointing up",
                if *positive { "+" } else { "−" },
                ["x", "y", "z"].get(*axis).copied().unwrap_or("?")
            ),
            CoverageGap::Flat { spread } => write!(
                f,
                "poses nearly in one plane (spread {spread}): tilt into more orientations"
            ),
            CoverageGap::BadDirection => f.write_str("a pose direction is not finite"),
        }
    }
}

impl core::error::Error for CoverageGap {}

impl CoverageRule {
    /// Check the directions (any length; normalised here) of the poses, e.g. each pose's
    /// mean corrected with an approximate calibration.
    pub fn check(&self, directions: &[[f32; 3]]) -> Result<(), CoverageGap> {
        let got = directions.len() as u32;
        if got < self.min_poses {
            return Err(CoverageGap::TooFewPoses {
                needed: self.min_poses,
                got,
            });
        }
        let mut max_c = [f32::NEG_INFINITY; 3];
        let mut min_c = [f32::INFINITY; 3];
        let mut scatter = crate::Mat3::zeros();
        for d in directions {
            let u = unit(d).ok_or(CoverageGap::BadDirection)?;
            for a in 0..3 {
                max_c[a] = max_c[a].max(u[a]);
                min_c[a] = min_c[a].min(u[a]);
            }
            let v = crate::Vec3::new(u[0], u[1], u[2]);
            scatter += v * v.transpose();
        }
        for axis in 0..3 {
            if max_c[axis] < self.min_axis_component {
                return Err(CoverageGap::MissingDirection {
                    axis,
                    positive: true,
                });
            }
            if min_c[axis] > -self.min_axis_component {
                return Err(CoverageGap::MissingDirection {
                    axis,
                    positive: false,
                });
            }
        }
        let spread = if got == 0 {
            0.0
        } else {
            nalgebra::SymmetricEigen::new(scatter / got as f32)
                .eigenvalues
                .min()
        };
        if !at_most(self.min_spread, spread) {
            return Err(CoverageGap::Flat { spread });
        }
        Ok(())
    }
}

/// `x ≤ limit`, false when either is NaN (so NaN never passes a limit).
fn at_most(x: f32, limit: f32) -> bool {
    matches!(
        x.partial_cmp(&limit),
        Some(core::cmp::Ordering::Less | core::cmp::Ordering::Equal)
    )
}

/// `v/‖v‖`, or `None` for a zero or non-finite vector.
pub fn unit(v: &[f32; 3]) -> Option<[f32; 3]> {
    let n = libm::sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if !(n.is_finite() && n > 0.0) {
        return None;
    }
    Some(v.map(|x| x / n))
}

/// Angle between two directions, radians (0 for a zero or non-finite vector, which callers
/// treat as "not new").
pub fn angle_between(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    match (unit(a), unit(b)) {
        (Some(u), Some(v)) => {
            let dot = (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]).clamp(-1.0, 1.0);
            libm::acosf(dot)
        }
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Effects;

    fn nunchuk_like() -> Calibration {
        Calibration {
            bias: [496.0, 502.0, 493.0],
            matrix: [
                [1.0 / 205.0, 1e-4, 0.0],
                [0.0, 1.0 / 194.0, -2e-4],
                [0.0, 0.0, 1.0 / 202.0],
            ],
            effects: Effects::default(),
        }
    }

    #[test]
    fn a_factory_like_calibration_is_accepted() {
        let acc = Acceptance::nunchuk();
        assert_eq!(acc.check(&nunchuk_like(), None), Ok(()));
        assert_eq!(acc.check(&nunchuk_like(), Some(0.005)), Ok(()));
        assert!(matches!(
            acc.check(&nunchuk_like(), Some(0.2)),
            Err(Rejection::FitRms { .. })
        ));
    }

    #[test]
    fn huge_numbers_in_messages_are_scientific() {
        extern crate std;
        use std::string::ToString;
        let r = Rejection::Offset {
            axis: 2,
            offset: 1e30,
        };
        assert_eq!(
            r.to_string(),
            "z offset 1e30 counts from nominal is beyond the limit"
        );
        let r = Rejection::TemperatureReference { temp_ref_c: 25.5 };
        assert_eq!(
            r.to_string(),
            "reference temperature 25.5 °C is implausible"
        );
    }

    #[test]
    fn absurd_uploads_are_refused_with_their_reason() {
        let acc = Acceptance::nunchuk();
        let mut c = nunchuk_like();
        c.effects.quadratic[1] = 1e30;
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::OutputBound { axis: 1, .. })
        ));
        let mut c = nunchuk_like();
        c.effects.cubic[2] = 3e38;
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::OutputBound { axis: 2, .. })
        ));
        let mut c = nunchuk_like();
        c.bias[0] = 1e30;
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::Offset { axis: 0, .. })
        ));
        let mut c = nunchuk_like();
        c.effects.temp_ref_c = 1e38;
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::TemperatureReference { .. })
        ));
        let mut c = nunchuk_like();
        c.matrix[1][1] = 1.0 / 100.0; // 100 counts/g: half the nominal sensitivity
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::Sensitivity { axis: 1, .. })
        ));
        let mut c = nunchuk_like();
        c.matrix[0][2] = 0.003; // a cross term as large as half the diagonal
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::CrossAxis { .. })
        ));
        let mut c = nunchuk_like();
        c.bias[2] = f32::NAN;
        assert_eq!(
            acc.check(&c, None),
            Err(Rejection::Unusable(Error::NonFinite))
        );
        // A drift that is harmless at t = 0 but reaches 20 g within the hour.
        let mut c = nunchuk_like();
        c.effects.bias_drift[0] = 1.2; // counts/s: 4320 counts = 21 g after an hour
        assert!(matches!(
            acc.check(&c, None),
            Err(Rejection::OutputBound { axis: 0, .. })
        ));
        let mut no_time = acc;
        no_time.conditions.max_time_s = 0.0;
        assert_eq!(no_time.check(&c, None), Ok(()));
    }

    /// Brute force in f64 over a dense grid of inputs, times and temperatures.
    fn sampled_extreme(acc: &Acceptance, cal: &Calibration, axis: usize) -> f64 {
        let e = &cal.effects;
        let (i0, i1) = (acc.input_range.0 as f64, acc.input_range.1 as f64);
        let (t0, t1) = acc.conditions.temperature_c.unwrap();
        let mut worst = 0.0f64;
        let n = 12;
        for a in 0..=n {
            for b in 0..=n {
                for c in 0..=n {
                    let m = [a, b, c].map(|k| i0 + (i1 - i0) * k as f64 / n as f64);
                    for ti in 0..=4 {
                        let t = acc.conditions.max_time_s as f64 * ti as f64 / 4.0;
                        for hi in 0..=20 {
                            let th = t0 as f64 + (t1 - t0) as f64 * hi as f64 / 20.0;
                            let dth = th - e.temp_ref_c as f64;
                            let mut u = 0.0;
                            for (j, mj) in m.iter().enumerate() {
                                let bj = cal.bias[j] as f64
                                    + e.bias_drift[j] as f64 * t
                                    + e.bias_temp[j] as f64 * dth;
                                u += cal.matrix[axis][j] as f64 * (mj - bj);
                            }
                            u *= 1.0 + e.scale_temp[axis] as f64 * dth;
                            let out = u
                                + e.quadratic[axis] as f64 * u * u
                                + e.cubic[axis] as f64 * u * u * u;
                            worst = worst.max(out.abs());
                        }
                    }
                }
            }
        }
        worst
    }

    #[test]
    fn the_exact_output_extreme_bounds_a_dense_f64_sampling() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
        let acc = Acceptance::nunchuk();
        for _ in 0..40 {
            let mut c = nunchuk_like();
            let e = &mut c.effects;
            for a in 0..3 {
                e.quadratic[a] = rng.random_range(-0.2..0.2);
                e.cubic[a] = rng.random_range(-0.1..0.1);
                e.bias_drift[a] = rng.random_range(-0.01..0.01);
                e.bias_temp[a] = rng.random_range(-2.0..2.0);
                e.scale_temp[a] = rng.random_range(-0.01..0.01);
            }
            e.temp_ref_c = rng.random_range(10.0..40.0);
            for axis in 0..3 {
                let exact = acc.output_extreme(&c, axis) as f64;
                let sampled = sampled_extreme(&acc, &c, axis);
                // The exact extreme is never below a sample, and the grid gets close to it.
                assert!(exact >= sampled * (1.0 - 1e-5), "{exact} < {sampled}");
                assert!(exact <= sampled * 1.05 + 1e-3, "{exact} ≫ {sampled}");
            }
        }
    }

    /// Brute force in f64 over a dense input grid (no time or temperature terms): the full
    /// correction with the cross terms, written from the monomial tables' exponents.
    fn sampled_extreme_with_cross(acc: &Acceptance, cal: &Calibration, axis: usize) -> f64 {
        use crate::model::{CROSS2, CROSS3, DEGREE2, DEGREE3};
        let e = &cal.effects;
        let (i0, i1) = (acc.input_range.0 as f64, acc.input_range.1 as f64);
        let mono =
            |u: &[f64; 3], ex: &[u8; 3]| (0..3).map(|j| u[j].powi(ex[j].into())).product::<f64>();
        let n = 16;
        let mut worst = 0.0f64;
        for a in 0..=n {
            for b in 0..=n {
                for c in 0..=n {
                    let m = [a, b, c].map(|k| i0 + (i1 - i0) * k as f64 / n as f64);
                    let u: [f64; 3] = core::array::from_fn(|i| {
                        (0..3)
                            .map(|j| cal.matrix[i][j] as f64 * (m[j] - cal.bias[j] as f64))
                            .sum()
                    });
                    let x = u[axis];
                    let mut out =
                        x + e.quadratic[axis] as f64 * x * x + e.cubic[axis] as f64 * x * x * x;
                    for (cf, k) in e.cross_quadratic[axis].iter().zip(CROSS2[axis]) {
                        out += *cf as f64 * mono(&u, &DEGREE2[k]);
                    }
                    for (cf, k) in e.cross_cubic[axis].iter().zip(CROSS3[axis]) {
                        out += *cf as f64 * mono(&u, &DEGREE3[k]);
                    }
                    worst = worst.max(out.abs());
                }
            }
        }
        worst
    }

    #[test]
    fn the_cross_term_bound_is_above_a_dense_f64_sampling_and_refuses_absurd_terms() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(19);
        let mut acc = Acceptance::nunchuk();
        acc.conditions = ConditionRange {
            max_time_s: 0.0,
            temperature_c: None,
        };
        for _ in 0..20 {
            let mut c = nunchuk_like();
            let e = &mut c.effects;
            for a in 0..3 {
                e.quadratic[a] = rng.random_range(-0.05..0.05);
                e.cubic[a] = rng.random_range(-0.02..0.02);
                e.cross_quadratic[a] = core::array::from_fn(|_| rng.random_range(-0.05..0.05));
                e.cross_cubic[a] = core::array::from_fn(|_| rng.random_range(-0.02..0.02));
            }
            for axis in 0..3 {
                let bound = acc.output_extreme(&c, axis) as f64;
                let sampled = sampled_extreme_with_cross(&acc, &c, axis);
                assert!(bound >= sampled * (1.0 - 1e-5), "{bound} < {sampled}");
                assert!(bound < 16.0, "a realistic calibration must pass: {bound}");
            }
            assert_eq!(acc.check(&c, None), Ok(()));
        }
        // One absurd cross coefficient per family and axis is refused on that axis.
        for axis in 0..3 {
            let mut c = nunchuk_like();
            c.effects.cross_quadratic[axis][4] = 1e30;
            assert!(matches!(
                acc.check(&c, None),
                Err(Rejection::OutputBound { axis: a, .. }) if a == axis
            ));
            let mut c = nunchuk_like();
            c.effects.cross_cubic[axis][8] = -3e38;
            assert!(matches!(
                acc.check(&c, None),
                Err(Rejection::OutputBound { axis: a, .. }) if a == axis
            ));
            let mut c = nunchuk_like();
            c.effects.cross_cubic[axis][0] = f32::INFINITY;
            assert_eq!(
                acc.check(&c, None),
                Err(Rejection::Unusable(Error::NonFinite))
            );
        }
    }

    fn axis_poses() -> [[f32; 3]; 6] {
        [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ]
    }

    #[test]
    fn coverage_rule_wants_count_both_signs_and_spread() {
        let rule = CoverageRule {
            min_poses: 6,
            ..Default::default()
        };
        assert_eq!(rule.check(&axis_poses()), Ok(()));
        assert_eq!(
            CoverageRule::default().check(&axis_poses()),
            Err(CoverageGap::TooFewPoses { needed: 12, got: 6 })
        );
        // Upper hemisphere only: −z missing.
        let mut upper = axis_poses();
        upper[5] = [0.3, 0.3, 0.9];
        assert_eq!(
            rule.check(&upper),
            Err(CoverageGap::MissingDirection {
                axis: 2,
                positive: false
            })
        );
        // All in the plane x = z (both signs everywhere, yet flat).
        let s = core::f32::consts::FRAC_1_SQRT_2;
        let flat: [[f32; 3]; 6] = [
            [s, 0.0, s],
            [-s, 0.0, -s],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.5, s, 0.5],
            [-0.5, -s, -0.5],
        ];
        assert!(matches!(rule.check(&flat), Err(CoverageGap::Flat { .. })));
        let mut bad = axis_poses();
        bad[0] = [f32::NAN, 0.0, 0.0];
        assert_eq!(rule.check(&bad), Err(CoverageGap::BadDirection));
    }

    #[test]
    fn angles_between_directions() {
        let a = angle_between(&[1.0, 0.0, 0.0], &[0.0, 2.0, 0.0]);
        assert!((a - core::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert_eq!(angle_between(&[0.0; 3], &[1.0, 0.0, 0.0]), 0.0);
    }

    /// A MotionPlus calibration in slow counts: 18.0 counts per °/s (0.967 of nominal), zeros
    /// 8100–8300, 1 % misalignment.
    fn motionplus_like() -> crate::gyro_correct::GyroCorrection<f32> {
        let k = core::f32::consts::PI / 180.0 / 18.0;
        crate::gyro_correct::GyroCorrection {
            bias: [8100.0, 8300.0, 8192.0],
            matrix: [[k, 0.01 * k, 0.0], [0.0, k, -0.01 * k], [0.0, 0.0, k]],
            effects: Default::default(),
        }
    }

    /// The gyro check accepts a MotionPlus-like calibration and refuses, with the reason a
    /// host prints, one fitted to another gyro (an MPU's zero near 0), one in a frame with a
    /// flipped axis, one ten times off in scale, and an unusable one.
    #[test]
    fn the_motionplus_limits_judge_a_gyro_calibration() {
        let acc = Acceptance::motionplus();
        // 8192 counts per 440 °/s, in counts per rad/s.
        let nominal = 8192.0 / 440.0 * 180.0 / core::f64::consts::PI;
        assert!((f64::from(acc.nominal_sensitivity) - nominal).abs() < 1e-3);
        let good = motionplus_like();
        assert_eq!(acc.check_gyro(&good), Ok(()));
        let mut mpu = good;
        mpu.bias = [-31.0, 12.5, 7.25];
        assert!(matches!(
            acc.check_gyro(&mpu),
            Err(Rejection::Offset { axis: 0, .. })
        ));
        let mut flipped = good;
        flipped.matrix[2] = flipped.matrix[2].map(|x| -x);
        let e = acc.check_gyro(&flipped).unwrap_err();
        assert!(matches!(e, Rejection::Sensitivity { axis: 2, ratio } if ratio < 0.0));
        let mut tenfold = good;
        tenfold.matrix[1] = tenfold.matrix[1].map(|x| x * 10.0);
        assert!(matches!(
            acc.check_gyro(&tenfold),
            Err(Rejection::Sensitivity { axis: 1, .. })
        ));
        let mut nan = good;
        nan.bias[1] = f32::NAN;
        assert!(matches!(acc.check_gyro(&nan), Err(Rejection::Unusable(_))));
        let mut g = good;
        g.effects.g_sensitivity[0][0] = 1.0;
        assert!(matches!(acc.check_gyro(&g), Err(Rejection::Unusable(_))));
    }
}
