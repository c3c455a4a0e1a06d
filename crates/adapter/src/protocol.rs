//! The adapter's side of the wire protocol, and the glue between the poller, the corrector,
//! the emulated register map and the calibration store.
//!
//! Data flow per Nunchuk report (call [`Protocol::on_poll`] with every poll result):
//!
//! ```text
//! NunchukPoller ──report──▶ Corrector ──counts──▶ EmulatedNunchuk ◀── Wii Remote (I²C target)
//!                               └──────g──────▶ Sample (when streaming) ──▶ host (serial)
//! ```
//!
//! Requests ([`Protocol::handle`]): `Hello` opens the session only when the schema keys
//! match (every other request is refused with `SchemaMismatch` until then); `PutCalibration`
//! stages a calibration that is usable (`InvalidCalibration` otherwise) and plausible by the
//! core's acceptance predicate ([`wiical_core::acceptance::Acceptance`], Nunchuk limits;
//! `ImplausibleCalibration` otherwise — in both cases the staged and live calibrations are
//! unchanged); `CommitCalibration` stores it (power-loss safe), reads it back, and only then
//! makes it live; `StartStream`/`StopStream` control the sample stream (rate = poll rate /
//! divider, `seq` restarting at 0 and +1 per sample sent); `GetStatus` reports the
//! self-calibration ([`crate::selfcal`]) and the stale-calibration estimate.
//!
//! ## Sessions
//! A session lasts from a `Hello` to the next `Hello`, to `EndSession` (the host ends it
//! before closing the port: the session belongs to the host that said Hello, not to the
//! port, which other processes may hold open) or to [`Protocol::reset_session`] (port
//! closed: the USB link went down, or the host hung up — DTR cleared when the last process
//! holding the port closed it, also when it was killed before its `EndSession`). Outside a session every request but `Hello` is refused (`SchemaMismatch`), so
//! each opener needs its own Hello. **A staged calibration belongs to the session that staged it**: a new
//! `Hello` or the end of the session discards it, so a later client's `CommitCalibration`
//! can never commit someone else's upload (it gets `NothingStaged`); a host uploads and
//! commits within one session. **A `Hello` does not stop a running stream**: the stream is
//! the port's, not the session's (a second client asking for `info` must not cut a
//! recording short); it stops with `StopStream` or when the port closes. While a
//! self-calibration session runs on the adapter, `PutCalibration` and `CommitCalibration`
//! answer `Busy`.
//!
//! ## The MotionPlus's gyro calibration (protocol 7)
//! `PutGyroCalibration` stages a gyro calibration judged by the core's MotionPlus limits
//! ([`Acceptance::motionplus`], [`Acceptance::check_gyro`]; `InvalidCalibration` or
//! `ImplausibleCalibration` otherwise, nothing changed), `CommitGyroCalibration` stores it
//! beside the accelerometer's (the store's gyro record, power-loss safe), reads it back and
//! only then makes it live, `GetGyroCalibration` reports live, staged and what was found at
//! boot. A staged gyro calibration belongs to its session as the accelerometer's does. The
//! live one is installed in the MotionPlus's corrector at boot and after every commit
//! ([`Protocol::motionplus`]; the `extension` child module serves the MotionPlus).
//! Without the crate's `gyro-calibration` feature (default on; the RP2040 firmware leaves it
//! out for its flash budget) the three requests answer `UnsupportedRequest`.
//!
//! ## Background recalibration (protocol 5)
//! Every report outside a C + Z session also ticks the background recalibration
//! ([`crate::background`], wired in the `recal` child module); `GetBackgroundStatus` reports
//! it and `SetBackground` stores its settings beside the calibration
//! ([`crate::settings`]).

mod answers;
#[cfg(feature = "motionplus")]
mod extension;
mod recal;
mod recal_wire;

use core::fmt::Write as _;
use core::future::Future;
use embedded_storage_async::nor_flash::NorFlash;

