//! The measurement model and its inversion (correction).
//!
//! A 3-axis sensor reading `m` (raw units) of a true vector `a` (units of the reference
//! magnitude, e.g. g) is modelled as
//!
//! ```text
//! m = D·a + b + v,      D = g·L·T
//! ```
//!
//! with `L` diagonal scale factors, `T` the non-orthogonality (cross-axis coupling) matrix,
//! `b` the bias and `v` white noise (seed: *Calibrazione del Wiimote*, eq. 1). A
//! [`Calibration`] stores the inverse map: `K = D⁻¹` and `b`, so that correcting a sample is
//! one subtraction and one 3×3 product, `a = K·(m − b)`.
//!
//! Real sensors also have effects the linear model lacks. [`Effects`] carries optional extra
//! terms (time drift and temperature dependence of the bias, temperature dependence of the
//! scale, per-axis even and odd nonlinearity, and an orientation-dependent error: a general
//! polynomial of degree 3 in the linearly corrected reading, i.e. in the gravity direction
//! when the sensor is still). They are all zero by default, in which case the correction is
//! exactly the linear one. Their correction-side definition is:
//!
//! ```text
//! b_eff = b + drift·t + bias_temp·(θ − θ₀)             (raw units)
//! u     = K·(m − b_eff)                                 (reference units)
//! u_i  ← u_i · (1 + scale_temp_i·(θ − θ₀))
//! a_i   = u_i + k2_i·u_i² + k3_i·u_i³
//!           + Σ_j cross_quadratic[i][j]·DEGREE2[CROSS2[i][j]](u)
//!           + Σ_j cross_cubic[i][j]·DEGREE3[CROSS3[i][j]](u)
//! ```
//!
//! where `t` is the time since the start of the recording (s) and `θ` the sensor temperature
//! (°C) given in [`Conditions`]. The cross sums run over every monomial of degree 2 and 3 of
//! `u` except the output axis's own power (`u_i²`, `u_i³`), which `k2_i`, `k3_i` already
//! carry: [`DEGREE2`] and [`DEGREE3`] list the monomials in a fixed order, [`CROSS2`] and
//! [`CROSS3`] which of them each output axis uses, in the order of its coefficients. They are
//! evaluated left to right in `f32`, after the per-axis polynomial, so that a host and a
//! device get the same bits; when every cross coefficient is zero they are skipped and the
//! result is bit for bit the per-axis correction.
//!
//! What depends on the acceleration alone (the per-axis and the cross terms) is applied by
//! any user of the calibration, the adapter included; the time and temperature terms only by
//! a user that has a clock origin and a thermometer.

use crate::error::Error;
use crate::linalg::{all_finite, Mat3, Vec3};
use crate::terms::{self, TermId, CALIBRATION_FLOATS, EFFECT_FLOATS, TERMS};
use nalgebra::RealField;

/// The float types a calibration is held in: `f32` on the device, `f64` in the analysis.
/// nalgebra's [`RealField`] for the arithmetic (for `f32` every operation is the same IEEE
/// operation as a hand-written `f32` loop), plus two things it lacks: a test for non-zero
/// coefficients on the bits, which is a few integer instructions per coefficient on a
/// Cortex-M where a float compare is a call, and the conversions between the two types.
pub trait Real: RealField + Copy + Default {
    /// True when some value in any of the slices is non-zero (`±0` count as zero, NaN as
    /// non-zero, as `!= 0.0` does), branch-free over the bits.
    fn any_nonzero(slices: &[&[Self]]) -> bool;
    /// The value rounded to `f32` (the device's type).
    fn to_f32(self) -> f32;
    /// The `f32` value, exactly.
    fn from_f32(x: f32) -> Self;
}

impl Real for f32 {
    #[inline]
    fn any_nonzero(slices: &[&[f32]]) -> bool {
        let acc = slices
            .iter()
            .fold(0u32, |a, s| s.iter().fold(a, |a, c| a | c.to_bits()));
        acc << 1 != 0
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline]
    fn from_f32(x: f32) -> Self {
        x
    }
}

impl Real for f64 {
    #[inline]
    fn any_nonzero(slices: &[&[f64]]) -> bool {
        let acc = slices
            .iter()
            .fold(0u64, |a, s| s.iter().fold(a, |a, c| a | c.to_bits()));
        acc << 1 != 0
    }
    #[inline]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline]
    fn from_f32(x: f32) -> Self {
        f64::from(x)
    }
}

/// Operating conditions of a sample, needed only by the time- and temperature-dependent
/// effect terms.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ConditionsT<T> {
    /// Time since the start of the recording / power-up, in seconds.
    pub time_s: T,
    /// Sensor temperature in °C, if known. `None` disables temperature terms.
    pub temperature_c: Option<T>,
}

/// The device's conditions, in `f32`.
pub type Conditions = ConditionsT<f32>;

