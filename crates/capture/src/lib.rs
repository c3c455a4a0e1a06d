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
pub mod hid;
pub mod io;
pub mod motionplus;
pub mod output;
pub mod replay;
pub mod session;

use anyhow::{bail, Context, Result};
use guided::{Guided, GuidedConfig, GuidedEvent, PoseRecord};
use hid::{parse_input, InputReport, ReportError, MAX_INPUT_LEN};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use io::WiimoteIo;
use output::{cal_path, CalFile, CaptureStats, CsvOut};
use serde::Serialize;
use session::{is_nunchuk_id, DeviceSetup, Session};
use std::io::{BufWriter, IsTerminal};
use std::path::PathBuf;
use std::time::Duration;
use wiical_extbus::motionplus::{Frame, MotionPlusReport, PassthroughMode};
use wiical_io::write::PendingFile;

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
    /// Called with every recorded sample (before [`CaptureUi::progress`]): its time (s since
    /// the first sample, host clock) and the raw counts of the remote and of the Nunchuk
    /// (when plugged in). `wiical capture --live` feeds its live view from here.
    fn sample(&mut self, _t: f64, _remote: [u16; 3], _nunchuk: Option<[u16; 3]>) {}
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
    // The CSV goes to a temporary file next to OUT; OUT and its side file are only replaced
    // when the capture succeeds (see `finish_failed`).
    let pending = PendingFile::create(&opts.out)?;
    let file = pending
        .file()
        .try_clone()
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
        stats: empty_stats(&opts.mode),
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
    let failure = match (result, flushed) {
        (Err(e), _) => Some(e),
        (Ok(()), Err(e)) => Some(e.context(format!("cannot write {}", opts.out.display()))),
        (Ok(()), Ok(())) => None,
    };
    if let Some(e) = failure {
        let kept = finish_failed(pending, &cal, &cal_file)?;
        return Err(e.context(format!("capture stopped after {n} samples; {kept}")));
    }
    pending.commit()?;
    cal.write(&cal_file)?;
    Ok(CaptureSummary {
        csv: opts.out.clone(),
        cal_file,
        calibration: cal,
    })
}

