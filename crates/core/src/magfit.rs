//! Magnetometer hard-/soft-iron fits from streaming sums (O(1) memory).
//!
//! Rotating a magnetometer in a constant field `h` makes its raw readings `m` lie on an
//! ellipsoid: `m = D·h + c` (soft iron and scale `D`, hard iron `c`). Three models of
//! increasing generality are fitted here, after the seed *AHRS Sensor Calibration*:
//!
//! | accumulator | surface | free parameters | soft-iron matrix `W` |
//! |---|---|---|---|
//! | [`SphereFit`] | `‖m − c‖ = R` | 4 | identity |
//! | [`AxisEllipsoidFit`] | axis-aligned ellipsoid | 6 | diagonal |
//! | [`EllipsoidFit`] | rotated ellipsoid | 9 | full symmetric |
//!
//! Every result is a [`MagFit`]: centre `c`, symmetric `W` with `det W = 1` and radius `R`
//! (raw units) such that `‖W·(m − c)‖ ≈ R` for every sample (MATLAB `magcal`'s convention:
//! `R` is the geometric mean of the semi-axes, i.e. the field strength in raw units).
//!
//! ## The algebraic fit and its normalisation
//! All three fit the quadric `Q(m) = mᵀA m + 2bᵀm + c₀ = 0` by linear least squares on the
//! algebraic residual, `min Σ Q(m_k)²`, under the **trace constraint `tr A = 3`** (Yury
//! Petrov's `ellipsoid_fit` parametrisation, which is the classic Kåsa fit for the sphere).
//! With `A` restricted to diagonal (axis) or to `I` (sphere) this leaves 6 and 4 unknowns,
//! and 9 for the full ellipsoid. Concretely the least-squares problem is
//! `x² + y² + z² ≈ Σ θ_i ψ_i(m)` with the regressors
//! `ψ = [x²+y²−2z², x²−2y²+z², 2xy, 2xz, 2yz, 2x, 2y, 2z, 1]` (the sphere uses the last
//! four, the axis-aligned fit the first two and the last four), so `A = I − (quadratic part
//! of Σθψ)` always has trace 3.
//!
//! Why not the seed's normalisation `ax²+by²+cz²+dx+ey+fz = 1` (constant term fixed)? It
//! ties the fitting criterion to where the coordinate origin is: translating the data
//! changes the answer, a quadric through the origin cannot be represented, and in raw
//! coordinates far from the origin (hard iron of thousands of counts) the regressors `x²`
//! and `x` are nearly collinear, which costs several digits in `f32`. The trace is
//! invariant under translation, rotation and (after the `s²` rescaling of `Q`) uniform
//! scaling of the coordinates, so the fit can be *computed* in centred, scaled coordinates
//! and yields the *same* ellipsoid as in raw coordinates; only rounding differs. It also
//! cannot collapse to the trivial solution, and a sphere is the special case `A = I`.
//! The family of surfaces (sphere / axis-aligned / rotated) is exactly the seed's.
//!
//! ## Streaming sums in centred, scaled coordinates
//! Every entry of the normal equations `ΨᵀΨ·θ = Ψᵀd` is a linear combination of the 35
//! power sums `S_abc = Σ uᵃ vᵇ wᶜ` (`a+b+c ≤ 4`) of the sample coordinates, so an
//! accumulator stores just those (plus the sample count) and the normal matrix is built in
//! [`solve`](EllipsoidFit::solve); memory is constant whatever the number of samples.
//! To keep those sums meaningful in `f32` with raw counts in the thousands:
//!
//! * **Coordinates** are `u = (m − o)·2⁻ᵉ`: an origin `o` (raw units) and a power-of-two
//!   scale. `o` starts at the first sample; `e` is chosen from the first non-zero deviation
//!   so that `|u| < 1` and grows whenever a sample would give `|u|∞ ≥ 2`. Changing `e` by `k`
//!   multiplies each `S_abc` by `2^(−k(a+b+c))`, which is exact in binary floating point.
//! * **Re-centring**: whenever the running mean of `u` (available exactly as `S_100/n`, …) is
//!   farther from the origin than a quarter of the RMS spread of the samples, the origin is
//!   moved to the mean and the sums are re-expressed about it by binomial expansion. The mean
//!   always lies inside the convex hull of the samples, hence inside the ellipsoid and
//!   usually close to its centre, so the quadratic and linear regressors stay far from
//!   collinear (the normal matrix is well conditioned). The rounding of a shift is relative to
//!   the sums of the samples seen *so far*, which keep being dominated by later samples.
//! * **Compensated summation**: each `S_abc` is a Neumaier (improved Kahan) pair, so summing
//!   tens of thousands of terms adds only `O(ε)` relative error instead of `O(n·ε)`.
//!
//! The normal equations are solved by Cholesky with equilibration and a relative pivot
//! threshold ([`crate::linalg::solve_spd`]); the quadric is then converted to centre,
//! `W = √A / det(A)^{1/6}` (symmetric square root via [`crate::linalg::sym3_eigen`]) and `R`,
//! and mapped back to raw units: `centre = o + 2ᵉ·u_c`, `R = 2ᵉ·R_u`.
//!
//! On the QMC5883L recording of `/work/shared/data/qmc5883l_mag_tomisuarez` (22 743 samples,
//! centre ≈ (6135, 249, 3443) counts) the `f32` centre, `W` and `R` agree with an `f64`
//! least-squares solution in raw coordinates to ~1e-6 relative (see `tests/magfit.rs`).
//!
//! ## Fit quality
//! [`MagFit::quality`] (or the streaming [`ResidualAccumulator`], a second pass over the
//! samples) reports MATLAB `magcal`'s fit error `100·√(mean((‖W(m−c)‖² − R²)²)) / (2R²)` in
//! percent and the RMS radius error `√mean((‖W(m−c)‖ − R)²)` in raw units.
//!
//! ## Errors
//! * [`Error::NonFinite`]: a NaN/inf sample (the accumulator is left unchanged), or a result
//!   that overflowed;
//! * [`Error::TooFewSamples`]: fewer samples than free parameters (4, 6, 9);
//! * [`Error::DegenerateGeometry`]: the samples do not determine the surface (all on one
//!   point, a line, a plane, …): the normal matrix is singular for `f32`;
//! * [`Error::NotAnEllipsoid`]: the best quadric is a hyperboloid, paraboloid, an imaginary
//!   ellipsoid, or has an eigenvalue ratio above 10⁶ (semi-axis ratio above 1000);
//! * [`Error::CapacityExceeded`]: more than `u32::MAX` samples.

