//! What the messages carry: the payload types of [`Request`](crate::Request) and
//! [`Response`](crate::Response), which are declared (with the pairing of each request with
//! its answer) in [`crate::protocol`].
//!
//! The host sends requests; the adapter sends responses, one per request, plus unsolicited
//! [`Sample`]s while a stream is running.

use serde::{Deserialize, Serialize};
use wiical_core::gyro_correct::{GyroCorrection, GyroEffects};
use wiical_core::terms::EFFECT_FLOATS;
use wiical_core::{Calibration, Effects};

/// Capacity of [`HelloResponse::firmware_version`], in bytes of UTF-8.
pub const FIRMWARE_VERSION_CAP: usize = 32;

/// The host's half of the handshake.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// Sender's [`PROTOCOL_VERSION`](crate::PROTOCOL_VERSION).
    pub protocol_version: u16,
    /// Sender's [`SCHEMA_KEY`](crate::SCHEMA_KEY).
    pub schema_key: u32,
}

/// The adapter's half of the handshake.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HelloResponse {
    /// Adapter's [`PROTOCOL_VERSION`](crate::PROTOCOL_VERSION).
    pub protocol_version: u16,
    /// Adapter's [`SCHEMA_KEY`](crate::SCHEMA_KEY).
    pub schema_key: u32,
    /// Firmware version string (e.g. `"0.1.0+g1234abc"`), at most
    /// [`FIRMWARE_VERSION_CAP`] bytes.
    pub firmware_version: heapless::String<FIRMWARE_VERSION_CAP>,
    /// Unique device ID (e.g. the MCU's 64-bit unique ID or flash ID).
    pub device_id: [u8; 8],
}

/// Why the adapter refused or failed a request. Serialized as its `u8` value, which never
/// changes and is never reused; new codes get new numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "u8", try_from = "u8")]
#[repr(u8)]
pub enum ErrorCode {
    /// The peer's schema key differs from ours: the two builds cannot talk.
    SchemaMismatch = 1,
    /// A frame arrived corrupt (COBS, CRC or decoding failure, or oversize).
    BadFrame = 2,
    /// The request is valid but not supported by this adapter.
    UnsupportedRequest = 3,
    /// The calibration is not usable (non-finite values or a singular matrix).
    InvalidCalibration = 4,
    /// Commit without a staged calibration.
    NothingStaged = 5,
    /// Writing persistent storage failed; the live calibration is unchanged.
    StorageFailure = 6,
    /// The adapter cannot do this now (e.g. a commit is in progress).
    Busy = 7,
    /// A request parameter is out of range (e.g. `rate_divider == 0`).
    InvalidParameter = 8,
    /// No sensor is connected / it did not answer.
    NoSensor = 9,
    /// An internal error in the adapter.
    Internal = 10,
    /// (Protocol 2.) The calibration is usable but implausible for the sensor (offsets,
    /// sensitivity, cross-axis terms or the output over the sensor's input range beyond the
    /// core's acceptance limits, `wiical_core::acceptance`); the old calibration is kept.
    ImplausibleCalibration = 11,
}

impl ErrorCode {
    /// Every code, for tests and tables.
    pub const ALL: [ErrorCode; 11] = [
        ErrorCode::SchemaMismatch,
        ErrorCode::BadFrame,
        ErrorCode::UnsupportedRequest,
        ErrorCode::InvalidCalibration,
        ErrorCode::NothingStaged,
        ErrorCode::StorageFailure,
        ErrorCode::Busy,
        ErrorCode::InvalidParameter,
        ErrorCode::NoSensor,
        ErrorCode::Internal,
        ErrorCode::ImplausibleCalibration,
    ];

    /// Short English description, for the host's messages.
    pub const fn description(self) -> &'static str {
        match self {
            ErrorCode::SchemaMismatch => {
                "protocol schema mismatch: host and firmware were built from different wire formats"
            }
            ErrorCode::BadFrame => "corrupt frame",
            ErrorCode::UnsupportedRequest => "request not supported by this firmware",
            ErrorCode::InvalidCalibration => "calibration rejected (non-finite or singular)",
            ErrorCode::NothingStaged => "no staged calibration to commit",
            ErrorCode::StorageFailure => "writing persistent storage failed",
            ErrorCode::Busy => "device busy",
            ErrorCode::InvalidParameter => "parameter out of range",
            ErrorCode::NoSensor => "no sensor connected",
            ErrorCode::Internal => "internal firmware error",
            ErrorCode::ImplausibleCalibration => {
                "calibration rejected as implausible for the sensor (offsets, scale or output range beyond the limits); the old one is kept"
            }
        }
    }
}

