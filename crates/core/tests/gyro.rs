//! Gyro calibration (RK4 integration, exact sensitivities, LM fit, leave-one-motion-out) and
//! the zero-rate tracker, against independent f64 code: nalgebra `UnitQuaternion` integration
//! by the exponential map on sub-steps (a different integrator), central-difference
//! Jacobians, and simulated recordings with known truth.

mod common;
use common::data_dir;

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_core::gyro::{Adjustment, GyroCalibration, MotionIntegrator, NPARAM};
use wiical_core::gyro_fit::{
    fit, leave_one_out, motion_spans, rms_angle, GyroFitConfig, GyroModel, Motion,
};
use wiical_core::gyro_zero::{ZeroRateConfig, ZeroRateTracker};
use wiical_core::multipos::{self, MultiPosConfig};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig};
use wiical_core::Error;

const DT: f64 = 0.01;

/// Independent reference: orientation of the end frame in the start frame, integrating
/// `ω = K(m − b)` (linear between samples) with the exponential map on `sub` sub-steps.
fn reference_rotation(
    samples: &[[f64; 3]],
    k: &Matrix3<f64>,
    b: &Vector3<f64>,
    sub: usize,
) -> UnitQuaternion<f64> {
    let mut q = UnitQuaternion::identity();
    let h = DT / sub as f64;
    for pair in samples.windows(2) {
        let w0 = k * (Vector3::from(pair[0]) - b);
        let w1 = k * (Vector3::from(pair[1]) - b);
        for s in 0..sub {
            let t = (s as f64 + 0.5) / sub as f64;
            let w = w0 * (1.0 - t) + w1 * t;
            q *= UnitQuaternion::from_scaled_axis(w * h);
        }
    }
    q
}

/// Reference gravity residual `q⁻¹·g₀ − g₁` (unit vectors).
fn reference_residual(
    m: &RefMotion,
    k: &Matrix3<f64>,
    b: &Vector3<f64>,
    sub: usize,
) -> Vector3<f64> {
    let q = reference_rotation(&m.samples, k, b, sub);
    q.inverse_transform_vector(&m.g0.normalize()) - m.g1.normalize()
}

/// A simulated motion in f64.
#[derive(Clone)]
struct RefMotion {
    samples: Vec<[f64; 3]>,
    g0: Vector3<f64>,
    g1: Vector3<f64>,
}

/// Known truth of a simulated gyro.
struct Truth {
    k: Matrix3<f64>,
    b: Vector3<f64>,
    nominal: GyroCalibration<f64>,
}

/// Scale within ±3 %, misalignment within ±2°, bias near 8000 counts (a MotionPlus-like
/// 14-bit zero), nominal 1e-3 rad/s per count.
fn random_truth(rng: &mut ChaCha8Rng) -> Truth {
    let s0 = 1e-3;
    let deg = std::f64::consts::PI / 180.0;
    let mut k = Matrix3::zeros();
    for i in 0..3 {
        for j in 0..3 {
            k[(i, j)] = if i == j {
                s0 * (1.0 + rng.random_range(-0.03..0.03))
            } else {
                s0 * rng.random_range(-2.0..2.0) * deg
            };
        }
    }
    let b = Vector3::new(8000.0, 8100.0, 7900.0)
        + Vector3::from_fn(|_, _| rng.random_range(-50.0..50.0));
    // Bias from a rest period: off by a fraction of a count.
    let b_rest = b + Vector3::from_fn(|_, _| rng.random_range(-0.2..0.2));
    Truth {
        k,
        b,
        nominal: GyroCalibration::nominal(b_rest.into(), [s0; 3]),
    }
}