use nalgebra::{SMatrix, SVector};

use crate::linalg::{solve_spd, sym3_eigen};
use crate::{Calibration, Error, Mat3, Vec3};

/// Number of monomials `uᵃvᵇwᶜ` with `a+b+c ≤ 4`.
const N_MONO: usize = 35;

/// Exponents of the monomials, in a fixed order.
const MONO: [[u8; 3]; N_MONO] = build_mono();

/// `MONO_IDX[a][b][c]` = index into [`MONO`] (only meaningful for `a+b+c ≤ 4`).
const MONO_IDX: [[[u8; 5]; 5]; 5] = build_mono_idx();

const fn build_mono() -> [[u8; 3]; N_MONO] {
    let mut out = [[0u8; 3]; N_MONO];
    let mut k = 0;
    let mut a = 0;
    while a <= 4 {
        let mut b = 0;
        while a + b <= 4 {
            let mut c = 0;
            while a + b + c <= 4 {
                out[k] = [a as u8, b as u8, c as u8];
                k += 1;
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
}

const fn build_mono_idx() -> [[[u8; 5]; 5]; 5] {
    let mono = build_mono();
    let mut out = [[[u8::MAX; 5]; 5]; 5];
    let mut k = 0;
    while k < N_MONO {
        let [a, b, c] = mono[k];
        out[a as usize][b as usize][c as usize] = k as u8;
        k += 1;
    }
    out
}

/// Exponents of the quadric basis `[x², y², z², xy, xz, yz, x, y, z, 1]`.
const QUAD: [[u8; 3]; 10] = [
    [2, 0, 0],
    [0, 2, 0],
    [0, 0, 2],
    [1, 1, 0],
    [1, 0, 1],
    [0, 1, 1],
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
    [0, 0, 0],
];

/// The nine regressors `ψ` as coefficient vectors over the quadric basis.
const PSI: [[f32; 10]; 9] = [
    [1.0, 1.0, -2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], // x²+y²−2z²
    [1.0, -2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], // x²−2y²+z²
    [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],  // 2xy
    [0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0],  // 2xz
    [0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0],  // 2yz
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0],  // 2x
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0],  // 2y
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0],  // 2z
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],  // 1
];

