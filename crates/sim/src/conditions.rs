//! Time and temperature: the simulated temperature (warm-up, hand, wobble), the true
//! conditions of every sample (time, temperature, lagged temperature, rate) and the holds'
//! statistics the open-basis magnitudes and references use.

use crate::motion::{Seg, SegKind};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Time constant of the simulated thermal lag, s: the sensing element follows the measured
/// (case) temperature through a first-order lag this slow, about the length of a recording.
pub const THERMAL_LAG_TAU_S: f64 = 300.0;

/// The true conditions of one sample: what the time and temperature terms depend on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleConditions {
    /// Time since the first sample, s.
    pub time_s: f64,
    /// True temperature (before the thermometer's noise and rounding), °C.
    pub temperature_c: f64,
    /// The true temperature through the first-order lag of
    /// [`THERMAL_LAG_TAU_S`], °C.
    pub lagged_c: f64,
    /// `dθ/dt` of the true temperature (central difference), °C/s.
    pub rate_c_per_s: f64,
}

/// Parameters of the simulated temperature.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TempModel {
    /// Room temperature, °C.
    pub room_c: f64,
    /// Self-heating warm-up amplitude, °C.
    pub warmup_c: f64,
    /// Warm-up time constant, s.
    pub warmup_tau_s: f64,
    /// Hand-warming steady-state rise while held, °C.
    pub hand_c: f64,
    /// Air-conditioning wobble amplitude, °C, and period, s.
    pub wobble_c: f64,
    /// Wobble period, s.
    pub wobble_period_s: f64,
}

/// The temperature model and the true temperature of every sample, °C.
pub(super) fn temperatures(
    rng: &mut ChaCha8Rng,
    segs: &[Seg],
    n: usize,
    fs: f64,
) -> (TempModel, Vec<f64>) {
    let tm = TempModel {
        room_c: rng.random_range(20.0..26.0),
        warmup_c: rng.random_range(3.0..8.0),
        warmup_tau_s: rng.random_range(50.0..150.0),
        hand_c: rng.random_range(2.0..5.0),
        wobble_c: rng.random_range(0.3..1.0),
        wobble_period_s: rng.random_range(80.0..200.0),
    };
    let wobble_phase = rng.random_range(0.0..std::f64::consts::TAU);
    let mut temps = Vec::with_capacity(n);
    let mut hand = 0.0;
    let mut seg_i = 0;
    for i in 0..n {
        let ti = i as f64 / fs;
        while seg_i + 1 < segs.len() && ti >= segs[seg_i].t1 {
            seg_i += 1;
        }
        let held = matches!(segs[seg_i].kind, SegKind::Move { .. });
        let target = if held { tm.hand_c } else { 0.0 };
        hand += (target - hand) / (30.0 * fs);
        let th = tm.room_c
            + tm.warmup_c * (1.0 - (-ti / tm.warmup_tau_s).exp())
            + hand
            + tm.wobble_c
                * ((std::f64::consts::TAU * ti / tm.wobble_period_s) + wobble_phase).sin()
            - tm.wobble_c * wobble_phase.sin();
        temps.push(th);
    }
    (tm, temps)
}

/// The true conditions of every sample: its time, the true temperature, that temperature
/// through the first-order lag of [`THERMAL_LAG_TAU_S`] (starting in equilibrium
/// with it, exact discretisation of `dθ_lag/dt = (θ − θ_lag)/τ`) and its rate (central
/// difference, one-sided at the ends).
pub(super) fn sample_conditions(temps: &[f64], fs: f64) -> Vec<SampleConditions> {
    let alpha = 1.0 - (-1.0 / (fs * THERMAL_LAG_TAU_S)).exp();
    let mut lag = temps.first().copied().unwrap_or(0.0);
    let last = temps.len().saturating_sub(1);
    temps
        .iter()
        .enumerate()
        .map(|(i, &th)| {
            lag += alpha * (th - lag);
            let (a, b) = (i.saturating_sub(1), (i + 1).min(last));
            let rate = if b > a {
                (temps[b] - temps[a]) * fs / (b - a) as f64
            } else {
                0.0
            };
            SampleConditions {
                time_s: i as f64 / fs,
                temperature_c: th,
                lagged_c: lag,
                rate_c_per_s: rate,
            }
        })
        .collect()
}

/// What the time and temperature families are drawn against: the conditions of the holds'
/// samples, the holds' mean times and mean temperatures.
pub struct HoldStats<'a> {
    /// Conditions of every sample that lies in a hold.
    pub samples: Vec<&'a SampleConditions>,
    /// Mean over holds of each hold's mid-time, s.
    pub t_ref: f64,
    /// Mean over holds of each hold's mean temperature, °C (the analysis' θ̄).
    pub theta_ref: f64,
    /// The same of the lagged temperature, °C (the thermal lag's reference, so that the
    /// truth's bias is the bias at the holds' mean lagged temperature).
    pub lagged_ref: f64,
}

impl HoldStats<'_> {
    /// Spread (max − min) of `value` (a regressor of the sample conditions) over the holds'
    /// samples, at least `floor`.
    pub(super) fn range(&self, value: impl Fn(&SampleConditions) -> f64, floor: f64) -> f64 {
        let (lo, hi) = self
            .samples
            .iter()
            .map(|c| value(c))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        (hi - lo).max(floor)
    }
}

/// The holds' samples, mean mid-time and mean temperature (each hold weighted equally, as
/// the analysis weighs its windows): what the open-basis magnitudes and references use.
pub(super) fn hold_stats<'a>(
    segs: &[Seg],
    conds: &'a [SampleConditions],
    fs: f64,
) -> HoldStats<'a> {
    let mut samples = Vec::new();
    let (mut mids, mut temps, mut lagged) = (Vec::new(), Vec::new(), Vec::new());
    for seg in segs.iter().filter(|s| matches!(s.kind, SegKind::Hold(_))) {
        let lo = ((seg.t0 * fs).ceil() as usize).min(conds.len());
        let hi = ((seg.t1 * fs).ceil() as usize).min(conds.len());
        let Some(hold) = conds.get(lo..hi).filter(|h| !h.is_empty()) else {
            continue;
        };
        samples.extend(hold);
        mids.push(0.5 * (seg.t0 + seg.t1));
        let n = hold.len() as f64;
        temps.push(hold.iter().map(|c| c.temperature_c).sum::<f64>() / n);
        lagged.push(hold.iter().map(|c| c.lagged_c).sum::<f64>() / n);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / (v.len().max(1) as f64);
    HoldStats {
        samples,
        t_ref: mean(&mids),
        theta_ref: mean(&temps),
        lagged_ref: mean(&lagged),
    }
}
