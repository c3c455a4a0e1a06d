//! `wiical fit`: static-interval detection followed by the multi-position fit, all in the
//! core's `f32` code (the same code the adapter firmware runs).

use crate::input::Recording;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use wiical_core::multipos::{self, MultiPosConfig, MultiPosModel};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};
use wiical_core::Calibration;

/// Capacity of the detector's window ring (samples). At 100 Hz this allows windows up to 5 s.
pub const MAX_WINDOW: usize = 511;

/// Settings of the detection + fit pipeline.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Variance window, seconds.
    pub window_s: f64,
    /// Initial rest period used as the noise reference, seconds.
    pub init_s: f64,
    /// Shortest static interval, seconds.
    pub min_static_s: f64,
    /// Static when window variance ≤ this × reference variance.
    pub threshold_factor: f64,
    /// Sample rate to assume when the file has neither a time column nor metadata.
    pub default_rate_hz: f64,
    /// Model to fit.
    pub model: MultiPosModel,
    /// ADC limits (lo, hi): a static interval touching them is refused as saturated.
    /// `None`: inferred from the data (integer counts in 10-bit or 16-bit ranges).
    pub adc_range: Option<(f64, f64)>,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            window_s: 1.0,
            init_s: 2.0,
            min_static_s: 2.0,
            threshold_factor: 6.0,
            default_rate_hz: 100.0,
            model: MultiPosModel::Full,
            adc_range: None,
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
    /// Number of samples.
    pub samples: u32,
    /// Mean raw reading.
    pub mean: [f32; 3],
    /// Per-axis standard deviation of the raw readings.
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
    /// Per-axis noise std of the initial rest period, raw units.
    pub noise_std: [f32; 3],
    /// The windows.
    pub windows: Vec<WindowReport>,
    /// The calibration (what `--out` writes).
    #[serde(skip)]
    pub calibration: Calibration,
}

/// Detected static intervals plus the noise reference.
pub struct Detection {
    /// Intervals in sample indices.
    pub intervals: Vec<StaticInterval>,
    /// Per-axis reference variance (raw units²).
    pub reference_variance: [f32; 3],
    /// Sample times.
    pub times: Vec<f64>,
}

/// Runs the core's streaming static detector over a recording.
pub fn detect(rec: &Recording, opts: &FitOptions) -> Result<Detection> {
    let rate = rec.estimated_rate_hz().unwrap_or(opts.default_rate_hz);
    if !(rate.is_finite() && rate > 0.0) {
        bail!("cannot determine the sample rate");
    }
    let mut cfg = StaticDetectorConfig::for_rate(
        rate as f32,
        opts.window_s as f32,
        opts.init_s as f32,
        opts.min_static_s as f32,
    );
    cfg.threshold_factor = opts.threshold_factor as f32;
    if cfg.window as usize > MAX_WINDOW {
        bail!(
            "window of {} samples exceeds the maximum {MAX_WINDOW}; use a shorter --window-s",
            cfg.window
        );
    }
    if (rec.len() as u32) < cfg.init_samples.max(cfg.window as u32) {
        bail!(
            "recording too short: {} samples, the initial rest period alone needs {} ({} s at {rate} Hz)",
            rec.len(),
            cfg.init_samples,
            opts.init_s
        );
    }
    let mut det: StaticDetector<MAX_WINDOW> =
        StaticDetector::new(cfg).map_err(|e| anyhow!("static detector settings: {e}"))?;
    let mut intervals = Vec::new();
    for (i, s) in rec.xyz.iter().enumerate() {
        let m = [s[0] as f32, s[1] as f32, s[2] as f32];
        if let Some(iv) = det.push(m).map_err(|e| anyhow!("sample {}: {e}", i + 1))? {
            intervals.push(iv);
        }
    }
    if let Some(iv) = det.finish() {
        intervals.push(iv);
    }
    let reference_variance = det.reference_variance().unwrap_or([0.0; 3]);
    Ok(Detection {
        intervals,
        reference_variance,
        times: rec.times(rate),
    })
}

