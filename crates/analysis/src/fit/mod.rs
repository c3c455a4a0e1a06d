//! Fitting: static windows in → a calibration out. [`base`] is the core's `f32`
//! multi-position fit (`wiical fit`); [`model`] the `f64` effect model the search extends, with
//! its held-out residuals at linear cost ([`press`]); [`six_position`] the seed's
//! six-position test `T̂ = M·Â⁺` on labelled poses.

pub mod base;
pub mod model;
pub mod press;
pub mod six_position;

pub use crate::error::fit::FitError;
pub use crate::error::six_position::SixPositionError;
