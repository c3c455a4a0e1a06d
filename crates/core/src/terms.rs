//! The effect terms of a calibration, declared once.
//!
//! [`TERMS`] lists every field of `Effects` in its canonical order with what the rest
//! of the project needs to know about it: its name (the serde key, the wire schema's field
//! name and the calibration file's key), its shape (how many coefficients, acting how, on
//! which axis), its unit, whether the adapter applies it, whether it needs a clock or a
//! thermometer, which acceptance check bounds it, and the format versions that added it.
//! Every format is derived from this table rather than restated: the flat coefficient order
//! (`model::EffectsT::coefficients`, the flash record's floats and the canonical bit
//! encoding `model::CalibrationT::bits`), the wire schema's `WireEffects` line and
//! key, the calibration file's keys and the lowest schema version holding a calibration, the
//! list of terms the adapter applies or leaves to hosts, and the term flags (`Terms`).
//!
//! The math of a term (its part of `model::CalibrationT::correct`) is code, not
//! data: a new term is a row here, a field of `EffectsT`, its arm in
//! `model::EffectsT::field` and its math in the correction.
//!
//! The gyroscope's calibration is another object (`ω = K·(m − b)` in rad/s, see
//! `gyro_correct`), so its terms have their own table, [`GYRO_TERMS`], of the same
//! [`TermSpec`] rows: the gyro's coefficient order
//! (`gyro_correct::GyroEffects::coefficients`) and the gyro calibration file's keys
//! and version are derived from it. The accelerometer's formats (wire, flash record,
//! calibration file) read [`TERMS`] alone and do not change when a gyro term is added. The
//! adapter's gyro record (`wiical_adapter::store`) and the wire's `WireGyroCalibration` hold
//! only the linear part and the rows with `device_applies` (none today), so the g-sensitivity
//! has no flash record (`since_record` 0): it needs the accelerometer fixed to the gyro, which
//! the adapter does not see, and stays on the host.

/// Which effect term a row of [`TERMS`] describes (one per field of `Effects`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TermId {
    /// Per-axis even nonlinearity `k2`.
    Quadratic,
    /// Per-axis odd nonlinearity `k3`.
    Cubic,
    /// Bias drift with time.
    BiasDrift,
    /// Reference temperature `θ₀` of the temperature terms.
    TempRef,
    /// Bias temperature coefficient.
    BiasTemp,
    /// Relative scale temperature coefficient.
    ScaleTemp,
    /// Orientation-dependent degree-2 cross terms.
    CrossQuadratic,
    /// Orientation-dependent degree-3 cross terms.
    CrossCubic,
    /// Gyro bias against the specific force (g-sensitivity), a 3×3 matrix ([`GYRO_TERMS`]).
    GSensitivity,
}

/// What a term's coefficients multiply and where the product enters the correction (see
/// `model` for the formula).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// One coefficient per axis, added to that axis's bias (raw units) times the regressor.
    Bias(Regressor),
    /// One coefficient per axis, multiplying that axis's linearly corrected `u_i` by
    /// `1 + c·regressor`.
    Scale(Regressor),
    /// One coefficient per axis, adding `c·u_i^power` to output axis `i`.
    AxisPower(u8),
    /// Per output axis `i`, one coefficient per monomial of this degree in `u` except `u_i`'s
    /// own power (`model::CROSS2`, `model::CROSS3`), added to output `i`.
    Cross(u8),
    /// One value, not a coefficient: the reference other terms are taken about.
    Reference,
    /// Per output axis `i`, one coefficient per component `j` of a 3-vector regressor `r`: a
    /// bias in output units, `Σ_j c[i][j]·r_j`, subtracted from output `i` after the linear
    /// map (3×3 coefficients, row = output axis).
    Matrix(Regressor),
}

/// The regressor of a bias or scale term.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regressor {
    /// Time since the start of the recording, s.
    Time,
    /// Temperature about the reference, `θ − θ₀`, °C.
    Temperature,
    /// The specific force the accelerometer beside the sensor reads, calibrated, in g, in
    /// the accelerometer's (= the gyro calibration's) frame.
    SpecificForce,
}

