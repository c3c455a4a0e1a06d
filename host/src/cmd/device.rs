//! `wiical device …`: the command line of the adapter client ([`crate::client`]).

use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::PathBuf;
use std::time::Duration;

use crate::cli_error::cli_error;
use crate::client::{same_bits, ClientOptions, Device};
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use wiical_analysis::calfile;
use wiical_core::Calibration;
use wiical_wire::{
    AdapterStatus, Sample, SelfCalOutcome, SelfCalPhase, PROTOCOL_VERSION, SCHEMA_KEY,
};

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
    /// Upload a calibration (JSON from `wiical fit --out`) and verify it; with `--commit`
    /// also make it live and store it. Without `--commit` the adapter discards the upload
    /// when this command closes the port (a staged calibration belongs to its session).
    Put {
        /// Calibration JSON.
        file: PathBuf,
        /// Commit in the same session.
        #[arg(long)]
        commit: bool,
    },
    /// Upload FILE, verify it and make it live and stored, in one session.
    Commit {
        /// Calibration JSON.
        file: PathBuf,
    },
    /// The adapter's self-calibration (C + Z held at plug-in): progress, last result, and
    /// the stale-calibration estimate from still moments during play.
    SelfcalStatus,
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

/// Upload `file` and read it back: the staged copy must be bit-identical.
fn put_verified(dev: &mut Device, file: &std::path::Path) -> Result<Calibration> {
    let cal = calfile::read_calibration(file).map_err(cli_error)?;
    dev.put_calibration(&cal)?;
    let s = dev.get_calibration()?;
    let ok = s
        .staged
        .map(|w| same_bits(&w, &cal.into()))
        .unwrap_or(false);
    if !ok {
        bail!("the calibration read back from the adapter differs from the one sent");
    }
    Ok(cal)
}

fn phase_text(p: SelfCalPhase) -> &'static str {
    match p {
        SelfCalPhase::Off => "not running",
        SelfCalPhase::Arming => "arming (C + Z held after plug-in)",
        SelfCalPhase::WaitingForStillness => "running: hold still in a new orientation",
        SelfCalPhase::PoseTaken => "running: pose taken",
        SelfCalPhase::MoveToNewOrientation => "running: orientation already taken, move on",
        SelfCalPhase::Committing => "storing the new calibration",
        SelfCalPhase::Done => "done",
        SelfCalPhase::Failed => "failed",
    }
}

fn fmt_stale(o: &mut String, st: &AdapterStatus) -> Result<()> {
    if st.stale_moments == 0 {
        writeln!(o, "  stale-calibration monitor: no still moment seen yet")?;
    } else {
        writeln!(
            o,
            "  stale-calibration monitor: ‖a‖ − 1 g RMS {:.1} mg over {} still moments{}",
            st.stale_rms_mg,
            st.stale_moments,
            if st.recalibration_suggested {
                ": recalibration suggested"
            } else {
                ""
            }
        )?;
    }
    Ok(())
}

fn fmt_status(o: &mut String, st: &AdapterStatus) -> Result<()> {
    writeln!(o, "self-calibration: {}", phase_text(st.phase))?;
    writeln!(o, "  poses taken: {}", st.poses)?;
    match &st.last_result {
        None => writeln!(o, "  last result: none since power-up")?,
        Some(SelfCalOutcome::Done { rms_mg, poses }) => writeln!(
            o,
            "  last result: done, {poses} poses, fit RMS {rms_mg:.2} mg (stored and live)"
        )?,
        Some(SelfCalOutcome::Failed { message }) => writeln!(
            o,
            "  last result: failed, {message}; the previous calibration is kept"
        )?,
    }
    fmt_stale(o, st)
}

fn selfcal_json(port: &str, st: &AdapterStatus) -> serde_json::Value {
    let last = match &st.last_result {
        None => serde_json::Value::Null,
        Some(SelfCalOutcome::Done { rms_mg, poses }) => {
            serde_json::json!({"ok": true, "rms_mg": rms_mg, "poses": poses})
        }
        Some(SelfCalOutcome::Failed { message }) => {
            serde_json::json!({"ok": false, "message": message.as_str()})
        }
    };
    serde_json::json!({
        "port": port,
        "phase": format!("{:?}", st.phase),
        "poses": st.poses,
        "last_result": last,
        "stale_moments": st.stale_moments,
        "stale_rms_mg": st.stale_rms_mg,
        "recalibration_suggested": st.recalibration_suggested,
    })
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
            let st = dev.status()?;
            fmt_stale(&mut o, &st)?;
        }
        DeviceAction::Get { out: file } => {
            let s = dev.get_calibration()?;
            let live = Calibration::from(s.live);
            if let Some(path) = file {
                calfile::write_calibration_unchecked(path, &live).map_err(cli_error)?;
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
                Some(c) => fmt_cal(&mut o, "staged in this session (not live):", c)?,
                None => writeln!(o, "nothing staged")?,
            }
        }
        DeviceAction::Put {
            file,
            commit: false,
        } => {
            let cal = put_verified(&mut dev, file)?;
            if args.json {
                return json(&serde_json::json!({
                    "port": port, "staged": true, "verified": true, "calibration": cal
                }));
            }
            writeln!(
                o,
                "staged {} on {} (verified bit for bit) for this session only: the adapter \
                 discards it when the port closes. `wiical device commit {} --port {}` uploads \
                 and commits it in one go",
                file.display(),
                port,
                file.display(),
                port
            )?;
        }
        DeviceAction::Put { file, commit: true } | DeviceAction::Commit { file } => {
            put_verified(&mut dev, file)?;
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
        DeviceAction::SelfcalStatus => {
            let st = dev.status()?;
            if args.json {
                return json(&selfcal_json(port, &st));
            }
            fmt_status(&mut o, &st)?;
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
