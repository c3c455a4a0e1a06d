//! `wiical`: accelerometer / gyro / magnetometer calibration from the command line.
//!
//! Every subcommand prints a readable table, or with `--json` a JSON object whose keys are a
//! stable contract (see README.md). Errors are printed as one readable chain, exit status 1.

use anyhow::{anyhow, Context, Result};
use clap::{Parser, Subcommand};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use wiical::analyze::{self, AnalyzeOptions};
use wiical::analyze_plot;
use wiical::fit_cmd::{self, FitOptions};
use wiical::input::{self, LoadOptions};
use wiical::magfit_cmd::{self, MagModel};
use wiical::simulate::{self, Device, SimConfig, SimEffect};
use wiical::six_position_cmd::{self, PoseEstimator};
use wiical_core::multipos::MultiPosModel;
use wiical_core::Calibration;

#[derive(Parser)]
#[command(name = "wiical", version, about = "Accelerometer / gyro / magnetometer calibration for the Wii Remote, Nunchuk and friends", long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Six-position test (seed: T̂ = M·Â⁺) from a CSV with a `pose` column (x+ x- y+ y- z+ z-).
    SixPosition {
        /// CSV file: pose,x,y,z (one row per pose, or blocks of raw samples per pose).
        file: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// How a block of samples becomes a pose mean: mean | kalman.
        #[arg(long, default_value = "mean", value_parser = parse_estimator)]
        estimator: PoseEstimator,
        /// Write the calibration (JSON) here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Static-interval detection + multi-position fit (bias + scale + non-orthogonality).
    Fit {
        /// Recording: CSV with header (t,x,y,z[,temp]) or whitespace `t x y z` text.
        file: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Write the calibration (JSON) here.
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        detect: DetectArgs,
        /// Model: full (9 parameters) | diagonal (6: bias and per-axis scale).
        #[arg(long, default_value = "full", value_parser = parse_model)]
        model: MultiPosModel,
    },
    /// Residual analysis: find what the linear model leaves unexplained, trace it to a missing
    /// effect (quadratic, cubic, bias-drift, temperature, temperature-scale, outliers), add it
    /// and report the error before and after (in-sample and leave-one-window-out CV).
    Analyze {
        /// Recording (as for `fit`: raw counts or g, optional `t` and `temp` columns), or a
        /// six-position CSV with a `pose` column.
        file: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Draw the residuals before/after against the relevant regressor (SVG).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Write the final calibration, effect terms included, here (JSON).
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        detect: DetectArgs,
        /// Family-wise significance level per step (Bonferroni over the candidates).
        #[arg(long, default_value_t = 1e-3)]
        alpha: f64,
        /// A candidate must divide the cross-validated RMS by at least this factor.
        #[arg(long, default_value_t = 1.1)]
        cv_factor: f64,
        /// Only try these candidates (comma-separated names).
        #[arg(long, value_delimiter = ',')]
        candidates: Option<Vec<String>>,
    },
    /// Simulate a Wiimote/Nunchuk multi-position recording with known truth and, optionally,
    /// one effect the linear model lacks (truth written to FILE.truth.json).
    Simulate {
        /// Output CSV (t,x,y,z,temp).
        #[arg(long)]
        out: PathBuf,
        /// none | quadratic | cubic | bias-drift | temperature | outliers.
        #[arg(long, default_value = "none", value_parser = parse_effect)]
        effect: SimEffect,
        /// Size of the effect in milli-g (meaning per effect: see `wiical::simulate`).
        #[arg(long)]
        magnitude: Option<f64>,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// wiimote (~105 counts/g) | nunchuk (~200 counts/g).
        #[arg(long, default_value = "wiimote", value_parser = parse_device)]
        device: Device,
        /// Number of poses after the initial rest.
        #[arg(long, default_value_t = 30)]
        poses: usize,
        /// Leave out the temperature column.
        #[arg(long)]
        no_temp: bool,
    },
    /// Record a Wii Remote's (and Nunchuk's) accelerometer over Bluetooth HID to CSV.
    ///
    /// Columns t,x,y,z (+ ext_x,ext_y,ext_z with a Nunchuk), raw counts; the factory
    /// calibrations go to OUT.cal.json. `--guided N` walks through N still poses for `fit`.
    Capture(wiical::capture::CaptureArgs),
    /// Talk to a wiical adapter over its serial port: info, get, put CAL.json, commit, stream.
    Device(wiical::device::DeviceArgs),
    /// Run the adapter's logic with a simulated Nunchuk and flash, serving the wire protocol
    /// on a pseudo-terminal (prints its path).
    #[cfg(unix)]
    DeviceSim(wiical::device_sim::SimArgs),
    /// Magnetometer hard/soft-iron fit: sphere (4 parameters), axis-aligned ellipsoid (6) or
    /// rotated ellipsoid (9), from streaming normal equations solved by Cholesky.
    Magfit {
        /// Recording: CSV with header (mx,my,mz or x,y,z) or whitespace `x y z` text.
        file: PathBuf,
        /// sphere | axis | ellipsoid.
        #[arg(long, default_value = "ellipsoid", value_parser = clap::value_parser!(MagModel))]
        model: MagModel,
        /// Header names of the x,y,z columns to use.
        #[arg(long, value_delimiter = ',')]
        columns: Option<Vec<String>>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Write the calibration (centre as bias, W/radius as matrix: unit field) here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Decode a factory accelerometer calibration block (hex bytes) of a Wii Remote (10 bytes
    /// at EEPROM 0x16, or both copies) or a Nunchuk (16 bytes at 0x20, or 0x20–0x3F).
    DecodeCal {
        /// wiimote | nunchuk.
        #[arg(long)]
        device: String,
        /// The bytes, e.g. "82 82 82 15 9C 9C 9E 38 40 3E" (spaces, commas, 0x prefixes allowed).
        #[arg(num_args = 1.., required = true)]
        hex: Vec<String>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// The Wiimote article's Kalman filter ([position, velocity, bias]) as a Monte Carlo:
    /// a still accelerometer with a 0.25 m/s² bias, positions every 0.01 s with 0.5 cm noise.
    KalmanDemo {
        /// Number of independent runs.
        #[arg(long, default_value_t = 1000)]
        runs: u32,
        /// Random seed (same seed, same report).
        #[arg(long, default_value_t = 2008)]
        seed: u64,
        /// Accelerometer white noise per sample, m/s².
        #[arg(long)]
        accel_noise: Option<f64>,
        /// Position measurement noise, m.
        #[arg(long)]
        pos_noise: Option<f64>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(clap::Args, Clone)]
struct DetectArgs {
    /// Header names of the x,y,z columns to use (e.g. gx,gy,gz).
    #[arg(long, value_delimiter = ',')]
    columns: Option<Vec<String>>,
    /// Variance window, seconds.
    #[arg(long, default_value_t = 1.0)]
    window_s: f64,
    /// Initial rest period (noise reference), seconds.
    #[arg(long, default_value_t = 2.0)]
    init_s: f64,
    /// Shortest static interval, seconds.
    #[arg(long, default_value_t = 2.0)]
    min_static_s: f64,
    /// Static when window variance ≤ THRESHOLD × rest-period variance.
    #[arg(long, default_value_t = 6.0)]
    threshold: f64,
    /// Sample rate when the file has no time column or Fs metadata, Hz.
    #[arg(long, default_value_t = 100.0)]
    rate_hz: f64,
    /// ADC limits LO:HI; static samples at a limit are refused as saturated (default: inferred
    /// from integer data: 8-bit, 10-bit or 16-bit).
    #[arg(long, value_parser = parse_range)]
    adc_range: Option<(f64, f64)>,
}

impl DetectArgs {
    fn load_options(&self) -> Result<LoadOptions> {
        load_options(self.columns.as_deref())
    }

    fn fit_options(&self, model: MultiPosModel) -> FitOptions {
        FitOptions {
            window_s: self.window_s,
            init_s: self.init_s,
            min_static_s: self.min_static_s,
            threshold_factor: self.threshold,
            default_rate_hz: self.rate_hz,
            model,
            adc_range: self.adc_range,
        }
    }
}

/// `--columns x,y,z`: exactly three header names.
fn load_options(columns: Option<&[String]>) -> Result<LoadOptions> {
    let columns = match columns {
        None => None,
        Some([x, y, z]) => Some([x.clone(), y.clone(), z.clone()]),
        Some(other) => {
            return Err(anyhow!(
                "--columns needs exactly three names (x,y,z), got {}: {}",
                other.len(),
                other.join(",")
            ))
        }
    };
    Ok(LoadOptions { columns })
}

fn parse_effect(s: &str) -> Result<SimEffect, String> {
    SimEffect::parse(s).ok_or_else(|| {
        format!("'{s}': expected none, quadratic, cubic, bias-drift, temperature or outliers")
    })
}

fn parse_device(s: &str) -> Result<Device, String> {
    Device::parse(s).ok_or_else(|| format!("'{s}': expected wiimote or nunchuk"))
}

fn parse_estimator(s: &str) -> Result<PoseEstimator, String> {
    match s {
        "mean" => Ok(PoseEstimator::Mean),
        "kalman" => Ok(PoseEstimator::Kalman),
        _ => Err(format!("'{s}': expected mean or kalman")),
    }
}

fn parse_model(s: &str) -> Result<MultiPosModel, String> {
    match s {
        "full" => Ok(MultiPosModel::Full),
        "diagonal" => Ok(MultiPosModel::Diagonal),
        _ => Err(format!("'{s}': expected full or diagonal")),
    }
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
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
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(format!("'{s}': need finite LO < HI"));
    }
    Ok((lo, hi))
}

fn to_json<T: serde::Serialize>(v: &T) -> Result<String> {
    Ok(serde_json::to_string_pretty(v)? + "\n")
}

fn write_calibration(path: &Path, cal: &Calibration) -> Result<()> {
    cal.validate()
        .map_err(|e| anyhow!("refusing to write an invalid calibration: {e}"))?;
    let text = serde_json::to_string_pretty(cal)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}

fn fmt_row(v: &[f32]) -> String {
    v.iter()
        .map(|x| format!("{x:>13.6}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn run(cli: Cli) -> Result<String> {
    let mut o = String::new();
    match cli.cmd {
        Cmd::SixPosition {
            file,
            json,
            estimator,
            out,
        } => {
            let rec = input::load(&file, &LoadOptions::default())?;
            let rep = six_position_cmd::run(&rec, estimator)?;
            if let Some(path) = &out {
                let cal = Calibration {
                    bias: rep.bias,
                    matrix: rep.d_inv,
                    effects: Default::default(),
                };
                write_calibration(path, &cal)?;
            }
            if json {
                return to_json(&rep);
            }
            writeln!(o, "Six-position test (T̂ = M·Â⁺), {}", file.display())?;
            writeln!(o, "\nT̂ = [D | b]:")?;
            for r in &rep.t_hat {
                writeln!(o, "  {}", fmt_row(r))?;
            }
            writeln!(o, "\nD⁻¹ (correction a = D⁻¹(m − b)):")?;
            for r in &rep.d_inv {
                writeln!(o, "  {}", fmt_row(r))?;
            }
            writeln!(o, "\nb: {}", fmt_row(&rep.bias))?;
            writeln!(o, "\nResidual M − T̂Â (columns x+ x- y+ y- z+ z-):")?;
            for r in &rep.residual {
                writeln!(o, "  {}", fmt_row(r))?;
            }
            Ok(o)
        }
        Cmd::Fit {
            file,
            json,
            out,
            detect,
            model,
        } => {
            let rec = input::load(&file, &detect.load_options()?)?;
            let rep = fit_cmd::run(&rec, &detect.fit_options(model))?;
            if let Some(path) = &out {
                write_calibration(path, &rep.calibration)?;
            }
            if json {
                return to_json(&rep);
            }
            writeln!(
                o,
                "Multi-position fit of {} ({} samples): {} static windows",
                file.display(),
                rec.len(),
                rep.static_windows
            )?;
            if rec.skipped_empty_rows > 0 {
                writeln!(
                    o,
                    "({} rows with empty {} skipped, e.g. while the extension was unplugged)",
                    rec.skipped_empty_rows,
                    rec.axis_columns.join(",")
                )?;
            }
            writeln!(o, "\n  #   t_start    t_end  samples   residual (mg)")?;
            for (i, w) in rep.windows.iter().enumerate() {
                writeln!(
                    o,
                    "{:>3} {:>9.2} {:>8.2} {:>8} {:>13.4}",
                    i + 1,
                    w.t_start,
                    w.t_end,
                    w.samples,
                    w.residual_mg
                )?;
            }
            writeln!(o, "\nbias b (raw): {}", fmt_row(&rep.bias))?;
            writeln!(o, "K = D⁻¹ (g per raw unit):")?;
            for r in &rep.matrix {
                writeln!(o, "  {}", fmt_row(&r.map(|x| x * 1e3)))?;
            }
            writeln!(o, "  (×1e-3)")?;
            writeln!(
                o,
                "\nRMS ‖a‖ − 1 g: {:.4} mg   max: {:.4} mg   iterations: {}",
                rep.rms_mg, rep.max_abs_mg, rep.iterations
            )?;
            Ok(o)
        }
        Cmd::Analyze {
            file,
            json,
            plot,
            out,
            detect,
            alpha,
            cv_factor,
            candidates,
        } => {
            let rec = input::load(&file, &detect.load_options()?)?;
            let opts = AnalyzeOptions {
                fit: detect.fit_options(MultiPosModel::Full),
                alpha,
                cv_factor,
                candidates,
                ..Default::default()
            };
            let rep = analyze::analyze(&rec, &opts)?;
            if let Some(path) = &out {
                write_calibration(path, &rep.calibration)?;
            }
            if let Some(path) = &plot {
                analyze_plot::write_plot(&rep, path)?;
            }
            if json {
                return to_json(&rep);
            }
            Ok(analyze::render_text(&rep, &file.display().to_string()))
        }
        Cmd::Simulate {
            out,
            effect,
            magnitude,
            seed,
            device,
            poses,
            no_temp,
        } => {
            let cfg = SimConfig {
                effect,
                magnitude_mg: magnitude,
                seed,
                device,
                poses,
                temp_column: !no_temp,
                ..Default::default()
            };
            let sim = simulate::simulate(&cfg)?;
            let truth = simulate::write(&sim, &out)?;
            writeln!(
                o,
                "wrote {} ({} samples, {} poses, {} {}, effect {} at {} mg) and the truth {}",
                out.display(),
                sim.recording.len(),
                sim.truth.poses.len() - 1,
                sim.truth.device,
                if sim.recording.temp.is_some() {
                    "with temp"
                } else {
                    "without temp"
                },
                sim.truth.effect,
                sim.truth.magnitude_mg,
                truth.display()
            )?;
            Ok(o)
        }
        Cmd::Capture(args) => wiical::capture::run(&args),
        Cmd::Device(args) => wiical::device::run(&args, &mut std::io::stdout().lock()),
        #[cfg(unix)]
        Cmd::DeviceSim(args) => wiical::device_sim::run(&args),
        Cmd::Magfit {
            file,
            model,
            columns,
            json,
            out,
        } => {
            let rec = input::load(&file, &load_options(columns.as_deref())?)?;
            let rep = magfit_cmd::fit_points(&rec.xyz, model)?;
            if let Some(path) = &out {
                let k = rep.matrix.map(|r| r.map(|x| (x / rep.radius) as f32));
                let cal = Calibration {
                    bias: rep.center.map(|x| x as f32),
                    matrix: k,
                    effects: Default::default(),
                };
                write_calibration(path, &cal)?;
            }
            if json {
                return to_json(&rep);
            }
            writeln!(
                o,
                "Magnetometer {} fit of {} ({} samples)",
                rep.model,
                file.display(),
                rep.samples
            )?;
            let c = rep.center.map(|x| x as f32);
            writeln!(o, "  centre (hard iron): {}", fmt_row(&c))?;
            writeln!(o, "  soft-iron W (det 1), ‖W(m − c)‖ ≈ R:")?;
            for r in &rep.matrix {
                writeln!(o, "    {}", fmt_row(&r.map(|x| x as f32)))?;
            }
            writeln!(o, "  field strength R: {:.3}", rep.radius)?;
            writeln!(
                o,
                "  fit error: {:.3} % of field strength   RMS radius error: {:.3}",
                rep.fit_error_pct, rep.rms_radius_error
            )?;
            Ok(o)
        }
        Cmd::DecodeCal { device, hex, json } => {
            let rep = wiical::decode_cal::decode_cal(&device, &hex.join(" "))?;
            if json {
                return to_json(&rep);
            }
            writeln!(o, "{} calibration block", rep.device)?;
            writeln!(o, "  zero-g (10-bit):  {:?}", rep.zero)?;
            writeln!(o, "  one-g  (10-bit):  {:?}", rep.one_g)?;
            writeln!(o, "  counts per g:     {:?}", rep.counts_per_g)?;
            writeln!(
                o,
                "  checksum:         {}",
                if rep.checksum_ok { "ok" } else { "BAD" }
            )?;
            Ok(o)
        }
        Cmd::KalmanDemo {
            runs,
            seed,
            accel_noise,
            pos_noise,
            json,
        } => kalman_demo(runs, seed, accel_noise, pos_noise, json),
    }
}

fn kalman_demo(
    runs: u32,
    seed: u64,
    accel_noise: Option<f64>,
    pos_noise: Option<f64>,
    json: bool,
) -> Result<String> {
    let mut cfg = wiical::kalman_demo::KalmanDemoConfig {
        runs,
        seed,
        ..Default::default()
    };
    if let Some(a) = accel_noise {
        cfg.accel_noise = a;
    }
    if let Some(p) = pos_noise {
        cfg.pos_noise_m = p;
    }
    let rep = wiical::kalman_demo::run(&cfg)?;
    if json {
        return to_json(&rep);
    }
    let mut o = String::new();
    writeln!(
        o,
        "Kalman [p, v, b] demo: {} runs, seed {}, true bias {} m/s², σ_p {} m, σ_a {} m/s²",
        rep.runs, cfg.seed, rep.true_bias, cfg.pos_noise_m, cfg.accel_noise
    )?;
    writeln!(
        o,
        "  |b̂ − b| after {} s: median {:.4} m/s², 95th percentile {:.4} m/s²",
        cfg.duration_s, rep.median_abs_bias_error_1s, rep.p95_abs_bias_error_1s
    )?;
    writeln!(
        o,
        "  mean NEES {:.3} (state dimension 3: a consistent filter gives ≈ 3)",
        rep.nees_mean
    )?;
    Ok(o)
}

fn main() {
    let cli = Cli::parse();
    match run(cli) {
        Ok(text) => {
            // A closed pipe (`wiical … | head`) is not an error worth a panic.
            let mut stdout = std::io::stdout().lock();
            if let Err(e) = stdout
                .write_all(text.as_bytes())
                .and_then(|_| stdout.flush())
            {
                if e.kind() != std::io::ErrorKind::BrokenPipe {
                    eprintln!("error: cannot write output: {e}");
                    std::process::exit(1);
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
