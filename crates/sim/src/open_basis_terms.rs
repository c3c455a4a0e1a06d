//! The simulator's open-basis families: effects beyond the seven candidates,
//! each put into a recording with its truth stated.
//!
//! Two kinds:
//! * **Orientation** (`cross-quadratic`, `cross-cubic`): one term `a_i += c·monomial(u)` on one
//!   output axis, held by the core's [`Effects`](wiical_core::Effects) (`cross_quadratic`,
//!   `cross_cubic`), so the truth calibration applies it and the forward model inverts it
//!   (3-D Newton, [`invert_with_cross`]).
//! * **Time and temperature** (`scale-drift`, `temperature-squared`, `thermal-lag`, …): terms
//!   the core cannot hold. They are the simulator's own, defined on the correction side like
//!   the core's: a *bias* term adds `c_i·r` (file units) to the bias subtracted from the
//!   reading, a *scale* term multiplies `u_i = (K·(m − b_eff))_i` by `1 + s_i·r` (applied
//!   with the core's `1 + scale_temp_i·Δθ`). `r` is the family's regressor at the sample
//!   ([`Regressor`]). [`crate::Truth::calibration_at`] folds them into a
//!   per-sample [`Calibration`](wiical_core::Calibration), so the truth is checked with the
//!   core's own `correct`.
//!
//! Every range that sets a magnitude (the regressor's spread) is taken over the samples of
//! the holds: what the windows see.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::conditions::{HoldStats, SampleConditions, THERMAL_LAG_TAU_S};
use crate::config::SimEffect;
use serde::Serialize;
use wiical_analysis::report::effect_names as names;
use wiical_core::model::{CROSS2, CROSS3, DEGREE2, DEGREE3};

/// What a time or temperature term multiplies (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Regressor {
    /// `t`, s since the first sample.
    Time,
    /// `(t − t_ref)²`, s².
    TimeSquared {
        /// Reference time, s.
        t_ref: f64,
    },
    /// `(θ − θ_ref)^power`, °C^power (true temperature).
    Temperature {
        /// 2 or 3.
        power: i32,
        /// Reference temperature, °C.
        theta_ref: f64,
    },
    /// `θ_lag − θ_ref`, °C: the temperature through a first-order lag of
    /// [`THERMAL_LAG_TAU_S`].
    Lagged {
        /// Reference temperature, °C.
        theta_ref: f64,
    },
    /// `dθ/dt`, °C/s (true temperature).
    Rate,
}

impl Regressor {
    /// The regressor's value at a sample.
    pub fn value(&self, c: &SampleConditions) -> f64 {
        match *self {
            Regressor::Time => c.time_s,
            Regressor::TimeSquared { t_ref } => (c.time_s - t_ref).powi(2),
            Regressor::Temperature { power, theta_ref } => {
                (c.temperature_c - theta_ref).powi(power)
            }
            Regressor::Lagged { theta_ref } => c.lagged_c - theta_ref,
            Regressor::Rate => c.rate_c_per_s,
        }
    }

    /// Text for the truth, e.g. `(θ − θ_ref)²`.
    fn text(&self) -> &'static str {
        match self {
            Regressor::Time => "t (s since the first sample)",
            Regressor::TimeSquared { .. } => "(t − t_ref)² (s²)",
            Regressor::Temperature { power: 2, .. } => "(θ − θ_ref)² (°C²)",
            Regressor::Temperature { .. } => "(θ − θ_ref)³ (°C³)",
            Regressor::Lagged { .. } => "θ_lag − θ_ref (°C), dθ_lag/dt = (θ − θ_lag)/τ",
            Regressor::Rate => "dθ/dt (°C/s)",
        }
    }

    /// Unit of the regressor, for the coefficient's unit.
    fn unit(&self) -> &'static str {
        match self {
            Regressor::Time => "s",
            Regressor::TimeSquared { .. } => "s²",
            Regressor::Temperature { power: 2, .. } => "°C²",
            Regressor::Temperature { .. } => "°C³",
            Regressor::Lagged { .. } => "°C",
            Regressor::Rate => "(°C/s)",
        }
    }

    /// The reference (t_ref, s, or θ_ref, °C) when the regressor has one.
    fn reference(&self) -> Option<f64> {
        match *self {
            Regressor::TimeSquared { t_ref } => Some(t_ref),
            Regressor::Temperature { theta_ref, .. } | Regressor::Lagged { theta_ref } => {
                Some(theta_ref)
            }
            Regressor::Time | Regressor::Rate => None,
        }
    }
}