use wiical_core::acceptance::Acceptance;
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;
use wiical_extbus::NunchukReport;
use wiical_wire::{
    AdapterStatus, BootRecord, ErrorCode, FrameError, RecordProblem, Request, Response, Sample,
    SelfCalOutcome, SelfCalPhase, FIRMWARE_VERSION_CAP, SCHEMA_KEY,
};

use crate::background::{Background, LiveOrigin};
use crate::corrector::{CorrectionMode, Corrector, IdealScale};
use crate::emulated::EmulatedNunchuk;
use crate::error::{Error, RecordError};
#[cfg(feature = "motionplus")]
use crate::extension::Extension;
#[cfg(feature = "motionplus")]
use crate::motionplus::{EmulatedMotionPlus, GyroCorrector};
use crate::poller::{NunchukInfo, PollEvent};
use crate::selfcal::{SelfCal, SelfCalConfig, SelfCalResult, SelfCalStatus};
use crate::settings::StoredSettings;
use crate::store::{CalibrationStore, Loaded};

/// Identity and timing of the adapter, reported in the Hello exchange.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfo {
    /// Firmware version string (truncated to [`FIRMWARE_VERSION_CAP`] bytes on the wire).
    pub firmware_version: heapless::String<FIRMWARE_VERSION_CAP>,
    /// Unique device ID (MCU or flash unique ID).
    pub device_id: [u8; 8],
    /// Report poll rate in millihertz: the sample rate with divider 1.
    pub base_rate_mhz: u32,
}

impl DeviceInfo {
    /// Info with `version` truncated to fit (at a character boundary).
    pub fn new(version: &str, device_id: [u8; 8], base_rate_mhz: u32) -> Self {
        let mut firmware_version = heapless::String::new();
        for ch in version.chars() {
            if firmware_version.push(ch).is_err() {
                break;
            }
        }
        Self {
            firmware_version,
            device_id,
            base_rate_mhz,
        }
    }
}

/// What happened to the stored calibration at boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BootLoad {
    /// Nothing stored: pass-through.
    Empty,
    /// A valid stored calibration is live.
    Loaded,
    /// A record was found but refused (damaged, unknown version, invalid): pass-through.
    Rejected(RecordError),
    /// The flash could not be read: pass-through.
    StorageError,
}

impl BootLoad {
    /// The wire form reported in `GetCalibration`, so that a host can tell a refused record
    /// from an empty store.
    pub fn to_wire(self) -> BootRecord {
        match self {
            BootLoad::Empty => BootRecord::Empty,
            BootLoad::Loaded => BootRecord::Loaded,
            BootLoad::StorageError => BootRecord::StorageError,
            BootLoad::Rejected(e) => BootRecord::Rejected(match e {
                RecordError::WrongLength(_) => RecordProblem::WrongLength,
                RecordError::BadMagic => RecordProblem::BadMagic,
                RecordError::UnsupportedVersion(v) => RecordProblem::UnsupportedVersion(v),
                RecordError::BadCrc => RecordProblem::BadCrc,
                RecordError::Invalid(_) => RecordProblem::Invalid,
            }),
        }
    }
}

/// A snapshot of the adapter's state, for a status LED or log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// A Nunchuk is connected and answering.
    pub connected: bool,
    /// Calibrated or pass-through (uncalibrated, or the stored record was unusable).
    pub mode: CorrectionMode,
    /// Outcome of loading the stored calibration at boot.
    pub boot: BootLoad,
    /// A host session is open (good Hello received).
    pub session_open: bool,
    /// Samples are being streamed.
    pub streaming: bool,
    /// A calibration is staged, awaiting commit.
    pub staged: bool,
    /// Damaged or interrupted records found in storage at boot (and skipped).
    pub damaged_records: u16,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stream {
    divider: u16,
    phase: u16,
}

