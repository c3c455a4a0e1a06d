//! `wiical kalman-demo`: Monte Carlo of the Wiimote article's Kalman filter.

use super::to_json;
use anyhow::Result;
use std::fmt::Write as _;

/// Arguments of `wiical kalman-demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Number of independent runs.
    #[arg(long, default_value_t = 1000)]
    pub runs: u32,
    /// Random seed (same seed, same report).
    #[arg(long, default_value_t = 2008)]
    pub seed: u64,
    /// Accelerometer white noise per sample, m/s².
    #[arg(long, value_parser = super::positive_finite)]
    pub accel_noise: Option<f64>,
    /// Position measurement noise, m.
    #[arg(long, value_parser = super::positive_finite)]
    pub pos_noise: Option<f64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `wiical kalman-demo`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    let mut cfg = crate::kalman_demo::KalmanDemoConfig {
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
    let rep = crate::kalman_demo::run(&cfg)?;
    if a.json {
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
