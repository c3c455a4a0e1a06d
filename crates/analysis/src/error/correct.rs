//! The host-side correction's error (`wiical correct`): a term of the calibration needs a
//! regressor the recording cannot give. Joined into [`super::Error`] as `Error::Correct`;
//! re-exported as `correct::CorrectError`.

/// Why a recording could not be corrected with a calibration file. Joined into
/// [`super::Error::Correct`].
#[derive(Debug, thiserror::Error)]
pub enum CorrectError {
    /// A term needs the temperature and the recording has no temperature column.
    #[error(
        "the calibration's term {term} needs the temperature, and the recording has no temperature column"
    )]
    NeedsTemperature {
        /// The term's name (`temperature-squared (x)`, `bias_temp (temperature)`).
        term: String,
    },
    /// A temperature-rate term at a sample whose ±15 s span holds no time spread (a single
    /// sample between gaps).
    #[error(
        "the calibration's term {term} needs the temperature rate, which sample {sample} has no neighbours within 15 s to give"
    )]
    RateUndefined {
        /// The term's name.
        term: String,
        /// 0-based sample index.
        sample: usize,
    },
    /// A temperature-rate term, and more samples within 30 s of one than a recording read
    /// from disk in passes holds to fit the rate (a time column in other units than seconds,
    /// or tens of kHz).
    #[error(
        "the calibration's term {term} needs the temperature rate over ±15 s, and more than {max} samples lie within 30 s of sample {sample}, more than a recording this large is held for: is the time column in seconds?"
    )]
    RateSpanTooDense {
        /// The term's name.
        term: String,
        /// 0-based sample index.
        sample: usize,
        /// Most samples held.
        max: usize,
    },
    /// The recording has no samples.
    #[error("the recording has no samples to correct")]
    Empty,
    /// The calibration fails the acceptance predicate `device put` applies
    /// (`wiical_core::acceptance::Acceptance::check`), with the limits taken from the
    /// recording (its input range, duration and temperatures).
    #[error("refusing to correct with an implausible calibration: {why} (over the recording's readings {lo} to {hi}); `device put` refuses it too: re-fit it, or check it is the right file")]
    Implausible {
        /// The predicate's reason.
        why: wiical_core::acceptance::Rejection,
        /// Smallest raw reading of the recording (the input range checked).
        lo: f32,
        /// Largest raw reading of the recording.
        hi: f32,
    },
    /// A corrected value is NaN or infinite, or beyond the plausible output bound (raw
    /// units per g do not allow more on any accelerometer the tool calibrates).
    #[error("corrected sample {sample} (t = {time_s} s) has {axis} = {value} g, {why}: the calibration's terms do not hold there; nothing was written")]
    BadOutput {
        /// 1-based sample number.
        sample: usize,
        /// The sample's time as the recording gives it, s.
        time_s: f64,
        /// The axis name.
        axis: &'static str,
        /// The corrected value, g.
        value: f32,
        /// "not a finite number" or "beyond ±16 g".
        why: String,
    },
    /// The corrected readings' typical magnitude is far from the 1 g of gravity: the
    /// calibration was made from readings in other units (counts vs g, mg, m/s²).
    #[error("the calibration and the recording are in different units: corrected by its bias and matrix, the readings' median magnitude is {median_g} g where gravity gives 1 g (the calibration expects readings near {zero} with about {per_g} units per g; the recording's median reading magnitude is {median_raw}); use a calibration made from a recording in these units, or convert the recording")]
    UnitsMismatch {
        /// Median `‖K·(m − b)‖` of the samples, g.
        median_g: f64,
        /// The calibration's zero point (mean bias), raw units.
        zero: f64,
        /// The calibration's mean sensitivity (diagonal of `K⁻¹`), raw units per g.
        per_g: f64,
        /// Median `‖m‖` of the raw samples.
        median_raw: f64,
    },
}
