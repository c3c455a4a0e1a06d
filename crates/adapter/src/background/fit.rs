//! The background fit's mathematics: a correction of the live calibration fitted to the grid's
//! bins by Gauss–Newton, one bin at a time so that the work can be cut into slices.
//!
//! ## Model
//! Each bin is first corrected with the live calibration: `u = K_L(m − b_L − s_L(θ − θ₀))`
//! (g; `s_L` the live bias temperature slope, counts/°C, zero when it has none). The fit then
//! looks for a small correction of that output,
//!
//! ```text
//! a = M·(u − δ − σ·(θ − θ_c)),     M = I + E, E upper triangular
//! ```
//!
//! with `δ` a bias (g), `E` the scale (diagonal) and non-orthogonality (off-diagonal) terms
//! and `σ` a bias slope against temperature (g/°C) about the training bins' mean temperature
//! `θ_c`. Parameter order: `δ0 δ1 δ2 e00 e01 e02 e11 e12 e22 σ0 σ1 σ2`. Starting at zero is
//! starting at the live calibration, so a few iterations reach the minimum (the corrections
//! are small), and working in g rather than raw counts keeps `f32` well conditioned. The new
//! calibration is `K = M·K_L` (upper triangular when `K_L` is, the frame convention of the
//! multi-position fit), `b = b_L + K_L⁻¹(δ + σ(θ₀ − θ_c))`, `s = s_L + K_L⁻¹σ` at `θ₀`.
//!
//! ## Residual of a bin
//! `r = √(‖a(ū)‖² + tr(M·C_u·Mᵀ)) − 1` with `ū` the bin's corrected mean and `C_u = K_L·C·K_Lᵀ`
//! its covariance (see the grid's module docs: the exact mean of `‖a‖²` over the bin's
//! moments, so bins with spread directions are not biased short).
//!
//! The 12×12 Cholesky below is written out (20 lines) rather than taken from `nalgebra`, which
//! this crate does not depend on; the core's solver works on `nalgebra` types.

use wiical_core::{Calibration, Effects, Error};

use super::grid::Bin;

/// Number of parameters.
pub const NP: usize = 12;

/// Smallest Cholesky pivot, relative to its diagonal entry, of a determined fit (`f32`).
const REL_PIVOT: f32 = 1e-6;

/// Which parameters a fit frees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitModel {
    /// Bias and per-axis scale (6 parameters).
    BiasScale,
    /// Bias, scale and non-orthogonality (9 parameters).
    Full,
}

/// The free-parameter mask of a model, with or without the temperature slope.
pub fn mask(model: FitModel, temperature: bool) -> [bool; NP] {
    let full = model == FitModel::Full;
    [
        true,
        true,
        true,
        true,
        full,
        full,
        true,
        full,
        true,
        temperature,
        temperature,
        temperature,
    ]
}

/// The linear part of a live calibration with its bias temperature slope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveModel {
    /// `K_L`, g per count.
    pub k: [[f32; 3]; 3],
    /// `b_L`, counts at `θ₀`.
    pub bias: [f32; 3],
    /// `s_L`, counts/°C.
    pub slope: [f32; 3],
    /// `θ₀`, °C.
    pub temp_ref_c: f32,
}

impl LiveModel {
    /// The model of `cal`, or `None` when it has effect terms other than the bias temperature
    /// slope (a nonlinearity applied after `K` does not compose with a correction of `K`).
    pub fn of(cal: &Calibration) -> Option<Self> {
        let e = &cal.effects;
        let only_temp = Effects {
            bias_temp: e.bias_temp,
            temp_ref_c: e.temp_ref_c,
            ..Effects::default()
        };
        if *e != only_temp || cal.validate().is_err() {
            return None;
        }
        Some(Self {
            k: cal.matrix,
            bias: cal.bias,
            slope: e.bias_temp,
            temp_ref_c: e.temp_ref_c,
        })
    }

    /// True when the live calibration has a temperature slope.
    pub fn has_slope(&self) -> bool {
        self.slope.iter().any(|s| *s != 0.0)
    }
}

/// A bin as the fit sees it: corrected mean (g), covariance (g²), temperature offset (°C).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BinData {
    /// `ū`, g.
    pub u: [f32; 3],
    /// `C_u`, g².
    pub c: [[f32; 3]; 3],
    /// `θ − θ_c`, °C (0 without a temperature).
    pub dtheta: f32,
}

