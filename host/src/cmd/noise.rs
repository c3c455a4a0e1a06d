//! `wiical noise`: the Allan deviation of a still recording, per axis, and the IEEE 952 noise
//! terms (engine: [`wiical_analysis::noise::allan`], [`wiical_analysis::noise::report`]).

use super::{check_outputs, to_json};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::noise::report::noise_of;
use wiical_analysis::NoiseRequest;

/// Arguments of `wiical noise`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A still recording (hours for bias instability and random walk): every accelerometer,
    /// gyroscope and magnetometer triplet its header names is analysed (.gz read as is).
    pub file: PathBuf,
    /// Only these three columns.
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0, value_parser = super::rate_hz, allow_negative_numbers = true)]
    pub rate_hz: f64,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Draw the Allan deviation of every axis with its fitted terms (SVG, log-log).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

impl Args {
    /// The engine's request from the flags (`--plot` and `--json` are the command line's).
    fn request(&self) -> NoiseRequest {
        NoiseRequest {
            columns: self.columns.clone(),
            read: self.read.options(),
            rate_hz: self.rate_hz,
            ..NoiseRequest::new(self.file.as_path())
        }
    }
}

/// Runs `wiical noise`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.plot.as_deref()])?;
    let req = a.request();
    let rate_hz = req.rate_hz;
    // A large plain text file is opened as sources read in passes (memory: a piece of the
    // file and the Allan sums, not the samples).
    let sensors = super::with_spinner(&format!("reading {}", a.file.display()), || {
        req.into_sensors()
    })
    .map_err(cli_error)?;
    if let Some(first) = sensors.first() {
        super::print_notes(&a.file, first);
    }
    let rep = super::with_spinner("computing Allan deviations", || noise_of(&sensors, rate_hz))
        .map_err(cli_error)?;
    if let Some(how) = &rep.streamed {
        eprintln!("note: in {}: {how}", a.file.display());
    }
    if let Some(path) = &a.plot {
        render::noise::write_plot(&rep, path)?;
    }
    if a.json {
        return to_json(&rep);
    }
    Ok(render::noise::text(&rep, &a.file.display().to_string()))
}
