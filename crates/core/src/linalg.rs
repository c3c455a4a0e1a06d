//! Small allocation-free linear-algebra helpers on static matrices: `f32` for the device's
//! fits, generic over the float type (`f32` / `f64`) where the host's analysis needs them.
//!
//! * [`solve_spd`] solves a symmetric positive-definite system `A·x = b` (the normal
//!   equations `MᵀM·x = Mᵀc` of a least-squares fit) by Cholesky factorisation, refusing
//!   systems whose pivots show the matrix is singular *for `f32`*.
//! * [`cholesky_checked`] factors a symmetric positive-definite matrix and refuses pivots
//!   below a relative threshold (the normal matrix of a fit whose parameters the data do not
//!   all determine); [`invert3_checked`] inverts a 3×3 matrix with a conditioning test.
//! * [`sym3_eigen`] and [`sym3_sqrt`] decompose a symmetric 3×3 matrix (used for the
//!   soft-iron matrix of a magnetometer fit).
//!
//! ## Why nalgebra's `Cholesky` and not a hand-written Banachiewicz loop
//! The seed (*AHRS Sensor Calibration*) factors the normal matrix with the
//! Cholesky–Banachiewicz loop and then does forward and back substitution. nalgebra's
//! [`nalgebra::Cholesky`] is the same factorisation (column-oriented, Cholesky–Crout order,
//! identical arithmetic up to summation order) plus the two triangular solves, and for
//! `SMatrix<f32, N, N>` it stores everything in an `ArrayStorage` on the stack: no `alloc`
//! (the core builds for `thumbv7em-none-eabihf` with nalgebra's default features off). It
//! only refuses pivots that are `<= 0`, which is not enough in `f32`: a matrix that is
//! singular in exact arithmetic usually yields tiny *positive* pivots made of rounding
//! noise. So [`solve_spd`] equilibrates the matrix first (unit diagonal) and then checks
//! every pivot `L_jj²` of the factor against a relative threshold; see [`solve_spd_with_tol`].

use nalgebra::{Cholesky, Const, Matrix3, RealField, SMatrix, SVector, SymmetricEigen};

use crate::error::Error;

/// Column 3-vector of `f32`.
pub type Vec3 = nalgebra::Vector3<f32>;
/// 3×3 matrix of `f32`.
pub type Mat3 = nalgebra::Matrix3<f32>;

/// True when every component is finite (not NaN, not ±inf).
#[inline]
pub fn all_finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Default relative pivot threshold of [`solve_spd`].
///
/// After equilibration (unit diagonal), the squared pivot `L_jj²` of the Cholesky factor is
/// `1 − R²_j`, the fraction of regressor `j` that the previous regressors do not explain
/// (a Schur complement). When it falls below `1e-5` the system's condition number is at
/// least `~1e5`, so with `f32` inputs (relative error `~6e-8` per entry, more after summing
/// many samples) the solution would carry errors of order `1e-2` or worse: we report
/// [`Error::Singular`] instead of returning noise. Exactly degenerate inputs (e.g. samples
/// on a plane for an ellipsoid fit) give pivots at the rounding level, `≲ 1e-6`.
pub const DEFAULT_PIVOT_TOL: f32 = 1e-5;

/// Solves `A·x = b` for symmetric positive-definite `A` with [`DEFAULT_PIVOT_TOL`].
///
/// Only the lower triangle of `a` is read. Errors: [`Error::NonFinite`] if any input is NaN
/// or infinite (or the solution overflows), [`Error::Singular`] if `A` is not positive
/// definite or too ill-conditioned for `f32` (see [`solve_spd_with_tol`]).
pub fn solve_spd<const N: usize>(
    a: &SMatrix<f32, N, N>,
    b: &SVector<f32, N>,
) -> Result<SVector<f32, N>, Error> {
    solve_spd_with_tol(a, b, DEFAULT_PIVOT_TOL)
}

