//! `wiical kalman-demo`'s text: the settings, the bias error after the still phase and the
//! mean NEES.

use std::path::Path;
use wiical_analysis::noise::report::AccelNoise;
use wiical_sim::kalman::KalmanDemoReport;

/// The report as text; `source` is the noise file σ_a and the bias walk came from, with the
/// axis read from it.
pub fn kalman_demo_text(rep: &KalmanDemoReport, source: Option<(&Path, AccelNoise)>) -> String {
    let cfg = &rep.config;
    let from_file = match source {
        None => String::new(),
        Some((path, n)) => format!(
            " (from {}, axis {}: N {:.3e} m/s²/√Hz, K {})",
            path.display(),
            n.column,
            n.n_ms2_per_sqrt_hz,
            if n.k_seen {
                format!("{:.3e} m/s²/√s", n.k_ms2_per_sqrt_s)
            } else {
                "not seen: bias held constant".into()
            }
        ),
    };
    let mut o = format!(
        "Kalman [p, v, b] demo: {} runs, seed {}, true bias {} m/s², σ_p {} m, σ_a {} m/s²{from_file}\n",
        rep.runs, cfg.seed, rep.true_bias, cfg.pos_noise_m, cfg.accel_noise
    );
    o += &format!(
        "  |b̂ − b| after {} s: median {:.4} m/s², 95th percentile {:.4} m/s²\n",
        cfg.duration_s, rep.median_abs_bias_error_1s, rep.p95_abs_bias_error_1s
    );
    o += &format!(
        "  mean NEES {:.3} (state dimension 3: a consistent filter gives ≈ 3)\n",
        rep.nees_mean
    );
    o
}
