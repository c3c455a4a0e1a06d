//! The analysis engine's error type.
//!
//! Messages describe the data and the settings by meaning ("the shortest static duration"),
//! never by a command-line flag: a program using this crate has no flags. The `wiical` CLI
//! matches the variants that concern a setting and names its own flag instead.

use std::path::PathBuf;

/// Everything that can go wrong between a file and a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    // ---- reading files ----
    /// A file could not be read or parsed ([`crate::input::error::InputError`]).
    #[error(transparent)]
    Input(#[from] crate::input::error::InputError),
    /// An output could not be written, or is refused before writing
    /// ([`crate::output::error::OutputError`]).
    #[error(transparent)]
    Output(#[from] crate::output::error::OutputError),
    /// An input or output path names something other than a regular file (a device, a
    /// directory, a pipe): `/dev/zero` would never end.
    #[error("{} is not a regular file (give a file, or - for standard input)", path.display())]
    NotRegularFile {
        /// The path.
        path: PathBuf,
    },
    /// An error inside a file's contents.
    #[error("in {}", path.display())]
    InFile {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        #[source]
        source: Box<Error>,
    },

    // ---- settings ----
    /// A setting out of its range.
    #[error("{0}")]
    InvalidSetting(&'static str),
    /// Explicit axis columns must be exactly three.
    #[error("exactly three axis column names are needed (x,y,z), got {}: {}", .0.len(), .0.join(","))]
    ColumnsNotThree(Vec<String>),

    // ---- the stages of a fit ----
    /// Static windows could not be detected ([`crate::detect::error::DetectError`]).
    #[error(transparent)]
    Detect(#[from] crate::detect::error::DetectError),
    /// The multi-position fit failed ([`crate::fit::error::FitError`]).
    #[error(transparent)]
    Fit(#[from] crate::fit::error::FitError),
    /// The search refused its settings or could not finish
    /// ([`crate::search::error::SearchError`]).
    #[error(transparent)]
    Search(#[from] crate::search::error::SearchError),
    /// A six-position table could not be solved
    /// ([`crate::fit::six_position_error::SixPositionError`]).
    #[error(transparent)]
    SixPosition(#[from] crate::fit::six_position_error::SixPositionError),

    // ---- magnetometer and gyroscope ----
    /// A magnetometer fit failed ([`crate::magnetometer_error::MagnetometerError`]).
    #[error(transparent)]
    Magnetometer(#[from] crate::magnetometer_error::MagnetometerError),
    /// A gyro calibration failed ([`crate::gyro_error::GyroError`]; its accelerometer
    /// detection and fit errors are joined as [`Error::Detect`] and [`Error::Fit`] instead).
    #[error(transparent)]
    Gyro(crate::gyro_error::GyroError),

    // ---- noise ----
    /// A noise report could not be made or a noise file read
    /// ([`crate::noise::error::NoiseError`]).
    #[error(transparent)]
    Noise(#[from] crate::noise::error::NoiseError),

    // ---- batch ----
    /// An input of `wiical batch` that is neither a file, a directory nor a pattern that
    /// can be expanded.
    #[error("batch input {}: {why}", input.display())]
    BatchInput {
        /// The input as given.
        input: PathBuf,
        /// Why it cannot be used.
        why: String,
    },

    // ---- factory calibration blocks ----
    /// A factory calibration block (hex text, length, device name) that cannot be decoded.
    #[error(transparent)]
    Factory(#[from] crate::factory::FactoryError),

    // ---- internal consistency (bugs, not bad input) ----
    /// The simulator's self-checks ([`crate::simulate::error::SimulateError`]).
    #[cfg(feature = "simulate")]
    #[error(transparent)]
    Simulate(#[from] crate::simulate::error::SimulateError),
    /// JSON (de)serialisation.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

impl From<crate::gyro_error::GyroError> for Error {
    /// The gyro fit's own errors as `Error::Gyro`; the accelerometer's detection and fit,
    /// which it runs first, as the same variants `fit` gives for them.
    fn from(e: crate::gyro_error::GyroError) -> Self {
        use crate::gyro_error::GyroError;
        match e {
            GyroError::Detect(e) => Error::Detect(e),
            GyroError::Fit(e) => Error::Fit(e),
            e => Error::Gyro(e),
        }
    }
}

/// Result with the analysis [`enum@Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The message with its causes, `outer: inner: …` (as the CLI prints it).
    pub fn full_message(&self) -> String {
        let mut s = self.to_string();
        let mut cur: Option<&(dyn std::error::Error + 'static)> = std::error::Error::source(self);
        while let Some(e) = cur {
            s.push_str(": ");
            s.push_str(&e.to_string());
            cur = e.source();
        }
        s
    }

    /// Attaches the file the error was found in.
    pub fn in_file(self, path: impl Into<PathBuf>) -> Self {
        Error::InFile {
            path: path.into(),
            source: Box::new(self),
        }
    }
}
