//! `wiical capture`: record a Wii Remote's accelerometer (and a Nunchuk's) over Bluetooth HID.
//!
//! The remote is paired with the computer over Bluetooth (press 1+2 or the red sync button);
//! the operating system then exposes it as a HID device (Linux: `/dev/hidraw*`), which
//! [`io::open_wiimote`] opens through hidapi (vendor `0x057E`, product `0x0306` RVL-CNT-01 or
//! `0x0330` RVL-CNT-01-TR). [`session::Session::init`] then
//!
//! 1. lights LED 1 and asks for a status report (`0x15` → `0x20`: is an extension plugged in?),
//! 2. reads the accelerometer calibration from the EEPROM (20 bytes at `0x0016`: the block and
//!    its copy at `0x0020`; Nintendo's rule: first copy with a valid checksum),
//! 3. if an extension is connected: unencrypted init (`0x55` → `0xA400F0`, `0x00` →
//!    `0xA400FB`), its ID (6 bytes at `0xA400FA`) and, for a Nunchuk, its calibration
//!    (32 bytes at `0xA40020`: block and copy),
//!    A MotionPlus is looked for first (its ID at `0xA600FA`; a refused read means none): if
//!    present its 32-byte calibration block (`0xA60020`) is read, the extension behind it is set
//!    up as above, and it is activated (`0x55` → `0xA600F0`, then `0x05` → `0xA600FE` with a
//!    Nunchuk behind it, else `0x04`). The CSV then has `gx,gy,gz` (pitch, roll, yaw, raw
//!    14-bit counts) and `gx_slow,gy_slow,gz_slow`; in pass-through mode rows alternate between
//!    gyro data and the Nunchuk's (whose accelerometer loses bit 0), see docs/gyro.md,
//! 4. selects continuous reporting in mode `0x35` (`12 04 35`: buttons, accelerometer and 16
//!    extension bytes, about 100 reports a second).
//!
//! [`capture`] then timestamps every data report with the host's monotonic clock (the
//! remote's reports carry no time; Bluetooth adds a few milliseconds of jitter) and writes
//! `t,x,y,z` (+ `ext_x,ext_y,ext_z` with a Nunchuk), raw 10-bit counts, to a CSV that
//! `wiical fit`/`analyze` read directly (`--columns ext_x,ext_y,ext_z` selects the Nunchuk).
//! Both factory calibrations go to `FILE.cal.json` (both copies decoded, hex, checksum flags)
//! and, as `# key: value` comments, to the top of the CSV. An unrequested status report
//! (extension plugged or unplugged) is answered by setting the reporting mode again, as
//! WiiBrew says the remote otherwise stops sending data reports.
//!
//! Modes: `--duration-s S` records S seconds; `--guided N` walks the user through N poses
//! ([`guided`]): still for `--hold-s`, then "turn the remote", then still again.
//!
//! **Testing.** No test here talks to a real remote: the build and CI machines have no
//! Bluetooth. The protocol and capture logic are tested against [`replay::ReplayWiimote`], a
//! fake that answers from the real calibration bytes (WiiBrew's EEPROM block, a Nunchuk dump)
//! and replays scripted reports; only the "no remote found" path of [`io::open_wiimote`]
//! runs for real. `--raw-log FILE` records a real session's reports so that it can be replayed
//! later with `--replay FILE`.
//!
//! On Linux the kernel's `hid-wiimote` driver also binds to the remote; hidraw access works
//! alongside it, but if reports stop, unload it (`modprobe -r hid_wiimote`).

pub mod guided;
pub mod io;
pub mod output;
pub mod protocol;
pub mod replay;
pub mod session;

use anyhow::{anyhow, bail, Context, Result};
use guided::{Guided, GuidedConfig, GuidedEvent, PoseRecord};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use io::WiimoteIo;
use output::{cal_path, CalFile, CaptureStats, CsvOut};
use protocol::{parse_input, InputReport, ReportError, MAX_INPUT_LEN};
use serde::Serialize;
use session::{is_nunchuk_id, DeviceSetup, Session};
use std::fmt::Write as _;
use std::io::{BufWriter, IsTerminal};
use std::path::PathBuf;
use std::time::Duration;
use wiical_extbus::motionplus::{Frame, MotionPlusReport, PassthroughMode};

/// How long a capture runs.
#[derive(Debug, Clone, PartialEq)]
pub enum CaptureMode {
    /// Record this many seconds.
    Duration(f64),
    /// Guided multi-pose capture.
    Guided(GuidedConfig),
}

