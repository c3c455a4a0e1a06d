//! `wiical noise`: the table of terms and the log-log plot of the Allan deviations.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use wiical_analysis::noise::allan::model_adev;
use wiical_analysis::noise::report::NoiseReport;

fn fmt(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.3e}"))
}

/// The readable report: per axis N, B (at τ), K, Q, R with units, "—" where not seen.
pub fn text(r: &NoiseReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Allan deviation (overlapping, IEEE 952) of {file}: {} samples at {:.3} Hz ({:.2} h)",
        r.samples,
        r.sample_rate_hz,
        r.duration_s / 3600.0
    );
    for p in &r.polled {
        let _ = writeln!(
            o,
            "{}: {}; the Allan deviation is of those, at the sensor's rate",
            p.columns,
            p.polling.sentence()
        );
    }
    let _ = writeln!(
        o,
        "\n{:<12} {:<8} {:>11} {:>11} {:>9} {:>11} {:>11} {:>11}",
        "column", "unit", "N /√Hz", "B", "B at τ s", "K /√s", "Q ·s", "R /s"
    );
    for a in &r.axes {
        let _ = writeln!(
            o,
            "{:<12} {:<8} {:>11} {:>11} {:>9} {:>11} {:>11} {:>11}",
            a.column,
            a.unit.as_deref().unwrap_or("(file)"),
            fmt(a.terms.n),
            fmt(a.terms.b),
            a.terms.b_tau_s.map_or("—".into(), |t| format!("{t:.0}")),
            fmt(a.terms.k),
            fmt(a.terms.q),
            fmt(a.terms.r),
        );
    }
    let tau_max = r
        .axes
        .iter()
        .filter_map(|a| a.curve.tau_s.last())
        .fold(0.0, |m: f64, t| m.max(*t));
    let _ = writeln!(
        o,
        "\n— : that term's slope is not seen in this recording (the curve reaches τ = {tau_max:.0} s; \
         rate random walk K and ramp R need longer still recordings, quantisation Q a curve that starts \
         on its −1 slope); it was not measured, which is not the same as zero."
    );
    o
}

/// The Allan deviation of every axis (points) with its fitted model (line), log-log, SVG.
pub fn write_plot(r: &NoiseReport, path: &Path) -> Result<()> {
    let pts: Vec<(f64, f64)> = r
        .axes
        .iter()
        .flat_map(|a| {
            a.curve
                .tau_s
                .iter()
                .copied()
                .zip(a.curve.adev.iter().copied())
        })
        .filter(|(t, s)| *t > 0.0 && *s > 0.0)
        .collect();
    if pts.is_empty() {
        return Err(anyhow!("nothing to plot: no Allan deviation point"));
    }
    let (tx0, tx1) = pts
        .iter()
        .fold((f64::MAX, 0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (sy0, sy1) = pts
        .iter()
        .fold((f64::MAX, 0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let tmp = path.with_extension("svg.tmp");
    {
        let root = SVGBackend::new(&tmp, (900, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption("Allan deviation", ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (tx0 / 1.5..tx1 * 1.5).log_scale(),
                (sy0 / 2.0..sy1 * 2.0).log_scale(),
            )
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc("τ (s)")
            .y_desc("σ(τ) (column unit)")
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        draw_axes(&mut chart, r)?;
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    let bytes = std::fs::read(&tmp)?;
    let _ = std::fs::remove_file(&tmp);
    wiical_analysis::output::write::write_file(path, &bytes).map_err(crate::cli_error::cli_error)
}

/// One axis's points and fitted line per colour.
fn draw_axes<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<
            plotters::coord::combinators::LogCoord<f64>,
            plotters::coord::combinators::LogCoord<f64>,
        >,
    >,
    r: &NoiseReport,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    for (i, a) in r.axes.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let label = format!(
            "{} ({})",
            a.column,
            a.unit.as_deref().unwrap_or("file unit")
        );
        let series: Vec<(f64, f64)> = a
            .curve
            .tau_s
            .iter()
            .copied()
            .zip(a.curve.adev.iter().copied())
            .collect();
        chart
            .draw_series(series.iter().map(|p| Circle::new(*p, 3, color.filled())))
            .map_err(|e| anyhow!("{e}"))?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
        let model: Vec<(f64, f64)> = series
            .iter()
            .map(|(t, _)| (*t, model_adev(&a.terms, *t)))
            .filter(|(_, s)| *s > 0.0)
            .collect();
        chart
            .draw_series(LineSeries::new(model, color.stroke_width(1)))
            .map_err(|e| anyhow!("{e}"))?;
    }
    Ok(())
}