/// The least-squares target `x² + y² + z²` over the quadric basis.
const TARGET: [f32; 10] = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

const SPHERE_PSI: [usize; 4] = [5, 6, 7, 8];
const AXIS_PSI: [usize; 6] = [0, 1, 5, 6, 7, 8];
const ELLIPSOID_PSI: [usize; 9] = [0, 1, 2, 3, 4, 5, 6, 7, 8];

/// Binomial coefficients `C(n, k)` for `n ≤ 4`.
const BINOM: [[f32; 5]; 5] = [
    [1.0, 0.0, 0.0, 0.0, 0.0],
    [1.0, 1.0, 0.0, 0.0, 0.0],
    [1.0, 2.0, 1.0, 0.0, 0.0],
    [1.0, 3.0, 3.0, 1.0, 0.0],
    [1.0, 4.0, 6.0, 4.0, 1.0],
];

/// Smallest ratio `λ_min/λ_max` of the quadratic form accepted as an ellipsoid
/// (semi-axis ratio ≤ 1000; anything flatter is not a plausible magnetometer ellipsoid and
/// is numerically a cylinder in `f32`).
const MIN_EIGEN_RATIO: f32 = 1e-6;

/// Neumaier-compensated addition of `x` to the pair `(hi, lo)`; the sum is `hi + lo`.
#[inline]
fn neumaier_add(hi: &mut f32, lo: &mut f32, x: f32) {
    let t = *hi + x;
    if libm::fabsf(*hi) >= libm::fabsf(x) {
        *lo += (*hi - t) + x;
    } else {
        *lo += (x - t) + *hi;
    }
    *hi = t;
}

/// The 35 compensated power sums in coordinates `u = (m − origin)·2^(−exp)`.
#[derive(Debug, Clone, PartialEq)]
struct Moments {
    n: u32,
    origin: [f32; 3],
    /// `u = (m − origin)·2^(−exp)`.
    exp: i32,
    /// False until a sample different from `origin` fixed `exp`.
    scaled: bool,
    hi: [f32; N_MONO],
    lo: [f32; N_MONO],
}

impl Moments {
    const fn new() -> Self {
        Self {
            n: 0,
            origin: [0.0; 3],
            exp: 0,
            scaled: false,
            hi: [0.0; N_MONO],
            lo: [0.0; N_MONO],
        }
    }

    fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        if !crate::all_finite(&m) {
            return Err(Error::NonFinite);
        }
        if self.n == u32::MAX {
            return Err(Error::CapacityExceeded);
        }
        // Everything is checked before the first mutation, so an error leaves `self` as it was.
        let origin = if self.n == 0 { m } else { self.origin };
        let d = [m[0] - origin[0], m[1] - origin[1], m[2] - origin[2]];
        if !crate::all_finite(&d) {
            // Finite inputs whose difference overflows f32 (|m − o| > 3.4e38).
            return Err(Error::NonFinite);
        }
        let dmax = libm::fabsf(d[0])
            .max(libm::fabsf(d[1]))
            .max(libm::fabsf(d[2]));

