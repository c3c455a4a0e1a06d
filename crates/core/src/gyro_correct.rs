//! The gyroscope's correction as a device or a host applies it, with its effect terms.
//!
//! ```text
//! ω = K·(m − b) − G·a
//! ```
//!
//! `m` raw gyro counts, `b` the bias (counts), `K` raw → rad/s (row-major; scale and
//! misalignment into the accelerometer's frame, as [`crate::gyro::GyroCalibration`] fits
//! them), `ω` rad/s in the sensor frame. `G` is the g-sensitivity: the bias a gyro adds per g
//! of specific force, in rad/s per g, row = gyro output axis, column = specific-force
//! component; `a` is the accelerometer's calibrated reading of the same sample, in g, in the
//! same frame (`[0, 0, 1]` for a level, still sensor with `+z` up). The sign is the one the
//! forward model `K·(m − b) = ω + G·a` gives: a gyro at rest reads `G·a`, the correction takes
//! it off. Datasheets quote `G` in °/s/g (consumer MEMS ≈ 0.1 °/s/g); the analysis reports it
//! so (`wiical gyrofit`), files and this type hold it in rad/s/g, the unit of `ω`.
//!
//! Evaluation order, fixed so that a host and a device get the same bits: per output axis the
//! linear row `k_i0·d_0 + k_i1·d_1 + k_i2·d_2` (`d = m − b`), then the `G` row
//! `g_i0·a_0 + g_i1·a_1 + g_i2·a_2`, then their difference. Generic over the float type
//! ([`Real`]): `f32` on a device, `f64` in the analysis, one algorithm.
//!
//! The terms are the rows of [`crate::terms::GYRO_TERMS`]; [`GyroEffects::field`] is the one
//! place a field is tied to its row. The adapter holds the linear part for a MotionPlus
//! (protocol 7, judged by `acceptance::Acceptance::check_gyro`), not the terms: they are
//! applied by an embedded user or a host that has the accelerometer reading beside the gyro.

use crate::model::Real;
use crate::terms::{TermId, GYRO_CALIBRATION_FLOATS, GYRO_EFFECT_FLOATS, GYRO_TERMS};
use crate::Error;

/// Largest plausible g-sensitivity coefficient, rad/s per g (5 °/s/g: fifty times the
/// ≈ 0.1 °/s/g datasheets give for consumer MEMS gyros). A larger value is a fit to something
/// else (hand-held windows, a wrong frame), and [`GyroCorrection::validate`] refuses it.
pub const G_SENSITIVITY_MAX: f64 = 5.0 * core::f64::consts::PI / 180.0;

/// The gyro's effect terms in the float type `T`; all zero is the linear model. The fields
/// are the rows of [`GYRO_TERMS`], in its order.
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
pub struct GyroEffects<T> {
    /// `G`, rad/s per g: row `i` is gyro output axis `i`, column `j` the specific-force
    /// component `a_j` (see the module docs for the sign).
    pub g_sensitivity: [[T; 3]; 3],
}

impl<T: Real> GyroEffects<T> {
    /// The coefficients of term `id` flattened row-major; empty for an id of the
    /// accelerometer's table ([`crate::terms::TERMS`]), which has no field here.
    pub fn field(&self, id: TermId) -> &[T] {
        match id {
            TermId::GSensitivity => self.g_sensitivity.as_flattened(),
            _ => &[],
        }
    }

    /// [`Self::field`], mutable.
    pub fn field_mut(&mut self, id: TermId) -> &mut [T] {
        match id {
            TermId::GSensitivity => self.g_sensitivity.as_flattened_mut(),
            _ => &mut [],
        }
    }

    /// Every coefficient, in the canonical order of [`GYRO_TERMS`].
    pub fn coefficients(&self) -> [T; GYRO_EFFECT_FLOATS] {
        let mut out = [T::zero(); GYRO_EFFECT_FLOATS];
        let mut at = 0;
        for t in &GYRO_TERMS {
            out[at..at + t.len()].copy_from_slice(self.field(t.id));
            at += t.len();
        }
        out
    }

    /// The effects from coefficients in the canonical order; missing trailing ones are zero.
    pub fn from_coefficients(c: &[T]) -> Self {
        let mut e = Self::default();
        let mut at = 0;
        for t in &GYRO_TERMS {
            for (k, x) in e.field_mut(t.id).iter_mut().enumerate() {
                *x = c.get(at + k).copied().unwrap_or_else(T::zero);
            }
            at += t.len();
        }
        e
    }

