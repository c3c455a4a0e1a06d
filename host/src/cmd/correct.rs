//! `wiical correct`: a recording corrected with a calibration file, host terms included
//! (`wiical_analysis::correct`): what a host with a clock and a thermometer applies, where
//! the adapter applies only the core's acceleration terms.

use super::{check_outputs, load_options, print_notes, with_spinner};
use crate::cli_error::cli_error;
use anyhow::Result;
use std::path::PathBuf;
use wiical_analysis::correct::correct_recording;
use wiical_analysis::correct::csv::write_corrected;
use wiical_analysis::correct::pass::correct_streamed;
use wiical_analysis::input::front_door::{load_samples, HoldLimit, Input};
use wiical_analysis::output::calfile::read_calibration_file;

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
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0, value_parser = super::rate_hz, allow_negative_numbers = true)]
    pub rate_hz: f64,
}

/// Runs `wiical correct`; returns the summary line. A large plain text file (and standard
/// input spooled to a temporary file) is corrected as it is read, in bounded memory
/// (`wiical_analysis::correct::pass`); the output is the same file either way.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.calibration, &a.recording], &[Some(&a.out)])?;
    let file = read_calibration_file(&a.calibration).map_err(cli_error)?;
    let opts = load_options(a.columns.as_deref(), &a.read)?;
    // Millions of rows take seconds to read: say so (hidden when stderr is not a terminal).
    // A recording that must be held (a raw file) is refused beyond the held bound.
    let limit = HoldLimit::of(
        "correct",
        "a text file (plain or gzip'd) of any length is read in passes: cut the raw recording shorter or convert it to text",
    );
    let samples = with_spinner(&format!("reading {}", a.recording.display()), || {
        load_samples(&a.recording, &opts, Some(limit))
    })
    .map_err(cli_error)?;
    print_notes(&a.recording, samples.recording());
    let (n, applied) = match samples {
        Input::Stream(src) => {
            let c = with_spinner(&format!("correcting {}", a.recording.display()), || {
                correct_streamed(&file, &src, a.rate_hz, &a.out, &a.recording)
            })
            .map_err(cli_error)?;
            (c.samples, c.applied)
        }
        held => {
            let c = correct_recording(&file, held.recording(), a.rate_hz)
                .map_err(|e| cli_error(e.in_file(&a.recording)))?;
            write_corrected(&a.out, &c).map_err(cli_error)?;
            (c.accel.len(), c.applied)
        }
    };
    Ok(format!(
        "{n} samples corrected to {} with {}\n",
        a.out.display(),
        applied.join(", ")
    ))
}
