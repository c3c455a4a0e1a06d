//! `wiical magfit`: magnetometer hard/soft-iron fit.

use super::{check_outputs, load, load_options, to_json, write_calibration};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::magnetometer::{self, MagModel};
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
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the calibration (centre as bias, W/radius as matrix: unit field) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `wiical magfit`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref()])?;
    let opts = wiical_analysis::LoadOptions {
        sensor: Some(wiical_analysis::input::columns::Sensor::Magnetometer),
        ..load_options(a.columns.as_deref())?
    };
    let rec = load(&a.file, &opts)?;
    let rep = magnetometer::fit_points(&rec.xyz, a.model).map_err(cli_error)?;
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
        return to_json(&rep);
    }
    Ok(render::magfit_text(&rep, &a.file.display().to_string()))
}
