//! `wiical live`: a calibration watched in the browser while it happens.

use super::{load, load_options, positive_finite, rate_hz};
use crate::live::{source, LiveServer, Shared};
use anyhow::{bail, Result};
use std::io::Write;
use std::net::{IpAddr, Ipv4Addr};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use wiical_analysis::input::columns::Sensor;
use wiical_analysis::live::{LiveSensor, LiveSession, Snapshot};

/// Fastest replay (`--speed`).
const MAX_SPEED: f64 = 10_000.0;

/// Slowest replay (`--speed`): a thousandth of the recorded pace already turns a second of
/// recording into a quarter of an hour; slower would overflow the replay clock.
const MIN_SPEED: f64 = 0.001;

/// Arguments of `wiical live`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Replay this recording (any file `fit` reads) at its own pace: its time column, else
    /// its rate.
    #[arg(long, required_unless_present = "device", conflicts_with = "device")]
    pub replay: Option<PathBuf>,
    /// Stream an adapter's samples (its serial port, or the pty `wiical device-sim --pty`
    /// prints) until it stops answering.
    #[arg(long)]
    pub device: Option<String>,
    /// Replay this many times faster than recorded (0.001 ≤ X ≤ 10000).
    #[arg(long, default_value_t = 1.0, value_parser = speed)]
    pub speed: f64,
    /// HTTP port (0: any free port; the one chosen is printed), or ADDR:PORT.
    #[arg(long, default_value = "8765")]
    pub port: String,
    /// Listen on this address even if it is not the loopback (anyone on that network can
    /// then watch). Without it only 127.0.0.1 / ::1 are accepted.
    #[arg(long)]
    pub bind: Option<IpAddr>,
    /// acc (poses, fit, verdict) | mag (points, ellipsoid fit error). Default: mag when the
    /// file's columns name a magnetometer (mx,my,mz), else acc.
    #[arg(long, value_parser = ["acc", "mag"])]
    pub sensor: Option<String>,
    /// Header names of the x,y,z columns to use.
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0, value_parser = rate_hz, allow_negative_numbers = true)]
    pub rate_hz: f64,
}

fn speed(s: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    if !(MIN_SPEED..=MAX_SPEED).contains(&v) {
        return Err(format!(
            "'{s}': give a speed from {MIN_SPEED} to {MAX_SPEED}"
        ));
    }
    Ok(v)
}

/// The address and port `--port` / `--bind` ask for, and whether a non-loopback address
/// was asked for explicitly.
fn listen_addr(a: &Args) -> Result<(IpAddr, u16, bool)> {
    parse_listen(&a.port, a.bind, ["--port", "--bind"])
}

/// The address and port a port flag (`PORT` or `ADDR:PORT`) and a bind flag ask for, and
/// whether a non-loopback address was asked for explicitly; `flags` names the two flags in
/// messages.
pub(crate) fn parse_listen(
    port_arg: &str,
    bind: Option<IpAddr>,
    flags: [&str; 2],
) -> Result<(IpAddr, u16, bool)> {
    let [port_flag, bind_flag] = flags;
    let (host, port) = match port_arg.rsplit_once(':') {
        Some((h, p)) => (Some(h.trim_matches(['[', ']'])), p),
        None => (None, port_arg),
    };
    let Ok(port) = port.parse::<u16>() else {
        bail!("{port_flag} {port_arg}: not a port number (0 to 65535, or ADDR:PORT)");
    };
    let from_port = match host {
        Some(h) => match h.parse::<IpAddr>() {
            Ok(ip) => Some(ip),
            Err(_) => bail!("{port_flag} {port_arg}: {h} is not an IP address"),
        },
        None => None,
    };
    match (from_port, bind) {
        (Some(p), Some(b)) if p != b => {
            bail!("{port_flag} names {p} and {bind_flag} {b}: give the address once")
        }
        (_, Some(b)) => Ok((b, port, true)),
        (Some(p), None) => Ok((p, port, false)),
        (None, None) => Ok((IpAddr::V4(Ipv4Addr::LOCALHOST), port, false)),
    }
}

