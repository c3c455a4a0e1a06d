//! The base fit: static-interval detection followed by the multi-position fit, all in the
//! core's `f32` code (the same code the adapter firmware runs).

use crate::detect::windows::{detect_windows, DetectOptions, Windows};
use crate::error::fit::FitError;
use crate::error::Result;
use crate::input::recording::Recording;
use serde::Serialize;
use wiical_core::multipos::{self, MultiPosConfig, MultiPosFit, MultiPosModel};
use wiical_core::Calibration;

/// Settings of the detection + fit pipeline.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Static-window detection.
    pub detect: DetectOptions,
    /// Model to fit.
    pub model: MultiPosModel,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            detect: DetectOptions::default(),
            model: MultiPosModel::Full,
        }
    }
}

/// One static window as reported.
#[derive(Debug, Clone, Serialize)]
pub struct WindowReport {
    /// Start time, s.
    pub t_start: f64,
    /// End time, s.
    pub t_end: f64,
    /// Number of samples (`null` for a window-mean table without a count column).
    pub samples: Option<u32>,
    /// Mean raw reading.
    pub mean: [f32; 3],
    /// Per-axis standard deviation of the raw readings (at least the quantisation's √(1/12)
    /// for integer counts).
    pub std: [f32; 3],
    /// Residual ‖a‖ − 1 g after calibration, milli-g.
    pub residual_mg: f32,
}

/// The `fit` command's result (JSON keys are part of the CLI contract).
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// Number of static windows used.
    pub static_windows: usize,
    /// Bias b, raw units.
    pub bias: [f32; 3],
    /// Correction matrix K = D⁻¹ (upper triangular), g per raw unit, row-major.
    pub matrix: [[f32; 3]; 3],
    /// RMS of ‖a‖ − 1 g over the static windows, milli-g.
    pub rms_mg: f32,
    /// Largest |‖a‖ − 1 g| over the windows, milli-g.
    pub max_abs_mg: f32,
    /// Solver iterations.
    pub iterations: u32,
    /// Smallest eigenvalue of the scaled normal matrix (near 0: poorly spread poses).
    pub identifiability: f32,
    /// Per-axis noise std of the detector's reference (the initial rest period, or the
    /// adaptive detector's quiet-block quantile), raw units (in the detector's view: rescaled
    /// for non-integer data with the fixed detector).
    pub noise_std: [f32; 3],
    /// The windows.
    pub windows: Vec<WindowReport>,
    /// Window-mean input only: how the table was read (absent for recordings of samples).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_input: Option<crate::report::contract::WindowInputInfo>,
    /// The calibration (what `--out` writes).
    #[serde(skip)]
    pub calibration: Calibration,
    /// The recognised protocol and its method, when it is not today's free poses
    /// ([`crate::protocol`]); absent otherwise, so free-pose reports are unchanged.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub protocol: Option<crate::protocol::ProtocolReport>,
    /// The log was polled faster than its sensor updates ([`crate::detect::polled`]): the
    /// windows' `std` are the distinct samples'; absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub polling: Option<crate::detect::polled::Polling>,
}

/// Detects static windows and fits the multi-position model: the same windows as
/// [`crate::analyze()`] ([`crate::detect::windows::detect_windows`]: one pipeline for `fit` and `analyze`), their
/// means fitted by the core's `f32` solver.
pub fn run(rec: &Recording, opts: &FitOptions) -> Result<FitReport> {
    if rec.labels.is_some() {
        return Err(FitError::PoseTable { rows: rec.len() }.into());
    }
    Ok(run_windows(&detect_windows(rec, &opts.detect)?, opts)?)
}

/// The fit of windows already found: detected by [`run`], or read from a window-mean table
/// ([`crate::input::window_means`]) — the same windows `analyze` uses for the same file.
pub fn run_windows(ws: &Windows, opts: &FitOptions) -> Result<FitReport, FitError> {
    let means: Vec<[f32; 3]> = ws.stats.iter().map(|w| w.mean.map(|x| x as f32)).collect();
    let fit = fit_means(&means, opts.model).map_err(|e| e.found_by(opts.detect.adaptive))?;
    let cal = fit.calibration;
    let windows = window_reports(ws, &cal);
    Ok(FitReport {
        static_windows: windows.len(),
        bias: cal.bias,
        matrix: cal.matrix,
        rms_mg: 1000.0 * fit.rms,
        max_abs_mg: 1000.0 * fit.max_abs_residual,
        iterations: fit.iterations,
        identifiability: fit.identifiability,
        noise_std: ws.reference_variance.map(f32::sqrt),
        windows,
        window_input: None,
        calibration: cal,
        protocol: None,
        polling: ws.polling.clone(),
    })
}

/// Each window as reported, with its residual `‖a‖ − 1 g` under `cal` (the multi-position
/// fit's and the protocols' calibrations alike).
pub(crate) fn window_reports(ws: &Windows, cal: &Calibration) -> Vec<WindowReport> {
    ws.stats
        .iter()
        .map(|w| {
            let m = w.mean.map(|x| x as f32);
            WindowReport {
                t_start: w.t_first,
                t_end: w.t_last,
                samples: w.count.map(|n| n as u32),
                mean: m,
                std: w.var.map(|v| v.sqrt() as f32),
                residual_mg: 1000.0 * multipos::norm_residual(cal, m, 1.0),
            }
        })
        .collect()
}

/// The core's `f32` multi-position fit of window means, its errors told in terms of windows.
pub fn fit_means(means: &[[f32; 3]], model: MultiPosModel) -> Result<MultiPosFit, FitError> {
    fit_means_named(means, model, model_name(model))
}

/// [`fit_means`] with the model named `name` in its errors.
pub(crate) fn fit_means_named(
    means: &[[f32; 3]],
    model: MultiPosModel,
    name: &'static str,
) -> Result<MultiPosFit, FitError> {
    let cfg = MultiPosConfig {
        model,
        ..Default::default()
    };
    multipos::fit(means, &cfg).map_err(|e| match e {
        wiical_core::Error::TooFewPoses { needed, got } => FitError::TooFewWindows {
            found: got,
            needed,
            model: name,
            adaptive: false,
        },
        wiical_core::Error::DegenerateGeometry => FitError::DegeneratePoses { poses: means.len() },
        other => FitError::FitFailed(other),
    })
}

fn model_name(m: MultiPosModel) -> &'static str {
    match m {
        MultiPosModel::Full => "9-parameter model",
        MultiPosModel::Diagonal => "6-parameter model",
    }
}
