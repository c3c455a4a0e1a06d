//! The readable report of `wiical gyrofit`.

use std::fmt::Write as _;
use wiical_analysis::gyro::GyroReport;

/// The readable report.
pub fn text(r: &GyroReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Gyro calibration (multi-position, Tedaldi et al. 2014), {file}\n{} static windows, {} motions, {:.1} Hz",
        r.static_windows, r.motions, r.sample_rate_hz
    );
    let _ = writeln!(
        o,
        "nominal sensitivity {} rad/s per count, from {}",
        r.nominal_rad_per_count
            .iter()
            .map(|v| format!("{v:.4e}"))
            .collect::<Vec<_>>()
            .join(" / "),
        r.nominal_source
    );
    let _ = writeln!(
        o,
        "\n{:<13} {:>6} {:>12} {:>14} {:>10}",
        "model", "params", "in-sample °", "held-out °", "ident."
    );
    for m in &r.models {
        let f = |v: Option<f64>, p: usize| v.map_or("—".to_string(), |x| format!("{x:.*}", p));
        let _ = writeln!(
            o,
            "{:<13} {:>6} {:>12} {:>14} {:>10}{}",
            m.name,
            m.parameters,
            f(m.rms_deg, 4),
            f(m.cv_rms_deg, 4),
            m.identifiability.map_or("—".into(), |x| format!("{x:.1e}")),
            if m.name == r.model {
                "  ← chosen"
            } else {
                ""
            }
        );
        if let Some(e) = &m.error {
            let _ = writeln!(o, "              ({e})");
        }
    }
    let _ = writeln!(
        o,
        "\nchosen: {} — RMS angle error {:.4}° → {:.4}° in-sample, {:.4}° on held-out motions",
        r.model, r.rms_deg_before, r.rms_deg_after, r.cv_rms_deg
    );
    let _ = writeln!(
        o,
        "bias (counts): {:.3} {:.3} {:.3}",
        r.bias[0], r.bias[1], r.bias[2]
    );
    let _ = writeln!(o, "K (raw → rad/s):");
    for row in &r.matrix {
        let _ = writeln!(o, "  {:>14.6e} {:>14.6e} {:>14.6e}", row[0], row[1], row[2]);
    }
    for n in &r.notes {
        let _ = writeln!(o, "note: {n}");
    }
    loop_part(&mut o, r);
    o
}

/// The loop: noise floor, the static windows' candidates with their limits, the verdict.
fn loop_part(o: &mut String, r: &GyroReport) {
    let _ = writeln!(
        o,
        "\nnoise floor: {:.4}° per motion (gyro noise at rest {:.4} °/s per sample, {:.5} °/s per window mean; accelerometer tilt noise at the ends)",
        r.noise_floor_deg, r.noise_floor_rate_dps, r.noise_floor_window_dps
    );
    let _ = writeln!(
        o,
        "static windows: the gyro's window means about one bias {:.4} °/s RMS, {} held out ({} windows)",
        r.base.rms_dps,
        r.base
            .cv_rms_dps
            .map_or("—".into(), |v| format!("{v:.4} °/s")),
        r.base.windows_used
    );
    for e in &r.effects {
        effect_lines(o, &e.name, &e.unit, &e.evidence, &e.values, &e.std_errors);
    }
    if r.effects.is_empty() {
        let _ = writeln!(
            o,
            "no effect passes the rule (F-test and held-out RMS down by 10 %)"
        );
    }
    if let Some(b) = &r.open_basis {
        let _ = writeln!(o, "static windows' {}", b.summary);
    }
    motion_part(o, r);
    for d in &r.diagnostics {
        let _ = writeln!(o, "  {d}");
    }
    let _ = writeln!(o, "\nverdict: {}", r.verdict);
}

/// The motions' candidates: the base with the window effects, each effect, the final model.
fn motion_part(o: &mut String, r: &GyroReport) {
    let Some(m) = &r.motion_loop else {
        let _ = writeln!(o, "motions: no motion candidate tried (see below)");
        return;
    };
    let applied = if m.window_effects_applied.is_empty() {
        String::new()
    } else {
        format!(" with {} applied", m.window_effects_applied.join(", "))
    };
    let _ = writeln!(
        o,
        "motions{applied}: {:.4}° RMS, {:.4}° held out (χ² {:.1} on {} dof against the floor)",
        m.base.rms_deg, m.base.cv_rms_deg, m.base.chi2, m.base.chi2_dof
    );
    for e in &m.effects {
        effect_lines(o, &e.name, &e.unit, &e.evidence, &e.values, &e.std_errors);
    }
    if m.effects.is_empty() {
        let _ = writeln!(
            o,
            "no motion effect passes the rule (F-test and held-out RMS down by 10 %)"
        );
    } else {
        let _ = writeln!(
            o,
            "motions with the effects: {:.4}° RMS, {:.4}° held out",
            m.final_model.rms_deg, m.final_model.cv_rms_deg
        );
    }
    if let Some(b) = &m.open_basis {
        let _ = writeln!(o, "motions' {}", b.summary);
    }
}

/// An accepted effect (window or motion): its name, unit and evidence, then its values with
/// their standard errors.
fn effect_lines(
    o: &mut String,
    name: &str,
    unit: &str,
    evidence: &str,
    values: &[f64],
    se: &[f64],
) {
    let shown: Vec<String> = values
        .iter()
        .zip(se)
        .map(|(v, s)| format!("{v:.4} ± {s:.4}"))
        .collect();
    let _ = writeln!(
        o,
        "effect {name} ({unit}): {evidence}\n  values: {}",
        shown.join(", ")
    );
}
