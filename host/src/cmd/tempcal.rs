//! `wiical tempcal`: the bias of a still warm-up against temperature, per axis, and the
//! autopilots' parameter files (engine: [`wiical_analysis::tempcal()`] with a
//! [`wiical_analysis::TempcalRequest`]).

use super::{check_outputs, to_json};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::{anyhow, bail, Result};
use std::path::PathBuf;
use wiical_analysis::output::calfile::CalibrationFile;
use wiical_analysis::tempcal::{params, TempcalError, TempcalOptions, TempcalReport, STILL_RATIO};
use wiical_analysis::TempcalRequest;

/// What `--format` writes.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// ArduPilot `.parm` (`INS_TCAL1_*`, `NAME VALUE` per line).
    Ardupilot,
    /// PX4 / QGroundControl `.params` (`TC_A0_*`, tab-separated).
    Px4,
    /// The calibration file given with `--calibration`, its `bias_temp` set to the linear fit.
    Calfile,
}

/// The values' units, when the magnitude does not tell.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    /// Standard gravity.
    G,
    /// m/s².
    #[value(name = "m/s2")]
    Ms2,
}

/// Arguments of `wiical tempcal`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A still warm-up recording: x,y,z and a temperature column (temp, temperature, temp_c),
    /// one pose or several, each held while the temperature changes (.gz read as is).
    pub file: PathBuf,
    /// Header names of the x,y,z columns to use.
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Reference temperature T_ref of the polynomial, °C (ArduPilot's TCAL uses 35).
    #[arg(long, default_value_t = wiical_analysis::tempcal::TEMP_REF_C, allow_negative_numbers = true, value_parser = engine_range(wiical_analysis::tempcal::check_tref_c))]
    pub tref: f64,
    /// Contiguous segments (by time) for the leave-one-segment-out choice of order, 2–50.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u16).range(2..=50))]
    pub segments: u16,
    /// Samples are averaged over blocks this long before the fit, s.
    #[arg(long, default_value_t = 1.0, value_parser = super::duration_s)]
    pub block_s: f64,
    /// A block more than this many degrees from its pose's first block starts a new pose
    /// (above 0, below 180).
    #[arg(long, default_value_t = 10.0, value_parser = engine_range(wiical_analysis::tempcal::check_pose_deg))]
    pub pose_deg: f64,
    /// Sample rate when the file has no time column or Fs metadata, Hz (above 0, at most
    /// 1 MHz: the range every other door checks).
    #[arg(long, default_value_t = 100.0, value_parser = super::rate_hz)]
    pub rate_hz: f64,
    /// The values' units, for the autopilot formats (m/s²), when the magnitude does not say
    /// g or m/s².
    #[arg(long, value_enum)]
    pub units: Option<Units>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Draw each axis's bias against temperature with the fitted polynomial (SVG).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write ArduPilot (INS_TCAL1_*) or PX4 (TC_A0_*) parameters, or `calfile`: the
    /// calibration of --calibration with the linear temperature term — to --out, else to
    /// standard output.
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// The calibration file (from `fit`/`analyze --out`, same raw units as FILE) that
    /// `--format calfile` adds the temperature term to; its reference temperature is --tref.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Where --format writes (atomically).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A parser through one of the engine's range checks (the Python keywords use the same).
fn engine_range(
    check: fn(f64) -> std::result::Result<f64, wiical_analysis::tempcal::TempcalError>,
) -> impl Fn(&str) -> std::result::Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a number"))?;
        check(v).map_err(|e| format!("'{s}': {e}"))
    }
}

impl Args {
    /// The engine's request from the flags (`--format`, `--calibration`, `--units`, `--out`,
    /// `--plot` and `--json` are the command line's own).
    fn request(&self) -> TempcalRequest {
        TempcalRequest {
            columns: self.columns.clone(),
            read: self.read.options(),
            options: TempcalOptions {
                t_ref_c: self.tref,
                segments: self.segments.into(),
                block_s: self.block_s,
                pose_deg: self.pose_deg,
                default_rate_hz: self.rate_hz,
            },
            ..TempcalRequest::new(self.file.as_path())
        }
    }
}

/// Runs `wiical tempcal`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    if a.out.is_some() && a.format.is_none() {
        bail!(
            "--out writes a parameter or calibration file: give --format ardupilot, px4 or calfile"
        );
    }
    if (a.format == Some(Format::Calfile)) != a.calibration.is_some() {
        bail!("--format calfile and --calibration CAL.json go together (the calibration the temperature term is added to)");
    }
    if a.json && a.format.is_some() && a.out.is_none() {
        bail!(
            "--json and --format both print to standard output: give --out for the --format file"
        );
    }
    let mut inputs = vec![a.file.as_path()];
    inputs.extend(a.calibration.as_deref());
    check_outputs(&inputs, &[a.plot.as_deref(), a.out.as_deref()])?;
    let req = a.request();
    let opts = req.load_options().map_err(cli_error)?;
    let rec = super::load_held(&a.file, &opts, "tempcal", super::CUT_IT_SHORTER)?;
    // The calibration `--format calfile` adds to: read and checked before anything is fitted
    // or written.
    let cal = match a.calibration.as_deref() {
        Some(path) => Some(suited_calibration(a, path, &rec)?),
        None => None,
    };
    let rep = super::with_spinner("fitting bias against temperature", || req.run(&rec))
        .map_err(|e| tempcal_error(e).context(format!("in {}", a.file.display())))?;
    warn_not_still(&rep, &a.file);
    if let Some(path) = &a.plot {
        render::tempcal::write_plot(&rep, path)?;
    }
    let written = match a.format {
        Some(f) => Some(output(a, f, &rep, cal)?),
        None => None,
    };
    if a.json {
        return to_json(&rep);
    }
    match (written, &a.out) {
        (Some(text), None) => Ok(text),
        _ => Ok(render::tempcal::text(&rep, &a.file.display().to_string())),
    }
}

