//! The Monte Carlo behind `wiical kalman-demo`: the fiducial experiment of *Where's the Wiimote?* (seed
//! `kalman_wiimote_article.txt`) as a deterministic Monte Carlo.
//!
//! The remote sits still (true acceleration 0, true position and velocity 0) while its
//! accelerometer has a bias of 0.25 m/s². Every `dt = 0.01 s` the filter
//! ([`wiical_core::kalman::PvbFilter`], `f32`) receives one accelerometer sample
//! `a_m = b + w_a` as its control input and one position measurement `z = 0 + w_p` with
//! σ_p = 0.5 cm (the article's values). After `duration_s = 1` s ("have them … hold that pose
//! for a half to one second") we look at the bias estimate `b̂`. The article's single run
//! settled at 0.28 m/s² (error 0.03); here many runs give the distribution of the error and
//! the NEES shows whether the filter's reported covariance is honest.
//!
//! ## Choices where the article is silent (its parameter image is lost)
//! * **Accelerometer noise σ_a = 0.05 m/s²** (≈ 5 mg) per 100 Hz sample. The Wiimote's
//!   ADXL330 has a noise density of ≈ 280 µg/√Hz (x, y; 350 z); over the ~50 Hz bandwidth of a
//!   100 Hz stream that is ≈ 2.5–3.5 mg rms. The remote's ~10-bit readings (≈ 0.01 g per
//!   count after the extra LSBs) and small vibrations of a "still" device add about as much
//!   again, so 5 mg is a plausible value for a still, low-pass-filtered accelerometer. It is
//!   [`KalmanDemoConfig::accel_noise`].
//! * **Initial state** all zero ("set all the states to zero unless there is otherwise a good
//!   reason").
//! * **P0** diagonal ("off diagonal elements as zero and the diagonal elements as the large
//!   enough value to accept new measurements but not too large"): σ_p0 = 5 mm, the accuracy
//!   of one position fix (the article's "good reason" to initialise the position from a
//!   measurement: the player's pose is known that well when the still phase begins);
//!   σ_v0 = 2 cm/s, the slow drift of a hand asked to hold still; σ_b0 = 0.5 m/s², so that a
//!   0.25 m/s² bias lies at half a standard deviation (an ADXL330 zero-g offset left after the
//!   factory calibration is of that order) without making the filter slow.
//! * No bias random walk (the article's bias is constant over one second); configurable.
//!
//! ## Reading the NEES
//! The truth starts exactly at the filter's initial position and velocity (0), whereas P0
//! allows them 5 mm and 2 cm/s, so the part of the NEES that random initial errors would
//! contribute is missing and the mean NEES sits a little below 3 (≈ 2.9 over 10 000 runs),
//! and the empirical spread of `b̂` a little below the reported `√P_bb` (≈ 0.94×).
//!
//! ## Randomness
//! Run `i` draws from `ChaCha8Rng::seed_from_u64(seed)` switched to stream `i`
//! (`set_stream(i)`): runs are independent, reproducible one by one, and the report depends
//! only on the configuration.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use wiical_core::kalman::{PvbConfig, PvbFilter};