/// The degree-2 monomials of `u = (x, y, z)`, as exponents of `(x, y, z)`, in the fixed order
/// the cross coefficients refer to: `x², y², z², xy, xz, yz`.
pub const DEGREE2: [[u8; 3]; 6] = [
    [2, 0, 0],
    [0, 2, 0],
    [0, 0, 2],
    [1, 1, 0],
    [1, 0, 1],
    [0, 1, 1],
];

/// The degree-3 monomials of `u = (x, y, z)`, as exponents, in the fixed order the cross
/// coefficients refer to: `x³, y³, z³, x²y, x²z, xy², y²z, xz², yz², xyz`.
pub const DEGREE3: [[u8; 3]; 10] = [
    [3, 0, 0],
    [0, 3, 0],
    [0, 0, 3],
    [2, 1, 0],
    [2, 0, 1],
    [1, 2, 0],
    [0, 2, 1],
    [1, 0, 2],
    [0, 1, 2],
    [1, 1, 1],
];

/// For output axis `i`, the indices into [`DEGREE2`] of its five cross coefficients
/// `Effects::cross_quadratic[i]`: every degree-2 monomial but `u_i²` (index `i`), in order.
pub const CROSS2: [[usize; 5]; 3] = [[1, 2, 3, 4, 5], [0, 2, 3, 4, 5], [0, 1, 3, 4, 5]];

/// For output axis `i`, the indices into [`DEGREE3`] of its nine cross coefficients
/// `Effects::cross_cubic[i]`: every degree-3 monomial but `u_i³` (index `i`), in order.
pub const CROSS3: [[usize; 9]; 3] = [
    [1, 2, 3, 4, 5, 6, 7, 8, 9],
    [0, 2, 3, 4, 5, 6, 7, 8, 9],
    [0, 1, 3, 4, 5, 6, 7, 8, 9],
];

/// The monomials of [`DEGREE2`] and [`DEGREE3`] at `u`, in their table order.
#[inline]
pub fn monomials<T: Real>(u: &[T; 3]) -> ([T; 6], [T; 10]) {
    let [x, y, z] = *u;
    let (xx, yy, zz) = (x * x, y * y, z * z);
    (
        [xx, yy, zz, x * y, x * z, y * z],
        [
            xx * x,
            yy * y,
            zz * z,
            xx * y,
            xx * z,
            x * yy,
            yy * z,
            x * zz,
            y * zz,
            x * y * z,
        ],
    )
}

/// The per-axis transfer curve `x + k2·x² + k3·x³` of the correction, evaluated left to right
/// (the device's bits in `f32`); the analysis's `f64` model evaluates the same function.
#[inline(always)]
pub fn axis_polynomial<T: Real>(x: T, k2: T, k3: T) -> T {
    x + k2 * x * x + k3 * x * x * x
}

/// The reading with the bias removed at a condition,
/// `m − b − drift·t − later_in_time − bias_temp·Δθ`, subtracted term by term in this order per
/// axis (`Δθ = θ − θ₀`; `None` without a thermometer: the temperature term is left out).
/// `later_in_time` is a further time-dependent bias already evaluated, zero for the core's
/// calibration (the analysis's `f64` model passes its drift curvature `d₂·τ²` there). The one
/// formula of [`CalibrationT::correct`] (the device's `f32`) and of the analysis's model,
/// which calls it with its normalised time and temperature.
#[inline(always)]
pub fn remove_bias<T: Real>(
    m: &[T; 3],
    bias: &[T; 3],
    drift: &[T; 3],
    time: T,
    later_in_time: &[T; 3],
    temp: &[T; 3],
    dtheta: Option<T>,
) -> [T; 3] {
    core::array::from_fn(|i| {
        let d = m[i] - bias[i] - drift[i] * time - later_in_time[i];
        match dtheta {
            Some(dt) => d - temp[i] * dt,
            None => d,
        }
    })
}

/// `K·d`, each row summed left to right: the linear step of the correction (`d` the reading
/// with the bias removed). Written out so that it compiles to straight-line multiply–adds on
/// a Cortex-M.
#[inline(always)]
pub fn linear<T: Real>(k: &[[T; 3]; 3], d: &[T; 3]) -> [T; 3] {
    [
        k[0][0] * d[0] + k[0][1] * d[1] + k[0][2] * d[2],
        k[1][0] * d[0] + k[1][1] * d[1] + k[1][2] * d[2],
        k[2][0] * d[0] + k[2][1] * d[1] + k[2][2] * d[2],
    ]
}

/// The relative scale `1 + scale_temp·Δθ` one axis's linearly corrected reading is multiplied
/// by.
#[inline(always)]
pub fn temperature_scale<T: Real>(scale_temp: T, dtheta: T) -> T {
    T::one() + scale_temp * dtheta
}

