//! The effect terms drawn into a simulated recording: for every effect asked for (in the
//! order given, each as if it were alone), its coefficients, the outlier poses for
//! `outliers`, the open-basis cross, time and temperature terms.

use crate::conditions::HoldStats;
use crate::config::{SimDraw, SimEffect};
use crate::error::Result;
use crate::error::SimulateError;
use crate::geometry::random_unit;
use crate::motion::{Seg, SegKind};
use crate::open_basis_terms::{self, Acts, Cross, ExtraTerm};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use wiical_core::model::{CROSS2, CROSS3, DEGREE2, DEGREE3};

/// A pose that was not still (`outliers` effect).
#[derive(Debug, Clone, Serialize)]
pub struct TrueOutlier {
    /// Index into `poses`.
    pub pose: usize,
    /// Start of the hold, s.
    pub t_start: f64,
    /// End of the hold, s.
    pub t_end: f64,
    /// Shift of the hold's mean ‖a‖, milli-g.
    pub shift_mg: f64,
}

impl TrueOutlier {
    /// The extra specific force along gravity (g) at time `ti` of its hold: a 2 s half-sine
    /// push in the middle of the hold whose average over the hold is the outlier's shift;
    /// `None` outside the push.
    pub(super) fn push(&self, ti: f64) -> Option<f64> {
        let len = self.t_end - self.t_start;
        let tb = 2.0f64.min(len * 0.5);
        let start = self.t_start + 0.5 * (len - tb);
        (start..start + tb).contains(&ti).then(|| {
            let amp = self.shift_mg / 1000.0 * std::f64::consts::PI * len / (2.0 * tb);
            amp * (std::f64::consts::PI * (ti - start) / tb).sin()
        })
    }
}

/// The effect terms drawn for a scene (correction side, see `wiical_core::model`).
#[derive(Debug, Clone, Default)]
pub(super) struct EffectTerms {
    /// Quadratic, cubic, drift (counts/s), bias temperature coefficient (counts/°C), scale
    /// temperature coefficient (1/°C), per axis.
    pub(super) eff64: [[f64; 3]; 5],
    /// The poses that were not still.
    pub(super) outliers: Vec<TrueOutlier>,
    /// Open-basis cross terms (1/g, 1/g²), as the core holds them.
    pub(super) cross: Cross,
    /// Open-basis time and temperature terms (bias coefficients in counts).
    pub(super) extras: Vec<ExtraTerm>,
}

/// The effect's draw moved onto axis `axis` alone: the whole magnitude `x` there, with the
/// sign it was drawn with, the other axes zero (the random draw is made as usual, so the rest
/// of the scene is the one the same seed gives without an axis).
fn onto_axis(v: [f64; 3], axis: Option<usize>, x: f64) -> [f64; 3] {
    match axis {
        None => v,
        Some(a) => std::array::from_fn(|j| if j == a { x.copysign(v[a]) } else { 0.0 }),
    }
}

/// The effect terms (and the outlier poses) for `effects` (each with its size in mg), drawn
/// in the order given, each as if it were alone (so a single effect draws exactly what it
/// always did; an open-basis family draws only when it is asked for).
pub(super) fn effect_terms(
    rng: &mut ChaCha8Rng,
    effects: &[SimDraw],
    s: &[f64; 3],
    segs: &[Seg],
    temps: &[f64],
    duration: f64,
    holds: &HoldStats,
) -> Result<EffectTerms> {
    let (tmin, tmax) = temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let t_range = (tmax - tmin).max(0.5);
    let mut eff64 = [[0.0f64; 3]; 5];
    let mut outliers = Vec::new();
    let mut cross = Cross::default();
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
            SimEffect::Outliers => outliers = outlier_poses(rng, magnitude, segs)?,
            SimEffect::CrossQuadratic | SimEffect::CrossCubic => {
                draw_cross(rng, effect, x, axis, &mut cross);
            }
            _ => extras.extend(draw_extra(rng, effect, x, axis, s, holds)),
        }
    }
    Ok(EffectTerms {
        eff64,
        outliers,
        cross,
        extras,
    })
}

/// Per-axis coefficients for a nonlinearity of size `x` (largest axis exactly `x`).
fn axis_coefficients(rng: &mut ChaCha8Rng, x: f64) -> [f64; 3] {
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

/// 2–3 distinct poses (not the rest) of the timeline `segs` whose mean ‖a‖ is pushed by
/// ±`magnitude` mg.
fn outlier_poses(rng: &mut ChaCha8Rng, magnitude: f64, segs: &[Seg]) -> Result<Vec<TrueOutlier>> {
    let count = rng.random_range(2..=3usize);
    // One hold per pose, the rest included.
    let poses = segs
        .iter()
        .filter(|s| matches!(s.kind, SegKind::Hold(_)))
        .count();
    let mut chosen: Vec<usize> = Vec::new();
    while chosen.len() < count {
        let k = rng.random_range(1..poses);
        if !chosen.contains(&k) {
            chosen.push(k);
        }
    }
    chosen.sort_unstable();
    let mut outliers = Vec::new();
    for k in chosen {
        let seg = segs
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

/// Draws a time or temperature family of size `x` (g): a bias moves by `x` (vector norm, in
/// counts through the scales `s`) over the regressor's range on the holds, a scale by `x` on
/// its largest axis. `None` for the other families.
fn draw_extra(
    rng: &mut ChaCha8Rng,
    effect: SimEffect,
    x: f64,
    axis: Option<usize>,
    s: &[f64; 3],
    h: &HoldStats,
) -> Option<ExtraTerm> {
    let (acts, regressor) = open_basis_terms::family_regressor(effect, h)?;
    let range = h.range(|c| regressor.value(c), 1e-9);
    let coefficients = match acts {
        Acts::Bias => {
            let v = onto_axis(random_unit(rng), axis, 1.0);
            std::array::from_fn(|j| v[j] * x * s[j] / range)
        }
        Acts::Scale => onto_axis(axis_coefficients(rng, x), axis, x).map(|k| k / range),
    };
    Some(ExtraTerm {
        family: effect,
        acts,
        regressor,
        coefficients,
    })
}

/// Draws a cross term of size `x` (g) into `cross`: output axis `axis` (drawn when `None`),
/// one monomial drawn among that axis's cross monomials, the coefficient such that the term
/// reaches `±x` at its largest over the sphere of directions.
fn draw_cross(
    rng: &mut ChaCha8Rng,
    effect: SimEffect,
    x: f64,
    axis: Option<usize>,
    cross: &mut Cross,
) {
    let i = axis.unwrap_or_else(|| rng.random_range(0..3usize));
    let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
    if effect == SimEffect::CrossQuadratic {
        let j = rng.random_range(0..5usize);
        cross.quadratic[i][j] = sign * x / open_basis_terms::sphere_peak(&DEGREE2[CROSS2[i][j]]);
    } else {
        let j = rng.random_range(0..9usize);
        cross.cubic[i][j] = sign * x / open_basis_terms::sphere_peak(&DEGREE3[CROSS3[i][j]]);
    }
}
