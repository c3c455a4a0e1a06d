//! One module per subcommand: parse its arguments, call the library, render the result.
//! Shared here: the detection flags, the small value parsers and JSON output.

pub mod analyze;
pub mod batch;
pub mod calibrate;
pub mod capture;
pub mod correct;
pub mod decode_cal;
pub mod device;
pub mod device_gyro;
pub mod device_sim;
pub mod fit;
pub mod gyrofit;
pub mod kalman_demo;
pub mod live;
pub mod magfit;
pub mod noise;
pub mod simulate;
pub mod six_position;
pub mod tempcal;

use crate::cli_error::cli_error;
use anyhow::Result;
use std::path::Path;
use wiical_analysis::detect::windows;
use wiical_analysis::input::front_door::{load_input, Input};
use wiical_analysis::input::read_options::{ReadOptions, SpillMode};
use wiical_analysis::input::window_means::WindowInputOptions;
use wiical_analysis::report::verdict::Quality;
use wiical_analysis::{DetectOptions, Error, FitOptions, LoadOptions};
use wiical_core::multipos::MultiPosModel;

/// Static-window detection flags (`fit`, `analyze`).
#[derive(clap::Args, Clone, Debug)]
pub struct DetectArgs {
    /// Header names of the x,y,z columns to use (e.g. gx,gy,gz).
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// Variance window, seconds (any of the four detector flags switches from the adaptive
    /// detector to the IMU-TK one with an initial rest period; defaults 1, 2, 2, 6).
    #[arg(long, value_parser = duration_s, allow_negative_numbers = true)]
    pub window_s: Option<f64>,
    /// Initial rest period (noise reference), seconds.
    #[arg(long, value_parser = duration_s, allow_negative_numbers = true)]
    pub init_s: Option<f64>,
    /// Shortest static interval, seconds.
    #[arg(long, value_parser = duration_s, allow_negative_numbers = true)]
    pub min_static_s: Option<f64>,
    /// Static when window variance ≤ THRESHOLD × rest-period variance.
    #[arg(long, value_parser = threshold, allow_negative_numbers = true)]
    pub threshold: Option<f64>,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0, value_parser = rate_hz, allow_negative_numbers = true)]
    pub rate_hz: f64,
    /// ADC limits LO:HI; static samples at a limit are refused as saturated (default: inferred
    /// from integer data: 8-bit, 10-bit or 16-bit).
    #[arg(long, value_parser = parse_range)]
    pub adc_range: Option<(f64, f64)>,
    /// Every row is already one still window (x,y,z means; optional SD, n, temp, t columns):
    /// analyse the rows directly, no static detection. Files with per-axis SD columns (sdx,
    /// sd_x, x_sd, std_x, …) or a sample-count column (n, samples) are read so without it.
    #[arg(long)]
    pub windows: bool,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: ReadArgs,
}

impl DetectArgs {
    /// The loader's options (`--columns`, and how the file is read).
    pub fn load_options(&self) -> Result<LoadOptions> {
        load_options(self.columns.as_deref(), &self.read)
    }

    /// Reads `path` (once: it may be standard input) as a window-mean table when its header
    /// says so or `--windows` is given, else as a recording of samples (notes on the file go
    /// to stderr as warnings, as [`load`] does).
    pub fn input(&self, path: &Path) -> Result<Input> {
        let opts = WindowInputOptions {
            load: self.load_options()?,
            force: self.windows,
        };
        // Millions of rows take seconds to read: say so (hidden when stderr is not a terminal).
        let input = with_spinner(&format!("reading {}", path.display()), || {
            load_input(path, &opts)
        })
        .map_err(cli_error)?;
        match &input {
            Input::Samples(rec) => print_notes(path, rec),
            Input::Stream(src) => print_notes(path, &src.meta),
            Input::Table(_) if self.detector_flags_given() || self.adc_range.is_some() => {
                eprintln!(
                    "warning: in {}: the rows are windows already: the detector settings are not used",
                    path.display()
                );
            }
            // A raw file's still-epoch table keeps the reader's warnings (skipped blocks).
            Input::Table(t) => {
                for note in &t.recording.notes {
                    eprintln!("warning: in {}: {note}", path.display());
                }
            }
        }
        Ok(input)
    }

    /// True when any of the IMU-TK detector's flags is given.
    fn detector_flags_given(&self) -> bool {
        self.window_s.is_some()
            || self.init_s.is_some()
            || self.min_static_s.is_some()
            || self.threshold.is_some()
    }