        self.origin = origin;
        if dmax > 0.0 {
            // dmax = mant·2^e with mant in [0.5, 1): dmax·2^(−e) < 1.
            let (_, e) = libm::frexpf(dmax);
            if !self.scaled {
                // Only copies of `origin` (u = 0) were summed so far: no sum depends on exp.
                self.exp = e;
                self.scaled = true;
            } else if e > self.exp.saturating_add(1) {
                self.rescale(e - self.exp);
                self.exp = e;
            }
        }
        let u = [
            libm::ldexpf(d[0], -self.exp),
            libm::ldexpf(d[1], -self.exp),
            libm::ldexpf(d[2], -self.exp),
        ];
        self.add_sample(u);
        self.n += 1;
        self.maybe_recentre();
        Ok(())
    }

    fn add_sample(&mut self, u: [f32; 3]) {
        let pw = |x: f32| [1.0, x, x * x, x * x * x, (x * x) * (x * x)];
        let (px, py, pz) = (pw(u[0]), pw(u[1]), pw(u[2]));
        for (k, [a, b, c]) in MONO.iter().enumerate() {
            let t = px[*a as usize] * py[*b as usize] * pz[*c as usize];
            neumaier_add(&mut self.hi[k], &mut self.lo[k], t);
        }
    }

    /// Coordinates get `k` more halvings: `S_abc ← S_abc·2^(−k(a+b+c))` (exact).
    fn rescale(&mut self, k: i32) {
        for (idx, [a, b, c]) in MONO.iter().enumerate() {
            let deg = i32::from(*a + *b + *c);
            let sh = k.saturating_mul(deg).saturating_neg();
            self.hi[idx] = libm::ldexpf(self.hi[idx], sh);
            self.lo[idx] = libm::ldexpf(self.lo[idx], sh);
        }
    }

    /// The compensated sums folded to single values.
    fn sums(&self) -> [f32; N_MONO] {
        let mut s = [0.0; N_MONO];
        for (k, v) in s.iter_mut().enumerate() {
            *v = self.hi[k] + self.lo[k];
        }
        s
    }

    fn at(s: &[f32; N_MONO], a: u8, b: u8, c: u8) -> f32 {
        s[MONO_IDX[a as usize][b as usize][c as usize] as usize]
    }

    /// Moves the origin to the running mean when it is off by more than a quarter of the RMS
    /// spread (see the module docs).
    fn maybe_recentre(&mut self) {
        if self.n < 2 || !self.scaled {
            return;
        }
        let s = self.sums();
        let n = self.n as f32;
        let mean = [
            Self::at(&s, 1, 0, 0) / n,
            Self::at(&s, 0, 1, 0) / n,
            Self::at(&s, 0, 0, 1) / n,
        ];
        let mean2 = mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2];
        let second = (Self::at(&s, 2, 0, 0) + Self::at(&s, 0, 2, 0) + Self::at(&s, 0, 0, 2)) / n;
        let spread2 = second - mean2;
        // Also skips NaN (comparisons with NaN are false).
        let off_centre = mean2.is_finite() && mean2 > 0.0 && 16.0 * mean2 > spread2;
        if !off_centre {
            return;
        }
        // New origin in raw units, then the shift actually applied, recomputed from the
        // rounded new origin so that old and new samples use the same coordinates.
        let mut t = [0.0f32; 3];
        let mut new_origin = self.origin;
        for i in 0..3 {
            new_origin[i] = self.origin[i] + libm::ldexpf(mean[i], self.exp);
            t[i] = libm::ldexpf(new_origin[i] - self.origin[i], -self.exp);
        }
        if !crate::all_finite(&new_origin) || !crate::all_finite(&t) {
            return;
        }
        self.shift(s, t);
        self.origin = new_origin;
    }

    /// Re-expresses the sums about `u' = u − t` by binomial expansion.
    fn shift(&mut self, s: [f32; N_MONO], t: [f32; 3]) {
        let pw = |x: f32| [1.0, x, x * x, x * x * x, (x * x) * (x * x)];
        let (px, py, pz) = (pw(-t[0]), pw(-t[1]), pw(-t[2]));
        for (idx, [a, b, c]) in MONO.iter().enumerate() {
            let (a, b, c) = (*a as usize, *b as usize, *c as usize);
            let mut acc = 0.0f32;
            for i in 0..=a {
                let fx = BINOM[a][i] * px[a - i];
                for j in 0..=b {
                    let fy = fx * BINOM[b][j] * py[b - j];
                    for k in 0..=c {
                        let fz = fy * BINOM[c][k] * pz[c - k];
                        acc += fz * s[MONO_IDX[i][j][k] as usize];
                    }
                }
            }
            self.hi[idx] = acc;
            self.lo[idx] = 0.0;
        }
    }

    /// Least-squares fit with the regressors `PSI[which[..]]`.
    fn solve<const N: usize>(&self, which: &[usize; N]) -> Result<MagFit, Error> {
        if (self.n as usize) < N {
            return Err(Error::TooFewSamples {
                needed: N as u32,
                got: self.n,
            });
        }
        let s = self.sums();
        if !crate::all_finite(&s) {
            return Err(Error::NonFinite);
        }
        // H_pq = Σ q_p(u)·q_q(u) over the quadric basis (10×10, moments of degree ≤ 4).
        let mut h = [[0.0f32; 10]; 10];
        for (p, ep) in QUAD.iter().enumerate() {
            for (q, eq) in QUAD.iter().enumerate() {
                h[p][q] = Self::at(&s, ep[0] + eq[0], ep[1] + eq[1], ep[2] + eq[2]);
            }
        }
        let hv = |x: &[f32; 10], y: &[f32; 10]| -> f32 {
            let mut acc = 0.0f32;
            for (&xp, hp) in x.iter().zip(&h) {
                if xp == 0.0 {
                    continue;
                }
                for (&yq, &hpq) in y.iter().zip(hp) {
                    if yq != 0.0 {
                        acc += xp * yq * hpq;
                    }
                }
            }
            acc
        };
        let mut g = SMatrix::<f32, N, N>::zeros();
        let mut rhs = SVector::<f32, N>::zeros();
        for (i, &wi) in which.iter().enumerate() {
            for (j, &wj) in which.iter().enumerate() {
                g[(i, j)] = hv(&PSI[wi], &PSI[wj]);
            }
            rhs[i] = hv(&PSI[wi], &TARGET);
        }
        let theta = solve_spd(&g, &rhs).map_err(|e| match e {
            Error::Singular => Error::DegenerateGeometry,
            other => other,
        })?;

        // Quadric Q = target − Σ θ_i ψ_i over the quadric basis.
        let mut qc = TARGET;
        for (i, &wi) in which.iter().enumerate() {
            for (p, c) in qc.iter_mut().enumerate() {
                *c -= theta[i] * PSI[wi][p];
            }
        }
        let a = Mat3::new(
            qc[0],
            0.5 * qc[3],
            0.5 * qc[4],
            0.5 * qc[3],
            qc[1],
            0.5 * qc[5],
            0.5 * qc[4],
            0.5 * qc[5],
            qc[2],
        );
        let b = Vec3::new(0.5 * qc[6], 0.5 * qc[7], 0.5 * qc[8]);
        let c0 = qc[9];
        quadric_to_fit(&a, &b, c0, self.origin, self.exp)
    }
}