    /// True when every term is zero (the correction is the linear one).
    pub fn is_none(&self) -> bool {
        !GYRO_TERMS
            .iter()
            .any(|t| T::any_nonzero(&[self.field(t.id)]))
    }

    /// True when a non-zero term needs the accelerometer's reading (a user without it cannot
    /// apply the whole calibration).
    pub fn needs_specific_force(&self) -> bool {
        GYRO_TERMS
            .iter()
            .filter(|t| t.needs == crate::terms::Needs::SpecificForce)
            .any(|t| T::any_nonzero(&[self.field(t.id)]))
    }
}

/// A gyro calibration with its effect terms, in the float type `T` (row-major arrays, as
/// [`crate::Calibration`], so that it reads the way it is printed and stored).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(bound(
        serialize = "T: serde::Serialize + PartialEq + Default",
        deserialize = "T: serde::Deserialize<'de> + Default"
    ))
)]
pub struct GyroCorrection<T> {
    /// `b`, raw counts: the reading at zero rate and zero specific force.
    pub bias: [T; 3],
    /// `K`, rad/s per count, row-major.
    pub matrix: [[T; 3]; 3],
    /// The effect terms; zero for the linear model.
    #[cfg_attr(feature = "serde", serde(default))]
    pub effects: GyroEffects<T>,
}

impl<T: Real> GyroCorrection<T> {
    /// The fitted linear calibration ([`crate::gyro::GyroCalibration`]) with no effect terms.
    pub fn from_fit(cal: &crate::gyro::GyroCalibration<T>) -> Self {
        Self {
            bias: cal.bias.into(),
            matrix: core::array::from_fn(|r| core::array::from_fn(|c| cal.matrix[(r, c)])),
            effects: GyroEffects::default(),
        }
    }

    /// `K·(m − b)`, rad/s: the correction without effect terms.
    #[inline]
    pub fn correct_linear(&self, m: [T; 3]) -> [T; 3] {
        let d = [
            m[0] - self.bias[0],
            m[1] - self.bias[1],
            m[2] - self.bias[2],
        ];
        let k = &self.matrix;
        [
            k[0][0] * d[0] + k[0][1] * d[1] + k[0][2] * d[2],
            k[1][0] * d[0] + k[1][1] * d[1] + k[1][2] * d[2],
            k[2][0] * d[0] + k[2][1] * d[1] + k[2][2] * d[2],
        ]
    }

    /// `ω = K·(m − b) − G·a`, rad/s, with `a` the accelerometer's calibrated reading of the
    /// same sample in g (see the module docs for the order of evaluation). Straight-line: with
    /// `G` zero it costs the nine multiply–adds of the `G` row all the same, and differs from
    /// [`Self::correct_linear`] at most in the sign of a zero.
    #[inline]
    pub fn correct(&self, m: [T; 3], specific_force_g: [T; 3]) -> [T; 3] {
        let u = self.correct_linear(m);
        let g = &self.effects.g_sensitivity;
        let a = specific_force_g;
        [
            u[0] - (g[0][0] * a[0] + g[0][1] * a[1] + g[0][2] * a[2]),
            u[1] - (g[1][0] * a[0] + g[1][1] * a[1] + g[1][2] * a[2]),
            u[2] - (g[2][0] * a[0] + g[2][1] * a[1] + g[2][2] * a[2]),
        ]
    }

    /// Every parameter in the canonical order: bias (3), `K` row-major (9), then the effect
    /// coefficients in the order of [`GYRO_TERMS`].
    pub fn floats(&self) -> [T; GYRO_CALIBRATION_FLOATS] {
        let mut out = [T::zero(); GYRO_CALIBRATION_FLOATS];
        out[..3].copy_from_slice(&self.bias);
        out[3..12].copy_from_slice(self.matrix.as_flattened());
        out[12..].copy_from_slice(&self.effects.coefficients());
        out
    }

