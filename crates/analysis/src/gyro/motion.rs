//! The motions as the motion candidates see them, and their least-squares fit.
//!
//! Three effects show only while the sensor turns, so the static windows cannot test them:
//!
//! | name | correction added to the calibrated rate `ω` (rad/s, per axis `i`) | unit reported |
//! |---|---|---|
//! | `scale-asymmetry` | `a_i·|ω_i|`: positive rates × (1 + a_i), negative × (1 − a_i) | % |
//! | `scale-nonlinearity` | `c_i·ω_i·(ω_i/ω_ref)²`, `ω_ref` = 100 °/s: the scale at ±100 °/s × (1 + c_i) | % at 100 °/s |
//! | `time-offset` | the gyro read `τ` later: `ω(t)` replaced by `ω(t + τ)` (linear interpolation) | s |
//!
//! The nonlinearity is the cubic `ω³` rather than `|ω|·ω`: a sensor's response to the sign of
//! the rate is the asymmetry's (`|ω|`, even), so the nonlinearity is taken odd like the scale
//! itself, and the smooth odd term after the linear one is the cubic (`|ω|·ω` has no second
//! derivative at rest). It is also the less collinear with the scale: over rates spread evenly
//! in ±ω_max the correlation of `ω` with `ω³` is 0.92, with `|ω|·ω` 0.97.
//! A positive `τ` means the gyro's samples lag the accelerometer's (the gyro reads at `t` what
//! happened at `t − τ`).
//!
//! Each motion's residual is the core's (`ĝ₁ − g₁`, unit vectors) projected on two directions
//! across `g₁` (the third component is zero to first order), divided by the motion's floor per
//! axis, so the residual sum of squares is a χ² against the noise floor. A model is the chosen
//! calibration's free parameters (the core's `P`, `δ` under its mask, sensitivities from the
//! core's integrator) plus the effects' coefficients (central differences: every effect is
//! smooth in its coefficient), fitted by Gauss–Newton from the chosen calibration. Held-out
//! residuals are the leave-one-motion-out ones of the last linearisation
//! (`(I − H_ii)⁻¹ e_i` on each motion's 2×2 block), as the one-step held-out errors of the
//! model choice.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2, Vector3};
use wiical_core::gyro::{Adjustment, GyroCalibration, MotionIntegrator, NPARAM};

/// Reference rate of the nonlinearity term, rad/s (100 °/s).
pub const RATE_REF: f64 = 100.0 * std::f64::consts::PI / 180.0;

/// Gauss–Newton iterations at most per fit (the effects are nearly linear: two suffice).
const MAX_GN: usize = 4;

/// A motion candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Per-axis scale for positive vs negative rates.
    Asymmetry,
    /// Per-axis cubic term in the rate.
    Nonlinearity,
    /// One accelerometer ↔ gyro time offset.
    TimeOffset,
    /// A generic term of the open basis (`motion_basis`): one coefficient on one
    /// gyro axis.
    Rate(RateTerm),
}

/// A generic rate term of the motions' open basis, added to the calibrated rate of gyro axis
/// `axis` times its coefficient `c` (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RateTerm {
    /// Gyro axis corrected (0, 1, 2).
    pub axis: u8,
    /// What multiplies the coefficient.
    pub form: RateForm,
}

/// The regressor of a [`RateTerm`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateForm {
    /// `ω_i·ω_j / ω_ref` (`ω_ref` = 100 °/s): a product of rates; the coefficient is the error
    /// at `ω_i = ω_j` = 100 °/s as a fraction of 100 °/s.
    Product(u8, u8),
    /// `|ω_j|`, `j` another axis: a rate on one axis read on another depending on its sign.
    Abs(u8),
}

impl RateTerm {
    /// The regressor at calibrated rate `w`, rad/s.
    fn regressor(self, w: &Vector3<f64>) -> f64 {
        match self.form {
            RateForm::Product(i, j) => w[i as usize] * w[j as usize] / RATE_REF,
            RateForm::Abs(j) => w[j as usize].abs(),
        }
    }

    /// The form in words, `ω_x·ω_z` or `|ω_y|`.
    pub fn form_name(self) -> String {
        const AX: [&str; 3] = ["x", "y", "z"];
        match self.form {
            RateForm::Product(i, j) => format!("ω_{}·ω_{}", AX[i as usize], AX[j as usize]),
            RateForm::Abs(j) => format!("|ω_{}|", AX[j as usize]),
        }
    }