/// Why a Monte Carlo did not run: a setting out of range (checked before any run), or the
/// filter failing inside one run (a step's `predict` / `update`, or a covariance that lost
/// positive definiteness). The sentences are those of `wiical kalman-demo`.
#[derive(Debug, thiserror::Error)]
pub enum KalmanDemoError {
    /// `runs` is 0.
    #[error("runs must be at least 1")]
    NoRuns,
    /// `runs` above [`MAX_RUNS`].
    #[error("runs must be at most {MAX_RUNS} (about 5 s; more adds no precision worth the wait), got {0}")]
    TooManyRuns(u32),
    /// A NaN or infinite setting.
    #[error("every parameter must be finite")]
    NotFinite,
    /// `dt` ≤ 0.
    #[error("dt must be > 0")]
    NonPositiveDt,
    /// `duration_s / dt` outside 1 ..= 10⁷ steps.
    #[error("duration_s / dt must give between 1 and 10^7 steps")]
    Steps,
    /// The core refused the filter's settings.
    #[error("invalid filter configuration")]
    Filter(#[source] wiical_core::Error),
    /// The filter failed at one step of one run (`stage` is `predict` or `update`).
    #[error("run {run}, step {step}: {stage}")]
    Step {
        /// The run (its random stream).
        run: u32,
        /// The step, from 1.
        step: u32,
        /// `predict` or `update`.
        stage: &'static str,
        /// The core's reason.
        #[source]
        source: wiical_core::Error,
    },
    /// The covariance at the end of a run has no Cholesky factor.
    #[error("run {0}: covariance not positive definite")]
    Covariance(u32),
}

type Result<T> = std::result::Result<T, KalmanDemoError>;

/// Settings of the Monte Carlo. Units: s, m, m/s, m/s².
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct KalmanDemoConfig {
    /// Number of independent runs (≥ 1).
    pub runs: u32,
    /// Seed of the random streams.
    pub seed: u64,
    /// True accelerometer bias, m/s² (article: 0.25).
    pub true_bias: f64,
    /// Step between accelerometer samples and position measurements, s (article: 0.01).
    pub dt: f64,
    /// Position measurement noise σ_p, m (article: 0.5 cm).
    pub pos_noise_m: f64,
    /// Accelerometer white noise σ_a per sample, m/s² (article's value lost; default 0.05,
    /// see the module docs).
    pub accel_noise: f64,
    /// Bias random-walk density σ_bw, m/s²/√s, in both the simulation and the filter
    /// (default 0: constant bias).
    pub bias_walk: f64,
    /// Length of one run, s; the report is taken at its end (default 1 s).
    pub duration_s: f64,
    /// Initial standard deviations of `[p, v, b]` for `P0` (m, m/s, m/s²).
    pub initial_std: [f64; 3],
}

impl Default for KalmanDemoConfig {
    fn default() -> Self {
        Self {
            runs: 1000,
            seed: 2008,
            true_bias: 0.25,
            dt: 0.01,
            pos_noise_m: 0.005,
            accel_noise: 0.05,
            bias_walk: 0.0,
            duration_s: 1.0,
            initial_std: [0.005, 0.02, 0.5],
        }
    }
}

/// Results of the Monte Carlo. "At 1 s" means at the end of a run (`duration_s`, 1 s by
/// default), after the last measurement update.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct KalmanDemoReport {
    /// True accelerometer bias, m/s².
    pub true_bias: f64,
    /// Number of runs.
    pub runs: u32,
    /// Filter steps (predict + update) per run.
    pub steps: u32,
    /// Median over runs of `|b̂ − b|` at the end of the run, m/s².
    pub median_abs_bias_error_1s: f64,
    /// 95th percentile over runs of `|b̂ − b|` at the end of the run, m/s² (linear
    /// interpolation between order statistics).
    pub p95_abs_bias_error_1s: f64,
    /// Mean over runs of `b̂` at the end of the run, m/s².
    pub mean_bias_estimate_1s: f64,
    /// Sample standard deviation over runs of `b̂` at the end of the run, m/s².
    pub sd_bias_estimate_1s: f64,
    /// Mean over runs of the filter's own `√P_bb` at the end of the run, m/s² (compare with
    /// `sd_bias_estimate_1s`).
    pub mean_reported_bias_sd_1s: f64,
    /// Mean over runs of the 3-state NEES `(x − x̂)ᵀ P⁻¹ (x − x̂)` at the end of the run,
    /// computed in f64 (≈ 3 for a consistent filter).
    pub nees_mean: f64,
    /// Fraction of runs whose NEES lies inside the two-sided 95 % interval of χ²(3),
    /// [0.2158, 9.3484] (≈ 0.95 for a consistent filter).
    pub nees_in_95_interval: f64,
    /// Bias estimate of run 0 after every step, `[t (s), b̂ (m/s²)]`: the article's Figure 1.
    pub fiducial_bias_trace: Vec<[f64; 2]>,
    /// The configuration used.
    pub config: KalmanDemoConfig,
}

/// Two-sided 95 % interval of χ²(3).
const CHI2_3_95: (f64, f64) = (0.215_795, 9.348_404);

/// Most runs accepted: memory and time grow linearly (per-run results are kept for the
/// medians), and 10⁵ runs already take seconds.
pub const MAX_RUNS: u32 = 100_000;

