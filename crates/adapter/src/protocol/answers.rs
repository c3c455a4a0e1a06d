//! The adapter's answer to each request of the wire protocol: one [`Answer`] per endpoint of
//! [`wiical_wire::endpoints`] (an [`AnswerAsync`] for the two that write the flash), returning
//! the typed reply or the error code the host gets.
//! [`wiical_wire::dispatch`] calls them (once [`Serve::admit`] has let the request through:
//! outside a session only `Hello`) and wraps the reply in its response, so an answer of the wrong kind
//! does not compile, and a request added to the protocol without its answer here does not
//! either ([`wiical_wire::Serve`]).

use embedded_storage_async::nor_flash::NorFlash;

#[cfg(feature = "gyro-calibration")]
use wiical_core::acceptance::Acceptance;
use wiical_core::acceptance::Rejection;
#[cfg(feature = "gyro-calibration")]
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;
use wiical_wire::endpoints::{
    CommitCalibration, CommitGyroCalibration, EndSession, GetBackgroundStatus, GetCalibration,
    GetGyroCalibration, GetStatus, Hello, PutCalibration, PutGyroCalibration, SetBackground,
    StartStream, StopStream,
};
use wiical_wire::{
    AdapterStatus, Answer, AnswerAsync, BackgroundReport, CalibrationState, ErrorCode,
    GyroCalibrationState, HelloResponse, Request, Serve, PROTOCOL_VERSION,
};

use super::recal::CommitError;
use super::{CorrectionMode, LiveOrigin, Protocol, Stream};

impl<F: NorFlash> Serve for Protocol<F> {
    /// Outside a session every request but `Hello` is refused (see the module docs of
    /// [`super`]).
    fn admit(&self, request: Request) -> Result<Request, ErrorCode> {
        if self.session_open || matches!(request, Request::Hello(_)) {
            Ok(request)
        } else {
            Err(ErrorCode::SchemaMismatch)
        }
    }
}

impl<F: NorFlash> Answer<Hello> for Protocol<F> {
    /// A new session, open when the keys match: the previous one's staged upload is not ours
    /// to commit. The stream keeps running (see the module docs).
    fn answer(&mut self, Hello(h): Hello) -> Result<HelloResponse, ErrorCode> {
        self.staged = None;
        self.gyro.staged = None;
        self.session_open = h.schema_key == self.schema_key;
        Ok(HelloResponse {
            protocol_version: PROTOCOL_VERSION,
            schema_key: self.schema_key,
            firmware_version: self.info.firmware_version.clone(),
            device_id: self.info.device_id,
        })
    }
}

impl<F: NorFlash> Answer<EndSession> for Protocol<F> {
    /// The host is leaving: its upload and session go with it (the stream is the port's and
    /// keeps running).
    fn answer(&mut self, _: EndSession) -> Result<(), ErrorCode> {
        self.session_open = false;
        self.staged = None;
        self.gyro.staged = None;
        Ok(())
    }
}

impl<F: NorFlash> Answer<GetCalibration> for Protocol<F> {
    fn answer(&mut self, _: GetCalibration) -> Result<CalibrationState, ErrorCode> {
        Ok(CalibrationState {
            live: self.corrector.live_calibration().into(),
            staged: self.staged.map(Into::into),
            stored: self.corrector.mode() == CorrectionMode::Calibrated,
            boot: self.boot.to_wire(),
            damaged_records: self.damaged_records,
        })
    }
}

impl<F: NorFlash> Answer<PutCalibration> for Protocol<F> {
    /// Staged when usable and plausible by the acceptance predicate; `Busy` while a C + Z
    /// session runs.
    fn answer(&mut self, PutCalibration(w): PutCalibration) -> Result<(), ErrorCode> {
        if self.selfcal.active() {
            return Err(ErrorCode::Busy);
        }
        let cal = Calibration::from(w);
        match self.acceptance.check(&cal, None) {
            Ok(()) => {
                self.staged = Some(cal);
                Ok(())
            }
            Err(Rejection::Unusable(_)) => Err(ErrorCode::InvalidCalibration),
            Err(_) => Err(ErrorCode::ImplausibleCalibration),
        }
    }
}

impl<F: NorFlash> AnswerAsync<CommitCalibration> for Protocol<F> {
    /// Stores the staged calibration (power-loss safe), reads it back, and only then makes
    /// it live; `Busy` while a C + Z session runs.
    async fn answer(&mut self, _: CommitCalibration) -> Result<(), ErrorCode> {
        if self.selfcal.active() {
            return Err(ErrorCode::Busy);
        }
        let cal = self.staged.ok_or(ErrorCode::NothingStaged)?;
        self.store_and_apply(cal, LiveOrigin::Host).await?;
        self.staged = None;
        Ok(())
    }
}

impl<F: NorFlash> Answer<GetStatus> for Protocol<F> {
    fn answer(&mut self, _: GetStatus) -> Result<AdapterStatus, ErrorCode> {
        Ok(self.adapter_status())
    }
}

