//! The gyro loop's settings and the small helpers every stage shares (its `Result`, degrees):
//! at the bottom of `gyro/`, so the stages import them from below, not from `mod.rs`.

use crate::detect::windows::DetectOptions;
pub use crate::error::gyro::GyroError;
use wiical_core::multipos::MultiPosModel;

pub(crate) type Result<T, E = GyroError> = std::result::Result<T, E>;

/// Settings of the gyro loop (`gyro::run`).
#[derive(Debug, Clone)]
pub struct GyroOptions {
    /// Static-window detection on the accelerometer.
    pub detect: DetectOptions,
    /// Nominal gyro sensitivity per axis, rad/s per count (signed: an inverted axis is
    /// negative), from the datasheet.
    pub nominal_rad_per_count: [f64; 3],
    /// Accelerometer model for the gravity directions.
    pub accel_model: MultiPosModel,
    /// Levenberg–Marquardt iteration budget per fit.
    pub max_iterations: u32,
    /// Where the nominal came from, for the report (`--scale`, the columns' unit, …).
    pub nominal_source: String,
    /// Estimate the nominal from the motions instead (`gyro::estimate_nominal`): no datasheet.
    pub estimate_nominal: bool,
    /// Held-out errors by an exact refit per motion instead of one Gauss–Newton step from the
    /// all-motion fit (`leave_one_out_one_step`; within 0.01° of exact on the real logs,
    /// docs/gyro.md, ~40× faster).
    pub exact_held_out: bool,
}

impl GyroOptions {
    /// Defaults with the nominal estimated from the motions (`gyro::estimate_nominal`).
    pub fn estimated() -> Self {
        Self {
            estimate_nominal: true,
            nominal_source: "estimated from the motions".into(),
            ..Self::new([1.0; 3])
        }
    }

    /// Defaults for the nominal a caller found (`--scale`, the columns' unit: rad/s per count
    /// and where it came from), else estimated from the motions.
    pub fn of_nominal(given: Option<([f64; 3], String)>) -> Self {
        match given {
            Some((scale, source)) => Self {
                nominal_source: source,
                ..Self::new(scale)
            },
            None => Self::estimated(),
        }
    }

    /// Defaults for a nominal sensitivity.
    pub fn new(nominal_rad_per_count: [f64; 3]) -> Self {
        Self {
            detect: DetectOptions::default(),
            nominal_rad_per_count,
            accel_model: MultiPosModel::Full,
            max_iterations: 100,
            nominal_source: "given".into(),
            estimate_nominal: false,
            exact_held_out: false,
        }
    }
}

/// Radians to degrees.
pub(crate) fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}
