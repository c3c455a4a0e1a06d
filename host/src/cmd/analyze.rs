//! `wiical analyze`: the residual analysis.

use super::{check_outputs, to_json, DetectArgs};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::search::select::check_rule;
use wiical_analysis::{AnalyzeOptions, Candidate};
use wiical_core::multipos::MultiPosModel;

/// Arguments of `wiical analyze`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording (as for `fit`: raw counts or g, optional `t` and `temp` columns), or a
    /// six-position CSV with a `pose` column.
    pub file: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Draw the residuals before/after against the relevant regressor (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write the final calibration, effect terms included, here (JSON). For a window-mean
    /// table this is the pipeline's selected model, not the GGIR-method comparison.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Family-wise significance level per step (Bonferroni over the candidates).
    #[arg(long, default_value_t = wiical_analysis::search::select::ALPHA, value_parser = alpha, allow_negative_numbers = true)]
    pub alpha: f64,
    /// A candidate must divide the cross-validated RMS by at least this factor.
    #[arg(long, default_value_t = wiical_analysis::search::select::CV_FACTOR, value_parser = cv_factor, allow_negative_numbers = true)]
    pub cv_factor: f64,
    /// Only try these candidates (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Option<Vec<String>>,
}

/// `--alpha`: a number within the engine's range (`select::ALPHA_RANGE`, shared with Python).
fn alpha(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    wiical_analysis::search::select::check_alpha(v).map_err(|e| format!("'{s}': {e}"))
}

/// `--cv-factor`: a number within the engine's range (`select::CV_FACTOR_RANGE`).
fn cv_factor(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    wiical_analysis::search::select::check_cv_factor(v).map_err(|e| format!("'{s}': {e}"))
}

fn number(s: &str) -> Result<f64, String> {
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))
}

/// Runs `wiical analyze`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref(), a.plot.as_deref()])?;
    let input = a.detect.input(&a.file)?;
    // The rule's settings first, then the names, as the engine would.
    check_rule(a.alpha, a.cv_factor).map_err(cli_error)?;
    let candidates = a
        .candidates
        .as_ref()
        .map(|names| names.iter().map(|n| n.parse::<Candidate>()).collect())
        .transpose()
        .map_err(cli_error)?;
    let judged = super::with_progress(|progress| {
        let opts = AnalyzeOptions {
            fit: a.detect.fit_options(MultiPosModel::Full),
            alpha: a.alpha,
            cv_factor: a.cv_factor,
            candidates,
            progress,
            ..Default::default()
        };
        wiical_analysis::pipeline::analyze_judged(&input, &opts)
    })
    .map_err(cli_error)?;
    let (rep, quality) = (&judged.report, &judged.quality);
    if let Some(path) = &a.out {
        write_calibration_file(path, rep, quality)?;
    }
    if let Some(path) = &a.plot {
        render::plot::write_plot(rep, path)?;
    }
    if a.json {
        return to_json(&judged);
    }
    let mut text = render::analyze::render_text(rep, &a.file.display().to_string());
    text.push_str(&quality.line());
    text.push('\n');
    Ok(text)
}

/// Writes the report's calibration with the fit's quality and the open basis's host terms
/// (schema `wiical-calibration/3` only when there are some), after validating it, atomically.
fn write_calibration_file(
    path: &std::path::Path,
    rep: &wiical_analysis::AnalyzeReport,
    quality: &wiical_analysis::report::verdict::Quality,
) -> Result<()> {
    use wiical_analysis::output::calfile::{write_calibration_file as write, CalibrationFile};
    let file = CalibrationFile {
        calibration: rep.calibration,
        quality: Some(quality.clone()),
        host_terms: rep.host_terms.clone(),
    };
    write(path, &file).map_err(cli_error)
}