impl<F: NorFlash> Answer<StartStream> for Protocol<F> {
    /// The sample rate in millihertz: the poll rate over the divider (0 is refused); `seq`
    /// restarts at 0.
    fn answer(&mut self, req: StartStream) -> Result<u32, ErrorCode> {
        if req.rate_divider == 0 {
            return Err(ErrorCode::InvalidParameter);
        }
        self.stream = Some(Stream {
            divider: req.rate_divider,
            phase: 0,
        });
        self.seq = 0;
        Ok(self.info.base_rate_mhz / u32::from(req.rate_divider))
    }
}

impl<F: NorFlash> Answer<StopStream> for Protocol<F> {
    fn answer(&mut self, _: StopStream) -> Result<(), ErrorCode> {
        self.stream = None;
        Ok(())
    }
}

impl<F: NorFlash> Answer<GetBackgroundStatus> for Protocol<F> {
    fn answer(&mut self, _: GetBackgroundStatus) -> Result<BackgroundReport, ErrorCode> {
        Ok(self.background_report())
    }
}

impl<F: NorFlash> AnswerAsync<SetBackground> for Protocol<F> {
    /// Stored and in force when within the protocol's bounds; `Busy` while a C + Z session
    /// runs.
    async fn answer(&mut self, SetBackground(b): SetBackground) -> Result<(), ErrorCode> {
        if self.selfcal.active() {
            return Err(ErrorCode::Busy);
        }
        self.set_background(&b).await.map_err(|e| match e {
            CommitError::OutOfBounds => ErrorCode::InvalidParameter,
            _ => ErrorCode::StorageFailure,
        })
    }
}

#[cfg(feature = "gyro-calibration")]
impl<F: NorFlash> Answer<GetGyroCalibration> for Protocol<F> {
    fn answer(&mut self, _: GetGyroCalibration) -> Result<GyroCalibrationState, ErrorCode> {
        Ok(GyroCalibrationState {
            live: self.gyro.live.map(Into::into),
            staged: self.gyro.staged.map(Into::into),
            boot: self.gyro.boot.to_wire(),
        })
    }
}

#[cfg(feature = "gyro-calibration")]
impl<F: NorFlash> Answer<PutGyroCalibration> for Protocol<F> {
    /// Staged when usable and plausible for a MotionPlus (`Acceptance::check_gyro`); the
    /// staged and live ones are unchanged otherwise.
    fn answer(&mut self, PutGyroCalibration(w): PutGyroCalibration) -> Result<(), ErrorCode> {
        let cal = GyroCorrection::from(w);
        match Acceptance::motionplus().check_gyro(&cal) {
            Ok(()) => {
                self.gyro.staged = Some(cal);
                Ok(())
            }
            Err(Rejection::Unusable(_)) => Err(ErrorCode::InvalidCalibration),
            Err(_) => Err(ErrorCode::ImplausibleCalibration),
        }
    }
}

#[cfg(feature = "gyro-calibration")]
impl<F: NorFlash> AnswerAsync<CommitGyroCalibration> for Protocol<F> {
    /// Stores the staged gyro calibration (power-loss safe), reads it back, and only then
    /// makes it live; a storage failure or a read-back that differs keeps the old one live
    /// and the upload staged.
    async fn answer(&mut self, _: CommitGyroCalibration) -> Result<(), ErrorCode> {
        let cal = self.gyro.staged.ok_or(ErrorCode::NothingStaged)?;
        self.store
            .save_gyro(&cal)
            .await
            .map_err(|_| ErrorCode::StorageFailure)?;
        match self.store.load_gyro().await {
            Ok(crate::store::LoadedGyro::Calibration(back)) if back.bits() == cal.bits() => {}
            _ => return Err(ErrorCode::StorageFailure),
        }
        self.gyro.live = Some(cal);
        self.gyro.staged = None;
        #[cfg(feature = "motionplus")]
        self.install_gyro();
        Ok(())
    }
}

// Without the `gyro-calibration` feature (the RP2040 firmware: its flash budget) the three
// gyro requests are refused, and none of their code is linked.
#[cfg(not(feature = "gyro-calibration"))]
impl<F: NorFlash> Answer<GetGyroCalibration> for Protocol<F> {
    fn answer(&mut self, _: GetGyroCalibration) -> Result<GyroCalibrationState, ErrorCode> {
        Err(ErrorCode::UnsupportedRequest)
    }
}

#[cfg(not(feature = "gyro-calibration"))]
impl<F: NorFlash> Answer<PutGyroCalibration> for Protocol<F> {
    fn answer(&mut self, _: PutGyroCalibration) -> Result<(), ErrorCode> {
        Err(ErrorCode::UnsupportedRequest)
    }
}

#[cfg(not(feature = "gyro-calibration"))]
impl<F: NorFlash> AnswerAsync<CommitGyroCalibration> for Protocol<F> {
    async fn answer(&mut self, _: CommitGyroCalibration) -> Result<(), ErrorCode> {
        Err(ErrorCode::UnsupportedRequest)
    }
}