/// Random unit vector.
fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// A recording of `poses` static poses joined by motions: each motion turns about a random
/// body axis by 40–140° with a smooth bump profile, plus a wobble about a second axis (so the
/// rotation axis moves, the case where integrators differ). Raw samples carry white noise
/// `noise` counts; gravity directions carry `g_noise` rad.
fn simulate(
    rng: &mut ChaCha8Rng,
    truth: &Truth,
    poses: usize,
    noise: f64,
    g_noise: f64,
) -> Vec<RefMotion> {
    let k_inv = truth.k.try_inverse().unwrap();
    let white = Normal::new(0.0, 1.0).unwrap();
    let mut g = random_unit(rng);
    let mut out = Vec::new();
    for _ in 1..poses {
        let axis = random_unit(rng);
        let wobble_axis = random_unit(rng);
        let angle = rng.random_range(40.0f64..140.0).to_radians();
        let len = rng.random_range(150..300);
        let period = len as f64 * DT;
        let rate = |t: f64| -> Vector3<f64> {
            let bump = angle / period * (1.0 - (2.0 * std::f64::consts::PI * t / period).cos());
            let wob = 0.6 * (2.0 * std::f64::consts::PI * t / period).sin();
            axis * bump + wobble_axis * wob
        };
        // Truth: the exact rates at each sample, integrated finely.
        let mut q = UnitQuaternion::identity();
        let mut samples = Vec::with_capacity(len + 1);
        let sub = 50;
        for i in 0..=len {
            let t = i as f64 * DT;
            let w = rate(t);
            let raw = k_inv * w + truth.b + Vector3::from_fn(|_, _| noise * white.sample(rng));
            samples.push(raw.into());
            if i < len {
                for s in 0..sub {
                    let tm = t + (s as f64 + 0.5) * DT / sub as f64;
                    q *= UnitQuaternion::from_scaled_axis(rate(tm) * DT / sub as f64);
                }
            }
        }
        let g_next = q.inverse_transform_vector(&g);
        let perturb = |v: Vector3<f64>, rng: &mut ChaCha8Rng| {
            (v + Vector3::from_fn(|_, _| g_noise * white.sample(rng))).normalize()
        };
        out.push(RefMotion {
            samples,
            g0: perturb(g, rng),
            g1: perturb(g_next, rng),
        });
        g = g_next;
    }
    out
}

/// Samples and the two gravity directions of one motion, in f32.
type Motion32 = (Vec<[f32; 3]>, Vector3<f32>, Vector3<f32>);

fn to_f32(m: &[RefMotion]) -> Vec<Motion32> {
    m.iter()
        .map(|m| {
            (
                m.samples.iter().map(|s| s.map(|x| x as f32)).collect(),
                m.g0.cast(),
                m.g1.cast(),
            )
        })
        .collect()
}

fn motions_f64(m: &[RefMotion]) -> Vec<Motion<'_, f64>> {
    m.iter()
        .map(|m| Motion {
            samples: &m.samples,
            g_start: m.g0,
            g_end: m.g1,
        })
        .collect()
}

fn cfg<T: nalgebra::RealField + Copy>(model: GyroModel, fit_bias: bool) -> GyroFitConfig<T> {
    GyroFitConfig {
        model,
        fit_bias,
        dt: nalgebra::convert(DT),
        max_iterations: 100,
    }
}

#[test]
fn rk4_rotation_matches_exponential_map_integration() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let truth = random_truth(&mut rng);
    let motions = simulate(&mut rng, &truth, 6, 0.0, 0.0);
    for m in &motions {
        let reference = reference_rotation(&m.samples, &truth.k, &truth.b, 64);
        let cal = GyroCalibration {
            bias: truth.b,
            matrix: truth.k,
        };
        let mut integ = MotionIntegrator::for_calibration(cal, DT).unwrap();
        for s in &m.samples {
            integ.push(s).unwrap();
        }
        let q = integ.finish(&m.g0, &m.g1).unwrap().rotation;
        let ours =
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let err = ours.angle_to(&reference);
        assert!(err < 1e-8, "RK4 vs exponential map: {err:e} rad");
        // f32 on 16-bit-like counts: limited by f32 rounding, not by the method.
        let cal32 = GyroCalibration {
            bias: truth.b.cast::<f32>(),
            matrix: truth.k.cast::<f32>(),
        };
        let mut integ = MotionIntegrator::for_calibration(cal32, DT as f32).unwrap();
        for s in &m.samples {
            integ.push(&s.map(|x| x as f32)).unwrap();
        }
        let q = integ
            .finish(&m.g0.cast(), &m.g1.cast())
            .unwrap()
            .rotation
            .cast::<f64>();
        let ours =
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let err = ours.angle_to(&reference);
        assert!(err < 2e-4, "f32 RK4 vs f64 reference: {err:e} rad");
    }
}

