//! The text (or JSON) `wiical capture` prints after a capture.

use anyhow::{anyhow, Result};
use std::fmt::Write as _;
use wiical_capture::CaptureSummary;

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
