//! `wiical-sim`, the recording simulator of wiical: Wiimote- / Nunchuk-like multi-position
//! recordings with known truth and, optionally, one or several effects the linear model lacks,
//! for testing `wiical analyze` blind (`wiical simulate`, the engine's tests and benchmarks).
//! It builds on the analysis engine (`wiical-analysis`: the `Recording` it gives, the effect
//! table it draws from, the atomic writes); the engine does not depend on it.
//!
//! What a recording looks like:
//! * 10-bit counts (bias near 512; ~105 counts/g for the Wiimote's ADXL330, ~200 counts/g for
//!   the Nunchuk's LIS3L02AL read at 10 bits), small non-orthogonality, white noise of about a
//!   count, rounding to integers (the noise dithers the quantiser, so window means are not
//!   biased by it), at 100 Hz.
//! * An initial rest period (lying flat, +z up), then `poses` hand-placed static poses
//!   (4–8 s each: six near the ± axes, the rest uniformly spread) with 1.5–3 s of hand
//!   motion between them (a rotation with a smooth profile plus hand accelerations of a few
//!   tenths of g). The `brisk` [`Profile`]: holds of 2–4 s, moves of 1–2 s with two hand
//!   bumps (lifting, knocking down: 20–40 ms pulses of 0.3–1 g).
//! * [`Device::Mems16`]: a 16-bit MEMS (16 384 counts/g, bias near 0) written in m/s²; the
//!   truth is in the same unit.
//! * A `temp` column (°C, 0.01 °C resolution): room temperature plus a self-heating warm-up
//!   `ΔT·(1 − e^{−t/τ})`, the hand warming the case while it moves the sensor (first-order,
//!   τ = 30 s) and a slow air-conditioning wobble. Temperature therefore rises with time, so
//!   time and temperature are correlated (typically r ≈ 0.9 over the windows) but not
//!   identical.
//!
//! The sensor's frame follows the same convention as the fit (the forward matrix `D` is upper
//! triangular: x axis kept, y in the x–y plane), so the truth's parameters are directly
//! comparable with what `analyze` reports.
//!
//! The effects (`--effect a,b`: several at once, each drawn as if it were alone, in the order
//! given) and their `--magnitude` (always milli-g, one value for all or one per effect):
//! | effect | truth term (correction side, see `wiical_core::model`) | magnitude X means |
//! |---|---|---|
//! | `quadratic` | `k2` per axis | largest `|k2|` is X mg/g² (X mg at 1 g on that axis) |
//! | `cubic` | `k3` per axis | largest `|k3|` is X mg/g³ |
//! | `bias-drift` | bias drift per axis (raw/s) | the bias moves by X mg (vector norm) over the recording |
//! | `temperature` | bias temperature coefficient (raw/°C) | the bias moves by X mg over the recording's temperature range |
//! | `temperature-scale` | relative scale temperature coefficient (1/°C) per axis | the largest axis's scale moves by X mg/g over the recording's temperature range |
//! | `outliers` | 2–3 poses that were not still | each carries an extra specific force along gravity that shifts its mean ‖a‖ by ±X mg |
//!
//! The open basis ([`open_basis_terms`]): families beyond the seven candidates.
//! The cross terms are held by the core's `Effects`; the time and temperature families are
//! the simulator's own terms (correction side: a bias term is added to the bias the correction
//! subtracts, a scale term multiplies `u_i` by `1 + s_i·r`), listed with value and unit in the
//! truth's `open_basis`. Ranges are over the samples of the holds (what the windows see);
//! `θ_ref` is the mean of the holds' mean temperatures (the analysis' `θ̄`; for the thermal
//! lag, of the lagged temperature), `t_ref` the mean of the holds' mid-times.
//! | effect | truth term | magnitude X means |
//! |---|---|---|
//! | `cross-quadratic` | one `cross_quadratic[i][j]` (1/g): output axis `i` (drawn, or `--axis`), one of its five monomials `u_j·u_k` (drawn) | the term reaches ±X mg at its largest over the sphere of directions (coefficient X/peak, peak ½ for `u_x·u_y`, 1 for `u_x²`) |
//! | `cross-cubic` | one `cross_cubic[i][j]` (1/g²), one of nine monomials | the same, peak `1/√27` for `u_x·u_y·u_z` |
//! | `scale-drift` | scale `1 + s_i·t` (1/s) | the largest axis's scale moves by X mg/g over the recording |
//! | `scale-drift-curved` | scale `1 + s_i·(t − t_ref)²` (1/s²) | the same over the range of `(t − t_ref)²` |
//! | `temperature-squared` | bias `c·(θ − θ_ref)²` (file unit/°C²) | the bias moves by X mg (vector norm) over the range of `(θ − θ_ref)²` |
//! | `temperature-cubed` | bias `c·(θ − θ_ref)³` (file unit/°C³) | the same over the range of `(θ − θ_ref)³` |
//! | `temperature-scale-squared`, `-cubed` | scale `1 + s_i·(θ − θ_ref)^2 or 3` | the largest axis's scale moves by X mg/g over that range |
//! | `thermal-lag` | bias `c·(θ_lag − θ_ref)`, `θ_lag` the true temperature through a first-order lag of τ = [`THERMAL_LAG_TAU_S`] (300 s) | the bias moves by X mg over the range of `θ_lag` |
//! | `temperature-rate` | bias `c·dθ/dt` (file unit per °C/s, true temperature) | the bias moves by X mg over the range of `dθ/dt` |
//!
//! The temperature families need the `temp` column (it is always written for them). The
//! temperature spans what the warm-up model gives: 3–8 °C of self-heating, 2–5 °C of hand
//! warming and a 0.3–1 °C wobble, so a few °C over the holds even in a brisk recording.
//!
//! The truth is written next to the recording as `FILE.truth.json` ([`Truth`]).
//!
//! One concern a file, each importing only the ones listed before it:
//! * the plain parts: `device` (the sensors imitated), `geometry` (directions on the unit
//!   sphere), `config` (the settings and their checks, the effects asked for, the
//!   [`Profile`]);
//! * the scene: `motion` (poses, the timeline of holds and moves, the motion's specific
//!   force), `conditions` (the temperature model, every sample's time and temperature, the
//!   holds' statistics);
//! * the effects: [`open_basis_terms`] (the open-basis families: their terms, their
//!   forward model, their truth rows), `draw` (every effect's coefficients drawn, the
//!   outlier poses);
//! * the recording and what is known of it: `sensor` (the scene, the specific force with
//!   the outliers' push, the noiseless reading and the recorded counts), `truth` (what the
//!   simulation knows and its self-check), `hold_score` (a detection against the true
//!   holds), `files` (the output, CSV and JSON);
//!
//! and this module runs them in that order. [`gyro`], [`magnetometer`] and [`kalman`]
//! simulate the other sensors and the Kalman demo; [`protocols`] simulates the calibration
//! protocols (six faces, one pose, Ferraris, rate table, turntable, a face missing) with an
//! IMU's accelerometer and gyro; [`noise`] a still sensor's noise with known IEEE 952 terms.
//! [`error`] holds the errors of them all.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod conditions;
mod config;
mod device;
mod draw;
pub mod error;
mod files;
mod geometry;
pub mod gyro;
mod hold_score;
pub mod kalman;
pub mod magnetometer;
mod motion;
pub mod noise;
pub mod open_basis_terms;
pub mod protocols;
mod sensor;
mod truth;

