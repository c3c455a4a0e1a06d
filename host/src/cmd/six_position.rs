//! `wiical six-position`: the seed's six-position test.

use super::{check_outputs, to_json, write_calibration};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::fit::six_position::{self, PoseEstimator};
use wiical_analysis::LoadOptions;
use wiical_core::Calibration;

/// Arguments of `wiical six-position`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// CSV file: pose,x,y,z (one row per pose, or blocks of raw samples per pose).
    pub file: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// How a block of samples becomes a pose mean: mean | kalman.
    #[arg(long, default_value = "mean", value_parser = parse_estimator)]
    pub estimator: PoseEstimator,
    /// Write the calibration (JSON) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

fn parse_estimator(s: &str) -> Result<PoseEstimator, String> {
    match s {
        "mean" => Ok(PoseEstimator::Mean),
        "kalman" => Ok(PoseEstimator::Kalman),
        _ => Err(format!("'{s}': expected mean or kalman")),
    }
}

/// Runs `wiical six-position`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref()])?;
    let opts = LoadOptions::default();
    let rec = super::load_held(&a.file, &opts, "six-position", super::CUT_IT_SHORTER)?;
    let rep = six_position::run(&rec, a.estimator).map_err(cli_error)?;
    if let Some(path) = &a.out {
        let cal = Calibration {
            bias: rep.bias,
            matrix: rep.d_inv,
            effects: Default::default(),
        };
        write_calibration(path, &cal)?;
    }
    if a.json {
        return to_json(&rep);
    }
    Ok(render::six_position_text(
        &rep,
        &a.file.display().to_string(),
    ))
}
