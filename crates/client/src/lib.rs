//! A typed client of a wiical adapter (or `wiical device-sim`) over its serial port: open,
//! handshake, read / stage / commit calibrations, stream corrected samples. `wiical device`
//! (host/src/cmd/device.rs) is its command line; other programs can use [`Device`] directly.
//!
//! What the CLI's actions do with it:
//! * `info` — Hello handshake: firmware version, device ID, protocol version and schema key
//!   of both sides. A schema mismatch stops every command with a message naming both
//!   versions (the two builds cannot understand each other's messages).
//! * `get [--out CAL.json]` — the live calibration (and the staged one, if any).
//! * `put CAL.json` — stage a calibration written by `wiical fit --out` (a
//!   [`wiical_core::Calibration`] as JSON); it is validated here and by the adapter and read
//!   back bit for bit. It is not used until `commit`.
//! * `commit` — make the staged calibration live and store it in the adapter's flash.
//! * `stream [--count N] [--divider D]` — corrected samples as CSV (or JSON lines).
//!
//! Robustness: a lone `0x00` is sent first to flush a half-received frame in the adapter;
//! every request waits `--timeout-ms` for its answer and is retried (`--retries`) when the
//! answer is lost, corrupted (CRC/COBS failure: the decoder resynchronises at the next
//! `0x00`) or when the adapter reports that the request arrived corrupted (`BadFrame`).
//! Pending input is drained before each request so a late answer to an earlier attempt is
//! not mistaken for the next one. A commit whose acknowledgement was lost is confirmed by
//! reading the calibration state back rather than blindly repeated.

use std::io::{self, Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

/// What can go wrong talking to an adapter.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ClientError {
    /// The port path does not exist.
    #[error("serial port {path} does not exist (is the adapter plugged in? `wiical device-sim --pty` prints the port of the simulator)")]
    NoSuchPort {
        /// The path given.
        path: String,
    },
    /// The path exists but is not a terminal device (`/dev/null`, a regular file).
    #[error("{path} is not a serial port (not a terminal device): give the adapter's port, e.g. /dev/ttyACM0, or the pty `wiical device-sim --pty` prints")]
    NotASerialPort {
        /// The path given.
        path: String,
    },
    /// The port exists but cannot be opened.
    #[error("cannot open serial port {path}: {cause}")]
    Open {
        /// The path given.
        path: String,
        /// Why.
        cause: serialport::Error,
    },
    /// Writing to the port failed.
    #[error("cannot write to {port}")]
    Write {
        /// The port.
        port: String,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A request could not be framed.
    #[error("cannot encode {request}: {cause}")]
    Encode {
        /// The request.
        request: &'static str,
        /// Why.
        cause: FrameError,
    },
    /// Reading from the port failed.
    #[error("lost the connection to the adapter on {port}: {cause}")]
    ConnectionLost {
        /// The port.
        port: String,
        /// Why.
        cause: io::Error,
    },
    /// No answer after every retry.
    #[error("the adapter on {port} did not answer {request} ({attempts} attempts, {timeout_ms} ms each): is it a wiical adapter, and is its firmware running?")]
    NoAnswer {
        /// The port.
        port: String,
        /// The request.
        request: &'static str,
        /// Attempts made.
        attempts: u32,
        /// Timeout per attempt, ms.
        timeout_ms: u128,
    },
    /// An answer of the wrong kind.
    #[error("unexpected answer to {request}: {answer}")]
    Unexpected {
        /// The request.
        request: &'static str,
        /// The answer (debug form).
        answer: String,
    },
    /// Host and adapter speak different wire protocols.
    #[error("the adapter on {port} (firmware {firmware:?}) speaks wire protocol v{protocol} with schema key 0x{schema:08X}, but this wiical speaks v{} with schema key 0x{:08X}: they cannot understand each other. Update the firmware or wiical so that both are built from the same wire protocol.", PROTOCOL_VERSION, SCHEMA_KEY)]
    SchemaMismatch {
        /// The port.
        port: String,
        /// The adapter's firmware version.
        firmware: String,
        /// Its protocol version.
        protocol: u16,
        /// Its schema key.
        schema: u32,
    },
    /// The peer speaks a known older or newer protocol version.
    #[error("the adapter on {port} (firmware {firmware:?}) speaks wire protocol v{protocol}, this wiical v{}: {older}", PROTOCOL_VERSION)]
    OlderPeer {
        /// The port.
        port: String,
        /// The adapter's firmware version.
        firmware: String,
        /// Its protocol version.
        protocol: u16,
        /// Which side is older, and what to do.
        older: &'static str,
    },
    /// The adapter answered with an error code.
    #[error("the adapter refused {request}: {code} (error code {})", *code as u8)]
    Refused {
        /// The request.
        request: &'static str,
        /// The adapter's code.
        code: ErrorCode,
    },
    /// The calibration does not validate locally.
    #[error("refusing to upload an invalid calibration: {0}")]
    InvalidCalibration(wiical_core::Error),
    /// The calibration fails the adapter's acceptance predicate (checked locally first).
    #[error("refusing to upload an implausible calibration: {0} (the adapter applies the same limits, wiical_core::acceptance::Acceptance::nunchuk)")]
    Implausible(wiical_core::acceptance::Rejection),
    /// Commit without a staged calibration.
    #[error("nothing to commit on {port}: the adapter only commits a calibration uploaded in the same session; use `wiical device commit FILE` (or `put FILE --commit`)")]
    NothingStaged {
        /// The port.
        port: String,
    },
    /// The commit's acknowledgement was lost and the state read back does not confirm it.
    #[error("commit on {port} could not be confirmed")]
    CommitUnconfirmed {
        /// The port.
        port: String,
    },
    /// The adapter refused the commit.
    #[error("the adapter refused the commit: {code} (error code {}); the live calibration is unchanged", *code as u8)]
    CommitRefused {
        /// The adapter's code.
        code: ErrorCode,
    },
    /// No streamed sample in time.
    #[error(
        "no sample from the adapter on {port} within {timeout_ms} ms: is the Nunchuk plugged in?"
    )]
    NoSample {
        /// The port.
        port: String,
        /// The timeout, ms.
        timeout_ms: u128,
    },
}