impl From<ErrorCode> for u8 {
    fn from(c: ErrorCode) -> u8 {
        c as u8
    }
}

/// A `u8` that is not a known [`ErrorCode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownErrorCode(pub u8);

impl core::fmt::Display for UnknownErrorCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "unknown error code {}", self.0)
    }
}

impl TryFrom<u8> for ErrorCode {
    type Error = UnknownErrorCode;
    fn try_from(v: u8) -> Result<Self, UnknownErrorCode> {
        ErrorCode::ALL
            .into_iter()
            .find(|c| *c as u8 == v)
            .ok_or(UnknownErrorCode(v))
    }
}

impl core::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.description())
    }
}

/// The calibration state reported by [`Request::GetCalibration`](crate::Request::GetCalibration).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CalibrationState {
    /// The calibration applied to streamed samples now.
    pub live: WireCalibration,
    /// The staged calibration awaiting commit, if any.
    pub staged: Option<WireCalibration>,
    /// True when `live` was loaded from / committed to persistent storage; false when it is
    /// the firmware's built-in default.
    pub stored: bool,
    /// (Protocol 4.) What the adapter found in storage at boot, so that a record it refused
    /// (and runs without) is told to the host instead of passing for "none committed".
    pub boot: BootRecord,
    /// (Protocol 4.) Damaged or interrupted records the adapter found in storage at boot
    /// and skipped: when non-zero, `live` is the newest intact record (or none), which may
    /// be older than the last commit.
    pub damaged_records: u16,
}

/// (Protocol 4.) The stored calibration record as the adapter found it at boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BootRecord {
    /// Nothing stored.
    Empty,
    /// A valid record was loaded and is live.
    Loaded,
    /// A record was found and refused; the adapter runs uncalibrated (pass-through).
    Rejected(RecordProblem),
    /// The storage could not be read; the adapter runs uncalibrated.
    StorageError,
}

/// (Protocol 4.) Why a stored record was refused at boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RecordProblem {
    /// The record's length is not that of any known version.
    WrongLength,
    /// The record does not start with the record magic.
    BadMagic,
    /// A record version this firmware does not read.
    UnsupportedVersion(u16),
    /// The record's CRC-32 does not match its bytes (damaged).
    BadCrc,
    /// The record decodes to a calibration that is not usable (non-finite, singular).
    Invalid,
}

impl RecordProblem {
    /// Short English description, for the host's messages.
    pub const fn description(self) -> &'static str {
        match self {
            RecordProblem::WrongLength => "wrong length",
            RecordProblem::BadMagic => "not a calibration record",
            RecordProblem::UnsupportedVersion(_) => "unsupported record version",
            RecordProblem::BadCrc => "CRC mismatch: the record is damaged",
            RecordProblem::Invalid => "the calibration in it is unusable",
        }
    }
}

/// Wire mirror of [`wiical_core::Calibration`].
///
/// A separate type (rather than serializing the core type directly) so that refactoring
/// the core cannot silently change the wire format: only this file and [`crate::SCHEMA`]
/// define it. Same meaning as the core: `a = K·(m − b)`, `matrix` = `K` row-major
/// (reference units, g, per raw count), `bias` = `b` in raw counts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireCalibration {
    /// Bias `b`, raw units.
    pub bias: [f32; 3],
    /// `K = D⁻¹`, row-major.
    pub matrix: [[f32; 3]; 3],
    /// Extra effect terms (zero = linear model).
    pub effects: WireEffects,
}

/// Wire form of [`wiical_core::Effects`]: its coefficients in the order of the core's table
/// of effect terms (`wiical_core::terms::TERMS`; see there for names, shapes and units), as
/// a fixed-length tuple of `f32`. Postcard writes a tuple exactly as it wrote the struct of
/// named arrays this replaced (fields in order, no names, no lengths), so the bytes are the
/// same; the schema's `WireEffects` line is rendered from the same table
/// ([`crate::SCHEMA`]), so a new term changes the key with the layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireEffects(pub [f32; EFFECT_FLOATS]);

impl Default for WireEffects {
    fn default() -> Self {
        Self([0.0; EFFECT_FLOATS])
    }
}

