//! The text `wiical device …` prints: calibrations, the adapter's identity and its
//! self-calibration status. The numbers come from the adapter's answers.

use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;
use wiical_core::Calibration;
use wiical_wire::{AdapterStatus, SelfCalOutcome, SelfCalPhase};

/// A calibration under a title: bias and `K = D⁻¹` (g per count, shown ×1e-3).
pub fn fmt_cal(o: &mut String, title: &str, c: &Calibration) -> Result<()> {
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

/// Which terms the adapter applies (`device put` / `commit`): one line for the
/// terms applied on the device, one for those kept in the file for hosts (if any).
pub fn fmt_terms(o: &mut String, t: &wiical_analysis::output::calfile::AdapterTerms) -> Result<()> {
    writeln!(o, "  applied by the adapter: {}", t.applied.join(", "))?;
    if !t.host_only.is_empty() {
        writeln!(
            o,
            "  stays in the file for hosts with a clock and a thermometer, not applied by the adapter: {}",
            t.host_only.join(", ")
        )?;
    }
    Ok(())
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

/// The stale-calibration monitor's line.
pub fn fmt_stale(o: &mut String, st: &AdapterStatus) -> Result<()> {
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

/// Self-calibration phase, pose count, last result and the stale-calibration line.
pub fn fmt_status(o: &mut String, st: &AdapterStatus) -> Result<()> {
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

/// The adapter's identity and protocol (`device info`).
pub fn fmt_info(o: &mut String, info: &InfoText<'_>) -> Result<()> {
    writeln!(o, "adapter on {}", info.port)?;
    writeln!(o, "  firmware:  {}", info.firmware_version)?;
    writeln!(o, "  device id: {}", info.device_id)?;
    writeln!(
        o,
        "  protocol:  v{} (schema {}), host v{} (schema {}): compatible",
        info.protocol_version, info.schema_key, info.host_protocol_version, info.host_schema_key
    )?;
    Ok(())
}

/// What [`fmt_info`] shows (the fields of `device info --json`).
pub struct InfoText<'a> {
    /// Serial port.
    pub port: &'a str,
    /// Firmware version string.
    pub firmware_version: &'a str,
    /// Device ID, hex.
    pub device_id: &'a str,
    /// The adapter's protocol version.
    pub protocol_version: u16,
    /// The adapter's schema key, `0x…`.
    pub schema_key: &'a str,
    /// This build's protocol version.
    pub host_protocol_version: u16,
    /// This build's schema key, `0x…`.
    pub host_schema_key: &'a str,
}

/// `device get`: the live calibration (stored or pass-through) and the staged one, if any.
pub fn state_text(
    live: &Calibration,
    staged: Option<&Calibration>,
    stored: bool,
) -> Result<String> {
    let title = if stored {
        "live calibration (committed, stored on the adapter):"
    } else {
        "live calibration: none committed, pass-through (the Nunchuk's factory calibration):"
    };
    let mut o = String::new();
    fmt_cal(&mut o, title, live)?;
    match staged {
        Some(c) => fmt_cal(&mut o, "staged in this session (not live):", c)?,
        None => writeln!(o, "nothing staged")?,
    }
    Ok(o)
}

/// `device put` without `--commit`: what was staged, and that it lasts only this session.
pub fn staged_text(file: &Path, port: &str) -> String {
    format!(
        "staged {} on {} (verified bit for bit) for this session only: the adapter \
         discards it when the port closes. `wiical device commit {} --port {}` uploads \
         and commits it in one go\n",
        file.display(),
        port,
        file.display(),
        port
    )
}

/// `device commit` (or `put --commit`): the calibration is live and in flash.
pub fn committed_text(port: &str) -> String {
    format!("committed on {port}: the calibration is live and stored in the adapter's flash\n")
}