/// `A·B` for 3×3 matrices.
pub fn mul3(a: &[[f32; 3]; 3], b: &[[f32; 3]; 3]) -> [[f32; 3]; 3] {
    core::array::from_fn(|i| core::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// `A·v`.
pub fn mul3v(a: &[[f32; 3]; 3], v: &[f32; 3]) -> [f32; 3] {
    core::array::from_fn(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

/// A bin corrected with the live model; `theta_c` is the fit's temperature centre.
pub fn bin_data(bin: &Bin, live: &LiveModel, theta_c: f32) -> BinData {
    let t = bin.temperature_c;
    let shift = if live.has_slope() && t.is_finite() {
        t - live.temp_ref_c
    } else {
        0.0
    };
    let d: [f32; 3] = core::array::from_fn(|i| bin.mean[i] - live.bias[i] - live.slope[i] * shift);
    let u = mul3v(&live.k, &d);
    let kc = mul3(&live.k, &bin.cov_matrix());
    let c = core::array::from_fn(|i| {
        core::array::from_fn(|j| (0..3).map(|k| kc[i][k] * live.k[j][k]).sum())
    });
    BinData {
        u,
        c,
        dtheta: if t.is_finite() { t - theta_c } else { 0.0 },
    }
}

/// `M = I + E` from the parameters.
fn m_of(p: &[f32; NP]) -> [[f32; 3]; 3] {
    [
        [1.0 + p[3], p[4], p[5]],
        [0.0, 1.0 + p[6], p[7]],
        [0.0, 0.0, 1.0 + p[8]],
    ]
}

/// The bin's residual `r` (g) and, when `grad` is given, `∂r/∂p` written into it.
pub fn residual(p: &[f32; NP], d: &BinData, grad: Option<&mut [f32; NP]>) -> f32 {
    let m = m_of(p);
    let v: [f32; 3] = core::array::from_fn(|i| d.u[i] - p[i] - p[9 + i] * d.dtheta);
    let a = mul3v(&m, &v);
    let mc = mul3(&m, &d.c);
    let mut q = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    for i in 0..3 {
        for k in 0..3 {
            q += mc[i][k] * m[i][k];
        }
    }
    let root = libm::sqrtf(q.max(0.0));
    if let Some(g) = grad {
        let inv = if root > 0.0 { 1.0 / root } else { 0.0 };
        // ∂r/∂v = Mᵀa/√q, and v = u − δ − σ·Δθ.
        for k in 0..3 {
            let mta = m[0][k] * a[0] + m[1][k] * a[1] + m[2][k] * a[2];
            g[k] = -mta * inv;
            g[9 + k] = -mta * inv * d.dtheta;
        }
        // ∂r/∂M_ik = (a_i·v_k + (M·C)_ik)/√q for the upper-triangular entries.
        let dm = |i: usize, k: usize| (a[i] * v[k] + mc[i][k]) * inv;
        g[3] = dm(0, 0);
        g[4] = dm(0, 1);
        g[5] = dm(0, 2);
        g[6] = dm(1, 1);
        g[7] = dm(1, 2);
        g[8] = dm(2, 2);
    }
    root - 1.0
}

/// Normal equations `JᵀJ`, `Jᵀr` and the cost `Σr²`, accumulated a bin at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normal {
    jtj: [[f32; NP]; NP],
    jtr: [f32; NP],
    /// `Σ r²`, g².
    pub cost: f32,
    /// Bins added.
    pub n: u32,
}

impl Default for Normal {
    fn default() -> Self {
        Self {
            jtj: [[0.0; NP]; NP],
            jtr: [0.0; NP],
            cost: 0.0,
            n: 0,
        }
    }
}

impl Normal {
    /// Adds one bin's residual at `p` (the upper triangle of `JᵀJ` only).
    pub fn add(&mut self, p: &[f32; NP], d: &BinData) {
        let mut g = [0.0f32; NP];
        let r = residual(p, d, Some(&mut g));
        for i in 0..NP {
            for k in i..NP {
                self.jtj[i][k] += g[i] * g[k];
            }
            self.jtr[i] += g[i] * r;
        }
        self.cost += r * r;
        self.n += 1;
    }

    /// RMS residual, g.
    pub fn rms(&self) -> f32 {
        libm::sqrtf(self.cost / self.n.max(1) as f32)
    }

    /// The damped Gauss–Newton step `(JᵀJ + λ·diag JᵀJ)·Δ = −Jᵀr` over the free parameters
    /// (fixed ones get 0). [`Error::DegenerateGeometry`] when a free parameter is not
    /// determined by the bins (a Cholesky pivot below 10⁻⁶ of its diagonal).
    pub fn step(&self, mask: &[bool; NP], damping: f32) -> Result<[f32; NP], Error> {
        let mut a = [[0.0f32; NP]; NP];
        let mut b = [0.0f32; NP];
        for i in 0..NP {
            for k in i..NP {
                let v = if mask[i] && mask[k] {
                    self.jtj[i][k]
                } else {
                    0.0
                };
                a[i][k] = v;
                a[k][i] = v;
            }
            if mask[i] {
                a[i][i] *= 1.0 + damping;
                b[i] = -self.jtr[i];
            } else {
                a[i][i] = 1.0;
            }
        }
        let diag: [f32; NP] = core::array::from_fn(|i| a[i][i]);
        cholesky_in_place(&mut a, &diag)?;
        Ok(cholesky_solve(&a, b))
    }
}

/// Lower Cholesky factor of `a` in place; refuses non-finite or relatively tiny pivots.
fn cholesky_in_place(a: &mut [[f32; NP]; NP], diag: &[f32; NP]) -> Result<(), Error> {
    for j in 0..NP {
        let row_j = a[j];
        let mut s = row_j[j];
        for x in &row_j[..j] {
            s -= x * x;
        }
        if !(s.is_finite() && s > REL_PIVOT * diag[j]) {
            return Err(Error::DegenerateGeometry);
        }
        let l = libm::sqrtf(s);
        a[j][j] = l;
        for row_i in a.iter_mut().skip(j + 1) {
            let mut t = row_i[j];
            for (x, y) in row_i[..j].iter().zip(&row_j[..j]) {
                t -= x * y;
            }
            row_i[j] = t / l;
        }
    }
    Ok(())
}

/// Solves `L·Lᵀ·x = b` with the factor from [`cholesky_in_place`].
fn cholesky_solve(l: &[[f32; NP]; NP], mut b: [f32; NP]) -> [f32; NP] {
    for i in 0..NP {
        for k in 0..i {
            b[i] -= l[i][k] * b[k];
        }
        b[i] /= l[i][i];
    }
    for i in (0..NP).rev() {
        for k in i + 1..NP {
            b[i] -= l[k][i] * b[k];
        }
        b[i] /= l[i][i];
    }
    b
}

/// The calibration the parameters describe (see the module docs), `None` when `K_L` is
/// singular. `theta_c` is the temperature centre the slope was fitted about.
pub fn compose(live: &LiveModel, p: &[f32; NP], theta_c: f32) -> Option<Calibration> {
    let base = Calibration {
        bias: live.bias,
        matrix: live.k,
        effects: Effects::default(),
    };
    let d = base.forward_matrix().ok()?;
    let fwd = |v: [f32; 3]| -> [f32; 3] {
        core::array::from_fn(|i| d[(i, 0)] * v[0] + d[(i, 1)] * v[1] + d[(i, 2)] * v[2])
    };
    let sigma = [p[9], p[10], p[11]];
    let temperature = live.has_slope() || sigma.iter().any(|s| *s != 0.0);
    let theta0 = if live.has_slope() {
        live.temp_ref_c
    } else {
        theta_c
    };
    let shift: [f32; 3] = core::array::from_fn(|i| p[i] + sigma[i] * (theta0 - theta_c));
    let db = fwd(shift);
    let ds = fwd(sigma);
    let mut effects = Effects::default();
    if temperature {
        effects.temp_ref_c = theta0;
        effects.bias_temp = core::array::from_fn(|i| live.slope[i] + ds[i]);
    }
    let cal = Calibration {
        bias: core::array::from_fn(|i| live.bias[i] + db[i]),
        matrix: mul3(&m_of(p), &live.k),
        effects,
    };
    cal.validate().ok().map(|_| cal)
}
