//! The gyroscope fit's error (`wiical gyrofit`): why the accelerometer and gyro recordings
//! cannot be paired or the gyro cannot be fitted. Joined into [`super::Error`] as
//! `Error::Gyro` and re-exported as `gyro::GyroError`; it holds the accelerometer's detection and fit errors whole (the gyro fit runs those stages first).

/// Why a gyro calibration failed: the two recordings are not the same samples, the columns are
/// not a gyro's, the nominal sensitivity is missing or implausible, or the motions are too few
/// for the core's fit; or the accelerometer's windows or fit, which come first. Joined into
/// [`super::Error::Gyro`], except that the accelerometer's errors become `Error::Detect` and
/// `Error::Fit` there, as from `wiical fit` (the CLI names the same flags for them).
#[derive(Debug, thiserror::Error)]
pub enum GyroError {
    /// The accelerometer's static windows could not be detected.
    #[error(transparent)]
    Detect(#[from] crate::error::detect::DetectError),
    /// The accelerometer's multi-position fit failed.
    #[error(transparent)]
    Fit(#[from] crate::error::fit::FitError),
    /// The accelerometer and gyro recordings cannot be paired row by row.
    #[error("the accelerometer has {accel} samples and the gyro {gyro}: they must be the same samples (same length, or time columns whose gyro times are all accelerometer times)")]
    GyroRowsMismatch {
        /// Accelerometer samples.
        accel: usize,
        /// Gyro samples.
        gyro: usize,
    },
    /// Too few motions between static windows for a gyro fit.
    #[error(
        "found {found} motions between static windows, need at least {needed}: record more poses"
    )]
    TooFewMotions {
        /// Motions found.
        found: usize,
        /// Needed.
        needed: usize,
    },
    /// The nominal gyro sensitivity is missing, zero or not finite.
    #[error(
        "the nominal gyro sensitivity (rad/s per count) must be finite and non-zero on every axis"
    )]
    GyroNominalScale,
    /// The nominal turns the motions by absurd angles: a wrong unit or a typo.
    #[error("the gyro nominal from {source_name} turns the motions by {} the tilt the accelerometer sees between their poses (median of {motions} motions; a right nominal gives about 1 to 5 times): check the value and its unit", if ratio.is_finite() { format!("{ratio:.3e} times") } else { "infinitely more than".to_string() })]
    GyroNominalImplausible {
        /// Where the nominal came from (`--scale`, `--counts-per-dps`, the columns' unit).
        source_name: String,
        /// Median of integrated rotation angle / tilt.
        ratio: f64,
        /// Motions that tilted enough to compare.
        motions: usize,
    },
    /// The core's gyro fit failed on the data.
    #[error("gyro fit failed: {0}")]
    GyroFitFailed(wiical_core::Error),
    /// The thread fitting one candidate model panicked: a bug in the fit, reported as an error
    /// of the whole fit rather than as a model that did not converge (which would hide it in
    /// the candidates' table and let another model be chosen as if nothing had happened).
    #[error("the thread fitting the {candidate} gyro model panicked (a bug, please report it): {message}")]
    WorkerPanicked {
        /// The candidate model's name (`wiical gyrofit`'s table).
        candidate: &'static str,
        /// The panic's message.
        message: String,
    },
    /// A single-file gyro calibration whose header names no gyroscope columns.
    #[error("the header names no gyroscope columns (the nearest triplet is {taken}, not a gyroscope): name them gx,gy,gz or gyro_x_dps,… (deg/s), gyro_x_rads,… (rad/s)")]
    NoGyroColumns {
        /// The triplet the loader would have taken.
        taken: String,
    },
    /// The gyro's clock does not match the accelerometer's row for row.
    #[error("the accelerometer's and the gyro's times differ by up to {offset_s:.4} s on the same row: the two files are not the same samples (shifted or from another recording)")]
    GyroClocksDiffer {
        /// Largest difference, s.
        offset_s: f64,
    },
    /// A gyro file that covers only part of the accelerometer's recording.
    #[error("the gyro covers t = {:.2}…{:.2} s but the accelerometer {:.2}…{:.2} s: the gyro file is cut short (or from another recording)", gyro.0, gyro.1, accel.0, accel.1)]
    GyroSpanShort {
        /// The gyro's first and last time, s.
        gyro: (f64, f64),
        /// The accelerometer's first and last time, s.
        accel: (f64, f64),
    },
    /// "Gyro" data that turn with the pose like gravity.
    #[error("the gyro columns ({columns}) change between the still poses like gravity (spread {spread:.3} against {motion_rms:.3} RMS during the motions): they are an accelerometer's, not a gyro's; give the gyro's columns (--gyro-columns) or its file")]
    GyroLooksLikeGravity {
        /// The columns taken as the gyro.
        columns: String,
        /// RMS spread of the gyro's window means.
        spread: f64,
        /// RMS of the gyro during the motions.
        motion_rms: f64,
    },
    /// Gyro axes that read one value on every row.
    #[error("the gyro reads nothing: {columns} hold {value} on all {rows} rows while the accelerometer reads {accel_norm:.3} on average; the gyro was off or not enabled, or these are not its columns (--gyro-columns)")]
    GyroReadsNothing {
        /// The constant columns.
        columns: String,
        /// Their value.
        value: f64,
        /// Rows.
        rows: usize,
        /// Mean magnitude of the accelerometer, its units.
        accel_norm: f64,
    },
    /// The recording never turns: nothing to fit a gyro's scale to.
    #[error("the recording is static: the accelerometer's direction moves at most {max_tilt_deg:.1}° over it (1-s means), so the gyro never turns and a static log carries no scale or misalignment, only the gyro's noise and bias; run `wiical noise` on it for its noise terms, or record turns between still poses for `gyrofit`")]
    GyroStaticOnly {
        /// Largest angle between a 1-s mean of the accelerometer and their overall mean, degrees.
        max_tilt_deg: f64,
    },
    /// The accelerometer and gyro recordings were given in swapped order.
    #[error("the two files are in swapped order: the second one has the {windows} still poses of an accelerometer and the first turns like a gyro; give the accelerometer's file first, then the gyro's")]
    GyroFilesSwapped {
        /// Static windows found in the second file.
        windows: usize,
    },
    /// The given nominal has the wrong sign on some axes.
    #[error("the gyro nominal from {source_name} turns the motions the wrong way on the {axes} axis (RMS angle error {given_deg:.1}° against {flipped_deg:.1}° with that sign flipped): the sign is wrong; give {source_name} {suggested} (an axis mounted the other way has a negative sensitivity)")]
    GyroNominalSign {
        /// Where the nominal came from.
        source_name: String,
        /// The axes whose sign is wrong.
        axes: String,
        /// RMS angle error with the given nominal, degrees.
        given_deg: f64,
        /// With the signs flipped, degrees.
        flipped_deg: f64,
        /// The nominal with the signs flipped, rad/s per count.
        suggested: String,
    },
    /// The motions' samples (what the fit integrates, kept in memory even when the file is
    /// read in passes) are more than [`crate::input::front_door::MAX_HELD_SAMPLES`]: refused
    /// before they are collected (a 1 GB `.gz` of rows took 2.2 GB).
    #[error("its motions between still poses hold {samples} samples, more than the {limit} `wiical gyrofit` keeps in memory; cut the recording to its calibration (still poses and the turns between them take minutes)")]
    GyroMotionsTooLong {
        /// Samples in the motions, margins included.
        samples: usize,
        /// The bound.
        limit: usize,
    },
    /// A request's arguments cannot be used (the caller's mistake, not the data's).
    #[error(transparent)]
    Arg(#[from] GyroArgError),
}

