//! What a caller of `tempcal` asks for, as one typed value (issue 48): the still warm-up, its
//! columns, how a file is read and the fit's settings ([`TempcalOptions`], whose ranges the
//! engine checks: [`TempcalError::Setting`] names no flag), which the command line
//! (`wiical tempcal`) and the Python package (`wiical.tempcal`) both take. The autopilot
//! files and the calibration file the command line writes are its own.

use super::{fit_warmup, TempcalError, TempcalOptions, TempcalReport};
use crate::input::read_options::ReadOptions;
use crate::input::recording::Recording;
use crate::input::text::LoadOptions;
use crate::request::SampleInput;

/// A `tempcal` request. [`TempcalRequest::new`] has the defaults: the triplet the loader
/// chooses, its reading, [`TempcalOptions::default`].
#[derive(Debug, Clone)]
pub struct TempcalRequest {
    /// The still warm-up (x, y, z and a temperature column).
    pub input: SampleInput,
    /// Header names of the x,y,z columns (three; `None`: the loader's choice).
    pub columns: Option<Vec<String>>,
    /// How the file is read.
    pub read: ReadOptions,
    /// The fit's settings: reference temperature, segments, block length, pose angle, rate.
    pub options: TempcalOptions,
}

/// Why a `tempcal` request gave no report: the samples could not be read, or the warm-up
/// cannot be calibrated (or a setting is out of range: [`TempcalError::Setting`]).
#[derive(Debug, thiserror::Error)]
pub enum TempcalRunError {
    /// The file could not be read, or the columns given are not three.
    #[error(transparent)]
    Read(#[from] crate::Error),
    /// The warm-up's fit refused it.
    #[error(transparent)]
    Tempcal(#[from] TempcalError),
}

impl TempcalRequest {
    /// The request for `input` with every setting at its default.
    pub fn new(input: impl Into<SampleInput>) -> Self {
        Self {
            input: input.into(),
            columns: None,
            read: ReadOptions::default(),
            options: TempcalOptions::default(),
        }
    }

    /// The loader's options (the columns checked: three).
    pub fn load_options(&self) -> crate::Result<LoadOptions> {
        crate::request::load_options(self.columns.as_deref(), self.read)
    }

    /// The fit of the warm-up `rec` (read by the caller) with the request's settings.
    pub fn run(&self, rec: &Recording) -> Result<TempcalReport, TempcalError> {
        fit_warmup(rec, &self.options)
    }
}

/// Runs `tempcal` as the library call: the warm-up read whole (or the samples held), then
/// the bias polynomial per axis. The command line reads with its own bound on what it holds
/// and runs the same [`TempcalRequest::run`].
pub fn tempcal(req: &TempcalRequest) -> Result<TempcalReport, TempcalRunError> {
    let rec = crate::request::held(&req.input, &req.load_options()?)?;
    Ok(req.run(&rec)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_and_columns_are_refused_as_typed_errors() {
        let rec = crate::arrays::recording(vec![[0.0, 0.0, 1.0]; 10], None, Some(vec![20.0; 10]))
            .unwrap();
        let mut req = TempcalRequest::new(rec);
        req.options.segments = 1;
        assert!(matches!(
            tempcal(&req),
            Err(TempcalRunError::Tempcal(TempcalError::Setting { .. }))
        ));
        let mut req = TempcalRequest::new("no-such-file.csv");
        req.columns = Some(vec!["x".into(), "y".into()]);
        assert!(matches!(
            tempcal(&req),
            Err(TempcalRunError::Read(crate::Error::ColumnsNotThree(_)))
        ));
    }
}
