//! Magnetometer fits (`wiical_core::magfit`) against an independent `f64` reference, against
//! simulations with known truth, and on the real recordings in `shared/data`.
//!
//! The `f64` reference solves the same algebraic least-squares problem (trace-normalised
//! quadric, see the module docs of `magfit`) *directly on the design matrix* by SVD, in raw
//! coordinates (no centring, no scaling tricks, no normal equations), and converts the
//! quadric with `f64` eigen-decompositions. The `f32` results are compared with it using
//! relative errors normalised by the field radius `R` (see [`RelDiff`]).
//!
//! Run with `--nocapture` to see the measured numbers.

// Parallel 3-vectors (ours, reference, expected) read more clearly with an index.
#![allow(clippy::needless_range_loop)]

mod common;
use common::data_dir;

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, SymmetricEigen, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use wiical_core::magfit::{
    AxisEllipsoidFit, EllipsoidFit, MagFit, ResidualAccumulator, SphereFit, StreamingMagFit,
};
use wiical_core::Error;

// ---------------------------------------------------------------- data

fn read_text(rel: &str) -> String {
    let path = data_dir().join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

fn parse_row(line: &str, sep: impl Fn(char) -> bool) -> [f64; 3] {
    let v: Vec<f64> = line
        .split(sep)
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().expect("number"))
        .collect();
    assert_eq!(v.len(), 3, "bad row {line:?}");
    [v[0], v[1], v[2]]
}

/// QMC5883L CSV: 2 metadata lines, header `mx,my,mz`, then integer rows.
fn read_qmc(name: &str) -> Vec<[f64; 3]> {
    let text = read_text(&format!("qmc5883l_mag_tomisuarez/{name}"));
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("Fs"));
    assert!(lines.next().unwrap().starts_with("Initialization"));
    assert_eq!(lines.next().unwrap().trim(), "mx,my,mz");
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| parse_row(l, |c| c == ','))
        .collect()
}

/// `mag_out.txt`: whitespace-separated `x y z`.
fn read_mag_out() -> Vec<[f64; 3]> {
    read_text("mag_ellipsoid_fit_python/mag_out.txt")
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| parse_row(l, char::is_whitespace))
        .collect()
}

fn to_f32(p: &[[f64; 3]]) -> Vec<[f32; 3]> {
    p.iter()
        .map(|m| [m[0] as f32, m[1] as f32, m[2] as f32])
        .collect()
}

// ---------------------------------------------------------------- f64 reference

#[derive(Clone, Copy, Debug, PartialEq)]
enum Model {
    Sphere,
    Axis,
    Ellipsoid,
}

const MODELS: [Model; 3] = [Model::Sphere, Model::Axis, Model::Ellipsoid];

#[derive(Clone, Copy, Debug)]
struct RefFit {
    center: Vector3<f64>,
    w: Matrix3<f64>,
    radius: f64,
}

impl RefFit {
    fn semi_axes(&self) -> [f64; 3] {
        let e = SymmetricEigen::new(self.w);
        let mut a: Vec<f64> = e.eigenvalues.iter().map(|s| self.radius / s).collect();
        a.sort_by(|x, y| x.partial_cmp(y).unwrap());
        [a[0], a[1], a[2]]
    }

    /// magcal error (percent) and RMS radius error of this fit over `pts`, in f64.
    fn quality(&self, pts: &[[f64; 3]]) -> (f64, f64) {
        let r2 = self.radius * self.radius;
        let (mut q2, mut e2) = (0.0, 0.0);
        for p in pts {
            let v = self.w * (Vector3::from(*p) - self.center);
            q2 += (v.norm_squared() - r2).powi(2);
            e2 += (v.norm() - self.radius).powi(2);
        }
        let n = pts.len() as f64;
        (100.0 * (q2 / n).sqrt() / (2.0 * r2), (e2 / n).sqrt())
    }
}

/// `x²+y²+z² ≈ Σθψ` with the trace-normalised regressors, solved by SVD on the column-scaled
/// design matrix in raw coordinates, then converted to (centre, W, R).
fn ref_fit(pts: &[[f64; 3]], model: Model) -> RefFit {
    type Reg = fn(f64, f64, f64) -> f64;
    let all: [Reg; 9] = [
        |x, y, z| x * x + y * y - 2.0 * z * z,
        |x, y, z| x * x - 2.0 * y * y + z * z,
        |x, y, _| 2.0 * x * y,
        |x, _, z| 2.0 * x * z,
        |_, y, z| 2.0 * y * z,
        |x, _, _| 2.0 * x,
        |_, y, _| 2.0 * y,
        |_, _, z| 2.0 * z,
        |_, _, _| 1.0,
    ];
    let which: &[usize] = match model {
        Model::Sphere => &[5, 6, 7, 8],
        Model::Axis => &[0, 1, 5, 6, 7, 8],
        Model::Ellipsoid => &[0, 1, 2, 3, 4, 5, 6, 7, 8],
    };
    let n = pts.len();
    let mut d = DMatrix::<f64>::zeros(n, which.len());
    let mut t = DVector::<f64>::zeros(n);
    for (k, p) in pts.iter().enumerate() {
        for (j, &w) in which.iter().enumerate() {
            d[(k, j)] = all[w](p[0], p[1], p[2]);
        }
        t[k] = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    }
    let scale: Vec<f64> = (0..which.len()).map(|j| d.column(j).norm()).collect();
    for (j, s) in scale.iter().enumerate() {
        d.column_mut(j).scale_mut(1.0 / s);
    }
    let y = d.svd(true, true).solve(&t, 0.0).unwrap();
    let mut theta = [0.0f64; 9];
    for (j, &w) in which.iter().enumerate() {
        theta[w] = y[j] / scale[j];
    }
    // Q = x²+y²+z² − Σθψ = uᵀAu + 2bᵀu + c0.
    let a = Matrix3::new(
        1.0 - theta[0] - theta[1],
        -theta[2],
        -theta[3],
        -theta[2],
        1.0 - theta[0] + 2.0 * theta[1],
        -theta[4],
        -theta[3],
        -theta[4],
        1.0 + 2.0 * theta[0] - theta[1],
    );
    let b = Vector3::new(-theta[5], -theta[6], -theta[7]);
    let c0 = -theta[8];
    quadric_to_ref(&a, &b, c0)
}

