//! The detection stage's error: why a recording's static windows could not be found (no
//! sample rate, a setting the detector cannot use, a recording too short, a saturated window).
//! Joined into [`super::Error`] as `Error::Detect`; re-exported as `detect::DetectError`.

/// Why static windows could not be detected. Joined into [`super::Error::Detect`]; the CLI
/// names its flag for the variants that concern a setting.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
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