impl Serialize for WireEffects {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(EFFECT_FLOATS)?;
        for x in &self.0 {
            t.serialize_element(x)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for WireEffects {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        /// Reads exactly [`EFFECT_FLOATS`] floats.
        struct Floats;
        impl<'de> serde::de::Visitor<'de> for Floats {
            type Value = WireEffects;
            fn expecting(&self, f: &mut core::fmt::Formatter) -> core::fmt::Result {
                write!(f, "{EFFECT_FLOATS} effect coefficients")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut a: A,
            ) -> Result<Self::Value, A::Error> {
                let mut out = [0f32; EFFECT_FLOATS];
                for (i, x) in out.iter_mut().enumerate() {
                    *x = a
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(WireEffects(out))
            }
        }
        d.deserialize_tuple(EFFECT_FLOATS, Floats)
    }
}

impl From<Effects> for WireEffects {
    fn from(e: Effects) -> Self {
        Self(e.coefficients())
    }
}

impl From<WireEffects> for Effects {
    fn from(e: WireEffects) -> Self {
        Effects::from_coefficients(&e.0)
    }
}

impl From<Calibration> for WireCalibration {
    fn from(c: Calibration) -> Self {
        Self {
            bias: c.bias,
            matrix: c.matrix,
            effects: c.effects.into(),
        }
    }
}

impl From<WireCalibration> for Calibration {
    /// Plain field copy. A calibration from the wire is untrusted: call
    /// [`Calibration::validate`] before using it.
    fn from(c: WireCalibration) -> Self {
        Self {
            bias: c.bias,
            matrix: c.matrix,
            effects: c.effects.into(),
        }
    }
}

/// (Protocol 7.) Wire form of the gyroscope calibration the adapter applies to the Wii
/// MotionPlus: `ω = K·(m − b)`, `m` the MotionPlus's **slow-range counts** (14-bit; the fast
/// range mapped onto the slow scale by the adapter's `GyroCorrector`), `ω` rad/s along the
/// MotionPlus's count axes (yaw, roll, pitch; positive where the counts rise), so that a
/// plausible `K` has a positive diagonal. The host turns a `gyrofit` file (rad/s in the
/// accelerometer's frame) into these axes before sending it (`wiical_analysis`'s
/// `output::gyrocal::for_motionplus`); the adapter re-encodes the corrected rates as counts at
/// its ideal scale.
///
/// The fields are the terms of the core's gyro table (`wiical_core::terms::GYRO_TERMS`) the
/// device applies: today only the linear part. The g-sensitivity (`G`, rad/s per g) needs the
/// accelerometer fixed to the gyro, which is in the Wii Remote and never seen by the adapter;
/// it stays in the host's file, and the schema's `WireGyroCalibration` line names it as
/// host-only ([`crate::SCHEMA`], rendered from the table). A gyro term a device could apply
/// would need a field here: a compile-time check refuses the table until it has one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WireGyroCalibration {
    /// Bias `b`, slow-range counts.
    pub bias: [f32; 3],
    /// `K`, rad/s per slow-range count, row-major (row = count axis yaw, roll, pitch).
    pub matrix: [[f32; 3]; 3],
}

/// Number of coefficients of the gyro terms a device applies (those of
/// [`wiical_core::terms::GYRO_TERMS`] with `device_applies`).
pub const GYRO_DEVICE_FLOATS: usize = {
    let t = &wiical_core::terms::GYRO_TERMS;
    let mut n = 0;
    let mut i = 0;
    while i < t.len() {
        if t[i].device_applies {
            n += t[i].len();
        }
        i += 1;
    }
    n
};

const _: () = assert!(
    GYRO_DEVICE_FLOATS == 0,
    "a gyro term the device applies needs its field in WireGyroCalibration (and its record)"
);

impl From<GyroCorrection<f32>> for WireGyroCalibration {
    /// The linear part; the host-only terms (g-sensitivity) are left out.
    fn from(c: GyroCorrection<f32>) -> Self {
        Self {
            bias: c.bias,
            matrix: c.matrix,
        }
    }
}

impl From<WireGyroCalibration> for GyroCorrection<f32> {
    /// Plain field copy with every effect term zero. Untrusted: judge it
    /// (`Acceptance::check_gyro`) before using it.
    fn from(c: WireGyroCalibration) -> Self {
        Self {
            bias: c.bias,
            matrix: c.matrix,
            effects: GyroEffects::default(),
        }
    }
}

/// (Protocol 7.) The gyro calibration state reported by
/// [`Request::GetGyroCalibration`](crate::Request::GetGyroCalibration).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GyroCalibrationState {
    /// The committed (stored) gyro calibration in force; `None`: none, the MotionPlus's
    /// rates pass through uncorrected.
    pub live: Option<WireGyroCalibration>,
    /// The staged gyro calibration awaiting commit, if any.
    pub staged: Option<WireGyroCalibration>,
    /// What the adapter found in storage at boot for the gyro record.
    pub boot: BootRecord,
}