/// The checked settings: the number of steps and the filter's configuration.
fn checked(cfg: &KalmanDemoConfig) -> Result<(u32, PvbConfig)> {
    if cfg.runs < 1 {
        return Err(KalmanDemoError::NoRuns);
    }
    if cfg.runs > MAX_RUNS {
        return Err(KalmanDemoError::TooManyRuns(cfg.runs));
    }
    let finite = [
        cfg.true_bias,
        cfg.dt,
        cfg.pos_noise_m,
        cfg.accel_noise,
        cfg.bias_walk,
        cfg.duration_s,
    ]
    .iter()
    .chain(cfg.initial_std.iter())
    .all(|v| v.is_finite());
    if !finite {
        return Err(KalmanDemoError::NotFinite);
    }
    if cfg.dt <= 0.0 {
        return Err(KalmanDemoError::NonPositiveDt);
    }
    let steps_f = (cfg.duration_s / cfg.dt).round();
    if !(1.0..=1e7).contains(&steps_f) {
        return Err(KalmanDemoError::Steps);
    }
    let filter_cfg = PvbConfig {
        dt: cfg.dt as f32,
        accel_noise: cfg.accel_noise as f32,
        bias_walk: cfg.bias_walk as f32,
        pos_noise: cfg.pos_noise_m as f32,
        initial_state: [0.0; 3],
        initial_std: cfg.initial_std.map(|v| v as f32),
    };
    // Validate once, with a readable message.
    PvbFilter::new(&filter_cfg).map_err(KalmanDemoError::Filter)?;
    Ok((steps_f as u32, filter_cfg))
}

/// One run's outcome: the bias estimate and its truth, the filter's reported SD of the bias,
/// and the NEES of [p, v, b].
struct RunOutcome {
    b_hat: f64,
    bias: f64,
    reported_sd: f64,
    nees: f64,
}

/// One Monte Carlo run (its own random stream); the first run's bias estimate per step goes
/// to `trace`.
fn one_run(
    cfg: &KalmanDemoConfig,
    filter_cfg: &PvbConfig,
    steps: u32,
    run: u32,
    mut trace: Option<&mut Vec<[f64; 2]>>,
) -> Result<RunOutcome> {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    rng.set_stream(u64::from(run));
    let mut filter = PvbFilter::new(filter_cfg).map_err(KalmanDemoError::Filter)?;
    let mut bias = cfg.true_bias;
    for k in 1..=steps {
        // Still device: true acceleration 0, so the accelerometer reads its bias + noise.
        let w: f64 = StandardNormal.sample(&mut rng);
        let a_m = bias + cfg.accel_noise * w;
        filter
            .predict(a_m as f32)
            .map_err(|source| KalmanDemoError::Step {
                run,
                step: k,
                stage: "predict",
                source,
            })?;
        // The bias random walk (if any) happens over the step, like the filter's model.
        let wb: f64 = StandardNormal.sample(&mut rng);
        bias += cfg.bias_walk * cfg.dt.sqrt() * wb;
        let e: f64 = StandardNormal.sample(&mut rng);
        let z = cfg.pos_noise_m * e;
        filter
            .update(z as f32)
            .map_err(|source| KalmanDemoError::Step {
                run,
                step: k,
                stage: "update",
                source,
            })?;
        if let Some(t) = trace.as_deref_mut() {
            t.push([f64::from(k) * cfg.dt, f64::from(filter.bias())]);
        }
    }
    // Error of [p, v, b] against the truth [0, 0, bias], and the NEES eᵀP⁻¹e in f64 via a
    // Cholesky solve.
    let x = filter.state().cast::<f64>();
    let mut err = -x;
    err[2] += bias;
    let p = filter.covariance().cast::<f64>();
    let nees = p
        .cholesky()
        .map(|c| err.dot(&c.solve(&err)))
        .ok_or(KalmanDemoError::Covariance(run))?;
    Ok(RunOutcome {
        b_hat: x[2],
        bias,
        reported_sd: p[(2, 2)].sqrt(),
        nees,
    })
}

