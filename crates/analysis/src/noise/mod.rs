//! Noise of a still sensor (`wiical noise`): a still recording in → per axis the overlapping
//! Allan deviation and the IEEE 952 terms ([`allan`]) out, as the command's report
//! ([`report`]), one code for held samples and a large text file read in passes ([`pass`]); the
//! simulator's `wiical_sim::noise` makes still noise with known terms.

pub mod allan;
pub mod pass;
pub(crate) mod reading;
pub mod report;
pub(crate) mod request;
pub mod still;

pub use crate::error::noise::NoiseError;