/// Settings of [`capture`].
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureOptions {
    /// Output CSV; the side file is `out` + `.cal.json`.
    pub out: PathBuf,
    /// Duration or guided.
    pub mode: CaptureMode,
    /// The capture fails when no data report arrives for this long, s.
    pub silence_timeout_s: f64,
    /// Longest wait for a reply during the start-up sequence, ms.
    pub reply_timeout_ms: u32,
}

impl Default for CaptureOptions {
    fn default() -> Self {
        Self {
            out: PathBuf::from("capture.csv"),
            mode: CaptureMode::Duration(30.0),
            silence_timeout_s: 2.0,
            reply_timeout_ms: 1000,
        }
    }
}

/// Where progress and instructions go.
pub trait CaptureUi {
    /// An instruction or event for the user (one line).
    fn message(&mut self, text: &str);
    /// Called after every sample: number written, time of the last one, and what to do now.
    fn progress(&mut self, _samples: u64, _t: f64, _prompt: &str) {}
    /// The capture is over.
    fn finish(&mut self) {}
}

/// Collects messages (tests, non-interactive use).
#[derive(Debug, Default, Clone)]
pub struct CollectUi {
    /// The messages, in order.
    pub messages: Vec<String>,
}

impl CaptureUi for CollectUi {
    fn message(&mut self, text: &str) {
        self.messages.push(text.to_string());
    }
}

/// Terminal output on stderr: an indicatif spinner with the sample count and rate when
/// stderr is a terminal; plain lines (messages only) otherwise.
pub struct TerminalUi {
    bar: Option<ProgressBar>,
}

impl TerminalUi {
    /// A spinner if stderr is a terminal, plain messages otherwise.
    pub fn new() -> Self {
        if !std::io::stderr().is_terminal() {
            return Self { bar: None };
        }
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        let style = ProgressStyle::with_template(
            "{spinner} {elapsed_precise} {pos} samples ({per_sec}) {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_spinner());
        bar.set_style(style);
        bar.enable_steady_tick(Duration::from_millis(200));
        Self { bar: Some(bar) }
    }
}

impl Default for TerminalUi {
    fn default() -> Self {
        Self::new()
    }
}

impl CaptureUi for TerminalUi {
    fn message(&mut self, text: &str) {
        match &self.bar {
            Some(b) => b.println(text),
            None => eprintln!("{text}"),
        }
    }

    fn progress(&mut self, samples: u64, t: f64, prompt: &str) {
        if let Some(b) = &self.bar {
            b.set_position(samples);
            b.set_message(format!("t = {t:.1} s  {prompt}"));
        }
    }

