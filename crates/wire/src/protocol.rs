//! The protocol, declared once: each [`Request`] with its index, payload and the [`Response`]
//! variant that answers it, and each response with its index and payload.
//!
//! From this one declaration [`crate::declare`]'s macro writes the two enums (the same
//! variants in the same order as when they were written by hand, so the same postcard bytes),
//! one [`Endpoint`] type per request ([`endpoints::GetCalibration`], ...), one [`ReplyKind`]
//! per response ([`replies`]), the pairing ([`Request::is_answered_by`]), the names
//! ([`Request::name`]), the schema's `Request:` and `Response:` lines ([`crate::SCHEMA`]) and
//! the adapter's typed [`dispatch`]. The pairing lives here, beside the messages, so that host
//! and adapter cannot disagree about it (postcard-rpc keeps it in the shared crate for the same
//! reason).
//!
//! A client writes `device.call(GetCalibration)` and gets a
//! [`CalibrationState`] back; a late answer to another request, or an answer of the wrong
//! kind, is recognised by [`Request::is_answered_by`]. The adapter answers each endpoint in
//! an [`Answer`] impl that returns the typed reply (or an [`ErrorCode`]), and [`dispatch`]
//! wraps it in its response: an answer of the wrong kind does not compile.
//!
//! ## Adding a request
//! 1. A line in the declaration below (at the end of `Request`; a new `Response` variant at
//!    the end of `Response` when no existing one carries its answer), and the payload type in
//!    [`crate::messages`] with its schema line ([`crate::schema`]) if it is a new one.
//! 2. Its [`Answer`] impl in the adapter (`wiical_adapter::protocol`'s `answers`; an
//!    [`AnswerAsync`] for a request declared `async`): [`Serve`] asks for one per request, so
//!    the adapter does not build without it.
//! 3. The format steps: [`crate::PROTOCOL_VERSION`] bumped with the old key appended to
//!    [`crate::PREVIOUS_SCHEMA_KEYS`] and the old schema text pinned in its test; its golden
//!    encoding in `tests/frames.rs`.

use serde::{Deserialize, Serialize};

use crate::messages::{
    AdapterStatus, BackgroundReport, BackgroundSettings, CalibrationState, ErrorCode,
    GyroCalibrationState, GyroSample, Hello, HelloResponse, Sample, WireCalibration,
    WireGyroCalibration,
};

/// A request kind and the reply it gets.
pub trait Endpoint {
    /// The request's name in messages (the `Request` variant's name).
    const NAME: &'static str;
    /// What a successful answer carries (`()` for a bare [`Response::Ack`]).
    type Reply;
    /// The [`Response`] variant that answers it.
    type Kind: ReplyKind<Value = Self::Reply>;
    /// The request to send.
    fn request(&self) -> Request;
    /// The typed reply out of a successful answer; `None` when the answer is of another
    /// kind (an [`Response::Error`] included: the caller decides what an error means).
    fn reply(response: &Response) -> Option<Self::Reply> {
        Self::Kind::take(response)
    }
    /// The response that carries `reply`.
    fn respond(reply: Self::Reply) -> Response {
        Self::Kind::wrap(reply)
    }
}

/// One [`Response`] variant as a type: the value it carries, out of and into a response.
pub trait ReplyKind {
    /// What the variant carries (`()` for none).
    type Value;
    /// True when `response` is this variant.
    fn is(response: &Response) -> bool;
    /// The value, when `response` is this variant.
    fn take(response: &Response) -> Option<Self::Value>;
    /// The response of this variant carrying `value`.
    fn wrap(value: Self::Value) -> Response;
}

/// The adapter's answer to the endpoint `E`, at once: its typed reply, or the error code the
/// host gets in a [`Response::Error`]. [`dispatch`] calls it for each request of that kind.
pub trait Answer<E: Endpoint> {
    /// Answer `request`.
    fn answer(&mut self, request: E) -> Result<E::Reply, ErrorCode>;
}

/// The adapter's answer to the endpoint `E` of a request declared `async` (one that waits for
/// the adapter's flash): as [`Answer`], awaited.
// `async fn` in a public trait cannot promise `Send` futures; the adapter runs on a
// single-threaded executor (embassy's thread mode, `block_on` in the simulator), which asks
// for none.
#[allow(async_fn_in_trait)]
pub trait AnswerAsync<E: Endpoint> {
    /// Answer `request`.
    async fn answer(&mut self, request: E) -> Result<E::Reply, ErrorCode>;
}