/// What a user of the calibration needs, besides the reading, to apply a term.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    /// The reading alone (the adapter applies these).
    Reading,
    /// A clock origin (time since the start of the recording).
    Time,
    /// A thermometer.
    Temperature,
    /// The calibrated accelerometer reading beside the sensor, same sample.
    SpecificForce,
}

/// Which check of `acceptance::Acceptance` bounds a term.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// The output bound: the corrected output stays within `±output_bound` over the input
    /// range at every condition (`Acceptance::output_bound`, exact for per-axis terms, an
    /// upper bound for cross terms).
    Output,
    /// The allowed range of the reference temperature (`Acceptance::temp_ref_range_c`).
    TempRefRange,
    /// Every coefficient's magnitude within the term's own plausibility limit (g-sensitivity:
    /// `gyro_correct::G_SENSITIVITY_MAX`).
    Magnitude,
}

/// One row of [`TERMS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TermSpec {
    /// Which term.
    pub id: TermId,
    /// Its name: the field of `Effects`, the serde and calibration-file key, the
    /// wire schema's field name.
    pub name: &'static str,
    /// What its coefficients act on.
    pub shape: Shape,
    /// Unit of its coefficients.
    pub unit: &'static str,
    /// True when the adapter applies it to every sample (it depends on the reading alone).
    pub device_applies: bool,
    /// What a user needs to apply it.
    pub needs: Needs,
    /// Which acceptance check bounds it.
    pub bound: Bound,
    /// Flash record version that added it (`wiical_adapter::store`); 0 for a term no flash
    /// record holds (the g-sensitivity: the adapter's gyro record keeps the linear part only).
    pub since_record: u16,
    /// Calibration file schema version that added it (`wiical-calibration/N` for [`TERMS`],
    /// `wiical-gyro-calibration/N` for [`GYRO_TERMS`]); a file is written with the highest
    /// `since_file` of its non-zero terms. Terms added after version 1 are left out of a file
    /// when zero.
    pub since_file: u8,
}

impl TermSpec {
    /// Coefficients per axis (row length): 1 for per-axis terms, the number of monomials
    /// for a cross term; for the scalar reference, 1 in total.
    pub const fn per_axis(&self) -> usize {
        match self.shape {
            Shape::Cross(degree) => monomial_count(degree) - 1,
            Shape::Matrix(_) => 3,
            _ => 1,
        }
    }

    /// Number of coefficients (floats) of the term.
    pub const fn len(&self) -> usize {
        match self.shape {
            Shape::Reference => 1,
            _ => 3 * self.per_axis(),
        }
    }

    /// Always false: every term has at least one coefficient (for clippy's `len` rule).
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// True for the effect terms proper, false for the reference value.
    pub const fn is_term(&self) -> bool {
        !matches!(self.shape, Shape::Reference)
    }

    /// What the term depends on besides the axis it acts on, in words, for lists of terms:
    /// `time`, `temperature`, `orientation`; `None` for the per-axis transfer curve.
    pub const fn depends_on(&self) -> Option<&'static str> {
        match (self.needs, self.shape) {
            (Needs::Time, _) => Some("time"),
            (Needs::Temperature, _) => Some("temperature"),
            (Needs::SpecificForce, _) => Some("specific force"),
            (_, Shape::Cross(_)) => Some("orientation"),
            _ => None,
        }
    }
}

/// Number of monomials of `degree` in three variables.
pub const fn monomial_count(degree: u8) -> usize {
    let d = degree as usize;
    (d + 1) * (d + 2) / 2
}