fn quadric_to_ref(a: &Matrix3<f64>, b: &Vector3<f64>, c0: f64) -> RefFit {
    // Orient the quadric so that A is positive (the "= 1" form gives −A when the origin is
    // outside the ellipsoid).
    let (a, b, c0) = if a.trace() < 0.0 {
        (-a, -b, -c0)
    } else {
        (*a, *b, c0)
    };
    let center = -a.try_inverse().unwrap() * b;
    let k = -(b.dot(&center) + c0);
    assert!(k > 0.0, "reference quadric is not an ellipsoid");
    let e = SymmetricEigen::new(a);
    assert!(e.eigenvalues.iter().all(|l| *l > 0.0));
    let det = e.eigenvalues.product();
    let sq = e.eigenvectors
        * Matrix3::from_diagonal(&e.eigenvalues.map(f64::sqrt))
        * e.eigenvectors.transpose();
    let g6 = det.powf(1.0 / 6.0);
    RefFit {
        center,
        w: sq / g6,
        radius: k.sqrt() / g6,
    }
}

/// The constant-normalised form `Ax²+By²+Cz²+2Dxy+2Exz+2Fyz+2Gx+2Hy+2Iz = 1` in raw
/// coordinates (f64, SVD), the seed's normalisation; `axis` drops the cross terms (the seed's
/// literal 6-parameter form). For comparison with SOURCE.md only: it is a *different*
/// algebraic criterion from ours (not translation invariant).
fn unit_rhs_fit(pts: &[[f64; 3]], axis: bool) -> RefFit {
    let np = if axis { 6 } else { 9 };
    let n = pts.len();
    let mut d = DMatrix::<f64>::zeros(n, np);
    for (k, p) in pts.iter().enumerate() {
        let (x, y, z) = (p[0], p[1], p[2]);
        let row: Vec<f64> = if axis {
            vec![x * x, y * y, z * z, 2.0 * x, 2.0 * y, 2.0 * z]
        } else {
            vec![
                x * x,
                y * y,
                z * z,
                2.0 * x * y,
                2.0 * x * z,
                2.0 * y * z,
                2.0 * x,
                2.0 * y,
                2.0 * z,
            ]
        };
        for j in 0..np {
            d[(k, j)] = row[j];
        }
    }
    let scale: Vec<f64> = (0..np).map(|j| d.column(j).norm()).collect();
    for (j, s) in scale.iter().enumerate() {
        d.column_mut(j).scale_mut(1.0 / s);
    }
    let y = d
        .svd(true, true)
        .solve(&DVector::from_element(n, 1.0), 0.0)
        .unwrap();
    let th: Vec<f64> = (0..np).map(|j| y[j] / scale[j]).collect();
    let (a, b) = if axis {
        (
            Matrix3::from_diagonal(&Vector3::new(th[0], th[1], th[2])),
            Vector3::new(th[3], th[4], th[5]),
        )
    } else {
        (
            Matrix3::new(
                th[0], th[3], th[4], th[3], th[1], th[5], th[4], th[5], th[2],
            ),
            Vector3::new(th[6], th[7], th[8]),
        )
    };
    quadric_to_ref(&a, &b, -1.0)
}

/// Model-free noise estimate (raw units): RMS over axes of `std(m_{k+1} − m_k)/√2`. Also
/// contains the motion between consecutive samples, so it slightly over-estimates the noise.
fn diff_noise(pts: &[[f64; 3]]) -> f64 {
    let n = (pts.len() - 1) as f64;
    let mut tot = 0.0;
    for i in 0..3 {
        let d: Vec<f64> = pts.windows(2).map(|w| w[1][i] - w[0][i]).collect();
        let mean = d.iter().sum::<f64>() / n;
        tot += d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n / 2.0;
    }
    (tot / 3.0).sqrt()
}

