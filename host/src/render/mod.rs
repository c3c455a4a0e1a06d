//! Rendering: the human-readable tables of each command and the SVG plot. Nothing here
//! computes a result; every number comes from a library report.

pub mod analyze;
pub mod capture;
pub mod decode_cal;
pub mod device;
pub mod gyrofit;
pub mod kalman_demo;
pub mod magfit;
pub mod noise;
pub mod plot;
pub mod protocol;
pub mod tempcal;

use std::fmt::Write as _;
use wiical_analysis::fit::base::FitReport;
use wiical_analysis::fit::six_position::SixPositionReport;
use wiical_analysis::magnetometer::MagFitReport;
use wiical_analysis::Recording;

/// One row of `f32` values, 13 characters each.
pub fn fmt_row(v: &[f32]) -> String {
    v.iter()
        .map(|x| format!("{x:>13.6}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The `six-position` table.
pub fn six_position_text(rep: &SixPositionReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "Six-position test (T̂ = M·Â⁺), {file}");
    let _ = writeln!(o, "\nT̂ = [D | b]:");
    for r in &rep.t_hat {
        let _ = writeln!(o, "  {}", fmt_row(r));
    }
    let _ = writeln!(o, "\nD⁻¹ (correction a = D⁻¹(m − b)):");
    for r in &rep.d_inv {
        let _ = writeln!(o, "  {}", fmt_row(r));
    }
    let _ = writeln!(o, "\nb: {}", fmt_row(&rep.bias));
    let _ = writeln!(o, "\nResidual M − T̂Â (columns x+ x- y+ y- z+ z-):");
    for r in &rep.residual {
        let _ = writeln!(o, "  {}", fmt_row(r));
    }
    o
}

/// The `fit` table.
pub fn fit_text(rep: &FitReport, rec: &Recording, samples: usize, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Multi-position fit of {file} ({} {}): {} static windows",
        samples,
        if rep.window_input.is_some() {
            "rows"
        } else {
            "samples"
        },
        rep.static_windows
    );
    if let Some(w) = &rep.window_input {
        let _ = writeln!(o, "{}", w.description);
    }
    if let Some(p) = &rep.polling {
        let _ = writeln!(o, "{}", p.sentence());
    }
    if rec.skipped_empty_rows > 0 {
        let _ = writeln!(
            o,
            "({} rows with empty {} skipped, e.g. while the extension was unplugged)",
            rec.skipped_empty_rows,
            rec.axis_columns.join(",")
        );
    }
    let _ = writeln!(o, "\n  #   t_start    t_end  samples   residual (mg)");
    for (i, w) in rep.windows.iter().enumerate() {
        let _ = writeln!(
            o,
            "{:>3} {:>9.2} {:>8.2} {:>8} {:>13.4}",
            i + 1,
            w.t_start,
            w.t_end,
            w.samples.map_or("-".into(), |n| n.to_string()),
            w.residual_mg
        );
    }
    let _ = writeln!(o, "\nbias b (raw): {}", fmt_row(&rep.bias));
    let _ = writeln!(o, "K = D⁻¹ (g per raw unit):");
    for r in &rep.matrix {
        let _ = writeln!(o, "  {}", fmt_row(&r.map(|x| x * 1e3)));
    }
    let _ = writeln!(o, "  (×1e-3)");
    let _ = writeln!(
        o,
        "\nRMS ‖a‖ − 1 g: {:.4} mg   max: {:.4} mg   iterations: {}",
        rep.rms_mg, rep.max_abs_mg, rep.iterations
    );
    o
}

/// The `magfit` table.
pub fn magfit_text(rep: &MagFitReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Magnetometer {} fit of {file} ({} samples)",
        rep.model, rep.samples
    );
    let c = rep.center.map(|x| x as f32);
    let _ = writeln!(o, "  centre (hard iron): {}", fmt_row(&c));
    let _ = writeln!(o, "  soft-iron W (det 1), ‖W(m − c)‖ ≈ R:");
    for r in &rep.matrix {
        let _ = writeln!(o, "    {}", fmt_row(&r.map(|x| x as f32)));
    }
    let _ = writeln!(o, "  field strength R: {:.3}", rep.radius);
    let _ = writeln!(
        o,
        "  fit error: {:.3} % of field strength   RMS radius error: {:.3}",
        rep.fit_error_pct, rep.rms_radius_error
    );
    o
}
