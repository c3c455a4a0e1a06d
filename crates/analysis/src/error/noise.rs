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
    /// A time column with missing samples or jumps.
    #[error("the time column is uneven (mean step {mean_ms:.3} ms against a median of {median_ms:.3} ms, {gaps} gaps): an Allan deviation needs evenly spaced samples — record without drops, or give the part between gaps")]
    UnevenTime {
        /// Steps over the gap factor × the median.
        gaps: usize,
        /// Median step, ms.
        median_ms: f64,
        /// Mean step, ms.
        mean_ms: f64,
    },
    /// An axis that never changes.
    #[error("column {column} is constant (every sample reads {value}): there is no noise to measure — check the column or the sensor")]
    ConstantAxis {
        /// The column.
        column: String,
        /// Its one value.
        value: f64,
    },
    /// An axis that steps like a counter (a sample index, a packet counter), not a sensor.
    #[error("column {column} counts rather than measures: {percent:.0}% of its changes are the same step of {step} (a sample counter or index column, not a still sensor) — choose the sensor's columns with --columns")]
    CounterAxis {
        /// The column.
        column: String,
        /// The step it repeats.
        step: f64,
        /// Share of its successive changes that repeat the previous one, %.
        percent: f64,
    },
    /// A recording that moved.
    #[error("columns {columns} are not still: {why}; the noise terms need the sensor at rest — record it lying still")]
    Moving {
        /// The triplet's columns.
        columns: String,
        /// What showed the motion.
        why: String,
    },
    /// A noise file that cannot give the Kalman filter its σ's.
    #[error("the noise file cannot give the filter's noise: {why}")]
    NoiseFileUnusable {
        /// Why.
        why: String,
    },
}