/// The protocol handler and glue; see the module docs.
pub struct Protocol<F: NorFlash> {
    info: DeviceInfo,
    schema_key: u32,
    session_open: bool,
    staged: Option<Calibration>,
    stream: Option<Stream>,
    seq: u32,
    connected: bool,
    store: CalibrationStore<F>,
    corrector: Corrector,
    emulated: EmulatedNunchuk,
    boot: BootLoad,
    damaged_records: u16,
    block_generation: u32,
    acceptance: Acceptance,
    selfcal: SelfCal,
    background: Background,
    settings: StoredSettings,
    gyro: GyroState,
    /// The extension presented to the Wii Remote.
    #[cfg(feature = "motionplus")]
    extension: Extension,
    /// The emulated MotionPlus (its corrector holds the live gyro calibration).
    #[cfg(feature = "motionplus")]
    motionplus: EmulatedMotionPlus,
    /// The stream's sample of the last MotionPlus gyro frame, until taken
    /// ([`Protocol::take_gyro_sample`]; protocol 8).
    #[cfg(feature = "motionplus")]
    gyro_sample: Option<wiical_wire::GyroSample>,
}

/// The MotionPlus's gyro calibration as the protocol keeps it (protocol 7).
// Without the `gyro-calibration` feature nothing is ever staged.
#[cfg_attr(not(feature = "gyro-calibration"), allow(dead_code))]
struct GyroState {
    /// The committed one in force (`None`: the rates pass through uncorrected).
    live: Option<GyroCorrection<f32>>,
    /// Staged by this session, awaiting commit.
    staged: Option<GyroCorrection<f32>>,
    /// What the store held at boot.
    boot: BootLoad,
}

impl GyroState {
    /// Reads the stored gyro record and judges it again with the MotionPlus limits: a
    /// damaged, unknown or implausible record leaves no gyro calibration.
    #[cfg(feature = "gyro-calibration")]
    async fn boot<F: NorFlash>(store: &mut CalibrationStore<F>) -> Self {
        use crate::store::LoadedGyro;
        let (live, boot) = match store.load_gyro().await {
            Ok(LoadedGyro::Empty) => (None, BootLoad::Empty),
            Ok(LoadedGyro::Calibration(cal)) => match Acceptance::motionplus().check_gyro(&cal) {
                Ok(()) => (Some(cal), BootLoad::Loaded),
                Err(_) => (
                    None,
                    BootLoad::Rejected(RecordError::Invalid(wiical_core::Error::InvalidParameter)),
                ),
            },
            Ok(LoadedGyro::Rejected(e)) => (None, BootLoad::Rejected(e)),
            Err(_) => (None, BootLoad::StorageError),
        };
        Self {
            live,
            staged: None,
            boot,
        }
    }

    /// Without the `gyro-calibration` feature: no gyro calibration, the record not read.
    #[cfg(not(feature = "gyro-calibration"))]
    async fn boot<F: NorFlash>(_: &mut CalibrationStore<F>) -> Self {
        Self {
            live: None,
            staged: None,
            boot: BootLoad::Empty,
        }
    }
}