    /// The base fit's options.
    pub fn fit_options(&self, model: MultiPosModel) -> FitOptions {
        FitOptions {
            detect: DetectOptions::from_settings(
                self.window_s,
                self.init_s,
                self.min_static_s,
                self.threshold,
                self.rate_hz,
                self.adc_range,
            ),
            model,
        }
    }
}

/// `--columns x,y,z`: exactly three header names; the file read as `read` says.
pub fn load_options(columns: Option<&[String]>, read: &ReadArgs) -> Result<LoadOptions> {
    let columns = match columns {
        None => None,
        Some([x, y, z]) => Some([x.clone(), y.clone(), z.clone()]),
        Some(other) => return Err(cli_error(Error::ColumnsNotThree(other.to_vec()))),
    };
    Ok(LoadOptions {
        columns,
        read: read.options(),
        ..Default::default()
    })
}

/// How a file is read ([`ReadOptions`]): flags hidden from `--help`, for tests and benchmarks
/// that compare the held and the streamed paths on one file; without them every command
/// reads as [`ReadOptions::default`] says.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ReadArgs {
    /// Stream plain text files of at least BYTES (read in passes; standard input longer than
    /// it is copied to a temporary file): 0 streams every one (default 128 MiB).
    #[arg(long, hide = true, value_name = "BYTES")]
    pub stream_from_bytes: Option<u64>,
    /// The most bytes of standard input copied to a temporary file (default 64 GiB).
    #[arg(long, hide = true, value_name = "BYTES")]
    pub max_spool_bytes: Option<u64>,
    /// Where a streamed file's first pass keeps its rows for the later passes: auto (memory,
    /// else a temporary file), disk.
    #[arg(long, hide = true, value_enum)]
    pub spill: Option<SpillArg>,
}

/// `--spill`: [`SpillMode`] on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpillArg {
    /// In memory while the rows fit, else a temporary file.
    Auto,
    /// Always a temporary file.
    Disk,
}

impl ReadArgs {
    /// The library's options: each flag given, else its default.
    pub fn options(&self) -> ReadOptions {
        let d = ReadOptions::default();
        ReadOptions {
            stream_from_bytes: self.stream_from_bytes.unwrap_or(d.stream_from_bytes),
            max_spool_bytes: self.max_spool_bytes.unwrap_or(d.max_spool_bytes),
            spill: match self.spill {
                None => d.spill,
                Some(SpillArg::Auto) => SpillMode::Auto,
                Some(SpillArg::Disk) => SpillMode::Disk,
            },
        }
    }
}

/// A finite number > 0 (rates, durations).
pub fn positive_finite(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("'{s}': must be a finite number above 0"))
    }
}

/// A duration in seconds, 1 ms to 10⁶ s (the analysis crate's range, shared with the Python
/// package).
pub fn duration_s(s: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    windows::check_duration_s(v).map_err(|e| format!("'{s}': {e}"))
}

/// A sample rate in Hz: above 0, at most 1 MHz (the analysis crate's range).
pub fn rate_hz(s: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    windows::check_rate_hz(v).map_err(|e| format!("'{s}': {e}"))
}

/// A variance-ratio threshold: above 1, at most 10⁶ (the analysis crate's range).
pub fn threshold(s: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    windows::check_threshold(v).map_err(|e| format!("'{s}': {e}"))
}

/// A noise standard deviation: above 0, at most `max` in `unit`.
pub fn noise_sigma(s: &str, max: f64, unit: &str) -> Result<f64, String> {
    let v = positive_finite(s)?;
    if v <= max {
        Ok(v)
    } else {
        Err(format!(
            "'{s}': give a noise level above 0 and at most {max} {unit}"
        ))
    }
}

/// `LO:HI` with finite LO < HI.
pub fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected LO:HI"))?;
    let lo: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("'{a}' is not a number"))?;
    let hi: f64 = b
        .trim()
        .parse()
        .map_err(|_| format!("'{b}' is not a number"))?;
    windows::check_adc_range((lo, hi)).map_err(|e| format!("'{s}': {e}"))
}

/// Pretty JSON with a final newline (every `--json`).
pub fn to_json<T: serde::Serialize>(v: &T) -> Result<String> {
    Ok(serde_json::to_string_pretty(v)? + "\n")
}

