//! `wiical kalman-demo`: Monte Carlo of the Wiimote article's Kalman filter.

use super::to_json;
use crate::cli_error::cli_error;
use crate::render;
use anyhow::Result;
use wiical_sim::kalman::{self, KalmanDemoConfig, MAX_RUNS};

/// Arguments of `wiical kalman-demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Number of independent runs.
    #[arg(long, default_value_t = 1000, value_parser = runs)]
    pub runs: u32,
    /// Random seed (same seed, same report).
    #[arg(long, default_value_t = 2008)]
    pub seed: u64,
    /// Accelerometer white noise per sample, m/s².
    #[arg(long, value_parser = |s: &str| super::noise_sigma(s, 100.0, "m/s²"), allow_negative_numbers = true)]
    pub accel_noise: Option<f64>,
    /// Position measurement noise, m.
    #[arg(long, value_parser = |s: &str| super::noise_sigma(s, 100.0, "m"), allow_negative_numbers = true)]
    pub pos_noise: Option<f64>,
    /// Take σ_a and the bias random walk from a still accelerometer's noise
    /// (`wiical noise --json` output): σ_a = N/√dt, bias walk = K (0 where K was not seen).
    #[arg(long, conflicts_with = "accel_noise")]
    pub noise: Option<std::path::PathBuf>,
    /// The axis of the noise file to use (default: the accelerometer axis with the largest N).
    #[arg(long, requires = "noise")]
    pub noise_axis: Option<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `wiical kalman-demo`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    let mut cfg = KalmanDemoConfig {
        runs: a.runs,
        seed: a.seed,
        ..Default::default()
    };
    if let Some(x) = a.accel_noise {
        cfg.accel_noise = x;
    }
    if let Some(p) = a.pos_noise {
        cfg.pos_noise_m = p;
    }
    let mut source = None;
    if let Some(path) = &a.noise {
        let text = wiical_analysis::input::bounded::read_text(path, 1 << 24).map_err(cli_error)?;
        let n =
            wiical_analysis::noise::report::accel_noise_from_json(&text, a.noise_axis.as_deref())
                .map_err(|e| cli_error(wiical_analysis::Error::from(e).in_file(path)))?;
        // The core's constructor does the conversion (σ_a = N/√dt, σ_bw = K).
        let pvb = wiical_core::kalman::PvbConfig::from_allan(
            cfg.dt as f32,
            n.n_ms2_per_sqrt_hz as f32,
            n.k_ms2_per_sqrt_s as f32,
            cfg.pos_noise_m as f32,
            cfg.initial_std.map(|v| v as f32),
        )
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        cfg.accel_noise = f64::from(pvb.accel_noise);
        cfg.bias_walk = f64::from(pvb.bias_walk);
        source = Some((path.as_path(), n));
    }
    let rep = kalman::run(&cfg)?;
    if a.json {
        return to_json(&rep);
    }
    Ok(render::kalman_demo::kalman_demo_text(&rep, source))
}

/// `--runs`: 1 to [`MAX_RUNS`], named where it is parsed.
fn runs(s: &str) -> Result<u32, String> {
    let max = MAX_RUNS;
    match s.trim().parse::<u32>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!(
            "'{s}': give a whole number of runs from 1 to at most {max} (about 5 s; more adds no precision worth the wait)"
        )),
    }
}
