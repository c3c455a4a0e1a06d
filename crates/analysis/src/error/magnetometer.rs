//! The magnetometer fit's error (`wiical magfit`): no usable samples, or the core's ellipsoid
//! fit failed. Joined into [`super::Error`] as `Error::Magnetometer`;
//! re-exported as `magnetometer::MagnetometerError`.

/// Why a magnetometer fit failed. Joined into [`super::Error::Magnetometer`].
#[derive(Debug, thiserror::Error)]
pub enum MagnetometerError {
    /// No points.
    #[error("magfit: no samples to fit")]
    NoMagSamples,
    /// A point that is not a finite f32.
    #[error("sample {index} ({x}, {y}, {z}) is not a finite f32 value")]
    MagSampleNotF32 {
        /// 1-based sample.
        index: usize,
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
    },
    /// Points that never leave a blob of their own noise.
    #[error("the points do not span the sphere: they spread over {spread:.3e} on their widest axis, about their own noise ({noise:.3e}) — the sensor was not rotated; turn it through all orientations while recording")]
    NotRotated {
        /// Standard deviation of the points on their widest axis (relative to its noise).
        spread: f64,
        /// That axis's noise.
        noise: f64,
    },
    /// The core's ellipsoid fit failed.
    #[error("{context}")]
    MagFit {
        /// What was being done.
        context: String,
        /// The core's error.
        #[source]
        source: wiical_core::Error,
    },
    /// A followed column without a value on some row of the field.
    #[error("column {column}: {got} rows against {rows} of the field (a row where one is empty): give a column filled on every row")]
    FollowRows {
        /// The followed column.
        column: String,
        /// Its rows.
        got: usize,
        /// The field's rows.
        rows: usize,
    },
    /// Followed columns asked of samples given without a file (they are read from the file).
    #[error("followed columns are read from the recording's file: give the samples as a file")]
    FollowNeedsFile,
}
