//! The generic Levenberg–Marquardt (`wiical_core::lm`) with a model larger than the core's:
//! the 9-parameter multi-position model plus a per-axis quadratic nonlinearity (12
//! parameters, `f64`), as the host's residual analysis plugs in its effect model. Checked
//! against the simulation's truth and against an independent f64 computation (Gauss–Newton
//! with a central-difference Jacobian and nalgebra's dense SVD / inverse, no shared code), and
//! `multipos::fit_generic::<f64>` against the f32 fit.

#![allow(clippy::needless_range_loop)] // parameter indices mirror the model's formulas

use nalgebra::{DMatrix, DVector, Matrix3, SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_core::lm::{self, LmSettings, Problem, REL_PIVOT_F64};
use wiical_core::multipos::{self, MultiPosConfig, MultiPosModel, MultiPosSettings};

const NP: usize = 12;
type P = SVector<f64, NP>;

/// Parameters `b0 b1 b2 k00 k01 k02 k11 k12 k22 q0 q1 q2` in raw units (g-sized data):
/// `v = K(m − b)`, `a_j = v_j + q_j v_j²`, `r = ‖a‖ − 1`.
struct Quadratic<'a>(&'a [[f64; 3]]);

fn model_residual(p: &[f64], m: &[f64; 3]) -> f64 {
    let e = [m[0] - p[0], m[1] - p[1], m[2] - p[2]];
    let v = [
        p[3] * e[0] + p[4] * e[1] + p[5] * e[2],
        p[6] * e[1] + p[7] * e[2],
        p[8] * e[2],
    ];
    let a: Vec<f64> = (0..3).map(|j| v[j] + p[9 + j] * v[j] * v[j]).collect();
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0
}

impl Problem<f64, NP> for Quadratic<'_> {
    fn observations(&self) -> usize {
        self.0.len()
    }

    fn residual_and_gradient(&self, p: &P, i: usize) -> (f64, P) {
        let m = &self.0[i];
        let e = [m[0] - p[0], m[1] - p[1], m[2] - p[2]];
        let v = [
            p[3] * e[0] + p[4] * e[1] + p[5] * e[2],
            p[6] * e[1] + p[7] * e[2],
            p[8] * e[2],
        ];
        let a: [f64; 3] = core::array::from_fn(|j| v[j] + p[9 + j] * v[j] * v[j]);
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let g: [f64; 3] = core::array::from_fn(|j| a[j] / n);
        // ∂r/∂v_j = g_j (1 + 2 q_j v_j) =: z_j; ∂r/∂K_jk = z_j e_k; ∂r/∂b = −Kᵀz.
        let z: [f64; 3] = core::array::from_fn(|j| g[j] * (1.0 + 2.0 * p[9 + j] * v[j]));
        let grad = P::from([
            -(p[3] * z[0]),
            -(p[4] * z[0] + p[6] * z[1]),
            -(p[5] * z[0] + p[7] * z[1] + p[8] * z[2]),
            z[0] * e[0],
            z[0] * e[1],
            z[0] * e[2],
            z[1] * e[1],
            z[1] * e[2],
            z[2] * e[2],
            g[0] * v[0] * v[0],
            g[1] * v[1] * v[1],
            g[2] * v[2] * v[2],
        ]);
        (n - 1.0, grad)
    }
}

fn truth() -> P {
    P::from([
        0.031, -0.018, 0.052, 1.02, 0.004, -0.006, 0.985, 0.003, 1.011, 0.021, -0.013, 0.017,
    ])
}

