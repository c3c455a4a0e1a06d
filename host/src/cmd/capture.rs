//! `wiical capture`: its arguments and run. The capture itself (start-up sequence, recording,
//! pose guide) is [`wiical_capture`]; the summary's text is [`crate::render::capture`].

use crate::cli_error::cli_error;
use crate::live::capture::LiveCaptureUi;
use crate::live::{LiveServer, ServeError, Shared};
use anyhow::{bail, Context, Result};
use std::io::BufWriter;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use wiical_analysis::output::write::PendingFile;
use wiical_capture::guided::GuidedConfig;
use wiical_capture::io::{self, WiimoteIo};
use wiical_capture::output::cal_path;
use wiical_capture::{capture, CaptureMode, CaptureOptions, CaptureSummary, CaptureUi, TerminalUi};

/// Arguments of `wiical capture`.
#[derive(clap::Args, Debug, Clone)]
pub struct CaptureArgs {
    /// Output CSV: t,x,y,z (+ ext_x,ext_y,ext_z with a Nunchuk, + gx,gy,gz and slow flags with a MotionPlus), raw counts; calibrations in OUT.cal.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Plain mode: record this many seconds.
    #[arg(long, default_value_t = 30.0, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub duration_s: f64,
    /// Guided mode: walk through N poses, each held still (for `wiical fit`: 9 or more).
    #[arg(long, value_name = "N", value_parser = clap::builder::TypedValueParser::map(clap::value_parser!(u16).range(1..=1000), usize::from))]
    pub guided: Option<usize>,
    /// Guided: how long each pose is held still, seconds.
    #[arg(long, default_value_t = 4.0, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub hold_s: f64,
    /// Guided: initial rest (noise reference), seconds.
    #[arg(long, default_value_t = 2.0, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub init_s: f64,
    /// Guided: still when the 0.5 s window variance ≤ THRESHOLD × rest variance.
    #[arg(long, default_value_t = 6.0, value_parser = super::threshold, allow_negative_numbers = true)]
    pub threshold: f64,
    /// Guided: give up when a pose is not held still (or no motion comes) within this time, s.
    #[arg(long, default_value_t = 60.0, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub still_timeout_s: f64,
    /// Fail when no data report arrives for this long, seconds.
    #[arg(long, default_value_t = 2.0, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub silence_timeout_s: f64,
    /// Also log every raw HID report (in and out, timestamped hex) to this file.
    #[arg(long)]
    pub raw_log: Option<PathBuf>,
    /// Replay a raw log written with --raw-log instead of opening a device.
    #[arg(long)]
    pub replay: Option<PathBuf>,
    /// With --replay: replay at this many times the logged pace (default: as fast as
    /// possible), e.g. to watch it with --live (a number above 0).
    #[arg(long, requires = "replay", value_parser = super::positive_finite)]
    pub replay_speed: Option<f64>,
    /// Print JSON (the side file's content) instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Watch the capture in the browser (the `wiical live` page, fed the remote's
    /// accelerometer while it records); after the capture the page stays up until Ctrl-C.
    #[arg(long)]
    pub live: bool,
    /// With --live: HTTP port (0: any free port; the one chosen is printed), or ADDR:PORT.
    #[arg(long, default_value = "8765", requires = "live")]
    pub live_port: String,
    /// With --live: listen on this address even if it is not the loopback (anyone on that
    /// network can then watch).
    #[arg(long, requires = "live")]
    pub live_bind: Option<std::net::IpAddr>,
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
            // Written like the CSV: replaced only when the capture succeeds; after a failure
            // a new log is kept (it shows what went wrong) but an existing one is not
            // replaced.
            let pending = PendingFile::create(path).map_err(cli_error)?;
            let f = pending
                .file()
                .try_clone()
                .with_context(|| format!("cannot create {}", path.display()))?;
            let mut logged = io::RawLogger::new(io, BufWriter::new(f))?;
            let r = capture(&mut logged, &opts, ui);
            logged.flush()?;
            drop(logged);
            if r.is_ok() || !pending.target_existed() {
                pending.commit().map_err(cli_error)?;
            } else {
                let kept = pending.keep_aside().map_err(cli_error)?;
                return r.with_context(|| {
                    format!(
                        "the raw log {} was left untouched; this session's log is in {}",
                        path.display(),
                        kept.display()
                    )
                });
            }
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
    // Outputs must differ from the replayed log and from each other (`--replay L --out L`
    // would replace the session log), checked before anything is opened.
    let cal_file = cal_path(&args.out);
    let inputs: Vec<&std::path::Path> = args.replay.iter().map(|p| p.as_path()).collect();
    let mut outputs = vec![args.out.as_path(), cal_file.as_path()];
    outputs.extend(args.raw_log.as_deref());
    wiical_analysis::output::write::check_outputs(&inputs, &outputs).map_err(cli_error)?;
    let mut ui = TerminalUi::new();
    if args.live {
        return run_live(args, &mut ui);
    }
    let summary = open_and_run(args, &mut ui)?;
    crate::render::capture::render(&summary, args.json)
}

fn open_and_run(args: &CaptureArgs, ui: &mut dyn CaptureUi) -> Result<CaptureSummary> {
    match &args.replay {
        Some(path) => {
            let log = io::LogReplay::load(path)?;
            match args.replay_speed {
                Some(speed) => run_on(log.paced(speed), args, ui),
                None => run_on(log, args, ui),
            }
        }
        None => run_on(io::open_wiimote()?, args, ui),
    }
}

/// `--live`: serves the live page (its address on stderr, before the device is opened),
/// captures through a [`LiveCaptureUi`], prints the summary, then serves until interrupted.
fn run_live(args: &CaptureArgs, ui: &mut dyn CaptureUi) -> Result<String> {
    let (ip, port, allow_remote) = crate::cmd::live::parse_listen(
        &args.live_port,
        args.live_bind,
        ["--live-port", "--live-bind"],
    )?;
    let server = match LiveServer::bind(ip, port, allow_remote) {
        Ok(s) => s,
        Err(ServeError::NotLocal { addr }) => bail!(
            "the live view listens on {addr} only when asked: anyone on that network could watch; give --live-bind {addr} to mean it"
        ),
        Err(e) => return Err(e.into()),
    };
    let addr = server.addr();
    let shared = Arc::new(Shared::default());
    let mut live_ui = LiveCaptureUi::new(ui, shared.clone())?;
    eprintln!("wiical capture: live view at http://{addr}/");
    let serving = shared.clone();
    let server_thread = std::thread::spawn(move || server.serve(&serving));
    let result = open_and_run(args, &mut live_ui);
    match &result {
        Ok(_) => live_ui.end("capture finished"),
        Err(e) => live_ui.end(&format!("capture failed: {e:#}")),
    }
    let text = crate::render::capture::render(&result?, args.json)?;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    drop(out);
    eprintln!("wiical capture: the live view stays at http://{addr}/ (Ctrl-C stops)");
    // The server serves until the process is interrupted; it returns only if its runtime
    // could not start, and a panic of its thread is this command's error, not lost.
    match server_thread.join() {
        Ok(Ok(())) => Ok(String::new()),
        Ok(Err(e)) => bail!("the live view's server stopped: {e}"),
        Err(_) => bail!("the live view's server thread panicked (its message is above)"),
    }
}