/// Whether a time or temperature term moves the bias or the scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acts {
    /// Added to the bias (file units per regressor unit).
    Bias,
    /// Relative scale of `u_i` (per regressor unit).
    Scale,
}

/// A time or temperature term the core cannot hold (correction side, see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtraTerm {
    /// Its family.
    pub family: SimEffect,
    /// Bias or scale.
    pub acts: Acts,
    /// What it multiplies.
    pub regressor: Regressor,
    /// Per axis: bias in counts per regressor unit, or relative scale per regressor unit.
    pub coefficients: [f64; 3],
}

/// One open-basis term of the truth, as `FILE.truth.json` states it.
#[derive(Debug, Clone, Serialize)]
pub struct OpenTerm {
    /// The family (an effect name, e.g. `thermal-lag`).
    pub family: &'static str,
    /// The names `analyze` gives this family's terms (`cross-quadratic (z: x·y)`,
    /// `scale-drift (x)`, …): one per axis that carries it.
    pub terms: Vec<String>,
    /// `orientation` (`a_i += c·monomial(u)`), `bias` (added to the bias the correction
    /// subtracts) or `scale` (`u_i ·= 1 + c_i·r`).
    pub acts_on: &'static str,
    /// What the coefficients multiply: the monomial of `u` (g) or the time/temperature
    /// regressor.
    pub regressor: String,
    /// Per output axis (x, y, z), in `unit`.
    pub coefficients: [f64; 3],
    /// Unit of the coefficients.
    pub unit: String,
    /// `t_ref` (s) or `θ_ref` (°C, the mean of the holds' mean temperatures, the analysis'
    /// θ̄; for the thermal lag that of the lagged temperature) when the regressor has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<f64>,
    /// The thermal lag's time constant, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_constant_s: Option<f64>,
    /// True: held by `calibration.effects` (so `Calibration::correct` applies it); false:
    /// the simulator's own term (`Truth::calibration_at` folds it in per sample).
    pub in_calibration: bool,
}

/// The cross terms drawn: degree-2 and degree-3 coefficients as in
/// [`wiical_core::Effects`] (1/g, 1/g²).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Cross {
    /// `cross_quadratic` (1/g).
    pub quadratic: [[f64; 5]; 3],
    /// `cross_cubic` (1/g²).
    pub cubic: [[f64; 9]; 3],
}

impl Cross {
    /// True when some coefficient is non-zero.
    pub fn any(&self) -> bool {
        self.quadratic.iter().flatten().any(|c| *c != 0.0)
            || self.cubic.iter().flatten().any(|c| *c != 0.0)
    }
}

/// `x^e` for small integer `e` (`0^0 = 1`).
fn pow(x: f64, e: u8) -> f64 {
    x.powi(i32::from(e))
}

/// A monomial of `u` with exponents `e`.
fn monomial(u: &[f64; 3], e: &[u8; 3]) -> f64 {
    pow(u[0], e[0]) * pow(u[1], e[1]) * pow(u[2], e[2])
}

/// Largest `|monomial|` over the unit sphere: `√(Π e_k^e_k / n^n)` (Lagrange), so that a
/// coefficient of `x / peak` makes the term reach `x` at its largest.
pub(super) fn sphere_peak(e: &[u8; 3]) -> f64 {
    let n: u8 = e.iter().sum();
    let num: f64 = e.iter().map(|&k| pow(f64::from(k), k)).product();
    (num / pow(f64::from(n), n)).sqrt()
}

/// The monomial's name as `analyze` writes it: `x·y`, `x²`, `x²·z`, `x·y·z`.
pub fn monomial_name(e: &[u8; 3]) -> String {
    monomial_text(e, "")
}