/// Relative differences between an `f32` fit and a reference, all normalised so that they
/// measure the error in the *corrected field* relative to its magnitude:
/// * `center`: `‖Δc‖ / R` — the centre contains the arbitrary hard-iron offset (thousands of
///   counts, which `f32` itself only holds to ~4e-4 counts), so relative-to-centre would be
///   meaningless; a centre error `δ` shifts corrected readings by `δ/R` of the field;
/// * `radius`: `|ΔR| / R`;
/// * `matrix`: `‖ΔW‖_F / ‖W‖_F` (`W` has `det = 1`, `‖W‖_F ≈ √3`).
#[derive(Debug, Clone, Copy)]
struct RelDiff {
    center: f64,
    radius: f64,
    matrix: f64,
}

impl RelDiff {
    fn of(f: &MagFit, r: &RefFit) -> Self {
        let c = Vector3::new(f.center[0] as f64, f.center[1] as f64, f.center[2] as f64);
        let w = Matrix3::from_fn(|i, j| f.matrix[i][j] as f64);
        RelDiff {
            center: (c - r.center).norm() / r.radius,
            radius: (f.radius as f64 - r.radius).abs() / r.radius,
            matrix: (w - r.w).norm() / r.w.norm(),
        }
    }
    fn max(&self) -> f64 {
        self.center.max(self.radius).max(self.matrix)
    }
}

fn fit_f32(pts: &[[f32; 3]], model: Model) -> Result<MagFit, Error> {
    fn run<F: StreamingMagFit + Default>(pts: &[[f32; 3]]) -> Result<MagFit, Error> {
        let mut f = F::default();
        for p in pts {
            f.push(*p)?;
        }
        f.solve()
    }
    match model {
        Model::Sphere => run::<SphereFit>(pts),
        Model::Axis => run::<AxisEllipsoidFit>(pts),
        Model::Ellipsoid => run::<EllipsoidFit>(pts),
    }
}

fn det3(w: &[[f32; 3]; 3]) -> f64 {
    Matrix3::from_fn(|i, j| w[i][j] as f64).determinant()
}

// ---------------------------------------------------------------- simulations

struct Truth {
    center: Vector3<f64>,
    w: Matrix3<f64>,
    radius: f64,
}

/// Random soft iron `W = Q·diag(w)·Qᵀ` with `det W = 1` and the given stretch factors
/// (renormalised), points `m = c + W⁻¹·(R·n̂) + noise`, `n̂` uniform on the sphere.
fn simulate(
    rng: &mut ChaCha8Rng,
    n: usize,
    stretch: [f64; 3],
    rotate: bool,
    center: [f64; 3],
    radius: f64,
    sigma: f64,
) -> (Truth, Vec<[f64; 3]>) {
    let q = if rotate {
        Rotation3::from_euler_angles(
            rng.random_range(-3.0..3.0),
            rng.random_range(-1.5..1.5),
            rng.random_range(-3.0..3.0),
        )
        .into_inner()
    } else {
        Matrix3::identity()
    };
    let g = (stretch[0] * stretch[1] * stretch[2]).cbrt();
    let diag = Vector3::new(stretch[0] / g, stretch[1] / g, stretch[2] / g);
    let w = q * Matrix3::from_diagonal(&diag) * q.transpose();
    let winv = w.try_inverse().unwrap();
    let c = Vector3::from(center);
    let noise = Normal::new(0.0, sigma.max(1e-300)).unwrap();
    let pts = (0..n)
        .map(|_| {
            let v = Vector3::<f64>::from_fn(|_, _| StandardNormal.sample(rng)).normalize();
            let mut m = c + winv * (radius * v);
            if sigma > 0.0 {
                m += Vector3::from_fn(|_, _| noise.sample(rng));
            }
            [m.x, m.y, m.z]
        })
        .collect();
    (
        Truth {
            center: c,
            w,
            radius,
        },
        pts,
    )
}

fn truth_diff(f: &MagFit, t: &Truth) -> RelDiff {
    RelDiff::of(
        f,
        &RefFit {
            center: t.center,
            w: t.w,
            radius: t.radius,
        },
    )
}

#[test]
fn noise_free_ellipsoids_are_recovered_exactly_in_f32() {
    // Hard iron of thousands of counts, rotation, anisotropy up to ~2.2:1 (like the QMC5883L
    // recording). Noise-free, so the only error is f32 rounding: 1e-4 relative.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for (i, (stretch, rotate, model)) in [
        ([1.0, 1.0, 1.0], false, Model::Sphere),
        ([0.7, 1.0, 1.5], false, Model::Axis),
        ([0.6, 1.1, 1.3], true, Model::Ellipsoid),
        ([1.0, 1.6, 2.2], true, Model::Ellipsoid),
    ]
    .into_iter()
    .enumerate()
    {
        let (truth, pts) = simulate(
            &mut rng,
            2000,
            stretch,
            rotate,
            [6135.0, -3249.0, 3443.0],
            1100.0,
            0.0,
        );
        let fit = fit_f32(&to_f32(&pts), model).unwrap();
        let d = truth_diff(&fit, &truth);
        println!("case {i} {model:?}: truth diff {d:?}");
        assert!(d.max() < 1e-4, "case {i}: {d:?} {fit:?}");
        assert!((det3(&fit.matrix) - 1.0).abs() < 1e-5);
        // The f32 pass over the same points: fit error ~ 0 (f32 rounding only).
        let q = fit.quality(to_f32(&pts)).unwrap();
        assert!(q.fit_error_pct < 1e-3 && q.rms_radius_error < 0.05, "{q:?}");
    }
}