/// The response of an answer: the endpoint's reply variant, or [`Response::Error`].
pub fn respond<E: Endpoint>(answer: Result<E::Reply, ErrorCode>) -> Response {
    match answer {
        Ok(reply) => E::respond(reply),
        Err(code) => Response::Error(code),
    }
}

// The declaration. A request: `INDEX Name`, its payload (`(Type)` or `{ field: type }`), `->`
// the `Response` variant that answers it, and `async` when the adapter's answer waits for its
// flash. A response: `INDEX Name` and its payload. New variants go at the end (postcard's tag
// is the position; the index is checked against it).
crate::declare::wire_protocol! {
    /// Host → adapter.
    ///
    /// Variant 0 (`Hello`) and the layout of [`Hello`] are frozen forever so that any two
    /// versions can at least agree that they disagree. New variants go at the end only.
    // No allocator here (no_std), so the calibration cannot be boxed: a message is handled
    // one at a time, and its size (≈ 0.3 KiB per calibration since protocol 3) is bounded.
    #[allow(clippy::large_enum_variant)]
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub enum Request {
        /// Open a session: the host's version and schema key. The adapter always answers
        /// with [`Response::Hello`]; if the keys differ it then refuses every other request
        /// with [`ErrorCode::SchemaMismatch`] until a Hello with a matching key arrives.
        0 Hello(Hello) -> Hello,
        /// Ask for the live (and staged, if any) calibration: answered by
        /// [`Response::Calibration`].
        1 GetCalibration -> Calibration,
        /// Stage a calibration (validated, not yet used nor stored): answered by
        /// [`Response::Ack`] or [`ErrorCode::InvalidCalibration`].
        2 PutCalibration(WireCalibration) -> Ack,
        /// Make the staged calibration live and store it persistently: [`Response::Ack`], or
        /// [`ErrorCode::NothingStaged`] / [`ErrorCode::StorageFailure`].
        3 CommitCalibration -> Ack async,
        /// Start streaming [`Response::Sample`]s at the adapter's base rate divided by
        /// `rate_divider` (≥ 1; 0 gives [`ErrorCode::InvalidParameter`]). Answered by
        /// [`Response::StreamStarted`].
        4 StartStream {
            /// Base-rate divider, ≥ 1.
            rate_divider: u16,
        } -> StreamStarted,
        /// Stop streaming: [`Response::Ack`] (also when no stream was running).
        5 StopStream -> Ack,
        /// (Protocol 2.) Ask for the self-calibration progress and result and the
        /// stale-calibration estimate: answered by [`Response::Status`].
        6 GetStatus -> Status,
        /// (Protocol 4.) End this host's session before it closes the port: the adapter
        /// discards the staged calibration and refuses every request but `Hello` until the
        /// next `Hello`, so that another process sharing the port cannot commit this host's
        /// upload. A running stream keeps running (it is the port's). Answered by
        /// [`Response::Ack`].
        7 EndSession -> Ack,
        /// (Protocol 5.) Ask for the background recalibration's state: answered by
        /// [`Response::Background`].
        8 GetBackgroundStatus -> Background,
        /// (Protocol 5.) Store the background recalibration's settings in the adapter's
        /// flash and put them in force: [`Response::Ack`], [`ErrorCode::InvalidParameter`]
        /// for a field outside its bounds ([`BackgroundSettings::out_of_bounds`]) or
        /// [`ErrorCode::StorageFailure`] (the old settings stay either way).
        9 SetBackground(BackgroundSettings) -> Ack async,
        /// (Protocol 7.) Ask for the MotionPlus gyro calibration (live, staged, what was found
        /// at boot): answered by [`Response::GyroCalibration`].
        10 GetGyroCalibration -> GyroCalibration,
        /// (Protocol 7.) Stage a gyro calibration (judged by the core's MotionPlus limits,
        /// `Acceptance::check_gyro`; not yet used nor stored): [`Response::Ack`],
        /// [`ErrorCode::InvalidCalibration`] or [`ErrorCode::ImplausibleCalibration`] (the
        /// staged and live ones unchanged).
        11 PutGyroCalibration(WireGyroCalibration) -> Ack,
        /// (Protocol 7.) Store the staged gyro calibration (power-loss safe, beside the
        /// accelerometer's) and make it live: [`Response::Ack`], or
        /// [`ErrorCode::NothingStaged`] / [`ErrorCode::StorageFailure`].
        12 CommitGyroCalibration -> Ack async,
    }

    /// Adapter → host.
    ///
    /// Variants 0 (`Hello`) and 1 (`Error`), the layout of [`HelloResponse`] and the numeric
    /// values of [`ErrorCode`] are frozen forever. New variants go at the end only.
    // No allocator here (no_std), so the calibration cannot be boxed: a message is handled
    // one at a time, and its size (≈ 0.3 KiB per calibration since protocol 3) is bounded.
    #[allow(clippy::large_enum_variant)]
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub enum Response {
        /// Answer to [`Request::Hello`], whatever the host's key.
        0 Hello(HelloResponse),
        /// A request was refused or failed.
        1 Error(ErrorCode),
        /// A request without a payload answer succeeded.
        2 Ack,
        /// Answer to [`Request::GetCalibration`].
        3 Calibration(CalibrationState),
        /// Answer to [`Request::StartStream`].
        4 StreamStarted {
            /// Resulting sample rate in millihertz (integer, so that e.g. 33.333 Hz is exact
            /// enough: 33333).
            sample_rate_mhz: u32,
        },
        /// One streamed sample.
        5 Sample(Sample),
        /// (Protocol 2.) Answer to [`Request::GetStatus`].
        6 Status(AdapterStatus),
        /// (Protocol 5.) Answer to [`Request::GetBackgroundStatus`].
        7 Background(BackgroundReport),
        /// (Protocol 7.) Answer to [`Request::GetGyroCalibration`].
        8 GyroCalibration(GyroCalibrationState),
        /// (Protocol 8.) One streamed MotionPlus sample (answers nothing, like
        /// [`Response::Sample`]).
        9 GyroSample(GyroSample),
    }
}

