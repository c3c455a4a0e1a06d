//! `wiical fit`: static-interval detection + multi-position fit.

// Field docs are clap help text, shown verbatim: `[,temp]` is not a link.
#![allow(rustdoc::broken_intra_doc_links)]

use super::{check_outputs, to_json, write_calibration_with, DetectArgs};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;

use wiical_core::multipos::MultiPosModel;

/// Arguments of `wiical fit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording: CSV with header (t,x,y,z[,temp]) or whitespace `t x y z` text, plain or
    /// gzip'd (text of 128 MiB or more is streamed, no size cap). `-` reads standard input;
    /// beyond 128 MiB it is copied to a temporary file in $TMPDIR (deleted on exit).
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
    let input = a.detect.input(&a.file)?;
    let judged = super::with_spinner("detecting static windows and fitting", || {
        wiical_analysis::pipeline::fit_judged(&input, &opts)
    })
    .map_err(cli_error)?;
    let (rep, quality) = (&judged.report, &judged.quality);
    if let Some(path) = &a.out {
        write_calibration_with(path, &rep.calibration, quality)?;
    }
    if a.json {
        return to_json(&judged);
    }
    let (rec, samples) = (input.recording(), input.len());
    let mut text = render::fit_text(rep, rec, samples, &a.file.display().to_string());
    if let Some(p) = &rep.protocol {
        text.push_str(&render::protocol::accel_lines(p));
    }
    text.push_str(&quality.line());
    text.push('\n');
    Ok(text)
}
