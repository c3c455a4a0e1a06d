//! The gyro's protocol methods' error ([`crate::protocol::gyro`]): why a gyro recording gave
//! nothing to calibrate from. Joined into [`super::Error`] as `Error::GyroProtocol`.

/// Why the gyro's protocol gives nothing.
#[derive(Debug, thiserror::Error)]
pub enum GyroProtocolError {
    /// No rest and no steady rate.
    #[error("the gyro is never still or steady (no still window found): nothing to calibrate from; record a rest of a few seconds")]
    NoRest,
    /// Detection failed.
    #[error(transparent)]
    Detect(#[from] crate::error::detect::DetectError),
}
