//! The `analyze` report as text: window table, model summaries, candidates per step, effects
//! and verdict (six-position files: the pose residual tables instead of the window table).

use std::fmt::Write as _;
use wiical_analysis::autocal::AutocalReport;
use wiical_analysis::report::contract::{
    AnalyzeReport, ModelSummary, SixPositionDetails, StepReport, WindowInfo,
};
use wiical_analysis::search::evidence::{fmt_p, fmt_vec};
use wiical_analysis::search::limits;

/// One model's line: parameters, RMS, CV, windows, χ²/dof.
fn model_line(name: &str, m: &ModelSummary) -> String {
    format!(
        "{name:<6} params {:>3}  RMS {:>9.4} mg  CV {:>10}  windows {:>3}  χ²/dof {}",
        m.params,
        m.rms_mg,
        m.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.4} mg")),
        m.windows_used,
        match (m.chi2, m.chi2_dof) {
            (Some(c), Some(d)) => format!(
                "{:.2} (p {})",
                c / d.max(1) as f64,
                fmt_p(m.chi2_p.unwrap_or(f64::NAN))
            ),
            _ => "n/a".into(),
        }
    )
}

/// The candidates of every step of the search.
fn steps_text(steps: &[StepReport]) -> String {
    let mut o = String::new();
    if steps.is_empty() {
        return o;
    }
    let _ = writeln!(o, "\nCandidates per step (level = α / candidates):");
    for (k, s) in steps.iter().enumerate() {
        let _ = writeln!(
            o,
            "  step {} (level {:.1e}) → {}",
            k + 1,
            s.level,
            s.accepted.as_deref().unwrap_or("none accepted")
        );
        for c in &s.candidates {
            let _ = writeln!(
                o,
                "    {:<18} CV {:>10} (current {:>10})  F {:>8}  p {:>9}  {}",
                c.name,
                c.cv_rms_mg.map_or("-".into(), |x| format!("{x:.4}")),
                c.cv_rms_current_mg
                    .map_or("-".into(), |x| format!("{x:.4}")),
                c.f_stat.map_or("-".into(), |x| format!("{x:.2}")),
                c.p_value.map_or("-".into(), |x| format!("{x:.1e}")),
                c.note
            );
        }
        if k + 1 == steps.len() {
            o.push_str(&limit_lines(s));
        }
    }
    o
}

/// The last step's candidates that did not pass, each as "no X above L unit": what a
/// search that found nothing (more) can say instead of "nothing is missing".
fn limit_lines(s: &StepReport) -> String {
    let mut o = String::new();
    let rows: Vec<String> = s
        .candidates
        .iter()
        .filter_map(|c| {
            let unit = c.detection_unit.as_deref()?;
            Some(limits::phrase(&c.name, c.detection_limit?, unit))
        })
        .collect();
    if rows.is_empty() {
        return o;
    }
    let _ = writeln!(
        o,
        "  detection limits (the smallest each would have shown at this step's level in 80 % of recordings like this one):"
    );
    for r in rows {
        let _ = writeln!(o, "    {r}");
    }
    o
}