#[test]
fn noisy_ellipsoids_match_f64_reference_and_truth() {
    // σ = 8 counts on R = 1000 (0.8 %), 5000 samples, hard iron of thousands of counts.
    // Statistical error of the centre ≈ σ·√(3/N)·(stretch ≤ 1.6) ≈ 0.3 counts, algebraic-fit
    // bias O(σ²/R) ≈ 0.1 counts: truth bounds at ~10× that (centre 3e-3·R, R and W 3e-3).
    // The f32/f64 difference has nothing to do with noise and must stay below 1e-4.
    let sigma = 8.0;
    for seed in 0..6u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
        let c = [
            rng.random_range(-8000.0..8000.0),
            rng.random_range(-8000.0..8000.0),
            rng.random_range(-8000.0..8000.0),
        ];
        let stretch = [rng.random_range(0.7..1.0), 1.0, rng.random_range(1.0..1.6)];
        let (truth, pts) = simulate(&mut rng, 5000, stretch, true, c, 1000.0, sigma);
        let p32 = to_f32(&pts);
        let fit = fit_f32(&p32, Model::Ellipsoid).unwrap();
        let reference = ref_fit(&pts, Model::Ellipsoid);
        let d64 = RelDiff::of(&fit, &reference);
        let dt = truth_diff(&fit, &truth);
        println!("seed {seed}: f32-f64 {d64:?}\n        vs truth {dt:?}");
        assert!(d64.max() < 1e-4, "seed {seed}: f32 vs f64 {d64:?}");
        assert!(
            dt.center < 3e-3 && dt.radius < 3e-3 && dt.matrix < 3e-3,
            "{dt:?}"
        );
        // Fit error of a correct model is the noise: rms radius error ≈ σ (within 10 %).
        let q = fit.quality(p32.iter().copied()).unwrap();
        assert!(
            (q.rms_radius_error as f64 / sigma - 1.0).abs() < 0.1,
            "{q:?}"
        );
        // magcal's metric for small residuals ≈ 100·σ/R percent.
        assert!(
            (q.fit_error_pct as f64 / (100.0 * sigma / 1000.0) - 1.0).abs() < 0.1,
            "{q:?}"
        );
    }
}

#[test]
fn axis_and_sphere_models_match_f64_on_their_own_geometry() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (truth, pts) = simulate(
        &mut rng,
        3000,
        [0.8, 1.0, 1.4],
        false,
        [-4000.0, 2500.0, 900.0],
        800.0,
        5.0,
    );
    let fit = fit_f32(&to_f32(&pts), Model::Axis).unwrap();
    let d64 = RelDiff::of(&fit, &ref_fit(&pts, Model::Axis));
    let dt = truth_diff(&fit, &truth);
    println!("axis: f32-f64 {d64:?} truth {dt:?}");
    assert!(d64.max() < 1e-4 && dt.max() < 3e-3);
    // Axis fit → diagonal W.
    assert!(fit.matrix[0][1] == 0.0 && fit.matrix[0][2] == 0.0 && fit.matrix[1][2] == 0.0);

    let (truth, pts) = simulate(
        &mut rng,
        3000,
        [1.0, 1.0, 1.0],
        false,
        [3000.0, 3000.0, -3000.0],
        500.0,
        5.0,
    );
    let fit = fit_f32(&to_f32(&pts), Model::Sphere).unwrap();
    let d64 = RelDiff::of(&fit, &ref_fit(&pts, Model::Sphere));
    let dt = truth_diff(&fit, &truth);
    println!("sphere: f32-f64 {d64:?} truth {dt:?}");
    assert!(d64.max() < 1e-4 && dt.max() < 3e-3);
    assert_eq!(
        fit.matrix,
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    );
}

#[test]
fn partial_coverage_hand_rotation_still_matches_f64() {
    // A slow sweep that starts at one spot and only covers one hemisphere densely: the
    // running-mean re-centring moves the origin many times; the result must still agree
    // with f64 to 1e-4.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let q = Rotation3::from_euler_angles(0.4, -0.3, 1.2).into_inner();
    let w = q * Matrix3::from_diagonal(&Vector3::new(0.8, 1.0, 1.25)) * q.transpose();
    let winv = w.try_inverse().unwrap();
    let c = Vector3::new(6135.0, 249.0, 3443.0);
    let noise = Normal::new(0.0, 4.0).unwrap();
    let mut pts = Vec::new();
    for k in 0..8000 {
        let t = k as f64 / 8000.0;
        let theta = 0.2 + 1.6 * t; // polar angle sweeps from near the pole
        let phi = 40.0 * t;
        let v = Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        let m = c + winv * (1100.0 * v) + Vector3::from_fn(|_, _| noise.sample(&mut rng));
        pts.push([m.x, m.y, m.z]);
    }
    let fit = fit_f32(&to_f32(&pts), Model::Ellipsoid).unwrap();
    let d = RelDiff::of(&fit, &ref_fit(&pts, Model::Ellipsoid));
    println!("hemisphere sweep: f32-f64 {d:?}");
    assert!(d.max() < 1e-4, "{d:?}");
}