/// Runs the Monte Carlo described in the [module docs](self).
pub fn run(cfg: &KalmanDemoConfig) -> Result<KalmanDemoReport> {
    let (steps, filter_cfg) = checked(cfg)?;
    let mut trace = Vec::with_capacity(steps as usize);
    let outcomes: Vec<RunOutcome> = (0..cfg.runs)
        .map(|run| {
            one_run(
                cfg,
                &filter_cfg,
                steps,
                run,
                (run == 0).then_some(&mut trace),
            )
        })
        .collect::<Result<_>>()?;
    let n = outcomes.len();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let estimates: Vec<f64> = outcomes.iter().map(|o| o.b_hat).collect();
    let nees: Vec<f64> = outcomes.iter().map(|o| o.nees).collect();
    let reported_sd: Vec<f64> = outcomes.iter().map(|o| o.reported_sd).collect();
    let mut abs_err: Vec<f64> = outcomes.iter().map(|o| (o.b_hat - o.bias).abs()).collect();
    let mean_b = mean(&estimates);
    let sd_b = if n > 1 {
        (estimates.iter().map(|b| (b - mean_b).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    abs_err.sort_by(f64::total_cmp);
    let inside = nees
        .iter()
        .filter(|q| (CHI2_3_95.0..=CHI2_3_95.1).contains(*q))
        .count();
    Ok(KalmanDemoReport {
        true_bias: cfg.true_bias,
        runs: cfg.runs,
        steps,
        median_abs_bias_error_1s: quantile_sorted(&abs_err, 0.5),
        p95_abs_bias_error_1s: quantile_sorted(&abs_err, 0.95),
        mean_bias_estimate_1s: mean_b,
        sd_bias_estimate_1s: sd_b,
        mean_reported_bias_sd_1s: mean(&reported_sd),
        nees_mean: mean(&nees),
        nees_in_95_interval: inside as f64 / n as f64,
        fiducial_bias_trace: trace,
        config: cfg.clone(),
    })
}

/// Quantile `q ∈ [0, 1]` of sorted, non-empty data, interpolating linearly between order
/// statistics (position `q·(n − 1)`).
fn quantile_sorted(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let frac = pos - lo as f64;
    v[lo] + (v[hi] - v[lo]) * frac
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(runs: u32) -> KalmanDemoConfig {
        KalmanDemoConfig {
            runs,
            ..Default::default()
        }
    }

    /// The project's acceptance numbers on 500 runs: median bias error after 1 s below
    /// 0.01 m/s², mean NEES near 3 (the mean of 500 χ²(3) has sd √(6/500) ≈ 0.11, so
    /// [2.5, 3.5] is > 4 sd wide each way), and about 95 % of runs inside χ²(3)'s 95 %
    /// interval (binomial sd √(0.05·0.95/500) ≈ 0.01: accept ≥ 0.92).
    #[test]
    fn acceptance_on_500_runs() {
        let r = run(&cfg(500)).unwrap();
        assert_eq!(r.runs, 500);
        assert_eq!(r.steps, 100);
        assert!(r.median_abs_bias_error_1s < 0.01, "{r:?}");
        assert!((2.5..=3.5).contains(&r.nees_mean), "NEES {}", r.nees_mean);
        assert!(r.nees_in_95_interval >= 0.92, "{}", r.nees_in_95_interval);
        // The filter's reported bias sd matches the spread it actually has: expected ratio
        // ≈ 0.94 (module docs, "Reading the NEES"), the sample sd of 500 runs is known to
        // ±3 % (1 sd); accept [0.8, 1.1].
        let ratio = r.sd_bias_estimate_1s / r.mean_reported_bias_sd_1s;
        assert!((0.8..=1.1).contains(&ratio), "{ratio}");
        // Unbiased: the mean estimate is within 4 standard errors of the truth.
        let se = r.sd_bias_estimate_1s / (500f64).sqrt();
        assert!((r.mean_bias_estimate_1s - 0.25).abs() < 4.0 * se, "{r:?}");
        // Ordering of the summary statistics.
        assert!(r.p95_abs_bias_error_1s > r.median_abs_bias_error_1s);
        assert_eq!(r.fiducial_bias_trace.len(), 100);
        assert!((r.fiducial_bias_trace[99][0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn same_seed_same_report_other_seed_other_report() {
        let a = run(&cfg(50)).unwrap();
        let b = run(&cfg(50)).unwrap();
        assert_eq!(a, b);
        let c = run(&KalmanDemoConfig { seed: 7, ..cfg(50) }).unwrap();
        assert_ne!(a.median_abs_bias_error_1s, c.median_abs_bias_error_1s);
        // Runs are streams of one seed: the first 10 runs of a 50-run report are the 10 runs
        // of a 10-run report (its fiducial run is identical).
        let d = run(&cfg(10)).unwrap();
        assert_eq!(a.fiducial_bias_trace, d.fiducial_bias_trace);
    }

    #[test]
    fn bad_configurations_are_errors() {
        assert!(run(&cfg(0)).is_err());
        assert!(run(&KalmanDemoConfig { dt: 0.0, ..cfg(1) }).is_err());
        assert!(run(&KalmanDemoConfig {
            pos_noise_m: 0.0,
            ..cfg(1)
        })
        .is_err());
        assert!(run(&KalmanDemoConfig {
            accel_noise: f64::NAN,
            ..cfg(1)
        })
        .is_err());
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile_sorted(&v, 0.5), 2.5);
        // Position 0.95·3 = 2.85 → 3 + 0.85.
        assert!((quantile_sorted(&v, 0.95) - 3.85).abs() < 1e-12);
        assert_eq!(quantile_sorted(&[7.0], 0.95), 7.0);
    }
}