    /// Its family in the report.
    pub fn family(self) -> &'static str {
        match self.form {
            RateForm::Product(..) => "rate-product",
            RateForm::Abs(_) => "cross-axis-asymmetry",
        }
    }
}

impl Kind {
    /// Every motion candidate, in the order tried.
    pub const ALL: [Kind; 3] = [Kind::Asymmetry, Kind::Nonlinearity, Kind::TimeOffset];

    /// Its name in the report.
    pub fn name(self) -> String {
        match self {
            Kind::Asymmetry => "scale-asymmetry".into(),
            Kind::Nonlinearity => "scale-nonlinearity".into(),
            Kind::TimeOffset => "time-offset".into(),
            Kind::Rate(t) => format!("{} on {}", t.form_name(), ["x", "y", "z"][t.axis as usize]),
        }
    }

    /// Unit of its reported coefficients.
    pub fn unit(self) -> &'static str {
        match self {
            Kind::Asymmetry => "%",
            Kind::Nonlinearity => "% at 100 °/s",
            Kind::TimeOffset => "s",
            Kind::Rate(RateTerm {
                form: RateForm::Product(..),
                ..
            }) => "% of 100 °/s at 100 °/s",
            Kind::Rate(_) => "%",
        }
    }

    /// Coefficients it adds.
    pub fn width(self) -> usize {
        match self {
            Kind::TimeOffset | Kind::Rate(_) => 1,
            _ => 3,
        }
    }

    /// Reported unit per internal unit (fractions are reported in %).
    pub fn to_unit(self) -> f64 {
        match self {
            Kind::TimeOffset => 1.0,
            _ => 100.0,
        }
    }

    /// What it looks for, for the evidence line.
    pub fn pattern(self) -> &'static str {
        match self {
            Kind::Asymmetry => "the motions' errors follow the rates' sign",
            Kind::Nonlinearity => "the motions' errors grow with the cube of the rate",
            Kind::TimeOffset => "the motions' errors follow the change of rate at their ends",
            Kind::Rate(_) => "the motions' errors follow a generic term of the rates",
        }
    }

    /// Central-difference step of one coefficient (internal units).
    fn step(self, dt: f64) -> f64 {
        match self {
            Kind::TimeOffset => 0.25 * dt,
            _ => 1e-3,
        }
    }
}

/// The motions with what their fit needs.
pub struct MotionSet {
    /// Calibrated rates (window effects removed) over each motion with a margin either side,
    /// rad/s.
    pub rates: Vec<Vec<Vector3<f64>>>,
    /// Index of each motion's first sample in its `rates`, and its sample count.
    pub span: Vec<(usize, usize)>,
    /// Gravity directions at each motion's start and end (sensor frame).
    pub gravity: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Each motion's floor per axis across gravity, rad.
    pub sigma: Vec<f64>,
    /// Sample period, s.
    pub dt: f64,
    /// The chosen calibration's free parameters (the core's order: `P` row-major, `δ`).
    pub mask: [bool; NPARAM],
}

/// A point of a model: the core's adjustment parameters and the effects' coefficients.
#[derive(Debug, Clone)]
pub struct Point {
    /// `P` row-major, then `δ` (identity: the chosen calibration).
    pub cal: [f64; NPARAM],
    /// The effects' coefficients, `kinds` in order, internal units.
    pub eff: Vec<f64>,
}

impl Point {
    /// The chosen calibration with every effect zero.
    pub fn start(kinds: &[Kind]) -> Self {
        let a = Adjustment::<f64>::identity().to_params();
        Self {
            cal: std::array::from_fn(|k| a[k]),
            eff: vec![0.0; kinds.iter().map(|k| k.width()).sum()],
        }
    }
}

/// Rate at fractional index `x` (clamped to the samples), linear between samples.
fn interp(r: &[Vector3<f64>], x: f64) -> Vector3<f64> {
    let last = r.len().saturating_sub(1);
    let x = x.clamp(0.0, last as f64);
    let i = (x.floor() as usize).min(last);
    let f = x - i as f64;
    let j = (i + 1).min(last);
    r[i] * (1.0 - f) + r[j] * f
}