/// Solves `A·x = b` for symmetric positive-definite `A`, with a caller-chosen relative pivot
/// threshold `tol` (dimensionless, `0 ≤ tol < 1`).
///
/// Procedure:
/// 1. Jacobi equilibration `Ã = S·A·S` with `S = diag(1/√A_jj)`, so that `Ã` has a unit
///    diagonal. This makes the pivot test independent of the units and scaling of the
///    unknowns (e.g. a quadratic coefficient versus a constant term) and also improves the
///    conditioning of the factorisation.
/// 2. Cholesky `Ã = L·Lᵀ` (nalgebra); any pivot `L_jj² < tol` → [`Error::Singular`].
/// 3. Forward and back substitution, `x = S·Ã⁻¹·S·b`.
///
/// A non-positive or non-finite diagonal entry of `A` is reported as [`Error::Singular`]
/// (a regressor that is identically zero on the data); NaN/inf anywhere in the input as
/// [`Error::NonFinite`].
pub fn solve_spd_with_tol<const N: usize>(
    a: &SMatrix<f32, N, N>,
    b: &SVector<f32, N>,
    tol: f32,
) -> Result<SVector<f32, N>, Error> {
    if !all_finite(a.as_slice()) || !all_finite(b.as_slice()) || !tol.is_finite() {
        return Err(Error::NonFinite);
    }
    let mut s = SVector::<f32, N>::zeros();
    for j in 0..N {
        let d = a[(j, j)];
        if d <= 0.0 {
            return Err(Error::Singular);
        }
        let sj = 1.0 / libm::sqrtf(d);
        if !sj.is_finite() || sj == 0.0 {
            return Err(Error::Singular);
        }
        s[j] = sj;
    }
    let mut eq = *a;
    for j in 0..N {
        for i in 0..N {
            eq[(i, j)] *= s[i] * s[j];
        }
    }
    if !all_finite(eq.as_slice()) {
        return Err(Error::Singular);
    }
    let chol = Cholesky::new(eq).ok_or(Error::Singular)?;
    let l = chol.l_dirty();
    for j in 0..N {
        let p = l[(j, j)];
        let p2 = p * p;
        if p2.is_nan() || p2 < tol {
            return Err(Error::Singular);
        }
    }
    let mut x = b.component_mul(&s);
    chol.solve_mut(&mut x);
    let x = x.component_mul(&s);
    if !all_finite(x.as_slice()) {
        return Err(Error::NonFinite);
    }
    Ok(x)
}