    /// The calibration from floats in the order of [`Self::floats`]; missing trailing ones
    /// (a file without the newest terms) are zero.
    pub fn from_floats(f: &[T]) -> Self {
        let at = |i: usize| f.get(i).copied().unwrap_or_else(T::zero);
        let v3 = |i: usize| [at(i), at(i + 1), at(i + 2)];
        Self {
            bias: v3(0),
            matrix: [v3(3), v3(6), v3(9)],
            effects: GyroEffects::from_coefficients(f.get(12..).unwrap_or(&[])),
        }
    }

    /// The calibration in another float type, each parameter converted on its own (e.g.
    /// `cal.cast(Real::to_f32)` for a device's `f32` copy of the analysis's `f64` result).
    pub fn cast<U: Real>(&self, f: impl Fn(T) -> U) -> GyroCorrection<U> {
        GyroCorrection::from_floats(&self.floats().map(f))
    }

    /// Checks what a calibration read from a file or storage must hold: every parameter
    /// finite, `K` invertible (as [`crate::gyro::GyroCalibration::validate`]) and every
    /// g-sensitivity coefficient within [`G_SENSITIVITY_MAX`] (the table's `Magnitude` bound).
    pub fn validate(&self) -> Result<(), Error> {
        if !self.floats().iter().all(|x| x.is_finite()) {
            return Err(Error::NonFinite);
        }
        let bound = <T as Real>::from_f32(G_SENSITIVITY_MAX as f32);
        if self
            .effects
            .g_sensitivity
            .as_flattened()
            .iter()
            .any(|g| g.abs() > bound)
        {
            return Err(Error::InvalidParameter);
        }
        crate::gyro::GyroCalibration {
            bias: self.bias.into(),
            matrix: nalgebra::Matrix3::from_fn(|r, c| self.matrix[r][c]),
        }
        .validate()
    }
}

