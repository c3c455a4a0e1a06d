//! Output files: a [`wiical_core::Calibration`] and its verdict ↔ the calibration file
//! ([`calfile`]), and the atomic writer every output goes through ([`mod@write`]: no
//! half-written file, no input overwritten).

pub mod calfile;
pub mod write;