pub use conditions::{SampleConditions, TempModel, THERMAL_LAG_TAU_S};
pub use config::{EffectSpec, Profile, SimConfig, SimEffect};
pub use device::Device;
pub use draw::TrueOutlier;
pub use error::{Error, Result, SimulateError};
pub use files::{to_csv, truth_path, write, SimOutput};
pub use hold_score::{score_holds, HoldScore, FOUND_EDGE_S, FOUND_MIN_S, HOLD_MIN_STILL_S};
pub use truth::{TruePose, Truth};

use conditions::{hold_stats, sample_conditions, temperatures};
use config::check_config;
use draw::effect_terms;
use motion::{pose_directions, timeline};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sensor::Scene;
use truth::{check_truth, truth};

/// Simulates a recording (see the crate docs).
pub fn simulate(cfg: &SimConfig) -> Result<SimOutput> {
    let (effects, noise) = check_config(cfg)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let cpg = cfg.device.counts_per_g();
    let fs = cfg.rate_hz;
    // Sensor: upper-triangular forward matrix, bias near mid-scale.
    let s: [f64; 3] = std::array::from_fn(|_| cpg * (1.0 + rng.random_range(-0.04..0.04)));
    let mut off = || cpg * rng.random_range(-0.015..0.015);
    let d = [[s[0], off(), off()], [0.0, s[1], off()], [0.0, 0.0, s[2]]];
    // 10-bit: within ±20 counts of mid-scale; 16-bit: within ±0.05 g of zero.
    let bias_spread = 20.0f64.max(0.05 * cpg);
    let zero = cfg.device.zero_g();
    let bias: [f64; 3] =
        std::array::from_fn(|_| zero + rng.random_range(-bias_spread..bias_spread));
    let dirs = pose_directions(&mut rng, cfg.poses);
    let (segs, duration) = timeline(&mut rng, cfg.init_s, dirs.len(), cfg.profile);
    let n = (duration * fs).floor() as usize;
    let (tm, temps) = temperatures(&mut rng, &segs, n, fs);
    let conds = sample_conditions(&temps, fs);
    let terms = {
        let holds = hold_stats(&segs, &conds, fs);
        effect_terms(&mut rng, &effects, &s, &segs, &temps, duration, &holds)?
    };
    let scene = Scene {
        fs,
        noise,
        d,
        bias,
        dirs,
        segs,
        tm,
        temps,
        terms,
        conds,
        adc: cfg.device.adc_range(),
        unit: cfg.device.unit_per_count(),
    };
    let rec = scene.record(
        &mut rng,
        cfg.temp_column || effects.iter().any(|(e, _, _)| e.needs_temperature()),
    );
    let truth = truth(&scene, cfg, &effects)?;
    check_truth(&scene, &truth)?;
    Ok(SimOutput {
        recording: rec,
        truth,
        conditions: scene.conds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_recording_and_parses_back() {
        let cfg = SimConfig {
            poses: 10,
            effects: vec![EffectSpec::new(SimEffect::Temperature, None)],
            ..Default::default()
        };
        let a = simulate(&cfg).unwrap();
        let b = simulate(&cfg).unwrap();
        assert_eq!(a.recording.xyz, b.recording.xyz);
        let text = to_csv(&a.recording);
        let back = wiical_analysis::input::text::parse(&text, &Default::default()).unwrap();
        assert_eq!(back.xyz, a.recording.xyz);
        assert_eq!(back.temp.as_ref().unwrap().len(), a.recording.len());
        assert!(a.recording.xyz.iter().flatten().all(|v| v.fract() == 0.0));
    }

    /// The 16-bit MEMS is written in m/s² (a hold's mean norm is ~9.8, on the lattice of
    /// 9.80665/16384), its truth in the same unit (`check_truth` inverts it inside
    /// `simulate`), and its 400 Hz times survive the CSV distinct and in order.
    #[test]
    fn mems16_brisk_at_400_hz_is_in_m_s2_and_parses_back() {
        let cfg = SimConfig {
            poses: 10,
            device: Device::Mems16,
            rate_hz: 400.0,
            profile: Profile::Brisk,
            ..Default::default()
        };
        let a = simulate(&cfg).unwrap();
        let rest = &a.recording.xyz[..400];
        let norm = rest
            .iter()
            .map(|m| m.iter().map(|v| v * v).sum::<f64>().sqrt())
            .sum::<f64>()
            / 400.0;
        assert!((norm - 9.80665).abs() < 0.6, "{norm}");
        let q = 9.80665 / 16384.0;
        assert!(rest
            .iter()
            .flatten()
            .all(|v| ((v / q) - (v / q).round()).abs() < 1e-6));
        let text = to_csv(&a.recording);
        let back = wiical_analysis::input::text::parse(&text, &Default::default()).unwrap();
        assert!((back.estimated_rate_hz().unwrap() - 400.0).abs() < 1e-6);
        // Brisk: holds of 2–4 s after the rest.
        for p in &a.truth.poses[1..] {
            assert!((2.0..4.0).contains(&(p.t_end - p.t_start)), "{p:?}");
        }
    }
}