/// Converts `uᵀAu + 2bᵀu + c₀ = 0` in coordinates `u = (m − origin)·2^(−exp)` into a
/// [`MagFit`] in raw units.
fn quadric_to_fit(
    a: &Mat3,
    b: &Vec3,
    c0: f32,
    origin: [f32; 3],
    exp: i32,
) -> Result<MagFit, Error> {
    let (vals, vecs) = sym3_eigen(a)?;
    let lmax = vals[2];
    let definite = lmax > 0.0 && vals[0] > MIN_EIGEN_RATIO * lmax;
    if !definite {
        return Err(Error::NotAnEllipsoid);
    }
    // Centre u_c = −A⁻¹b through the eigen-decomposition (A is SPD here).
    let vtb = vecs.transpose() * b;
    let uc = -(vecs * Vec3::new(vtb[0] / vals[0], vtb[1] / vals[1], vtb[2] / vals[2]));
    // Q(u) = (u − u_c)ᵀA(u − u_c) − k with k = −(bᵀu_c + c₀).
    let k = -(b.dot(&uc) + c0);
    if k.is_nan() || k <= 0.0 {
        return Err(Error::NotAnEllipsoid);
    }
    // W = √A / det(A)^{1/6}: symmetric, det W = 1.
    let g6 = libm::cbrtf(libm::sqrtf(vals[0] * vals[1] * vals[2]));
    let roots = Vec3::new(
        libm::sqrtf(vals[0]) / g6,
        libm::sqrtf(vals[1]) / g6,
        libm::sqrtf(vals[2]) / g6,
    );
    let w = vecs * Mat3::from_diagonal(&roots) * vecs.transpose();
    let w = (w + w.transpose()) * 0.5;
    // ‖W(u − u_c)‖² = k / g6² on the surface; raw units multiply lengths by 2^exp.
    let radius = libm::ldexpf(libm::sqrtf(k) / g6, exp);
    let center = [
        origin[0] + libm::ldexpf(uc[0], exp),
        origin[1] + libm::ldexpf(uc[1], exp),
        origin[2] + libm::ldexpf(uc[2], exp),
    ];
    let fit = MagFit {
        center,
        matrix: crate::model::mat3_to_rows(&w),
        radius,
    };
    if !crate::all_finite(&fit.center)
        || !fit.matrix.iter().all(|r| crate::all_finite(r))
        || !fit.radius.is_finite()
        || fit.radius <= 0.0
    {
        return Err(Error::NonFinite);
    }
    Ok(fit)
}

