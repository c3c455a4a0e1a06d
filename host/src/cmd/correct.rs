//! `wiical correct`: a recording corrected with a calibration file, host terms included
//! (`wiical_analysis::correct`): what a host with a clock and a thermometer applies, where
//! the adapter applies only the core's acceleration terms.

use super::{check_outputs, load_options};
use crate::cli_error::cli_error;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::PathBuf;
use wiical_analysis::correct::{correct_recording, Corrected};
use wiical_analysis::output::calfile::read_calibration_file;
use wiical_analysis::output::write::write_file;

/// Arguments of `wiical correct`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Calibration file (`analyze --out`, `fit --out`, …); its `host_terms` are applied too.
    pub calibration: PathBuf,
    /// Recording of samples in the units the calibration was made from (optional `t` and
    /// `temp` columns: the time and temperature terms need them).
    pub recording: PathBuf,
    /// Where to write the corrected samples: CSV `t,a_x,a_y,a_z` (s as the recording gives
    /// them, g).
    #[arg(long)]
    pub out: PathBuf,
    /// Header names of the x,y,z columns to use (e.g. ax,ay,az).
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0, value_parser = super::rate_hz, allow_negative_numbers = true)]
    pub rate_hz: f64,
}

/// Runs `wiical correct`; returns the summary line.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.calibration, &a.recording], &[Some(&a.out)])?;
    let file = read_calibration_file(&a.calibration).map_err(cli_error)?;
    let rec = super::load(&a.recording, &load_options(a.columns.as_deref())?)?;
    let c = correct_recording(&file, &rec, a.rate_hz)
        .map_err(|e| cli_error(wiical_analysis::Error::from(e).in_file(&a.recording)))?;
    write_file(&a.out, csv(&c).as_bytes()).map_err(cli_error)?;
    Ok(format!(
        "{} samples corrected to {} with {}\n",
        c.accel.len(),
        a.out.display(),
        c.applied.join(", ")
    ))
}

/// The corrected samples as CSV text.
fn csv(c: &Corrected) -> String {
    let mut s = String::with_capacity(48 * c.accel.len() + 16);
    s.push_str("t,a_x,a_y,a_z\n");
    for (t, a) in c.times.iter().zip(&c.accel) {
        // Shortest round-trip text of each value (f64 time, f32 acceleration).
        let _ = writeln!(s, "{t},{},{},{}", a[0], a[1], a[2]);
    }
    s
}
