//! `wiical magfit`: magnetometer hard/soft-iron fit, and the residual loop around it (noise
//! floor, candidate effects, detection limits, verdict).

use super::{check_outputs, load_options, print_notes, to_json, with_spinner, write_calibration};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::{anyhow, Result};
use std::path::{Path, PathBuf};
use wiical_analysis::input::text_source::TextSource;
use wiical_analysis::magnetometer::{self, pass, Follow, MagAnalysis, MagFitReport, MagModel};
use wiical_analysis::search::select::ALPHA;
use wiical_analysis::source::RowSource;
use wiical_analysis::{LoadOptions, Recording};
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
    let file = a.file.as_path();
    let (rep, analysis, unit) = match open_in_passes(a, &opts)? {
        Some(src) => fit_and_loop(a, &src, |name, o| column_in_passes(file, name, o))?,
        None => {
            let rec = super::load_held(file, &opts, "magfit", super::PLAIN_TEXT_IN_PASSES)?;
            fit_and_loop(a, &rec, |_, o| column_held(file, o))?
        }
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

/// The fit and the loop of `src` (the field's rows, held or read in passes: the same code),
/// its `--follow` columns read as it is (`open_column` with a column's name and load options);
/// the field's unit besides.
fn fit_and_loop<R: RowSource>(
    a: &Args,
    src: &R,
    open_column: impl Fn(&str, &LoadOptions) -> Result<R>,
) -> Result<(MagFitReport, MagAnalysis, &'static str)> {
    let prep = magnetometer::fit_source(src, a.model).map_err(cli_error)?;
    let follow = follow_columns(a, src, open_column)?;
    let analysis =
        magnetometer::analyze_source(src, &prep, &follow, a.model, ALPHA).map_err(cli_error)?;
    Ok((prep.report, analysis, pass::unit_of(src)))
}

/// The field's rows read in passes from the file (memory bounded) when it is a regular plain
/// text file of at least `--stream-from-bytes`; `None`: it is held whole.
fn open_in_passes(a: &Args, opts: &LoadOptions) -> Result<Option<TextSource>> {
    let large = a.file.as_os_str() != "-"
        && std::fs::metadata(&a.file)
            .is_ok_and(|m| m.is_file() && m.len() >= opts.read.stream_from_bytes);
    if large {
        let src = with_spinner(&format!("reading {}", a.file.display()), || {
            TextSource::open(&a.file, opts, |_| true).map_err(|e| e.in_file(&a.file))
        })
        .map_err(cli_error)?;
        if let Some(src) = src {
            print_notes(&a.file, &src.meta);
            return Ok(Some(src));
        }
    }
    Ok(None)
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

/// Each named column, read as the field is (`open`: in passes or held) by the same loader, so
/// that its rows are the field's.
fn follow_columns<R: RowSource>(
    a: &Args,
    field: &R,
    open: impl Fn(&str, &LoadOptions) -> Result<R>,
) -> Result<Vec<Follow<R>>> {
    let mut out = Vec::new();
    for name in a.follow.as_deref().unwrap_or(&[]) {
        let opts = pass::follow_options(name, field.axis_columns(), &a.read.options());
        let col = open(name, &opts)?;
        check_rows(name, col.len(), field.len(), &a.file)?;
        out.push((name.clone(), col));
    }
    Ok(out)
}

/// The followed column `name` of `file` read in passes (the field was: the file must still be
/// plain text).
fn column_in_passes(file: &Path, name: &str, opts: &LoadOptions) -> Result<TextSource> {
    let col = TextSource::open(file, opts, |_| true).map_err(|e| e.in_file(file));
    col.map_err(cli_error)?.ok_or_else(|| {
        anyhow!(
            "--follow {name}: {} is no longer plain text (was it replaced while read?)",
            file.display()
        )
    })
}

/// A followed column of `file` held whole (the field was).
fn column_held(file: &Path, opts: &LoadOptions) -> Result<Recording> {
    use wiical_analysis::input::front_door::{load_held, HoldLimit};
    let limit = HoldLimit::of("magfit", super::PLAIN_TEXT_IN_PASSES);
    load_held(file, opts, limit).map_err(cli_error)
}