/// One streamed sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Sequence number, +1 per sample sent (wrapping); gaps mean lost samples.
    pub seq: u32,
    /// Raw accelerometer `[x, y, z]`, 10-bit counts as the sensor reports them.
    pub raw: [u16; 3],
    /// `raw` corrected with the live calibration, in g.
    pub corrected: [f32; 3],
    /// Buttons, set bit = pressed: [`Sample::BUTTON_Z`], [`Sample::BUTTON_C`].
    pub buttons: u16,
    /// Joystick `[x, y]`, raw 8-bit.
    pub stick: [u8; 2],
}

impl Sample {
    /// Nunchuk Z button bit in [`Sample::buttons`].
    pub const BUTTON_Z: u16 = 1 << 0;
    /// Nunchuk C button bit in [`Sample::buttons`].
    pub const BUTTON_C: u16 = 1 << 1;
}

/// (Protocol 8.) One streamed MotionPlus sample: what the adapter's MotionPlus poller read and
/// what its corrector made of it (`wiical_adapter::motionplus::GyroCorrector`), sent in the
/// stream [`Request::StartStream`](crate::Request::StartStream) started, at its divider,
/// instead of [`Sample`]s while a MotionPlus is the extension served.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GyroSample {
    /// Sequence number, counted with [`Sample::seq`] (one stream): +1 per sample sent
    /// (wrapping); gaps mean lost samples.
    pub seq: u32,
    /// Raw 14-bit rates `[yaw, roll, pitch]` as the real MotionPlus reported them.
    pub raw: [u16; 3],
    /// Range bits of `raw`: bit `i` set = axis `i` in the slow (high-resolution) range
    /// ([`GyroSample::SLOW_YAW`], [`GyroSample::SLOW_ROLL`], [`GyroSample::SLOW_PITCH`]).
    pub slow: u8,
    /// `raw` corrected with the committed gyro calibration: rad/s along the count axes
    /// `[yaw, roll, pitch]` (positive where the counts rise), fast counts first mapped onto the
    /// slow scale with the device's block, the zero-rate tracker's bias in force, the
    /// g-sensitivity not applied. `None`: no gyro calibration committed (the rates pass
    /// through to the Wii Remote as they came).
    pub corrected: Option<[f32; 3]>,
}

impl GyroSample {
    /// Yaw in the slow range, in [`GyroSample::slow`].
    pub const SLOW_YAW: u8 = 1 << 0;
    /// Roll in the slow range.
    pub const SLOW_ROLL: u8 = 1 << 1;
    /// Pitch in the slow range.
    pub const SLOW_PITCH: u8 = 1 << 2;

    /// The range bits as `[yaw, roll, pitch]`.
    pub fn slow_axes(&self) -> [bool; 3] {
        core::array::from_fn(|i| self.slow >> i & 1 == 1)
    }
}

/// Capacity of [`SelfCalOutcome::Failed::message`], bytes of UTF-8.
pub const SELFCAL_MESSAGE_CAP: usize = 96;

/// The adapter's self-calibration progress, its last result and the stale-calibration
/// estimate (protocol 2; see `wiical_adapter::selfcal`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdapterStatus {
    /// What the status LED shows now.
    pub phase: SelfCalPhase,
    /// Poses taken in the current (or last) session.
    pub poses: u8,
    /// The last finished session, if any since boot.
    pub last_result: Option<SelfCalOutcome>,
    /// Still moments seen during play since the calibration last changed.
    pub stale_moments: u32,
    /// Running RMS of ‖a‖ − 1 g over those moments, mg.
    pub stale_rms_mg: f32,
    /// True when the adapter suggests recalibrating (RMS past its threshold).
    pub recalibration_suggested: bool,
}

/// Self-calibration phase (the status LED's pattern).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SelfCalPhase {
    /// Not in the mode.
    Off,
    /// C + Z held after plug-in; the mode starts when the hold completes.
    Arming,
    /// Hold still in a new orientation.
    WaitingForStillness,
    /// A pose was just taken.
    PoseTaken,
    /// That orientation was taken already: move to a new one.
    MoveToNewOrientation,
    /// Fitted and accepted; being stored.
    Committing,
    /// The session succeeded.
    Done,
    /// The session failed; the old calibration is kept.
    Failed,
}

