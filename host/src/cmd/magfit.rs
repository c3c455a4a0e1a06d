//! `wiical magfit`: magnetometer hard/soft-iron fit, and the residual loop around it (noise
//! floor, candidate effects, detection limits, verdict).

use super::{check_outputs, load_options, print_notes, to_json, with_spinner, write_calibration};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::{anyhow, Result};
use std::path::{Path, PathBuf};
use wiical_analysis::input::text_source::TextSource;
use wiical_analysis::magnetometer::{self, stream, MagAnalysis, MagFitReport, MagInput, MagModel};
use wiical_analysis::search::select::ALPHA;
use wiical_core::Calibration;

/// Arguments of `wiical magfit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording: CSV with header (mx,my,mz or x,y,z) or whitespace `x y z` text.
    pub file: PathBuf,
    /// sphere | axis | ellipsoid.
    #[arg(long, default_value = "ellipsoid", value_parser = clap::value_parser!(MagModel))]
    pub model: MagModel,
    /// Header names of the x,y,z columns to use.
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Header names of columns the hard iron may follow (current, throttle, PWM): each is
    /// tested as an interference `offset = k × column` (ArduPilot COMPASS_MOT's model).
    #[arg(long, value_delimiter = ',')]
    pub follow: Option<Vec<String>>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the calibration (centre as bias, W/radius as matrix: unit field) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The JSON: the fit's keys, then the loop's.
#[derive(serde::Serialize)]
struct Json<'a> {
    #[serde(flatten)]
    fit: &'a MagFitReport,
    #[serde(flatten)]
    analysis: &'a MagAnalysis,
}

/// Runs `wiical magfit`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref()])?;
    let opts = wiical_analysis::LoadOptions {
        sensor: Some(wiical_analysis::input::columns::Sensor::Magnetometer),
        ..load_options(a.columns.as_deref(), &a.read)?
    };
    let source = with_spinner(&format!("reading {}", a.file.display()), || {
        stream::open_field_from(&a.file, &opts, opts.read.stream_from_bytes)
    })
    .map_err(cli_error)?;
    let (rep, analysis, unit) = match source {
        Some(src) => streamed(a, &src)?,
        None => held(a, &opts)?,
    };
    if let Some(path) = &a.out {
        let k = rep.matrix.map(|r| r.map(|x| (x / rep.radius) as f32));
        let cal = Calibration {
            bias: rep.center.map(|x| x as f32),
            matrix: k,
            effects: Default::default(),
        };
        write_calibration(path, &cal)?;
    }
    if a.json {
        return to_json(&Json {
            fit: &rep,
            analysis: &analysis,
        });
    }
    let mut text = render::magfit_text(&rep, &a.file.display().to_string());
    text.push_str(&render::magfit::analysis_text(&analysis, unit));
    Ok(text)
}

/// The fit and the loop with every sample held.
fn held(
    a: &Args,
    opts: &wiical_analysis::LoadOptions,
) -> Result<(MagFitReport, MagAnalysis, &'static str)> {
    let rec = super::load_held(&a.file, opts, "magfit", super::PLAIN_TEXT_IN_PASSES)?;
    magnetometer::check_spans(&rec.xyz).map_err(cli_error)?;
    let rep = magnetometer::fit_points(&rec.xyz, a.model).map_err(cli_error)?;
    let names = a.follow.as_deref().unwrap_or(&[]);
    let follow = follow_columns(a, names, &rec.axis_columns, rec.len())?;
    let times = rec
        .t
        .clone()
        .or_else(|| rec.sample_rate_hz.map(|_| rec.times(1.0)));
    let unit = wiical_analysis::input::columns::triplet_unit(&rec.axis_columns).unwrap_or("raw");
    let input = MagInput {
        xyz: &rec.xyz,
        t: times.as_deref(),
        temp: rec.temp.as_deref(),
        follow: &follow,
        unit,
    };
    let analysis = magnetometer::analyze(&input, &rep, a.model, ALPHA).map_err(cli_error)?;
    Ok((rep, analysis, unit))
}

/// The fit and the loop in passes over a large plain text file (the same numbers as
/// [`held`], memory bounded: `magnetometer::stream`).
fn streamed(a: &Args, src: &TextSource) -> Result<(MagFitReport, MagAnalysis, &'static str)> {
    print_notes(&a.file, &src.meta);
    let prep = stream::fit_source(src, a.model).map_err(cli_error)?;
    let mut follow = Vec::new();
    for name in a.follow.as_deref().unwrap_or(&[]) {
        let col = stream::open_follow(&a.file, name, &src.meta.axis_columns, &a.read.options());
        let Some(col) = col.map_err(cli_error)? else {
            return Err(anyhow!(
                "--follow {name}: {} is no longer plain text (was it replaced while read?)",
                a.file.display()
            ));
        };
        check_rows(name, col.len(), src.len(), &a.file)?;
        follow.push((name.clone(), col));
    }
    let analysis =
        stream::analyze_source(src, &prep, &follow, a.model, ALPHA).map_err(cli_error)?;
    Ok((prep.report, analysis, stream::unit_of(src)))
}

/// A followed column must have a value on every row the field has.
fn check_rows(name: &str, got: usize, rows: usize, file: &Path) -> Result<()> {
    if got != rows {
        return Err(anyhow!(
            "--follow {name}: {got} rows in {} against {rows} of the field (a row where one \
             is empty): give a column filled on every row",
            file.display()
        ));
    }
    Ok(())
}

/// Each named column, read by the same loader as the field (so its rows are the field's).
fn follow_columns(
    a: &Args,
    names: &[String],
    field_axes: &[String; 3],
    rows: usize,
) -> Result<Vec<(String, Vec<f64>)>> {
    names
        .iter()
        .map(|name| {
            let file = a.file.as_path();
            let opts = stream::follow_options(name, field_axes, &a.read.options());
            use wiical_analysis::input::front_door::{load_held, HoldLimit};
            let limit = HoldLimit::of("magfit", super::PLAIN_TEXT_IN_PASSES);
            let rec = load_held(file, &opts, limit).map_err(cli_error)?;
            check_rows(name, rec.len(), rows, file)?;
            Ok((name.clone(), rec.xyz.iter().map(|v| v[0]).collect()))
        })
        .collect()
}