impl<F: NorFlash> Protocol<F> {
    /// Start the adapter: load the stored calibration (a missing, damaged or unreadable one
    /// means pass-through) and prepare the emulated register map.
    pub async fn boot(mut store: CalibrationStore<F>, info: DeviceInfo, scale: IdealScale) -> Self {
        let mut corrector = Corrector::new(scale);
        let boot = match store.load().await {
            Ok(Loaded::Empty) => BootLoad::Empty,
            Ok(Loaded::Calibration(cal)) => match corrector.set_user_calibration(Some(cal)) {
                Ok(()) => BootLoad::Loaded,
                Err(e) => BootLoad::Rejected(RecordError::Invalid(e)),
            },
            Ok(Loaded::Rejected(e)) => BootLoad::Rejected(e),
            Err(_) => BootLoad::StorageError,
        };
        // Told to the host: a damaged newest record is skipped by the storage layer
        // without a word, and the previous one loaded as if it were the newest.
        let damaged_records = store.damaged_records().await.unwrap_or(0);
        // A missing or damaged settings record: the defaults (a stored calibration of
        // unknown origin counts as the host's, the protected case).
        let settings = store
            .load_settings()
            .await
            .ok()
            .flatten()
            .unwrap_or_default();
        let origin = match boot {
            BootLoad::Loaded => settings.origin,
            _ => LiveOrigin::Factory,
        };
        let gyro = GyroState::boot(&mut store).await;
        let emulated = EmulatedNunchuk::new(&corrector.calibration_block_bytes());
        let rate_hz = info.base_rate_mhz / 1000;
        #[cfg_attr(not(feature = "motionplus"), allow(unused_mut))]
        let mut proto = Self {
            info,
            schema_key: SCHEMA_KEY,
            session_open: false,
            staged: None,
            stream: None,
            seq: 0,
            connected: false,
            store,
            corrector,
            emulated,
            boot,
            damaged_records,
            block_generation: 0,
            acceptance: Acceptance::nunchuk(),
            selfcal: SelfCal::new(SelfCalConfig::nunchuk(rate_hz)),
            background: recal::background_for(rate_hz, &settings, origin),
            settings,
            gyro,
            #[cfg(feature = "motionplus")]
            extension: Extension::Nunchuk,
            #[cfg(feature = "motionplus")]
            motionplus: EmulatedMotionPlus::new(GyroCorrector::default()),
            #[cfg(feature = "motionplus")]
            gyro_sample: None,
        };
        #[cfg(feature = "motionplus")]
        proto.install_gyro();
        proto
    }

    /// Use other self-calibration settings (tests, other sensors). Also sets the
    /// acceptance limits for uploads to the self-calibration's.
    pub fn with_selfcal_config(mut self, cfg: SelfCalConfig) -> Self {
        self.acceptance = cfg.acceptance;
        self.selfcal = SelfCal::new(cfg);
        self
    }

    /// Present a different schema key in Hello (simulators and tests of the mismatch path
    /// only; a real firmware always uses [`SCHEMA_KEY`]).
    pub fn with_schema_key(mut self, key: u32) -> Self {
        self.schema_key = key;
        self
    }

