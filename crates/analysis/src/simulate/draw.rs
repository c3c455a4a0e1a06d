//! The effects put into a simulated recording and their draw: which effect (one enum with
//! the analysis's candidates, [`crate::report::effect_table::Effect`]), its size and axis,
//! and the coefficients drawn for it (the outlier poses for `outliers`).

use super::motion::{random_unit, SegKind};
use super::open_basis_terms;
use super::sensor::Scene;
use super::truth::TrueOutlier;
use super::SimulateError;
use crate::error::Result;
pub use crate::report::effect_table::Effect;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The effect put into a simulated recording: an [`Effect`] the simulator can put in
/// ([`Effect::simulated`]: [`Effect::SIMULATED_CANDIDATES`], `none` first, then
/// [`Effect::OPEN_BASIS`]), named and parsed by the same table as the analysis's candidates.
pub type SimEffect = Effect;

/// One effect put into a simulation and its size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectSpec {
    /// Which effect.
    pub effect: SimEffect,
    /// Its size in milli-g (see the module docs); `None`: [`SimEffect::default_magnitude_mg`].
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

/// The effect's draw moved onto axis `axis` alone: the whole magnitude `x` there, with the
/// sign it was drawn with, the other axes zero (the random draw is made as usual, so the rest
/// of the scene is the one the same seed gives without an axis).
pub(super) fn onto_axis(v: [f64; 3], axis: Option<usize>, x: f64) -> [f64; 3] {
    match axis {
        None => v,
        Some(a) => std::array::from_fn(|j| if j == a { x.copysign(v[a]) } else { 0.0 }),
    }
}

/// The effect terms drawn for a scene.
pub(super) struct Drawn {
    /// See [`Scene::eff64`].
    pub(super) eff64: [[f64; 3]; 5],
    pub(super) outliers: Vec<TrueOutlier>,
    pub(super) cross: open_basis_terms::Cross,
    pub(super) extras: Vec<open_basis_terms::ExtraTerm>,
}

/// The effect terms (and the outlier poses) for `effects` (each with its size in mg), drawn
/// in the order given, each as if it were alone (so a single effect draws exactly what it
/// always did; an open-basis family draws only when it is asked for).
pub(super) fn effect_terms(
    rng: &mut ChaCha8Rng,
    effects: &[SimDraw],
    s: &[f64; 3],
    scene: &Scene,
    duration: f64,
    holds: &open_basis_terms::HoldStats,
) -> Result<Drawn> {
    let (tmin, tmax) = scene
        .temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let t_range = (tmax - tmin).max(0.5);
    let mut eff64 = [[0.0f64; 3]; 5];
    let mut outliers = Vec::new();
    let mut cross = open_basis_terms::Cross::default();
    let mut extras = Vec::new();
    for &(effect, magnitude, axis) in effects {
        let x = magnitude / 1000.0;
        match effect {
            SimEffect::None => {}
            SimEffect::Quadratic => eff64[0] = onto_axis(axis_coefficients(rng, x), axis, x),
            SimEffect::Cubic => eff64[1] = onto_axis(axis_coefficients(rng, x), axis, x),
            SimEffect::BiasDrift => {
                let v = onto_axis(random_unit(rng), axis, 1.0);
                eff64[2] = std::array::from_fn(|j| v[j] * x * s[j] / duration);
            }
            SimEffect::Temperature => {
                let v = onto_axis(random_unit(rng), axis, 1.0);
                eff64[3] = std::array::from_fn(|j| v[j] * x * s[j] / t_range);
            }
            SimEffect::TemperatureScale => {
                eff64[4] = onto_axis(axis_coefficients(rng, x), axis, x).map(|k| k / t_range);
            }
            SimEffect::Outliers => outliers = outlier_poses(rng, magnitude, scene)?,
            SimEffect::CrossQuadratic | SimEffect::CrossCubic => {
                open_basis_terms::draw_cross(rng, effect, x, axis, &mut cross);
            }
            _ => extras.extend(open_basis_terms::draw_extra(rng, effect, x, axis, s, holds)),
        }
    }
    Ok(Drawn {
        eff64,
        outliers,
        cross,
        extras,
    })
}

/// Per-axis coefficients for a nonlinearity of size `x` (largest axis exactly `x`).
pub(super) fn axis_coefficients(rng: &mut ChaCha8Rng, x: f64) -> [f64; 3] {
    let mut k = [0.0; 3];
    let big = rng.random_range(0..3usize);
    for (j, kj) in k.iter_mut().enumerate() {
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let size = if j == big {
            1.0
        } else {
            rng.random_range(0.4..1.0)
        };
        *kj = sign * size * x;
    }
    k
}

/// 2–3 distinct poses (not the rest) whose mean ‖a‖ is pushed by ±`magnitude` mg.
pub(super) fn outlier_poses(
    rng: &mut ChaCha8Rng,
    magnitude: f64,
    scene: &Scene,
) -> Result<Vec<TrueOutlier>> {
    let count = rng.random_range(2..=3usize);
    let mut chosen: Vec<usize> = Vec::new();
    while chosen.len() < count {
        let k = rng.random_range(1..scene.dirs.len());
        if !chosen.contains(&k) {
            chosen.push(k);
        }
    }
    chosen.sort_unstable();
    let mut outliers = Vec::new();
    for k in chosen {
        let seg = scene
            .segs
            .iter()
            .find(|s| matches!(s.kind, SegKind::Hold(p) if p == k))
            .ok_or(SimulateError::NoHoldSegment)?;
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        outliers.push(TrueOutlier {
            pose: k,
            t_start: seg.t0,
            t_end: seg.t1,
            shift_mg: sign * magnitude,
        });
    }
    Ok(outliers)
}
