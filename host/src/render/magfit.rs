//! `wiical magfit`: the residual loop's text after the fit's table — noise floor, base →
//! final, effects with their evidence, the detection limit of every candidate not accepted,
//! and the verdict with its reasons.

use std::fmt::Write as _;
use wiical_analysis::magnetometer::MagAnalysis;

fn cv(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.4e}"))
}

/// The loop's report in words; `unit` is the field's (raw counts when the file states none).
pub fn analysis_text(a: &MagAnalysis, unit: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "  noise floor (short-term scatter about the track, along the radius): {:.4e} {unit}",
        a.noise_floor
    );
    let _ = writeln!(
        o,
        "  residual RMS {:.4e} {unit}, held out (10 time blocks) {} → after effects {:.4e}, held out {}",
        a.base.rms,
        cv(a.base.cv_rms),
        a.final_model.rms,
        cv(a.final_model.cv_rms)
    );
    if a.effects.is_empty() {
        let _ = writeln!(o, "  effects: none accepted");
    }
    for e in &a.effects {
        let _ = writeln!(o, "  effect {}: {}", e.name, e.evidence);
    }
    if let Some(last) = a.steps.last().filter(|s| s.accepted.is_none()) {
        for c in &last.candidates {
            if let Some(l) = c.detection_limit {
                let _ = writeln!(
                    o,
                    "  no {} above {l:.3e} {} ({})",
                    c.name, c.detection_unit, c.note
                );
            }
        }
    }
    for d in &a.diagnostics {
        let _ = writeln!(o, "  {d}");
    }
    let _ = writeln!(o, "verdict: {}", a.verdict);
    for r in &a.reasons {
        let _ = writeln!(o, "  {r}");
    }
    o
}