fn finite<T: RealField + Copy>(v: &[T]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Cholesky factor of a symmetric positive-definite `a` (lower triangle read), refusing it
/// (`None`) when a squared pivot `L_jj²` is not above `rel_pivot · |A_jj|` (or is NaN): a
/// normal matrix `JᵀJ` whose parameters the data do not all determine. Unlike
/// [`solve_spd_with_tol`] there is no equilibration, so `rel_pivot` is relative to each
/// diagonal entry; `1e-13` suits `f64` (the least-squares solver's `REL_PIVOT_F64`).
pub fn cholesky_checked<T: RealField + Copy, const N: usize>(
    a: &SMatrix<T, N, N>,
    rel_pivot: T,
) -> Option<Cholesky<T, Const<N>>> {
    let chol = Cholesky::new(*a)?;
    let l = chol.l_dirty();
    for j in 0..N {
        let pivot = l[(j, j)] * l[(j, j)];
        // Written so that a NaN pivot is refused too.
        if pivot.partial_cmp(&(rel_pivot * a[(j, j)].abs())) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
    }
    Some(chol)
}

/// Inverse of a 3×3 matrix in any float type, refusing ([`Error::Singular`]) a matrix whose
/// determinant is at most `rel_det` times the product of its row norms (for `f32` the core
/// uses `1e-6`, the model's `invert3`); [`Error::NonFinite`] on NaN/inf input.
pub fn invert3_checked<T: RealField + Copy>(
    m: &Matrix3<T>,
    rel_det: T,
) -> Result<Matrix3<T>, Error> {
    if !finite(m.as_slice()) {
        return Err(Error::NonFinite);
    }
    let det = m.determinant();
    let scale = m.row(0).norm() * m.row(1).norm() * m.row(2).norm();
    if !det.is_finite() || scale == T::zero() || det.abs() <= rel_det * scale {
        return Err(Error::Singular);
    }
    m.try_inverse().ok_or(Error::Singular)
}

/// Eigen-decomposition of a symmetric 3×3 matrix: `M = V·diag(λ)·Vᵀ`.
///
/// Returns the eigenvalues in ascending order and the matching unit eigenvectors as the
/// columns of `V` (orthonormal, a rotation or a reflection). Only the lower triangle of `m`
/// is read. Uses nalgebra's [`SymmetricEigen`] (implicit symmetric QR), which for a static
/// 3×3 works on the stack without `alloc`; the iteration count is bounded, so a failure to
/// converge is reported as [`Error::NotConverged`] rather than looping or panicking.
pub fn sym3_eigen(m: &Mat3) -> Result<(Vec3, Mat3), Error> {
    if !all_finite(m.as_slice()) {
        return Err(Error::NonFinite);
    }
    let eig = SymmetricEigen::try_new(*m, f32::EPSILON, 200).ok_or(Error::NotConverged)?;
    let mut order = [0usize, 1, 2];
    // Sort indices by eigenvalue (3 elements: a tiny insertion sort, no allocation).
    for i in 1..3 {
        let mut k = i;
        while k > 0 && eig.eigenvalues[order[k - 1]] > eig.eigenvalues[order[k]] {
            order.swap(k - 1, k);
            k -= 1;
        }
    }
    let vals = Vec3::new(
        eig.eigenvalues[order[0]],
        eig.eigenvalues[order[1]],
        eig.eigenvalues[order[2]],
    );
    let mut vecs = Mat3::zeros();
    for (dst, &src) in order.iter().enumerate() {
        let col = eig.eigenvectors.column(src);
        vecs.set_column(dst, &col.normalize());
    }
    if !all_finite(vals.as_slice()) || !all_finite(vecs.as_slice()) {
        return Err(Error::NonFinite);
    }
    Ok((vals, vecs))
}

/// Principal (symmetric positive semi-definite) square root of a symmetric 3×3 matrix:
/// `R = V·diag(√λ)·Vᵀ`, so that `R·R = M` and `Rᵀ = R`.
///
/// Errors: [`Error::NonFinite`] on NaN/inf, [`Error::Singular`] if an eigenvalue is
/// negative beyond rounding (`λ_min < −64·ε·λ_max`); eigenvalues within rounding of zero are
/// clamped to zero.
pub fn sym3_sqrt(m: &Mat3) -> Result<Mat3, Error> {
    let (vals, vecs) = sym3_eigen(m)?;
    let lmax = libm::fabsf(vals[0]).max(libm::fabsf(vals[2]));
    if vals[0] < -64.0 * f32::EPSILON * lmax {
        return Err(Error::Singular);
    }
    let roots = Vec3::new(
        libm::sqrtf(vals[0].max(0.0)),
        libm::sqrtf(vals[1].max(0.0)),
        libm::sqrtf(vals[2].max(0.0)),
    );
    let r = vecs * Mat3::from_diagonal(&roots) * vecs.transpose();
    // Symmetrise away rounding so that callers can rely on `Rᵀ = R` exactly.
    let r = (r + r.transpose()) * 0.5;
    if !all_finite(r.as_slice()) {
        return Err(Error::NonFinite);
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix4, Vector4};

    #[test]
    fn spd_solve_matches_known_solution() {
        // A = Bᵀ B + I is SPD; pick x, compute b, solve back.
        let bm = Matrix4::new(
            1.0, 2.0, 0.5, -1.0, 0.0, 3.0, 1.0, 2.0, 4.0, -1.0, 2.0, 0.0, 1.0, 1.0, 1.0, 5.0,
        );
        let a = bm.transpose() * bm + Matrix4::identity();
        let x = Vector4::new(1.0, -2.0, 0.25, 3.0);
        let b = a * x;
        let got = solve_spd(&a, &b).unwrap();
        assert!((got - x).norm() < 1e-4 * x.norm(), "{got} vs {x}");
    }

    #[test]
    fn spd_solve_rejects_singular_and_indefinite_and_nan() {
        let v = Vector4::new(1.0f32, 2.0, 3.0, 4.0);
        let rank1 = v * v.transpose();
        assert_eq!(solve_spd(&rank1, &v), Err(Error::Singular));
        let indefinite = Matrix4::from_diagonal(&Vector4::new(1.0, 1.0, -1.0, 1.0));
        assert_eq!(solve_spd(&indefinite, &v), Err(Error::Singular));
        let mut nan = Matrix4::<f32>::identity();
        nan[(1, 2)] = f32::NAN;
        assert_eq!(solve_spd(&nan, &v), Err(Error::NonFinite));
        let mut nearly = Matrix4::<f32>::identity();
        nearly[(1, 0)] = 1.0 - 1e-7;
        nearly[(0, 1)] = 1.0 - 1e-7;
        assert_eq!(solve_spd(&nearly, &v), Err(Error::Singular));
    }

    #[test]
    fn spd_solve_is_scale_invariant() {
        // Wildly different unknown scales (1e-6 .. 1e6) must not trip the pivot test.
        let base = Matrix4::new(
            4.0, 1.0, 0.5, 0.2, 1.0, 3.0, 0.3, 0.1, 0.5, 0.3, 2.0, 0.4, 0.2, 0.1, 0.4, 1.0,
        );
        let d = Matrix4::from_diagonal(&Vector4::new(1e-6, 1.0, 1e3, 1e6));
        let a = d * base * d;
        let x = Vector4::new(1e6, -2.0, 3e-3, 4e-6);
        let got = solve_spd(&a, &(a * x)).unwrap();
        for i in 0..4 {
            assert!((got[i] - x[i]).abs() < 1e-4 * x[i].abs(), "{got} vs {x}");
        }
    }

    #[test]
    fn f64_helpers_solve_factor_and_invert() {
        let bm = Matrix4::<f64>::new(
            1.0, 2.0, 0.5, -1.0, 0.0, 3.0, 1.0, 2.0, 4.0, -1.0, 2.0, 0.0, 1.0, 1.0, 1.0, 5.0,
        );
        let a = bm.transpose() * bm + Matrix4::identity();
        let x = Vector4::new(1.0, -2.0, 0.25, 3.0);
        let chol = cholesky_checked(&a, 1e-13).unwrap();
        assert!((chol.solve(&(a * x)) - x).norm() < 1e-12 * x.norm());
        // Rank 3 (last column = sum of the first two): refused.
        let mut r = bm;
        for i in 0..4 {
            r[(i, 3)] = r[(i, 0)] + r[(i, 1)];
        }
        assert!(cholesky_checked(&(r.transpose() * r), 1e-13).is_none());
        let m = nalgebra::Matrix3::<f64>::new(2.0, 0.1, 0.0, 0.0, 3.0, 0.2, 0.0, 0.0, 4.0);
        let inv = invert3_checked(&m, 1e-12).unwrap();
        assert!((inv * m - nalgebra::Matrix3::identity()).amax() < 1e-15);
        let sing = nalgebra::Matrix3::<f64>::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0);
        assert_eq!(invert3_checked(&sing, 1e-12), Err(Error::Singular));
    }

    #[test]
    fn eigen_and_sqrt_of_rotated_diagonal() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.3f32, -0.7, 1.1).into_inner();
        let m = rot * Mat3::from_diagonal(&Vec3::new(4.0, 1.0, 9.0)) * rot.transpose();
        let (vals, vecs) = sym3_eigen(&m).unwrap();
        assert!((vals - Vec3::new(1.0, 4.0, 9.0)).norm() < 1e-5);
        assert!((vecs * Mat3::from_diagonal(&vals) * vecs.transpose() - m).norm() < 1e-5);
        let r = sym3_sqrt(&m).unwrap();
        assert!((r * r - m).norm() < 1e-5);
        assert_eq!(r, r.transpose());
        let neg = Mat3::from_diagonal(&Vec3::new(1.0, -1.0, 2.0));
        assert_eq!(sym3_sqrt(&neg), Err(Error::Singular));
        let mut nan = Mat3::identity();
        nan[(2, 2)] = f32::INFINITY;
        assert_eq!(sym3_eigen(&nan).map(|_| ()), Err(Error::NonFinite));
    }
}