/// Optional effect terms beyond the linear model, in the float type `T`. All zero means
/// "linear model only". The fields are the rows of [`crate::terms::TERMS`], in its order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
#[cfg_attr(
    feature = "serde",
    serde(bound(
        serialize = "T: serde::Serialize + PartialEq + Default",
        deserialize = "T: serde::Deserialize<'de> + Default"
    ))
)]
pub struct EffectsT<T> {
    /// Per-axis even-order nonlinearity `k2` (1/reference unit): `a = u + k2·u²`.
    pub quadratic: [T; 3],
    /// Per-axis odd-order nonlinearity `k3` (1/reference unit²): `a = u + k3·u³`.
    pub cubic: [T; 3],
    /// Bias drift with time, raw units per second.
    pub bias_drift: [T; 3],
    /// Reference temperature `θ₀` for the temperature terms, °C.
    pub temp_ref_c: T,
    /// Bias temperature coefficient, raw units per °C.
    pub bias_temp: [T; 3],
    /// Relative scale temperature coefficient, 1/°C.
    pub scale_temp: [T; 3],
    /// Orientation-dependent degree-2 cross terms (1/reference unit, i.e. 1/g): row `i`
    /// holds the coefficients of output axis `i` for the monomials [`DEGREE2`]`[`[`CROSS2`]`[i][j]]`
    /// (every square and product but `u_i²`). Applied by the adapter. Left out of serde
    /// output when all zero, so that JSON without cross terms is what it was before them.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "rows_are_zero"))]
    pub cross_quadratic: [[T; 5]; 3],
    /// Orientation-dependent degree-3 cross terms (1/reference unit², i.e. 1/g²): row `i`
    /// holds the coefficients of output axis `i` for the monomials [`DEGREE3`]`[`[`CROSS3`]`[i][j]]`
    /// (every cubic monomial but `u_i³`, `xyz` included). Applied by the adapter. Left out of
    /// serde output when all zero.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "rows_are_zero"))]
    pub cross_cubic: [[T; 9]; 3],
}

/// The device's effect terms, in `f32`.
pub type Effects = EffectsT<f32>;

/// True when every coefficient is zero (serde: cross terms left out of the output).
#[cfg(feature = "serde")]
fn rows_are_zero<T: PartialEq + Default, const N: usize>(rows: &[[T; N]; 3]) -> bool {
    rows.iter().flatten().all(|x| *x == T::default())
}

impl<T: Real> EffectsT<T> {
    /// The coefficients of term `id`, flattened row-major (the row of `TERMS` says how many).
    /// The one place a field is tied to its table row.
    pub fn field(&self, id: TermId) -> &[T] {
        match id {
            TermId::Quadratic => &self.quadratic,
            TermId::Cubic => &self.cubic,
            TermId::BiasDrift => &self.bias_drift,
            TermId::TempRef => core::slice::from_ref(&self.temp_ref_c),
            TermId::BiasTemp => &self.bias_temp,
            TermId::ScaleTemp => &self.scale_temp,
            TermId::CrossQuadratic => self.cross_quadratic.as_flattened(),
            TermId::CrossCubic => self.cross_cubic.as_flattened(),
            // A gyro term (`terms::GYRO_TERMS`): no field of the accelerometer's calibration.
            TermId::GSensitivity => &[],
        }
    }

    /// [`Self::field`], mutable.
    pub fn field_mut(&mut self, id: TermId) -> &mut [T] {
        match id {
            TermId::Quadratic => &mut self.quadratic,
            TermId::Cubic => &mut self.cubic,
            TermId::BiasDrift => &mut self.bias_drift,
            TermId::TempRef => core::slice::from_mut(&mut self.temp_ref_c),
            TermId::BiasTemp => &mut self.bias_temp,
            TermId::ScaleTemp => &mut self.scale_temp,
            TermId::CrossQuadratic => self.cross_quadratic.as_flattened_mut(),
            TermId::CrossCubic => self.cross_cubic.as_flattened_mut(),
            TermId::GSensitivity => &mut [],
        }
    }

    /// Every coefficient, in the canonical order of [`TERMS`].
    pub fn coefficients(&self) -> [T; EFFECT_FLOATS] {
        let mut out = [T::zero(); EFFECT_FLOATS];
        let mut at = 0;
        for t in &TERMS {
            out[at..at + t.len()].copy_from_slice(self.field(t.id));
            at += t.len();
        }
        out
    }

    /// The effects from coefficients in the canonical order; missing trailing ones (an
    /// older format without the newest terms) are zero, extra ones are ignored.
    pub fn from_coefficients(c: &[T]) -> Self {
        let mut e = Self::default();
        let mut at = 0;
        for t in &TERMS {
            for (k, x) in e.field_mut(t.id).iter_mut().enumerate() {
                *x = c.get(at + k).copied().unwrap_or_else(T::zero);
            }
            at += t.len();
        }
        e
    }