/// Every effect term, in the canonical order of the flat coefficients, the wire encoding,
/// the flash record and the calibration file.
pub const TERMS: [TermSpec; 8] = [
    TermSpec {
        id: TermId::Quadratic,
        name: "quadratic",
        shape: Shape::AxisPower(2),
        unit: "1/g",
        device_applies: true,
        needs: Needs::Reading,
        bound: Bound::Output,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::Cubic,
        name: "cubic",
        shape: Shape::AxisPower(3),
        unit: "1/g²",
        device_applies: true,
        needs: Needs::Reading,
        bound: Bound::Output,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::BiasDrift,
        name: "bias_drift",
        shape: Shape::Bias(Regressor::Time),
        unit: "raw/s",
        device_applies: false,
        needs: Needs::Time,
        bound: Bound::Output,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::TempRef,
        name: "temp_ref_c",
        shape: Shape::Reference,
        unit: "°C",
        device_applies: false,
        needs: Needs::Temperature,
        bound: Bound::TempRefRange,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::BiasTemp,
        name: "bias_temp",
        shape: Shape::Bias(Regressor::Temperature),
        unit: "raw/°C",
        device_applies: false,
        needs: Needs::Temperature,
        bound: Bound::Output,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::ScaleTemp,
        name: "scale_temp",
        shape: Shape::Scale(Regressor::Temperature),
        unit: "1/°C",
        device_applies: false,
        needs: Needs::Temperature,
        bound: Bound::Output,
        since_record: 1,
        since_file: 1,
    },
    TermSpec {
        id: TermId::CrossQuadratic,
        name: "cross_quadratic",
        shape: Shape::Cross(2),
        unit: "1/g",
        device_applies: true,
        needs: Needs::Reading,
        bound: Bound::Output,
        since_record: 2,
        since_file: 2,
    },
    TermSpec {
        id: TermId::CrossCubic,
        name: "cross_cubic",
        shape: Shape::Cross(3),
        unit: "1/g²",
        device_applies: true,
        needs: Needs::Reading,
        bound: Bound::Output,
        since_record: 2,
        since_file: 2,
    },
];

/// Every effect term of the gyroscope's calibration (`gyro_correct::GyroEffects`),
/// in the canonical order of its flat coefficients and of the gyro calibration file.
pub const GYRO_TERMS: [TermSpec; 1] = [TermSpec {
    id: TermId::GSensitivity,
    name: "g_sensitivity",
    shape: Shape::Matrix(Regressor::SpecificForce),
    unit: "rad/s/g",
    device_applies: false,
    needs: Needs::SpecificForce,
    bound: Bound::Magnitude,
    since_record: 0,
    since_file: 2,
}];

/// Number of coefficients of the terms of `table`.
pub const fn floats_of(table: &[TermSpec]) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < table.len() {
        n += table[i].len();
        i += 1;
    }
    n
}

/// Number of effect coefficients of `gyro_correct::GyroEffects`.
pub const GYRO_EFFECT_FLOATS: usize = floats_of(&GYRO_TERMS);

/// Number of floats of a whole gyro calibration: bias (3), matrix (9), then the effects.
pub const GYRO_CALIBRATION_FLOATS: usize = 12 + GYRO_EFFECT_FLOATS;

/// The names of [`GYRO_TERMS`], in order.
pub const GYRO_NAMES: [&str; GYRO_TERMS.len()] = names_of(&GYRO_TERMS);

/// The row of `table` named `name`, if any.
pub fn by_name_in(table: &'static [TermSpec], name: &str) -> Option<&'static TermSpec> {
    table.iter().find(|t| t.name == name)
}

/// Number of effect coefficients (floats) of `Effects`: the sum of [`TERMS`]' lengths.
pub const EFFECT_FLOATS: usize = floats_through_record(u16::MAX);

/// Number of floats of a whole calibration: bias (3), matrix (9), then the effects.
pub const CALIBRATION_FLOATS: usize = 12 + EFFECT_FLOATS;

/// Number of effect coefficients of the terms a flash record of `version` holds (the ones
/// with `since_record ≤ version`; later terms come after them in [`TERMS`]).
pub const fn floats_through_record(version: u16) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < TERMS.len() {
        if TERMS[i].since_record <= version {
            n += TERMS[i].len();
        }
        i += 1;
    }
    n
}

