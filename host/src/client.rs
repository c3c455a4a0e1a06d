//! A typed client of a wiical adapter (or `wiical device-sim`) over its serial port: open,
//! handshake, read / stage / commit calibrations, stream corrected samples. `wiical device`
//! ([`crate::cmd::device`]) is its command line; other programs can use [`Device`] directly.
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

use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;
use serialport::SerialPort;
use wiical_core::Calibration;
use wiical_wire::{
    encode_frame, CalibrationState, DefaultFrameDecoder, ErrorCode, FrameError, Hello,
    HelloResponse, Request, Response, Sample, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_KEY,
};

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

/// A connection to an adapter. Open with [`Device::open`], then [`Device::hello`].
pub struct Device {
    port: Box<dyn SerialPort>,
    name: String,
    rx: DefaultFrameDecoder,
    opts: ClientOptions,
    stats: LinkStats,
    /// Whole messages decoded but not consumed yet (a chunk can complete several frames).
    queue: std::collections::VecDeque<Result<Response, FrameError>>,
}

fn request_name(r: &Request) -> &'static str {
    match r {
        Request::Hello(_) => "Hello",
        Request::GetCalibration => "GetCalibration",
        Request::PutCalibration(_) => "PutCalibration",
        Request::CommitCalibration => "CommitCalibration",
        Request::StartStream { .. } => "StartStream",
        Request::StopStream => "StopStream",
        Request::GetStatus => "GetStatus",
    }
}

/// True when `resp` is an answer `req` can get (so a late answer to another request is
/// not taken for this one).
fn answers(req: &Request, resp: &Response) -> bool {
    match (req, resp) {
        (Request::Hello(_), Response::Hello(_)) => true,
        (Request::Hello(_), _) => false,
        (_, Response::Error(_)) => true,
        (Request::GetCalibration, Response::Calibration(_)) => true,
        (Request::GetStatus, Response::Status(_)) => true,
        (Request::StartStream { .. }, Response::StreamStarted { .. }) => true,
        (
            Request::PutCalibration(_) | Request::CommitCalibration | Request::StopStream,
            Response::Ack,
        ) => true,
        _ => false,
    }
}