    /// True when some effect term (not the reference) described by a row for which
    /// `which` holds is non-zero.
    pub fn any_term(&self, which: impl Fn(&terms::TermSpec) -> bool) -> bool {
        TERMS
            .iter()
            .filter(|t| t.is_term() && which(t))
            .any(|t| T::any_nonzero(&[self.field(t.id)]))
    }

    /// True when every term is zero (the correction is purely linear).
    pub fn is_none(&self) -> bool {
        !self.any_term(|_| true)
    }

    /// True when some orientation-dependent cross coefficient is non-zero.
    #[inline]
    pub fn has_cross_terms(&self) -> bool {
        // Branch-free OR of the bits without the sign (±0 count as zero, as `!= 0.0` does):
        // on a Cortex-M this is a few integer instructions per coefficient. Called per sample
        // by `correct`, so the two fields are named here rather than found in the table (a
        // test checks they are the table's cross rows).
        T::any_nonzero(&[
            self.cross_quadratic.as_flattened(),
            self.cross_cubic.as_flattened(),
        ])
    }

    /// True when some term that needs a clock or a thermometer (bias drift, bias or scale
    /// temperature coefficient) is non-zero: the terms a user without them cannot apply.
    pub fn has_time_or_temperature_terms(&self) -> bool {
        self.any_term(|t| t.needs != terms::Needs::Reading)
    }

    /// The cross terms' contribution to each output axis at `u` (see the module docs for the
    /// order of evaluation), in reference units.
    #[inline]
    pub fn cross_terms(&self, u: &[T; 3]) -> [T; 3] {
        let (m2, m3) = monomials(u);
        let mut out = [T::zero(); 3];
        for (i, o) in out.iter_mut().enumerate() {
            let mut s = T::zero();
            for (c, k) in self.cross_quadratic[i].iter().zip(CROSS2[i]) {
                s += *c * m2[k];
            }
            for (c, k) in self.cross_cubic[i].iter().zip(CROSS3[i]) {
                s += *c * m3[k];
            }
            *o = s;
        }
        out
    }

    /// The per-axis polynomial of output axis `i` at `x = u_i` ([`axis_polynomial`]).
    #[inline]
    pub fn axis_polynomial(&self, i: usize, x: T) -> T {
        axis_polynomial(x, self.quadratic[i], self.cubic[i])
    }

    /// The effects in another float type (each coefficient converted on its own).
    pub fn cast<U: Real>(&self, f: impl Fn(T) -> U) -> EffectsT<U> {
        EffectsT::from_coefficients(&self.coefficients().map(f))
    }

    fn all_finite(&self) -> bool {
        self.coefficients().iter().all(|x| x.is_finite())
    }
}

/// A sensor calibration: the inverse of the measurement model, in the float type `T`.
///
/// `matrix` is `K = D⁻¹` (row-major), mapping de-biased raw units to reference units;
/// `bias` is `b` in raw units. The seed's worked example prints `K` under the name "D".
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(bound(
        serialize = "T: serde::Serialize + PartialEq + Default",
        deserialize = "T: serde::Deserialize<'de> + Default"
    ))
)]
pub struct CalibrationT<T> {
    /// Bias `b`, raw units.
    pub bias: [T; 3],
    /// Correction matrix `K = D⁻¹`, row-major, reference units per raw unit.
    pub matrix: [[T; 3]; 3],
    /// Extra effect terms; zero for the linear model.
    #[cfg_attr(feature = "serde", serde(default))]
    pub effects: EffectsT<T>,
}

/// The device's calibration, in `f32`: what the adapter stores and applies, the wire and the
/// calibration file carry.
pub type Calibration = CalibrationT<f32>;

impl<T: Real> Default for CalibrationT<T> {
    fn default() -> Self {
        Self::pass_through()
    }
}

impl Calibration {
    /// The pass-through calibration: zero bias, identity matrix, no effects.
    pub const fn identity() -> Self {
        Self {
            bias: [0.0; 3],
            matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            effects: Effects {
                quadratic: [0.0; 3],
                cubic: [0.0; 3],
                bias_drift: [0.0; 3],
                temp_ref_c: 0.0,
                bias_temp: [0.0; 3],
                scale_temp: [0.0; 3],
                cross_quadratic: [[0.0; 5]; 3],
                cross_cubic: [[0.0; 9]; 3],
            },
        }
    }

    /// Build a calibration from the forward model `m = D·a + b` by inverting `D`.
    pub fn from_forward(d: &Mat3, b: &Vec3) -> Result<Self, Error> {
        if !all_finite(d.as_slice()) || !all_finite(b.as_slice()) {
            return Err(Error::NonFinite);
        }
        let k = invert3(d)?;
        Ok(Self::from_inverse(&k, b))
    }

    /// Build a calibration directly from `K = D⁻¹` and `b`.
    pub fn from_inverse(k: &Mat3, b: &Vec3) -> Self {
        Self {
            bias: [b.x, b.y, b.z],
            matrix: mat3_to_rows(k),
            effects: Effects::default(),
        }
    }