// ---------------------------------------------------------------- real data

struct RealResult {
    fit: MagFit,
    d64: RelDiff,
    pct: f32,
    rms: f32,
}

fn real_fit(pts: &[[f64; 3]], model: Model) -> RealResult {
    let p32 = to_f32(pts);
    let fit = fit_f32(&p32, model).unwrap();
    let reference = ref_fit(pts, model);
    let d64 = RelDiff::of(&fit, &reference);
    let q = fit.quality(p32.iter().copied()).unwrap();
    // The f32 quality pass agrees with the same metric computed in f64 for the f32 fit.
    let as64 = RefFit {
        center: Vector3::new(
            fit.center[0] as f64,
            fit.center[1] as f64,
            fit.center[2] as f64,
        ),
        w: Matrix3::from_fn(|i, j| fit.matrix[i][j] as f64),
        radius: fit.radius as f64,
    };
    let (pct64, rms64) = as64.quality(pts);
    assert!(
        (q.fit_error_pct as f64 - pct64).abs() < 1e-4 * pct64,
        "{q:?} {pct64}"
    );
    assert!(
        (q.rms_radius_error as f64 - rms64).abs() < 1e-4 * rms64,
        "{q:?} {rms64}"
    );
    assert_eq!(q.samples as usize, pts.len());
    RealResult {
        fit,
        d64,
        pct: q.fit_error_pct,
        rms: q.rms_radius_error,
    }
}

fn print_result(name: &str, model: Model, r: &RealResult) {
    let axes = r.fit.semi_axes().unwrap();
    println!(
        "{name} {model:?}: centre ({:.2}, {:.2}, {:.2}) R {:.2} semi-axes ({:.1}, {:.1}, {:.1}) \
         fit_error {:.3} % rms {:.2} | f32-f64 centre {:.1e} R {:.1e} W {:.1e}",
        r.fit.center[0],
        r.fit.center[1],
        r.fit.center[2],
        r.fit.radius,
        axes[0],
        axes[1],
        axes[2],
        r.pct,
        r.rms,
        r.d64.center,
        r.d64.radius,
        r.d64.matrix
    );
}

#[test]
fn qmc5883l_all_models_match_f64_and_ellipsoid_beats_sphere() {
    for name in ["noisy_raw_data.csv", "filtered_raw_data.csv"] {
        let pts = read_qmc(name);
        assert!(pts.len() > 22_000, "{name}: {} rows", pts.len());
        let res: Vec<RealResult> = MODELS.iter().map(|&m| real_fit(&pts, m)).collect();
        for (m, r) in MODELS.iter().zip(&res) {
            print_result(name, *m, r);
            assert!(r.d64.max() < 1e-4, "{name} {m:?}: {:?}", r.d64);
        }
        let (sphere, axis, ell) = (&res[0], &res[1], &res[2]);
        // The recording is strongly anisotropic (semi-axes ~730..1620, SOURCE.md): a sphere
        // cannot describe it, so its residual is dominated by the shape mismatch, while the
        // ellipsoid's residual is the sensor noise (which is large in this recording, ~60
        // counts rms per axis in the "noisy" file, ~30 in the "filtered" one).
        let noise = diff_noise(&pts);
        println!(
            "{name}: noise estimate {noise:.1}, rms radius error sphere {:.1} axis {:.1} \
             ellipsoid {:.1}; fit error ratio sphere/ellipsoid {:.2}",
            sphere.rms,
            axis.rms,
            ell.rms,
            sphere.pct / ell.pct
        );
        assert!(
            (ell.rms as f64) < 1.3 * noise,
            "{name}: {} vs noise {noise}",
            ell.rms
        );
        assert!(
            (sphere.rms as f64) > 3.0 * noise,
            "{name}: {} vs noise {noise}",
            sphere.rms
        );
        assert!(
            ell.pct * 2.5 < sphere.pct,
            "{name}: {} vs {}",
            ell.pct,
            sphere.pct
        );
        assert!(ell.pct <= axis.pct && axis.pct < sphere.pct);
        // Semi-axis spread of the ellipsoid fit ≈ 2.2:1 (SOURCE.md: ≈ 749 / 1029 / 1626).
        let ax = ell.fit.semi_axes().unwrap();
        assert!(ax[2] / ax[0] > 1.8 && ax[2] / ax[0] < 2.6, "{ax:?}");
    }
}

