//! `wiical device-sim`: its arguments and run. The simulated adapter itself is
//! [`wiical_device_sim`].

use anyhow::{bail, Result};
use std::io::{self, Write};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use wiical_device_sim::{spawn, SimExtension, SimFlash, SimMotion, SimOptions};

/// Arguments of `wiical device-sim`.
#[derive(clap::Args, Debug, Clone)]
pub struct SimArgs {
    /// Serve on a new pseudo-terminal and print its path (the only transport so far).
    #[arg(long)]
    pub pty: bool,
    /// Keep the simulated flash in this file (created if missing), so that a committed
    /// calibration survives a restart of the simulator.
    #[arg(long)]
    pub flash: Option<PathBuf>,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long, value_parser = super::duration_s, allow_negative_numbers = true)]
    pub seconds: Option<f64>,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// What the simulated Nunchuk does: sweep (turns continuously, never still) or poses (a
    /// calibration by hand: 18 orientations held 4 s each, smooth turns between, C + Z held
    /// at plug-in for the adapter's self-calibration; starts when a host opens the port).
    #[arg(long, value_enum, default_value_t = SimMotion::Sweep)]
    pub motion: SimMotion,
    /// The extension on the simulated adapter's bus: nunchuk (making --motion), or motionplus
    /// (a MotionPlus alone with a known truth, at rest then turned at 90 °/s yaw and −45 °/s
    /// pitch, at rest, then −600 °/s roll, every 12 s; its corrected rates stream for
    /// `wiical live` once a gyro calibration is committed).
    #[arg(long, value_enum, default_value_t = SimExtension::Nunchuk)]
    pub extension: SimExtension,
    /// Run the simulated clock this many times faster than real time (1 to 50): samples
    /// come that much more often, timed (by their sequence number) in simulated time.
    #[arg(long, default_value_t = 1.0, value_parser = time_scale)]
    pub time_scale: f64,
    /// Present this schema key (hex) instead of the real one, to see how hosts refuse it.
    #[arg(long, hide = true, value_parser = parse_hex_u32)]
    pub schema_key: Option<u32>,
}

/// Fastest simulated clock (`--time-scale`): 50 × 200 Hz = 10 000 samples a second.
const MAX_TIME_SCALE: f64 = 50.0;

fn time_scale(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (1.0..=MAX_TIME_SCALE).contains(&v) => Ok(v),
        _ => Err(format!("'{s}': a number from 1 to {MAX_TIME_SCALE}")),
    }
}

fn parse_hex_u32(s: &str) -> Result<u32, String> {
    let d = s.trim_start_matches("0x").trim_start_matches("0X");
    u32::from_str_radix(d, 16).map_err(|e| format!("'{s}': {e}"))
}

/// Run `wiical device-sim`: prints the pty path alone on the first line of stdout (so that
/// scripts can read it), then serves until interrupted or `--seconds` elapse.
pub fn run(args: &SimArgs) -> Result<String> {
    if !args.pty {
        bail!("only --pty is supported: `wiical device-sim --pty`");
    }
    let flash = match &args.flash {
        Some(p) => SimFlash::file(p)?,
        None => SimFlash::in_memory(),
    };
    let (path, handle) = spawn(SimOptions {
        flash,
        seed: args.seed,
        schema_key: args.schema_key,
        motion: args.motion,
        extension: args.extension,
        time_scale: args.time_scale,
        ..Default::default()
    })?;
    {
        let mut out = io::stdout().lock();
        writeln!(out, "{}", path.display())?;
        out.flush()?;
    }
    eprintln!(
        "wiical device-sim: simulated adapter on {} (flash: {}); try `wiical device info --port {}`",
        path.display(),
        args.flash
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "in memory".into()),
        path.display()
    );
    let started = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(50));
        if !handle.is_running() {
            break;
        }
        if let Some(s) = args.seconds {
            if started.elapsed().as_secs_f64() >= s {
                break;
            }
        }
    }
    let c = handle.counters();
    let summary = format!(
        "device-sim stopped after {:.1} s: {} requests, {} corrupt frames, {} samples\n",
        started.elapsed().as_secs_f64(),
        c.requests.load(Ordering::Relaxed),
        c.bad_frames.load(Ordering::Relaxed),
        c.samples.load(Ordering::Relaxed)
    );
    handle.stop()?;
    Ok(summary)
}