/// Human-readable report.
pub fn render_text(rep: &AnalyzeReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Residual analysis of {file} ({} {}, {} mode, units {}): {} static windows",
        rep.samples,
        if rep.window_input.is_some() {
            "rows"
        } else {
            "samples"
        },
        rep.mode,
        rep.units,
        rep.static_windows
    );
    if let Some(w) = &rep.window_input {
        let _ = writeln!(o, "{}", w.description);
    }
    if let Some(six) = &rep.six_position {
        o.push_str(&six_text(six));
    } else {
        o.push_str(&window_table(&rep.windows));
    }
    let _ = writeln!(
        o,
        "\nnoise floor {} mg{}",
        rep.noise_floor_mg
            .map_or("n/a".into(), |x| format!("{x:.4}")),
        rep.noise_floor_batch_mg
            .map_or(String::new(), |x| format!(" (batch means {x:.4} mg)"))
    );
    if let Some(p) = &rep.polling {
        let _ = writeln!(o, "{}", p.sentence());
    }
    let _ = writeln!(o, "{}", model_line("base", &rep.base));
    let _ = writeln!(o, "{}", model_line("final", &rep.final_model));
    o.push_str(&steps_text(&rep.steps));
    if rep.effects.is_empty() {
        let _ = writeln!(o, "\nEffects added: none");
    } else {
        let _ = writeln!(o, "\nEffects added:");
        for e in &rep.effects {
            let _ = writeln!(
                o,
                "  {} (+{} params): CV {} mg\n    {}",
                e.name,
                e.params,
                e.cv_rms_mg.map_or("n/a".into(), |x| format!("{x:.4}")),
                e.evidence
            );
        }
    }
    let _ = writeln!(o, "\n{}", rep.verdict);
    if let Some(line) = rep
        .residual_correlates
        .as_deref()
        .and_then(|c| wiical_analysis::search::correlates::sentence(c, rep.time_temp_correlation))
    {
        let _ = writeln!(o, "{line}");
    }
    if let Some(ac) = &rep.autocalibration {
        o.push_str(&autocal_text(rep, ac));
    }
    if let Some(ac) = &rep.autocalibration_converged {
        o.push_str("The same method iterated to its fixed point (GGIR stops earlier):\n");
        o.push_str(&autocal_values(ac));
    }
    o
}

/// The GGIR-method block of a window-mean table's report, with the pipeline's mean
/// |‖a‖ − 1| beside it (the same measure GGIR reports).
fn autocal_text(rep: &AnalyzeReport, ac: &AutocalReport) -> String {
    let mut o = String::new();
    let mean_abs = |f: fn(&WindowInfo) -> f64| {
        rep.windows.iter().map(|w| f(w).abs()).sum::<f64>() / rep.windows.len().max(1) as f64
    };
    let _ = writeln!(
        o,
        "\nPipeline (written by --out): mean |‖a‖ − 1| over the windows {:.3} mg (base model) → {:.3} mg (final model)",
        mean_abs(|w| w.residual_base_mg),
        mean_abs(|w| w.residual_final_mg)
    );
    let _ = writeln!(
        o,
        "GGIR's autocalibration (van Hees et al. 2014) of the same windows, stopped as GGIR stops it, for comparison:"
    );
    if !ac.done {
        let _ = writeln!(
            o,
            "  not done: {}",
            ac.reason.as_deref().unwrap_or("unknown reason")
        );
        return o;
    }
    o.push_str(&autocal_values(ac));
    o
}

/// The numbers of one autocalibration.
fn autocal_values(ac: &AutocalReport) -> String {
    let mut o = String::new();
    if !ac.done {
        let _ = writeln!(o, "  not done: {}", ac.reason.as_deref().unwrap_or("?"));
        return o;
    }
    let v3 = |v: Option<[f64; 3]>, d: usize| v.map_or("-".into(), |v| fmt_vec(&v, d));
    let _ = writeln!(
        o,
        "  offset {} mg (added before scaling)",
        v3(ac.offset_mg, 2)
    );
    let _ = writeln!(o, "  scale {}", v3(ac.scale, 5));
    if let (Some(k), Some(t)) = (ac.temp_offset_mg_per_c, ac.temp_mean_c) {
        let _ = writeln!(
            o,
            "  temperature offset {} mg/°C (about the mean {t:.2} °C)",
            fmt_vec(&k, 3)
        );
    }
    let _ = writeln!(
        o,
        "  mean |‖a‖ − 1| {:.3} mg → {:.3} mg ({} epochs, {} iterations)",
        ac.error_before_mg.unwrap_or(f64::NAN),
        ac.error_after_mg.unwrap_or(f64::NAN),
        ac.epochs,
        ac.iterations.unwrap_or(0)
    );
    o
}

/// Window rows shown in full; longer tables (window-mean files hold thousands) show their
/// first and last rows and every rejected window.
const MAX_WINDOW_ROWS: usize = 60;

