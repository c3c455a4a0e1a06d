//! `wiical analyze`: the residual analysis.

use super::{check_outputs, to_json_with_quality, write_calibration_with, DetectArgs};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::select::check_rule;
use wiical_analysis::verdict::Quality;
use wiical_analysis::window_input::Input;
use wiical_analysis::{AnalyzeOptions, Candidate};
use wiical_core::multipos::MultiPosModel;
use wiical_core::quality::CoverageRule;

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
    #[arg(long, default_value_t = wiical_analysis::select::ALPHA)]
    pub alpha: f64,
    /// A candidate must divide the cross-validated RMS by at least this factor.
    #[arg(long, default_value_t = wiical_analysis::select::CV_FACTOR)]
    pub cv_factor: f64,
    /// Only try these candidates (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Option<Vec<String>>,
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
    let rep = super::with_progress(|progress| {
        let opts = AnalyzeOptions {
            fit: a.detect.fit_options(MultiPosModel::Full),
            alpha: a.alpha,
            cv_factor: a.cv_factor,
            candidates,
            progress,
            ..Default::default()
        };
        match &input {
            Input::Table(t) => wiical_analysis::window_input::analyze_table(t, &opts),
            Input::Samples(rec) => wiical_analysis::analyze(rec, &opts),
        }
    })
    .map_err(cli_error)?;
    // A six-position table is judged on its six poses by the six-position rule.
    let quality = match &rep.six_position {
        Some(six) => Quality::assess_with(
            &rep.calibration,
            &six.pose_means_raw,
            rep.final_model.rms_mg,
            CoverageRule::six_position(),
        ),
        None => {
            let means: Vec<[f64; 3]> = rep.windows.iter().map(|w| w.mean).collect();
            Quality::assess(&rep.calibration, &means, rep.final_model.rms_mg)
        }
    };
    if let Some(path) = &a.out {
        write_calibration_with(path, &rep.calibration, &quality)?;
    }
    if let Some(path) = &a.plot {
        render::plot::write_plot(&rep, path)?;
    }
    if a.json {
        return to_json_with_quality(&rep, &quality);
    }
    let mut text = render::analyze::render_text(&rep, &a.file.display().to_string());
    text.push_str(&quality.line());
    text.push('\n');
    Ok(text)
}