/// ADC limits inferred from integer-valued data: 10-bit (0..1023), 8-bit (0..255),
/// signed 16-bit or unsigned 16-bit. `None` for non-integer (already scaled) data.
pub fn infer_adc_range(rec: &Recording) -> Option<(f64, f64)> {
    let all_int = rec.xyz.iter().all(|s| s.iter().all(|v| v.fract() == 0.0));
    if !all_int {
        return None;
    }
    let lo = rec
        .xyz
        .iter()
        .flatten()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let hi = rec
        .xyz
        .iter()
        .flatten()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    [
        (0.0, 255.0),
        (0.0, 1023.0),
        (-32768.0, 32767.0),
        (0.0, 65535.0),
    ]
    .into_iter()
    .find(|(a, b)| lo >= *a && hi <= *b)
}

/// Refuses static intervals with a sample at an ADC limit.
pub fn check_saturation(
    rec: &Recording,
    intervals: &[StaticInterval],
    range: Option<(f64, f64)>,
) -> Result<()> {
    let Some((lo, hi)) = range else {
        return Ok(());
    };
    for (k, iv) in intervals.iter().enumerate() {
        for i in iv.start as usize..(iv.end as usize).min(rec.len()) {
            for a in 0..3 {
                let v = rec.xyz[i][a];
                if v <= lo || v >= hi {
                    bail!(
                        "{}: static window {} (samples {}..{}) has axis {} at the ADC limit ({v}) in sample {}: that pose is saturated and cannot be used; re-record it or pass --adc-range",
                        wiical_core::Error::Saturated,
                        k + 1,
                        iv.start,
                        iv.end,
                        ["x", "y", "z"][a],
                        i + 1
                    );
                }
            }
        }
    }
    Ok(())
}

/// Detects static windows and fits the multi-position model.
pub fn run(rec: &Recording, opts: &FitOptions) -> Result<FitReport> {
    let det = detect(rec, opts)?;
    let range = opts.adc_range.or_else(|| infer_adc_range(rec));
    check_saturation(rec, &det.intervals, range)?;
    let means: Vec<[f32; 3]> = det.intervals.iter().map(|iv| iv.mean).collect();
    let cfg = MultiPosConfig {
        model: opts.model,
        ..Default::default()
    };
    let fit = multipos::fit(&means, &cfg).map_err(|e| match e {
        wiical_core::Error::TooFewPoses { needed, got } => anyhow!(
            "found {got} static windows but the {} model needs at least {needed}: hold the sensor still in more orientations (or lower --min-static-s / raise --threshold)",
            model_name(opts.model)
        ),
        wiical_core::Error::DegenerateGeometry => anyhow!(
            "the {} static poses do not spread over enough orientations (e.g. all in one plane): turn the sensor so that each axis points up and down",
            means.len()
        ),
        other => anyhow!("multi-position fit failed: {other}"),
    })?;
    let cal = fit.calibration;
    let windows: Vec<WindowReport> = det
        .intervals
        .iter()
        .map(|iv| WindowReport {
            t_start: det
                .times
                .get(iv.start as usize)
                .copied()
                .unwrap_or(f64::NAN),
            t_end: det
                .times
                .get((iv.end as usize).saturating_sub(1))
                .copied()
                .unwrap_or(f64::NAN),
            samples: iv.len(),
            mean: iv.mean,
            std: iv.variance.map(f32::sqrt),
            residual_mg: 1000.0 * multipos::norm_residual(&cal, iv.mean, 1.0),
        })
        .collect();
    Ok(FitReport {
        static_windows: windows.len(),
        bias: cal.bias,
        matrix: cal.matrix,
        rms_mg: 1000.0 * fit.rms,
        max_abs_mg: 1000.0 * fit.max_abs_residual,
        iterations: fit.iterations,
        identifiability: fit.identifiability,
        noise_std: det.reference_variance.map(f32::sqrt),
        windows,
        calibration: cal,
    })
}

fn model_name(m: MultiPosModel) -> &'static str {
    match m {
        MultiPosModel::Full => "9-parameter",
        MultiPosModel::Diagonal => "6-parameter",
    }
}