/// The per-window table of the text report.
fn window_table(windows: &[WindowInfo]) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "\n  #   t_start    t_end  samples  temp°C   base(mg)  final(mg)  floor(mg)"
    );
    // Long tables (window-mean files hold thousands) show their head and tail; the JSON
    // has every window.
    let n = windows.len();
    let shown = |i: usize| {
        n <= MAX_WINDOW_ROWS || i < MAX_WINDOW_ROWS - 10 || i >= n - 10 || windows[i].rejected
    };
    for (i, w) in windows.iter().enumerate() {
        if !shown(i) {
            if shown(i - 1) {
                let hidden = (i..n).take_while(|&j| !shown(j)).count();
                let _ = writeln!(o, "  … {hidden} more windows (all of them in --json)");
            }
            continue;
        }
        let _ = writeln!(
            o,
            "{:>3} {:>9.2} {:>8.2} {:>8} {:>7} {:>10.3} {:>10.3} {:>10}{}",
            w.index,
            w.t_start,
            w.t_end,
            w.samples.map_or("-".into(), |n| n.to_string()),
            w.temp.map_or("-".into(), |t| format!("{t:.2}")),
            w.residual_base_mg,
            w.residual_final_mg,
            if w.floor_mg.is_finite() {
                format!("{:.3}", w.floor_mg)
            } else {
                "-".into()
            },
            if w.rejected { "  rejected" } else { "" }
        );
    }
    o
}

/// The six-position block of the report.
pub fn six_text(d: &SixPositionDetails) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "\nResidual K·(M − T̂Â), mg (rows x, y, z; columns x+ x- y+ y- z+ z-):"
    );
    for r in &d.pose_residual_mg {
        let _ = writeln!(
            o,
            "  {}",
            r.iter()
                .map(|x| format!("{x:>9.3}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    let _ = writeln!(
        o,
        "‖a‖ − 1 g per pose, mg: {}",
        d.norm_residual_mg
            .iter()
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    let _ = writeln!(
        o,
        "implied k2 (own pair) mg/g²: {}   other-pairs contrast mg: {}",
        fmt_vec(&d.implied_k2_mg, 2),
        fmt_vec(&d.misalignment_contrast_mg, 2)
    );
    if let (Some(ce), Some(pe), Some(cm), Some(pm)) =
        (d.chi2_even, d.p_even, d.chi2_misalignment, d.p_misalignment)
    {
        let _ = writeln!(
            o,
            "χ² even {ce:.2} (p {pe:.1e}), misalignment {cm:.2} (p {pm:.1e}), 3 dof each"
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(index: usize, rejected: bool) -> WindowInfo {
        WindowInfo {
            index,
            t_start: index as f64,
            t_end: index as f64 + 1.0,
            t_centre: index as f64 + 0.5,
            samples: None,
            temp: None,
            mean: [0.0, 0.0, 1.0],
            residual_base_mg: 1.0,
            residual_final_mg: 0.5,
            cv_base_mg: None,
            cv_final_mg: None,
            floor_mg: f64::NAN,
            rejected,
            signature_mg: None,
        }
    }

    /// A window-mean file's thousands of rows: head, tail and every rejected window shown,
    /// the rest counted; an unknown floor reads "-", not NaN.
    #[test]
    fn long_window_tables_show_head_tail_and_rejections() {
        let windows: Vec<WindowInfo> = (1..=1000).map(|i| window(i, i == 500)).collect();
        let text = window_table(&windows);
        let rows: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        // header + 50 head rows + gap + row 500 + gap + 10 tail rows
        assert_eq!(rows.len(), 1 + 50 + 1 + 1 + 1 + 10, "{text}");
        assert!(rows.iter().any(|l| l.contains("rejected")), "{text}");
        assert!(text.contains("  … 449 more windows"), "{text}");
        assert!(text.contains("  … 490 more windows"), "{text}");
        assert!(!text.contains("NaN"), "{text}");
        let short: Vec<WindowInfo> = (1..=60).map(|i| window(i, false)).collect();
        assert_eq!(window_table(&short).lines().count(), 2 + 60);
    }
}
