//! Which [`Response`] answers which [`Request`]: the pairing lives here, beside the messages,
//! so that host and adapter cannot disagree about it (postcard-rpc keeps it in the shared
//! crate for the same reason).
//!
//! Each request kind is an [`Endpoint`]: a type that builds its [`Request`] and takes its
//! typed reply out of a [`Response`]. A client writes `device.call(GetCalibration)` and gets a
//! [`CalibrationState`] back; a late answer to another request, or an answer of the wrong
//! kind, is recognised by [`Request::is_answered_by`] instead of a hand-written table.

use crate::messages::{
    AdapterStatus, BackgroundReport, BackgroundSettings, CalibrationState, Hello, HelloResponse,
    Request, Response, WireCalibration,
};

/// A request kind and the reply it gets.
pub trait Endpoint {
    /// The request's name in messages (the `Request` variant's name).
    const NAME: &'static str;
    /// What a successful answer carries (`()` for a bare [`Response::Ack`]).
    type Reply;
    /// The request to send.
    fn request(&self) -> Request;
    /// The typed reply out of a successful answer; `None` when the answer is of another
    /// kind (an [`Response::Error`] included: the caller decides what an error means).
    fn reply(response: &Response) -> Option<Self::Reply>;
}

/// [`Request::GetCalibration`] → [`CalibrationState`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GetCalibration;

/// [`Request::PutCalibration`] → `()` ([`Response::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PutCalibration(pub WireCalibration);

/// [`Request::CommitCalibration`] → `()` ([`Response::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommitCalibration;

/// [`Request::StartStream`] → the stream's sample rate in millihertz.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartStream {
    /// Base-rate divider, ≥ 1.
    pub rate_divider: u16,
}

/// [`Request::StopStream`] → `()` ([`Response::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StopStream;

/// [`Request::GetStatus`] → [`AdapterStatus`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GetStatus;

/// [`Request::EndSession`] → `()` ([`Response::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EndSession;

/// (Protocol 5.) [`Request::GetBackgroundStatus`] → [`BackgroundReport`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GetBackgroundStatus;

/// (Protocol 5.) [`Request::SetBackground`] → `()` ([`Response::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SetBackground(pub BackgroundSettings);

impl Endpoint for Hello {
    const NAME: &'static str = "Hello";
    type Reply = HelloResponse;
    fn request(&self) -> Request {
        Request::Hello(*self)
    }
    fn reply(response: &Response) -> Option<HelloResponse> {
        match response {
            Response::Hello(h) => Some(h.clone()),
            _ => None,
        }
    }
}

impl Endpoint for GetCalibration {
    const NAME: &'static str = "GetCalibration";
    type Reply = CalibrationState;
    fn request(&self) -> Request {
        Request::GetCalibration
    }
    fn reply(response: &Response) -> Option<CalibrationState> {
        match response {
            Response::Calibration(s) => Some(*s),
            _ => None,
        }
    }
}

/// `Some(())` for [`Response::Ack`].
fn ack(response: &Response) -> Option<()> {
    match response {
        Response::Ack => Some(()),
        _ => None,
    }
}

impl Endpoint for PutCalibration {
    const NAME: &'static str = "PutCalibration";
    type Reply = ();
    fn request(&self) -> Request {
        Request::PutCalibration(self.0)
    }
    fn reply(response: &Response) -> Option<()> {
        ack(response)
    }
}

impl Endpoint for CommitCalibration {
    const NAME: &'static str = "CommitCalibration";
    type Reply = ();
    fn request(&self) -> Request {
        Request::CommitCalibration
    }
    fn reply(response: &Response) -> Option<()> {
        ack(response)
    }
}

impl Endpoint for StartStream {
    const NAME: &'static str = "StartStream";
    type Reply = u32;
    fn request(&self) -> Request {
        Request::StartStream {
            rate_divider: self.rate_divider,
        }
    }
    fn reply(response: &Response) -> Option<u32> {
        match response {
            Response::StreamStarted { sample_rate_mhz } => Some(*sample_rate_mhz),
            _ => None,
        }
    }
}

impl Endpoint for StopStream {
    const NAME: &'static str = "StopStream";
    type Reply = ();
    fn request(&self) -> Request {
        Request::StopStream
    }
    fn reply(response: &Response) -> Option<()> {
        ack(response)
    }
}

impl Endpoint for GetStatus {
    const NAME: &'static str = "GetStatus";
    type Reply = AdapterStatus;
    fn request(&self) -> Request {
        Request::GetStatus
    }
    fn reply(response: &Response) -> Option<AdapterStatus> {
        match response {
            Response::Status(s) => Some(s.clone()),
            _ => None,
        }
    }
}

impl Endpoint for EndSession {
    const NAME: &'static str = "EndSession";
    type Reply = ();
    fn request(&self) -> Request {
        Request::EndSession
    }
    fn reply(response: &Response) -> Option<()> {
        ack(response)
    }
}

impl Endpoint for GetBackgroundStatus {
    const NAME: &'static str = "GetBackgroundStatus";
    type Reply = BackgroundReport;
    fn request(&self) -> Request {
        Request::GetBackgroundStatus
    }
    fn reply(response: &Response) -> Option<BackgroundReport> {
        match response {
            Response::Background(b) => Some(b.clone()),
            _ => None,
        }
    }
}

impl Endpoint for SetBackground {
    const NAME: &'static str = "SetBackground";
    type Reply = ();
    fn request(&self) -> Request {
        Request::SetBackground(self.0)
    }
    fn reply(response: &Response) -> Option<()> {
        ack(response)
    }
}