    /// Answer one request: outside a session only `Hello` (see the module docs); each by
    /// its endpoint's [`wiical_wire::Answer`] (in the `answers` child module), whose typed
    /// reply [`wiical_wire::dispatch`] wraps in its response.
    // Not an `async fn`: one would hold `req` beside the dispatch future that holds it too
    // (288 B more of the serial task's static RAM).
    pub fn handle(&mut self, req: Request) -> impl Future<Output = Response> + '_ {
        wiical_wire::dispatch(self, req)
    }

    /// Store `cal` (power-loss safe) with its origin, read it back, and only then make it
    /// live; the background recalibration starts over from the new calibration.
    async fn store_and_apply(
        &mut self,
        cal: Calibration,
        origin: LiveOrigin,
    ) -> Result<(), ErrorCode> {
        let stored = self.store_with_origin(cal, origin).await;
        if stored.is_ok() {
            self.background.calibration_changed(origin);
        }
        stored.map_err(|e| match e {
            recal::CommitError::Storage => ErrorCode::StorageFailure,
            recal::CommitError::Internal => ErrorCode::Internal,
            recal::CommitError::OutOfBounds => ErrorCode::InvalidParameter,
        })
    }

    /// Finish what the report path cannot do synchronously: commit a self-calibration that
    /// passed its checks, or a calibration the background recalibration adopted. Call after
    /// every [`Protocol::on_poll`] (cheap when idle). A storage failure keeps the old
    /// calibration (and ends a self-calibration session as failed).
    pub async fn service(&mut self) {
        if let Some((cal, rms)) = self.selfcal.take_pending() {
            let stored = self.store_and_apply(cal, LiveOrigin::SelfCal).await;
            self.selfcal.committed(stored.map(|()| rms).map_err(|_| ()));
        }
        self.service_background().await;
    }

    /// The self-calibration state machine (LED status, last result, stale estimate).
    pub fn selfcal(&self) -> &SelfCal {
        &self.selfcal
    }

    /// The wire form of the self-calibration and stale-monitor state.
    pub fn adapter_status(&self) -> AdapterStatus {
        let (phase, poses) = match self.selfcal.status() {
            SelfCalStatus::Off => (SelfCalPhase::Off, 0),
            SelfCalStatus::Arming => (SelfCalPhase::Arming, 0),
            SelfCalStatus::WaitingForStillness { poses } => {
                (SelfCalPhase::WaitingForStillness, poses)
            }
            SelfCalStatus::PoseTaken { poses } => (SelfCalPhase::PoseTaken, poses),
            SelfCalStatus::MoveToNewOrientation { poses } => {
                (SelfCalPhase::MoveToNewOrientation, poses)
            }
            SelfCalStatus::Committing => (SelfCalPhase::Committing, 0),
            SelfCalStatus::Done => (SelfCalPhase::Done, 0),
            SelfCalStatus::Failed(_) => (SelfCalPhase::Failed, 0),
        };
        let poses = if poses == 0 {
            self.selfcal.poses().len() as u8
        } else {
            poses
        };
        let last_result = self.selfcal.last_result().map(|r| match r {
            SelfCalResult::Done { rms_g, poses } => SelfCalOutcome::Done {
                rms_mg: rms_g * 1000.0,
                poses,
            },
            SelfCalResult::Failed(why) => {
                let mut message = heapless::String::new();
                // Truncated at the capacity: the message is for people.
                let _ = TruncatingWriter(&mut message).write_str(why.summary());
                SelfCalOutcome::Failed { message }
            }
        });
        let stale = self.selfcal.stale();
        AdapterStatus {
            phase,
            poses,
            last_result,
            stale_moments: stale.moments,
            stale_rms_mg: stale.rms_g * 1000.0,
            recalibration_suggested: stale.recalibration_suggested,
        }
    }

    /// The answer to a frame that could not be decoded.
    pub fn bad_frame(&mut self, _e: FrameError) -> Response {
        Response::Error(ErrorCode::BadFrame)
    }

    /// The host went away (USB link down, or a hang-up: DTR cleared, the simulator's pty
    /// closed by its last holder): close the session, stop the stream and discard the staged
    /// calibration (it belonged to that session; a host killed before its `EndSession` must
    /// not leave it for the next opener).
    pub fn reset_session(&mut self) {
        self.session_open = false;
        self.stream = None;
        self.staged = None;
        self.gyro.staged = None;
        #[cfg(feature = "motionplus")]
        {
            self.gyro_sample = None;
        }
    }

    /// Feed one poll result. `still_connected` is
    /// [`crate::NunchukPoller::is_connected`] after the poll. Returns the sample to send
    /// when streaming.
    pub fn on_poll<E>(
        &mut self,
        result: &Result<PollEvent, Error<E>>,
        still_connected: bool,
    ) -> Option<Sample> {
        match result {
            Ok(PollEvent::Connected(info)) => {
                self.on_connected(info);
                None
            }
            Ok(PollEvent::Report(r)) => self.on_report(r),
            Ok(PollEvent::Idle) | Err(_) => {
                if !still_connected && self.connected {
                    self.on_disconnected();
                }
                None
            }
        }
    }

    /// A Nunchuk was (re)initialised: take its factory block.
    pub fn on_connected(&mut self, info: &NunchukInfo) {
        self.connected = true;
        self.selfcal.on_plug_in();
        self.background.on_plug_in(info.calibration_bytes);
        self.corrector.set_factory(info);
        self.refresh_block();
    }

    /// The Nunchuk is gone. The emulated map keeps its last report (the firmware may also
    /// release the extension-detect line).
    pub fn on_disconnected(&mut self) {
        self.connected = false;
        self.selfcal.on_unplug();
        self.background.on_unplug();
    }

    /// Correct a report, update the emulated register map, and return the sample to send
    /// if streaming (every `rate_divider`-th report).
    pub fn on_report(&mut self, report: &NunchukReport) -> Option<Sample> {
        let live = self.corrector.live_calibration();
        self.selfcal
            .on_report(report.accel, report.c, report.z, &live);
        self.tick_background(&live);
        let c = self.corrector.correct(report.accel);
        self.emulated.set_report(&NunchukReport {
            accel: c.counts,
            ..*report
        });
        let seq = self.stream_seq()?;
        let mut buttons = 0;
        if report.z {
            buttons |= Sample::BUTTON_Z;
        }
        if report.c {
            buttons |= Sample::BUTTON_C;
        }
        Some(Sample {
            seq,
            raw: report.accel,
            corrected: c.g,
            buttons,
            stick: report.stick,
        })
    }

    /// The sequence number of the stream's next sample when this report is one to send (every
    /// `rate_divider`-th while streaming), `None` otherwise.
    fn stream_seq(&mut self) -> Option<u32> {
        let stream = self.stream.as_mut()?;
        let send = stream.phase == 0;
        stream.phase = (stream.phase + 1) % stream.divider.max(1);
        if !send {
            return None;
        }
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        Some(seq)
    }

    fn refresh_block(&mut self) {
        let bytes = self.corrector.calibration_block_bytes();
        let current: [u8; 16] = core::array::from_fn(|i| {
            self.emulated
                .registers()
                .register(wiical_extbus::nunchuk::CALIBRATION_REGISTER + i as u8)
        });
        if current != bytes {
            self.emulated.set_calibration_bytes(&bytes);
            self.block_generation = self.block_generation.wrapping_add(1);
        }
    }

    /// Incremented whenever the emulated calibration block changes (commit, Nunchuk with a
    /// different block plugged in). The Wii Remote reads the block only when an extension
    /// is inserted, so on a change the firmware should pulse the extension-detect line to
    /// make it re-read; until then it converts the new counts with the old block.
    pub fn block_generation(&self) -> u32 {
        self.block_generation
    }

    /// The emulated register map, for the I²C-target side.
    pub fn emulated(&mut self) -> &mut EmulatedNunchuk {
        &mut self.emulated
    }

    /// The corrector (live calibration, mode).
    pub fn corrector(&self) -> &Corrector {
        &self.corrector
    }

    /// The staged calibration, if any.
    pub fn staged(&self) -> Option<&Calibration> {
        self.staged.as_ref()
    }

    /// The committed gyro calibration in force (installed in the MotionPlus's corrector,
    /// [`Protocol::motionplus`]); `None`: the rates pass through.
    pub fn gyro_calibration(&self) -> Option<&GyroCorrection<f32>> {
        self.gyro.live.as_ref()
    }

    /// What the store held for the gyro record at boot.
    pub fn gyro_boot(&self) -> BootLoad {
        self.gyro.boot
    }

    /// State snapshot.
    pub fn status(&self) -> Status {
        Status {
            connected: self.connected,
            mode: self.corrector.mode(),
            boot: self.boot,
            session_open: self.session_open,
            streaming: self.stream.is_some(),
            staged: self.staged.is_some(),
            damaged_records: self.damaged_records,
        }
    }
}

/// Bitwise equality of every parameter (so that `-0.0 ≠ 0.0` and NaN payloads count): the
/// core's canonical bit encoding ([`Calibration::bits_equal`]).
pub fn bits_equal(a: &Calibration, b: &Calibration) -> bool {
    a.bits_equal(b)
}

/// `fmt::Write` into a bounded string that drops what does not fit (at a char boundary).
struct TruncatingWriter<'a, const N: usize>(&'a mut heapless::String<N>);

impl<const N: usize> core::fmt::Write for TruncatingWriter<'_, N> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for ch in s.chars() {
            if self.0.push(ch).is_err() {
                break;
            }
        }
        Ok(())
    }
}