#[test]
fn qmc5883l_compared_with_source_md_and_authors_parameters() {
    let noisy = read_qmc("noisy_raw_data.csv");
    let ell = real_fit(&noisy, Model::Ellipsoid);
    let sph = real_fit(&noisy, Model::Sphere);
    let axes = ell.fit.semi_axes().unwrap();
    println!("noisy ellipsoid centre {:?} axes {axes:?}", ell.fit.center);
    println!("noisy sphere centre {:?}", sph.fit.center);

    // Same algorithm, independent implementation: aleksandrbazhin/ellipsoid_fit_python's
    // `ellipsoid_fit` (Petrov's trace-normalised fit, numpy float64), run on this file:
    // centre (6147.0716, 259.1297, 3447.3323), radii (727.993, 1071.786, 1619.523).
    let numpy_c = [6147.0716, 259.1297, 3447.3323];
    let numpy_ax = [727.993, 1071.786, 1619.523];
    for i in 0..3 {
        // f32 near 6000 has a 5e-4 ulp: 0.01 counts is rounding plus print precision.
        assert!(
            (ell.fit.center[i] as f64 - numpy_c[i]).abs() < 0.01,
            "{:?}",
            ell.fit.center
        );
        assert!((axes[i] as f64 - numpy_ax[i]).abs() < 0.01, "{axes:?}");
    }

    // SOURCE.md ("my fits"): centre ≈ (6135, 249, 3443), semi-axes ≈ 749 / 1029 / 1626,
    // sphere centre y ≈ 3. Those numbers are the constant-normalised ("= 1") ellipsoid
    // criterion, which the f64 helper reproduces to the count; ours differs from it by
    // ~1.5 % of R on this very noisy recording (different algebraic criteria weight the
    // ~6 % residuals differently), so that difference is reported, not asserted.
    let unit = unit_rhs_fit(&noisy, false);
    let src_c = [6135.0, 249.0, 3443.0];
    let src_ax = [749.0, 1029.0, 1626.0];
    let unit_ax = unit.semi_axes();
    for i in 0..3 {
        assert!((unit.center[i] - src_c[i]).abs() < 1.0, "{:?}", unit.center);
        assert!((unit_ax[i] - src_ax[i]).abs() < 1.0, "{unit_ax:?}");
    }
    println!(
        "'= 1' criterion centre {:?} axes {unit_ax:?}; ours differs by {:?}",
        unit.center,
        RelDiff::of(&ell.fit, &unit)
    );
    // The sphere fit (Kåsa, same criterion as SOURCE.md's) does reproduce y ≈ 3.
    assert!(
        (sph.fit.center[1] as f64 - 3.0).abs() < 1.0,
        "{:?}",
        sph.fit.center
    );

    // The authors' result m_cal = A·m_raw + B (their own optimisation, unit sphere):
    // centre = −A⁻¹B. Different method (their own optimisation, possibly on a different data
    // selection), so we only check it is the same ellipsoid to within 3 % of R, about twice
    // the spread between algebraic criteria seen above on this noisy recording.
    let vals: Vec<f64> = read_text("qmc5883l_mag_tomisuarez/reference_params_mag.csv")
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.trim().parse().unwrap())
        .collect();
    assert_eq!(vals.len(), 12);
    let a = Matrix3::from_row_slice(&vals[..9]);
    let b = Vector3::new(vals[9], vals[10], vals[11]);
    let c_auth = -a.try_inverse().unwrap() * b;
    let c_f = Vector3::new(
        ell.fit.center[0] as f64,
        ell.fit.center[1] as f64,
        ell.fit.center[2] as f64,
    );
    // Authors' A vs ours W/R: both map the ellipsoid to the unit sphere; compare AᵀA with
    // (W/R)² (rotation-free).
    let w = Matrix3::from_fn(|i, j| ell.fit.matrix[i][j] as f64) / ell.fit.radius as f64;
    let ata = a.transpose() * a;
    let ww = w * w;
    let shape = (ata - ww).norm() / ww.norm();
    println!(
        "authors' centre {c_auth:?}, ours {c_f:?}, |Δ| = {:.2} counts = {:.2e} R; \
         ‖AᵀA − (W/R)²‖/‖(W/R)²‖ = {shape:.3e}; asymmetry of A {:.3e}",
        (c_auth - c_f).norm(),
        (c_auth - c_f).norm() / ell.fit.radius as f64,
        (a - a.transpose()).norm() / a.norm()
    );
    assert!((c_auth - c_f).norm() < 0.03 * ell.fit.radius as f64);
    assert!(shape < 0.05);

    // The seed's literal axis-aligned form (`… = 1`, raw coordinates, f64) vs our
    // trace-normalised axis fit: report only (different algebraic criterion).
    let seed = unit_rhs_fit(&noisy, true);
    let axis = real_fit(&noisy, Model::Axis);
    println!(
        "seed '=1' axis form: centre {:?} R {:.2}; ours {:?} R {:.2}; diff {:?}",
        seed.center,
        seed.radius,
        axis.fit.center,
        axis.fit.radius,
        RelDiff::of(&axis.fit, &seed)
    );
}

