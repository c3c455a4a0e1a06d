//! # wiical-wire
//!
//! `no_std`, allocation-free wire protocol between the `wiical` host and the adapter
//! firmware over USB serial: [`Request`]s from the host, [`Response`]s (including streamed
//! [`Sample`]s) from the adapter, each serialized with postcard inside a CRC-protected
//! COBS frame ([`encode_frame`], [`FrameDecoder`]).
//!
//! ```
//! use wiical_wire::{encode_frame, DefaultFrameDecoder, Request, Response, MAX_FRAME_LEN};
//!
//! // Host side: frame a request.
//! let mut buf = [0u8; MAX_FRAME_LEN];
//! let frame = encode_frame(&Request::StartStream { rate_divider: 2 }, &mut buf).unwrap();
//! assert_eq!(frame.last(), Some(&0x00));
//!
//! // Adapter side: feed bytes as they arrive, in any chunks.
//! let mut rx = DefaultFrameDecoder::new();
//! let (a, b) = frame.split_at(3);
//! assert_eq!(rx.feed::<Request>(a).count(), 0);
//! let got: Vec<_> = rx.feed::<Request>(b).collect();
//! assert_eq!(got, vec![Ok(Request::StartStream { rate_divider: 2 })]);
//! # let _ = Response::Ack;
//! ```
//!
//! ## Session
//! 1. The host sends `Request::Hello(Hello::CURRENT)`.
//! 2. The adapter always answers `Response::Hello(HelloResponse { .. })` with its own
//!    version, schema key, firmware version and device ID.
//! 3. Each side compares the other's [`SCHEMA_KEY`] ([`Hello::check`],
//!    [`HelloResponse::check`]). On mismatch the host stops with a message naming both
//!    versions; the adapter answers every request other than Hello with
//!    `Response::Error(ErrorCode::SchemaMismatch)`.
//! 4. Then any request; one response each; `Sample`s arrive between responses while
//!    streaming.
//! 5. (Protocol 4.) Before closing the port the host sends `Request::EndSession`: its staged
//!    upload is discarded and the session closed, so a process that shares the port and
//!    never said Hello cannot commit it. Every opener says its own Hello.
//! 6. (Protocol 5.) `GetBackgroundStatus` reads the background recalibration's grid, candidate,
//!    last adoption and last refusal; `SetBackground` stores its settings (adoption on/off,
//!    whether a host upload may be replaced) in the adapter's flash.
//! 7. (Protocol 7.) `GetGyroCalibration`, `PutGyroCalibration` and `CommitGyroCalibration`
//!    read, stage and store the MotionPlus's gyro calibration ([`WireGyroCalibration`]) as
//!    the three calibration requests do the accelerometer's.
//! 8. (Protocol 8.) While a MotionPlus is the extension served, the stream carries
//!    [`GyroSample`]s (its raw rates, range bits and corrected rates) instead of `Sample`s.
//!
//! ## Declared once
//! [`Request`] and [`Response`] are declared in one place, [`protocol`]: each request with
//! its payload and the response variant that answers it. From that declaration come the
//! endpoint types ([`endpoints`]), the pairing ([`Request::is_answered_by`]), the schema's
//! `Request:` and `Response:` lines and the adapter's typed [`dispatch`] (see [`declare`]).
//!
//! ## Versioning rules
//! * [`SCHEMA`] describes every message; [`SCHEMA_KEY`] is its FNV-1a hash computed in a
//!   `const fn`. Its `Request:`, `Response:` and `WireEffects:` lines are rendered from the
//!   declarations; **any other change to a message type must update [`SCHEMA`]'s text**. Either
//!   way the key changes: bump [`PROTOCOL_VERSION`]. The `golden_encodings` test pins the
//!   bytes of each message so a forgotten update fails the tests.
//! * Frozen forever, so that mismatched builds can still tell each other so: variant 0 of
//!   [`Request`] and [`Hello`]'s layout; variants 0 and 1 of [`Response`],
//!   [`HelloResponse`]'s layout, and the numeric values of [`ErrorCode`] (serialized as
//!   `u8`, never reused).
//! * New enum variants are added at the end only (postcard encodes variants by index).
//!
//! ## Calibration on the wire
//! [`WireCalibration`] mirrors [`wiical_core::Calibration`] with `From` conversions both
//! ways. A separate type was chosen over serializing the core type so that the core can
//! evolve without silently changing the wire format.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod bins;
pub mod declare;
pub mod frame;
pub mod messages;
pub mod protocol;
pub mod schema;

pub use frame::{
    encode_frame, DefaultFrameDecoder, FrameDecoder, FrameError, Frames, MAX_FRAME_LEN,
};
pub use messages::{
    AdapterStatus, AdoptionReport, BackgroundPhase, BackgroundReport, BackgroundSettings,
    BackgroundSettingsField, BootRecord, CalibrationOrigin, CalibrationState, CandidateReport,
    CoverageGapReport, ErrorCode, GyroCalibrationState, GyroSample, Hello, HelloResponse,
    RecordProblem, RefusalReport, Sample, SelfCalOutcome, SelfCalPhase, WireCalibration,
    WireEffects, WireGyroCalibration, BACKGROUND_BINS, FIRMWARE_VERSION_CAP, GYRO_DEVICE_FLOATS,
    SELFCAL_MESSAGE_CAP,
};
pub use protocol::{dispatch, endpoints, Answer, AnswerAsync, Endpoint, Request, Response, Serve};
pub use schema::{
    check_schema_key, fnv1a_32, protocol_of_key, PREVIOUS_SCHEMA_KEYS, PROTOCOL_VERSION, SCHEMA,
    SCHEMA_KEY,
};
