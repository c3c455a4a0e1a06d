//! What a caller of `noise` asks for, as one typed value (issue 48): the still recording, the
//! columns, how a file is read and the sample rate to assume, which the command line
//! (`wiical noise`) and the Python package (`wiical.noise`) both take. A file is opened as the
//! command line opens it: every sensor triplet its header names, a large plain text file read
//! in passes ([`open_sensors`]); held samples are one sensor.

use super::report::{noise_of, open_sensors, NoiseReport, Sensors};
use crate::input::read_options::ReadOptions;
use crate::request::{three_columns, SampleInput};

/// A `noise` request. [`NoiseRequest::new`] has the defaults: every sensor of the file, the
/// loader's reading, 100 Hz when the recording states no rate.
#[derive(Debug, Clone)]
pub struct NoiseRequest {
    /// The still recording.
    pub input: SampleInput,
    /// Header names of the only three columns to analyse (`None`: every triplet named).
    pub columns: Option<Vec<String>>,
    /// How the file is read (a plain text file of at least `stream_from_bytes` in passes).
    pub read: ReadOptions,
    /// Sample rate when the recording has no time column or `Fs` metadata, Hz.
    pub rate_hz: f64,
}

impl NoiseRequest {
    /// The request for `input` with every setting at its default.
    pub fn new(input: impl Into<SampleInput>) -> Self {
        Self {
            input: input.into(),
            columns: None,
            read: ReadOptions::default(),
            rate_hz: 100.0,
        }
    }

    /// The sensors to analyse: the file's (held, or sources read in passes), or the held
    /// samples as one sensor (moved, not copied).
    pub fn into_sensors(self) -> crate::Result<Sensors> {
        let columns = three_columns(self.columns.as_deref())?;
        match self.input {
            SampleInput::File(path) => open_sensors(&path, columns, &self.read),
            SampleInput::Held(rec) => Ok(Sensors::Held(vec![*rec])),
        }
    }
}

/// Runs `noise`: the request's sensors opened, then each axis's Allan deviation and IEEE 952
/// terms ([`noise_of`]). Takes the request by value so that held samples are analysed where
/// they are.
pub fn noise(req: NoiseRequest) -> crate::Result<NoiseReport> {
    let rate_hz = req.rate_hz;
    noise_of(&req.into_sensors()?, rate_hz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_samples_are_one_sensor_at_the_rate_given() {
        // White noise of a known σ from a fixed linear congruential sequence.
        let mut state = 12_345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let xyz: Vec<[f64; 3]> = (0..20_000)
            .map(|_| [uniform(), uniform(), 1.0 + uniform()])
            .collect();
        let rec = crate::arrays::recording(xyz, None, None).unwrap();
        let req = NoiseRequest {
            rate_hz: 50.0,
            ..NoiseRequest::new(rec)
        };
        let rep = noise(req).unwrap();
        assert_eq!(rep.sample_rate_hz, 50.0);
        assert_eq!(rep.samples, 20_000);
        assert_eq!(rep.axes.len(), 3);
    }

    #[test]
    fn columns_must_be_three() {
        let req = NoiseRequest {
            columns: Some(vec!["x".into()]),
            ..NoiseRequest::new("no-such-file.csv")
        };
        assert!(matches!(noise(req), Err(crate::Error::ColumnsNotThree(_))));
    }
}