/// The statistics of a capture that has not recorded anything yet.
fn empty_stats(mode: &CaptureMode) -> CaptureStats {
    CaptureStats {
        mode: match mode {
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
    }
}

/// After a failed capture: existing files are never replaced. If neither OUT nor its side
/// file existed, the samples so far become OUT (nothing is lost by that); otherwise they are
/// kept under the temporary name next to it. Returns the sentence saying where they are.
fn finish_failed(
    pending: PendingFile,
    cal: &CalFile,
    cal_file: &std::path::Path,
) -> Result<String> {
    let out = pending.path().to_path_buf();
    if !pending.target_existed() && !cal_file.exists() {
        pending.commit()?;
        cal.write(cal_file)?;
        return Ok(format!(
            "they are in {} (side file {})",
            out.display(),
            cal_file.display()
        ));
    }
    let kept = pending.keep_aside()?;
    let kept_cal = cal_path(&kept);
    cal.write(&kept_cal)?;
    Ok(format!(
        "{} and its side file were left untouched; the samples are in {} (side file {})",
        out.display(),
        kept.display(),
        kept_cal.display()
    ))
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
            hid::hex(&setup.motionplus.as_ref().map(|m| m.id).unwrap_or_default()),
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

/// What one input report means for the recording.
enum Incoming {
    /// A data report: the remote's accelerometer, the Nunchuk's (if any) and the gyro's.
    Sample([u16; 3], Option<[u16; 3]>, Option<MotionPlusReport>),
    /// An unrequested status report: the extension is (dis)connected.
    Status(bool),
    /// Nothing to record (read replies, acks, reports without accelerometer data).
    Nothing,
}

/// The recording's clock: the host's time of the first sample (t = 0), of the last data
/// report (for the silence timeout) and of the last flush.
struct Clock {
    t_first: Option<f64>,
    last_data: f64,
    last_flush: f64,
}

impl<D: WiimoteIo + ?Sized> Recorder<'_, '_, D> {
    fn run<W: std::io::Write>(
        &mut self,
        csv: &mut CsvOut<W>,
        ui: &mut dyn CaptureUi,
    ) -> Result<()> {
        let mut guided = self.start(csv.has_ext(), ui)?;
        let mut buf = [0u8; MAX_INPUT_LEN + 10];
        let start = self.session.io().now_s();
        let mut clock = Clock {
            t_first: None,
            last_data: start,
            last_flush: start,
        };
        let mut bad_in_a_row = 0u32;
        loop {
            let Some((now, incoming)) = self.next_report(&mut buf, &mut bad_in_a_row, &clock)?
            else {
                continue;
            };
            let (accel, nunchuk, gyro) = match incoming {
                Incoming::Sample(a, n, g) => (a, n, g),
                Incoming::Status(connected) => {
                    self.stats.status_reports += 1;
                    let t = clock.t_first.map(|t0| now - t0).unwrap_or(0.0);
                    self.on_status(connected, t, csv, ui)?;
                    clock.last_data = self.session.io().now_s();
                    continue;
                }
                Incoming::Nothing => continue,
            };
            clock.last_data = now;
            let t = now - *clock.t_first.get_or_insert(now);
            let ext = if self.ext_present { nunchuk } else { None };
            csv.row(t, accel, ext, gyro.as_ref())?;
            ui.sample(t, accel, ext);
            self.stats.samples += 1;
            self.stats.duration_s = t;
            if now - clock.last_flush > 1.0 {
                csv.flush()?;
                clock.last_flush = now;
            }
            if self.after_sample(t, accel, ext, guided.as_mut(), csv.has_ext(), ui)? {
                return Ok(());
            }
        }
    }

    /// Says what is about to happen and, in guided mode, starts the pose guide.
    fn start(&self, has_ext: bool, ui: &mut dyn CaptureUi) -> Result<Option<Guided>> {
        match &self.opts.mode {
            CaptureMode::Guided(cfg) => {
                let mut quantum = vec![[1.0, 2.0, 2.0]];
                if has_ext {
                    quantum.push([1.0, 1.0, 1.0]);
                }
                ui.message(&format!(
                    "guided capture of {} poses: lay the remote{} still for {} s to start",
                    cfg.poses,
                    if has_ext { " and the Nunchuk" } else { "" },
                    cfg.init_s
                ));
                Ok(Some(Guided::new(cfg.clone(), quantum)?))
            }
            CaptureMode::Duration(d) => {
                ui.message(&format!("recording {d} s to {}", self.opts.out.display()));
                Ok(None)
            }
        }
    }

    /// Reads and decodes the next input report (`None`: nothing arrived within 200 ms, or
    /// an unknown or malformed report was skipped and counted). Fails after
    /// `silence_timeout_s` without data, or after [`MAX_BAD_IN_A_ROW`] malformed reports.
    fn next_report(
        &mut self,
        buf: &mut [u8],
        bad_in_a_row: &mut u32,
        clock: &Clock,
    ) -> Result<Option<(f64, Incoming)>> {
        let n = self.session.io().read_timeout(buf, 200)?;
        let now = self.session.io().now_s();
        if n == 0 {
            if now - clock.last_data > self.opts.silence_timeout_s {
                bail!(
                    "no data report from the Wii Remote for {} s (out of range, batteries, or switched off?)",
                    self.opts.silence_timeout_s
                );
            }
            return Ok(None);
        }
        let report = match parse_input(buf.get(..n).unwrap_or(buf)) {
            Ok(r) => r,
            Err(ReportError::Unknown(_)) => {
                self.session.unknown_reports += 1;
                return Ok(None);
            }
            Err(e) => {
                self.stats.bad_reports += 1;
                *bad_in_a_row += 1;
                if *bad_in_a_row >= MAX_BAD_IN_A_ROW {
                    bail!("the Wii Remote sends malformed reports ({MAX_BAD_IN_A_ROW} in a row; last: {e})");
                }
                return Ok(None);
            }
        };
        *bad_in_a_row = 0;
        let incoming = match report {
            InputReport::Data(core) => match (core.accel, &self.setup.motionplus) {
                (Some(a), Some(mp)) => {
                    let (n, g) = split_motionplus_frame(core.ext, mp.mode);
                    Incoming::Sample(a, n, g)
                }
                (Some(a), None) => Incoming::Sample(a, core.nunchuk().map(|n| n.accel), None),
                (None, _) => Incoming::Nothing,
            },
            InputReport::Status(s) => Incoming::Status(s.extension_connected()),
            InputReport::ReadReply(_) | InputReport::Ack(_) => Incoming::Nothing,
        };
        Ok(Some((now, incoming)))
    }

    /// Feeds a recorded sample to the pose guide (if any) and shows the progress; true when
    /// the capture is complete (all poses taken, or the duration reached).
    fn after_sample(
        &mut self,
        t: f64,
        accel: [u16; 3],
        ext: Option<[u16; 3]>,
        guided: Option<&mut Guided>,
        has_ext: bool,
        ui: &mut dyn CaptureUi,
    ) -> Result<bool> {
        let prompt = match guided {
            Some(g) => {
                let mut devs = vec![accel.map(f64::from)];
                if has_ext {
                    // An unplugged Nunchuk holds its last reading for the stillness test.
                    if let Some(e) = ext {
                        self.last_ext = e.map(f64::from);
                    }
                    devs.push(self.last_ext);
                }
                for ev in g.push(t, &devs)? {
                    self.on_guided(&ev, ui);
                }
                self.stats.poses = g.poses().to_vec();
                if g.finished() {
                    return Ok(true);
                }
                g.prompt()
            }
            None => String::new(),
        };
        ui.progress(self.stats.samples, t, &prompt);
        Ok(matches!(self.opts.mode, CaptureMode::Duration(d) if t >= d))
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