#[test]
fn mag_out_all_models_match_f64() {
    let pts = read_mag_out();
    assert_eq!(pts.len(), 347);
    let res: Vec<RealResult> = MODELS.iter().map(|&m| real_fit(&pts, m)).collect();
    for (m, r) in MODELS.iter().zip(&res) {
        print_result("mag_out", *m, r);
        assert!(r.d64.max() < 1e-4, "{m:?}: {:?}", r.d64);
    }
    // The repository's own `ellipsoid_fit` (numpy float64) on this file gives centre
    // (−68.10391, 82.87299, −133.42923), radii (163.5423, 170.9441, 187.6559).
    let ell = &res[2];
    let numpy_c = [-68.10391, 82.87299, -133.42923];
    let numpy_ax = [163.5423, 170.9441, 187.6559];
    let axes = ell.fit.semi_axes().unwrap();
    for i in 0..3 {
        assert!(
            (ell.fit.center[i] as f64 - numpy_c[i]).abs() < 1e-3,
            "{:?}",
            ell.fit.center
        );
        assert!((axes[i] as f64 - numpy_ax[i]).abs() < 1e-3, "{axes:?}");
    }
    // SOURCE.md: ellipsoid centre ≈ (−64.8, 79.6, −130.1), semi-axes ≈ 163/169/198 — the
    // "= 1" criterion again (reproduced here); sphere r ≈ 173 (ours 172.55).
    let unit = unit_rhs_fit(&pts, false);
    let unit_ax = unit.semi_axes();
    let src_c = [-64.8, 79.6, -130.1];
    let src_ax = [163.0, 169.0, 198.0];
    for i in 0..3 {
        assert!((unit.center[i] - src_c[i]).abs() < 0.1, "{:?}", unit.center);
        assert!((unit_ax[i] - src_ax[i]).abs() < 1.0, "{unit_ax:?}");
    }
    println!(
        "mag_out: '= 1' criterion vs ours {:?}",
        RelDiff::of(&ell.fit, &unit)
    );
    assert!(
        (res[0].fit.radius - 173.0).abs() < 1.0,
        "{}",
        res[0].fit.radius
    );
}

// ---------------------------------------------------------------- calibration output

#[test]
fn to_calibration_gives_unit_field() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (_, pts) = simulate(
        &mut rng,
        2000,
        [0.7, 1.0, 1.4],
        true,
        [500.0, -700.0, 300.0],
        300.0,
        1.0,
    );
    let p32 = to_f32(&pts);
    let fit = fit_f32(&p32, Model::Ellipsoid).unwrap();
    let cal = fit.to_calibration();
    cal.validate().unwrap();
    assert_eq!(cal.bias, fit.center);
    let mags: Vec<f64> = p32
        .iter()
        .map(|m| {
            let a = cal.correct_linear(*m);
            (a[0] as f64).hypot(a[1] as f64).hypot(a[2] as f64)
        })
        .collect();
    let mean = mags.iter().sum::<f64>() / mags.len() as f64;
    let rms = (mags.iter().map(|m| (m - 1.0).powi(2)).sum::<f64>() / mags.len() as f64).sqrt();
    // Noise σ = 1 count on R = 300: |a| = 1 ± 1/300.
    assert!((mean - 1.0).abs() < 1e-3, "{mean}");
    let q = fit.quality(p32.iter().copied()).unwrap();
    assert!((rms - q.rms_radius_error as f64 / fit.radius as f64).abs() < 1e-4);
}

// ---------------------------------------------------------------- degenerate input

fn all_errors(pts: &[[f32; 3]]) -> [Result<MagFit, Error>; 3] {
    [
        fit_f32(pts, Model::Sphere),
        fit_f32(pts, Model::Axis),
        fit_f32(pts, Model::Ellipsoid),
    ]
}

#[test]
fn too_few_samples() {
    let pts: Vec<[f32; 3]> = (0..8)
        .map(|i| [i as f32, (i * i) as f32, (i % 3) as f32])
        .collect();
    assert_eq!(
        fit_f32(&pts[..3], Model::Sphere),
        Err(Error::TooFewSamples { needed: 4, got: 3 })
    );
    assert_eq!(
        fit_f32(&pts[..5], Model::Axis),
        Err(Error::TooFewSamples { needed: 6, got: 5 })
    );
    assert_eq!(
        fit_f32(&pts, Model::Ellipsoid),
        Err(Error::TooFewSamples { needed: 9, got: 8 })
    );
    assert_eq!(
        SphereFit::new().solve(),
        Err(Error::TooFewSamples { needed: 4, got: 0 })
    );
    assert_eq!(
        ResidualAccumulator::new(MagFit {
            center: [0.0; 3],
            matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            radius: 1.0
        })
        .finish(),
        Err(Error::TooFewSamples { needed: 1, got: 0 })
    );
}

#[test]
fn degenerate_geometry_is_refused() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let off = Vector3::new(6135.0, 249.0, 3443.0);
    let rot = Rotation3::from_euler_angles(0.3, 0.5, -0.2).into_inner();
    // Planar: a full circle (and a filled disc) in a tilted plane, far from the origin.
    let circle: Vec<[f32; 3]> = (0..500)
        .map(|i| {
            let t = i as f64 * 0.05;
            let r = if i % 2 == 0 {
                1000.0
            } else {
                rng.random_range(0.0..1000.0)
            };
            let p = off + rot * Vector3::new(r * t.cos(), 0.7 * r * t.sin(), 0.0);
            [p.x as f32, p.y as f32, p.z as f32]
        })
        .collect();
    // Collinear.
    let line: Vec<[f32; 3]> = (0..500)
        .map(|i| {
            let p = off + rot * Vector3::new(i as f64 - 250.0, 0.0, 0.0);
            [p.x as f32, p.y as f32, p.z as f32]
        })
        .collect();
    // One point, repeated.
    let single = vec![[6135.0f32, 249.0, 3443.0]; 100];
    for (name, pts) in [("plane", &circle), ("line", &line), ("point", &single)] {
        for (m, r) in MODELS.iter().zip(all_errors(pts)) {
            assert_eq!(r, Err(Error::DegenerateGeometry), "{name} {m:?}");
        }
    }
}

