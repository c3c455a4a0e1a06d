//! The simulator's errors: a setting refused before anything is drawn, a file not written, and
//! the self-checks that find a bug in the simulator ([`SimulateError`]).

/// Why a simulation gave no recording, or its files were not written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A setting out of its range (the sentence names the setting by meaning, as the engine's
    /// `Error::InvalidSetting` does; the `wiical simulate` flags check their own ranges first).
    #[error("{0}")]
    InvalidSetting(&'static str),
    /// The recording or its truth could not be written (`wiical-io`'s atomic writes: the
    /// engine's, so the sentences are the engine's `Error::Output` / `Error::NotRegularFile`).
    #[error(transparent)]
    Io(#[from] wiical_io::Error),
    /// The truth could not be serialised as JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A self-check of the simulator failed ([`SimulateError`]).
    #[error(transparent)]
    Simulate(#[from] SimulateError),
}

/// The simulator's result type.
pub type Result<T> = std::result::Result<T, Error>;

/// A self-check of the simulator failed: a bug, not a bad setting (settings are refused with
/// [`Error::InvalidSetting`] before anything is drawn).
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// An outlier was to be placed in a hold the scene does not have.
    #[error("internal: hold segment")]
    NoHoldSegment,
    /// The forward (truth) matrix has no inverse.
    #[error("internal: forward matrix not invertible: {0}")]
    ForwardNotInvertible(wiical_core::Error),
    /// The truth calibration does not map the simulated poses back to their directions.
    #[error("internal: truth calibration does not invert the simulation ({err_g} g)")]
    TruthNotInverse {
        /// Largest per-axis error, g.
        err_g: f64,
    },
}
