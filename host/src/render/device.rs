//! The text `wiical device …` prints: calibrations, the adapter's identity and its
//! self-calibration and background recalibration status. The numbers come from the adapter's
//! answers.

use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;
use wiical_core::Calibration;
use wiical_wire::{
    AdapterStatus, BackgroundPhase, BackgroundReport, BackgroundSettings, BootRecord,
    CalibrationOrigin, CoverageGapReport, RefusalReport, SelfCalOutcome, SelfCalPhase,
};

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

/// One refusal of the background recalibration, in a sentence with its numbers.
pub fn refusal_text(r: &RefusalReport) -> String {
    match r {
        RefusalReport::Coverage(g) => format!("the still moments do not cover the sphere: {}", gap_text(g)),
        RefusalReport::TooFewHeldOut { needed, got } => {
            format!("{got} held-out bins, {needed} needed to judge a candidate")
        }
        RefusalReport::Fit => "the fit failed (the bins do not determine the parameters)".into(),
        RefusalReport::Implausible => "the candidate failed the acceptance limits".into(),
        RefusalReport::NotBetter { candidate_mg, live_mg } => format!(
            "the candidate ({candidate_mg:.2} mg held out) is not better than the live calibration ({live_mg:.2} mg) by the margin"
        ),
        RefusalReport::MonitorOnly { candidate_mg, live_mg } => format!(
            "a better candidate ({candidate_mg:.2} mg held out vs {live_mg:.2} mg live) was not adopted: adoption is off"
        ),
        RefusalReport::HostCalibration => {
            "a better candidate was not adopted: the live calibration was uploaded by the host (selfcal-set --replace-uploaded yes allows it)".into()
        }
        RefusalReport::Budget { wait_s } => {
            format!("a better candidate waits for the flash-write budget: {wait_s} s of play")
        }
        RefusalReport::UnsupportedLive => {
            "the live calibration has terms the background fit cannot keep".into()
        }
        RefusalReport::Interrupted => {
            "the fit was interrupted (new calibration, unplug or self-calibration)".into()
        }
        RefusalReport::Storage => "storing the adopted calibration failed; the old one is live".into(),
    }
}

fn gap_text(g: &CoverageGapReport) -> String {
    match g {
        CoverageGapReport::TooFewBins { needed, got } => format!("{got} of {needed} bins"),
        CoverageGapReport::MissingDirection { axis, positive } => format!(
            "the {}{} side was never met",
            if *positive { "+" } else { "−" },
            ["x", "y", "z"].get(usize::from(*axis)).unwrap_or(&"?")
        ),
        CoverageGapReport::Flat => "the orientations lie nearly in one plane".into(),
        CoverageGapReport::BadDirection => "a still moment had no finite direction".into(),
    }
}

fn origin_text(o: CalibrationOrigin) -> &'static str {
    match o {
        CalibrationOrigin::Factory => "the Nunchuk's own (no calibration stored)",
        CalibrationOrigin::SelfCal => "the adapter's self-calibration (C + Z)",
        CalibrationOrigin::Background => "the background recalibration",
        CalibrationOrigin::Host => "uploaded by the host (or of unknown origin)",
    }
}

/// The flash-write budget and the fit interval, in a sentence.
pub fn budget_text(s: &BackgroundSettings) -> String {
    format!(
        "at most one commit per {} s of play and {} per 24 h of play; a fit every {} s of play",
        s.commit_interval_s,
        s.commits_per_day,
        f64::from(s.fit_interval_ms) / 1000.0
    )
}

/// The background recalibration (`device selfcal-status`): one row per fact.
pub fn fmt_background(o: &mut String, b: &BackgroundReport) -> Result<()> {
    let phase = match b.phase {
        BackgroundPhase::Collecting => "collecting still moments",
        BackgroundPhase::Fitting => "fitting",
        BackgroundPhase::Committing => "storing an adopted calibration",
        BackgroundPhase::Invalid => "off (invalid detector settings)",
    };
    let row = |o: &mut String, k: &str, v: &str| writeln!(o, "  {k:<18} {v}");
    writeln!(o, "background recalibration:")?;
    row(o, "state", phase)?;
    let adoption = match (b.settings.adopt, b.settings.replace_uploaded) {
        (false, _) => "off (monitor only)",
        (true, false) => "on; a host upload is kept",
        (true, true) => "on; may replace a host upload",
    };
    row(o, "adoption", adoption)?;
    row(o, "budget", &budget_text(&b.settings))?;
    row(o, "live calibration", origin_text(b.origin))?;
    row(o, "play time", &format!("{} s since power-up", b.play_s))?;
    let bins = format!(
        "{} in {} of {} bins (fresh)",
        b.moments,
        b.bins_filled,
        b.bin_moments.len()
    );
    row(o, "still moments", &bins)?;
    let coverage = match (&b.coverage_gap, &b.candidate) {
        (Some(g), _) => gap_text(g),
        (None, Some(_)) => "covered".into(),
        (None, None) => "not judged yet (first attempt after a minute of play)".into(),
    };
    row(o, "coverage", &coverage)?;
    let t = b
        .temperature_c
        .map_or("not measured".into(), |t| format!("{t:.1} °C"));
    row(o, "temperature", &t)?;
    let candidate = b.candidate.map_or("none yet".into(), |c| {
        format!(
            "{:.2} mg under the candidate vs {:.2} mg live ({}{}; {} + {} held-out bins)",
            c.candidate_mg,
            c.live_mg,
            if c.full_model {
                "full 9 parameters"
            } else {
                "bias + scale"
            },
            if c.temperature {
                " + temperature slope"
            } else {
                ""
            },
            c.training_bins,
            c.heldout_bins
        )
    });
    row(o, "held-out error", &candidate)?;
    let adoption = b.last_adoption.map_or("none since power-up".into(), |a| {
        format!(
            "at {} s of play: {:.2} → {:.2} mg held out",
            a.at_s, a.before_mg, a.after_mg
        )
    });
    row(o, "last adoption", &adoption)?;
    let refusal = b.last_refusal.as_ref().map_or("none".into(), refusal_text);
    row(o, "last refusal", &refusal)?;
    Ok(())
}

/// What the adapter found in storage at boot, as JSON text.
pub fn boot_word(b: &BootRecord) -> String {
    match b {
        BootRecord::Empty => "empty".into(),
        BootRecord::Loaded => "loaded".into(),
        BootRecord::Rejected(p) => format!("rejected: {}", p.description()),
        BootRecord::StorageError => "storage error".into(),
    }
}
