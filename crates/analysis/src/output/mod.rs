//! Output files: a [`wiical_core::Calibration`] and its verdict ↔ the calibration file
//! ([`calfile`]), a gyro calibration with its effect terms ↔ the gyro calibration file
//! ([`gyrocal`]), and the atomic writer every output goes through ([`mod@write`], the
//! `wiical-io` crate's: no half-written file, no input overwritten); [`OutputError`] says why
//! one was not written.

pub mod calfile;
pub mod gyrocal;
pub mod host_term_checks;
/// The atomic writer (`wiical-io`'s).
pub use wiical_io::write;

pub use crate::error::output::OutputError;