/// The newest flash record version any term needs.
pub const RECORD_VERSION: u16 = {
    let mut v = 0;
    let mut i = 0;
    while i < TERMS.len() {
        if TERMS[i].since_record > v {
            v = TERMS[i].since_record;
        }
        i += 1;
    }
    v
};

/// The names of [`TERMS`], in order (e.g. the keys a strict reader accepts).
pub const NAMES: [&str; TERMS.len()] = names_of(&TERMS);

/// The names of a table's rows, in order (evaluated at compile time for [`NAMES`] and
/// [`GYRO_NAMES`]).
pub const fn names_of<const N: usize>(table: &[TermSpec; N]) -> [&'static str; N] {
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = table[i].name;
        i += 1;
    }
    out
}

/// The row of `id`.
pub const fn spec(id: TermId) -> &'static TermSpec {
    let mut i = 0;
    while i < TERMS.len() {
        if TERMS[i].id as u8 == id as u8 {
            return &TERMS[i];
        }
        i += 1;
    }
    panic!("every TermId has a row in TERMS")
}

/// Offset of `id`'s first coefficient in the flat effect coefficients.
pub const fn offset(id: TermId) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < TERMS.len() {
        if TERMS[i].id as u8 == id as u8 {
            return n;
        }
        n += TERMS[i].len();
        i += 1;
    }
    panic!("every TermId has a row in TERMS")
}

/// The row named `name`, if any.
pub fn by_name(name: &str) -> Option<&'static TermSpec> {
    TERMS.iter().find(|t| t.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table's counts against the layout written out by hand: three each for the
    /// per-axis terms, one reference, 3×5 and 3×9 cross coefficients, in this order.
    #[test]
    fn table_counts_match_the_layout() {
        let lens = TERMS.map(|t| t.len());
        assert_eq!(lens, [3, 3, 3, 1, 3, 3, 15, 27]);
        assert_eq!(EFFECT_FLOATS, 58);
        assert_eq!(CALIBRATION_FLOATS, 70);
        assert_eq!(floats_through_record(1), 16);
        assert_eq!(RECORD_VERSION, 2);
        assert_eq!(offset(TermId::TempRef), 9);
        assert_eq!(offset(TermId::CrossCubic), 31);
        for (i, t) in TERMS.iter().enumerate() {
            assert_eq!(spec(t.id), t);
            assert_eq!(by_name(t.name), Some(t));
            assert_eq!(NAMES[i], t.name);
            // The adapter applies exactly what depends on the reading alone.
            assert_eq!(t.device_applies, t.needs == Needs::Reading, "{}", t.name);
        }
        assert_eq!(by_name("bias-drift"), None);
    }

    /// The gyro's table against its layout written out by hand: one 3×3 matrix, named as
    /// the gyro calibration file names it, in no flash record, not in the accelerometer's
    /// table.
    #[test]
    fn gyro_table_counts_match_the_layout() {
        assert_eq!(GYRO_TERMS.map(|t| t.len()), [9]);
        assert_eq!(GYRO_TERMS[0].per_axis(), 3);
        assert_eq!(GYRO_EFFECT_FLOATS, 9);
        assert_eq!(GYRO_CALIBRATION_FLOATS, 21);
        assert_eq!(GYRO_NAMES, ["g_sensitivity"]);
        assert_eq!(
            by_name_in(&GYRO_TERMS, "g_sensitivity").map(|t| t.id),
            Some(TermId::GSensitivity)
        );
        assert_eq!(by_name("g_sensitivity"), None);
        assert_eq!(GYRO_TERMS[0].depends_on(), Some("specific force"));
        for t in &GYRO_TERMS {
            assert_eq!(t.since_record, 0, "{}", t.name);
            assert!(
                !t.device_applies,
                "{}: the adapter holds no gyro calibration",
                t.name
            );
        }
    }
}
