//! `wiical tempcal`: the table of orders and coefficients, and the plot of each axis's bias
//! against temperature with its fitted polynomial.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use wiical_analysis::tempcal::{TempcalAxis, TempcalReport, MAX_ORDER};

fn opt(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.3e}"))
}

/// The readable report.
pub fn text(r: &TempcalReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Temperature calibration of {file}: {} samples at {:.3} Hz in {} blocks of {} ({} moving and {} of one-block poses left out), {} pose(s)",
        r.samples, r.sample_rate_hz, r.blocks, r.block_samples, r.blocks_moving, r.blocks_single, r.poses
    );
    let _ = writeln!(
        o,
        "temperature {:.2} … {:.2} °C (range {:.2} °C); bias polynomial in ΔT = T − {} °C, units {}; order by leave-one-of-{}-segments-out RMS (a lower order within {} % is taken)",
        r.t_min_c,
        r.t_max_c,
        r.t_max_c - r.t_min_c,
        r.t_ref_c,
        r.units,
        r.segments,
        r.tie_tolerance * 100.0
    );
    let _ = writeln!(
        o,
        "\n{:<10} {:>5}  {:>10} {:>10} {:>10}   {:>22} {:>22} {:>22}",
        "column",
        "order",
        "RMS o1",
        "RMS o2",
        "RMS o3",
        "c1 /°C ± se",
        "c2 /°C² ± se",
        "c3 /°C³ ± se"
    );
    for a in &r.axes {
        let coef: Vec<String> = (0..MAX_ORDER)
            .map(|k| match (a.coefficients.get(k), a.std_errors.get(k)) {
                (Some(c), Some(s)) => format!("{c:.3e} ± {s:.1e}"),
                _ => "—".into(),
            })
            .collect();
        let _ = writeln!(
            o,
            "{:<10} {:>5}  {:>10} {:>10} {:>10} {:>7}   {:>22} {:>22} {:>22}",
            a.column,
            a.order,
            opt(a.heldout_rms[0]),
            opt(a.heldout_rms[1]),
            opt(a.heldout_rms[2]),
            a.noise_ratio.map_or("—".into(), |r| format!("{r:.2}")),
            coef[0],
            coef[1],
            coef[2]
        );
    }
    let _ = writeln!(
        o,
        "\nlinear fit (what a calibration file's bias_temp holds):"
    );
    for a in &r.axes {
        let _ = writeln!(
            o,
            "  {:<10} {:.4e} ± {:.1e} per °C",
            a.column, a.linear[0], a.linear[1]
        );
    }
    let _ = writeln!(
        o,
        "\n/noise: in-sample RMS over the block-to-block noise (≈ 1 when still; above {} the record is not a still warm-up).\nThe correction subtracts Σ c_k ΔT^k (ArduPilot's and PX4's sign); --format ardupilot|px4 writes the parameters.",
        wiical_analysis::tempcal::STILL_RATIO
    );
    o
}

/// Each axis's block values minus their pose constant against temperature (points, at most
/// 2000 shown) and the fitted polynomial (line), one panel per axis, SVG.
pub fn write_plot(r: &TempcalReport, path: &Path) -> Result<()> {
    let tmp = path.with_extension("svg.tmp");
    {
        let root = SVGBackend::new(&tmp, (900, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
        let panels = root.split_evenly((r.axes.len().max(1), 1));
        for (i, (a, area)) in r.axes.iter().zip(&panels).enumerate() {
            draw_axis(area, r, a, i)?;
        }
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    let bytes = std::fs::read(&tmp)?;
    let _ = std::fs::remove_file(&tmp);
    wiical_analysis::output::write::write_file(path, &bytes).map_err(crate::cli_error::cli_error)
}

fn draw_axis<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    r: &TempcalReport,
    a: &TempcalAxis,
    i: usize,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let stride = (a.points.len() / 2000).max(1);
    let pts: Vec<(f64, f64)> = a
        .points
        .iter()
        .step_by(stride)
        .copied()
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .collect();
    let steps = 200;
    let line: Vec<(f64, f64)> = (0..=steps)
        .map(|s| {
            let t = r.t_min_c + (r.t_max_c - r.t_min_c) * s as f64 / steps as f64;
            (t, a.bias_at(t, r.t_ref_c))
        })
        .collect();
    let (y0, y1) = pts
        .iter()
        .chain(&line)
        .fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let pad = ((y1 - y0) * 0.05).max(1e-12);
    let color = Palette99::pick(i).to_rgba();
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!("{}: bias vs temperature (order {})", a.column, a.order),
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(80)
        .build_cartesian_2d(r.t_min_c..r.t_max_c, (y0 - pad)..(y1 + pad))
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc("temperature (°C)")
        .y_desc(format!("bias − pose constant ({})", r.units))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .draw_series(
            pts.iter()
                .map(|p| Circle::new(*p, 1, color.mix(0.4).filled())),
        )
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .draw_series(LineSeries::new(line, BLACK.stroke_width(2)))
        .map_err(|e| anyhow!("{e}"))?;
    Ok(())
}
