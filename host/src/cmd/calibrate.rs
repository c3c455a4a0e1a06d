//! `wiical calibrate`: every sensor of a recording with the method its recognised protocol
//! calls for, one table and verdict per sensor (engine: [`wiical_analysis::calibrate`]).

use super::{check_outputs, to_json, write_calibration_with, DetectArgs};
use crate::cli_error::cli_error;
use anyhow::Result;
use std::path::{Path, PathBuf};
use wiical_analysis::calibrate::{calibrate, CalibrateOptions, CalibrateReport, Outcome};

/// Arguments of `wiical calibrate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording holding an accelerometer, a gyroscope and/or a magnetometer (columns named
    /// in the header: ax,ay,az / gx,gy,gz / mx,my,mz and the other common names).
    pub file: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the accelerometer's calibration here (the file `device put` reads); the gyro's,
    /// when one was measured, goes beside it as `NAME.gyro.json`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Known table rates for the gyro, °/s (0 for a rest part): see `gyrofit --table-rate`.
    #[arg(long, value_delimiter = ',', value_parser = rate_dps)]
    pub table_rate: Option<Vec<f64>>,
    /// The angle of each full turn between rests (Ferraris), degrees.
    #[arg(long, default_value_t = 360.0, value_parser = angle_deg)]
    pub rotation_deg: f64,
    #[command(flatten)]
    pub detect: DetectArgs,
}

/// A table rate, °/s: finite, 0 (a rest) or above (a turn's direction comes from the data).
pub fn rate_dps(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}': a rate in °/s, finite and 0 or above")),
    }
}

/// A turn's angle, degrees: finite and above 0.
pub fn angle_deg(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}': an angle in degrees, finite and above 0")),
    }
}

/// `cal.json` → `cal.gyro.json`.
fn gyro_path(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or_else(|| "cal".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}.gyro.json"))
}

/// Runs `wiical calibrate`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    let gyro_out = a.out.as_deref().map(gyro_path);
    check_outputs(&[&a.file], &[a.out.as_deref(), gyro_out.as_deref()])?;
    let fit = a
        .detect
        .fit_options(wiical_core::multipos::MultiPosModel::Full);
    let mut opts = CalibrateOptions {
        fit,
        read: a.detect.read.options(),
        ..Default::default()
    };
    opts.gyro.rotation_deg = a.rotation_deg;
    opts.gyro.table_rates_dps = a.table_rate.clone();
    let rep = super::with_spinner("recognising the protocol and calibrating", || {
        calibrate(&a.file, &opts)
    })
    .map_err(cli_error)?;
    if let Some(path) = &a.out {
        save(path, gyro_out.as_deref(), &rep)?;
    }
    if a.json {
        return to_json(&rep);
    }
    Ok(crate::render::protocol::calibrate_text(
        &rep,
        &a.file.display().to_string(),
    ))
}

/// Writes the accelerometer's calibration (and the gyro's beside it, when measured).
fn save(path: &Path, gyro_path: Option<&Path>, rep: &CalibrateReport) -> Result<()> {
    match &rep.accelerometer {
        Some(Outcome::Ok(j)) => write_calibration_with(path, &j.report.calibration, &j.quality)?,
        _ => anyhow::bail!(
            "--out {}: the file gave no accelerometer calibration (see above)",
            path.display()
        ),
    }
    let (Some(gp), Some(Outcome::Ok(g))) = (gyro_path, &rep.gyroscope) else {
        return Ok(());
    };
    let Some(file) = g.cal_file() else {
        return Ok(());
    };
    wiical_analysis::output::gyrocal::write_gyro_calibration(gp, &file).map_err(cli_error)
}