/// Result of the client.
pub type Result<T, E = ClientError> = std::result::Result<T, E>;
use serde::Serialize;
use serialport::SerialPort;
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;
/// The centre direction of the adapter's background-recalibration bin `i` (bins as
/// [`wiical_wire::BackgroundReport::bin_moments`] numbers them), for drawing the grid.
pub use wiical_wire::bins::bin_centre as background_bin_centre;
use wiical_wire::{
    encode_frame, CalibrationState, DefaultFrameDecoder, ErrorCode, FrameError,
    GyroCalibrationState, GyroSample, Hello, HelloResponse, Request, Response, Sample,
    WireGyroCalibration, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_KEY,
};
use wiical_wire::{endpoints, Endpoint};

/// Timeouts and retries of a [`Device`] connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientOptions {
    /// How long to wait for each answer (and for each streamed sample).
    pub timeout: Duration,
    /// How many times a request is re-sent after a lost or corrupted answer.
    pub retries: u32,
}

impl Default for ClientOptions {
    fn default() -> Self {
        Self {
            timeout: Duration::from_millis(1000),
            retries: 3,
        }
    }
}

/// Counters of what went wrong on the line (for tests and `--verbose`-style reports).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct LinkStats {
    /// Frames that failed COBS/CRC/decoding (discarded, decoder resynchronised).
    pub frame_errors: u64,
    /// Requests re-sent.
    pub retries: u64,
    /// Bytes or messages discarded because they were not the awaited answer.
    pub discarded: u64,
}

/// A connection to an adapter. Open with [`Device::open`], then [`Device::hello`]; the
/// session ends when it is dropped ([`Device::end_session`]).
pub struct Device {
    port: Box<dyn SerialPort>,
    name: String,
    rx: DefaultFrameDecoder,
    opts: ClientOptions,
    stats: LinkStats,
    /// Whole messages decoded but not consumed yet (a chunk can complete several frames).
    queue: std::collections::VecDeque<Result<Response, FrameError>>,
    /// A Hello was answered with a matching key: the session is this host's, and is ended
    /// ([`Request::EndSession`]) when the device is dropped.
    session_open: bool,
}

fn unexpected(req: &Request, resp: &Response) -> ClientError {
    ClientError::Unexpected {
        request: req.name(),
        answer: format!("{resp:?}"),
    }
}