/// The monomial with each axis name after `prefix` (`u_x·u_y` for `u_`).
fn monomial_text(e: &[u8; 3], prefix: &str) -> String {
    let parts: Vec<String> = (0..3)
        .filter(|&k| e[k] > 0)
        .map(|k| {
            let power = match e[k] {
                1 => "",
                2 => "²",
                _ => "³",
            };
            format!("{prefix}{}{power}", names::AXES[k])
        })
        .collect();
    parts.join("·")
}

/// Cross terms of output axis `i` at `u` and their gradient (row of the Jacobian).
fn cross_and_gradient(cross: &Cross, i: usize, u: &[f64; 3]) -> (f64, [f64; 3]) {
    let mut value = 0.0;
    let mut grad = [0.0; 3];
    let terms = cross.quadratic[i]
        .iter()
        .zip(CROSS2[i].map(|k| DEGREE2[k]))
        .chain(cross.cubic[i].iter().zip(CROSS3[i].map(|k| DEGREE3[k])));
    for (c, e) in terms {
        if *c == 0.0 {
            continue;
        }
        value += c * monomial(u, &e);
        for (k, g) in grad.iter_mut().enumerate() {
            if e[k] > 0 {
                let mut d = e;
                d[k] -= 1;
                *g += c * f64::from(e[k]) * monomial(u, &d);
            }
        }
    }
    (value, grad)
}

/// Solves `a_i = w_i + q_i·w_i² + c_i·w_i³ + cross_i(w)` for `w` near `start` (the per-axis
/// inverse) by Newton's method on the 3×3 system.
pub fn invert_with_cross(
    a: &[f64; 3],
    q: &[f64; 3],
    c: &[f64; 3],
    cross: &Cross,
    start: [f64; 3],
) -> [f64; 3] {
    let mut w = start;
    for _ in 0..50 {
        let mut f = [0.0; 3];
        let mut jac = [[0.0; 3]; 3];
        for i in 0..3 {
            let (v, g) = cross_and_gradient(cross, i, &w);
            let x = w[i];
            f[i] = x + q[i] * x * x + c[i] * x * x * x + v - a[i];
            jac[i] = g;
            jac[i][i] += 1.0 + 2.0 * q[i] * x + 3.0 * c[i] * x * x;
        }
        let Some(step) = solve3(&jac, &f) else {
            break;
        };
        for (wk, s) in w.iter_mut().zip(step) {
            *wk -= s;
        }
        if step.iter().all(|s| s.abs() < 1e-15) {
            break;
        }
    }
    w
}

/// `J⁻¹·f` by Cramer's rule; `None` when `J` is (nearly) singular.
fn solve3(j: &[[f64; 3]; 3], f: &[f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(j);
    if !(d.abs() > 1e-12) {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let mut m = *j;
        for (row, fi) in m.iter_mut().zip(f) {
            row[k] = *fi;
        }
        det(&m) / d
    }))
}

/// The regressor and kind of a time or temperature family (`None` for the others).
pub(super) fn family_regressor(effect: SimEffect, h: &HoldStats) -> Option<(Acts, Regressor)> {
    let temp = |power| Regressor::Temperature {
        power,
        theta_ref: h.theta_ref,
    };
    Some(match effect {
        SimEffect::ScaleDrift => (Acts::Scale, Regressor::Time),
        SimEffect::ScaleDriftCurved => (Acts::Scale, Regressor::TimeSquared { t_ref: h.t_ref }),
        SimEffect::TemperatureSquared => (Acts::Bias, temp(2)),
        SimEffect::TemperatureCubed => (Acts::Bias, temp(3)),
        SimEffect::TemperatureScaleSquared => (Acts::Scale, temp(2)),
        SimEffect::TemperatureScaleCubed => (Acts::Scale, temp(3)),
        SimEffect::ThermalLag => (
            Acts::Bias,
            Regressor::Lagged {
                theta_ref: h.lagged_ref,
            },
        ),
        SimEffect::TemperatureRate => (Acts::Bias, Regressor::Rate),
        _ => return None,
    })
}

