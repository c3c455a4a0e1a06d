//! # wiical-core
//!
//! `no_std`, allocation-free, `f32` calibration mathematics for low-cost inertial sensors
//! (the Wii Remote's ADXL330, the Nunchuk's LIS3L02AL, and any 3-axis accelerometer,
//! gyroscope or magnetometer).
//!
//! Everything here runs unchanged on a Cortex-M0+/M33 and on a desktop: fixed-size data
//! on the stack, `nalgebra` without its default features, `heapless` where a bounded
//! buffer is needed, and no floating-point type wider than `f32` on the device. The
//! least-squares solver ([`lm`]) and the multi-position fit ([`multipos::fit_generic`]) are
//! generic over nalgebra's `RealField`, so the host's analysis runs the same code in `f64`.
//!
//! ## Conventions
//! * Raw measurements `m` are in sensor units (ADC counts, or whatever the sensor gives).
//! * The measurement model is `m = D·a + b + v` with `D = g·L·T` (scale `L`,
//!   non-orthogonality `T`), bias `b` and white noise `v` (see [`model`]).
//! * Calibrated acceleration is in units of the reference magnitude (1 g for an
//!   accelerometer: a level, still sensor reads `[0, 0, 1]` when `+z` points up, i.e. the
//!   sensor measures the specific force, the reaction to gravity).
//! * Matrices in public data types are row-major `[[f32; 3]; 3]` so that they read the way
//!   they are printed in the seed documents and in JSON.
//!
//! ## Modules
//! | module | what |
//! |---|---|
//! | [`model`] | calibration type (generic over the float type: `f32` device, `f64` analysis), correction `a = D⁻¹(m − b)` plus optional effect terms; [`PreparedCalibration`] for per-sample correction |
//! | [`terms`] | the tables of effect terms (accelerometer, gyro) every format (wire, flash record, calibration files) is derived from |
//! | [`six_position`] | the six-position test with the constant right pseudo-inverse |
//! | [`estimators`] | Welford mean/variance and the Kalman observer for a constant (scalar, 3-vector) |
//! | [`offset`] | offset-only accelerometer and gyro calibration |
//! | [`multipos`] | multi-position fit in arbitrary orientations (Levenberg–Marquardt) |
//! | [`magfit`] | magnetometer sphere / axis-aligned / rotated-ellipsoid fits from streaming sums |
//! | [`kalman`] | the 3-state `[position, velocity, bias]` Kalman filter |
//! | [`gyro`] | gyro model `ω = K(m − b)`, RK4 quaternion integration of a motion with exact parameter sensitivities |
//! | [`gyro_correct`] | the gyro's correction with its effect terms, `ω = K(m − b) − G·a` (g-sensitivity needs the accelerometer's reading), generic over the float type |
//! | [`gyro_fit`] | multi-position gyro scale / misalignment / bias fit (Tedaldi et al. 2014), leave-one-motion-out |
//! | [`gyro_zero`] | zero-rate (bias) tracker that re-zeroes whenever the sensor is still |
//! | [`static_detect`] | static-interval detection on a stream; [`static_detect::adaptive`]: thresholds from the recording's own noise, no rest period needed |
//! | [`lm`] | Levenberg–Marquardt generic over the float type (`f32` device, `f64` analysis), standard errors, leverage, leave-one-out |
//! | [`acceptance`] | the one acceptance predicate (plausibility limits) and the pose-coverage rule |
//! | [`linalg`] | small helpers (Cholesky solves of normal equations) |
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod acceptance;
pub mod error;
pub mod estimators;
pub mod gyro;
pub mod gyro_correct;
pub mod gyro_fit;
pub mod gyro_zero;
pub mod kalman;
pub mod linalg;
pub mod lm;
pub mod magfit;
pub mod model;
pub mod multipos;
pub mod offset;
pub mod six_position;
pub mod static_detect;
pub mod terms;

pub use error::Error;
pub use linalg::{all_finite, Mat3, Vec3};
pub use model::{
    Calibration, CalibrationT, Conditions, ConditionsT, Effects, EffectsT, PreparedCalibration,
    Real, Terms,
};

/// Standard gravity in m/s², used only where a result is reported in SI units.
pub const STANDARD_GRAVITY: f32 = 9.806_65;