impl GyroCorrection<f32> {
    /// The canonical bit encoding ([`Self::floats`]' IEEE bits): equal exactly when every
    /// parameter is, signed zeros and NaN payloads included.
    pub fn bits(&self) -> [u32; GYRO_CALIBRATION_FLOATS] {
        self.floats().map(f32::to_bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gyro::GyroCalibration;
    use nalgebra::{Matrix3, Vector3};

    /// A calibration with every parameter distinct, so that a misplaced float shows.
    fn numbered() -> GyroCorrection<f32> {
        let f: [f32; GYRO_CALIBRATION_FLOATS] = core::array::from_fn(|i| 1.0 + i as f32);
        GyroCorrection::from_floats(&f)
    }

    /// The canonical order against the layout written out by hand: bias, `K` row-major,
    /// then `G` row-major (row = gyro axis).
    #[test]
    fn floats_follow_the_layout() {
        let c = numbered();
        assert_eq!(c.bias, [1.0, 2.0, 3.0]);
        assert_eq!(c.matrix[2], [10.0, 11.0, 12.0]);
        assert_eq!(
            c.effects.g_sensitivity,
            [[13.0, 14.0, 15.0], [16.0, 17.0, 18.0], [19.0, 20.0, 21.0]]
        );
        assert_eq!(GyroCorrection::from_floats(&c.floats()), c);
        // A linear-only file (version 1): the terms read as zero.
        let v1 = GyroCorrection::from_floats(&c.floats()[..12]);
        assert!(v1.effects.is_none() && !v1.effects.needs_specific_force());
        assert!(c.effects.needs_specific_force());
        let mut z = c;
        z.effects.g_sensitivity[1][1] = -0.0;
        assert_ne!(z.bits(), c.bits());
    }

    /// A gyro MPU-like in counts (16.4 counts per °/s), misaligned, with a bias and the
    /// g-sensitivity `G` (rad/s/g).
    fn truth() -> (Matrix3<f64>, Vector3<f64>, Matrix3<f64>) {
        let s = 1f64.to_radians() / 16.4;
        let k = Matrix3::new(
            s,
            2e-3 * s,
            -1e-3 * s,
            0.0,
            1.01 * s,
            3e-3 * s,
            0.0,
            0.0,
            -0.99 * s,
        );
        let b = Vector3::new(-31.0, 12.5, 7.25);
        let d = 1f64.to_radians();
        let g = Matrix3::new(
            0.10 * d,
            -0.02 * d,
            0.05 * d,
            0.01 * d,
            -0.12 * d,
            0.03 * d,
            -0.04 * d,
            0.02 * d,
            0.08 * d,
        );
        (k, b, g)
    }

    /// The correction inverts the forward model it documents: raw counts made from a known
    /// rate and specific force (`m = K⁻¹(ω + G·a) + b`, in `f64`) give the rate back, in `f64`
    /// to 1e-12 rad/s and in `f32` to the `f32` rounding of the counts; without `G` the error
    /// is `G·a`.
    #[test]
    fn the_correction_inverts_the_forward_model() {
        let (k, b, g) = truth();
        let fit = GyroCalibration { bias: b, matrix: k };
        let mut cal = GyroCorrection::from_fit(&fit);
        cal.effects.g_sensitivity = core::array::from_fn(|r| core::array::from_fn(|c| g[(r, c)]));
        let cal32 = cal.cast(f64::to_f32);
        let k_inv = k.try_inverse().unwrap();
        for (w, a) in [
            ([0.5, -1.0, 0.25], [0.0, 0.0, 1.0]),
            ([0.0, 0.0, 0.0], [0.6, -0.8, 0.0]),
            ([-3.0, 2.0, 1.5], [0.2, 0.3, -0.93]),
        ] {
            let (wv, av) = (Vector3::from(w), Vector3::from(a));
            let m: [f64; 3] = (k_inv * (wv + g * av) + b).into();
            let got = cal.correct(m, a);
            let lin = cal.correct_linear(m);
            for i in 0..3 {
                assert!((got[i] - w[i]).abs() < 1e-12, "{got:?} vs {w:?}");
                assert!((lin[i] - w[i] - (g * av)[i]).abs() < 1e-12);
            }
            let got32 = cal32.correct(m.map(|x| x as f32), a.map(|x| x as f32));
            for i in 0..3 {
                // 16.4 counts per °/s: an f32 count of ~1000 is exact to 6e-5 counts.
                assert!(
                    (f64::from(got32[i]) - w[i]).abs() < 1e-5,
                    "{got32:?} vs {w:?}"
                );
            }
        }
    }

    /// The `f64` instantiation is the `f32` one: the same parameters and inputs give results
    /// within the `f32` rounding bound of the two dot products, `4·ε·Σ|terms|` per axis.
    #[test]
    fn the_f64_correction_is_the_f32_one() {
        let (k, b, g) = truth();
        let mut c64 = GyroCorrection::from_fit(&GyroCalibration { bias: b, matrix: k });
        c64.effects.g_sensitivity = core::array::from_fn(|r| core::array::from_fn(|c| g[(r, c)]));
        let c32 = c64.cast(f64::to_f32);
        let back = c32.cast(f64::from_f32);
        for i in 0..50u32 {
            let m = [
                i as f32 * 37.0 - 900.0,
                400.0 - i as f32 * 11.0,
                (i * i) as f32 - 700.0,
            ];
            let a = [0.02 * i as f32 - 0.5, 0.3, 0.9 - 0.01 * i as f32];
            let w32 = c32.correct(m, a);
            let w64 = back.correct(m.map(f64::from), a.map(f64::from));
            for r in 0..3 {
                let mag: f64 = (0..3)
                    .map(|j| {
                        (back.matrix[r][j] * (f64::from(m[j]) - back.bias[j])).abs()
                            + (back.effects.g_sensitivity[r][j] * f64::from(a[j])).abs()
                    })
                    .sum();
                let tol = 4.0 * f64::from(f32::EPSILON) * mag;
                assert!((f64::from(w32[r]) - w64[r]).abs() <= tol, "axis {r}");
            }
        }
    }

    #[test]
    fn implausible_and_nan_are_refused() {
        let (k, b, _) = truth();
        let mut cal = GyroCorrection::from_fit(&GyroCalibration { bias: b, matrix: k });
        assert_eq!(cal.validate(), Ok(()));
        cal.effects.g_sensitivity[2][0] = 0.1; // 5.7 °/s/g
        assert_eq!(cal.validate(), Err(Error::InvalidParameter));
        cal.effects.g_sensitivity[2][0] = f64::NAN;
        assert_eq!(cal.validate(), Err(Error::NonFinite));
        cal.effects.g_sensitivity[2][0] = 0.0;
        cal.matrix[1] = [0.0; 3];
        assert_eq!(cal.validate(), Err(Error::Singular));
    }
}