impl Device {
    /// Open the serial port (any baud rate works over USB CDC and ptys).
    pub fn open(path: &str, opts: ClientOptions) -> Result<Self> {
        if !Path::new(path).exists() && cfg!(unix) {
            return Err(ClientError::NoSuchPort { path: path.into() });
        }
        let port = serialport::new(path, 115_200)
            .timeout(opts.timeout)
            .open()
            .map_err(|cause| {
                // ENOTTY ("Not a typewriter"): the path is no terminal device at all.
                if cause.to_string().contains("Not a typewriter")
                    || cause.to_string().contains("Inappropriate ioctl")
                {
                    ClientError::NotASerialPort { path: path.into() }
                } else {
                    ClientError::Open {
                        path: path.into(),
                        cause,
                    }
                }
            })?;
        let d = Self {
            port,
            name: path.to_string(),
            rx: DefaultFrameDecoder::new(),
            opts,
            stats: LinkStats::default(),
            queue: Default::default(),
            session_open: false,
        };
        // Bytes that were waiting in the port (e.g. samples of a previous session) are stale.
        let _ = d.port.clear(serialport::ClearBuffer::Input);
        Ok(d)
    }

    /// Open and perform the Hello handshake.
    pub fn connect(path: &str, opts: ClientOptions) -> Result<(Self, HelloResponse)> {
        let mut d = Self::open(path, opts)?;
        let h = d.hello()?;
        Ok((d, h))
    }

    /// Port name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Line error counters so far.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// Send raw bytes (tests: inject garbage towards the adapter).
    pub fn write_raw(&mut self, bytes: &[u8]) -> Result<()> {
        self.port
            .write_all(bytes)
            .and_then(|_| self.port.flush())
            .map_err(|source| ClientError::Write {
                port: self.name.clone(),
                source,
            })
    }

