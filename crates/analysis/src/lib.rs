//! `wiical-analysis`: the calibration analysis engine of wiical, usable from any program.
//!
//! It takes a recording of a still-then-turned 3-axis sensor (accelerometer counts, g or
//! m/s²), finds the static windows, fits the linear calibration (bias, scale,
//! non-orthogonality) with the same `f32` code the adapter firmware runs, and then asks what
//! that model leaves unexplained: it compares the residual with the noise floor, tries
//! candidate effects (nonlinearity, drift, temperature, outliers) and adds one only when it is
//! significant *and* improves the error on held-out windows. Everything here is `std` and
//! `f64`; the device-side core (`wiical-core`) is `no_std` `f32`.
//!
//! # Pipeline
//!
//! | step | module | in → out |
//! |---|---|---|
//! | load | [`mod@load`] | file or text → [`Recording`] (CSV with a header, or `t x y z` text) |
//! | raw files | [`raw`] | Axivity `.cwa` / GENEActiv `.bin` bytes → blocks → [`Recording`]; GGIR's still 10-s epochs → window-mean table; GGIRread's grid (tests) |
//! | GRT files | [`grt`] | Gesture Recognition Toolkit `.grt` text → [`Recording`] (no time) |
//! | columns | [`columns`] | header names → the wanted sensor's axis triplet by pattern |
//! | units, rate | [`recording`] | recording → sample rate; window means → `raw` / `g` / `m/s^2` |
//! | window detection | [`windows`] | recording → static windows (core detector) + f64 window statistics |
//! | window-mean input | [`window_input`] | a table of still-window means (GGIR sphere data) → the windows directly, no detection |
//! | autocalibration | [`autocal`] | still-epoch means (g) + temperature → van Hees et al. 2014 offset / scale / temperature (GGIR's method) |
//! | gyroscope | [`gyro`] | accelerometer + gyro recordings → motions between windows, gyro scale / misalignment / bias by held-out error ([`gyro::run`]) |
//! | base fit | [`fit`] | window means → 9- (or 6-) parameter [`Calibration`] (core `f32` LM) |
//! | effect model | [`model`] | base + effect blocks, f64 residual ‖a‖ − 1 g, LM, leave-one-out |
//! | held-out errors at linear cost | [`press`] | full fit → leave-one-window-out residuals (PRESS identity above 200 windows) |
//! | noise floor | [`noise`] | window variances → per-window floor, χ² of a model |
//! | candidates | [`candidate`], [`trial`], [`outliers`] | current model → each candidate's fit, F-test, CV |
//! | selection | [`select`] | the candidates' numbers → the one added (the rule and its constants) |
//! | motion check | [`motion`] | window spread → predicted shortening of each mean, correlated with the base residual (not-still windows) |
//! | evidence | [`evidence`] | the chosen effect → why (pattern, tests, runner-up), verdict |
//! | noise | [`allan`], [`noise_report`] | still recording → overlapping Allan deviation per axis and the IEEE 952 terms (`wiical noise`) |
//! | many files | [`batch`] | files → one JSON line each (fit or analyze), resumable results file |
//! | entries | [`pipeline`] | input (samples or window table) → report + quality verdict: what `fit`/`analyze --json` print |
//! | report | [`report`] | → [`AnalyzeReport`] (the JSON contract of `wiical analyze`) |
//! | six-position | [`six_position`], [`six`] | labelled poses → the seed's `T̂ = M·Â⁺` and its residual contrasts |
//! | temperature | [`tempcal`] | still warm-up (one or more poses) + temperature → bias polynomial in T − T_ref, order by held-out segments; ArduPilot / PX4 parameter files (`wiical tempcal`) |
//! | magnetometer | [`magnetometer`] | points → sphere / ellipsoid hard/soft-iron fit |
//! | factory calibration blocks | [`factory`] | Wii Remote / Nunchuk / MotionPlus block bytes → decoded report (`decode-cal`, the capture side file) |
//! | calibration file | [`calfile`], [`mod@write`] | [`Calibration`] ↔ JSON file |
//! | simulator (feature `simulate`) | [`simulate`] | settings → recording with known truth |
//!
//! [`analyze()`] runs the whole analysis; [`fit::run`] only the base fit.
//!
//! # Example: analysing samples from your own program
//!
//! ```
//! use wiical_analysis::{analyze, AnalyzeOptions, Recording};
//!
//! // Stand-in for samples your program recorded: a simulated Wii Remote held still, then
//! // turned through 30 poses, 100 Hz, raw 10-bit counts.
//! let sim = wiical_analysis::simulate::simulate(&Default::default())?;
//! let samples: Vec<[f64; 3]> = sim.recording.xyz.clone();
//!
//! let rec = Recording {
//!     xyz: samples,
//!     sample_rate_hz: Some(100.0),
//!     ..Default::default()
//! };
//! let report = analyze(&rec, &AnalyzeOptions::default())?;
//! assert_eq!(report.units, "raw");
//! assert!(report.static_windows >= 25);
//! // The simulation has no effect beyond the linear model: nothing is added, and the
//! // calibration maps the rest pose to ≈ 1 g.
//! assert!(report.effects.is_empty());
//! let g = report.calibration.correct(
//!     rec.xyz[0].map(|v| v as f32),
//!     &wiical_core::Conditions::default(),
//! );
//! let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
//! assert!((norm - 1.0).abs() < 0.02);
//! # Ok::<(), wiical_analysis::Error>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod allan;
pub mod analyze;
pub mod autocal;
pub mod batch;
pub mod calfile;
pub mod candidate;
pub mod columns;
pub mod effect_names;
pub mod error;
pub mod evidence;
pub mod factory;
pub mod fit;
pub mod grt;
pub mod gyro;
pub mod input;
pub mod live;
pub mod load;
pub mod magnetometer;
pub mod model;
pub mod motion;
pub mod noise;
pub mod noise_report;
#[cfg(feature = "simulate")]
pub mod noise_sim;
pub mod options;
pub mod outliers;
pub mod pipeline;
pub mod press;
pub mod progress;
pub mod raw;
pub mod recording;
pub mod report;
pub mod select;
#[cfg(feature = "simulate")]
pub mod simulate;
pub mod six;
pub mod six_position;
pub mod stats;
pub mod table;
pub mod tempcal;
pub mod timecheck;
pub mod trial;
pub mod verdict;
pub mod window_input;
pub mod windows;
pub mod write;

pub use analyze::analyze;
pub use candidate::Candidate;
pub use error::{Error, Result};
pub use fit::{FitOptions, FitReport};
pub use load::{load, parse, LoadOptions};
pub use options::AnalyzeOptions;
pub use progress::{Progress, ProgressHook, Stage};
pub use recording::Recording;
pub use report::AnalyzeReport;
pub use wiical_core::Calibration;
pub use windows::DetectOptions;
