//! `wiical device put/commit GYRO.json` and the gyro part of `device get` (issue 50 item 2):
//! the gyro file `gyrofit --out` writes, turned into the MotionPlus's count axes
//! ([`gyrocal::for_motionplus`]), judged by the core's MotionPlus limits
//! ([`Acceptance::check_gyro`], the ones the adapter applies) before the port is opened,
//! uploaded, read back bit for bit and, with a commit, stored beside the accelerometer's
//! calibration.
//!
//! `device put` tells a gyro file from an accelerometer file by its content: a JSON object
//! whose `format` starts with `wiical-gyro-calibration/` ([`is_gyro_file`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use wiical_analysis::input::bounded::{read_text, MAX_CALIBRATION_BYTES};
use wiical_analysis::output::gyrocal::{self, MotionPlusGyro};
use wiical_core::acceptance::Acceptance;
use wiical_wire::{BootRecord, ErrorCode, GyroCalibrationState, WireGyroCalibration};

use crate::cli_error::cli_error;
use crate::client::{same_gyro_bits, ClientError, Device};
use crate::cmd::to_json;

/// The names of the count axes, in report order.
const COUNT_AXES: [&str; 3] = ["yaw", "roll", "pitch"];

/// True when `path` holds a gyro calibration file (its `format` names one). A file that
/// cannot be read or parsed is not one: the accelerometer's reader then says why.
pub fn is_gyro_file(path: &Path) -> bool {
    read_text(path, MAX_CALIBRATION_BYTES)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v.get("format")?.as_str().map(str::to_owned))
        .is_some_and(|f| f.starts_with("wiical-gyro-calibration/"))
}

/// A gyro file read, converted and judged for upload.
#[derive(Debug, Clone)]
pub struct GyroPut {
    /// The file.
    pub file: PathBuf,
    /// The conversion to the count axes.
    pub motionplus: MotionPlusGyro,
}

/// Reads a gyro file for `device put`, converts it to the count axes, prints the warnings
/// (terms kept for hosts) and refuses (without `force`) one the core's MotionPlus limits
/// refuse, in one sentence naming the parameter.
pub fn checked_for_put(path: &Path, force: bool) -> Result<GyroPut> {
    let file = gyrocal::read_gyro_calibration(path).map_err(cli_error)?;
    let motionplus = match gyrocal::for_motionplus(&file.correction) {
        Ok(m) => m,
        Err(why) => bail!("refusing to upload {}: {why}", path.display()),
    };
    for name in &motionplus.host_only {
        eprintln!(
            "warning: {}: the adapter does not apply the {name} term (it needs the accelerometer fixed to the gyro, which is in the Wii Remote); it stays in the file for hosts and is not uploaded",
            path.display()
        );
    }
    if let Err(why) = Acceptance::motionplus().check_gyro(&motionplus.device) {
        let reason = format!(
            "not plausible for a MotionPlus: {why} (axes x, y, z are the count axes yaw, roll, pitch)"
        );
        if !force {
            bail!(
                "refusing to upload {}: {reason} (pass --force to upload anyway; the adapter refuses it too)",
                path.display()
            );
        }
        eprintln!(
            "warning: {}: uploading with --force although {reason}",
            path.display()
        );
    }
    Ok(GyroPut {
        file: path.to_path_buf(),
        motionplus,
    })
}

/// `device put GYRO.json [--commit]` / `device commit GYRO.json`: upload, read back bit for
/// bit, and with `commit` store and read back again.
pub fn put(dev: &mut Device, port: &str, g: &GyroPut, commit: bool, json: bool) -> Result<String> {
    let cal = g.motionplus.device;
    let sent = WireGyroCalibration::from(cal);
    dev.put_gyro_judged(&cal)?;
    let s = dev.get_gyro_calibration()?;
    if !s.staged.is_some_and(|w| same_gyro_bits(&w, &sent)) {
        bail!("the gyro calibration read back from the adapter differs from the one sent");
    }
    if commit {
        dev.commit_gyro()?;
        let s = dev.get_gyro_calibration()?;
        if !s.live.is_some_and(|w| same_gyro_bits(&w, &sent)) {
            bail!("the adapter acknowledged the gyro commit but its live gyro calibration differs from the one sent");
        }
    }
    if json {
        return to_json(&serde_json::json!({
            "port": port,
            "kind": "gyro",
            "staged": !commit,
            "committed": commit,
            "verified": true,
            "calibration": calibration_json(&sent),
            "count_axes_from": axes_json(&g.motionplus),
            "host_only_terms": g.motionplus.host_only,
        }));
    }
    let mut o = if commit {
        format!("committed the gyro calibration {} on {port}: it is live and stored in the adapter's flash beside the accelerometer's\n", g.file.display())
    } else {
        format!(
            "staged the gyro calibration {} on {port} (verified bit for bit) for this session only: the adapter discards it when the port closes. `wiical device commit {} --port {port}` uploads and commits it in one go\n",
            g.file.display(),
            g.file.display()
        )
    };
    fmt_axes(&mut o, &g.motionplus)?;
    fmt_gyro(&mut o, "uploaded:", &sent)?;
    if !g.motionplus.host_only.is_empty() {
        writeln!(
            o,
            "kept for hosts, not on the adapter: {}",
            g.motionplus.host_only.join(", ")
        )?;
    }
    Ok(o)
}