/// Raw pose means whose corrected vectors are the given unit vectors exactly under `p`.
fn poses_for(p: &P, dirs: &[Vector3<f64>], noise_sd: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 3]> {
    let k = Matrix3::new(p[3], p[4], p[5], 0.0, p[6], p[7], 0.0, 0.0, p[8]);
    let kinv = k.try_inverse().unwrap();
    let noise = Normal::new(0.0, noise_sd.max(1e-300)).unwrap();
    dirs.iter()
        .map(|a| {
            // Invert a_j = v_j + q_j v_j² on the branch through 0.
            let v = Vector3::from_fn(|j, _| {
                let q = p[9 + j];
                (-1.0 + (1.0 + 4.0 * q * a[j]).sqrt()) / (2.0 * q)
            });
            let m = kinv * v + Vector3::new(p[0], p[1], p[2]);
            let jitter = |r: &mut ChaCha8Rng| {
                if noise_sd > 0.0 {
                    noise.sample(r)
                } else {
                    0.0
                }
            };
            [m.x + jitter(rng), m.y + jitter(rng), m.z + jitter(rng)]
        })
        .collect()
}

fn directions(n: usize, rng: &mut ChaCha8Rng) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|_| loop {
            let v = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if v.norm() > 0.1 && v.norm() <= 1.0 {
                break v.normalize();
            }
        })
        .collect()
}

fn start() -> P {
    let mut p = P::zeros();
    p[3] = 1.0;
    p[6] = 1.0;
    p[8] = 1.0;
    p
}

/// Independent reference: Gauss–Newton (with step halving) on a central-difference Jacobian,
/// dense SVD solve, over the observations with `used[i]`.
fn reference_fit(poses: &[[f64; 3]], used: &[bool]) -> (Vec<f64>, DMatrix<f64>) {
    let mut p: Vec<f64> = start().iter().copied().collect();
    let rows: Vec<usize> = (0..poses.len()).filter(|i| used[*i]).collect();
    let cost = |p: &[f64]| -> f64 {
        rows.iter()
            .map(|&i| model_residual(p, &poses[i]).powi(2))
            .sum()
    };
    let jac = |p: &[f64]| -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), NP, |r, c| {
            let h = 1e-6;
            let (mut a, mut b) = (p.to_vec(), p.to_vec());
            a[c] += h;
            b[c] -= h;
            (model_residual(&a, &poses[rows[r]]) - model_residual(&b, &poses[rows[r]])) / (2.0 * h)
        })
    };
    for _ in 0..100 {
        let j = jac(&p);
        let r = DVector::from_iterator(
            rows.len(),
            rows.iter().map(|&i| model_residual(&p, &poses[i])),
        );
        let step = j.clone().svd(true, true).solve(&(-r), 1e-14).unwrap();
        let c0 = cost(&p);
        let mut t = 1.0;
        loop {
            let cand: Vec<f64> = p.iter().zip(step.iter()).map(|(a, s)| a + t * s).collect();
            if cost(&cand) <= c0 || t < 1e-6 {
                p = cand;
                break;
            }
            t *= 0.5;
        }
        if step.amax() < 1e-13 {
            break;
        }
    }
    let j = jac(&p);
    (p, j)
}

#[test]
fn quadratic_model_recovers_truth_from_exact_poses() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let t = truth();
    let poses = poses_for(&t, &directions(40, &mut rng), 0.0, &mut rng);
    let fit = lm::minimize(
        &Quadratic(&poses),
        start(),
        &[true; NP],
        None,
        &LmSettings::default(),
    )
    .unwrap();
    for j in 0..NP {
        assert!(
            (fit.params[j] - t[j]).abs() < 1e-9,
            "param {j}: {} vs {}",
            fit.params[j],
            t[j]
        );
    }
    assert!(fit.cost < 1e-20);
}

