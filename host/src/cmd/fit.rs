//! `wiical fit`: static-interval detection + multi-position fit.

// Field docs are clap help text, shown verbatim: `[,temp]` is not a link.
#![allow(rustdoc::broken_intra_doc_links)]

use super::{check_outputs, to_json_with_quality, write_calibration_with, DetectArgs};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::verdict::Quality;
use wiical_analysis::window_input::Input;
use wiical_core::multipos::MultiPosModel;

/// Arguments of `wiical fit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording: CSV with header (t,x,y,z[,temp]) or whitespace `t x y z` text.
    pub file: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the calibration (JSON) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Model: full (9 parameters) | diagonal (6: bias and per-axis scale).
    #[arg(long, default_value = "full", value_parser = parse_model)]
    pub model: MultiPosModel,
}

fn parse_model(s: &str) -> Result<MultiPosModel, String> {
    match s {
        "full" => Ok(MultiPosModel::Full),
        "diagonal" => Ok(MultiPosModel::Diagonal),
        _ => Err(format!("'{s}': expected full or diagonal")),
    }
}

/// Runs `wiical fit`; returns what to print.
/// The quality verdict (fit RMS and pose coverage) is printed, added to `--json` and stored
/// in the `--out` file for `device put` to check.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref()])?;
    let opts = a.detect.fit_options(a.model);
    let (rep, rec) = match a.detect.input(&a.file)? {
        Input::Table(table) => (
            wiical_analysis::window_input::fit_table(&table, &opts).map_err(cli_error)?,
            table.recording,
        ),
        Input::Samples(rec) => {
            let rep = super::with_spinner("detecting static windows and fitting", || {
                wiical_analysis::fit::run(&rec, &opts)
            })
            .map_err(cli_error)?;
            (rep, rec)
        }
    };
    let means: Vec<[f64; 3]> = rep.windows.iter().map(|w| w.mean.map(f64::from)).collect();
    let quality = Quality::assess(&rep.calibration, &means, f64::from(rep.rms_mg));
    if let Some(path) = &a.out {
        write_calibration_with(path, &rep.calibration, &quality)?;
    }
    if a.json {
        return to_json_with_quality(&rep, &quality);
    }
    let mut text = render::fit_text(&rep, &rec, &a.file.display().to_string());
    text.push_str(&quality.line());
    text.push('\n');
    Ok(text)
}