    /// `K = D⁻¹` as an nalgebra matrix.
    pub fn k(&self) -> Mat3 {
        rows_to_mat3(&self.matrix)
    }

    /// `b` as an nalgebra vector.
    pub fn b(&self) -> Vec3 {
        Vec3::new(self.bias[0], self.bias[1], self.bias[2])
    }

    /// The forward matrix `D = K⁻¹`.
    pub fn forward_matrix(&self) -> Result<Mat3, Error> {
        invert3(&self.k())
    }

    /// Checks that every parameter is finite and `K` is invertible, so that a calibration read
    /// from untrusted storage can be used safely.
    pub fn validate(&self) -> Result<(), Error> {
        let flat_ok = all_finite(&self.bias)
            && self.matrix.iter().all(|r| all_finite(r))
            && self.effects.all_finite();
        if !flat_ok {
            return Err(Error::NonFinite);
        }
        invert3(&self.k()).map(|_| ())
    }

    /// The canonical bit encoding: the IEEE bits of every float in the order of
    /// [`Self::floats`]. Two calibrations are the same exactly when their bits are (so that
    /// `-0.0 ≠ 0.0` and NaN payloads count); host and adapter compare with it.
    pub fn bits(&self) -> [u32; CALIBRATION_FLOATS] {
        self.floats().map(f32::to_bits)
    }

    /// Bitwise equality of every parameter ([`Self::bits`]).
    pub fn bits_equal(&self, other: &Self) -> bool {
        self.bits() == other.bits()
    }

    /// This calibration with its term flags found once, for per-sample correction.
    pub fn prepare(&self) -> PreparedCalibration {
        PreparedCalibration::new(*self)
    }
}

impl<T: Real> CalibrationT<T> {
    /// The pass-through calibration in any float type (see [`Calibration::identity`]).
    pub fn pass_through() -> Self {
        let (o, z) = (T::one(), T::zero());
        Self {
            bias: [z; 3],
            matrix: [[o, z, z], [z, o, z], [z, z, o]],
            effects: EffectsT::default(),
        }
    }

    /// Every parameter in the canonical order: bias (3), `K` row-major (9), then the effect
    /// coefficients in the order of [`TERMS`] ([`EffectsT::coefficients`]).
    pub fn floats(&self) -> [T; CALIBRATION_FLOATS] {
        let mut out = [T::zero(); CALIBRATION_FLOATS];
        out[..3].copy_from_slice(&self.bias);
        out[3..12].copy_from_slice(self.matrix.as_flattened());
        out[12..].copy_from_slice(&self.effects.coefficients());
        out
    }

    /// The calibration from floats in the order of [`Self::floats`]; missing trailing ones
    /// (an older format without the newest terms) are zero.
    pub fn from_floats(f: &[T]) -> Self {
        let at = |i: usize| f.get(i).copied().unwrap_or_else(T::zero);
        let v3 = |i: usize| [at(i), at(i + 1), at(i + 2)];
        Self {
            bias: v3(0),
            matrix: [v3(3), v3(6), v3(9)],
            effects: EffectsT::from_coefficients(f.get(12..).unwrap_or(&[])),
        }
    }

    /// The calibration in another float type, each parameter converted on its own (e.g.
    /// `cal.cast(Real::to_f32)` for the device's `f32` calibration of an `f64` fit).
    pub fn cast<U: Real>(&self, f: impl Fn(T) -> U) -> CalibrationT<U> {
        CalibrationT::from_floats(&self.floats().map(f))
    }

    /// Linear correction `a = K·(m − b)`, ignoring effect terms. This is the hot path
    /// (a handful of FPU instructions): written out by hand so it compiles to straight-line
    /// multiply–adds on a Cortex-M.
    #[inline]
    pub fn correct_linear(&self, m: [T; 3]) -> [T; 3] {
        self.linear_with_bias(m, &self.bias)
    }

    /// `K·(m − b)` for a given bias `b` (the calibration's, or the drift- and
    /// temperature-shifted one), without copying the calibration.
    #[inline]
    fn linear_with_bias(&self, m: [T; 3], b: &[T; 3]) -> [T; 3] {
        linear(&self.matrix, &[m[0] - b[0], m[1] - b[1], m[2] - b[2]])
    }

    /// Full correction including the effect terms (see the module docs for their definition).
    ///
    /// The convenience path: it finds on every call whether the calibration has cross terms
    /// (42 coefficients tested; about 90 of its ≈ 190 instructions per sample on a
    /// Cortex-M33 when there are none). A caller correcting many samples with one calibration
    /// builds a [`PreparedCalibration`] once ([`Calibration::prepare`]) and corrects with it:
    /// the same bits, without the per-sample test.
    pub fn correct(&self, m: [T; 3], cond: &ConditionsT<T>) -> [T; 3] {
        self.correct_with(m, cond, self.effects.has_cross_terms())
    }

