//! What the final residual correlates with, computed only when the residual
//! stays above the noise floor (the verdict's test, [`crate::report::verdict::residual_unexplained`]).
//!
//! The multi-position model has one residual per window, `‖a‖ − 1 g` (there is no reference
//! direction, so no per-axis residual). The fit has already taken out of it everything its
//! free parameters span (to first order, the columns of its Jacobian: bias ∝ `g`, matrix ∝
//! `g_a·g_b`, each accepted effect), so each regressor is first projected off that span and
//! a constant (an added-variable plot, Frisch–Waugh–Lovell): r is the partial correlation of
//! the residual with what of the regressor the model cannot describe, tested by Student's t
//! on `windows − rank − 1` degrees of freedom, and the slope is the coefficient the regressor
//! would get if it were added to the model, in mg per the regressor's unit. A regressor
//! inside the span (e.g. `g_x` under the full model, time once a bias drift is accepted)
//! is skipped: the fit already describes it.
//!
//! Regressors: window mid-time (minutes since the first sample), window temperature (°C,
//! when the recording has a temperature column), the three axes of the fitted gravity
//! direction `g = K·(m − b) / ‖K·(m − b)‖` ("per g"; in the span of the full model), their
//! cubes (the residual of a per-axis even nonlinearity `q·u²` is `q·g_a³`), their fourth
//! powers (of an odd one, `c·u³`: `c·g_a⁴`) and the product `g_x·g_y·g_z` (a cross-axis
//! term), and time and temperature times each axis of `g` (the residual of a bias that
//! drifts on axis a, with time or with temperature, is `d·t·g_a`), and temperature times
//! each axis's square (of a scale that follows the temperature on axis a: `σ·ϑ·g_a²`).
//! Squares alone are not tried: the matrix spans them.

use crate::fit::model;
use crate::report::correlate::ResidualCorrelate;
use crate::stats as st;
use nalgebra::{DMatrix, DVector};

/// One window as the correlation sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowPoint {
    /// Final-model residual `‖a‖ − 1`, milli-g.
    pub residual_mg: f64,
    /// Window mid-time, s since the first sample.
    pub t_s: f64,
    /// Window mean temperature, °C.
    pub temp_c: Option<f64>,
    /// Fitted gravity direction (unit vector, sensor frame).
    pub g: [f64; 3],
    /// Gradient of the residual with respect to the model's free parameters: the directions
    /// the fit has already taken out of the residual.
    pub span: Vec<f64>,
}

/// The regressors' names, units and values for one window.
fn regressors(w: &WindowPoint) -> Vec<(&'static str, &'static str, Option<f64>)> {
    let [x, y, z] = w.g;
    vec![
        ("time", "mg/min", Some(w.t_s / 60.0)),
        ("temperature", "mg/°C", w.temp_c),
        ("g_x", "mg/g", Some(x)),
        ("g_y", "mg/g", Some(y)),
        ("g_z", "mg/g", Some(z)),
        ("g_x^3", "mg/g^3", Some(x * x * x)),
        ("g_y^3", "mg/g^3", Some(y * y * y)),
        ("g_z^3", "mg/g^3", Some(z * z * z)),
        ("g_x^4", "mg/g^4", Some(x.powi(4))),
        ("g_y^4", "mg/g^4", Some(y.powi(4))),
        ("g_z^4", "mg/g^4", Some(z.powi(4))),
        ("g_x*g_y*g_z", "mg/g^3", Some(x * y * z)),
        ("time*g_x", "mg/(g·min)", Some(w.t_s / 60.0 * x)),
        ("time*g_y", "mg/(g·min)", Some(w.t_s / 60.0 * y)),
        ("time*g_z", "mg/(g·min)", Some(w.t_s / 60.0 * z)),
        ("temperature*g_x", "mg/(g·°C)", w.temp_c.map(|c| c * x)),
        ("temperature*g_y", "mg/(g·°C)", w.temp_c.map(|c| c * y)),
        ("temperature*g_z", "mg/(g·°C)", w.temp_c.map(|c| c * z)),
        (
            "temperature*g_x^2",
            "mg/(g²·°C)",
            w.temp_c.map(|c| c * x * x),
        ),
        (
            "temperature*g_y^2",
            "mg/(g²·°C)",
            w.temp_c.map(|c| c * y * y),
        ),
        (
            "temperature*g_z^2",
            "mg/(g²·°C)",
            w.temp_c.map(|c| c * z * z),
        ),
    ]
}

