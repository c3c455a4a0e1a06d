//! The noise stage's error (`wiical noise`, and the noise file `kalman-demo` reads): a
//! recording without a rate or too short for an Allan deviation, or a noise file that cannot
//! give the filter its σ's. Joined into [`super::Error`] as `Error::Noise`;
//! re-exported as `noise::NoiseError`.

/// Why a noise report could not be made or read. Joined into [`super::Error::Noise`].
#[derive(Debug, thiserror::Error)]
pub enum NoiseError {
    /// Neither a time column, metadata nor a default rate.
    #[error("cannot determine the sample rate")]
    NoSampleRate,
    /// A recording too short for an Allan deviation.
    #[error("{samples} samples are too few for an Allan deviation (at least {needed}; the curve reaches τ = n/9 samples, so a long still recording — hours — is what shows bias instability and random walk)")]
    NoiseTooShort {
        /// Samples given.
        samples: usize,
        /// Fewest accepted.
        needed: usize,
    },
    /// A noise file that cannot give the Kalman filter its σ's.
    #[error("the noise file cannot give the filter's noise: {why}")]
    NoiseFileUnusable {
        /// Why.
        why: String,
    },
}