impl Request {
    /// True when `response` is an answer this request can get: its endpoint's reply, or an
    /// [`Response::Error`] (except for `Hello`, which the adapter always answers with
    /// [`Response::Hello`]). A streamed [`Response::Sample`] or [`Response::GyroSample`] answers
    /// nothing.
    pub fn is_answered_by(&self, response: &Response) -> bool {
        if matches!(response, Response::Error(_)) {
            return !matches!(self, Request::Hello(_));
        }
        self.expects(response)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn wire_identity() -> WireCalibration {
        wiical_core::Calibration::identity().into()
    }

    /// One response of every kind.
    fn responses() -> [Response; 10] {
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
            Response::GyroCalibration(GyroCalibrationState {
                live: None,
                staged: None,
                boot: crate::messages::BootRecord::Empty,
            }),
            Response::GyroSample(GyroSample {
                seq: 0,
                raw: [8192; 3],
                slow: 0b111,
                corrected: None,
            }),
        ]
    }

    /// The pairing the protocol documents on each `Request` variant, written out
    /// independently: (request, index of its success answer in `responses()`).
    fn documented_pairs() -> [(Request, usize); 13] {
        [
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
            (Request::GetGyroCalibration, 8),
            (
                Request::PutGyroCalibration(WireGyroCalibration {
                    bias: [8192.0; 3],
                    matrix: [[1e-3, 0.0, 0.0], [0.0, 1e-3, 0.0], [0.0, 0.0, 1e-3]],
                }),
                2,
            ),
            (Request::CommitGyroCalibration, 2),
        ]
    }

    #[test]
    fn each_request_is_answered_by_its_documented_reply_and_errors_only() {
        for (req, ok) in documented_pairs() {
            for (i, resp) in responses().iter().enumerate() {
                let is_error = matches!(resp, Response::Error(_));
                let want = i == ok || (is_error && !matches!(req, Request::Hello(_)));
                assert_eq!(req.is_answered_by(resp), want, "{} vs {resp:?}", req.name());
            }
        }
    }