/// Why the arguments of a `gyrofit` request ([`crate::gyro::request::GyrofitRequest`]) cannot
/// be used. The messages name no flag or keyword argument: the command line names its flags
/// for them, Python raises them as `ValueError`.
#[derive(Debug, thiserror::Error)]
pub enum GyroArgError {
    /// The gyro columns must be three names.
    #[error("the gyro columns need exactly three names (e.g. gx,gy,gz), got {}: {}", .0.len(), .0.join(","))]
    ColumnsNotThree(Vec<String>),
    /// A nominal sensitivity given with neither one value nor three.
    #[error("the nominal {setting} takes one value or three (x,y,z), got {given}")]
    NotPerAxis {
        /// Which way the nominal was given.
        setting: NominalSetting,
        /// How many values were given.
        given: usize,
    },
    /// The nominal given both as a scale and as counts per °/s.
    #[error("give the nominal either as a scale (rad/s per count) or as counts per °/s, not both")]
    BothNominals,
    /// A given nominal that is zero or not finite on some axis.
    #[error("the nominal sensitivity must be finite and non-zero on every axis")]
    NominalUnusable,
}

/// The two ways a nominal gyro sensitivity is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NominalSetting {
    /// rad/s per count (`--scale`, `scale=`).
    Scale,
    /// Counts per °/s, datasheet style (`--counts-per-dps`, `counts_per_dps=`).
    CountsPerDps,
}

impl std::fmt::Display for NominalSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NominalSetting::Scale => "scale (rad/s per count)",
            NominalSetting::CountsPerDps => "counts per °/s",
        })
    }
}

impl GyroError {
    /// Whether this refusal of the motion fit says the recording is another protocol (the
    /// accelerometer's poses too few or all on faces, a static log, too few motions) rather
    /// than that the input is wrong (an absurd nominal, a gyro shifted, cut short or reading
    /// gravity), which stays refused: `gyrofit` and `calibrate` then try the protocols'
    /// methods (`crate::protocol::gyro`).
    pub fn says_another_protocol(&self) -> bool {
        use crate::error::fit::FitError;
        matches!(
            self,
            GyroError::Fit(
                FitError::TooFewWindows { .. }
                    | FitError::DegeneratePoses { .. }
                    | FitError::FitFailed(_)
            ) | GyroError::TooFewMotions { .. }
                | GyroError::GyroStaticOnly { .. }
        )
    }
}