/// Result of a magnetometer fit, in raw sensor units.
///
/// Convention (MATLAB `magcal`): `‖W·(m − center)‖ ≈ radius` for every sample `m`, with
/// `W = matrix` symmetric positive definite and `det W = 1`. Hence `radius` is the
/// geometric mean of the ellipsoid's semi-axes, i.e. the local field strength expressed in
/// raw units, and `W` alone corrects the *shape* (soft iron) without changing the scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagFit {
    /// Hard-iron offset: centre of the ellipsoid, raw units.
    pub center: [f32; 3],
    /// Soft-iron matrix `W` (row-major, symmetric, `det W = 1`): identity for a sphere fit,
    /// diagonal for an axis-aligned fit.
    pub matrix: [[f32; 3]; 3],
    /// Field strength `R` in raw units (geometric mean of the semi-axes).
    pub radius: f32,
}

impl MagFit {
    /// `W·(m − center)`: the corrected field in raw units (magnitude ≈ `radius`).
    pub fn apply(&self, m: [f32; 3]) -> [f32; 3] {
        let d = [
            m[0] - self.center[0],
            m[1] - self.center[1],
            m[2] - self.center[2],
        ];
        let w = &self.matrix;
        [
            w[0][0] * d[0] + w[0][1] * d[1] + w[0][2] * d[2],
            w[1][0] * d[0] + w[1][1] * d[1] + w[1][2] * d[2],
            w[2][0] * d[0] + w[2][1] * d[1] + w[2][2] * d[2],
        ]
    }

    /// The calibration `a = K·(m − b)` with `b = center` and `K = W / radius`, so that the
    /// corrected field has unit magnitude (units of the local field strength).
    ///
    /// Meaningful for a fit returned by `solve` (radius > 0); use
    /// [`Calibration::validate`] on hand-made values.
    pub fn to_calibration(&self) -> Calibration {
        let inv_r = 1.0 / self.radius;
        let mut k = self.matrix;
        for row in k.iter_mut() {
            for v in row.iter_mut() {
                *v *= inv_r;
            }
        }
        let mut cal = Calibration::identity();
        cal.bias = self.center;
        cal.matrix = k;
        cal
    }

    /// Semi-axes of the fitted ellipsoid in raw units, ascending (`radius / σ_i(W)`).
    pub fn semi_axes(&self) -> Result<[f32; 3], Error> {
        let (vals, _) = sym3_eigen(&crate::model::rows_to_mat3(&self.matrix))?;
        if vals[0].is_nan() || vals[0] <= 0.0 {
            return Err(Error::NotAnEllipsoid);
        }
        Ok([
            self.radius / vals[2],
            self.radius / vals[1],
            self.radius / vals[0],
        ])
    }

    /// Fit quality over `samples` (a second pass): see [`FitQuality`].
    pub fn quality<I: IntoIterator<Item = [f32; 3]>>(
        &self,
        samples: I,
    ) -> Result<FitQuality, Error> {
        let mut acc = ResidualAccumulator::new(*self);
        for m in samples {
            acc.push(m)?;
        }
        acc.finish()
    }

