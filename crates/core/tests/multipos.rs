//! Multi-position fit and static detection against an independent f64 reference, on simulated
//! data with known truth and on the real IMU-TK Xsens recording.

mod common;
use common::data_dir;

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_core::multipos::{fit, fit_weighted, MultiPosConfig, MultiPosModel};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig};
use wiical_core::Error;

/// f64 reference: Levenberg–Marquardt with central-difference Jacobian, written independently
/// of the core (raw units, no normalisation, Marquardt diagonal scaling).
fn reference_fit(poses: &[[f64; 3]], g: f64) -> ([f64; 3], Matrix3<f64>, f64) {
    let r = reference_fit_status(poses, g);
    (r.bias, r.k, r.rms)
}

/// What the f64 reference reached.
struct Reference {
    bias: [f64; 3],
    k: Matrix3<f64>,
    rms: f64,
    /// Stopped because no step improved the cost any more (not by its iteration budget).
    converged: bool,
    /// RMS spread of the poses about their centroid (raw units).
    spread: f64,
    centroid: Vector3<f64>,
}

fn reference_fit_status(poses: &[[f64; 3]], g: f64) -> Reference {
    type V = SVector<f64, 9>;
    let cost_vec = |p: &V| -> Vec<f64> {
        let k = Matrix3::new(p[3], p[4], p[5], 0.0, p[6], p[7], 0.0, 0.0, p[8]);
        let b = Vector3::new(p[0], p[1], p[2]);
        poses
            .iter()
            .map(|m| (k * (Vector3::from(*m) - b)).norm() - g)
            .collect()
    };
    let n = poses.len() as f64;
    let mean = poses
        .iter()
        .fold(Vector3::zeros(), |a, m| a + Vector3::from(*m))
        / n;
    let spread = (poses
        .iter()
        .map(|m| (Vector3::from(*m) - mean).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    let s = g / spread;
    let mut p = V::from([mean.x, mean.y, mean.z, s, 0.0, 0.0, s, 0.0, s]);
    let mut lambda = 1e-3;
    let sumsq = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let mut cost = sumsq(&cost_vec(&p));
    let mut converged = false;
    for _ in 0..500 {
        let (jtj, jtr) = reference_normal(&cost_vec, &p, poses.len(), (spread, s));
        let mut improved = false;
        for _ in 0..40 {
            let mut a = jtj;
            for i in 0..9 {
                a[(i, i)] *= 1.0 + lambda;
            }
            let step = a.lu().solve(&(-jtr)).unwrap();
            let cand = p + step;
            let c = sumsq(&cost_vec(&cand));
            if c < cost {
                let rel = (cost - c) / cost.max(1e-300);
                p = cand;
                cost = c;
                lambda *= 0.3;
                improved = rel > 1e-15;
                break;
            }
            lambda *= 5.0;
        }
        if !improved {
            converged = true;
            break;
        }
    }
    let k = Matrix3::new(p[3], p[4], p[5], 0.0, p[6], p[7], 0.0, 0.0, p[8]);
    Reference {
        bias: [p[0], p[1], p[2]],
        k,
        rms: (cost / n).sqrt(),
        converged,
        spread,
        centroid: mean,
    }
}

/// The Gauss–Newton normal equations `JᵀJ`, `Jᵀr` of [`reference_fit_status`] at `p` over
/// its `n` poses, with a central-difference Jacobian of `cost_vec` (relative steps, at least
/// `spread` for the bias and `s` for the matrix). Apart from the damping loop so that each
/// reads alone.
fn reference_normal(
    cost_vec: &impl Fn(&SVector<f64, 9>) -> Vec<f64>,
    p: &SVector<f64, 9>,
    n: usize,
    (spread, s): (f64, f64),
) -> (SMatrix<f64, 9, 9>, SVector<f64, 9>) {
    let r = cost_vec(p);
    let mut j = vec![[0.0f64; 9]; n];
    for c in 0..9 {
        let h = 1e-6 * p[c].abs().max(if c < 3 { spread } else { s });
        let (mut pp, mut pm) = (*p, *p);
        pp[c] += h;
        pm[c] -= h;
        let (rp, rm) = (cost_vec(&pp), cost_vec(&pm));
        for i in 0..n {
            j[i][c] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    let mut jtj = SMatrix::<f64, 9, 9>::zeros();
    let mut jtr = SVector::<f64, 9>::zeros();
    for i in 0..n {
        for a in 0..9 {
            jtr[a] += j[i][a] * r[i];
            for b in 0..9 {
                jtj[(a, b)] += j[i][a] * j[i][b];
            }
        }
    }
    (jtj, jtr)
}

/// Smallest eigenvalue of the unit-diagonal `JᵀJ` at the reference's solution, with a
/// central-difference Jacobian in raw units (scale-free, so comparable with the core's
/// `identifiability` whatever the parametrisation's units).
fn reference_identifiability(poses: &[[f64; 3]], r: &Reference) -> f64 {
    let p0 = [
        r.bias[0],
        r.bias[1],
        r.bias[2],
        r.k[(0, 0)],
        r.k[(0, 1)],
        r.k[(0, 2)],
        r.k[(1, 1)],
        r.k[(1, 2)],
        r.k[(2, 2)],
    ];
    let res = |p: &[f64; 9], m: &[f64; 3]| {
        let k = Matrix3::new(p[3], p[4], p[5], 0.0, p[6], p[7], 0.0, 0.0, p[8]);
        (k * (Vector3::from(*m) - Vector3::new(p[0], p[1], p[2]))).norm()
    };
    let mut jtj = SMatrix::<f64, 9, 9>::zeros();
    for m in poses {
        let mut row = [0.0; 9];
        for (c, slot) in row.iter_mut().enumerate() {
            let h = 1e-6
                * p0[c]
                    .abs()
                    .max(if c < 3 { r.spread } else { 1e-3 / r.spread });
            let (mut a, mut b) = (p0, p0);
            a[c] += h;
            b[c] -= h;
            *slot = (res(&a, m) - res(&b, m)) / (2.0 * h);
        }
        for a in 0..9 {
            for b in 0..9 {
                jtj[(a, b)] += row[a] * row[b];
            }
        }
    }
    let d = SVector::<f64, 9>::from_fn(|i, _| 1.0 / jtj[(i, i)].sqrt());
    let scaled = SMatrix::<f64, 9, 9>::from_fn(|a, b| jtj[(a, b)] * d[a] * d[b]);
    scaled.symmetric_eigen().eigenvalues.min()
}

/// Relative agreement of an f32 fit with the f64 reference: bias difference in units of the
/// sensor's scale (raw units per g, 1/‖K‖), and matrix difference relative to ‖K‖ (max norm).
fn relative_differences(
    bias: [f32; 3],
    k: [[f32; 3]; 3],
    rb: [f64; 3],
    rk: &Matrix3<f64>,
) -> (f64, f64) {
    let kmax = rk.amax();
    let scale = 1.0 / kmax;
    let db = (0..3)
        .map(|i| (bias[i] as f64 - rb[i]).abs())
        .fold(0.0, f64::max)
        / scale;
    let dk = (0..3)
        .flat_map(|r| (0..3).map(move |c| (r, c)))
        .map(|(r, c)| (k[r][c] as f64 - rk[(r, c)]).abs())
        .fold(0.0, f64::max)
        / kmax;
    (db, dk)
}

fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// A Wiimote-like truth: ~105 counts/g (10-bit), bias near 512, small cross-axis terms,
/// expressed as the upper-triangular K that the fit must return.
fn wiimote_truth() -> (Matrix3<f64>, Vector3<f64>) {
    let k = Matrix3::new(
        1.0 / 106.0,
        0.8e-4,
        -1.1e-4,
        0.0,
        1.0 / 104.5,
        0.6e-4,
        0.0,
        0.0,
        1.0 / 110.2,
    );
    (k, Vector3::new(521.3, 519.8, 524.6))
}

#[test]
fn recovers_truth_from_noiseless_poses_and_matches_f64() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (k, b) = wiimote_truth();
    let d = k.try_inverse().unwrap();
    let poses64: Vec<[f64; 3]> = (0..30)
        .map(|_| {
            let m = d * random_unit(&mut rng) + b;
            [m.x, m.y, m.z]
        })
        .collect();
    let poses: Vec<[f32; 3]> = poses64.iter().map(|p| p.map(|x| x as f32)).collect();
    let got = fit(&poses, &MultiPosConfig::default()).unwrap();
    let (db, dk) = relative_differences(got.calibration.bias, got.calibration.matrix, b.into(), &k);
    // Exact data: truth within f32 resolution of the inputs (ulp of ~600 is 6e-5 counts).
    assert!(db < 2e-5 && dk < 2e-5, "vs truth: db {db:e} dk {dk:e}");
    let (rb, rk, _) = reference_fit(&poses64, 1.0);
    let (db, dk) = relative_differences(got.calibration.bias, got.calibration.matrix, rb, &rk);
    assert!(db < 1e-4 && dk < 1e-4, "vs f64: db {db:e} dk {dk:e}");
    assert!(got.rms < 1e-5);
}

#[test]
fn noisy_poses_f32_matches_f64_and_truth_within_noise() {
    for seed in 0..20u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
        let (k, b) = wiimote_truth();
        let d = k.try_inverse().unwrap();
        // Pose means of ~300 samples with 1-count noise: σ ≈ 0.06 counts.
        let noise = Normal::new(0.0, 0.06).unwrap();
        let poses64: Vec<[f64; 3]> = (0..30)
            .map(|_| {
                let m = d * random_unit(&mut rng) + b;
                [
                    m.x + noise.sample(&mut rng),
                    m.y + noise.sample(&mut rng),
                    m.z + noise.sample(&mut rng),
                ]
            })
            .collect();
        let poses: Vec<[f32; 3]> = poses64.iter().map(|p| p.map(|x| x as f32)).collect();
        let got = fit(&poses, &MultiPosConfig::default()).unwrap();
        let (rb, rk, rrms) = reference_fit(&poses64, 1.0);
        let (db, dk) = relative_differences(got.calibration.bias, got.calibration.matrix, rb, &rk);
        assert!(
            db < 1e-4 && dk < 1e-4,
            "seed {seed}: vs f64 db {db:e} dk {dk:e}"
        );
        assert!(((got.rms as f64) - rrms).abs() < 1e-3 * rrms + 1e-7);
        // Against truth: a 0.06-count error on ~105 counts/g is 6e-4 relative; 30 poses
        // average it down, so 3e-3 is a generous (≈ 5σ) bound.
        let (tb, tk) =
            relative_differences(got.calibration.bias, got.calibration.matrix, b.into(), &k);
        assert!(
            tb < 3e-3 && tk < 3e-3,
            "seed {seed}: vs truth db {tb:e} dk {tk:e}"
        );
    }
}

#[test]
fn diagonal_model_and_weights() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let k = Matrix3::from_diagonal(&Vector3::new(1.0 / 4000.0, 1.0 / 3950.0, 1.0 / 4100.0));
    let b = Vector3::new(33120.0, 33280.0, 32360.0);
    let d = k.try_inverse().unwrap();
    let mut poses: Vec<[f32; 3]> = (0..8)
        .map(|_| {
            let m = d * random_unit(&mut rng) + b;
            [m.x as f32, m.y as f32, m.z as f32]
        })
        .collect();
    let cfg = MultiPosConfig {
        model: MultiPosModel::Diagonal,
        ..Default::default()
    };
    let got = fit(&poses, &cfg).unwrap();
    let (db, dk) = relative_differences(got.calibration.bias, got.calibration.matrix, b.into(), &k);
    assert!(db < 1e-4 && dk < 1e-4, "db {db:e} dk {dk:e}");
    // A wild pose with weight 0 changes nothing.
    poses.push([40000.0, 20000.0, 30000.0]);
    let mut w = vec![1.0f32; poses.len()];
    *w.last_mut().unwrap() = 0.0;
    let got2 = fit_weighted(&poses, Some(&w), &cfg).unwrap();
    let (db, dk) =
        relative_differences(got2.calibration.bias, got2.calibration.matrix, b.into(), &k);
    assert!(db < 1e-4 && dk < 1e-4, "weighted: db {db:e} dk {dk:e}");
    // Too few effective poses for the full model.
    assert_eq!(
        fit_weighted(&poses, Some(&w), &MultiPosConfig::default()).unwrap_err(),
        Error::TooFewPoses { needed: 9, got: 8 }
    );
}

#[test]
fn bad_geometry_and_input_are_typed_errors() {
    let (k, b) = wiimote_truth();
    let d = k.try_inverse().unwrap();
    // All poses rotated about z only: gravity directions in one plane.
    let planar: Vec<[f32; 3]> = (0..20)
        .map(|i| {
            let th = i as f64 * 0.3;
            let m = d * Vector3::new(th.cos(), th.sin(), 0.0) + b;
            [m.x as f32, m.y as f32, m.z as f32]
        })
        .collect();
    assert_eq!(
        fit(&planar, &MultiPosConfig::default()).unwrap_err(),
        Error::DegenerateGeometry
    );
    assert_eq!(
        fit(&planar[..5], &MultiPosConfig::default()).unwrap_err(),
        Error::TooFewPoses { needed: 9, got: 5 }
    );
    assert_eq!(
        fit(&[[512.0; 3]; 12], &MultiPosConfig::default()).unwrap_err(),
        Error::DegenerateGeometry
    );
    let mut bad = planar.clone();
    bad[3][1] = f32::INFINITY;
    assert_eq!(
        fit(&bad, &MultiPosConfig::default()).unwrap_err(),
        Error::NonFinite
    );
    let cfg = MultiPosConfig {
        reference_magnitude: -1.0,
        ..Default::default()
    };
    assert_eq!(fit(&planar, &cfg).unwrap_err(), Error::InvalidParameter);
}

/// The real IMU-TK Xsens recording: detect static windows with the core's streaming detector,
/// fit in f32, and compare with the f64 reference on f64 means of the same windows.
#[test]
fn imu_tk_xsens_real_recording() {
    let text = std::fs::read_to_string(data_dir().join("imu_tk_xsens/xsens_acc.mat")).unwrap();
    let samples: Vec<[f64; 3]> = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[1], v[2], v[3]]
        })
        .collect();
    assert_eq!(samples.len(), 51175);
    let cfg = StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0);
    let mut det: StaticDetector<101> = StaticDetector::new(cfg).unwrap();
    let mut intervals = Vec::new();
    for s in &samples {
        if let Some(iv) = det.push(s.map(|x| x as f32)).unwrap() {
            intervals.push(iv);
        }
    }
    intervals.extend(det.finish());
    assert!(
        intervals.len() >= 35,
        "found {} static windows",
        intervals.len()
    );

    // f32 means from the detector vs f64 means of the same samples.
    let means64: Vec<[f64; 3]> = intervals
        .iter()
        .map(|iv| {
            let s = &samples[iv.start as usize..iv.end as usize];
            let n = s.len() as f64;
            [0, 1, 2].map(|a| s.iter().map(|v| v[a]).sum::<f64>() / n)
        })
        .collect();
    for (iv, m) in intervals.iter().zip(&means64) {
        for a in 0..3 {
            assert!(
                (iv.mean[a] as f64 - m[a]).abs() < 0.01,
                "{:?} vs {m:?}",
                iv.mean
            );
        }
    }
    let means: Vec<[f32; 3]> = intervals.iter().map(|iv| iv.mean).collect();
    let got = fit(&means, &MultiPosConfig::default()).unwrap();
    let (rb, rk, rrms) = reference_fit(&means64, 1.0);
    let (db, dk) = relative_differences(got.calibration.bias, got.calibration.matrix, rb, &rk);
    assert!(db < 1e-4 && dk < 1e-4, "vs f64: db {db:e} dk {dk:e}");
    let rms_mg = 1000.0 * got.rms;
    eprintln!(
        "xsens: {} windows, rms {rms_mg:.4} mg (f64 {:.4} mg), f32-vs-f64 bias {db:.2e}, K {dk:.2e}",
        intervals.len(),
        rrms * 1000.0
    );
    assert!(rms_mg < 0.5, "rms {rms_mg} mg");
    assert!(
        (got.rms as f64 - rrms).abs() < 0.02 * rrms,
        "{} vs {rrms}",
        got.rms
    );
    // The authors' nominal offsets (IMU-TK calibrate.m: 33123, 33276, 32360) are settings,
    // not truth, but an independent fit should land within a few counts of them.
    for (got, nominal) in got.calibration.bias.iter().zip([33123.0, 33276.0, 32360.0]) {
        assert!(
            (got - nominal).abs() < 10.0,
            "bias {got} vs nominal {nominal}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]
    /// No input makes the solver panic: any f32 values, any count.
    #[test]
    fn fit_never_panics(poses in prop::collection::vec(prop::array::uniform3(any::<f32>()), 0..40),
                        diag in any::<bool>()) {
        let cfg = MultiPosConfig {
            model: if diag { MultiPosModel::Diagonal } else { MultiPosModel::Full },
            ..Default::default()
        };
        let _ = fit(&poses, &cfg);
    }

    /// Plausible but random pose sets (finite, moderate values) also never panic, and any
    /// success is a valid calibration.
    #[test]
    fn fit_on_finite_points_returns_valid_or_error(
        poses in prop::collection::vec(prop::array::uniform3(-2000.0f32..2000.0), 0..30)) {
        if let Ok(f) = fit(&poses, &MultiPosConfig::default()) {
            prop_assert!(f.calibration.validate().is_ok());
            prop_assert!(f.rms.is_finite());
        }
    }

    /// The detector never panics on arbitrary streams.
    #[test]
    fn detector_never_panics(samples in prop::collection::vec(prop::array::uniform3(any::<f32>()), 0..400)) {
        let cfg = StaticDetectorConfig { window: 11, init_samples: 20, threshold_factor: 6.0,
            min_static_samples: 5, min_variance: 1.0 / 12.0 };
        let mut d: StaticDetector<15> = StaticDetector::new(cfg).unwrap();
        for s in samples {
            let _ = d.push(s);
        }
        let _ = d.finish();
    }
}

/// Random subsets (9 to 40 windows, 30 per file, seeded) of the static windows (f64 means) that
/// the adaptive detector finds in five real recordings: `(file, means)`.
fn real_window_subsets() -> Vec<(&'static str, Vec<[f64; 3]>)> {
    use wiical_core::static_detect::adaptive;
    let files = [
        "imu_tk_xsens/xsens_acc.mat",
        "acc_mag_ck_explorer/acc_log.csv",
        "mpu9150_mikoff_5units/imu0.csv",
        "mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv",
        "mpu6050_multipos_tomisuarez/example_data_calibration.csv",
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut out = Vec::new();
    for rel in files {
        let (xyz, rate) = common::load_accelerometer(&data_dir().join(rel));
        let samples: Vec<[f32; 3]> = xyz.iter().map(|s| s.map(|v| v as f32)).collect();
        let mut means64 = Vec::new();
        adaptive::detect::<511, _>(
            samples.iter().copied(),
            rate.unwrap_or(100.0) as f32,
            12,
            |iv| {
                let s = &xyz[iv.start as usize..iv.end as usize];
                let n = s.len() as f64;
                means64.push([0, 1, 2].map(|a| s.iter().map(|v| v[a]).sum::<f64>() / n));
            },
        )
        .unwrap();
        for _ in 0..30 {
            let k = rng.random_range(9..=means64.len().min(40));
            let mut pick: Vec<[f64; 3]> = means64.clone();
            for i in 0..k {
                let j = rng.random_range(i..pick.len());
                pick.swap(i, j);
            }
            pick.truncate(k);
            out.push((rel, pick));
        }
    }
    out
}

/// Solver robustness on real data: the sets of [`real_window_subsets`],
/// fitted by the core in f32 and by the independent f64 reference. Wherever the reference
/// converges to a finite, well-determined minimum the core must converge to the same RMS;
/// wherever the core refuses (diverged / not converged / degenerate) the reference must have
/// failed too or found an ill-determined minimum. (SciPy on the same sets:
/// `dump_window_subsets_for_scipy` below and `scripts/peers/solver_check.py`.)
#[test]
fn solver_converges_where_the_f64_reference_does_on_real_window_subsets() {
    let (mut both_ok, mut both_refuse, mut ill_determined, mut only_core) = (0, 0, 0, 0);
    for (rel, pick) in real_window_subsets() {
        let k = pick.len();
        let p32: Vec<[f32; 3]> = pick.iter().map(|m| m.map(|x| x as f32)).collect();
        let ours = fit(&p32, &MultiPosConfig::default());
        let r = reference_fit_status(&pick, 1.0);
        let finite = r.converged
            && (Vector3::from(r.bias) - r.centroid).norm() < 100.0 * r.spread
            && r.rms.is_finite();
        let ident = if finite {
            reference_identifiability(&pick, &r)
        } else {
            0.0
        };
        let well_determined = finite && ident > 1e-4;
        match &ours {
            Ok(f) => {
                if finite {
                    let d = (f.rms as f64 - r.rms).abs();
                    assert!(
                        d < 1e-3 * r.rms + 2e-6,
                        "{rel} k={k}: rms {} vs {}",
                        f.rms,
                        r.rms
                    );
                    both_ok += 1;
                } else {
                    only_core += 1;
                }
            }
            Err(e) => {
                assert!(
                    matches!(
                        e,
                        Error::Diverged | Error::NotConverged | Error::DegenerateGeometry
                    ),
                    "{rel} k={k}: {e:?}"
                );
                assert!(
                    !well_determined,
                    "{rel} k={k}: core {e:?} but the reference converged (rms {} g, \
                         identifiability {ident:e})",
                    r.rms
                );
                if finite {
                    ill_determined += 1;
                } else {
                    both_refuse += 1;
                }
            }
        }
    }
    eprintln!(
        "subsets: {both_ok} fitted by both, {only_core} by the core only, {both_refuse} refused \
         by both, {ill_determined} refused by the core where the reference's minimum is \
         ill-determined"
    );
    assert!(both_ok > 100, "{both_ok}");
}

/// Writes the sets of [`real_window_subsets`] with the core's outcome as JSON to the file named
/// by `WIICAL_SOLVER_SETS`, for `scripts/peers/solver_check.py` (SciPy). Run with
/// `WIICAL_SOLVER_SETS=/tmp/sets.json cargo test -p wiical-core --test multipos -- --ignored dump`.
#[test]
#[ignore]
fn dump_window_subsets_for_scipy() {
    let path = std::env::var("WIICAL_SOLVER_SETS").expect("set WIICAL_SOLVER_SETS to a file");
    let mut rows = Vec::new();
    for (rel, pick) in real_window_subsets() {
        let p32: Vec<[f32; 3]> = pick.iter().map(|m| m.map(|x| x as f32)).collect();
        let ours = fit(&p32, &MultiPosConfig::default());
        let means: Vec<String> = pick
            .iter()
            .map(|m| format!("[{:e},{:e},{:e}]", m[0], m[1], m[2]))
            .collect();
        let (status, rms) = match ours {
            Ok(f) => ("ok".to_string(), format!("{:e}", f.rms)),
            Err(e) => (format!("{e:?}"), "null".to_string()),
        };
        rows.push(format!(
            "{{\"file\":\"{rel}\",\"core\":\"{status}\",\"core_rms_g\":{rms},\"means\":[{}]}}",
            means.join(",")
        ));
    }
    std::fs::write(&path, format!("[{}]\n", rows.join(",\n"))).unwrap();
}
