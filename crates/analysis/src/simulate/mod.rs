//! The simulator: Wiimote- / Nunchuk-like multi-position recordings with known truth and,
//! optionally, one or several effects the linear model lacks, for testing `wiical analyze` blind.
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
//! | `thermal-lag` | bias `c·(θ_lag − θ_ref)`, `θ_lag` the true temperature through a first-order lag of τ = [`open_basis_terms::THERMAL_LAG_TAU_S`] (300 s) | the bias moves by X mg over the range of `θ_lag` |
//! | `temperature-rate` | bias `c·dθ/dt` (file unit per °C/s, true temperature) | the bias moves by X mg over the range of `dθ/dt` |
//!
//! The temperature families need the `temp` column (it is always written for them). The
//! temperature spans what the warm-up model gives: 3–8 °C of self-heating, 2–5 °C of hand
//! warming and a 0.3–1 °C wobble, so a few °C over the holds even in a brisk recording.
//!
//! The truth is written next to the recording as `FILE.truth.json` ([`Truth`]).
//!
//! One concern a file: `config` (the settings and their checks, the [`Profile`]), `device`
//! (the sensors imitated), `motion` (poses, the timeline of holds and moves, the specific
//! force), `conditions` (the temperature model, every sample's time and temperature, the
//! holds' statistics), `draw` (the effects and their coefficients), [`open_basis_terms`]
//! (the open-basis families), `sensor` (the noiseless reading and the recorded counts),
//! `truth` (what the simulation knows and its self-check), `hold_score` (a detection against
//! the true holds), `files` (CSV and JSON out); [`gyro`], [`magnetometer`] and [`kalman`]
//! simulate the other sensors and the Kalman demo.

mod conditions;
mod config;
mod device;
mod draw;
mod files;
pub mod gyro;
mod hold_score;
pub mod kalman;
pub mod magnetometer;
mod motion;
pub mod open_basis_terms;
mod sensor;
mod truth;

pub use crate::error::simulate::SimulateError;
pub use conditions::{SampleConditions, TempModel};
pub use config::{Profile, SimConfig};
pub use device::Device;
pub use draw::{EffectSpec, SimEffect};
pub use files::{to_csv, truth_path, write};
pub use hold_score::{score_holds, HoldScore, FOUND_EDGE_S, FOUND_MIN_S, HOLD_MIN_STILL_S};
pub use truth::{TrueOutlier, TruePose, Truth};

use crate::error::Result;
use crate::input::recording::Recording;
use conditions::{hold_stats, sample_conditions, temperatures};
use config::check_config;
use draw::effect_terms;
use motion::{pose_directions, timeline};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sensor::Scene;

/// A simulated recording and its truth.
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// The recording, as `input::front_door::load` would return it.
    pub recording: Recording,
    /// The truth.
    pub truth: Truth,
    /// The true conditions of every sample (the truth's time and temperature terms depend on
    /// them, see [`Truth::calibration_at`]).
    pub conditions: Vec<SampleConditions>,
}

/// Simulates a recording (see the module docs).
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
    let mut scene = Scene {
        fs,
        noise,
        d,
        bias,
        dirs,
        segs,
        tm,
        temps,
        eff64: [[0.0; 3]; 5],
        outliers: Vec::new(),
        cross: open_basis_terms::Cross::default(),
        extras: Vec::new(),
        conds,
        adc: cfg.device.adc_range(),
        unit: cfg.device.unit_per_count(),
    };
    let drawn = {
        let holds = hold_stats(&scene.segs, &scene.conds, fs);
        effect_terms(&mut rng, &effects, &s, &scene, duration, &holds)?
    };
    (scene.eff64, scene.outliers) = (drawn.eff64, drawn.outliers);
    (scene.cross, scene.extras) = (drawn.cross, drawn.extras);
    let rec = scene.record(
        &mut rng,
        cfg.temp_column || effects.iter().any(|(e, _, _)| e.needs_temperature()),
    );
    let truth = scene.truth(cfg, &effects)?;
    scene.check_truth(&truth)?;
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
        let back = crate::input::text::parse(&text, &Default::default()).unwrap();
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
        let back = crate::input::text::parse(&text, &Default::default()).unwrap();
        assert!((back.estimated_rate_hz().unwrap() - 400.0).abs() < 1e-6);
        // Brisk: holds of 2–4 s after the rest.
        for p in &a.truth.poses[1..] {
            assert!((2.0..4.0).contains(&(p.t_end - p.t_start)), "{p:?}");
        }
    }
}