#[test]
fn jacobian_matches_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let truth = random_truth(&mut rng);
    let motions = simulate(&mut rng, &truth, 4, 0.5, 1e-3);
    let adj = Adjustment {
        p: Matrix3::new(1.02, 0.01, -0.02, 0.015, 0.97, 0.01, -0.01, 0.02, 1.01),
        delta: Vector3::new(0.002, -0.001, 0.003),
    };
    let residual = |m: &RefMotion, a: &Adjustment<f64>, tracked| {
        let mut integ = MotionIntegrator::new(truth.nominal, *a, DT, tracked).unwrap();
        for s in &m.samples {
            integ.push(s).unwrap();
        }
        integ.finish(&m.g0, &m.g1).unwrap()
    };
    for m in &motions {
        let analytic = residual(m, &adj, [true; NPARAM]).jacobian;
        let x = adj.to_params();
        for k in 0..NPARAM {
            let h = 1e-6;
            let (mut xp, mut xm) = (x, x);
            xp[k] += h;
            xm[k] -= h;
            let rp = residual(m, &Adjustment::from_params(&xp), [false; NPARAM]).residual;
            let rm = residual(m, &Adjustment::from_params(&xm), [false; NPARAM]).residual;
            let numeric = (rp - rm) / (2.0 * h);
            let err = (analytic.column(k) - numeric).norm();
            assert!(
                err < 1e-6 * (1.0 + numeric.norm()),
                "param {k}: analytic {} numeric {}",
                analytic.column(k),
                numeric
            );
        }
    }
}

