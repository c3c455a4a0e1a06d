//! The multi-position fit's error: why window means gave no calibration (too few windows, poses
//! in a plane, the core's fit refusing them) or why a file is not for this fit. Joined into
//! [`super::Error`] as `Error::Fit`; re-exported as `fit::FitError`.

/// Why the multi-position fit failed. Joined into [`super::Error::Fit`].
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// `fit` was given a six-position table (a `pose` column): its rows are labelled poses for
    /// the six-position method, not samples in which to look for static windows.
    #[error("the file has a pose column: its {rows} rows are labelled poses for the six-position method, not samples to search for static windows")]
    PoseTable {
        /// Rows in the file.
        rows: usize,
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
    /// The file does not name its sensor, the accelerometer's fit refused it, and its samples
    /// look like another sensor's ([`crate::protocol::sensor_kind`]).
    #[error("{evidence}; the accelerometer's fit: {fit}")]
    AnotherSensor {
        /// What the samples look like, measured, and the command for that sensor.
        evidence: String,
        /// The fit's own refusal.
        fit: Box<FitError>,
    },
    /// The recognised protocol's method cannot calibrate these windows.
    #[error("protocol: {summary}: {why}")]
    Protocol {
        /// What was recognised.
        summary: String,
        /// Why its method gives no calibration, and what to record.
        why: String,
    },
}

impl FitError {
    /// The same error, a too-few-windows one marked as found by the adaptive detector when
    /// `adaptive` (its advice is then about the recording, not the settings).
    pub fn found_by(self, adaptive: bool) -> Self {
        match self {
            FitError::TooFewWindows {
                found,
                needed,
                model,
                ..
            } => FitError::TooFewWindows {
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