/// The truth's entries for the cross terms (one per non-zero coefficient).
pub fn cross_truth(cross: &Cross) -> Vec<OpenTerm> {
    let mut out = Vec::new();
    for i in 0..3 {
        let quad = cross.quadratic[i]
            .iter()
            .zip(CROSS2[i].map(|k| DEGREE2[k]))
            .map(|(c, e)| (names::CROSS_QUADRATIC, *c, e, "1/g"));
        let cub = cross.cubic[i]
            .iter()
            .zip(CROSS3[i].map(|k| DEGREE3[k]))
            .map(|(c, e)| (names::CROSS_CUBIC, *c, e, "1/g²"));
        for (family, c, e, unit) in quad.chain(cub).filter(|t| t.1 != 0.0) {
            let mono = monomial_name(&e);
            let mut coefficients = [0.0; 3];
            coefficients[i] = c;
            out.push(OpenTerm {
                family,
                terms: vec![format!("{family} ({}: {mono})", names::AXES[i])],
                acts_on: "orientation",
                regressor: format!("{} (u in g)", monomial_text(&e, "u_")),
                coefficients,
                unit: unit.into(),
                reference: None,
                time_constant_s: None,
                in_calibration: true,
            });
        }
    }
    out
}

/// The truth's entry for a time or temperature term; `unit` is the name of one file unit
/// (`counts` or `m/s²`) and `per_count` its value, for a bias stated in the file's unit.
pub fn extra_truth(t: &ExtraTerm, unit: &str, per_count: f64) -> OpenTerm {
    let family = t.family.name();
    let (acts_on, coefficients, unit) = match t.acts {
        Acts::Bias => (
            "bias",
            t.coefficients.map(|c| c * per_count),
            format!("{unit} per {}", t.regressor.unit()),
        ),
        Acts::Scale => ("scale", t.coefficients, format!("1/{}", t.regressor.unit())),
    };
    OpenTerm {
        family,
        terms: (0..3)
            .filter(|&j| coefficients[j] != 0.0)
            .map(|j| format!("{family} ({})", names::AXES[j]))
            .collect(),
        acts_on,
        regressor: t.regressor.text().into(),
        coefficients,
        unit,
        reference: t.regressor.reference(),
        time_constant_s: matches!(t.regressor, Regressor::Lagged { .. })
            .then_some(THERMAL_LAG_TAU_S),
        in_calibration: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_peaks_are_the_maxima() {
        // Brute force over a grid of the sphere.
        for e in DEGREE2.iter().chain(DEGREE3.iter()) {
            let mut best: f64 = 0.0;
            for a in 0..400 {
                for b in 0..200 {
                    let (th, ph) = (
                        f64::from(a) * 0.0157,
                        f64::from(b) * 0.0157 - std::f64::consts::FRAC_PI_2,
                    );
                    let u = [ph.cos() * th.cos(), ph.cos() * th.sin(), ph.sin()];
                    best = best.max(monomial(&u, e).abs());
                }
            }
            let p = sphere_peak(e);
            assert!(
                (best - p).abs() < 2e-3 && best <= p + 1e-12,
                "{e:?}: {best} vs {p}"
            );
        }
    }

    #[test]
    fn cross_inverse_solves_the_forward_model() {
        let mut cross = Cross::default();
        cross.quadratic[2][2] = 0.04; // z += 0.04·x·y
        cross.cubic[0][8] = -0.03; // x += −0.03·x·y·z
        let (q, c) = ([0.01, -0.02, 0.0], [0.0, 0.01, 0.02]);
        let a = [0.5, -0.6, 0.62];
        let w = invert_with_cross(&a, &q, &c, &cross, a);
        for i in 0..3 {
            let (v, _) = cross_and_gradient(&cross, i, &w);
            let back = w[i] + q[i] * w[i] * w[i] + c[i] * w[i].powi(3) + v;
            assert!((back - a[i]).abs() < 1e-13, "{i}: {back} vs {}", a[i]);
        }
    }

    #[test]
    fn monomials_are_named_as_the_analysis_names_them() {
        assert_eq!(monomial_name(&[1, 1, 0]), "x·y");
        assert_eq!(monomial_name(&[0, 2, 0]), "y²");
        assert_eq!(monomial_name(&[2, 0, 1]), "x²·z");
        assert_eq!(monomial_name(&[1, 1, 1]), "x·y·z");
    }
}