    /// [`Self::correct`] with the cross-term test already done: `cross` is
    /// `self.effects.has_cross_terms()` (found once by [`PreparedCalibration::new`]);
    /// `false` skips the cross terms. Private so that the flag cannot disagree with the
    /// coefficients. One branch here, then straight-line code: each case is its own
    /// instantiation, so that without cross terms no per-axis test or select is left.
    #[inline]
    fn correct_with(&self, m: [T; 3], cond: &ConditionsT<T>, cross: bool) -> [T; 3] {
        if cross {
            self.correct_terms::<true>(m, cond)
        } else {
            self.correct_terms::<false>(m, cond)
        }
    }

    /// The correction of the module docs, with (`CROSS`) or without the cross terms.
    ///
    /// Out of line: each instantiation exists once however many callers there are, and a
    /// caller that often takes another path (the adapter's linear one) keeps a small stack
    /// frame. Measured on a Cortex-M33 under QEMU, inlining it saves 6 instructions per
    /// sample without cross terms but costs 12 with them and 64 B more stack.
    #[inline(never)]
    fn correct_terms<const CROSS: bool>(&self, m: [T; 3], cond: &ConditionsT<T>) -> [T; 3] {
        let e = &self.effects;
        let dtheta = cond.temperature_c.map(|t| t - e.temp_ref_c);
        let zero = [T::zero(); 3];
        let (drift, temp) = (&e.bias_drift, &e.bias_temp);
        let d = remove_bias(&m, &self.bias, drift, cond.time_s, &zero, temp, dtheta);
        let mut u = linear(&self.matrix, &d);
        for (i, ui) in u.iter_mut().enumerate() {
            if let Some(dt) = dtheta {
                *ui *= temperature_scale(e.scale_temp[i], dt);
            }
        }
        // The per-axis polynomial, then (left to right, after it) the cross sum of the same u.
        let mut a = [T::zero(); 3];
        for ((ai, x), i) in a.iter_mut().zip(u).zip(0..) {
            *ai = e.axis_polynomial(i, x);
        }
        if CROSS {
            for (ai, c) in a.iter_mut().zip(e.cross_terms(&u)) {
                *ai += c;
            }
        }
        a
    }
}

/// Which effect terms a calibration has, found once by [`PreparedCalibration::new`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Terms {
    /// Every effect term is zero ([`Effects::is_none`]): the model is the linear one. A user
    /// that wants exactly [`Calibration::correct_linear`] for such a calibration (as the
    /// adapter does) branches on this; [`PreparedCalibration::correct`] does not, because the
    /// full path differs from the linear one in the sign of a zero or for non-finite input.
    pub linear_only: bool,
    /// Some orientation-dependent cross coefficient is non-zero ([`Effects::has_cross_terms`]).
    pub cross: bool,
    /// Some term that needs a clock or a thermometer is non-zero
    /// ([`Effects::has_time_or_temperature_terms`]): a user without them cannot apply the
    /// whole calibration.
    pub time_or_temperature: bool,
}

impl Terms {
    /// The flags of `e`.
    pub fn of(e: &Effects) -> Self {
        Self {
            linear_only: e.is_none(),
            cross: e.has_cross_terms(),
            time_or_temperature: e.has_time_or_temperature_terms(),
        }
    }
}

/// A [`Calibration`] with its [`Terms`] found once: the per-sample correction path.
///
/// [`PreparedCalibration::correct`] returns bit for bit what [`Calibration::correct`] returns,
/// without testing the 42 cross coefficients on every call (on a Cortex-M33 under QEMU, all
/// effect terms and no cross terms: 94 instructions per sample instead of 186, with them 206
/// instead of 298; see BENCHMARKS.md). The calibration is private and immutable, so the flags
/// always describe its coefficients; it is not serialised (store the [`Calibration`] and
/// prepare it after loading).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedCalibration {
    cal: Calibration,
    terms: Terms,
}

impl PreparedCalibration {
    /// Finds the terms of `cal` (about 70 coefficient tests, once).
    pub fn new(cal: Calibration) -> Self {
        Self {
            terms: Terms::of(&cal.effects),
            cal,
        }
    }

    /// The calibration.
    pub fn calibration(&self) -> &Calibration {
        &self.cal
    }

    /// Which effect terms it has.
    pub fn terms(&self) -> Terms {
        self.terms
    }

    /// [`Calibration::correct`], with the cross-term test done at construction.
    #[inline]
    pub fn correct(&self, m: [f32; 3], cond: &Conditions) -> [f32; 3] {
        self.cal.correct_with(m, cond, self.terms.cross)
    }

    /// [`Calibration::correct_linear`] (the effect terms ignored).
    #[inline]
    pub fn correct_linear(&self, m: [f32; 3]) -> [f32; 3] {
        self.cal.correct_linear(m)
    }
}