/// Which accelerometer axis each count axis measures, and the sign.
fn fmt_axes(o: &mut String, m: &MotionPlusGyro) -> Result<()> {
    let parts: Vec<String> = axes_json(m)
        .iter()
        .zip(COUNT_AXES)
        .map(|(from, count)| format!("{count} = {from}"))
        .collect();
    writeln!(
        o,
        "count axes from the file's accelerometer frame: {}",
        parts.join(", ")
    )?;
    Ok(())
}

/// `["-z", "+y", "-x"]`: the accelerometer axis (signed) each count axis measures.
fn axes_json(m: &MotionPlusGyro) -> Vec<String> {
    m.axes
        .iter()
        .map(|(a, s)| {
            format!(
                "{}{}",
                if *s < 0.0 { "-" } else { "+" },
                ["x", "y", "z"][*a]
            )
        })
        .collect()
}

/// A gyro calibration as JSON (count axes, units named).
fn calibration_json(w: &WireGyroCalibration) -> serde_json::Value {
    serde_json::json!({
        "axes": COUNT_AXES,
        "bias": w.bias,
        "matrix": w.matrix,
        "units": "rad/s per slow-range count",
    })
}

/// A gyro calibration under a title: bias (counts) and `K` (°/s per count, so that the
/// MotionPlus's ≈ 0.054 reads as a number).
fn fmt_gyro(o: &mut String, title: &str, w: &WireGyroCalibration) -> Result<()> {
    writeln!(o, "{title}")?;
    writeln!(
        o,
        "  bias b (slow counts; yaw, roll, pitch): {:>10.3} {:>10.3} {:>10.3}",
        w.bias[0], w.bias[1], w.bias[2]
    )?;
    writeln!(o, "  K (°/s per slow count, rows yaw, roll, pitch):")?;
    let deg = 180.0 / std::f32::consts::PI;
    for r in &w.matrix {
        writeln!(
            o,
            "    {:>12.7} {:>12.7} {:>12.7}",
            r[0] * deg,
            r[1] * deg,
            r[2] * deg
        )?;
    }
    Ok(())
}

/// The adapter's gyro calibration state; `None` from an adapter built without it (the RP2040
/// firmware, whose flash has no room for it, answers `UnsupportedRequest`).
pub fn state(dev: &mut Device) -> Result<Option<GyroCalibrationState>> {
    match dev.get_gyro_calibration() {
        Ok(s) => Ok(Some(s)),
        Err(ClientError::Refused {
            code: ErrorCode::UnsupportedRequest,
            ..
        }) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

/// True when `device get` has something to say about the gyro: a calibration live or staged,
/// or a gyro record refused at boot. Otherwise `get` prints what it printed before the gyro
/// calibration existed.
pub fn has_news(s: &GyroCalibrationState) -> bool {
    s.live.is_some()
        || s.staged.is_some()
        || matches!(s.boot, BootRecord::Rejected(_) | BootRecord::StorageError)
}

/// The gyro part of `device get`'s text.
pub fn state_text(s: &GyroCalibrationState) -> Result<String> {
    let mut o = String::new();
    match &s.live {
        Some(w) => fmt_gyro(
            &mut o,
            "live gyro calibration (MotionPlus, committed, stored on the adapter):",
            w,
        )?,
        None => writeln!(
            o,
            "live gyro calibration: none committed (the MotionPlus's rates pass through)"
        )?,
    }
    match &s.staged {
        Some(w) => fmt_gyro(
            &mut o,
            "gyro calibration staged in this session (not live):",
            w,
        )?,
        None => writeln!(o, "no gyro calibration staged")?,
    }
    match s.boot {
        BootRecord::Rejected(p) => writeln!(
            o,
            "warning: the adapter rejected its stored gyro calibration record at boot ({}): commit a gyro calibration again",
            p.description()
        )?,
        BootRecord::StorageError => writeln!(
            o,
            "warning: the adapter could not read its gyro calibration record at boot"
        )?,
        BootRecord::Empty | BootRecord::Loaded => {}
    }
    Ok(o)
}

/// The gyro part of `device get --json`.
pub fn state_json(s: &GyroCalibrationState) -> serde_json::Value {
    serde_json::json!({
        "live": s.live.as_ref().map(calibration_json),
        "staged": s.staged.as_ref().map(calibration_json),
        "boot": crate::render::device::boot_word(&s.boot),
    })
}
