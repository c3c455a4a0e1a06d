//! `wiical analyze --plot FILE.svg`: residual ‖a‖ − 1 g of every static window, before (base
//! model) and after (final model). Left: against the variable of the first effect added —
//! window temperature (`temperature`, `temperature-scale`), window index (`outliers`), else
//! window time. Right (when an effect was added): against that effect's fitted signature, how
//! much the effect changes each window's ‖a‖ (for a bias drift `(â·Δb)·t`, for a quadratic
//! `Σ k2ᵢ·âᵢ³`, …): the signature is the regressor the residual actually follows, since the
//! sign of a bias change in ‖a‖ depends on the pose direction; a missing effect lies on the
//! diagonal before and flat after. Six-position reports plot the pair residuals per axis.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;
use wiical_analysis::report::contract::WindowInfo;
use wiical_analysis::AnalyzeReport;

fn range(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let lo = v.clone().fold(f64::INFINITY, f64::min);
    let hi = v.fold(f64::NEG_INFINITY, f64::max);
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(1e-6);
    (lo - pad, hi + pad)
}

type Pts = Vec<(f64, f64)>;

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_desc: &str,
    before: &Pts,
    after: &Pts,
    rejected: &Pts,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let xr = range(before.iter().chain(after).map(|p| p.0));
    let yr = range(before.iter().chain(after).chain(rejected).map(|p| p.1));
    // Head-room for the legend.
    let yr = (yr.0, yr.1 + 0.3 * (yr.1 - yr.0));
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("‖a‖ − 1 g (mg)")
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .draw_series(LineSeries::new([(xr.0, 0.0), (xr.1, 0.0)], BLACK.mix(0.3)))
        .map_err(|e| anyhow!("plot: {e}"))?;
    chart
        .draw_series(
            before
                .iter()
                .map(|p| Circle::new(*p, 4, RED.mix(0.8).filled())),
        )
        .map_err(|e| anyhow!("plot: {e}"))?
        .label("before (base model)")
        .legend(|(x, y)| Circle::new((x + 10, y), 4, RED.filled()));
    chart
        .draw_series(
            after
                .iter()
                .map(|p| TriangleMarker::new(*p, 5, BLUE.filled())),
        )
        .map_err(|e| anyhow!("plot: {e}"))?
        .label("after (final model)")
        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 5, BLUE.filled()));
    if !rejected.is_empty() {
        chart
            .draw_series(
                rejected
                    .iter()
                    .map(|p| Cross::new(*p, 6, BLACK.stroke_width(2))),
            )
            .map_err(|e| anyhow!("plot: {e}"))?
            .label("rejected window (final model)")
            .legend(|(x, y)| Cross::new((x + 10, y), 6, BLACK.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("plot: {e}"))?;
    Ok(())
}

/// Writes the residual plot as SVG (drawn in memory, then written like every other output
/// file, through [`wiical_analysis::output::write::write_file`]).
pub fn write_plot(rep: &AnalyzeReport, path: &Path) -> Result<()> {
    let svg = render_svg(rep)?;
    wiical_analysis::output::write::write_file(path, svg.as_bytes())
        .map_err(crate::cli_error::cli_error)
}

/// The residual plot as SVG text.
pub fn render_svg(rep: &AnalyzeReport) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 520)).into_drawing_area();
        draw(rep, &root)?;
    }
    Ok(svg)
}

type Root<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn draw(rep: &AnalyzeReport, root: &Root<'_>) -> Result<()> {
    root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
    if let Some(six) = &rep.six_position {
        // Pair residuals per axis: x = pair index (0 x, 1 y, 2 z) offset by axis.
        let mut before = Vec::new();
        for (a, row) in six.pair_residual_mg.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                before.push((j as f64 + 0.2 * (a as f64 - 1.0), *v));
            }
        }
        panel(
            root,
            "six-position pair residuals (per pair x, y, z; axis x, y, z left to right)",
            "± pair",
            &before,
            &Vec::new(),
            &Vec::new(),
        )?;
        root.present().map_err(|e| anyhow!("plot: {e}"))?;
        return Ok(());
    }
    let panels = if rep.effects.is_empty() { 1 } else { 2 };
    let areas = root.split_evenly((1, panels));
    let kept = |f: fn(&WindowInfo) -> f64, after: bool| -> (Pts, Pts, Pts) {
        let mut b = Vec::new();
        let mut a = Vec::new();
        let mut r = Vec::new();
        for w in &rep.windows {
            let x = f(w);
            b.push((x, w.residual_base_mg));
            if after {
                if w.rejected {
                    r.push((x, w.residual_final_mg));
                } else {
                    a.push((x, w.residual_final_mg));
                }
            }
        }
        (b, a, r)
    };
    // Panel 1: against the effect's own variable (time, temperature, window index).
    let first = rep.effects.first().map(|e| e.name.as_str());
    use wiical_analysis::report::effect_names as names;
    let (title, xd, f): (&str, &str, fn(&WindowInfo) -> f64) = match first {
        Some(names::TEMPERATURE) | Some(names::TEMPERATURE_SCALE) => (
            "residual vs window temperature",
            "window temperature (°C)",
            |w| w.temp.unwrap_or(f64::NAN),
        ),
        Some(names::OUTLIERS) => ("residual vs window", "window #", |w| w.index as f64),
        _ => (
            "residual vs window time",
            "window time since start (s)",
            |w| w.t_centre,
        ),
    };
    let (b, a, r) = kept(f, true);
    panel(&areas[0], title, xd, &b, &a, &r)?;
    // Panel 2: against the fitted signature of the first effect (how much it changes each
    // window's ‖a‖): a missing effect lies on the diagonal before and flat after.
    if let (Some(e), Some(area)) = (rep.effects.first(), areas.get(1)) {
        let title = format!("residual vs fitted {} signature", e.name);
        let (b, a, r) = kept(|w| w.signature_mg.unwrap_or(0.0), true);
        panel(
            area,
            &title,
            "fitted effect contribution to ‖a‖ − 1 g (mg)",
            &b,
            &a,
            &r,
        )?;
    }
    root.present().map_err(|e| anyhow!("plot: {e}"))?;
    Ok(())
}