#[test]
fn hyperboloid_is_not_an_ellipsoid() {
    // Points on the one-sheet hyperboloid x² + y² − z² = R²: the best quadric has a negative
    // eigenvalue.
    let pts: Vec<[f32; 3]> = (0..400)
        .map(|i| {
            let t = i as f64 * 0.37;
            let z = -600.0 + 1200.0 * (i as f64 / 400.0);
            let rho = (500.0f64 * 500.0 + z * z).sqrt();
            [
                (1000.0 + rho * t.cos()) as f32,
                (rho * t.sin()) as f32,
                (2000.0 + z) as f32,
            ]
        })
        .collect();
    assert_eq!(fit_f32(&pts, Model::Ellipsoid), Err(Error::NotAnEllipsoid));
    assert_eq!(fit_f32(&pts, Model::Axis), Err(Error::NotAnEllipsoid));
}

#[test]
fn nan_and_inf_are_rejected_and_leave_the_accumulator_unchanged() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (_, pts) = simulate(
        &mut rng,
        200,
        [0.8, 1.0, 1.2],
        true,
        [100.0, 200.0, 300.0],
        50.0,
        0.5,
    );
    let p32 = to_f32(&pts);
    let mut e = EllipsoidFit::new();
    let mut s = SphereFit::new();
    let mut a = AxisEllipsoidFit::new();
    for (k, p) in p32.iter().enumerate() {
        if k == 50 {
            for bad in [
                [f32::NAN, 0.0, 0.0],
                [0.0, f32::INFINITY, 0.0],
                [0.0, 0.0, f32::NEG_INFINITY],
            ] {
                let (e0, s0, a0) = (e.clone(), s.clone(), a.clone());
                assert_eq!(e.push(bad), Err(Error::NonFinite));
                assert_eq!(s.push(bad), Err(Error::NonFinite));
                assert_eq!(a.push(bad), Err(Error::NonFinite));
                assert_eq!((&e, &s, &a), (&e0, &s0, &a0));
            }
        }
        e.push(*p).unwrap();
        s.push(*p).unwrap();
        a.push(*p).unwrap();
    }
    assert_eq!(e.count(), 200);
    let fit = e.solve().unwrap();
    let mut clean = EllipsoidFit::new();
    for p in &p32 {
        clean.push(*p).unwrap();
    }
    assert_eq!(fit, clean.solve().unwrap());
    let mut q = ResidualAccumulator::new(fit);
    assert_eq!(q.push([f32::NAN, 1.0, 1.0]), Err(Error::NonFinite));
    assert_eq!(q.count(), 0);

    // Finite samples whose difference from the origin (first sample) overflows f32.
    let mut e = EllipsoidFit::new();
    e.push([-3.0e38, 0.0, 0.0]).unwrap();
    let e0 = e.clone();
    assert_eq!(e.push([3.0e38, 0.0, 0.0]), Err(Error::NonFinite));
    assert_eq!(e, e0);
}

// ---------------------------------------------------------------- no panics

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn arbitrary_f32_input_never_panics(
        pts in proptest::collection::vec(proptest::array::uniform3(proptest::num::f32::ANY), 0..40)
    ) {
        let mut s = SphereFit::new();
        let mut a = AxisEllipsoidFit::new();
        let mut e = EllipsoidFit::new();
        for p in &pts {
            let _ = s.push(*p);
            let _ = a.push(*p);
            let _ = e.push(*p);
        }
        for f in [s.solve(), a.solve(), e.solve()].into_iter().flatten() {
            prop_assert!(f.radius.is_finite() && f.radius > 0.0);
            prop_assert!(f.center.iter().all(|x| x.is_finite()));
            let _ = f.quality(pts.iter().copied());
            let _ = f.semi_axes();
            let _ = f.to_calibration();
        }
    }

    #[test]
    fn near_ellipsoid_input_never_panics(
        pts in proptest::collection::vec(
            proptest::array::uniform3(-1.0e4f32..1.0e4), 0..60),
        scale in -30i32..30,
    ) {
        // Bounded data at scales from 2^-30 to 2^30 (exercises the power-of-two rescaling).
        let mut e = EllipsoidFit::new();
        for p in &pts {
            let q = [p[0] * 2f32.powi(scale), p[1] * 2f32.powi(scale), p[2] * 2f32.powi(scale)];
            prop_assert!(e.push(q).is_ok());
        }
        if let Ok(f) = e.solve() {
            prop_assert!(f.radius.is_finite());
        }
    }
}
