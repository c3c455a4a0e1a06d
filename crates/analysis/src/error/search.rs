//! The search's error (`wiical analyze`): a rule setting out of range, an unknown candidate
//! name, or a fit of the search that failed. Joined into [`super::Error`] as
//! `Error::Search`; re-exported as `search::SearchError`.

/// Why the search refused its settings or could not finish. Joined into
/// [`super::Error::Search`].
#[derive(Debug, thiserror::Error)]
pub enum SearchError {
    /// A setting of the selection rule (`alpha`, `cv_factor`) out of its range: its keyword,
    /// the value and the range, in the words of the detector settings' `SettingError` (held
    /// as text: this module is below the detector's in the module graph).
    #[error("{0}")]
    InvalidSetting(String),
    /// An unknown candidate effect name.
    #[error("unknown candidate effect '{name}'; known: {known}")]
    UnknownCandidate {
        /// The name given.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// The f64 refinement could not be solved.
    #[error("the f64 refinement of the base fit failed (degenerate poses)")]
    RefinementFailed,
    /// The final calibration does not validate.
    #[error("the final calibration is not valid: {0}")]
    InvalidCalibration(wiical_core::Error),
}