impl Device {
    /// Open the serial port (any baud rate works over USB CDC and ptys).
    pub fn open(path: &str, opts: ClientOptions) -> Result<Self> {
        if !Path::new(path).exists() && cfg!(unix) {
            bail!(
                "serial port {path} does not exist (is the adapter plugged in? \
                 `wiical device-sim --pty` prints the port of the simulator)"
            );
        }
        let port = serialport::new(path, 115_200)
            .timeout(opts.timeout)
            .open()
            .map_err(|e| anyhow!("cannot open serial port {path}: {e}"))?;
        let d = Self {
            port,
            name: path.to_string(),
            rx: DefaultFrameDecoder::new(),
            opts,
            stats: LinkStats::default(),
            queue: Default::default(),
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
            .with_context(|| format!("cannot write to {}", self.name))
    }

    fn send(&mut self, req: &Request) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(req, &mut buf)
            .map_err(|e| anyhow!("cannot encode {}: {e}", request_name(req)))?
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
                Err(e) => {
                    return Err(anyhow!(
                        "lost the connection to the adapter on {}: {e}",
                        self.name
                    ))
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
                    Some(Ok(resp)) if answers(req, &resp) => return Ok((resp, attempt)),
                    Some(Ok(_)) => self.stats.discarded += 1,
                }
            }
            if attempt < attempts {
                self.stats.retries += 1;
            }
        }
        bail!(
            "the adapter on {} did not answer {} ({} attempts, {} ms each): \
             is it a wiical adapter, and is its firmware running?",
            self.name,
            request_name(req),
            attempts,
            self.opts.timeout.as_millis()
        )
    }

    /// Hello handshake. Fails with both versions on a schema mismatch.
    pub fn hello(&mut self) -> Result<HelloResponse> {
        // A lone delimiter ends whatever half frame the adapter may hold.
        self.write_raw(&[0])?;
        let (resp, _) = self.transact(&Request::Hello(Hello::CURRENT))?;
        let Response::Hello(h) = resp else {
            bail!("unexpected answer to Hello: {resp:?}");
        };
        if h.check().is_err() {
            // Say which side is older when the key is a known one.
            if let Some(v) = wiical_wire::protocol_of_key(h.schema_key) {
                let older = if v < PROTOCOL_VERSION {
                    "the adapter's firmware is older: flash the firmware built with this wiical"
                } else {
                    "this wiical is older than the firmware: update wiical"
                };
                bail!(
                    "the adapter on {} (firmware {:?}) speaks wire protocol v{}, this wiical v{}: \
                     {older}",
                    self.name,
                    h.firmware_version.as_str(),
                    v,
                    PROTOCOL_VERSION
                );
            }
            bail!(
                "the adapter on {} (firmware {:?}) speaks wire protocol v{} with schema key \
                 0x{:08X}, but this wiical speaks v{} with schema key 0x{:08X}: they cannot \
                 understand each other. Update the firmware or wiical so that both are built \
                 from the same wire protocol.",
                self.name,
                h.firmware_version.as_str(),
                h.protocol_version,
                h.schema_key,
                PROTOCOL_VERSION,
                SCHEMA_KEY
            );
        }
        Ok(h)
    }

    fn expect_ok(&mut self, req: &Request) -> Result<(Response, u32)> {
        let (resp, n) = self.transact(req)?;
        if let Response::Error(code) = resp {
            bail!(
                "the adapter refused {}: {code} (error code {})",
                request_name(req),
                code as u8
            );
        }
        Ok((resp, n))
    }

    /// The live and staged calibrations.
    pub fn get_calibration(&mut self) -> Result<CalibrationState> {
        match self.expect_ok(&Request::GetCalibration)?.0 {
            Response::Calibration(s) => Ok(s),
            other => bail!("unexpected answer to GetCalibration: {other:?}"),
        }
    }

    /// Stage a calibration for this session (checked locally first with the same
    /// acceptance predicate the adapter applies, so that a refusal names its reason).
    pub fn put_calibration(&mut self, cal: &Calibration) -> Result<()> {
        cal.validate()
            .map_err(|e| anyhow!("refusing to upload an invalid calibration: {e}"))?;
        wiical_core::quality::Acceptance::nunchuk()
            .check(cal, None)
            .map_err(|r| {
                anyhow!(
                    "refusing to upload an implausible calibration: {r} (the adapter applies \
                     the same limits, wiical_core::quality::Acceptance::nunchuk)"
                )
            })?;
        self.expect_ok(&Request::PutCalibration((*cal).into()))?;
        Ok(())
    }

    /// Self-calibration progress and result, and the stale-calibration estimate.
    pub fn status(&mut self) -> Result<wiical_wire::AdapterStatus> {
        match self.expect_ok(&Request::GetStatus)?.0 {
            Response::Status(s) => Ok(s),
            other => bail!("unexpected answer to GetStatus: {other:?}"),
        }
    }

    /// Commit the staged calibration. If the acknowledgement is lost and the retry finds
    /// nothing staged, the state is read back to decide whether the first attempt worked.
    pub fn commit(&mut self) -> Result<()> {
        let before = self.get_calibration()?;
        let Some(staged) = before.staged else {
            bail!(
                "nothing to commit on {}: the adapter only commits a calibration uploaded in \
                 the same session; use `wiical device commit FILE` (or `put FILE --commit`)",
                self.name
            );
        };
        let (resp, attempts) = self.transact(&Request::CommitCalibration)?;
        match resp {
            Response::Ack => Ok(()),
            Response::Error(ErrorCode::NothingStaged) if attempts > 1 => {
                let after = self.get_calibration()?;
                if after.stored && after.staged.is_none() && same_bits(&after.live, &staged) {
                    Ok(())
                } else {
                    bail!("commit on {} could not be confirmed", self.name)
                }
            }
            Response::Error(code) => bail!(
                "the adapter refused the commit: {code} (error code {}); the live calibration \
                 is unchanged",
                code as u8
            ),
            other => bail!("unexpected answer to CommitCalibration: {other:?}"),
        }
    }

    /// Start streaming; returns the sample rate in mHz.
    pub fn start_stream(&mut self, rate_divider: u16) -> Result<u32> {
        match self.expect_ok(&Request::StartStream { rate_divider })?.0 {
            Response::StreamStarted { sample_rate_mhz } => Ok(sample_rate_mhz),
            other => bail!("unexpected answer to StartStream: {other:?}"),
        }
    }

    /// The next streamed sample (corrupted frames are skipped and counted).
    pub fn next_sample(&mut self) -> Result<Sample> {
        let deadline = Instant::now() + self.opts.timeout;
        loop {
            match self.recv(deadline)? {
                Some(Ok(Response::Sample(s))) => return Ok(s),
                Some(Ok(_)) => self.stats.discarded += 1,
                Some(Err(_)) => {}
                None => bail!(
                    "no sample from the adapter on {} within {} ms: is the Nunchuk plugged in?",
                    self.name,
                    self.opts.timeout.as_millis()
                ),
            }
        }
    }

    /// Stop streaming.
    pub fn stop_stream(&mut self) -> Result<()> {
        self.expect_ok(&Request::StopStream).map(|_| ())
    }
}

/// Bitwise equality of two wire calibrations.
pub fn same_bits(a: &wiical_wire::WireCalibration, b: &wiical_wire::WireCalibration) -> bool {
    wiical_adapter::protocol::bits_equal(&Calibration::from(*a), &Calibration::from(*b))
}
