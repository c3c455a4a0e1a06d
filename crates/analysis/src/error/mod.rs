//! The analysis engine's error type, and each stage's own type beside it.
//!
//! Messages describe the data and the settings by meaning ("the shortest static duration"),
//! never by a command-line flag: a program using this crate has no flags. The `wiical` CLI
//! matches the variants that concern a setting and names its own flag instead.
//!
//! The stage types live here rather than in their stages so that this room is imported by
//! the stages and imports none of them: each file below names nothing of the crate but its
//! neighbours here ([`gyro::GyroError`] holds a [`detect::DetectError`] and a
//! [`fit::FitError`]), and every stage re-exports its own type from its module.

pub(crate) mod correct;
pub(crate) mod detect;
pub(crate) mod fit;
pub(crate) mod gyro;
pub(crate) mod magnetometer;
pub(crate) mod noise;
pub(crate) mod protocol;
pub(crate) mod search;
pub(crate) mod six_position;

// The I/O stages' errors are `wiical-io`'s (bounded reads, atomic writes), under their old paths.
pub use wiical_io::error::{input, output};

use std::path::{Path, PathBuf};

/// Everything that can go wrong between a file and a report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    // ---- reading files ----
    /// A file could not be read or parsed ([`crate::error::input::InputError`]).
    #[error(transparent)]
    Input(#[from] crate::error::input::InputError),
    /// An output could not be written, or is refused before writing
    /// ([`crate::error::output::OutputError`]).
    #[error(transparent)]
    Output(#[from] crate::error::output::OutputError),
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
    /// Static windows could not be detected ([`crate::error::detect::DetectError`]).
    #[error(transparent)]
    Detect(#[from] crate::error::detect::DetectError),
    /// The multi-position fit failed ([`crate::error::fit::FitError`]).
    #[error(transparent)]
    Fit(#[from] crate::error::fit::FitError),
    /// The gyro's protocol methods found nothing to calibrate from
    /// ([`crate::error::protocol::GyroProtocolError`]).
    #[error(transparent)]
    GyroProtocol(#[from] crate::error::protocol::GyroProtocolError),
    /// The search refused its settings or could not finish
    /// ([`crate::error::search::SearchError`]).
    #[error(transparent)]
    Search(#[from] crate::error::search::SearchError),
    /// A six-position table could not be solved
    /// ([`crate::error::six_position::SixPositionError`]).
    #[error(transparent)]
    SixPosition(#[from] crate::error::six_position::SixPositionError),

    // ---- host-side correction ----
    /// A recording could not be corrected with a calibration file
    /// ([`crate::error::correct::CorrectError`]).
    #[error(transparent)]
    Correct(#[from] crate::error::correct::CorrectError),

    // ---- magnetometer and gyroscope ----
    /// A magnetometer fit failed ([`crate::error::magnetometer::MagnetometerError`]).
    #[error(transparent)]
    Magnetometer(#[from] crate::error::magnetometer::MagnetometerError),
    /// A gyro calibration failed ([`crate::error::gyro::GyroError`]; its accelerometer
    /// detection and fit errors are joined as [`Error::Detect`] and [`Error::Fit`] instead).
    #[error(transparent)]
    Gyro(crate::error::gyro::GyroError),

    // ---- noise ----
    /// A noise report could not be made or a noise file read
    /// ([`crate::error::noise::NoiseError`]).
    #[error(transparent)]
    Noise(#[from] crate::error::noise::NoiseError),

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

    // ---- serialisation ----
    /// JSON (de)serialisation.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}

impl From<crate::error::gyro::GyroError> for Error {
    /// The gyro fit's own errors as `Error::Gyro`; the accelerometer's detection and fit,
    /// which it runs first, as the same variants `fit` gives for them.
    fn from(e: crate::error::gyro::GyroError) -> Self {
        use crate::error::gyro::GyroError;
        match e {
            GyroError::Detect(e) => Error::Detect(e),
            GyroError::Fit(e) => Error::Fit(e),
            e => Error::Gyro(e),
        }
    }
}

impl From<crate::error::gyro::GyroArgError> for Error {
    /// A `gyrofit` request's argument error as `Error::Gyro`, where the gyro fit's are.
    fn from(e: crate::error::gyro::GyroArgError) -> Self {
        Error::Gyro(e.into())
    }
}

impl From<wiical_io::Error> for Error {
    /// An I/O error as the variant of the same name: `Error::Input`, `Error::Output` and
    /// `Error::NotRegularFile` read the same whether the engine or `wiical-io` found them.
    fn from(e: wiical_io::Error) -> Self {
        match e {
            wiical_io::Error::Input(e) => Error::Input(e),
            wiical_io::Error::Output(e) => Error::Output(e),
            wiical_io::Error::NotRegularFile { path } => Error::NotRegularFile { path },
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
    /// An error in that file already is left as it is (one name, not the same twice).
    pub fn in_file(self, path: impl Into<PathBuf>) -> Self {
        let path = path.into();
        if matches!(&self, Error::InFile { path: named, .. } if *named == path) {
            return self;
        }
        Error::InFile {
            path,
            source: Box::new(self),
        }
    }

    /// This error with the file `from` named `to` wherever it names it: standard input too
    /// long to hold is read from a temporary file ([`crate::input::front_door::Opened::Spooled`]),
    /// but the user gave `-`, and a temporary name they never saw would not tell them which
    /// input is meant.
    pub fn renaming(mut self, from: &Path, to: &Path) -> Self {
        self.rename_file(from, to);
        self
    }

    /// [`Error::renaming`] in place, down the chain of files.
    fn rename_file(&mut self, from: &Path, to: &Path) {
        let named = match self {
            Error::InFile { path, source } => {
                source.rename_file(from, to);
                Some(path)
            }
            Error::NotRegularFile { path } => Some(path),
            Error::Input(e) => e.file_mut(),
            _ => None,
        };
        if let Some(path) = named.filter(|p| p.as_path() == from) {
            *path = to.to_path_buf();
        }
    }
}