/// The residual's partial correlation with every regressor the model does not already
/// span, strongest (largest |r|) first; `alpha` is the level of the Bonferroni test over
/// those regressors. Empty when fewer than 3 degrees of freedom remain.
pub fn residual_correlates(points: &[WindowPoint], alpha: f64) -> Vec<ResidualCorrelate> {
    let n = points.len();
    let spans: Vec<&[f64]> = points.iter().map(|p| p.span.as_slice()).collect();
    let Some(proj) = Projector::new(&spans) else {
        return Vec::new();
    };
    let rank = proj.rank;
    if n < rank + 4 {
        return Vec::new();
    }
    let project = |v: Vec<f64>| proj.project(v);
    let res = project(points.iter().map(|p| p.residual_mg).collect());
    let ss_res: f64 = res.iter().map(|x| x * x).sum();
    let rows: Vec<_> = points.iter().map(regressors).collect();
    let dof = (n - rank - 1) as f64;
    let mut out = Vec::new();
    for (k, &(name, unit, _)) in rows[0].iter().enumerate() {
        let Some(xs) = rows.iter().map(|r| r[k].2).collect::<Option<Vec<f64>>>() else {
            continue;
        };
        let total = spread(&xs).powi(2) * n as f64;
        let xp = project(xs);
        let ss_x: f64 = xp.iter().map(|x| x * x).sum();
        // In the model's span (or constant): the fit has already taken it out.
        if !(ss_x > 1e-9 * total && ss_res > 0.0) {
            continue;
        }
        let sxy: f64 = xp.iter().zip(&res).map(|(x, y)| x * y).sum();
        let r = (sxy / (ss_x * ss_res).sqrt()).clamp(-1.0, 1.0);
        let t = r * (dof / (1.0 - r * r).max(1e-300)).sqrt();
        out.push(ResidualCorrelate {
            regressor: name.to_string(),
            r,
            p_value: st::t_two_sided(t.abs(), dof),
            p_bonferroni: 0.0,
            alpha,
            significant: false,
            slope: sxy / ss_x,
            slope_unit: unit,
            windows: n,
            dof: n - rank - 1,
        });
    }
    let m = out.len() as f64;
    for c in &mut out {
        c.p_bonferroni = (c.p_value * m).min(1.0);
        c.significant = c.p_bonferroni < alpha;
    }
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out
}

/// The projection off the span of a constant and per-window span columns (the model's
/// first-order patterns, [`WindowPoint::span`]): what of a per-window series the model cannot
/// describe. Shared by the correlates and the open basis's screening
/// ([`crate::search::open_basis_screening`]).
pub(crate) struct Projector {
    /// Orthonormal basis (columns) of the span.
    basis: DMatrix<f64>,
    /// Its rank (singular values above 1e-9 of the largest).
    pub rank: usize,
}

impl Projector {
    /// From each window's span columns (all of the same length); `None` without windows or
    /// when the decomposition fails.
    pub(crate) fn new(spans: &[&[f64]]) -> Option<Self> {
        let n = spans.len();
        let k = spans.first()?.len() + 1;
        let j = DMatrix::from_fn(n, k, |i, c| if c == 0 { 1.0 } else { spans[i][c - 1] });
        let svd = j.svd(true, false);
        let u = svd.u?;
        let smax = svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > 1e-9 * smax)
            .collect();
        let basis = DMatrix::from_fn(n, keep.len(), |i, c| u[(i, keep[c])]);
        Some(Self {
            rank: keep.len(),
            basis,
        })
    }

    /// `v` minus its projection on the span: O(windows × rank).
    pub(crate) fn project(&self, v: Vec<f64>) -> Vec<f64> {
        let x = DVector::from_vec(v);
        let perp = &x - &self.basis * (self.basis.transpose() * &x);
        perp.iter().copied().collect()
    }
}

/// What each free parameter (`mask`) changes in a window's residual to first order, at the
/// fitted gravity direction `g` (where the residual is zero): a bias `g_a`, a matrix entry
/// `g_j·g_k`, a drift `τ·g_a`, a curved drift `τ²·g_a`, a temperature bias `ϑ·g_a`, a
/// temperature scale `ϑ·g_a²`, a quadratic `g_a³`, a cubic `g_a⁴`, an open slot
/// [`slot_pattern`]. The model's Jacobian at the fit itself is not used: the norm is
/// homogeneous in the matrix, so its columns span `1 + r` and would take the residual itself
/// out.
pub(crate) fn span_of(mask: &model::Mask, g: [f64; 3], w: &model::Win) -> Vec<f64> {
    const K_ENTRIES: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
    let (tau, theta) = (w.tau, w.theta);
    let mut out = Vec::new();
    for (j, free) in mask.iter().enumerate() {
        if !*free {
            continue;
        }
        if j >= model::OPEN {
            out.push(slot_pattern(&w.slots[j - model::OPEN], g));
            continue;
        }
        let (block, a) = (j / 3 * 3, j % 3);
        let ga = g[a];
        out.push(match block {
            model::BIAS => ga,
            model::DRIFT => tau * ga,
            model::DRIFT2 => tau * tau * ga,
            model::BTEMP => theta * ga,
            model::STEMP => theta * ga * ga,
            model::QUAD => ga.powi(3),
            model::CUBIC => ga.powi(4),
            _ if (model::KMAT..model::KMAT + 6).contains(&j) => {
                let (r, c) = K_ENTRIES[j - model::KMAT];
                g[r] * g[c]
            }
            _ => continue,
        });
    }
    out
}

