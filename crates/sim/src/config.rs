//! The simulator's settings: the effects to put in (which effect, one enum with the
//! analysis's candidates, [`wiical_analysis::report::effect_table::Effect`]; its size and
//! axis), the recording's profile (how poses are held and changed), the settings and their
//! checks.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::device::Device;
use crate::error::{Error, Result};
use wiical_analysis::report::effect_table::Effect;

/// The effect put into a simulated recording: an [`Effect`] the simulator can put in
/// ([`Effect::simulated`]: [`Effect::SIMULATED_CANDIDATES`], `none` first, then
/// [`Effect::OPEN_BASIS`]), named and parsed by the same table as the analysis's candidates.
pub type SimEffect = Effect;

/// One effect put into a simulation and its size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectSpec {
    /// Which effect.
    pub effect: SimEffect,
    /// Its size in milli-g (see the crate docs); `None`: [`SimEffect::default_magnitude_mg`].
    pub magnitude_mg: Option<f64>,
    /// On one sensor axis only (0, 1, 2 = x, y, z), with the whole magnitude there and the
    /// other axes zero; `None`: on every axis as drawn. Not for `outliers` (no axis).
    pub axis: Option<usize>,
}

impl EffectSpec {
    /// `effect` at `magnitude_mg` (`None`: its default).
    pub fn new(effect: SimEffect, magnitude_mg: Option<f64>) -> Self {
        Self {
            effect,
            magnitude_mg,
            axis: None,
        }
    }

    /// `effect` at `magnitude_mg` on sensor axis `axis` alone (0, 1, 2 = x, y, z).
    pub fn on_axis(effect: SimEffect, magnitude_mg: Option<f64>, axis: usize) -> Self {
        Self {
            axis: Some(axis),
            ..Self::new(effect, magnitude_mg)
        }
    }

    /// The magnitude in use, mg.
    pub fn magnitude(&self) -> f64 {
        self.magnitude_mg
            .unwrap_or_else(|| self.effect.default_magnitude_mg())
    }
}

/// One effect to draw: which, its size (mg), and the one axis it is on (`None`: every axis).
pub(super) type SimDraw = (SimEffect, f64, Option<usize>);

/// How the poses are held and changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// Holds of 4–8 s, moves of 1.5–3 s (a careful calibration session).
    #[default]
    Calm,
    /// Hand-placed holds of 2–4 s, moves of 1–2 s with two hand bumps each (lifting the
    /// sensor and knocking it down on the table): a quick session.
    Brisk,
}

impl Profile {
    /// Parses `calm` / `brisk`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "calm" => Some(Profile::Calm),
            "brisk" => Some(Profile::Brisk),
            _ => None,
        }
    }

    /// Hold and move durations, s (uniform in each range).
    pub(super) fn durations(self) -> ((f64, f64), (f64, f64)) {
        match self {
            Profile::Calm => ((4.0, 8.0), (1.5, 3.0)),
            Profile::Brisk => ((2.0, 4.0), (1.0, 2.0)),
        }
    }
}

/// Simulation settings.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// The effects to put in (empty or `none` only: the linear model alone). Each appears at
    /// most once.
    pub effects: Vec<EffectSpec>,
    /// Seed of every random choice.
    pub seed: u64,
    /// Device.
    pub device: Device,
    /// Number of poses after the initial rest.
    pub poses: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Initial rest, s.
    pub init_s: f64,
    /// Write a `temp` column (forced on for the `temperature` and `temperature-scale` effects).
    pub temp_column: bool,
    /// Per-sample noise std (counts); `None`: the device's.
    pub noise_counts: Option<f64>,
    /// Hold and move lengths.
    pub profile: Profile,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            effects: Vec::new(),
            seed: 1,
            device: Device::Wiimote,
            poses: 30,
            rate_hz: 100.0,
            init_s: 5.0,
            temp_column: true,
            noise_counts: None,
            profile: Profile::Calm,
        }
    }
}

/// Checks the settings; returns the effects in use (without `none`) with their magnitudes (mg)
/// and the noise (counts).
pub(super) fn check_config(cfg: &SimConfig) -> Result<(Vec<SimDraw>, f64)> {
    if !(cfg.rate_hz.is_finite() && cfg.rate_hz >= 20.0 && cfg.rate_hz <= 2000.0) {
        return Err(Error::InvalidSetting("rate must be between 20 and 2000 Hz"));
    }
    if cfg.poses < 9 || cfg.poses > 20_000 {
        return Err(Error::InvalidSetting(
            "poses must be between 9 and 20000 (the full model needs at least 9)",
        ));
    }
    let mut effects: Vec<SimDraw> = Vec::new();
    for spec in &cfg.effects {
        let magnitude = spec.magnitude();
        if !(magnitude.is_finite() && (0.0..=200.0).contains(&magnitude)) {
            return Err(Error::InvalidSetting(
                "magnitude must be between 0 and 200 mg",
            ));
        }
        if spec.effect == SimEffect::None {
            continue;
        }
        if effects.iter().any(|(e, _, _)| *e == spec.effect) {
            return Err(Error::InvalidSetting("effect: each effect may appear once"));
        }
        if spec
            .axis
            .is_some_and(|a| a > 2 || spec.effect == SimEffect::Outliers)
        {
            return Err(Error::InvalidSetting(
                "axis: x, y or z, and not for outliers (they have no axis)",
            ));
        }
        effects.push((spec.effect, magnitude, spec.axis));
    }
    if !(cfg.init_s.is_finite() && cfg.init_s >= 3.0) {
        return Err(Error::InvalidSetting(
            "the initial rest must be at least 3 s (the detector's noise reference)",
        ));
    }
    let noise = cfg
        .noise_counts
        .unwrap_or_else(|| cfg.device.noise_counts());
    // 20 counts for the 10-bit devices, 0.01 g for finer ones.
    let max_noise = 20.0f64.max(0.01 * cfg.device.counts_per_g());
    if !(noise.is_finite() && (0.0..=max_noise).contains(&noise)) {
        return Err(Error::InvalidSetting(
            "noise must be between 0 and 20 counts (0.01 g for a 16-bit device)",
        ));
    }
    Ok((effects, noise))
}