/// Independent f64 fit: Gauss–Newton with Levenberg damping on a central-difference Jacobian
/// of the exponential-map integrator, parameters `K` (9, raw units) and `b` (3).
fn reference_fit(
    motions: &[RefMotion],
    nominal: &GyroCalibration<f64>,
    fit_bias: bool,
) -> (Matrix3<f64>, Vector3<f64>) {
    type V = SVector<f64, 12>;
    let np = if fit_bias { 12 } else { 9 };
    let unpack = |x: &V| {
        (
            Matrix3::from_row_slice(&x.as_slice()[..9]),
            Vector3::new(x[9], x[10], x[11]),
        )
    };
    let residuals = |x: &V| -> Vec<f64> {
        let (k, b) = unpack(x);
        motions
            .iter()
            .flat_map(|m| {
                reference_residual(m, &k, &b, 4)
                    .iter()
                    .copied()
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let mut x = V::zeros();
    x.as_mut_slice()[..9].copy_from_slice(nominal.matrix.transpose().as_slice());
    x[9] = nominal.bias.x;
    x[10] = nominal.bias.y;
    x[11] = nominal.bias.z;
    let scale = |c: usize| {
        if c < 9 {
            1e-3 * nominal.matrix.norm()
        } else {
            1e-2
        }
    };
    let mut lambda = 1e-4;
    let mut cost: f64 = residuals(&x).iter().map(|r| r * r).sum();
    for _ in 0..50 {
        let (a, g) = reference_normal(&residuals, &x, np, &scale);
        let mut improved = false;
        for _ in 0..20 {
            let mut damped = a;
            for c in 0..np {
                damped[(c, c)] *= 1.0 + lambda;
            }
            let step = damped.lu().solve(&(-g)).unwrap();
            let cand = x + step;
            let c2: f64 = residuals(&cand).iter().map(|r| r * r).sum();
            if c2 < cost {
                let done = cost - c2 < 1e-14 * cost;
                x = cand;
                cost = c2;
                lambda *= 0.3;
                improved = true;
                if done {
                    return unpack(&x);
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    unpack(&x)
}

/// The Gauss–Newton normal equations of [`reference_fit`] at `x`: `JᵀJ` (the identity outside
/// the first `np` rows and columns) and `Jᵀr`, with a central-difference Jacobian of
/// `residuals` in steps of `scale(c)`. Apart from the damping loop so that each reads alone.
fn reference_normal(
    residuals: &impl Fn(&SVector<f64, 12>) -> Vec<f64>,
    x: &SVector<f64, 12>,
    np: usize,
    scale: &impl Fn(usize) -> f64,
) -> (SMatrix<f64, 12, 12>, SVector<f64, 12>) {
    let r = residuals(x);
    let mut jac = vec![vec![0.0; np]; r.len()];
    for c in 0..np {
        let h = scale(c);
        let (mut xp, mut xm) = (*x, *x);
        xp[c] += h;
        xm[c] -= h;
        let (rp, rm) = (residuals(&xp), residuals(&xm));
        for i in 0..r.len() {
            jac[i][c] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    let mut a = SMatrix::<f64, 12, 12>::identity();
    let mut g = SVector::<f64, 12>::zeros();
    for c in 0..np {
        for d in 0..np {
            a[(c, d)] = (0..r.len()).map(|i| jac[i][c] * jac[i][d]).sum();
        }
        g[c] = (0..r.len()).map(|i| jac[i][c] * r[i]).sum();
    }
    (a, g)
}

fn rel(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

#[test]
fn noiseless_recording_recovers_truth_f64_and_f32() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = random_truth(&mut rng);
    let recording = simulate(&mut rng, &truth, 20, 0.0, 0.0);
    let motions = motions_f64(&recording);
    for fit_bias in [false, true] {
        let f = fit(
            &motions,
            &truth.nominal,
            &cfg(GyroModel::Full, fit_bias),
            None,
        )
        .unwrap();
        let e = rel(&f.calibration.matrix, &truth.k);
        // The samples are the true rates at the sample instants but the model interpolates
        // linearly between them (as any integrator of sampled data must): that sampling error
        // limits recovery to ~1e-5. Without the bias in the fit, the rest bias's 0.2-count
        // error dominates.
        let tol = if fit_bias { 5e-5 } else { 2e-4 };
        assert!(e < tol, "f64 fit_bias={fit_bias}: K error {e:e}");
        if fit_bias {
            assert!(
                (f.calibration.bias - truth.b).amax() < 1e-2,
                "bias {}",
                f.calibration.bias - truth.b
            );
        }
        let rms_tol = if fit_bias { 1e-4 } else { 1e-3 };
        assert!(f.rms_after < rms_tol, "rms after {}", f.rms_after);
        assert!(f.rms_before > 100.0 * f.rms_after.max(1e-9));
    }
    let rec32 = to_f32(&recording);
    let motions32: Vec<Motion<'_, f32>> = rec32
        .iter()
        .map(|(s, g0, g1)| Motion {
            samples: s,
            g_start: *g0,
            g_end: *g1,
        })
        .collect();
    let nominal32 = GyroCalibration {
        bias: truth.nominal.bias.cast(),
        matrix: truth.nominal.matrix.cast(),
    };
    let f = fit(&motions32, &nominal32, &cfg(GyroModel::Full, true), None).unwrap();
    let e = rel(&f.calibration.matrix.cast(), &truth.k);
    assert!(e < 2e-4, "f32: K error {e:e}");
}

/// Acceptance: scale ±3 %, misalignment ±2°, 20–40 poses, realistic noise: the f32 fit agrees
/// with the independent f64 fit and with the truth within the noise (4 standard errors from
/// the fit's own covariance), and leave-one-motion-out beats the nominal calibration.
#[test]
fn noisy_recordings_recover_truth_within_noise() {
    for (seed, poses) in [(11u64, 20usize), (12, 40)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = random_truth(&mut rng);
        let recording = simulate(&mut rng, &truth, poses, 2.0, 2e-4);
        let rec32 = to_f32(&recording);
        let motions32: Vec<Motion<'_, f32>> = rec32
            .iter()
            .map(|(s, g0, g1)| Motion {
                samples: s,
                g_start: *g0,
                g_end: *g1,
            })
            .collect();
        let nominal32 = GyroCalibration {
            bias: truth.nominal.bias.cast(),
            matrix: truth.nominal.matrix.cast(),
        };
        let c = cfg::<f32>(GyroModel::Full, true);
        let f = fit(&motions32, &nominal32, &c, None).unwrap();
        let (k_ref, b_ref) = reference_fit(&recording, &truth.nominal, true);
        let k32: Matrix3<f64> = f.calibration.matrix.cast();
        let agree = rel(&k32, &k_ref);
        assert!(agree < 1e-3, "f32 vs f64 reference K: {agree:e}");
        assert!(
            (f.calibration.bias.cast::<f64>() - b_ref).amax() < 0.05,
            "bias vs reference"
        );

        // Standard errors from the f64 normal equations at the reference solution.
        let nominal = truth.nominal;
        let adj_true = Adjustment {
            p: truth.k * nominal.matrix.try_inverse().unwrap(),
            delta: nominal.matrix * (truth.b - nominal.bias),
        };
        let f64fit = fit(
            &motions_f64(&recording),
            &nominal,
            &cfg(GyroModel::Full, true),
            None,
        )
        .unwrap();
        let mut jtj = SMatrix::<f64, 12, 12>::zeros();
        let mut cost = 0.0;
        for m in &recording {
            let mut integ =
                MotionIntegrator::new(nominal, f64fit.adjustment, DT, [true; NPARAM]).unwrap();
            for s in &m.samples {
                integ.push(s).unwrap();
            }
            let out = integ.finish(&m.g0, &m.g1).unwrap();
            jtj += out.jacobian.transpose() * out.jacobian;
            cost += out.residual.norm_squared();
        }
        let dof = (2 * recording.len()) as f64 - 12.0;
        let cov = jtj.try_inverse().unwrap() * (cost / dof);
        let err = f64fit.adjustment.to_params() - adj_true.to_params();
        for k in 0..NPARAM {
            let z = err[k] / cov[(k, k)].sqrt();
            assert!(
                z.abs() < 4.0,
                "seed {seed}: param {k} off by {z:.1} standard errors"
            );
        }
        let cv = leave_one_out(&motions32, &nominal32, &f.adjustment, &c, |_, _| {}).unwrap();
        let none = rms_angle(&motions32, &nominal32, DT as f32, None).unwrap();
        println!(
            "{poses} poses: K vs f64 ref {agree:.2e}; rms before {:.3}° after {:.4}°; CV {:.4}° (nominal {:.3}°)",
            f.rms_before.to_degrees(),
            f.rms_after.to_degrees(),
            cv.to_degrees(),
            none.to_degrees()
        );
        assert!(
            cv < none,
            "held-out error must beat the nominal calibration"
        );
        assert!(cv >= f.rms_after, "held-out error is never below in-sample");
    }
}

#[test]
fn too_few_motions_and_bad_input_are_errors() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let truth = random_truth(&mut rng);
    let recording = simulate(&mut rng, &truth, 5, 0.0, 0.0);
    let motions = motions_f64(&recording);
    // 4 motions give 8 equations: not enough for 12 parameters.
    let e = fit(&motions, &truth.nominal, &cfg(GyroModel::Full, true), None).unwrap_err();
    assert_eq!(e, Error::TooFewPoses { needed: 6, got: 4 });
    let mut bad = recording[0].samples.clone();
    bad[3][1] = f64::NAN;
    let m = [Motion {
        samples: &bad,
        g_start: recording[0].g0,
        g_end: recording[0].g1,
    }];
    assert_eq!(
        fit(&m, &truth.nominal, &cfg(GyroModel::BiasOnly, false), None).unwrap_err(),
        Error::NonFinite
    );
    let zero_g = [Motion {
        samples: &recording[0].samples,
        g_start: Vector3::zeros(),
        g_end: recording[0].g1,
    }];
    assert_eq!(
        fit(
            &zero_g,
            &truth.nominal,
            &cfg(GyroModel::BiasOnly, false),
            None
        )
        .unwrap_err(),
        Error::InvalidParameter
    );
    let singular = GyroCalibration::nominal([0.0; 3], [1e-3, 0.0, 1e-3]);
    assert_eq!(
        fit(&motions, &singular, &cfg(GyroModel::Scale, false), None).unwrap_err(),
        Error::Singular
    );
}

/// A gyro whose bias drifts (a slow ramp plus a step), used in bursts of motion separated by
/// still periods: the tracker follows the drift, and the heading integrated over the whole
/// run drifts far less than with the bias fixed at its initial value.
#[test]
fn zero_rate_tracker_follows_simulated_drift() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let white = Normal::new(0.0, 1.5).unwrap();
    let scale = 1e-3; // rad/s per count
    let b0 = Vector3::new(8000.0, 8050.0, 7950.0);
    let cfg = ZeroRateConfig {
        block: 50,
        max_spread: 14.0f32,
        blend: 0.5,
    };
    let mut tracker = ZeroRateTracker::new(cfg, [b0.x as f32, b0.y as f32, b0.z as f32]).unwrap();
    let (mut err_fixed, mut err_tracked) = (Vector3::<f64>::zeros(), Vector3::<f64>::zeros());
    let n = 60_000; // 10 minutes at 100 Hz
    let mut worst_after_still = 0.0f64;
    for i in 0..n {
        let t = i as f64 * DT;
        // Drift: 40 counts over the run, plus a 15-count step at 5 min (a temperature jump).
        let drift = Vector3::new(40.0, -30.0, 20.0) * (t / 600.0)
            + Vector3::new(15.0, 0.0, -15.0) * f64::from(u8::from(t > 300.0));
        let bias = b0 + drift;
        // 4 s of motion every 10 s.
        let moving = (t % 10.0) < 4.0;
        let rate = if moving {
            Vector3::new(1.5, -0.8, 0.6) * (t * 1.3).sin()
        } else {
            Vector3::zeros()
        };
        let raw = rate / scale + bias + Vector3::from_fn(|_, _| white.sample(&mut rng));
        let raw32 = [raw.x as f32, raw.y as f32, raw.z as f32];
        let still_hint = !moving; // what a still accelerometer would say
        let est = Vector3::from(tracker.bias()).cast::<f64>();
        err_fixed += (b0 - bias) * scale * DT;
        err_tracked += (est - bias) * scale * DT;
        tracker.push(raw32, still_hint).unwrap();
        if !moving && (t % 10.0) > 9.9 && t > 20.0 {
            worst_after_still = worst_after_still.max((est - bias).amax());
        }
    }
    println!(
        "zero-rate tracker: {} updates, worst bias error after a still period {worst_after_still:.2} counts; heading drift fixed {:.1}° vs tracked {:.2}°",
        tracker.updates(),
        err_fixed.norm().to_degrees(),
        err_tracked.norm().to_degrees()
    );
    // Noise of a block mean blended over blocks: 1.5/√50 ≈ 0.2 count; plus the drift within a
    // period (40 counts / 600 s · 10 s ≈ 0.7 count).
    assert!(
        worst_after_still < 1.5,
        "bias error after a still period: {worst_after_still}"
    );
    assert!(err_tracked.norm() < 0.05 * err_fixed.norm());
    // Without the hint a constant-rate rotation is not mistaken for rest as long as the rate
    // varies; with constant raw values it would be (documented).
    let mut t2 = ZeroRateTracker::new(cfg, [0.0f32; 3]).unwrap();
    assert!(t2.push([f32::NAN, 0.0, 0.0], true).is_err());
    assert_eq!(
        ZeroRateTracker::new(ZeroRateConfig { block: 1, ..cfg }, [0.0f32; 3]).unwrap_err(),
        Error::InvalidParameter
    );
}

fn read_imu_tk(name: &str) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(data_dir().join("imu_tk_xsens").join(name)).unwrap();
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[1], v[2], v[3]]
        })
        .collect()
}

/// IMU-TK's Xsens recording: static windows from the accelerometer (core detector), gravity
/// from the core's accelerometer fit, gyro bias from the initial rest and IMU-TK's nominal
/// scale 1/6258 rad/s per count; the f32 core fit (9 + 3 parameters) against the independent
/// f64 exponential-map / central-difference fit on the same motions.
#[test]
fn imu_tk_xsens_gyro_fit_matches_f64_reference() {
    let acc = read_imu_tk("xsens_acc.mat");
    let gyro = read_imu_tk("xsens_gyro.mat");
    assert_eq!(acc.len(), gyro.len());
    let mut det: StaticDetector<101> =
        StaticDetector::new(StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0)).unwrap();
    let mut windows = Vec::new();
    for s in &acc {
        windows.extend(det.push(s.map(|x| x as f32)).unwrap());
    }
    windows.extend(det.finish());
    let means: Vec<[f32; 3]> = windows.iter().map(|w| w.mean).collect();
    let accel = multipos::fit(&means, &MultiPosConfig::default())
        .unwrap()
        .calibration;
    let rest = &gyro[windows[0].start as usize..windows[0].end as usize];
    let bias: [f64; 3] =
        [0, 1, 2].map(|a| rest.iter().map(|v| v[a]).sum::<f64>() / rest.len() as f64);
    let nominal = GyroCalibration::nominal(bias, [1.0 / 6258.0; 3]);
    let spans: Vec<_> = motion_spans(&windows, &accel)
        .collect::<Result<_, _>>()
        .unwrap();
    let recording: Vec<RefMotion> = spans
        .iter()
        .map(|s| RefMotion {
            samples: gyro[s.start as usize..s.end as usize].to_vec(),
            g0: Vector3::from(s.g_start).cast(),
            g1: Vector3::from(s.g_end).cast(),
        })
        .collect();
    let rec32 = to_f32(&recording);
    let motions32: Vec<Motion<'_, f32>> = rec32
        .iter()
        .map(|(s, g0, g1)| Motion {
            samples: s,
            g_start: *g0,
            g_end: *g1,
        })
        .collect();
    let nominal32 = GyroCalibration {
        bias: nominal.bias.cast(),
        matrix: nominal.matrix.cast(),
    };
    let f = fit(&motions32, &nominal32, &cfg(GyroModel::Full, true), None).unwrap();
    let (k_ref, b_ref) = reference_fit(&recording, &nominal, true);
    let k32: Matrix3<f64> = f.calibration.matrix.cast();
    let dk = rel(&k32, &k_ref);
    // Bias: relative to its size, and in counts (each count is 2e-4 rad/s here).
    let db_counts = (f.calibration.bias.cast::<f64>() - b_ref).amax();
    let db = db_counts / b_ref.amax();
    let rms_ref = rms_angle(
        &motions_f64(&recording),
        &GyroCalibration {
            bias: b_ref,
            matrix: k_ref,
        },
        DT,
        None,
    )
    .unwrap();
    println!(
        "xsens gyro: {} windows, {} motions; rms {:.3}° → {:.4}° (f64 ref {:.4}°); K vs ref {dk:.2e}, bias {db:.2e} ({db_counts:.1e} counts)\nK = {}b = {}",
        windows.len(),
        spans.len(),
        f.rms_before.to_degrees(),
        f.rms_after.to_degrees(),
        rms_ref.to_degrees(),
        f.calibration.matrix,
        f.calibration.bias
    );
    assert!(spans.len() >= 35);
    assert!(dk < 1e-3, "K vs f64 reference: {dk:e}");
    assert!(
        db < 1e-3 && db_counts < 0.01,
        "bias vs f64 reference: {db:e} ({db_counts} counts)"
    );
    assert!((f64::from(f.rms_after) - rms_ref).abs() < 0.02 * rms_ref);
    assert!(f.rms_after < f.rms_before);
}

/// Holding a motion out (`exclude`) is the same fit as removing it from the slice.
#[test]
fn excluding_a_motion_equals_removing_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let truth = random_truth(&mut rng);
    let recording = simulate(&mut rng, &truth, 12, 1.0, 1e-4);
    let motions = motions_f64(&recording);
    let c = cfg(GyroModel::Full, true);
    for held in [0, 5, 10] {
        let excluded = fit(&motions, &truth.nominal, &c, Some(held)).unwrap();
        let mut rest = motions.clone();
        rest.remove(held);
        let removed = fit(&rest, &truth.nominal, &c, None).unwrap();
        assert_eq!(excluded.motions, removed.motions);
        assert!(rel(&excluded.calibration.matrix, &removed.calibration.matrix) < 1e-12);
        assert!((excluded.rms_after - removed.rms_after).abs() < 1e-12);
    }
}

/// The fit's own Levenberg–Marquardt loop (every trial integrated with its sensitivities)
/// takes the steps of the crate's generic solver on [`GyroProblem`], and `fit_keeping` leaves
/// each motion's residual, Jacobian and angle at the fit, even when the fit starts far away
/// (where trials get rejected and overwrite them), with `normal`/`gradient` their sums.
#[test]
fn fit_keeping_matches_the_generic_solver_and_keeps_the_motions_at_the_fit() {
    use wiical_core::gyro::MotionResidual;
    use wiical_core::gyro_fit::{fit_from, fit_keeping, GyroProblem};
    use wiical_core::lm::{self, LmSettings};
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let truth = random_truth(&mut rng);
    let recording = simulate(&mut rng, &truth, 15, 1.0, 1e-4);
    let motions = motions_f64(&recording);
    // Both solvers run off (Diverged) from the second start.
    let starts = [
        Matrix3::new(1.4, 0.1, -0.1, 0.05, 0.7, 0.1, -0.1, 0.1, 1.3),
        Matrix3::new(3.0, 0.5, -0.4, 0.3, 2.5, 0.6, -0.5, 0.2, 0.4),
        // The full fit from here rejects a trial before it converges (checked by hand).
        Matrix3::new(0.3, 0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.3),
    ];
    let cases = [(GyroModel::Scale, false), (GyroModel::Full, true)];
    for (start, (model, fit_bias)) in starts.iter().flat_map(|s| cases.map(|c| (s, c))) {
        let far = Adjustment {
            p: *start,
            delta: Vector3::new(0.05, -0.03, 0.02),
        };
        let c = cfg::<f64>(model, fit_bias);
        let free = model.mask(fit_bias);
        let problem = GyroProblem::new(&motions, truth.nominal, DT, free, None).unwrap();
        let mut x0 = far.to_params();
        for k in (0..NPARAM).filter(|k| !free[*k]) {
            x0[k] = Adjustment::<f64>::identity().to_params()[k];
        }
        let generic = lm::minimize(&problem, x0, &free, None, &LmSettings::multipos(100));
        let blank = MotionResidual {
            residual: Vector3::zeros(),
            jacobian: SMatrix::zeros(),
            angle: 0.0,
            rotation: nalgebra::Vector4::zeros(),
        };
        let mut kept = vec![blank; motions.len()];
        let f = fit_keeping(&motions, &truth.nominal, &far, &c, &mut kept);
        let (generic, f) = match (generic, f) {
            (Ok(g), Ok(f)) => (g, f),
            (Err(a), Err(b)) => {
                assert_eq!(a, b, "{model:?}");
                continue;
            }
            (g, f) => panic!("{model:?}: generic {g:?}, fit {f:?}"),
        };
        let plain = fit_from(&motions, &truth.nominal, &far, &c, None).unwrap();
        assert_eq!(f.adjustment, plain.adjustment);
        assert_eq!(f.iterations, generic.iterations, "{model:?}");
        let d = (f.adjustment.to_params() - generic.params).amax();
        assert!(d < 1e-12, "{model:?}: {d:e} from the generic solver");
        let (mut jtj, mut jtr) = (SMatrix::<f64, 12, 12>::zeros(), SVector::<f64, 12>::zeros());
        for (m, k) in motions.iter().zip(&kept) {
            let mut integ = MotionIntegrator::new(truth.nominal, f.adjustment, DT, free).unwrap();
            for s in m.samples {
                integ.push(s).unwrap();
            }
            let fresh = integ.finish(&m.g_start, &m.g_end).unwrap();
            assert_eq!(
                fresh, *k,
                "{model:?}: a kept motion is not the one at the fit"
            );
            jtj += fresh.jacobian.transpose() * fresh.jacobian;
            jtr += fresh.jacobian.transpose() * fresh.residual;
        }
        assert!((f.normal - jtj).amax() <= 1e-12 * jtj.amax());
        assert!((f.gradient - jtr).amax() <= 1e-12 * jtj.amax());
    }
}

/// Candidate models sharing one nominal pass (all 12 sensitivities, masked per model) get
/// exactly the fits and kept motions of their own passes.
#[test]
fn a_shared_nominal_pass_gives_the_same_fits_bit_for_bit() {
    use wiical_core::gyro::MotionResidual;
    use wiical_core::gyro_fit::{fit_keeping, fit_keeping_from_nominal, nominal_pass};
    let mut rng = ChaCha8Rng::seed_from_u64(34);
    let truth = random_truth(&mut rng);
    let recording = simulate(&mut rng, &truth, 12, 1.0, 1e-4);
    let motions = motions_f64(&recording);
    let blank = MotionResidual {
        residual: Vector3::zeros(),
        jacobian: SMatrix::zeros(),
        angle: 0.0,
        rotation: nalgebra::Vector4::zeros(),
    };
    let mut shared = vec![blank; motions.len()];
    let pass = nominal_pass(&motions, &truth.nominal, DT, &mut shared).unwrap();
    for model in [GyroModel::BiasOnly, GyroModel::Scale, GyroModel::Full] {
        for fit_bias in [false, true] {
            let c = cfg::<f64>(model, fit_bias);
            let mut own = vec![blank; motions.len()];
            let alone = fit_keeping(
                &motions,
                &truth.nominal,
                &Adjustment::identity(),
                &c,
                &mut own,
            );
            let mut from_pass = shared.clone();
            let shared_fit = fit_keeping_from_nominal(&motions, &c, &pass, &mut from_pass);
            assert_eq!(alone.unwrap(), shared_fit.unwrap(), "{model:?} {fit_bias}");
            assert_eq!(own, from_pass, "{model:?} {fit_bias}");
        }
    }
    let other_dt = cfg::<f64>(GyroModel::Full, true);
    let other_dt = GyroFitConfig {
        dt: 2.0 * DT,
        ..other_dt
    };
    let mut k = shared.clone();
    assert_eq!(
        fit_keeping_from_nominal(&motions, &other_dt, &pass, &mut k).unwrap_err(),
        Error::InvalidParameter
    );
}