#[test]
fn quadratic_model_matches_independent_f64_fit_errors_leverage_and_loo() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let t = truth();
    let poses = poses_for(&t, &directions(36, &mut rng), 1e-3, &mut rng);
    let problem = Quadratic(&poses);
    let mask = [true; NP];
    let settings = LmSettings::default();
    let fit = lm::minimize(&problem, start(), &mask, None, &settings).unwrap();
    let all = vec![true; poses.len()];
    let (rp, j) = reference_fit(&poses, &all);
    for k in 0..NP {
        assert!(
            (fit.params[k] - rp[k]).abs() < 1e-8,
            "param {k}: {} vs {}",
            fit.params[k],
            rp[k]
        );
    }
    // Standard errors: σ̂²·(JᵀJ)⁻¹ with the independent Jacobian.
    let inv = (j.transpose() * &j).try_inverse().unwrap();
    let rss: f64 = poses.iter().map(|m| model_residual(&rp, m).powi(2)).sum();
    assert!((fit.cost - rss).abs() < 1e-9 * rss);
    let s2 = rss / (poses.len() - NP) as f64;
    let se = lm::standard_errors(&problem, &fit, &mask, None, REL_PIVOT_F64).unwrap();
    for k in 0..NP {
        let want = (s2 * inv[(k, k)]).sqrt();
        assert!(
            (se[k] - want).abs() < 1e-5 * want,
            "se {k}: {} vs {want}",
            se[k]
        );
    }
    // Leverage of window 5: gᵀ(JᵀJ)⁻¹g.
    let g5 = j.row(5).transpose();
    let want_h = (g5.transpose() * &inv * &g5)[(0, 0)];
    let h = lm::leverage(&problem, &fit.params, &mask, None, 5, REL_PIVOT_F64).unwrap();
    assert!((h - want_h).abs() < 1e-6 * want_h, "{h} vs {want_h}");
    // Leave-one-out: the refit without window i, by the independent solver.
    let mut loo = vec![None; poses.len()];
    lm::loo_residuals(&problem, &fit, &mask, None, &settings, &mut loo).unwrap();
    for i in [0usize, 7, 20] {
        let mut used = all.clone();
        used[i] = false;
        let (pi, _) = reference_fit(&poses, &used);
        let want = model_residual(&pi, &poses[i]);
        let got = loo[i].unwrap();
        assert!((got - want).abs() < 1e-8, "loo {i}: {got} vs {want}");
    }
    // A mask fixing the quadratic block at 0 equals the 9-parameter fit in f64.
    let mut mask9 = [true; NP];
    mask9[9..].fill(false);
    let fit9 = lm::minimize(&problem, start(), &mask9, None, &settings).unwrap();
    assert_eq!(&fit9.params.as_slice()[9..], &[0.0; 3]);
    let mp = multipos::fit_generic::<f64>(
        &poses,
        None,
        &MultiPosSettings {
            model: MultiPosModel::Full,
            reference_magnitude: 1.0,
            max_iterations: 200,
        },
    )
    .unwrap();
    for a in 0..3 {
        assert!((mp.bias[a] - fit9.params[a]).abs() < 1e-9);
    }
    assert!((mp.matrix[0][1] - fit9.params[4]).abs() < 1e-9);
    assert!((mp.matrix[2][2] - fit9.params[8]).abs() < 1e-9);
    // Without the quadratic terms the fit is clearly worse (the effect is real and found).
    assert!(fit9.cost > 10.0 * fit.cost, "{} vs {}", fit9.cost, fit.cost);
}

#[test]
fn f64_multipos_agrees_with_f32_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut t = truth();
    t.as_mut_slice()[9..].fill(1e-12); // linear sensor (q → 0 keeps the inversion formula finite)
    let poses = poses_for(&t, &directions(30, &mut rng), 1e-3, &mut rng);
    let p32: Vec<[f32; 3]> = poses.iter().map(|p| p.map(|x| x as f32)).collect();
    let f32fit = multipos::fit(&p32, &MultiPosConfig::default()).unwrap();
    let f64fit = multipos::fit_generic::<f64>(
        &poses,
        None,
        &MultiPosSettings {
            model: MultiPosModel::Full,
            reference_magnitude: 1.0,
            max_iterations: 200,
        },
    )
    .unwrap();
    for a in 0..3 {
        assert!((f32fit.calibration.bias[a] as f64 - f64fit.bias[a]).abs() < 2e-5);
        for b in 0..3 {
            let d = f32fit.calibration.matrix[a][b] as f64 - f64fit.matrix[a][b];
            assert!(d.abs() < 2e-5, "K[{a}][{b}] differs by {d}");
        }
    }
    assert!((f32fit.rms as f64 - f64fit.rms).abs() < 1e-5);
    assert!((f64fit.rms - 1e-3).abs() < 1e-3, "rms {}", f64fit.rms);
}
