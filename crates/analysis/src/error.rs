//! The analysis engine's error type.
//!
//! Messages describe the data and the settings by meaning ("the shortest static duration"),
//! never by a command-line flag: a program using this crate has no flags. The `wiical` CLI
//! matches the variants that concern a setting and names its own flag instead.

use std::path::PathBuf;
use wiical_core::six_position::Pose;

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

    // ---- fitting a recording ----
    /// `fit` was given a six-position table (a `pose` column): its rows are labelled poses for
    /// the six-position method, not samples in which to look for static windows.
    #[error("the file has a pose column: its {rows} rows are labelled poses for the six-position method, not samples to search for static windows")]
    PoseTable {
        /// Rows in the file.
        rows: usize,
    },

    // ---- settings ----
    /// A setting out of its range.
    #[error("{0}")]
    InvalidSetting(&'static str),
    /// Explicit axis columns must be exactly three.
    #[error("exactly three axis column names are needed (x,y,z), got {}: {}", .0.len(), .0.join(","))]
    ColumnsNotThree(Vec<String>),
    /// An unknown candidate effect name.
    #[error("unknown candidate effect '{name}'; known: {known}")]
    UnknownCandidate {
        /// The name given.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },

    // ---- detection and fitting ----
    /// Neither a time column, metadata nor a default rate.
    #[error("cannot determine the sample rate")]
    NoSampleRate,
    /// The variance window does not fit the detector's ring.
    #[error(
        "window of {samples} samples exceeds the maximum {max}; use a shorter variance window"
    )]
    WindowTooLong {
        /// Window in samples.
        samples: usize,
        /// The detector's capacity.
        max: usize,
    },
    /// Shorter than the initial rest period.
    #[error("recording too short: {samples} samples, the initial rest period alone needs {needed} ({init_s} s at {rate_hz} Hz)")]
    TooShort {
        /// Samples in the recording.
        samples: usize,
        /// Samples the rest period needs.
        needed: u32,
        /// Rest period, s.
        init_s: f64,
        /// Sample rate, Hz.
        rate_hz: f64,
    },
    /// A sample rate too low to find still holds in (see `windows::MIN_SAMPLE_RATE_HZ`).
    #[error("the sample rate is {rate_hz} Hz, too low to find still holds of half a second to two seconds: is the time column in milliseconds rather than seconds, or are the rows already window means?")]
    RateTooLow {
        /// The rate, Hz (from the time column or metadata).
        rate_hz: f64,
    },
    /// Shorter than the adaptive detector's noise survey (it needs that many quiet-or-not
    /// blocks to find the recording's own noise level).
    #[error("recording too short: {samples} samples, the adaptive detector's noise survey alone needs {needed} ({survey_s} s at {rate_hz:.3} Hz) to learn the sensor's noise")]
    TooShortForSurvey {
        /// Samples in the recording.
        samples: usize,
        /// Samples the survey needs.
        needed: u32,
        /// Survey length, s.
        survey_s: f64,
        /// Sample rate, Hz.
        rate_hz: f64,
    },
    /// A detector setting that cannot work with this recording, named.
    #[error("{setting} is too short or invalid: {why}")]
    DetectorSetting {
        /// Which setting.
        setting: Setting,
        /// Why, with the numbers.
        why: String,
    },
    /// The core refused the detector settings.
    #[error("static detector settings: {0}")]
    DetectorSettings(wiical_core::Error),
    /// The detector refused a sample.
    #[error("sample {index}: {cause}")]
    Sample {
        /// 1-based sample.
        index: usize,
        /// Why.
        cause: wiical_core::Error,
    },
    /// A static window touches the ADC limits.
    #[error("{}: static window {window} (samples {start}..{end}) has axis {axis} at the ADC limit ({value}) in sample {sample}: that pose is saturated and cannot be used; re-record it or give the ADC range explicitly", wiical_core::Error::Saturated)]
    Saturated {
        /// 1-based window.
        window: usize,
        /// First sample index.
        start: u32,
        /// One past the last.
        end: u32,
        /// `x`, `y` or `z`.
        axis: &'static str,
        /// The reading.
        value: f64,
        /// 1-based sample.
        sample: usize,
    },
    /// Fewer static windows than the model has parameters.
    #[error("found {found} static windows but the {model} needs at least {needed}: {}", too_few_windows_hint(*adaptive))]
    TooFewWindows {
        /// Windows found.
        found: u32,
        /// Windows needed.
        needed: u32,
        /// `9-parameter model`, `6-parameter model` or just `model`.
        model: &'static str,
        /// True when the adaptive detector found them: it already tried holds down to its
        /// shortest, so only the recording can change the count, not a setting.
        adaptive: bool,
    },
    /// The poses lie in a plane or a line.
    #[error("the {poses} static poses do not spread over enough orientations (e.g. all in one plane): turn the sensor so that each axis points up and down")]
    DegeneratePoses {
        /// Poses found.
        poses: usize,
    },
    /// The core's multi-position fit failed otherwise.
    #[error("multi-position fit failed: {0}")]
    FitFailed(wiical_core::Error),
    /// The f64 refinement could not be solved.
    #[error("the f64 refinement of the base fit failed (degenerate poses)")]
    RefinementFailed,
    /// The final calibration does not validate.
    #[error("the final calibration is not valid: {0}")]
    InvalidCalibration(wiical_core::Error),
    /// Refusing to write a calibration that does not validate.
    #[error("refusing to write an invalid calibration: {0}")]
    RefuseInvalidCalibration(wiical_core::Error),

    // ---- six-position ----
    /// No `pose` column.
    #[error("the file needs a 'pose' column with labels x+ x- y+ y- z+ z-")]
    NoPoseColumn,
    /// A label that is not a pose.
    #[error("row {row}: unknown pose label '{label}' (expected x+ x- y+ y- z+ z-)")]
    UnknownPose {
        /// 1-based row.
        row: usize,
        /// The label.
        label: String,
    },
    /// A pose in two separate blocks.
    #[error("{}: pose '{}' appears again at row {row} after other poses (first block starts at row {first})", wiical_core::Error::DuplicatePose, pose.label())]
    DuplicatePose {
        /// The pose.
        pose: Pose,
        /// 1-based row of the second block.
        row: usize,
        /// 1-based first row of the first block.
        first: usize,
    },
    /// A pose without rows.
    #[error("{}: no rows for pose '{}'", wiical_core::Error::MissingPose, .0.label())]
    MissingPose(Pose),
    /// The core refused a pose block.
    #[error("{0}")]
    PoseBlock(wiical_core::Error),
    /// The ± poses coincide.
    #[error("the ± poses do not differ enough to determine the scale (was the sensor turned between poses?)")]
    PosesNotTurned,
    /// The core's six-position solve failed otherwise.
    #[error("six-position solve failed: {0}")]
    SixPositionFailed(wiical_core::Error),
    /// The f64 six-position solve is singular.
    #[error("six-position solve is singular")]
    SixPositionSingular,
    /// `D` has no inverse.
    #[error("D is singular")]
    SingularD,

    // ---- magnetometer and gyroscope ----
    /// A magnetometer fit failed ([`crate::magnetometer_error::MagnetometerError`]).
    #[error(transparent)]
    Magnetometer(#[from] crate::magnetometer_error::MagnetometerError),
    /// A gyro calibration failed ([`crate::gyro_error::GyroError`]).
    #[error(transparent)]
    Gyro(#[from] crate::gyro_error::GyroError),

    // ---- calibration files ----
    /// Not a calibration JSON.
    #[error("{} is not a calibration JSON", path.display())]
    NotCalibrationJson {
        /// The file.
        path: PathBuf,
        /// The parser's complaint.
        #[source]
        source: serde_json::Error,
    },
    /// A calibration file that does not validate.
    #[error("{}: invalid calibration: {cause}", path.display())]
    InvalidCalibrationFile {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: wiical_core::Error,
    },

    /// A recording too short for an Allan deviation.
    #[error("{samples} samples are too few for an Allan deviation (at least {needed}; the curve reaches τ = n/9 samples, so a long still recording — hours — is what shows bias instability and random walk)")]
    NoiseTooShort {
        /// Samples given.
        samples: usize,
        /// Fewest accepted.
        needed: usize,
    },

    /// A noise file that cannot give the Kalman filter its σ's.
    #[error("the noise file cannot give the filter's noise: {why}")]
    NoiseFileUnusable {
        /// Why.
        why: String,
    },

    /// A six-position axis that reads lower with it up than down.
    #[error("axis {} reads {up:.2} with it up and {down:.2} with it down (pose {}+ and {}−): the ± labels are swapped, which would make its scale negative; relabel the poses", ["x","y","z"][*axis], ["x","y","z"][*axis], ["x","y","z"][*axis])]
    SixPoseSwapped {
        /// Axis 0..3.
        axis: usize,
        /// Mean with the axis up.
        up: f64,
        /// Mean with the axis down.
        down: f64,
    },
    /// A six-position axis whose up and down blocks differ by no more than their noise.
    #[error("the {}+ and {}− poses differ by {difference:.3} on that axis, within the noise of their blocks (standard error {standard_error:.3}): they are not opposite orientations; record each pose with the axis straight up and straight down", ["x","y","z"][*axis], ["x","y","z"][*axis])]
    SixPoseNotSeparated {
        /// Axis 0..3.
        axis: usize,
        /// Mean up − mean down.
        difference: f64,
        /// Its standard error.
        standard_error: f64,
    },

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
    /// The six-position calibration written to the report does not map the pose means back
    /// to ±1 g (a self-check after the fit).
    #[error("internal: six-position calibration does not reproduce the poses")]
    SixPositionNotReproduced,
    /// JSON (de)serialisation.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
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

/// A static-detector setting, named in errors (the CLI names its flag instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// The initial rest period (noise reference).
    InitialRest,
    /// The shortest static duration.
    MinStatic,
    /// The detection threshold factor.
    Threshold,
}

impl std::fmt::Display for Setting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Setting::InitialRest => "the initial rest period",
            Setting::MinStatic => "the shortest static duration",
            Setting::Threshold => "the detection threshold",
        })
    }
}

impl Error {
    /// The same error, a too-few-windows one marked as found by the adaptive detector when
    /// `adaptive` (its advice is then about the recording, not the settings).
    pub fn found_by(self, adaptive: bool) -> Self {
        match self {
            Error::TooFewWindows {
                found,
                needed,
                model,
                ..
            } => Error::TooFewWindows {
                found,
                needed,
                model,
                adaptive,
            },
            other => other,
        }
    }
}

/// What to do about too few static windows: with the adaptive detector only a new recording
/// helps; with fixed settings, shorter holds or a looser threshold may find more.
fn too_few_windows_hint(adaptive: bool) -> String {
    if adaptive {
        let shortest = wiical_core::static_detect::adaptive::HOLD_SCHEDULE
            .last()
            .map_or(0.0, |h| h.1);
        format!("the recording is still (for at least {shortest} s) in no more orientations than that; record again holding the sensor still for about a second in more orientations, each axis up and down")
    } else {
        "hold the sensor still in more orientations (or shorten the minimum static duration / raise the detection threshold)".to_string()
    }
}