    /// MATLAB `magcal`'s fit error in percent over `samples`:
    /// `100·√(mean((‖W(m−c)‖² − R²)²)) / (2R²)`.
    pub fn fit_error_pct(&self, samples: &[[f32; 3]]) -> Result<f32, Error> {
        self.quality(samples.iter().copied())
            .map(|q| q.fit_error_pct)
    }
}

/// Residual statistics of a [`MagFit`] over a set of samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitQuality {
    /// Number of samples evaluated.
    pub samples: u32,
    /// MATLAB `magcal` fit error, percent: `100·√(mean((‖W(m−c)‖² − R²)²)) / (2R²)`.
    /// For small residuals this is about the RMS relative radius error in percent.
    pub fit_error_pct: f32,
    /// RMS of `‖W(m−c)‖ − R`, raw units.
    pub rms_radius_error: f32,
}

/// Streaming second pass computing [`FitQuality`] for a fixed [`MagFit`] (O(1) memory).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualAccumulator {
    fit: MagFit,
    n: u32,
    q2: (f32, f32),
    e2: (f32, f32),
}

impl ResidualAccumulator {
    /// Starts a pass for `fit`.
    pub const fn new(fit: MagFit) -> Self {
        Self {
            fit,
            n: 0,
            q2: (0.0, 0.0),
            e2: (0.0, 0.0),
        }
    }

    /// Adds a raw sample. NaN/inf (or a residual that overflows `f32`) → [`Error::NonFinite`],
    /// accumulator unchanged.
    pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        if !crate::all_finite(&m) {
            return Err(Error::NonFinite);
        }
        if self.n == u32::MAX {
            return Err(Error::CapacityExceeded);
        }
        let v = self.fit.apply(m);
        let e = libm::sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        let r = self.fit.radius;
        let de = e - r;
        // ‖W(m−c)‖² − R² written as a product to avoid cancellation.
        let q = de * (e + r);
        let (q2, de2) = (q * q, de * de);
        if !q2.is_finite() || !de2.is_finite() {
            return Err(Error::NonFinite);
        }
        neumaier_add(&mut self.q2.0, &mut self.q2.1, q2);
        neumaier_add(&mut self.e2.0, &mut self.e2.1, de2);
        self.n += 1;
        Ok(())
    }

    /// Number of samples pushed.
    pub fn count(&self) -> u32 {
        self.n
    }

    /// The statistics; [`Error::TooFewSamples`] if nothing was pushed.
    pub fn finish(&self) -> Result<FitQuality, Error> {
        if self.n == 0 {
            return Err(Error::TooFewSamples { needed: 1, got: 0 });
        }
        let n = self.n as f32;
        let r2 = self.fit.radius * self.fit.radius;
        let q = FitQuality {
            samples: self.n,
            fit_error_pct: 100.0 * libm::sqrtf((self.q2.0 + self.q2.1) / n) / (2.0 * r2),
            rms_radius_error: libm::sqrtf((self.e2.0 + self.e2.1) / n),
        };
        if !q.fit_error_pct.is_finite() || !q.rms_radius_error.is_finite() {
            return Err(Error::NonFinite);
        }
        Ok(q)
    }
}

/// Common interface of the three streaming fits, so callers can be generic over the model.
pub trait StreamingMagFit {
    /// Number of free parameters, also the minimum number of samples.
    const PARAMS: u32;
    /// Adds a raw sample (raw units). NaN/inf → [`Error::NonFinite`] and the accumulator is
    /// unchanged; more than `u32::MAX` samples → [`Error::CapacityExceeded`].
    fn push(&mut self, m: [f32; 3]) -> Result<(), Error>;
    /// Number of samples accumulated.
    fn count(&self) -> u32;
    /// Solves the fit from the sums accumulated so far (the accumulator can keep going).
    fn solve(&self) -> Result<MagFit, Error>;
}