/// The corrected rates of motion `i` under the effects `kinds` with coefficients `eff`.
fn corrected(set: &MotionSet, i: usize, kinds: &[Kind], eff: &[f64]) -> Vec<[f64; 3]> {
    let (s0, n) = set.span[i];
    let r = &set.rates[i];
    let (mut tau, mut asym, mut cube) = (0.0, [0.0; 3], [0.0; 3]);
    let mut generic: Vec<(RateTerm, f64)> = Vec::new();
    let mut at = 0;
    for k in kinds {
        match k {
            Kind::TimeOffset => tau = eff[at],
            Kind::Asymmetry => asym.copy_from_slice(&eff[at..at + 3]),
            Kind::Nonlinearity => cube.copy_from_slice(&eff[at..at + 3]),
            Kind::Rate(t) => generic.push((*t, eff[at])),
        }
        at += k.width();
    }
    let shift = tau / set.dt;
    (0..n)
        .map(|j| {
            let w = interp(r, (s0 + j) as f64 + shift);
            let mut out: [f64; 3] = std::array::from_fn(|a| {
                let x = w[a];
                x + asym[a] * x.abs() + cube[a] * x * (x / RATE_REF).powi(2)
            });
            for (t, c) in &generic {
                out[t.axis as usize] += c * t.regressor(&w);
            }
            out
        })
        .collect()
}

/// Two unit directions across `g`.
fn across(g: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let n = g.normalize();
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&helper).normalize();
    [u, n.cross(&u)]
}

/// One motion integrated: weighted residual (2), weighted Jacobian rows of the free
/// calibration parameters (2 × free), and the angle error, rad.
type Integrated = (Vector2<f64>, Vec<[f64; 2]>, f64);

fn integrate(
    set: &MotionSet,
    i: usize,
    p: &Point,
    kinds: &[Kind],
    jac: bool,
) -> Option<Integrated> {
    let id = GyroCalibration::nominal([0.0; 3], [1.0; 3]);
    let adj = Adjustment::from_params(&nalgebra::SVector::<f64, NPARAM>::from(p.cal));
    let tracked = if jac { set.mask } else { [false; NPARAM] };
    let mut integ = MotionIntegrator::new(id, adj, set.dt, tracked).ok()?;
    for w in corrected(set, i, kinds, &p.eff) {
        integ.push(&w).ok()?;
    }
    let (g0, g1) = &set.gravity[i];
    let out = integ.finish(g0, g1).ok()?;
    let [u, v] = across(g1);
    let s = set.sigma[i].max(1e-300);
    let r = Vector2::new(u.dot(&out.residual), v.dot(&out.residual)) / s;
    let cols = (0..NPARAM)
        .filter(|k| jac && set.mask[*k])
        .map(|k| {
            let c = out.jacobian.column(k);
            [u.dot(&c) / s, v.dot(&c) / s]
        })
        .collect();
    Some((r, cols, out.angle))
}

/// A linearisation of a model at a point: weighted residuals (2 per motion), the design
/// (free calibration parameters, then the effects' coefficients), the angles, rad.
struct Lin {
    r: DVector<f64>,
    x: DMatrix<f64>,
    angles: Vec<f64>,
}

fn linearize(set: &MotionSet, p: &Point, kinds: &[Kind]) -> Option<Lin> {
    let n = set.span.len();
    let free = set.mask.iter().filter(|m| **m).count();
    let ne = p.eff.len();
    let mut r = DVector::zeros(2 * n);
    let mut x = DMatrix::zeros(2 * n, free + ne);
    let mut angles = Vec::with_capacity(n);
    let steps: Vec<f64> = kinds
        .iter()
        .flat_map(|k| std::iter::repeat_n(k.step(set.dt), k.width()))
        .collect();
    for i in 0..n {
        let (ri, cols, angle) = integrate(set, i, p, kinds, true)?;
        angles.push(angle);
        r.rows_mut(2 * i, 2).copy_from(&ri);
        for (c, col) in cols.iter().enumerate() {
            x[(2 * i, c)] = col[0];
            x[(2 * i + 1, c)] = col[1];
        }
        for (e, h) in steps.iter().enumerate() {
            let moved = |sign: f64| {
                let mut q = p.clone();
                q.eff[e] += sign * h;
                integrate(set, i, &q, kinds, false).map(|o| o.0)
            };
            let d = (moved(1.0)? - moved(-1.0)?) / (2.0 * h);
            x[(2 * i, free + e)] = d[0];
            x[(2 * i + 1, free + e)] = d[1];
        }
    }
    Some(Lin { r, x, angles })
}