/// A warning on stderr when the residual is well above the block-to-block noise.
fn warn_not_still(rep: &TempcalReport, file: &std::path::Path) {
    let high: Vec<String> = rep
        .axes
        .iter()
        .filter_map(|x| {
            x.noise_ratio
                .filter(|r| *r > STILL_RATIO)
                .map(|r| format!("{} {r:.1}×", x.column))
        })
        .collect();
    if !high.is_empty() {
        eprintln!(
            "warning: in {}: the residual is far above the block-to-block noise ({}): the poses were not still (or the bias depends on more than the temperature); the coefficients describe this record, not the sensor's temperature response",
            file.display(),
            high.join(", ")
        );
    }
}

/// The engine's refusals, naming this command's flags where a setting is concerned (clap
/// checks them first; the engine checks again for other callers).
fn tempcal_error(e: TempcalError) -> anyhow::Error {
    match e {
        TempcalError::Setting { what } => {
            anyhow!("{what} (--tref, --segments, --block-s, --pose-deg)")
        }
        other => anyhow::Error::new(other),
    }
}

/// The text of `--format` (written to `--out` when given); `cal` is the calibration of
/// `--calibration` (read by [`suited_calibration`]).
fn output(
    a: &Args,
    f: Format,
    rep: &TempcalReport,
    cal: Option<CalibrationFile>,
) -> Result<String> {
    let text = match (f, cal) {
        (Format::Ardupilot, _) => params::ardupilot(rep, to_ms2(a, rep)?),
        (Format::Px4, _) => params::px4(rep, to_ms2(a, rep)?),
        (Format::Calfile, Some(cal)) => calfile(a, rep, cal)?,
        (Format::Calfile, None) => bail!("--format calfile needs --calibration"),
    };
    if let Some(path) = &a.out {
        wiical_analysis::output::write::write_file(path, text.as_bytes()).map_err(cli_error)?;
    }
    Ok(text)
}

/// m/s² per file unit.
fn to_ms2(a: &Args, rep: &TempcalReport) -> Result<f64> {
    match (a.units, rep.units.as_str()) {
        (Some(Units::G), _) | (None, "g") => Ok(params::G),
        (Some(Units::Ms2), _) | (None, "m/s^2") => Ok(1.0),
        _ => bail!(
            "the values of {} are not in g or m/s² by their magnitude (raw counts?); the autopilots' parameters are in m/s²: convert the recording, or give --units g or --units m/s2 if it is in those units",
            a.file.display()
        ),
    }
}

/// The calibration file at `path` (`--calibration`), refused when it is in other units than
/// the warm-up `rec` (`correct`'s check): the fitted slope is in the warm-up's units per °C,
/// and written into a calibration of other units (g per °C into a raw-counts file) it would
/// be wrong by the ratio of the two.
fn suited_calibration(
    a: &Args,
    path: &std::path::Path,
    rec: &wiical_analysis::Recording,
) -> Result<CalibrationFile> {
    let file = wiical_analysis::output::calfile::read_calibration_file(path).map_err(cli_error)?;
    wiical_analysis::correct::check_units(&file.calibration, rec).map_err(|e| {
        anyhow!(
            "--calibration {} does not suit {}: {e}",
            path.display(),
            a.file.display()
        )
    })?;
    Ok(file)
}

/// The calibration of `--calibration` (`file`) with `bias_temp` = the linear fit's slope and
/// `temp_ref_c` = `--tref` (the calibration file holds a linear temperature term only).
fn calfile(a: &Args, rep: &TempcalReport, mut file: CalibrationFile) -> Result<String> {
    let path = a
        .calibration
        .as_deref()
        .unwrap_or(std::path::Path::new("-"));
    let e = &mut file.calibration.effects;
    if e.bias_temp.iter().any(|v| *v != 0.0) {
        eprintln!(
            "note: {}'s temperature term {:?} (at {} °C) is replaced",
            path.display(),
            e.bias_temp,
            e.temp_ref_c
        );
    }
    e.temp_ref_c = rep.t_ref_c as f32;
    e.bias_temp = std::array::from_fn(|j| rep.axes[j].linear[0] as f32);
    if rep.axes.iter().any(|x| x.order > 1) {
        eprintln!("note: the calibration file holds a linear temperature term only: the linear fit is written (orders chosen {}; --format ardupilot/px4 carry the polynomial)", rep.axes.iter().map(|x| x.order.to_string()).collect::<Vec<_>>().join(","));
    }
    file.calibration
        .validate()
        .map_err(|e| anyhow!("the calibration with the temperature term is invalid: {e}"))?;
    wiical_analysis::output::calfile::to_json_with(&file.calibration, file.quality.as_ref())
        .map_err(cli_error)
}