/// Loads a recording, errors told the CLI's way.
/// Which axis triplet was taken (when the header offers several) goes to stderr as a note;
/// notes on the file (time gaps, a millisecond-looking time step) go there as warnings.
pub fn load(path: &std::path::Path, opts: &LoadOptions) -> Result<wiical_analysis::Recording> {
    // Millions of rows take seconds to read: say so (hidden when stderr is not a terminal).
    let rec = with_spinner(&format!("reading {}", path.display()), || {
        wiical_analysis::load(path, opts)
    })
    .map_err(cli_error)?;
    print_notes(path, &rec);
    Ok(rec)
}

/// [`load`] for a command that holds the whole recording: refused beyond
/// `front_door::MAX_HELD_SAMPLES` in one sentence naming the file, the bound and `instead`.
pub fn load_held(
    path: &std::path::Path,
    opts: &LoadOptions,
    command: &'static str,
    instead: &'static str,
) -> Result<wiical_analysis::Recording> {
    use wiical_analysis::input::front_door::{load_held as held, HoldLimit};
    let limit = HoldLimit::of(command, instead);
    let rec = with_spinner(&format!("reading {}", path.display()), || {
        held(path, opts, limit)
    })
    .map_err(cli_error)?;
    print_notes(path, &rec);
    Ok(rec)
}

/// What reads a recording too long for `magfit` or `gyrofit` to hold ([`load_held`]).
pub const PLAIN_TEXT_IN_PASSES: &str =
    "a plain text file (not gzip'd, not raw) of any length is read in passes: decompress it or export it as text";

/// What reads a recording too long for `tempcal` or `six-position` to hold.
pub const CUT_IT_SHORTER: &str =
    "cut the recording shorter (`fit`, `analyze`, `correct` and `noise` read any length in passes)";

/// What the loader chose (which triplet, a GRT file) as notes, what it noticed about the
/// file (time gaps, bursts) as warnings, on stderr.
pub fn print_notes(path: &Path, rec: &wiical_analysis::Recording) {
    for note in &rec.info {
        eprintln!("note: in {}: {note}", path.display());
    }
    for note in &rec.notes {
        eprintln!("warning: in {}: {note}", path.display());
    }
}

/// Writes a calibration file (`--out`), errors told the CLI's way.
pub fn write_calibration(path: &std::path::Path, cal: &wiical_core::Calibration) -> Result<()> {
    wiical_analysis::output::calfile::write_calibration(path, cal).map_err(cli_error)
}

/// Writes a calibration file with the fit's quality verdict (`fit --out`, `analyze --out`).
pub fn write_calibration_with(
    path: &std::path::Path,
    cal: &wiical_core::Calibration,
    quality: &Quality,
) -> Result<()> {
    wiical_analysis::output::calfile::write_calibration_with(path, cal, Some(quality))
        .map_err(cli_error)
}

/// Refuses, before anything is read or written, outputs that are an input or each other.
/// `None`s (options not given) are skipped.
pub fn check_outputs(inputs: &[&Path], outputs: &[Option<&Path>]) -> Result<()> {
    let outputs: Vec<&Path> = outputs.iter().flatten().copied().collect();
    wiical_analysis::output::write::check_outputs(inputs, &outputs).map_err(cli_error)
}

/// Runs `work` with an indicatif progress display on stderr, fed by the analysis's progress
/// callback: a spinner while the stage has no known total (detection), a bar of the
/// candidates fitted of the step's total during the greedy search. Hidden when stderr is
/// not a terminal (indicatif's stderr target draws nothing then), so scripted output, tests
/// and goldens are unchanged.
pub fn with_progress<T>(work: impl FnOnce(wiical_analysis::ProgressHook) -> T) -> T {
    let bar =
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr());
    let spinner = indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner());
    let counted =
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} ({elapsed})")
            .map(|s| s.progress_chars("=> "))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar());
    bar.set_style(spinner.clone());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let shown = bar.clone();
    let hook = wiical_analysis::ProgressHook::new(move |p| {
        if p.total == 0 {
            shown.set_style(spinner.clone());
        } else {
            shown.set_length(p.total as u64);
            shown.set_position(p.done as u64);
            shown.set_style(counted.clone());
        }
        shown.set_message(p.to_string());
    });
    let out = work(hook);
    bar.finish_and_clear();
    out
}

/// Runs `work` with an indicatif spinner on stderr saying `what` and the elapsed time (hidden
/// when stderr is not a terminal, so scripted output is unchanged). Analyses of long
/// recordings (thousands of windows) take seconds; the spinner says the program is working.
pub fn with_spinner<T>(what: &str, work: impl FnOnce() -> T) -> T {
    let bar =
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr());
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.set_message(what.to_string());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let out = work();
    bar.finish_and_clear();
    out
}
