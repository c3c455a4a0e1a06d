//! `wiical device …`: talk to a wiical adapter (or `wiical device-sim`) over its serial port.
//!
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

use std::fmt::Write as _;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
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

    /// Stage a calibration (checked locally first).
    pub fn put_calibration(&mut self, cal: &Calibration) -> Result<()> {
        cal.validate()
            .map_err(|e| anyhow!("refusing to upload an invalid calibration: {e}"))?;
        self.expect_ok(&Request::PutCalibration((*cal).into()))?;
        Ok(())
    }

    /// Commit the staged calibration. If the acknowledgement is lost and the retry finds
    /// nothing staged, the state is read back to decide whether the first attempt worked.
    pub fn commit(&mut self) -> Result<()> {
        let before = self.get_calibration()?;
        let Some(staged) = before.staged else {
            bail!(
                "nothing to commit on {}: upload a calibration with `wiical device put` first",
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

/// Read a calibration JSON as written by `wiical fit --out`.
pub fn read_calibration(path: &Path) -> Result<Calibration> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let cal: Calibration = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a calibration JSON", path.display()))?;
    cal.validate()
        .map_err(|e| anyhow!("{}: invalid calibration: {e}", path.display()))?;
    Ok(cal)
}

// ------------------------------------------------------------------------------------------
// CLI

/// Arguments of `wiical device`.
#[derive(clap::Args, Debug, Clone)]
pub struct DeviceArgs {
    #[command(subcommand)]
    pub action: DeviceAction,
    /// Serial port of the adapter (e.g. /dev/ttyACM0, or the pty printed by `device-sim`).
    #[arg(long, global = true)]
    pub port: Option<String>,
    /// Print JSON (stream: one JSON object per line).
    #[arg(long, global = true)]
    pub json: bool,
    /// Answer timeout per request (and per sample), ms.
    #[arg(long, global = true, default_value_t = 1000)]
    pub timeout_ms: u64,
    /// Re-sends of a request whose answer was lost or corrupted.
    #[arg(long, global = true, default_value_t = 3)]
    pub retries: u32,
}

/// `wiical device` subcommands.
#[derive(clap::Subcommand, Debug, Clone)]
pub enum DeviceAction {
    /// Handshake and show firmware version, device ID and protocol versions.
    Info,
    /// Show the live (and staged) calibration.
    Get {
        /// Also write the live calibration here (JSON, the format `put` reads).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Stage a calibration (JSON from `wiical fit --out`); `commit` makes it live.
    Put {
        /// Calibration JSON.
        file: PathBuf,
    },
    /// Make the staged calibration live and store it in the adapter's flash.
    Commit,
    /// Stream corrected samples (CSV: seq,raw_x,raw_y,raw_z,ax,ay,az,c,z,stick_x,stick_y).
    Stream {
        /// Stop after this many samples (default: until interrupted).
        #[arg(long)]
        count: Option<u64>,
        /// Keep one report in DIVIDER (the adapter polls at 200 Hz).
        #[arg(long, default_value_t = 1)]
        divider: u16,
    },
}

#[derive(Serialize)]
struct InfoJson {
    port: String,
    firmware_version: String,
    device_id: String,
    protocol_version: u16,
    schema_key: String,
    host_protocol_version: u16,
    host_schema_key: String,
}

#[derive(Serialize)]
struct StateJson {
    port: String,
    live: Calibration,
    staged: Option<Calibration>,
    /// True when `live` is a committed (stored) calibration; false: pass-through with the
    /// Nunchuk's factory calibration.
    stored: bool,
}

#[derive(Serialize)]
struct SampleJson {
    seq: u32,
    raw: [u16; 3],
    corrected: [f32; 3],
    c: bool,
    z: bool,
    stick: [u8; 2],
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

fn fmt_cal(o: &mut String, title: &str, c: &Calibration) -> Result<()> {
    writeln!(o, "{title}")?;
    writeln!(
        o,
        "  bias b (counts): {:>12.4} {:>12.4} {:>12.4}",
        c.bias[0], c.bias[1], c.bias[2]
    )?;
    writeln!(o, "  K = D⁻¹ (g per count, ×1e-3):")?;
    for r in &c.matrix {
        writeln!(
            o,
            "    {:>12.6} {:>12.6} {:>12.6}",
            r[0] * 1e3,
            r[1] * 1e3,
            r[2] * 1e3
        )?;
    }
    if !c.effects.is_none() {
        writeln!(o, "  (+ effect terms; see --json)")?;
    }
    Ok(())
}

fn json<T: Serialize>(v: &T) -> Result<String> {
    Ok(serde_json::to_string_pretty(v)? + "\n")
}

/// Run `wiical device …`. Streamed samples are written to `out` as they arrive; the
/// returned text is printed afterwards.
pub fn run(args: &DeviceArgs, out: &mut dyn Write) -> Result<String> {
    let port = args
        .port
        .as_deref()
        .ok_or_else(|| anyhow!("--port is required (e.g. --port /dev/ttyACM0)"))?;
    let opts = ClientOptions {
        timeout: Duration::from_millis(args.timeout_ms.max(1)),
        retries: args.retries,
    };
    let (mut dev, hello) = Device::connect(port, opts)?;
    let mut o = String::new();
    match &args.action {
        DeviceAction::Info => {
            let j = InfoJson {
                port: port.to_string(),
                firmware_version: hello.firmware_version.to_string(),
                device_id: hex(&hello.device_id),
                protocol_version: hello.protocol_version,
                schema_key: format!("0x{:08X}", hello.schema_key),
                host_protocol_version: PROTOCOL_VERSION,
                host_schema_key: format!("0x{SCHEMA_KEY:08X}"),
            };
            if args.json {
                return json(&j);
            }
            writeln!(o, "adapter on {}", j.port)?;
            writeln!(o, "  firmware:  {}", j.firmware_version)?;
            writeln!(o, "  device id: {}", j.device_id)?;
            writeln!(
                o,
                "  protocol:  v{} (schema {}), host v{} (schema {}): compatible",
                j.protocol_version, j.schema_key, j.host_protocol_version, j.host_schema_key
            )?;
        }
        DeviceAction::Get { out: file } => {
            let s = dev.get_calibration()?;
            let live = Calibration::from(s.live);
            if let Some(path) = file {
                let text = serde_json::to_string_pretty(&live)? + "\n";
                std::fs::write(path, text)
                    .with_context(|| format!("cannot write {}", path.display()))?;
            }
            let j = StateJson {
                port: port.to_string(),
                live,
                staged: s.staged.map(Calibration::from),
                stored: s.stored,
            };
            if args.json {
                return json(&j);
            }
            let title = if s.stored {
                "live calibration (committed, stored on the adapter):"
            } else {
                "live calibration: none committed, pass-through (the Nunchuk's factory calibration):"
            };
            fmt_cal(&mut o, title, &j.live)?;
            match &j.staged {
                Some(c) => fmt_cal(&mut o, "staged (not live until `wiical device commit`):", c)?,
                None => writeln!(o, "nothing staged")?,
            }
        }
        DeviceAction::Put { file } => {
            let cal = read_calibration(file)?;
            dev.put_calibration(&cal)?;
            // Read it back: the staged copy must be bit-identical.
            let s = dev.get_calibration()?;
            let ok = s
                .staged
                .map(|w| same_bits(&w, &cal.into()))
                .unwrap_or(false);
            if !ok {
                bail!("the calibration read back from the adapter differs from the one sent");
            }
            if args.json {
                return json(&serde_json::json!({
                    "port": port, "staged": true, "verified": true, "calibration": cal
                }));
            }
            writeln!(
                o,
                "staged {} on {} (verified bit for bit); run `wiical device commit --port {}` \
                 to make it live and store it",
                file.display(),
                port,
                port
            )?;
        }
        DeviceAction::Commit => {
            dev.commit()?;
            let s = dev.get_calibration()?;
            if args.json {
                return json(&serde_json::json!({
                    "port": port, "committed": true, "stored": s.stored,
                    "live": Calibration::from(s.live)
                }));
            }
            writeln!(
                o,
                "committed on {port}: the calibration is live and stored in the adapter's flash"
            )?;
        }
        DeviceAction::Stream { count, divider } => {
            stream(&mut dev, *count, *divider, args.json, out)?;
        }
    }
    Ok(o)
}

/// Stream samples to `out` (CSV with header, or JSON lines). Ends after `count` samples, or
/// when `out` is closed (`| head`).
pub fn stream(
    dev: &mut Device,
    count: Option<u64>,
    divider: u16,
    as_json: bool,
    out: &mut dyn Write,
) -> Result<u64> {
    if divider == 0 {
        bail!("--divider must be at least 1");
    }
    dev.start_stream(divider)?;
    let mut n = 0u64;
    let mut write = |line: String| -> Result<bool> {
        match out.write_all(line.as_bytes()) {
            Ok(()) => Ok(true),
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(false),
            Err(e) => Err(e.into()),
        }
    };
    let mut open =
        as_json || write("seq,raw_x,raw_y,raw_z,ax,ay,az,c,z,stick_x,stick_y\n".to_string())?;
    while open && count.is_none_or(|c| n < c) {
        let s = dev.next_sample()?;
        let c = s.buttons & Sample::BUTTON_C != 0;
        let z = s.buttons & Sample::BUTTON_Z != 0;
        let line = if as_json {
            serde_json::to_string(&SampleJson {
                seq: s.seq,
                raw: s.raw,
                corrected: s.corrected,
                c,
                z,
                stick: s.stick,
            })? + "\n"
        } else {
            format!(
                "{},{},{},{},{},{},{},{},{},{},{}\n",
                s.seq,
                s.raw[0],
                s.raw[1],
                s.raw[2],
                s.corrected[0],
                s.corrected[1],
                s.corrected[2],
                u8::from(c),
                u8::from(z),
                s.stick[0],
                s.stick[1]
            )
        };
        open = write(line)?;
        n += 1;
    }
    let _ = out.flush();
    dev.stop_stream()?;
    Ok(n)
}