/// The weighted residuals' derivative (2 per motion) in the coefficient of `extra` added at
/// zero to the model `kinds` at `p` (central differences, as the effects' columns).
pub fn column(set: &MotionSet, p: &Point, kinds: &[Kind], extra: Kind) -> Option<DVector<f64>> {
    let mut all = kinds.to_vec();
    all.push(extra);
    let h = extra.step(set.dt);
    let n = set.span.len();
    let mut z = DVector::zeros(2 * n);
    for i in 0..n {
        let moved = |sign: f64| {
            let mut q = p.clone();
            q.eff.push(sign * h);
            integrate(set, i, &q, &all, false).map(|o| o.0)
        };
        let d = (moved(1.0)? - moved(-1.0)?) / (2.0 * h);
        z[2 * i] = d[0];
        z[2 * i + 1] = d[1];
    }
    Some(z)
}

/// A fitted model.
pub struct Fit {
    /// Where it ended.
    pub point: Point,
    /// Weighted residual sum of squares (a χ² against the floor).
    pub rss: f64,
    /// Residual degrees of freedom (2 per motion less the parameters).
    pub dof: usize,
    /// `(XᵀX)⁻¹` of the last linearisation (weighted: the coefficients' covariance in units
    /// of the reference variance).
    pub inv: DMatrix<f64>,
    /// In-sample angle error per motion, rad.
    pub angles: Vec<f64>,
    /// Held-out angle error per motion, rad.
    pub held: Vec<f64>,
    /// Free calibration parameters (the first columns of `inv`).
    pub free: usize,
    /// The last linearisation's weighted residuals at `point` (2 per motion).
    pub r: DVector<f64>,
    /// Its design (free calibration parameters, then the effects' coefficients).
    pub x: DMatrix<f64>,
}

/// Fits the free calibration parameters and the effects `kinds` from the chosen calibration.
pub fn fit(set: &MotionSet, kinds: &[Kind]) -> Option<Fit> {
    let mut p = Point::start(kinds);
    let free = set.mask.iter().filter(|m| **m).count();
    let idx: Vec<usize> = (0..NPARAM).filter(|k| set.mask[*k]).collect();
    let mut lin = linearize(set, &p, kinds)?;
    for _ in 0..MAX_GN {
        let (rows, cols) = lin.x.shape();
        if rows <= cols {
            return None;
        }
        let inv = (lin.x.transpose() * &lin.x).try_inverse()?;
        let beta = -(&inv * lin.x.transpose() * &lin.r);
        let mut q = p.clone();
        for (c, k) in idx.iter().enumerate() {
            q.cal[*k] += beta[c];
        }
        for e in 0..q.eff.len() {
            q.eff[e] += beta[free + e];
        }
        let next = linearize(set, &q, kinds)?;
        let (old, new) = (lin.r.norm_squared(), next.r.norm_squared());
        if new > old {
            break;
        }
        (p, lin) = (q, next);
        if old - new <= 1e-6 * old.max(1e-300) {
            break;
        }
    }
    finish(set, p, lin, free)
}

/// The fit's statistics at its last linearisation.
fn finish(set: &MotionSet, point: Point, lin: Lin, free: usize) -> Option<Fit> {
    let (rows, cols) = lin.x.shape();
    let inv = (lin.x.transpose() * &lin.x).try_inverse()?;
    // Residuals after the last (small) step, so the held-out ones are the fit's.
    let e = &lin.r - &lin.x * (&inv * lin.x.transpose() * &lin.r);
    let held = (0..set.span.len())
        .map(|i| {
            let xi = lin.x.rows(2 * i, 2);
            let h = xi * &inv * xi.transpose();
            let ih = Matrix2::identity() - Matrix2::from_fn(|r, c| h[(r, c)]);
            let ei = Vector2::new(e[2 * i], e[2 * i + 1]);
            let loo = ih.try_inverse().map_or(ei, |m| m * ei);
            loo.norm() * set.sigma[i]
        })
        .collect();
    Some(Fit {
        point,
        rss: e.norm_squared(),
        dof: rows - cols,
        inv,
        angles: lin.angles,
        held,
        free,
        r: lin.r,
        x: lin.x,
    })
}