/// Result of a finished self-calibration session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SelfCalOutcome {
    /// Stored and live.
    Done {
        /// Fit RMS of ‖a‖ − 1 g over the poses, mg.
        rms_mg: f32,
        /// Poses used.
        poses: u8,
    },
    /// Failed; the old calibration is unchanged.
    Failed {
        /// Why, in English (at most [`SELFCAL_MESSAGE_CAP`] bytes).
        message: heapless::String<SELFCAL_MESSAGE_CAP>,
    },
}

/// (Protocol 5.) Bins of the background recalibration's orientation grid (6 cube faces × 3 × 3
/// cells of ≈ 30°; [`crate::bins`] numbers them).
pub const BACKGROUND_BINS: usize = 54;

/// (Protocol 5; the budget and the fit interval since protocol 6.) The background
/// recalibration's settings, kept in the adapter's flash.
///
/// Times are of play (reports at the fixed poll rate: the adapter has no clock). The adapter
/// refuses values outside [`BackgroundSettings::COMMIT_INTERVAL_S`],
/// [`BackgroundSettings::COMMITS_PER_DAY`] and [`BackgroundSettings::FIT_INTERVAL_MS`] with
/// [`ErrorCode::InvalidParameter`]: the budget exists to bound flash wear.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct BackgroundSettings {
    /// Adopt better calibrations found during play (false: monitor only).
    pub adopt: bool,
    /// A calibration the host uploaded may be replaced by one found during play.
    pub replace_uploaded: bool,
    /// (Protocol 6.) Fewest seconds of play between two commits of adopted calibrations.
    pub commit_interval_s: u32,
    /// (Protocol 6.) Most commits per 24 h of play.
    pub commits_per_day: u8,
    /// (Protocol 6.) Milliseconds of play between two fit attempts (an attempt also needs
    /// new still moments since the last).
    pub fit_interval_ms: u32,
}

/// A field of [`BackgroundSettings`] outside its bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackgroundSettingsField {
    /// [`BackgroundSettings::commit_interval_s`].
    CommitInterval,
    /// [`BackgroundSettings::commits_per_day`].
    CommitsPerDay,
    /// [`BackgroundSettings::fit_interval_ms`].
    FitInterval,
}

impl BackgroundSettings {
    /// Bounds of [`BackgroundSettings::commit_interval_s`]: at least 10 s (a commit is a few
    /// hundred bytes of flash and about 0.7 M cycles outside the report path; the daily cap
    /// is what bounds wear), at most a week.
    pub const COMMIT_INTERVAL_S: core::ops::RangeInclusive<u32> = 10..=604_800;
    /// Bounds of [`BackgroundSettings::commits_per_day`]: 1 to the 16 commit times the
    /// adapter's budget record remembers (monitor only is `adopt: false`, not 0 commits).
    pub const COMMITS_PER_DAY: core::ops::RangeInclusive<u8> = 1..=16;
    /// Bounds of [`BackgroundSettings::fit_interval_ms`]: at least 0.5 s (a fit takes about
    /// 0.36 s of reports on the RP2040), at most an hour.
    pub const FIT_INTERVAL_MS: core::ops::RangeInclusive<u32> = 500..=3_600_000;

    /// The first field outside its bounds, if any.
    pub fn out_of_bounds(&self) -> Option<BackgroundSettingsField> {
        if !Self::COMMIT_INTERVAL_S.contains(&self.commit_interval_s) {
            Some(BackgroundSettingsField::CommitInterval)
        } else if !Self::COMMITS_PER_DAY.contains(&self.commits_per_day) {
            Some(BackgroundSettingsField::CommitsPerDay)
        } else if !Self::FIT_INTERVAL_MS.contains(&self.fit_interval_ms) {
            Some(BackgroundSettingsField::FitInterval)
        } else {
            None
        }
    }
}

/// (Protocol 5.) Who made the adapter's live calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CalibrationOrigin {
    /// No user calibration: the Nunchuk's own block (pass-through).
    Factory,
    /// The C + Z self-calibration on the adapter.
    SelfCal,
    /// Adopted by the background recalibration during play.
    Background,
    /// Uploaded by the host (or of unknown origin: treated as uploaded, the protected case).
    Host,
}

/// (Protocol 5.) What the background recalibration is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BackgroundPhase {
    /// Binning still moments.
    Collecting,
    /// A fit runs, one slice per report.
    Fitting,
    /// A calibration was adopted and is being stored.
    Committing,
    /// The detector refused its settings: nothing is binned.
    Invalid,
}