macro_rules! fit_type {
    ($(#[$doc:meta])* $name:ident, $psi:ident, $params:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            m: Moments,
        }

        impl Default for $name {
            fn default() -> Self {
                Self::new()
            }
        }

        impl $name {
            /// Number of free parameters, also the minimum number of samples.
            pub const PARAMS: u32 = $params;

            /// An empty accumulator.
            pub const fn new() -> Self {
                Self { m: Moments::new() }
            }

            /// Adds a raw sample (raw units). NaN/inf → [`Error::NonFinite`] and the
            /// accumulator is unchanged; more than `u32::MAX` samples →
            /// [`Error::CapacityExceeded`].
            pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
                self.m.push(m)
            }

            /// Number of samples accumulated.
            pub fn count(&self) -> u32 {
                self.m.n
            }

            /// Solves the fit from the sums accumulated so far (the accumulator can keep
            /// going). Errors: see the [module docs](self).
            pub fn solve(&self) -> Result<MagFit, Error> {
                self.m.solve(&$psi)
            }
        }

        impl StreamingMagFit for $name {
            const PARAMS: u32 = $params;
            fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
                $name::push(self, m)
            }
            fn count(&self) -> u32 {
                $name::count(self)
            }
            fn solve(&self) -> Result<MagFit, Error> {
                $name::solve(self)
            }
        }
    };
}

fit_type!(
    /// Sphere (hard iron only): `‖m − c‖ = R`, 4 parameters (Kåsa fit,
    /// `x²+y²+z² = 2cᵀm + R² − ‖c‖²`). The result has `W = I`.
    SphereFit,
    SPHERE_PSI,
    4
);

fit_type!(
    /// Axis-aligned ellipsoid (hard iron and per-axis scale, the seed's model):
    /// `a x² + b y² + c z² + 2g x + 2h y + 2i z + j = 0` with `a + b + c = 3`, 6 parameters.
    /// The result has a diagonal `W`.
    AxisEllipsoidFit,
    AXIS_PSI,
    6
);

fit_type!(
    /// Rotated ellipsoid (hard iron and full soft iron):
    /// `Ax²+By²+Cz²+2Dxy+2Exz+2Fyz+2Gx+2Hy+2Iz+J = 0` with `A + B + C = 3`, 9 parameters.
    EllipsoidFit,
    ELLIPSOID_PSI,
    9
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monomial_tables_are_consistent() {
        for (k, [a, b, c]) in MONO.iter().enumerate() {
            assert!(a + b + c <= 4);
            assert_eq!(MONO_IDX[*a as usize][*b as usize][*c as usize] as usize, k);
        }
    }

    #[test]
    fn shift_matches_direct_sums() {
        // Sums accumulated about one origin and shifted must equal sums accumulated about the
        // shifted origin (small integer data: everything exact or nearly so).
        let pts = [
            [1.0f32, 2.0, -1.0],
            [0.5, -1.5, 0.25],
            [-1.0, 0.0, 1.5],
            [0.0, 1.0, 1.0],
        ];
        let mut a = Moments::new();
        a.scaled = true;
        for p in pts {
            a.add_sample(p);
        }
        let t = [0.25f32, -0.5, 0.75];
        let s = a.sums();
        a.shift(s, t);
        let mut b = Moments::new();
        for p in pts {
            b.add_sample([p[0] - t[0], p[1] - t[1], p[2] - t[2]]);
        }
        for k in 0..N_MONO {
            assert!(
                (a.hi[k] - b.hi[k]).abs() < 1e-5 * (1.0 + b.hi[k].abs()),
                "{k}"
            );
        }
    }

    #[test]
    fn exact_sphere_is_recovered() {
        let c = [100.0f32, -50.0, 25.0];
        let r = 40.0f32;
        let mut f = SphereFit::new();
        let mut e = EllipsoidFit::new();
        for i in 0..60 {
            let th = 0.37 * i as f32;
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / 60.0;
            let rho = libm::sqrtf(1.0 - z * z);
            let p = [
                c[0] + r * rho * libm::cosf(th),
                c[1] + r * rho * libm::sinf(th),
                c[2] + r * z,
            ];
            f.push(p).unwrap();
            e.push(p).unwrap();
        }
        for fit in [f.solve().unwrap(), e.solve().unwrap()] {
            for (got, want) in fit.center.iter().zip(c) {
                assert!((got - want).abs() < 1e-3 * r, "{fit:?}");
            }
            assert!((fit.radius - r).abs() < 1e-3 * r, "{fit:?}");
        }
    }
}
