//! The simulator's self-check errors. Joined into [`super::Error`] as `Error::Simulate`;
//! re-exported as `simulate::SimulateError`.

/// A self-check of the simulator failed: a bug, not a bad setting (settings are refused with
/// the engine's [`super::Error`] sentences before anything is drawn).
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