/// (Protocol 5.) Why the still moments do not yet cover the sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CoverageGapReport {
    /// Fewer fresh bins than the rule asks.
    TooFewBins {
        /// Needed.
        needed: u8,
        /// Present.
        got: u8,
    },
    /// No still moment pointed far enough along `±axis` (0 = x).
    MissingDirection {
        /// Axis, 0 = x.
        axis: u8,
        /// `true`: the `+axis` side is missing.
        positive: bool,
    },
    /// The directions are nearly in one plane.
    Flat,
    /// A direction was not finite.
    BadDirection,
}

/// (Protocol 5.) The latest candidate that passed the fit and the acceptance limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CandidateReport {
    /// Held-out RMS of ‖a‖ − 1 g under the candidate, mg.
    pub candidate_mg: f32,
    /// Held-out RMS under the live calibration, mg.
    pub live_mg: f32,
    /// Training RMS under the candidate, mg.
    pub fit_rms_mg: f32,
    /// The full 9-parameter model (false: bias and scale).
    pub full_model: bool,
    /// A bias-against-temperature slope was fitted.
    pub temperature: bool,
    /// Training bins.
    pub training_bins: u8,
    /// Held-out bins.
    pub heldout_bins: u8,
}

/// (Protocol 5.) The latest adoption.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AdoptionReport {
    /// Play time of the commit, s since power-up.
    pub at_s: u32,
    /// Held-out RMS before (the old live calibration), mg.
    pub before_mg: f32,
    /// Held-out RMS under the adopted one, mg.
    pub after_mg: f32,
}

/// (Protocol 5.) Why the last attempt did not adopt. Numbers in mg and seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum RefusalReport {
    /// The fresh bins do not cover the sphere.
    Coverage(CoverageGapReport),
    /// Too few held-out bins to judge a candidate.
    TooFewHeldOut {
        /// Needed.
        needed: u8,
        /// Present.
        got: u8,
    },
    /// The fit failed.
    Fit,
    /// The candidate failed the acceptance limits.
    Implausible,
    /// Not better than the live calibration by the margin.
    NotBetter {
        /// Candidate's held-out RMS, mg.
        candidate_mg: f32,
        /// Live calibration's held-out RMS, mg.
        live_mg: f32,
    },
    /// Better, but adoption is off.
    MonitorOnly {
        /// Candidate's held-out RMS, mg.
        candidate_mg: f32,
        /// Live calibration's held-out RMS, mg.
        live_mg: f32,
    },
    /// Better, but the live calibration was uploaded by the host and is protected.
    HostCalibration,
    /// Better, but the flash-write budget is spent for this long (s of play).
    Budget {
        /// Seconds of play until a commit is allowed.
        wait_s: u32,
    },
    /// The live calibration has terms the background fit cannot carry over.
    UnsupportedLive,
    /// The fit was interrupted (new calibration, unplug, self-calibration session).
    Interrupted,
    /// Storing the adopted calibration failed.
    Storage,
}

/// (Protocol 5.) The background recalibration's state: answer to
/// [`Request::GetBackgroundStatus`](crate::Request::GetBackgroundStatus).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BackgroundReport {
    /// What it is doing.
    pub phase: BackgroundPhase,
    /// The stored settings in force.
    pub settings: BackgroundSettings,
    /// Who made the live calibration.
    pub origin: CalibrationOrigin,
    /// Play time since power-up, s.
    pub play_s: u32,
    /// Still moments binned since power-up.
    pub moments: u32,
    /// Fresh bins (visited recently enough to enter a fit), of [`BACKGROUND_BINS`].
    pub bins_filled: u8,
    /// Bit `i` set: bin `i` is fresh.
    pub fresh_bins: u64,
    /// Still moments per bin, saturated at 255, in bin order ([`BACKGROUND_BINS`] entries).
    pub bin_moments: heapless::Vec<u8, BACKGROUND_BINS>,
    /// The board's temperature, °C, when it measures one.
    pub temperature_c: Option<f32>,
    /// The coverage gap at the last attempt (`None`: covered, or no attempt yet).
    pub coverage_gap: Option<CoverageGapReport>,
    /// The last candidate that passed the fit and the acceptance limits.
    pub candidate: Option<CandidateReport>,
    /// The last adoption since power-up.
    pub last_adoption: Option<AdoptionReport>,
    /// Why the last attempt did not adopt (`None` after an adoption or before any attempt).
    pub last_refusal: Option<RefusalReport>,
}
