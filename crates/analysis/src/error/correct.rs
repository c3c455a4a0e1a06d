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
    /// The recording has no samples.
    #[error("the recording has no samples to correct")]
    Empty,
}