/// First-order pattern of an open slot in the residual at direction `g` (up to its sign
/// convention): a bias `x·g_a`, a scale `x·g_a²`, a cross term on axis `i` with monomial
/// `u^e` `g_i·g^e`.
pub(crate) fn slot_pattern(slot: &model::Slot, g: [f64; 3]) -> f64 {
    match *slot {
        model::Slot::Empty => 0.0,
        model::Slot::Bias { axis, x } => x * g[axis as usize],
        model::Slot::Scale { axis, x } => x * g[axis as usize].powi(2),
        model::Slot::Cross { axis, exps } => g[axis as usize] * model::monomial(&g, exps).0,
    }
}

/// Standard deviation (population) of a series.
fn spread(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
}

/// The text line: the strongest correlate with r, p, slope, and what its significance
/// (at the entries' `alpha`) allows one to say; `time_temp_r` the correlation of window time and temperature (when
/// both were tried, a strong one makes them indistinguishable). `None` for an empty list.
pub fn sentence(list: &[ResidualCorrelate], time_temp_r: Option<f64>) -> Option<String> {
    let c = list.first()?;
    let alpha = c.alpha;
    let mut s = format!(
        "What is left (‖a‖ − 1 of the final model) correlates most with {} \
         (r = {:.2}, p {}, {:.3} {} over {} windows)",
        c.regressor,
        c.r,
        st::fmt_p(c.p_value),
        c.slope,
        c.slope_unit,
        c.windows
    );
    if !c.significant {
        s.push_str(&format!(
            ", not significant after Bonferroni over {} regressors at α = {alpha}: \
             none of these regressors correlates significantly with what is left.",
            list.len()
        ));
        return Some(s);
    }
    let what = match c.regressor.as_str() {
        "time" => "a change over time the accepted effects do not describe",
        "temperature" => "a temperature dependence the accepted effects do not describe",
        x if x.starts_with("time*") => {
            "a bias change over time on that axis the accepted effects do not describe"
        }
        x if x.starts_with("temperature*") && x.ends_with("^2") => {
            "a scale change with temperature on that axis the accepted effects do not describe"
        }
        x if x.starts_with("temperature*") => {
            "a bias change with temperature on that axis the accepted effects do not describe"
        }
        _ => "a dependence on orientation the model and the accepted effects do not describe",
    };
    s.push_str(&format!(
        ": significant after Bonferroni over {} regressors at α = {alpha}, {what}",
        list.len()
    ));
    let both = list.iter().any(|x| x.regressor == "temperature");
    match time_temp_r {
        Some(r)
            if both && matches!(c.regressor.as_str(), "time" | "temperature") && r.abs() > 0.5 =>
        {
            s.push_str(&format!(
                " (window time and temperature correlate, r = {r:.2}, so either may be the cause)."
            ));
        }
        _ => s.push('.'),
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(f: impl Fn(f64, [f64; 3]) -> f64) -> Vec<WindowPoint> {
        (0..30)
            .map(|i| {
                let (th, ph) = (i as f64 * 2.4, (i as f64 * 0.37).sin() * 1.2);
                let g = [ph.cos() * th.cos(), ph.cos() * th.sin(), ph.sin()];
                let t = i as f64 * 60.0;
                // A deterministic wiggle standing in for noise.
                let e = ((i * 7919) % 13) as f64 / 13.0 - 0.5;
                let [x, y, z] = g;
                WindowPoint {
                    residual_mg: f(t, g) + 0.1 * e,
                    t_s: t,
                    temp_c: None,
                    g,
                    // What a 9-parameter model spans: linear (bias) and quadratic (matrix).
                    span: vec![x, y, z, x * x, y * y, z * z, x * y, x * z, y * z],
                }
            })
            .collect()
    }

    /// A residual of 0.5 mg per minute is named as time, with the slope in mg/min.
    #[test]
    fn a_drift_is_named_with_its_slope() {
        let c = residual_correlates(&points(|t, _| 0.5 * t / 60.0), 1e-3);
        assert_eq!(c[0].regressor, "time");
        assert!(c[0].significant && c[0].r > 0.99);
        assert!((c[0].slope - 0.5).abs() < 0.01, "{}", c[0].slope);
        // No temperature column, and g_x, g_y, g_z lie in the span: 11 regressors.
        assert_eq!(c.len(), 11, "{c:?}");
    }

    /// A cubic on y is named as g_y^3.
    #[test]
    fn a_cubic_is_named_with_its_axis() {
        let c = residual_correlates(&points(|_, g| 3.0 * g[1].powi(3)), 1e-3);
        assert_eq!(c[0].regressor, "g_y^3");
        assert!(c[0].significant);
    }

    /// Noise alone: nothing is significant.
    #[test]
    fn noise_alone_is_not_significant() {
        let c = residual_correlates(&points(|_, _| 0.0), 1e-3);
        assert!(c.iter().all(|x| !x.significant), "{c:?}");
        let s = sentence(&c, None).unwrap();
        assert!(s.contains("not significant"), "{s}");
    }
}
