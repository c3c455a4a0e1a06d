//! The linearised residual model of a magnetometer fit, and every candidate's columns, as
//! block-wise normal equations accumulated in one pass.
//!
//! **Residual.** For a sample `m` and the fit (centre `c`, soft iron `W`, radius `R`), with
//! `d = m − c`, `v = W·d`, `n̂ = v/‖v‖`: `r = ‖v‖ − R` (raw units). Its derivative with respect
//! to the centre is `−Wᵀn̂`, to the radius `−1`, and to a soft-iron perturbation `W(I + E)`
//! is `(Wᵀn̂)_j·d_k` for `E_jk`. A Gauss–Newton step from the core's fit on these columns is
//! the base model; a candidate adds its own columns, and every F-test and held-out error is
//! that of the joint linear least squares (valid where the effect is small against `R`, the
//! case the loop looks for).
//!
//! **Candidates.** An effect that moves the centre with a scalar `g` (time, a step in time,
//! temperature, a named column: ArduPilot COMPASS_MOT's `offset = k·current`) has columns
//! `g·Wᵀn̂` (three: `k` per axis, in raw units per unit of `g`). Shape beyond the ellipsoid
//! has the ten cubic monomials of `n̂`.
//!
//! **Blocks.** The recording is cut into [`BLOCKS`] consecutive spans of time; each keeps its
//! own `XᵀX`, `Xᵀy`, `yᵀy` over *all* columns, so that any sub-model's fit and its
//! leave-one-block-out error are small solves, never another pass over the samples.

use nalgebra::{DMatrix, DVector};

/// Consecutive time blocks for the held-out error: each is left out once. Ten: enough held
/// out fits for a stable RMS, blocks long enough (a tenth of the rotation) to hold a real
/// piece of the sphere.
pub const BLOCKS: usize = 10;

/// One sample's geometry under the fit.
#[derive(Debug, Clone, Copy)]
pub struct Geo {
    /// `‖W(m − c)‖ − R`, raw units.
    pub res: f64,
    /// `Wᵀn̂`: how the residual falls as the centre moves.
    pub grad: [f64; 3],
    /// `m − c`.
    pub d: [f64; 3],
    /// `n̂ = W(m − c)/‖W(m − c)‖`, the direction on the fitted sphere.
    pub u: [f64; 3],
}

/// The geometry of `m` under centre `c`, matrix `w`, radius `r`.
pub fn geo(m: &[f64; 3], c: &[f64; 3], w: &[[f64; 3]; 3], r: f64) -> Geo {
    let d: [f64; 3] = std::array::from_fn(|a| m[a] - c[a]);
    let v: [f64; 3] = std::array::from_fn(|i| (0..3).map(|k| w[i][k] * d[k]).sum());
    let rho = v
        .iter()
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
        .max(f64::MIN_POSITIVE);
    let u = v.map(|x| x / rho);
    let grad = std::array::from_fn(|k| (0..3).map(|i| w[i][k] * u[i]).sum());
    Geo {
        res: rho - r,
        grad,
        d,
        u,
    }
}

/// Which parameters of the soft iron the base model frees (the user's model's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// None (`W = I`).
    Sphere,
    /// The diagonal.
    Axis,
    /// The six of a symmetric matrix.
    Ellipsoid,
}

/// The base columns of one sample: centre (3), radius (1), soft iron at `det W = 1` (0, 2 or
/// 5): the model's own 4, 6 or 9 parameters.
pub fn base_row(g: &Geo, shape: Shape, out: &mut Vec<f64>) {
    out.extend(g.grad.map(|x| -x));
    out.push(-1.0);
    let pair = |j: usize, k: usize| g.grad[j] * g.d[k] + g.grad[k] * g.d[j];
    match shape {
        Shape::Sphere => {}
        Shape::Axis => out.extend(traceless(g)),
        Shape::Ellipsoid => {
            out.extend(traceless(g));
            out.extend([pair(0, 1), pair(0, 2), pair(1, 2)]);
        }
    }
}

/// The two traceless diagonal directions of `E`: `det W = 1` fixes the overall scale, and
/// a trace column would equal `‖W(m − c)‖` itself, with which (and the radius column) the
/// linear model could absorb the whole residual.
fn traceless(g: &Geo) -> [f64; 2] {
    let dg = |j: usize| g.grad[j] * g.d[j];
    [dg(0) - dg(2), dg(1) - dg(2)]
}

/// The centre-following columns `g·Wᵀn̂`: the residual a centre moving by `k·g` leaves under
/// the fixed fit (`m − c` grows by `k·g`), so the fitted coefficients are `k` itself.
pub fn follow_row(g: &Geo, x: f64, out: &mut Vec<f64>) {
    out.extend(g.grad.map(|v| x * v));
}

/// The ten cubic monomials of `n̂`: shape beyond the ellipsoid (odd, so not absorbed by the
/// quadratic soft iron; their first-degree part is absorbed by the centre).
pub fn shape_row(g: &Geo, out: &mut Vec<f64>) {
    let [x, y, z] = g.u;
    out.extend([
        x * x * x,
        y * y * y,
        z * z * z,
        x * x * y,
        x * x * z,
        y * y * x,
        y * y * z,
        z * z * x,
        z * z * y,
        x * y * z,
    ]);
}

/// Normal equations of one block over all columns.
#[derive(Debug, Clone)]
pub struct Normal {
    /// `XᵀX`.
    pub xtx: DMatrix<f64>,
    /// `Xᵀy`.
    pub xty: DVector<f64>,
    /// `yᵀy`.
    pub yty: f64,
    /// Samples.
    pub n: usize,
}