    fn send(&mut self, req: &Request) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(req, &mut buf)
            .map_err(|cause| ClientError::Encode {
                request: req.name(),
                cause,
            })?
            .to_vec();
        self.write_raw(&frame)
    }

    /// Discard whatever is pending (late answers, stream samples) without waiting.
    fn drain(&mut self) {
        self.discard_queue();
        let _ = self.port.set_timeout(Duration::from_millis(0));
        let mut buf = [0u8; 1024];
        loop {
            match self.port.read(&mut buf) {
                Ok(n) if n > 0 => self.stats.discarded += n as u64,
                _ => break,
            }
        }
        self.rx.reset();
        let _ = self.port.set_timeout(self.opts.timeout);
    }

    fn discard_queue(&mut self) {
        self.stats.discarded += self.queue.len() as u64;
        self.queue.clear();
    }

    /// The next decoded item, or `None` at the deadline.
    fn recv(&mut self, deadline: Instant) -> Result<Option<Result<Response, FrameError>>> {
        let mut buf = [0u8; 512];
        loop {
            if let Some(item) = self.queue.pop_front() {
                if item.is_err() {
                    self.stats.frame_errors += 1;
                }
                return Ok(Some(item));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let _ = self
                .port
                .set_timeout((deadline - now).max(Duration::from_millis(1)));
            match self.port.read(&mut buf) {
                Ok(0) => {}
                Ok(n) => {
                    let items: Vec<_> = self.rx.feed::<Response>(&buf[..n]).collect();
                    self.queue.extend(items);
                }
                Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(cause) => {
                    return Err(ClientError::ConnectionLost {
                        port: self.name.clone(),
                        cause,
                    })
                }
            }
        }
    }

    /// Send `req` and wait for its answer, re-sending on loss or corruption. Returns the
    /// answer and the number of attempts it took.
    fn transact(&mut self, req: &Request) -> Result<(Response, u32)> {
        let attempts = self.opts.retries + 1;
        for attempt in 1..=attempts {
            self.drain();
            self.send(req)?;
            let deadline = Instant::now() + self.opts.timeout;
            loop {
                match self.recv(deadline)? {
                    None => break,
                    Some(Err(_)) => continue,
                    Some(Ok(Response::Error(ErrorCode::BadFrame))) => break,
                    Some(Ok(resp)) if req.is_answered_by(&resp) => return Ok((resp, attempt)),
                    Some(Ok(_)) => self.stats.discarded += 1,
                }
            }
            if attempt < attempts {
                self.stats.retries += 1;
            }
        }
        Err(ClientError::NoAnswer {
            port: self.name.clone(),
            request: req.name(),
            attempts,
            timeout_ms: self.opts.timeout.as_millis(),
        })
    }

    /// Hello handshake. Fails with both versions on a schema mismatch.
    pub fn hello(&mut self) -> Result<HelloResponse> {
        // A lone delimiter ends whatever half frame the adapter may hold.
        self.write_raw(&[0])?;
        let hello = endpoints::Hello(Hello::CURRENT).request();
        let (resp, _) = self.transact(&hello)?;
        let h = endpoints::Hello::reply(&resp).ok_or_else(|| unexpected(&hello, &resp))?;
        if h.check().is_err() {
            // Say which side is older when the key is a known one.
            if let Some(v) = wiical_wire::protocol_of_key(h.schema_key) {
                let older = if v < PROTOCOL_VERSION {
                    "the adapter's firmware is older: flash the firmware built with this wiical"
                } else {
                    "this wiical is older than the firmware: update wiical"
                };
                return Err(ClientError::OlderPeer {
                    port: self.name.clone(),
                    firmware: h.firmware_version.as_str().into(),
                    protocol: v,
                    older,
                });
            }
            return Err(ClientError::SchemaMismatch {
                port: self.name.clone(),
                firmware: h.firmware_version.as_str().into(),
                protocol: h.protocol_version,
                schema: h.schema_key,
            });
        }
        self.session_open = true;
        Ok(h)
    }

    /// Ends this host's session: the adapter discards what this session staged and refuses
    /// further requests until a new Hello, so that another process holding the same port
    /// cannot commit this host's upload. Also done, without waiting for the answer, when the
    /// device is dropped.
    pub fn end_session(&mut self) -> Result<()> {
        if !self.session_open {
            return Ok(());
        }
        self.session_open = false;
        self.call(endpoints::EndSession)
    }

    /// Send an endpoint's request, wait for its answer and take its typed reply: an
    /// adapter error is [`ClientError::Refused`], an answer of another kind
    /// [`ClientError::Unexpected`] (the pairing is `wiical_wire::endpoints`').
    pub fn call<E: Endpoint>(&mut self, endpoint: E) -> Result<E::Reply> {
        let req = endpoint.request();
        let (resp, _) = self.transact(&req)?;
        if let Response::Error(code) = resp {
            return Err(ClientError::Refused {
                request: E::NAME,
                code,
            });
        }
        E::reply(&resp).ok_or_else(|| unexpected(&req, &resp))
    }

    /// The live and staged calibrations.
    pub fn get_calibration(&mut self) -> Result<CalibrationState> {
        self.call(endpoints::GetCalibration)
    }

    /// Stage a calibration for this session (checked locally first with the same
    /// acceptance predicate the adapter applies, so that a refusal names its reason).
    pub fn put_calibration(&mut self, cal: &Calibration) -> Result<()> {
        wiical_core::acceptance::Acceptance::nunchuk()
            .check(cal, None)
            .map_err(ClientError::Implausible)?;
        self.put_judged(cal)
    }

    /// Stage a calibration the caller has already judged with the acceptance predicate (as
    /// `device put` does, to list every reason before opening the port): only its validity
    /// is checked here, and an implausible one sent with `--force` is refused by the adapter.
    pub fn put_judged(&mut self, cal: &Calibration) -> Result<()> {
        cal.validate().map_err(ClientError::InvalidCalibration)?;
        self.call(endpoints::PutCalibration((*cal).into()))
    }

    /// Self-calibration progress and result, and the stale-calibration estimate.
    pub fn status(&mut self) -> Result<wiical_wire::AdapterStatus> {
        self.call(endpoints::GetStatus)
    }

    /// (Protocol 5.) The background recalibration's grid, candidate, last adoption and last
    /// refusal.
    pub fn background_status(&mut self) -> Result<wiical_wire::BackgroundReport> {
        self.call(endpoints::GetBackgroundStatus)
    }

    /// (Protocol 5.) Store the background recalibration's settings in the adapter's flash:
    /// adoption on or off, and whether a calibration uploaded by the host may be replaced.
    pub fn set_background(&mut self, settings: wiical_wire::BackgroundSettings) -> Result<()> {
        self.call(endpoints::SetBackground(settings))
    }

    /// Self-calibration status asked for while streaming: unlike [`Device::status`], which
    /// discards the samples that arrive before the answer, this keeps them (returned in
    /// order, to be used as if read by [`Device::next_sample`]). Asks once; `None` when no
    /// status came within the timeout (or the adapter refused), which a live view can
    /// survive.
    pub fn status_while_streaming(
        &mut self,
    ) -> Result<(Option<wiical_wire::AdapterStatus>, Vec<Sample>)> {
        let (reply, streamed) = self.call_while_streaming(endpoints::GetStatus)?;
        Ok((reply, self.accelerometer_only(streamed)))
    }

    /// (Protocol 5.) The background recalibration's state asked for while streaming, as
    /// [`Device::status_while_streaming`].
    pub fn background_while_streaming(
        &mut self,
    ) -> Result<(Option<wiical_wire::BackgroundReport>, Vec<Sample>)> {
        let (reply, streamed) = self.call_while_streaming(endpoints::GetBackgroundStatus)?;
        Ok((reply, self.accelerometer_only(streamed)))
    }

    /// [`Device::status_while_streaming`] keeping the gyro samples too (protocol 8), for a
    /// reader of [`Device::next_streamed`].
    pub fn status_while_streaming_all(
        &mut self,
    ) -> Result<(Option<wiical_wire::AdapterStatus>, Vec<Streamed>)> {
        self.call_while_streaming(endpoints::GetStatus)
    }

    /// [`Device::background_while_streaming`] keeping the gyro samples too.
    pub fn background_while_streaming_all(
        &mut self,
    ) -> Result<(Option<wiical_wire::BackgroundReport>, Vec<Streamed>)> {
        self.call_while_streaming(endpoints::GetBackgroundStatus)
    }

    /// The accelerometer's samples of `streamed`; the gyro's are counted as discarded.
    fn accelerometer_only(&mut self, streamed: Vec<Streamed>) -> Vec<Sample> {
        let mut out = Vec::with_capacity(streamed.len());
        for s in streamed {
            match s {
                Streamed::Accelerometer(s) => out.push(s),
                Streamed::Gyro(_) => self.stats.discarded += 1,
            }
        }
        out
    }

    /// One request while streaming: its reply (`None`: refused, or none within the timeout)
    /// and the samples that arrived before it, in order.
    fn call_while_streaming<E: Endpoint>(
        &mut self,
        endpoint: E,
    ) -> Result<(Option<E::Reply>, Vec<Streamed>)> {
        self.send(&endpoint.request())?;
        let deadline = Instant::now() + self.opts.timeout;
        let mut samples = Vec::new();
        loop {
            match self.recv(deadline)? {
                Some(Ok(Response::Sample(s))) => samples.push(Streamed::Accelerometer(s)),
                Some(Ok(Response::GyroSample(s))) => samples.push(Streamed::Gyro(s)),
                Some(Ok(Response::Error(_))) | None => return Ok((None, samples)),
                Some(Ok(r)) => match E::reply(&r) {
                    Some(reply) => return Ok((Some(reply), samples)),
                    None => self.stats.discarded += 1,
                },
                Some(Err(_)) => {}
            }
        }
    }

    /// Commit the staged calibration. If the acknowledgement is lost and the retry finds
    /// nothing staged, the state is read back to decide whether the first attempt worked.
    pub fn commit(&mut self) -> Result<()> {
        let before = self.get_calibration()?;
        let Some(staged) = before.staged else {
            return Err(ClientError::NothingStaged {
                port: self.name.clone(),
            });
        };
        let (resp, attempts) = self.transact(&Request::CommitCalibration)?;
        match resp {
            Response::Ack => Ok(()),
            Response::Error(ErrorCode::NothingStaged) if attempts > 1 => {
                let after = self.get_calibration()?;
                if after.stored && after.staged.is_none() && same_bits(&after.live, &staged) {
                    Ok(())
                } else {
                    Err(ClientError::CommitUnconfirmed {
                        port: self.name.clone(),
                    })
                }
            }
            Response::Error(code) => Err(ClientError::CommitRefused { code }),
            other => Err(unexpected(&Request::CommitCalibration, &other)),
        }
    }

    /// (Protocol 7.) The MotionPlus gyro calibration: live, staged, what was found at boot.
    pub fn get_gyro_calibration(&mut self) -> Result<GyroCalibrationState> {
        self.call(endpoints::GetGyroCalibration)
    }

    /// (Protocol 7.) Stage a gyro calibration in the MotionPlus's count axes (the host's
    /// conversion of a `gyrofit` file, `wiical_analysis::output::gyrocal::for_motionplus`),
    /// checked locally for validity; the adapter judges it with the core's MotionPlus limits
    /// (`Acceptance::check_gyro`), which a caller applies first to name a refusal's reason.
    pub fn put_gyro_judged(&mut self, cal: &GyroCorrection<f32>) -> Result<()> {
        cal.validate().map_err(ClientError::InvalidCalibration)?;
        self.call(endpoints::PutGyroCalibration((*cal).into()))
    }

    /// (Protocol 7.) Commit the staged gyro calibration, confirmed by reading the state back
    /// when the acknowledgement was lost (as [`Device::commit`]).
    pub fn commit_gyro(&mut self) -> Result<()> {
        let before = self.get_gyro_calibration()?;
        let Some(staged) = before.staged else {
            return Err(ClientError::NothingStaged {
                port: self.name.clone(),
            });
        };
        let (resp, attempts) = self.transact(&Request::CommitGyroCalibration)?;
        match resp {
            Response::Ack => Ok(()),
            Response::Error(ErrorCode::NothingStaged) if attempts > 1 => {
                let after = self.get_gyro_calibration()?;
                if after.staged.is_none() && after.live.is_some_and(|l| same_gyro_bits(&l, &staged))
                {
                    Ok(())
                } else {
                    Err(ClientError::CommitUnconfirmed {
                        port: self.name.clone(),
                    })
                }
            }
            Response::Error(code) => Err(ClientError::CommitRefused { code }),
            other => Err(unexpected(&Request::CommitGyroCalibration, &other)),
        }
    }

    /// Start streaming; returns the sample rate in mHz.
    pub fn start_stream(&mut self, rate_divider: u16) -> Result<u32> {
        self.call(endpoints::StartStream { rate_divider })
    }

    /// The next streamed sample (corrupted frames are skipped and counted).
    pub fn next_sample(&mut self) -> Result<Sample> {
        self.next_taken(|r| match r {
            Response::Sample(s) => Some(s),
            _ => None,
        })
    }

    /// The next streamed sample of either kind (protocol 8: a MotionPlus's [`GyroSample`]s
    /// while the adapter serves one); corrupted frames are skipped and counted.
    pub fn next_streamed(&mut self) -> Result<Streamed> {
        self.next_taken(|r| match r {
            Response::Sample(s) => Some(Streamed::Accelerometer(s)),
            Response::GyroSample(s) => Some(Streamed::Gyro(s)),
            _ => None,
        })
    }

    /// The first response `take` accepts within one timeout; the ones it refuses are counted
    /// as discarded, corrupted frames skipped.
    fn next_taken<T>(&mut self, take: impl Fn(Response) -> Option<T>) -> Result<T> {
        let deadline = Instant::now() + self.opts.timeout;
        loop {
            match self.recv(deadline)? {
                Some(Ok(r)) => match take(r) {
                    Some(t) => return Ok(t),
                    None => self.stats.discarded += 1,
                },
                Some(Err(_)) => {}
                None => {
                    return Err(ClientError::NoSample {
                        port: self.name.clone(),
                        timeout_ms: self.opts.timeout.as_millis(),
                    })
                }
            }
        }
    }

    /// Stop streaming.
    pub fn stop_stream(&mut self) -> Result<()> {
        self.call(endpoints::StopStream)
    }
}