    fn finish(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// The result of a capture (`wiical capture --json`).
#[derive(Debug, Clone, Serialize)]
pub struct CaptureSummary {
    /// The CSV written.
    pub csv: PathBuf,
    /// The calibration side file written.
    pub cal_file: PathBuf,
    /// Everything in the side file.
    pub calibration: CalFile,
}

/// Runs the start-up sequence on `io`, then records to `opts.out` until the duration is
/// reached or all guided poses are done. On an error after recording started, the files
/// are completed (the CSV has the rows so far; the side file says `complete: false`) and the
/// error says so.
pub fn capture<D: WiimoteIo + ?Sized>(
    io: &mut D,
    opts: &CaptureOptions,
    ui: &mut dyn CaptureUi,
) -> Result<CaptureSummary> {
    if !(opts.silence_timeout_s.is_finite() && opts.silence_timeout_s > 0.0) {
        bail!("the silence timeout must be positive");
    }
    match &opts.mode {
        CaptureMode::Duration(d) => {
            if !(d.is_finite() && *d > 0.0) {
                bail!("--duration-s must be positive, got {d}");
            }
        }
        // Check the settings before talking to the device.
        CaptureMode::Guided(cfg) => drop(Guided::new(cfg.clone(), vec![[1.0; 3]])?),
    }
    let mut session = Session::new(io);
    session.reply_timeout_ms = opts.reply_timeout_ms;
    let setup = session.init().context("setting up the Wii Remote")?;
    let mut cal = CalFile::new(&setup)?;
    report_setup(&setup, &cal, ui);
    let cal_file = cal_path(&opts.out);
    cal.write(&cal_file)?;
    let file = std::fs::File::create(&opts.out)
        .with_context(|| format!("cannot create {}", opts.out.display()))?;
    let cal_name = cal_file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut csv = CsvOut::start(BufWriter::new(file), &cal, &cal_name)?;
    let mut rec = Recorder {
        session,
        setup: &setup,
        opts,
        stats: CaptureStats {
            mode: match opts.mode {
                CaptureMode::Duration(_) => "duration".into(),
                CaptureMode::Guided(_) => "guided".into(),
            },
            samples: 0,
            duration_s: 0.0,
            mean_rate_hz: None,
            bad_reports: 0,
            unknown_reports: 0,
            status_reports: 0,
            poses: Vec::new(),
            complete: false,
        },
        ext_present: csv.has_ext(),
        last_ext: [0.0; 3],
    };
    let result = rec.run(&mut csv, ui);
    ui.finish();
    let flushed = csv.flush();
    let mut stats = rec.stats;
    // Counted by the session, during the start-up and the recording alike.
    stats.unknown_reports = rec.session.unknown_reports;
    stats.complete = result.is_ok() && flushed.is_ok();
    if stats.samples >= 2 && stats.duration_s > 0.0 {
        stats.mean_rate_hz = Some((stats.samples - 1) as f64 / stats.duration_s);
    }
    let n = stats.samples;
    cal.capture = Some(stats);
    let written = cal.write(&cal_file);
    if let Err(e) = result {
        return Err(e.context(format!(
            "capture stopped after {n} samples; they are in {} (side file {})",
            opts.out.display(),
            cal_file.display()
        )));
    }
    flushed.with_context(|| format!("cannot write {}", opts.out.display()))?;
    written?;
    Ok(CaptureSummary {
        csv: opts.out.clone(),
        cal_file,
        calibration: cal,
    })
}

fn report_setup(setup: &DeviceSetup, cal: &CalFile, ui: &mut dyn CaptureUi) {
    ui.message(&format!("connected: {}", setup.description));
    for c in std::iter::once(&cal.wiimote).chain(cal.nunchuk.as_ref()) {
        match (&c.copy_used, &c.zero, &c.counts_per_g) {
            (Some(copy), Some(z), Some(s)) => ui.message(&format!(
                "{} factory calibration ({copy} copy): zero {:?}, counts per g {:?}",
                c.device, z, s
            )),
            _ => ui.message(&format!(
                "warning: no copy of the {} calibration has a valid checksum; recording raw counts anyway (bytes in the side file)",
                c.device
            )),
        }
    }
    if let Some(mp) = &cal.motionplus {
        ui.message(&format!(
            "MotionPlus found ({}), activated in mode 0x{:02X}; its calibration block's CRC-32 is {}",
            protocol::hex(&setup.motionplus.as_ref().map(|m| m.id).unwrap_or_default()),
            mp.mode.unwrap_or(0),
            if mp.checksum_ok { "correct" } else { "WRONG (bytes in the side file)" }
        ));
    }
    if let Some(ext) = &setup.extension {
        if !is_nunchuk_id(&ext.id) {
            ui.message(&format!(
                "extension {} is not a Nunchuk: only the remote is recorded",
                session::describe_extension(&ext.id)
            ));
        }
    }
}

struct Recorder<'a, 's, D: WiimoteIo + ?Sized> {
    session: Session<'s, D>,
    setup: &'a DeviceSetup,
    opts: &'a CaptureOptions,
    stats: CaptureStats,
    /// The CSV has Nunchuk columns and the Nunchuk is currently plugged in.
    ext_present: bool,
    /// Latest Nunchuk reading (held for the stillness test while it is unplugged).
    last_ext: [f64; 3],
}

/// The extension bytes of a report from an active MotionPlus: gyro data, or the pass-through
/// Nunchuk's accelerometer (bit 0 of each axis lost on the way), or neither (too short, or
/// extension data the mode does not expect).
fn split_motionplus_frame(
    ext: &[u8],
    mode: PassthroughMode,
) -> (Option<[u16; 3]>, Option<MotionPlusReport>) {
    match ext.get(..6).map(|b| Frame::decode(b, mode)) {
        Some(Ok(Frame::MotionPlus(g))) => (None, Some(g)),
        Some(Ok(Frame::Nunchuk(n))) => (Some(n.report.accel), None),
        _ => (None, None),
    }
}

/// After this many consecutive undecodable reports the capture gives up.
const MAX_BAD_IN_A_ROW: u32 = 100;

impl<D: WiimoteIo + ?Sized> Recorder<'_, '_, D> {
    fn run<W: std::io::Write>(
        &mut self,
        csv: &mut CsvOut<W>,
        ui: &mut dyn CaptureUi,
    ) -> Result<()> {
        let mut guided = match &self.opts.mode {
            CaptureMode::Guided(cfg) => {
                let mut quantum = vec![[1.0, 2.0, 2.0]];
                if csv.has_ext() {
                    quantum.push([1.0, 1.0, 1.0]);
                }
                ui.message(&format!(
                    "guided capture of {} poses: lay the remote{} still for {} s to start",
                    cfg.poses,
                    if csv.has_ext() {
                        " and the Nunchuk"
                    } else {
                        ""
                    },
                    cfg.init_s
                ));
                Some(Guided::new(cfg.clone(), quantum)?)
            }
            CaptureMode::Duration(d) => {
                ui.message(&format!("recording {d} s to {}", self.opts.out.display()));
                None
            }
        };
        let mut buf = [0u8; MAX_INPUT_LEN + 10];
        let mut t_first: Option<f64> = None;
        let mut last_data = self.session.io().now_s();
        let mut bad_in_a_row = 0u32;
        let mut last_flush = last_data;
        loop {
            let n = self.session.io().read_timeout(&mut buf, 200)?;
            let now = self.session.io().now_s();
            if n == 0 {
                if now - last_data > self.opts.silence_timeout_s {
                    bail!(
                        "no data report from the Wii Remote for {} s (out of range, batteries, or switched off?)",
                        self.opts.silence_timeout_s
                    );
                }
                continue;
            }
            let bytes = buf.get(..n).unwrap_or(&buf);
            let report = match parse_input(bytes) {
                Ok(r) => {
                    bad_in_a_row = 0;
                    r
                }
                Err(ReportError::Unknown(_)) => {
                    self.session.unknown_reports += 1;
                    continue;
                }
                Err(e) => {
                    self.stats.bad_reports += 1;
                    bad_in_a_row += 1;
                    if bad_in_a_row >= MAX_BAD_IN_A_ROW {
                        bail!("the Wii Remote sends malformed reports ({MAX_BAD_IN_A_ROW} in a row; last: {e})");
                    }
                    continue;
                }
            };
            let (accel, nunchuk, gyro) = match report {
                InputReport::Data(core) => match core.accel {
                    Some(a) => match &self.setup.motionplus {
                        Some(mp) => {
                            let (n, g) = split_motionplus_frame(core.ext, mp.mode);
                            (a, n, g)
                        }
                        None => (a, core.nunchuk().map(|n| n.accel), None),
                    },
                    None => continue,
                },
                InputReport::Status(s) => {
                    self.stats.status_reports += 1;
                    let t = t_first.map(|t0| now - t0).unwrap_or(0.0);
                    self.on_status(s.extension_connected(), t, csv, ui)?;
                    last_data = self.session.io().now_s();
                    continue;
                }
                InputReport::ReadReply(_) | InputReport::Ack(_) => continue,
            };
            last_data = now;
            let t = now - *t_first.get_or_insert(now);
            let ext = if self.ext_present { nunchuk } else { None };
            csv.row(t, accel, ext, gyro.as_ref())?;
            self.stats.samples += 1;
            self.stats.duration_s = t;
            if now - last_flush > 1.0 {
                csv.flush()?;
                last_flush = now;
            }
            let prompt = match guided.as_mut() {
                Some(g) => {
                    let mut devs = vec![accel.map(f64::from)];
                    if csv.has_ext() {
                        // An unplugged Nunchuk holds its last reading for the stillness test.
                        if let Some(e) = ext {
                            self.last_ext = e.map(f64::from);
                        }
                        devs.push(self.last_ext);
                    }
                    for ev in g.push(t, &devs)? {
                        self.on_guided(&ev, ui);
                    }
                    if g.finished() {
                        self.stats.poses = g.poses().to_vec();
                        return Ok(());
                    }
                    self.stats.poses = g.poses().to_vec();
                    g.prompt()
                }
                None => String::new(),
            };
            ui.progress(self.stats.samples, t, &prompt);
            if let CaptureMode::Duration(d) = self.opts.mode {
                if t >= d {
                    return Ok(());
                }
            }
        }
    }

    fn on_guided(&mut self, ev: &GuidedEvent, ui: &mut dyn CaptureUi) {
        let total = match &self.opts.mode {
            CaptureMode::Guided(c) => c.poses,
            CaptureMode::Duration(_) => 0,
        };
        match ev {
            GuidedEvent::RestDone { noise_std } => ui.message(&format!(
                "rest done: noise {} counts RMS",
                noise_std
                    .iter()
                    .map(|s| format!("{s:.2}"))
                    .collect::<Vec<_>>()
                    .join(" / ")
            )),
            GuidedEvent::Holding { pose } => ui.message(&format!("pose {pose}: still, hold it…")),
            GuidedEvent::PoseDone(PoseRecord { pose, .. }) if *pose < total => ui.message(&format!(
                "pose {pose} done: turn the remote to a new orientation"
            )),
            GuidedEvent::PoseDone(PoseRecord { pose, .. }) => {
                ui.message(&format!("pose {pose} done"))
            }
            GuidedEvent::TooClose { pose, same_as } => ui.message(&format!(
                "that is the orientation of pose {same_as} again: turn the remote further for pose {pose}"
            )),
            GuidedEvent::Moving { pose } => {
                ui.message(&format!("moving: now hold pose {pose} still"))
            }
            GuidedEvent::Finished => ui.message(&format!("all {total} poses done")),
        }
    }

    /// An unrequested status report: the extension was plugged or unplugged. The remote
    /// stops data reporting until the mode is set again (WiiBrew, "Status Reporting").
    fn on_status<W: std::io::Write>(
        &mut self,
        connected: bool,
        t: f64,
        csv: &mut CsvOut<W>,
        ui: &mut dyn CaptureUi,
    ) -> Result<()> {
        if self.setup.motionplus.is_some() {
            // The active MotionPlus is the extension the remote sees; what is plugged into
            // the MotionPlus shows in its reports, not in status reports. Re-initialising an
            // extension here would deactivate it (a write to 0xA400F0 does).
            csv.comment(&format!(
                "t={t:.6}: status report (extension {})",
                if connected {
                    "connected"
                } else {
                    "disconnected"
                }
            ))?;
            if !connected {
                ui.message("the MotionPlus stopped answering: its columns stay empty");
            }
        } else if !connected && self.ext_present {
            self.ext_present = false;
            csv.comment(&format!("t={t:.6}: extension unplugged"))?;
            ui.message("Nunchuk unplugged: its columns stay empty until it is plugged back in");
        } else if connected && csv.has_ext() && !self.ext_present {
            match self.session.init_extension() {
                Ok(ext) if is_nunchuk_id(&ext.id) => {
                    let initial = self
                        .setup
                        .extension
                        .as_ref()
                        .and_then(|e| e.nunchuk_calibration.as_ref());
                    let same = ext.nunchuk_calibration.as_ref() == initial;
                    csv.comment(&format!(
                        "t={t:.6}: extension plugged in{}",
                        if same {
                            ""
                        } else {
                            " (a different Nunchuk: its calibration differs from the header's)"
                        }
                    ))?;
                    ui.message(if same {
                        "Nunchuk plugged back in"
                    } else {
                        "warning: a different Nunchuk was plugged in (its calibration differs); its readings are recorded in the same columns"
                    });
                    self.ext_present = true;
                }
                Ok(ext) => ui.message(&format!(
                    "extension {} plugged in: not a Nunchuk, not recorded",
                    session::describe_extension(&ext.id)
                )),
                Err(e) => ui.message(&format!("extension plugged in but not usable: {e:#}")),
            }
        } else if connected && !csv.has_ext() {
            ui.message(
                "an extension was plugged in: not recorded (the capture started without one)",
            );
        }
        self.session.start_reporting()
    }
}

/// Arguments of `wiical capture`.
#[derive(clap::Args, Debug, Clone)]
pub struct CaptureArgs {
    /// Output CSV: t,x,y,z (+ ext_x,ext_y,ext_z with a Nunchuk, + gx,gy,gz and slow flags with a MotionPlus), raw counts; calibrations in OUT.cal.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Plain mode: record this many seconds.
    #[arg(long, default_value_t = 30.0)]
    pub duration_s: f64,
    /// Guided mode: walk through N poses, each held still (for `wiical fit`: 9 or more).
    #[arg(long, value_name = "N")]
    pub guided: Option<usize>,
    /// Guided: how long each pose is held still, seconds.
    #[arg(long, default_value_t = 4.0)]
    pub hold_s: f64,
    /// Guided: initial rest (noise reference), seconds.
    #[arg(long, default_value_t = 2.0)]
    pub init_s: f64,
    /// Guided: still when the 0.5 s window variance ≤ THRESHOLD × rest variance.
    #[arg(long, default_value_t = 6.0)]
    pub threshold: f64,
    /// Guided: give up when a pose is not held still (or no motion comes) within this time, s.
    #[arg(long, default_value_t = 60.0)]
    pub still_timeout_s: f64,
    /// Fail when no data report arrives for this long, seconds.
    #[arg(long, default_value_t = 2.0)]
    pub silence_timeout_s: f64,
    /// Also log every raw HID report (in and out, timestamped hex) to this file.
    #[arg(long)]
    pub raw_log: Option<PathBuf>,
    /// Replay a raw log written with --raw-log instead of opening a device.
    #[arg(long)]
    pub replay: Option<PathBuf>,
    /// Print JSON (the side file's content) instead of a summary.
    #[arg(long)]
    pub json: bool,
}

impl CaptureArgs {
    /// The capture options these arguments describe.
    pub fn options(&self) -> CaptureOptions {
        let mode = match self.guided {
            Some(poses) => CaptureMode::Guided(GuidedConfig {
                poses,
                init_s: self.init_s,
                hold_s: self.hold_s,
                threshold: self.threshold,
                still_timeout_s: self.still_timeout_s,
                ..Default::default()
            }),
            None => CaptureMode::Duration(self.duration_s),
        };
        CaptureOptions {
            out: self.out.clone(),
            mode,
            silence_timeout_s: self.silence_timeout_s,
            ..Default::default()
        }
    }
}

fn run_on<D: WiimoteIo>(
    io: D,
    args: &CaptureArgs,
    ui: &mut dyn CaptureUi,
) -> Result<CaptureSummary> {
    let opts = args.options();
    match &args.raw_log {
        Some(path) => {
            let f = std::fs::File::create(path)
                .with_context(|| format!("cannot create {}", path.display()))?;
            let mut logged = io::RawLogger::new(io, BufWriter::new(f))?;
            let r = capture(&mut logged, &opts, ui);
            logged.flush()?;
            r
        }
        None => {
            let mut io = io;
            capture(&mut io, &opts, ui)
        }
    }
}

/// `wiical capture`: open the first Wii Remote (or replay a raw log), record, and return the
/// text (or JSON) to print.
pub fn run(args: &CaptureArgs) -> Result<String> {
    let mut ui = TerminalUi::new();
    let summary = match &args.replay {
        Some(path) => run_on(io::LogReplay::load(path)?, args, &mut ui)?,
        None => run_on(io::open_wiimote()?, args, &mut ui)?,
    };
    render(&summary, args.json)
}

/// The text (or JSON) printed after a capture.
pub fn render(summary: &CaptureSummary, json: bool) -> Result<String> {
    if json {
        return Ok(serde_json::to_string_pretty(&summary.calibration)? + "\n");
    }
    let mut o = String::new();
    let c = &summary.calibration;
    let stats = c
        .capture
        .as_ref()
        .ok_or_else(|| anyhow!("capture summary missing"))?;
    writeln!(
        o,
        "wrote {} ({} samples, {:.1} s{}) and {}",
        summary.csv.display(),
        stats.samples,
        stats.duration_s,
        stats
            .mean_rate_hz
            .map(|r| format!(", {r:.1} Hz"))
            .unwrap_or_default(),
        summary.cal_file.display()
    )?;
    for f in std::iter::once(&c.wiimote).chain(c.nunchuk.as_ref()) {
        match (&f.zero, &f.counts_per_g) {
            (Some(z), Some(s)) => writeln!(
                o,
                "  {} factory calibration: zero {:?}, counts per g {:?} ({} copy)",
                f.device,
                z,
                s,
                f.copy_used.as_deref().unwrap_or("-")
            )?,
            _ => writeln!(o, "  {} factory calibration: no valid copy", f.device)?,
        }
    }
    if !stats.poses.is_empty() {
        writeln!(o, "  poses: {}", stats.poses.len())?;
        for p in &stats.poses {
            writeln!(
                o,
                "    {:>2}: t {:>7.2}–{:>7.2} s  mean {:?}",
                p.pose,
                p.t_start,
                p.t_end,
                p.mean[0].map(|v| (v * 10.0).round() / 10.0)
            )?;
        }
    }
    if stats.bad_reports + stats.unknown_reports > 0 {
        writeln!(
            o,
            "  skipped reports: {} malformed, {} unknown",
            stats.bad_reports, stats.unknown_reports
        )?;
    }
    Ok(o)
}