    #[test]
    fn endpoints_build_their_request_and_take_their_reply() {
        assert_eq!(endpoints::GetCalibration.request(), Request::GetCalibration);
        assert_eq!(
            endpoints::StartStream { rate_divider: 4 }.request(),
            Request::StartStream { rate_divider: 4 }
        );
        assert_eq!(
            endpoints::Hello(Hello::CURRENT).request(),
            Request::Hello(Hello::CURRENT)
        );
        let rate = endpoints::StartStream::reply(&Response::StreamStarted {
            sample_rate_mhz: 25_000,
        });
        assert_eq!(rate, Some(25_000));
        assert_eq!(
            endpoints::StopStream::reply(&Response::Error(ErrorCode::Busy)),
            None
        );
        assert_eq!(endpoints::StopStream.request().name(), "StopStream");
        assert_eq!(
            endpoints::StartStream::respond(7),
            Response::StreamStarted { sample_rate_mhz: 7 }
        );
    }

    /// A server that answers every endpoint generically: with the first of [`responses`] its
    /// reply kind accepts (or with `refuse`), noting which endpoint it was asked and the
    /// request its endpoint value rebuilds; its gate refuses everything with `gate`.
    struct Toy {
        gate: Option<ErrorCode>,
        refuse: Option<ErrorCode>,
        asked: Vec<(&'static str, Request)>,
    }

    impl Serve for Toy {
        fn admit(&self, request: Request) -> Result<Request, ErrorCode> {
            self.gate.map_or(Ok(request), Err)
        }
    }

    impl<E: Endpoint> Answer<E> for Toy {
        fn answer(&mut self, request: E) -> Result<E::Reply, ErrorCode> {
            self.asked.push((E::NAME, request.request()));
            if let Some(code) = self.refuse {
                return Err(code);
            }
            responses()
                .iter()
                .find_map(E::reply)
                .ok_or(ErrorCode::Internal)
        }
    }

    impl<E: Endpoint> AnswerAsync<E> for Toy {
        async fn answer(&mut self, request: E) -> Result<E::Reply, ErrorCode> {
            Answer::answer(self, request)
        }
    }

    /// Polls a future that never waits (the toy's) to its end.
    fn run<F: core::future::Future>(f: F) -> F::Output {
        let mut f = core::pin::pin!(f);
        let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
        match f.as_mut().poll(&mut cx) {
            core::task::Poll::Ready(out) => out,
            core::task::Poll::Pending => panic!("the toy server never waits"),
        }
    }

    /// `dispatch` hands each request, payload intact, to its own endpoint's answer and wraps
    /// the reply in the response the documented pairing names; a refusal becomes `Error`, and
    /// so does the gate's, without asking the endpoint.
    #[test]
    fn dispatch_routes_each_request_to_its_endpoint_and_reply() {
        let expected = responses();
        for (req, ok) in documented_pairs() {
            let mut toy = Toy {
                gate: None,
                refuse: None,
                asked: Vec::new(),
            };
            let got = run(dispatch(&mut toy, req.clone()));
            assert_eq!(got, expected[ok], "{}", req.name());
            assert_eq!(toy.asked, [(req.name(), req.clone())]);
            toy.refuse = Some(ErrorCode::Busy);
            let refused = run(dispatch(&mut toy, req.clone()));
            assert_eq!(refused, Response::Error(ErrorCode::Busy), "{}", req.name());
            // The gate answers first: the endpoint is not asked.
            toy.gate = Some(ErrorCode::SchemaMismatch);
            toy.asked.clear();
            let gated = run(dispatch(&mut toy, req.clone()));
            assert_eq!(gated, Response::Error(ErrorCode::SchemaMismatch));
            assert!(toy.asked.is_empty(), "{}", req.name());
        }
    }

    /// The schema's lines are rendered from the declaration: the variant names and the
    /// payloads' type names, in order, with their indices.
    #[test]
    fn declared_variants_are_listed_in_order() {
        let names: Vec<_> = Request::VARIANTS.iter().map(|v| v.name).collect();
        let want: Vec<_> = documented_pairs().iter().map(|(r, _)| r.name()).collect();
        assert_eq!(names, want);
        assert!(crate::declare::indices_in_order(Request::VARIANTS));
        assert!(crate::declare::indices_in_order(Response::VARIANTS));
        let mut shuffled = [Request::VARIANTS[0], Request::VARIANTS[1]];
        shuffled.swap(0, 1);
        assert!(!crate::declare::indices_in_order(&shuffled));
        assert_eq!(
            Request::VARIANTS[4].payload,
            crate::declare::PayloadSchema::Fields(&[("rate_divider", "u16")])
        );
        assert_eq!(
            Response::VARIANTS[3].payload,
            crate::declare::PayloadSchema::Newtype("CalibrationState")
        );
    }
}