impl Normal {
    /// Empty, over `p` columns.
    pub fn zeros(p: usize) -> Self {
        Self {
            xtx: DMatrix::zeros(p, p),
            xty: DVector::zeros(p),
            yty: 0.0,
            n: 0,
        }
    }

    /// Adds one sample's row `x` with residual `y`.
    pub fn push(&mut self, x: &[f64], y: f64) {
        let p = x.len();
        for i in 0..p {
            self.xty[i] += x[i] * y;
            for j in i..p {
                self.xtx[(i, j)] += x[i] * x[j];
            }
        }
        self.yty += y * y;
        self.n += 1;
    }

    /// Fills the lower triangle from the upper one (after the last [`Normal::push`]).
    pub fn symmetrise(&mut self) {
        let p = self.xty.len();
        for i in 0..p {
            for j in 0..i {
                self.xtx[(i, j)] = self.xtx[(j, i)];
            }
        }
    }

    /// The sum of two blocks' equations; `sign` −1 subtracts.
    fn combine(&self, o: &Normal, sign: f64) -> Normal {
        Normal {
            xtx: &self.xtx + &o.xtx * sign,
            xty: &self.xty + &o.xty * sign,
            yty: self.yty + sign * o.yty,
            n: (self.n as i64 + sign as i64 * o.n as i64).max(0) as usize,
        }
    }

    /// The equations restricted to the columns `cols`.
    fn select(&self, cols: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
        let k = cols.len();
        let a = DMatrix::from_fn(k, k, |i, j| self.xtx[(cols[i], cols[j])]);
        let b = DVector::from_fn(k, |i, _| self.xty[cols[i]]);
        (a, b)
    }

    /// `‖y − Xβ‖²` over this block for the coefficients `beta` on `cols`.
    fn rss(&self, cols: &[usize], beta: &DVector<f64>) -> f64 {
        let (a, b) = self.select(cols);
        (self.yty - 2.0 * beta.dot(&b) + (a * beta).dot(beta)).max(0.0)
    }
}

/// A least-squares fit of the residual on some columns.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Coefficients, one per column.
    pub beta: DVector<f64>,
    /// Their standard errors under the reference variance (filled by the caller's scale).
    pub cov_unit: DMatrix<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// Independent columns (the rank: the ellipsoid's scale and the radius are one direction).
    pub rank: usize,
    /// Leave-one-block-out RMS, raw units (`None` when a block is empty).
    pub cv: Option<f64>,
}

/// Relative singular-value cut below which a direction of the (column-scaled) normal matrix
/// counts as absent: the radius and the soft iron's overall scale are the same direction.
const RANK_TOL: f64 = 1e-9;

/// Solves `a·β = b` by SVD with the columns scaled to a unit diagonal; the rank and the
/// pseudo-inverse (for standard errors) come with it.
fn solve(a: &DMatrix<f64>, b: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>, usize) {
    let k = b.len();
    let s = DVector::from_fn(k, |i, _| {
        let d = a[(i, i)];
        if d > 0.0 {
            1.0 / d.sqrt()
        } else {
            0.0
        }
    });
    let sa = DMatrix::from_fn(k, k, |i, j| a[(i, j)] * s[i] * s[j]);
    let sb = DVector::from_fn(k, |i, _| b[i] * s[i]);
    let svd = sa.svd(true, true);
    let eps = RANK_TOL * svd.singular_values.max().max(f64::MIN_POSITIVE);
    let rank = svd.rank(eps);
    let pinv = svd
        .pseudo_inverse(eps)
        .unwrap_or_else(|_| DMatrix::zeros(k, k));
    let beta_s = &pinv * sb;
    let beta = DVector::from_fn(k, |i, _| beta_s[i] * s[i]);
    let cov = DMatrix::from_fn(k, k, |i, j| pinv[(i, j)] * s[i] * s[j]);
    (beta, cov, rank)
}

/// The fit on `cols` over all blocks, and its leave-one-block-out RMS.
pub fn fit(blocks: &[Normal], total: &Normal, cols: &[usize]) -> Fit {
    let (a, b) = total.select(cols);
    let (beta, cov_unit, rank) = solve(&a, &b);
    let rss = total.rss(cols, &beta);
    let mut held = 0.0;
    let mut ok = total.n > 0;
    for blk in blocks {
        if blk.n == 0 {
            ok = false;
            continue;
        }
        let rest = total.combine(blk, -1.0);
        let (a, b) = rest.select(cols);
        let (bb, _, _) = solve(&a, &b);
        held += blk.rss(cols, &bb);
    }
    Fit {
        beta,
        cov_unit,
        rss,
        rank,
        cv: ok.then(|| (held / total.n as f64).sqrt()),
    }
}

/// The sum of the blocks' equations.
pub fn total(blocks: &[Normal]) -> Normal {
    let p = blocks.first().map_or(0, |b| b.xty.len());
    blocks
        .iter()
        .fold(Normal::zeros(p), |acc, b| acc.combine(b, 1.0))
}

/// The Schur complement of the columns `extra` against `base` in `total`'s `XᵀX`: the
/// information the data hold about the extra coefficients once the base is fitted
/// (`Δrss = βᵀ·S·β` for an effect `β` on those columns).
pub fn schur(total: &Normal, base: &[usize], extra: &[usize]) -> DMatrix<f64> {
    let sel = |r: &[usize], c: &[usize]| {
        DMatrix::from_fn(r.len(), c.len(), |i, j| total.xtx[(r[i], c[j])])
    };
    let abb = sel(base, base);
    let abe = sel(base, extra);
    let aee = sel(extra, extra);
    let k = base.len();
    let (_, pinv, _) = solve(&abb, &DVector::zeros(k));
    aee - abe.transpose() * pinv * abe
}