/// The source thread's work: it publishes to the shared state and returns the last snapshot.
type SourceFn = Box<dyn FnOnce(&Arc<Shared>) -> Option<Snapshot> + Send>;

/// The replay source for `--replay FILE` and what to print about it.
fn replay_source(a: &Args, file: &Path) -> Result<(SourceFn, String)> {
    let mag_asked = a.sensor.as_deref() == Some("mag");
    let opts = wiical_analysis::LoadOptions {
        sensor: mag_asked.then_some(Sensor::Magnetometer),
        ..load_options(a.columns.as_deref(), &a.read)?
    };
    let rec = load(file, &opts)?;
    let names_mag = rec
        .axis_columns
        .iter()
        .all(|c| c.to_ascii_lowercase().starts_with('m'));
    let sensor = match a.sensor.as_deref() {
        Some("mag") => LiveSensor::Magnetometer,
        Some(_) => LiveSensor::Accelerometer,
        None if names_mag => LiveSensor::Magnetometer,
        None => LiveSensor::Accelerometer,
    };
    let rate = rec.estimated_rate_hz().unwrap_or(a.rate_hz);
    let session = LiveSession::new(sensor, rate, rec.is_integer())
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let what = format!(
        "replaying {} at {}x, {} samples at {rate:.1} Hz",
        file.display(),
        a.speed,
        rec.len()
    );
    let speed = a.speed;
    let times = rec.times(rate);
    let run: SourceFn =
        Box::new(move |shared| Some(source::replay(&rec, &times, speed, session, shared)));
    Ok((run, what))
}

/// One line about how the session ended.
fn summary(source: &str, snap: &Snapshot) -> String {
    let end = snap.ended.as_deref().unwrap_or("source ended");
    match (&snap.mag, &snap.fit) {
        (Some(m), _) => format!(
            "{end} ({source}): {} magnetometer points; ellipsoid fit error {}",
            m.points,
            m.fit_error_pct
                .map_or_else(|| "unknown".to_string(), |e| format!("{e:.2} %"))
        ),
        (None, Some(f)) => format!("{end} ({source}): {} poses; {}", snap.pose_count, f.line),
        (None, None) => format!(
            "{end} ({source}): {} poses; no fit: {}",
            snap.pose_count,
            snap.fit_note.as_deref().unwrap_or("too few poses")
        ),
    }
}

/// Runs `wiical live`: prints the address, runs the source, serves until interrupted.
pub fn run(a: &Args) -> Result<String> {
    let (ip, port, allow_remote) = listen_addr(a)?;
    let (run_source, what, name): (SourceFn, String, String) = match (&a.replay, &a.device) {
        (Some(file), _) => {
            let (f, what) = replay_source(a, file)?;
            (f, what, file.display().to_string())
        }
        (None, Some(dev)) => {
            // Refused before the page is served: a port that is missing or not a serial
            // port would otherwise leave an empty page up until Ctrl-C.
            let probe = wiical_client::Device::connect(dev, Default::default());
            drop(probe.map_err(|e| anyhow::anyhow!("--device: {e}"))?);
            let dev2 = dev.clone();
            let f: SourceFn = Box::new(move |shared| source::device(&dev2, shared));
            (f, format!("streaming {dev}"), dev.clone())
        }
        (None, None) => bail!("give --replay FILE or --device PORT"),
    };
    let server = LiveServer::bind(ip, port, allow_remote)?;
    let shared = Arc::new(Shared::default());
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "wiical live: http://{}/ ({what}; Ctrl-C stops)",
        server.addr()
    )?;
    out.flush()?;
    drop(out);
    let shared2 = shared.clone();
    std::thread::spawn(move || {
        if let Some(snap) = run_source(&shared2) {
            println!("{}", summary(&name, &snap));
        }
    });
    server
        .serve(&shared)
        .map_err(|e| anyhow::anyhow!("the live view's server could not start: {e}"))?;
    Ok(String::new())
}
