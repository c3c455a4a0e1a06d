//! `wiical gyrofit`: gyroscope scale, misalignment and bias from a multi-position recording
//! (engine: [`wiical_analysis::gyro`]; method: docs/gyro.md).

use super::{load, load_options, to_json, DetectArgs};
use crate::cli_error::cli_error;
use anyhow::{bail, Result};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;
use wiical_analysis::gyro::{GyroOptions, GyroReport};

/// Arguments of `wiical gyrofit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording with accelerometer and gyro columns (x,y,z and gx,gy,gz), or the
    /// accelerometer file of a pair (IMU-TK's `t x y z` text).
    pub file: PathBuf,
    /// The gyro file of a pair (same samples as FILE).
    pub gyro_file: Option<PathBuf>,
    /// Nominal gyro sensitivity in rad/s per count: one value for all axes or three
    /// (signed: an inverted axis is negative), e.g. 1.598e-4 (IMU-TK's Xsens, 1/6258).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub scale: Option<Vec<f64>>,
    /// Nominal gyro sensitivity as counts per °/s (datasheet style, e.g. 16.384 for ±2000 °/s
    /// on 16 bits); one value or three (signed). Alternative to --scale.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub counts_per_dps: Option<Vec<f64>>,
    /// Header names of the gyro columns in a single file.
    #[arg(long, value_delimiter = ',', default_value = "gx,gy,gz")]
    pub gyro_columns: Vec<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the chosen gyro calibration (bias, matrix raw → rad/s, model) as JSON here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub detect: DetectArgs,
}

/// Three values from one or three given.
fn per_axis(v: &[f64], flag: &str) -> Result<[f64; 3]> {
    match v {
        [a] => Ok([*a; 3]),
        [a, b, c] => Ok([*a, *b, *c]),
        _ => bail!("{flag} takes one value or three (x,y,z), got {}", v.len()),
    }
}

/// The nominal sensitivity in rad/s per count from `--scale` or `--counts-per-dps`.
fn nominal(a: &Args) -> Result<[f64; 3]> {
    let s = match (&a.scale, &a.counts_per_dps) {
        (Some(s), None) => per_axis(s, "--scale")?,
        (None, Some(c)) => per_axis(c, "--counts-per-dps")?.map(|c| 1f64.to_radians() / c),
        (Some(_), Some(_)) => bail!("give either --scale or --counts-per-dps, not both"),
        (None, None) => bail!(
            "the gyro's nominal sensitivity is needed (the uncalibrated baseline and the fit's start): --scale RAD_PER_S_PER_COUNT or --counts-per-dps COUNTS (from the datasheet)"
        ),
    };
    if !s.iter().all(|x| x.is_finite() && *x != 0.0) {
        bail!("the nominal sensitivity must be finite and non-zero on every axis");
    }
    Ok(s)
}

/// What `--out` writes.
#[derive(Serialize)]
struct GyroCalFile<'a> {
    format: &'static str,
    model: &'a str,
    /// Raw counts.
    bias: [f64; 3],
    /// Raw → rad/s, row-major: `ω = matrix · (m − bias)`.
    matrix: [[f64; 3]; 3],
    units: &'static str,
    cv_rms_deg: f64,
}

/// Runs `wiical gyrofit`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    let scale = nominal(a)?;
    let acc = load(&a.file, &a.detect.load_options()?)?;
    let gyro = match &a.gyro_file {
        Some(g) => load(g, &load_options(None)?)?,
        None => load(&a.file, &load_options(Some(&a.gyro_columns))?)?,
    };
    let mut opts = GyroOptions::new(scale);
    opts.detect = a
        .detect
        .fit_options(wiical_core::multipos::MultiPosModel::Full)
        .detect;
    let rep = wiical_analysis::gyro::run(&acc, &gyro, &opts).map_err(cli_error)?;
    if let Some(path) = &a.out {
        let file = GyroCalFile {
            format: "wiical-gyro-calibration/1",
            model: rep.model,
            bias: rep.bias,
            matrix: rep.matrix,
            units: "rad/s",
            cv_rms_deg: rep.cv_rms_deg,
        };
        wiical_analysis::write::write_file(path, to_json(&file)?.as_bytes()).map_err(cli_error)?;
    }
    if a.json {
        return to_json(&rep);
    }
    Ok(text(&rep, &a.file.display().to_string()))
}

/// The readable report.
fn text(r: &GyroReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "Gyro calibration (multi-position, Tedaldi et al. 2014), {file}\n{} static windows, {} motions, {:.1} Hz",
        r.static_windows, r.motions, r.sample_rate_hz
    );
    let _ = writeln!(
        o,
        "\n{:<13} {:>6} {:>12} {:>14} {:>10}",
        "model", "params", "in-sample °", "held-out °", "ident."
    );
    for m in &r.models {
        let f = |v: Option<f64>, p: usize| v.map_or("—".to_string(), |x| format!("{x:.*}", p));
        let _ = writeln!(
            o,
            "{:<13} {:>6} {:>12} {:>14} {:>10}{}",
            m.name,
            m.parameters,
            f(m.rms_deg, 4),
            f(m.cv_rms_deg, 4),
            m.identifiability.map_or("—".into(), |x| format!("{x:.1e}")),
            if m.name == r.model {
                "  ← chosen"
            } else {
                ""
            }
        );
        if let Some(e) = &m.error {
            let _ = writeln!(o, "              ({e})");
        }
    }
    let _ = writeln!(
        o,
        "\nchosen: {} — RMS angle error {:.4}° → {:.4}° in-sample, {:.4}° on held-out motions",
        r.model, r.rms_deg_before, r.rms_deg_after, r.cv_rms_deg
    );
    let _ = writeln!(
        o,
        "bias (counts): {:.3} {:.3} {:.3}",
        r.bias[0], r.bias[1], r.bias[2]
    );
    let _ = writeln!(o, "K (raw → rad/s):");
    for row in &r.matrix {
        let _ = writeln!(o, "  {:>14.6e} {:>14.6e} {:>14.6e}", row[0], row[1], row[2]);
    }
    for n in &r.notes {
        let _ = writeln!(o, "note: {n}");
    }
    o
}
