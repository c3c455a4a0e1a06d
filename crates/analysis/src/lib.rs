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
//! The crate is laid out by stage; each room's `mod.rs` says what its stage takes and gives.
//!
//! | stage | room | in → out |
//! |---|---|---|
//! | input | [`input`] | file or text → [`Recording`] (CSV / `t x y z` text, GRT, raw `.cwa` / `.bin`), or a table whose rows are still windows; bounded reads, time and column checks |
//! | detection | [`detect`] | recording → static windows (core detector) + f64 window statistics; the not-still check |
//! | fit | [`fit`] | window means → 9- (or 6-) parameter [`Calibration`] (core `f32` LM); the f64 effect model; PRESS; the six-position test |
//! | search | [`search`] | base fit → candidate effects tried, tested, selected one per step, with evidence ([`analyze()`]) |
//! | report | [`report`] | → [`AnalyzeReport`] (the JSON contract), effect names, quality verdict, progress |
//! | output | [`output`] | [`Calibration`] ↔ calibration file; atomic writes (`wiical-io`'s, re-exported) |
//! | correction | [`correct`] | calibration file (core + host terms) + recording → corrected samples, g (`wiical correct`) |
//! | entries | [`pipeline`] | input (samples or window table) → report + quality verdict: what `fit`/`analyze --json` print |
//! | many files | [`batch`] | files → one JSON line each (through [`pipeline`]), resumable results file |
//!
//! Pipelines of their own, each one module or room:
//!
//! | pipeline | module | in → out |
//! |---|---|---|
//! | autocalibration | [`autocal`] | still-epoch means (g) + temperature → van Hees et al. 2014 offset / scale / temperature (GGIR's method) |
//! | gyroscope | [`gyro`] | accelerometer + gyro recordings → gyro scale / misalignment / bias by held-out error ([`gyro::run`]) |
//! | magnetometer | [`magnetometer`] | points → sphere / ellipsoid hard/soft-iron fit, then its residual loop: noise floor, candidate effects, detection limits, verdict |
//! | noise | [`noise`](mod@noise) | still recording → overlapping Allan deviation per axis and the IEEE 952 terms (`wiical noise`) |
//! | temperature | [`tempcal`](mod@tempcal) | still warm-up + temperature → bias polynomial in T − T_ref; ArduPilot / PX4 parameter files (`wiical tempcal`) |
//! | live session | [`live`] | samples as they come → poses, refit and verdict after each pose (`wiical live`) |
//!
//! Shared below them all: [`error`] (the error type) and `stats` (distribution functions).
//!
//! [`pipeline::fit_judged`] and [`pipeline::analyze_judged`] are the entries of `wiical fit` and `wiical
//! analyze`; [`analyze()`] runs the analysis on a [`Recording`] you hold.
//!
//! # One request, one function per pipeline
//!
//! The command line and the Python package build the same typed request and call the same
//! function, so that the translation of what a user gives into the pipeline's settings exists
//! once and argument errors are typed (they name no flag or keyword; each door names its own):
//! [`gyrofit()`] with [`GyrofitRequest`], [`magfit()`] with [`MagfitRequest`], [`noise()`] with
//! [`NoiseRequest`], [`tempcal()`] with [`TempcalRequest`]; the samples of a request are a file
//! or samples held ([`SampleInput`]). The rooms' internals (statistics, folds, trials,
//! designs) are the crate's own; the public items are listed in
//! `docs/public-api/wiical-analysis.txt`, checked by `scripts/test`, so that the surface only
//! grows on purpose.
//!
//! # Example: analysing samples from your own program
//!
//! ```
//! use wiical_analysis::{analyze, AnalyzeOptions, Recording};
//!
//! // Stand-in for samples your program recorded: a simulated Wii Remote held still, then
//! // turned through 30 poses, 100 Hz, raw 10-bit counts (the simulator, `wiical-sim`, is a
//! // crate of its own, built on this one).
//! let sim = wiical_sim::simulate(&Default::default())?;
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
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unnameable_types)]

pub mod arrays;
pub mod autocal;
pub mod batch;
pub mod calibrate;
pub mod correct;
pub mod detect;
pub mod error;
pub mod fit;
pub mod gyro;
pub mod input;
pub mod live;
pub mod magnetometer;
pub mod noise;
pub mod output;
pub mod pipeline;
pub mod protocol;
pub mod report;
pub(crate) mod request;
pub mod search;
pub mod source;
pub(crate) mod stats;
pub mod tempcal;

pub use detect::windows::DetectOptions;
pub use error::{Error, Result};
pub use fit::base::{FitOptions, FitReport};
pub use gyro::request::{gyrofit, GyrofitRequest};
pub use input::front_door::load;
pub use input::recording::Recording;
pub use input::text::{parse, LoadOptions};
pub use magnetometer::request::{magfit, MagfitOutput, MagfitRequest};
pub use noise::request::{noise, NoiseRequest};
pub use report::contract::AnalyzeReport;
pub use report::progress::{Progress, ProgressHook, Stage};
pub use request::SampleInput;
pub use search::analyze::analyze;
pub use search::candidate::Candidate;
pub use search::options::AnalyzeOptions;
pub use tempcal::request::{tempcal, TempcalRequest, TempcalRunError};
pub use wiical_core::Calibration;