impl Drop for Device {
    /// Ends the session before the port closes (the adapter may not see the close while
    /// another process holds the port): the frame is written, its answer not awaited.
    fn drop(&mut self) {
        if self.session_open {
            self.session_open = false;
            let _ = self.send(&endpoints::EndSession.request());
            let _ = self.port.flush();
        }
    }
}

/// One streamed sample: the accelerometer's (a Nunchuk's) or, while the adapter serves a
/// MotionPlus, the gyro's (protocol 8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Streamed {
    /// A [`Sample`].
    Accelerometer(Sample),
    /// A [`GyroSample`].
    Gyro(GyroSample),
}

impl Streamed {
    /// The stream's sequence number (one count for both kinds).
    pub fn seq(&self) -> u32 {
        match self {
            Streamed::Accelerometer(s) => s.seq,
            Streamed::Gyro(g) => g.seq,
        }
    }
}

/// Bitwise equality of two wire gyro calibrations (the core's canonical bit encoding).
pub fn same_gyro_bits(a: &WireGyroCalibration, b: &WireGyroCalibration) -> bool {
    GyroCorrection::from(*a).bits() == GyroCorrection::from(*b).bits()
}

/// Bitwise equality of two wire calibrations (the core's canonical bit encoding).
pub fn same_bits(a: &wiical_wire::WireCalibration, b: &wiical_wire::WireCalibration) -> bool {
    Calibration::from(*a).bits_equal(&Calibration::from(*b))
}