impl From<Calibration> for PreparedCalibration {
    fn from(cal: Calibration) -> Self {
        Self::new(cal)
    }
}

/// Row-major array to nalgebra matrix.
pub fn rows_to_mat3(r: &[[f32; 3]; 3]) -> Mat3 {
    Mat3::new(
        r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
    )
}

/// nalgebra matrix to row-major array.
pub fn mat3_to_rows(m: &Mat3) -> [[f32; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

/// Inverse of a 3×3 matrix, refusing matrices whose condition makes the inverse meaningless
/// in `f32` (determinant tiny relative to the product of row norms).
pub fn invert3(m: &Mat3) -> Result<Mat3, Error> {
    crate::linalg::invert3_checked(m, 1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_then_correct_recovers_truth() {
        let d = Mat3::new(25.0, 0.04, 0.0, -0.4, 26.0, 0.4, 0.0, 0.3, 24.6);
        let b = Vec3::new(128.0, 127.5, 129.6);
        let cal = Calibration::from_forward(&d, &b).unwrap();
        let a = Vec3::new(0.3, -0.5, 0.8);
        let m = d * a + b;
        let got = cal.correct_linear([m.x, m.y, m.z]);
        for i in 0..3 {
            assert!((got[i] - a[i]).abs() < 1e-5, "{got:?} vs {a:?}");
        }
        // With no effects the full correction equals the linear one.
        let cond = Conditions {
            time_s: 100.0,
            temperature_c: Some(40.0),
        };
        assert_eq!(cal.correct([m.x, m.y, m.z], &cond), got);
    }

    #[test]
    fn singular_and_nan_are_refused() {
        let d = Mat3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0);
        assert_eq!(
            Calibration::from_forward(&d, &Vec3::zeros()),
            Err(Error::Singular)
        );
        let mut cal = Calibration::identity();
        cal.bias[1] = f32::NAN;
        assert_eq!(cal.validate(), Err(Error::NonFinite));
    }

    /// A calibration with every field distinct, so that a misplaced float shows.
    fn numbered() -> Calibration {
        let f: [f32; CALIBRATION_FLOATS] = core::array::from_fn(|i| 1.0 + i as f32);
        Calibration::from_floats(&f)
    }

    /// The canonical order against the layout written out by hand (the flash record's and
    /// the wire's field order since their first versions): bias, K row-major, quadratic,
    /// cubic, bias_drift, temp_ref_c, bias_temp, scale_temp, cross_quadratic, cross_cubic.
    #[test]
    fn floats_follow_the_published_layout() {
        let c = numbered();
        let e = &c.effects;
        assert_eq!(c.bias, [1.0, 2.0, 3.0]);
        assert_eq!(
            c.matrix,
            [[4.0, 5.0, 6.0], [7.0, 8.0, 9.0], [10.0, 11.0, 12.0]]
        );
        assert_eq!(e.quadratic, [13.0, 14.0, 15.0]);
        assert_eq!(e.cubic, [16.0, 17.0, 18.0]);
        assert_eq!(e.bias_drift, [19.0, 20.0, 21.0]);
        assert_eq!(e.temp_ref_c, 22.0);
        assert_eq!(e.bias_temp, [23.0, 24.0, 25.0]);
        assert_eq!(e.scale_temp, [26.0, 27.0, 28.0]);
        assert_eq!(e.cross_quadratic[0], [29.0, 30.0, 31.0, 32.0, 33.0]);
        assert_eq!(e.cross_quadratic[2][4], 43.0);
        assert_eq!(e.cross_cubic[0][0], 44.0);
        assert_eq!(e.cross_cubic[2][8], 70.0);
        assert_eq!(Calibration::from_floats(&c.floats()), c);
        // An older format's shorter payload: the newest terms read as zero.
        let v1 =
            Calibration::from_floats(&c.floats()[..12 + crate::terms::floats_through_record(1)]);
        assert_eq!(v1.effects.scale_temp, e.scale_temp);
        assert!(!v1.effects.has_cross_terms());
    }

    /// The bit encoding tells apart what `==` does not (signed zero, NaN payloads) and
    /// nothing else.
    #[test]
    fn bits_compare_every_float() {
        let a = numbered();
        assert!(a.bits_equal(&a));
        let mut b = a;
        b.effects.cross_cubic[1][3] = -b.effects.cross_cubic[1][3];
        assert!(!a.bits_equal(&b));
        let (mut z, mut nz) = (Calibration::identity(), Calibration::identity());
        nz.effects.bias_temp[2] = -0.0;
        assert_eq!(z, nz);
        assert!(!z.bits_equal(&nz));
        z.bias[0] = f32::NAN;
        let same = z;
        assert!(z.bits_equal(&same) && z != same);
    }

    /// The flags read from the table agree with the fields: each term alone, set non-zero.
    #[test]
    fn term_flags_follow_the_table() {
        use crate::terms::{Needs, Shape};
        assert!(Effects::default().is_none());
        for t in TERMS {
            let mut e = Effects::default();
            e.field_mut(t.id)[t.len() - 1] = -0.5;
            let flags = Terms::of(&e);
            assert_eq!(flags.linear_only, !t.is_term(), "{}", t.name);
            assert_eq!(
                flags.cross,
                matches!(t.shape, Shape::Cross(_)),
                "{}",
                t.name
            );
            assert_eq!(
                flags.time_or_temperature,
                t.is_term() && t.needs != Needs::Reading,
                "{}",
                t.name
            );
        }
    }

    /// The `f64` instantiation is the same correction: on a calibration with every term, the
    /// `f64` result of the `f32` parameters agrees with the `f32` result to `f32` rounding, and
    /// an `f64` reference written out independently of the generic code agrees with both.
    #[test]
    fn the_f64_correction_is_the_f32_one() {
        let mut c = Calibration::identity();
        c.bias = [510.0, 505.0, 515.0];
        c.matrix = [[0.005, 1e-5, 0.0], [0.0, 0.0051, -2e-5], [0.0, 0.0, 0.0049]];
        let e = &mut c.effects;
        e.quadratic = [0.01, -0.02, 0.005];
        e.cubic = [0.003, 0.0, -0.004];
        e.bias_drift = [0.01, -0.02, 0.0];
        e.temp_ref_c = 25.0;
        e.bias_temp = [0.5, 0.0, -0.3];
        e.scale_temp = [1e-3, -2e-3, 0.0];
        e.cross_quadratic[0][3] = 0.02;
        e.cross_cubic[2][7] = -0.01;
        let c64 = c.cast(f64::from_f32);
        assert_eq!(c64.cast(f64::to_f32), c);
        let (m, t, th) = ([700.0f32, 410.0, 600.0], 30.0f32, 31.0f32);
        let a32 = c.correct(
            m,
            &Conditions {
                time_s: t,
                temperature_c: Some(th),
            },
        );
        let cond64 = ConditionsT {
            time_s: f64::from(t),
            temperature_c: Some(f64::from(th)),
        };
        let a64 = c64.correct(m.map(f64::from), &cond64);
        // Independent reference: the module docs' formula, written out.
        let p = |x: f32| f64::from(x);
        let e = &c.effects;
        let dth = p(th) - p(e.temp_ref_c);
        let d: [f64; 3] = core::array::from_fn(|j| {
            p(m[j]) - (p(c.bias[j]) + p(e.bias_drift[j]) * p(t) + p(e.bias_temp[j]) * dth)
        });
        let u: [f64; 3] = core::array::from_fn(|i| {
            (0..3).map(|j| p(c.matrix[i][j]) * d[j]).sum::<f64>() * (1.0 + p(e.scale_temp[i]) * dth)
        });
        let poly = |i: usize| u[i] + p(e.quadratic[i]) * u[i] * u[i] + p(e.cubic[i]) * u[i].powi(3);
        // Row 0, coefficient 3 is the monomial DEGREE2[CROSS2[0][3]] = x·z; row 2,
        // coefficient 7 is DEGREE3[CROSS3[2][7]] = y·z².
        let want = [
            poly(0) + p(e.cross_quadratic[0][3]) * u[0] * u[2],
            poly(1),
            poly(2) + p(e.cross_cubic[2][7]) * u[1] * u[2] * u[2],
        ];
        assert_eq!(CROSS2[0][3], 4);
        assert_eq!(DEGREE2[4], [1, 0, 1]);
        assert_eq!(DEGREE3[CROSS3[2][7]], [0, 1, 2]);
        for i in 0..3 {
            assert!((a64[i] - want[i]).abs() < 1e-12, "{a64:?} vs {want:?}");
            assert!(
                (f64::from(a32[i]) - want[i]).abs() < 1e-5,
                "{a32:?} vs {want:?}"
            );
        }
    }

    #[test]
    fn effects_follow_their_definition() {
        let mut cal = Calibration::identity();
        cal.effects.bias_drift = [1.0, 0.0, 0.0];
        cal.effects.quadratic = [0.0, 0.1, 0.0];
        cal.effects.cubic = [0.0, 0.0, 0.01];
        cal.effects.temp_ref_c = 25.0;
        cal.effects.bias_temp = [0.0, 0.0, 2.0];
        let cond = Conditions {
            time_s: 2.0,
            temperature_c: Some(26.0),
        };
        let a = cal.correct([5.0, 2.0, 4.0], &cond);
        // x: 5 - 1*2 = 3; y: 2 + 0.1*4 = 2.4; z: (4 - 2) = 2 -> 2 + 0.01*8 = 2.08
        assert!((a[0] - 3.0).abs() < 1e-6);
        assert!((a[1] - 2.4).abs() < 1e-6);
        assert!((a[2] - 2.08).abs() < 1e-6);
    }
}
