//! Noise of a still sensor (`wiical noise`): a still recording in → per axis the overlapping
//! Allan deviation and the IEEE 952 terms ([`allan`]) out, as the command's report
//! ([`report`]), one code for held samples and a large text file read in passes ([`pass`]); [`sim`] (feature `simulate`) makes still noise with known terms.

pub mod allan;
pub mod pass;
pub mod reading;
pub mod report;
#[cfg(feature = "simulate")]
pub mod sim;
pub mod still;

pub use crate::error::noise::NoiseError;