impl Request {
    /// The request's name (its [`Endpoint::NAME`]), for messages.
    pub const fn name(&self) -> &'static str {
        match self {
            Request::Hello(_) => Hello::NAME,
            Request::GetCalibration => GetCalibration::NAME,
            Request::PutCalibration(_) => PutCalibration::NAME,
            Request::CommitCalibration => CommitCalibration::NAME,
            Request::StartStream { .. } => StartStream::NAME,
            Request::StopStream => StopStream::NAME,
            Request::GetStatus => GetStatus::NAME,
            Request::EndSession => EndSession::NAME,
            Request::GetBackgroundStatus => GetBackgroundStatus::NAME,
            Request::SetBackground(_) => SetBackground::NAME,
        }
    }

    /// True when `response` is an answer this request can get: its endpoint's reply, or an
    /// [`Response::Error`] (except for `Hello`, which the adapter always answers with
    /// [`Response::Hello`]). A streamed [`Response::Sample`] answers nothing.
    pub fn is_answered_by(&self, response: &Response) -> bool {
        if matches!(response, Response::Error(_)) {
            return !matches!(self, Request::Hello(_));
        }
        // The endpoints' own `reply` decides, so the pairing is written once.
        let r = response;
        match self {
            Request::Hello(_) => Hello::reply(r).is_some(),
            Request::GetCalibration => GetCalibration::reply(r).is_some(),
            Request::PutCalibration(_) => PutCalibration::reply(r).is_some(),
            Request::CommitCalibration => CommitCalibration::reply(r).is_some(),
            Request::StartStream { .. } => StartStream::reply(r).is_some(),
            Request::StopStream => StopStream::reply(r).is_some(),
            Request::GetStatus => GetStatus::reply(r).is_some(),
            Request::EndSession => EndSession::reply(r).is_some(),
            Request::GetBackgroundStatus => GetBackgroundStatus::reply(r).is_some(),
            Request::SetBackground(_) => SetBackground::reply(r).is_some(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::ErrorCode;

    fn wire_identity() -> WireCalibration {
        wiical_core::Calibration::identity().into()
    }

    /// One response of every kind.
    fn responses() -> [Response; 8] {
        let hello = HelloResponse {
            protocol_version: 1,
            schema_key: 2,
            firmware_version: heapless::String::new(),
            device_id: [0; 8],
        };
        [
            Response::Hello(hello),
            Response::Error(ErrorCode::Busy),
            Response::Ack,
            Response::Calibration(CalibrationState {
                live: wire_identity(),
                staged: None,
                stored: false,
                boot: crate::messages::BootRecord::Empty,
                damaged_records: 0,
            }),
            Response::StreamStarted {
                sample_rate_mhz: 100_000,
            },
            Response::Sample(crate::messages::Sample {
                seq: 0,
                raw: [512; 3],
                corrected: [0.0; 3],
                buttons: 0,
                stick: [128; 2],
            }),
            Response::Status(AdapterStatus {
                phase: crate::messages::SelfCalPhase::Off,
                poses: 0,
                last_result: None,
                stale_moments: 0,
                stale_rms_mg: 0.0,
                recalibration_suggested: false,
            }),
            Response::Background(crate::messages::BackgroundReport {
                phase: crate::messages::BackgroundPhase::Collecting,
                settings: BackgroundSettings {
                    adopt: true,
                    replace_uploaded: false,
                    commit_interval_s: 1800,
                    commits_per_day: 8,
                    fit_interval_ms: 60_000,
                },
                origin: crate::messages::CalibrationOrigin::Factory,
                play_s: 0,
                moments: 0,
                bins_filled: 0,
                fresh_bins: 0,
                bin_moments: heapless::Vec::new(),
                temperature_c: None,
                coverage_gap: None,
                candidate: None,
                last_adoption: None,
                last_refusal: None,
            }),
        ]
    }

    /// The pairing the protocol documents on each `Request` variant, written out
    /// independently: (request, index of its success answer in `responses()`).
    #[test]
    fn each_request_is_answered_by_its_documented_reply_and_errors_only() {
        let cases: [(Request, usize); 10] = [
            (Request::Hello(Hello::CURRENT), 0),
            (Request::GetCalibration, 3),
            (Request::PutCalibration(wire_identity()), 2),
            (Request::CommitCalibration, 2),
            (Request::StartStream { rate_divider: 1 }, 4),
            (Request::StopStream, 2),
            (Request::GetStatus, 6),
            (Request::EndSession, 2),
            (Request::GetBackgroundStatus, 7),
            (
                Request::SetBackground(BackgroundSettings {
                    adopt: false,
                    replace_uploaded: false,
                    commit_interval_s: 1800,
                    commits_per_day: 8,
                    fit_interval_ms: 60_000,
                }),
                2,
            ),
        ];
        for (req, ok) in cases {
            for (i, resp) in responses().iter().enumerate() {
                let is_error = matches!(resp, Response::Error(_));
                let want = i == ok || (is_error && !matches!(req, Request::Hello(_)));
                assert_eq!(req.is_answered_by(resp), want, "{} vs {resp:?}", req.name());
            }
        }
    }

    #[test]
    fn endpoints_build_their_request_and_take_their_reply() {
        assert_eq!(GetCalibration.request(), Request::GetCalibration);
        assert_eq!(
            StartStream { rate_divider: 4 }.request(),
            Request::StartStream { rate_divider: 4 }
        );
        let rate = StartStream::reply(&Response::StreamStarted {
            sample_rate_mhz: 25_000,
        });
        assert_eq!(rate, Some(25_000));
        assert_eq!(StopStream::reply(&Response::Error(ErrorCode::Busy)), None);
        assert_eq!(StopStream.request().name(), "StopStream");
    }
}
