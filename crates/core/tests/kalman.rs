//! The `[p, v, b]` Kalman filter (`kalman::PvbFilter`, f32) against an f64 implementation of
//! the same equations, against the continuous kinematics it discretises, and for statistical
//! consistency (NEES / NIS) on seeded simulations.
// Loops over the three axes index several parallel arrays; ranges read best here.
#![allow(clippy::needless_range_loop)]

use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use wiical_core::kalman::{PvbConfig, PvbFilter};
use wiical_core::Error;

type M3 = Matrix3<f64>;
type V3 = Vector3<f64>;

/// The same filter in f64, written from the equations in the module docs.
struct Ref {
    x: V3,
    p: M3,
    f: M3,
    b: V3,
    q: M3,
    r: f64,
}

impl Ref {
    fn new(c: &PvbConfig) -> Self {
        let dt = c.dt as f64;
        let f = M3::new(1.0, dt, -dt * dt / 2.0, 0.0, 1.0, -dt, 0.0, 0.0, 1.0);
        let b = V3::new(dt * dt / 2.0, dt, 0.0);
        let sa = c.accel_noise as f64;
        let sbw = c.bias_walk as f64;
        let mut q = b * b.transpose() * sa * sa;
        q[(2, 2)] += sbw * sbw * dt;
        let s = V3::from(c.initial_std.map(|v| v as f64));
        Ref {
            x: V3::from(c.initial_state.map(|v| v as f64)),
            p: M3::from_diagonal(&s.component_mul(&s)),
            f,
            b,
            q,
            r: (c.pos_noise as f64).powi(2),
        }
    }
    fn predict(&mut self, a: f64) {
        self.x = self.f * self.x + self.b * a;
        self.p = self.f * self.p * self.f.transpose() + self.q;
    }
    fn update(&mut self, z: f64) {
        let h = V3::new(1.0, 0.0, 0.0);
        let s = (h.transpose() * self.p * h)[0] + self.r;
        let k = self.p * h / s;
        self.x += k * (z - self.x[0]);
        let ikh = M3::identity() - k * h.transpose();
        self.p = ikh * self.p * ikh.transpose() + k * k.transpose() * self.r;
    }
}

fn to64(m: &wiical_core::kalman::Mat3x3) -> M3 {
    M3::from_fn(|i, j| m[(i, j)] as f64)
}

/// The article's fiducial settings: 100 Hz, 0.5 cm position noise; σ_a = 0.05 m/s²
/// (see the host demo for that choice); P0 for a player holding still.
fn fiducial() -> PvbConfig {
    PvbConfig {
        dt: 0.01,
        accel_noise: 0.05,
        bias_walk: 0.0,
        pos_noise: 0.005,
        initial_state: [0.0; 3],
        initial_std: [0.01, 0.05, 0.5],
    }
}

/// One simulated step of a moving device. Returns (a_m, z) and advances the truth.
struct Truth {
    x: V3,
    t: f64,
}

impl Truth {
    /// True acceleration held over the step (zero-order hold, as the filter assumes), an
    /// accelerometer reading a_m = a + b + w, the truth moved over dt, the bias random-walked,
    /// then a position measurement of the new state.
    fn step(&mut self, c: &PvbConfig, rng: &mut ChaCha8Rng, a_true: f64) -> (f64, f64) {
        let dt = c.dt as f64;
        let w: f64 = StandardNormal.sample(rng);
        let a_m = a_true + self.x[2] + w * c.accel_noise as f64;
        let (p, v) = (self.x[0], self.x[1]);
        self.x[0] = p + v * dt + a_true * dt * dt / 2.0;
        self.x[1] = v + a_true * dt;
        let wb: f64 = StandardNormal.sample(rng);
        self.x[2] += wb * c.bias_walk as f64 * dt.sqrt();
        self.t += dt;
        let e: f64 = StandardNormal.sample(rng);
        (a_m, self.x[0] + e * c.pos_noise as f64)
    }
}

#[test]
fn f32_filter_tracks_the_f64_equations_step_by_step() {
    let c = PvbConfig {
        bias_walk: 0.02,
        ..fiducial()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut truth = Truth {
        x: V3::new(0.0, 0.0, 0.25),
        t: 0.0,
    };
    let mut f = PvbFilter::new(&c).unwrap();
    let mut r = Ref::new(&c);
    // Differences normalised by the filter's own standard deviation √P_ii (f64), worst over
    // the run, and covariance differences relative to √(P_ii P_jj).
    let (mut worst_x, mut worst_p) = (V3::zeros(), 0.0f64);
    for k in 0..3000 {
        // A swing from rest: a = 2 cos(ωt) m/s² at 0.7 Hz (v = (2/ω) sin ωt, p within
        // [0, 0.2 m]), then still. Bounded positions keep the f32 spacing of p small.
        let a = if k < 1500 {
            2.0 * (2.0 * std::f64::consts::PI * 0.7 * truth.t).cos()
        } else {
            0.0
        };
        let (a_m, z) = truth.step(&c, &mut rng, a);
        f.predict(a_m as f32).unwrap();
        r.predict(a_m as f32 as f64);
        f.update(z as f32).unwrap();
        r.update(z as f32 as f64);
        let dx = f.state().map(|v| v as f64) - r.x;
        for i in 0..3 {
            worst_x[i] = worst_x[i].max(dx[i].abs() / r.p[(i, i)].sqrt());
        }
        let p32 = to64(&f.covariance());
        for i in 0..3 {
            for j in 0..3 {
                let scale = (r.p[(i, i)] * r.p[(j, j)]).sqrt();
                worst_p = worst_p.max((p32[(i, j)] - r.p[(i, j)]).abs() / scale);
            }
        }
    }
    // f32 must not change the answer: every state within 1e-3 of its own standard deviation
    // of the f64 result. Rounding (relative 6e-8 of values ≤ 1) is re-injected every step
    // and forgotten only at the filter's time constants (~1 s = 100 steps for the bias), and
    // velocity and bias are reconstructed from position differences, amplifying a
    // position rounding of ~1e-8 m (≈ 1e-5 σ_p) by the gains. Covariances: relative 1e-4.
    println!("worst |Δx|/σ = {worst_x:?}, worst ΔP (rel) = {worst_p:e}");
    assert!(worst_x.max() < 1e-3, "{worst_x:?}");
    assert!(worst_p < 1e-4, "{worst_p:e}");
}

/// F and B must be the exact discretisation of ṗ = v, v̇ = a_m − b, ḃ = 0 with a_m held over
/// the step: integrate that ODE with RK4 on 1000 sub-steps and compare.
#[test]
fn transition_and_input_matrices_discretise_the_kinematics() {
    let c = PvbConfig {
        dt: 0.02,
        ..fiducial()
    };
    let f = PvbFilter::new(&c).unwrap();
    let (fm, bm) = (to64(&f.transition()), f.input().map(|v| v as f64));
    let x0 = V3::new(0.3, -1.2, 0.7);
    let a_m = 3.5;
    let deriv = |x: &V3| V3::new(x[1], a_m - x[2], 0.0);
    let n = 1000;
    let h = c.dt as f64 / n as f64;
    let mut x = x0;
    for _ in 0..n {
        let k1 = deriv(&x);
        let k2 = deriv(&(x + k1 * (h / 2.0)));
        let k3 = deriv(&(x + k2 * (h / 2.0)));
        let k4 = deriv(&(x + k3 * h));
        x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    }
    let disc = fm * x0 + bm * a_m;
    // f32 entries of F and B (relative 6e-8) times values ~1: 1e-6 is a generous bound.
    assert!((disc - x).amax() < 1e-6, "{disc} vs {x}");
    // Q is B Bᵀ σ_a² (no bias walk configured).
    let q = to64(&f.process_noise());
    let want = bm * bm.transpose() * 0.05f64.powi(2);
    assert!((q - want).amax() < 1e-6 * want.amax());
    assert!((f.measurement_noise() as f64 - 0.005f64.powi(2)).abs() < 1e-10);
}

/// Consistency: with the initial truth drawn from N(x̂0, P0) and the simulation following the
/// filter's model, the NEES (x − x̂)ᵀP⁻¹(x − x̂) is χ²(3) at every step and the NIS is χ²(1).
/// Mean NEES over 500 runs has sd √(6/500) ≈ 0.11: accept [2.6, 3.4] (> 3.5 sd). Mean NIS
/// over 500 runs × 200 steps (correlated little): accept [0.95, 1.05].
#[test]
fn nees_and_nis_are_consistent_over_many_runs() {
    for bias_walk in [0.0f32, 0.05] {
        let c = PvbConfig {
            bias_walk,
            ..fiducial()
        };
        let runs = 500;
        let checkpoints = [1usize, 10, 50, 100, 200];
        let mut nees = [0.0f64; 5];
        let (mut nis, mut nis_n) = (0.0f64, 0u32);
        for run in 0..runs {
            let mut rng = ChaCha8Rng::seed_from_u64(5000 + run);
            let x0 = V3::from_fn(|i, _| {
                let s: f64 = StandardNormal.sample(&mut rng);
                c.initial_state[i] as f64 + s * c.initial_std[i] as f64
            });
            let mut truth = Truth { x: x0, t: 0.0 };
            let mut f = PvbFilter::new(&c).unwrap();
            let accel = Normal::new(0.0, 1.0).unwrap();
            let mut ci = 0;
            for step in 1..=200 {
                let a = accel.sample(&mut rng);
                let (a_m, z) = truth.step(&c, &mut rng, a);
                f.predict(a_m as f32).unwrap();
                let inn = f.update(z as f32).unwrap();
                nis += (inn.residual as f64).powi(2) / inn.variance as f64;
                nis_n += 1;
                if checkpoints.get(ci) == Some(&step) {
                    let e = truth.x - f.state().map(|v| v as f64);
                    let p = to64(&f.covariance());
                    let pinv = p.try_inverse().expect("P invertible");
                    nees[ci] += (e.transpose() * pinv * e)[0];
                    ci += 1;
                }
            }
        }
        for (i, s) in nees.iter().enumerate() {
            let m = s / runs as f64;
            assert!(
                (2.6..=3.4).contains(&m),
                "bias_walk {bias_walk}, step {}: NEES {m}",
                checkpoints[i]
            );
        }
        let m = nis / nis_n as f64;
        assert!((0.95..=1.05).contains(&m), "NIS {m}");
    }
}

/// Long run with a tiny accelerometer noise: the bias variance shrinks by ~6 decades, the
/// regime where the short-form covariance update loses symmetry/definiteness in f32. The
/// Joseph-form P must stay symmetric, positive definite and close to the f64 one.
#[test]
fn covariance_stays_symmetric_positive_definite_over_a_long_run() {
    let c = PvbConfig {
        accel_noise: 0.002,
        initial_std: [1.0, 1.0, 1.0],
        ..fiducial()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let mut truth = Truth {
        x: V3::new(0.0, 0.0, 0.25),
        t: 0.0,
    };
    let mut f = PvbFilter::new(&c).unwrap();
    let mut r = Ref::new(&c);
    for k in 0..100_000 {
        let (a_m, z) = truth.step(&c, &mut rng, 0.0);
        f.predict(a_m as f32).unwrap();
        f.update(z as f32).unwrap();
        r.predict(a_m as f32 as f64);
        r.update(z as f32 as f64);
        if k % 1000 == 999 {
            let p = f.covariance();
            assert_eq!(p, p.transpose(), "P symmetric at step {k}");
            let eig = to64(&p).symmetric_eigenvalues();
            assert!(eig.min() > 0.0, "P not PD at step {k}: {eig}");
            for i in 0..3 {
                let rel = (p[(i, i)] as f64 - r.p[(i, i)]).abs() / r.p[(i, i)];
                // Tight steady state, errors damped each step: 1e-3 relative.
                assert!(rel < 1e-3, "P[{i}{i}] rel err {rel} at step {k}");
            }
        }
    }
    // The bias is known to ~1e-3 m/s² after 1000 s; the estimate must be within 5 sd.
    let sd_b = (f.covariance()[(2, 2)] as f64).sqrt();
    assert!(sd_b < 2e-3, "{sd_b}");
    assert!((f.bias() as f64 - truth.x[2]).abs() < 5.0 * sd_b);
}

#[test]
fn non_finite_input_is_rejected_and_leaves_the_filter_unchanged() {
    let mut f = PvbFilter::new(&fiducial()).unwrap();
    f.predict(0.3).unwrap();
    f.update(0.001).unwrap();
    let before = f;
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(f.predict(bad), Err(Error::NonFinite));
        assert_eq!(f, before);
        assert_eq!(f.update(bad), Err(Error::NonFinite));
        assert_eq!(f, before);
    }
}

#[test]
fn invalid_configurations_are_refused() {
    let ok = fiducial();
    let cases = [
        (PvbConfig { dt: 0.0, ..ok }, Error::InvalidParameter),
        (
            PvbConfig {
                pos_noise: 0.0,
                ..ok
            },
            Error::InvalidParameter,
        ),
        (
            PvbConfig {
                accel_noise: -1.0,
                ..ok
            },
            Error::InvalidParameter,
        ),
        (
            PvbConfig {
                initial_std: [1.0, -1.0, 1.0],
                ..ok
            },
            Error::InvalidParameter,
        ),
        (PvbConfig { dt: f32::NAN, ..ok }, Error::NonFinite),
        (
            PvbConfig {
                initial_state: [0.0, f32::INFINITY, 0.0],
                ..ok
            },
            Error::NonFinite,
        ),
        (
            PvbConfig {
                pos_noise: 1e-30,
                ..ok
            },
            Error::InvalidParameter,
        ),
    ];
    for (c, e) in cases {
        assert_eq!(PvbFilter::new(&c), Err(e), "{c:?}");
    }
}

proptest! {
    /// Arbitrary configurations and inputs never panic, and whatever state is reached after
    /// accepted steps is finite.
    #[test]
    fn never_panics(
        dt in any::<f32>(), sa in any::<f32>(), sp in any::<f32>(), sb in any::<f32>(),
        s0 in prop::array::uniform3(any::<f32>()),
        inputs in prop::collection::vec((any::<f32>(), any::<f32>()), 0..50),
    ) {
        let c = PvbConfig {
            dt, accel_noise: sa, bias_walk: sb, pos_noise: sp,
            initial_state: [0.0; 3], initial_std: s0,
        };
        if let Ok(mut f) = PvbFilter::new(&c) {
            for (a, z) in inputs {
                let _ = f.predict(a);
                let _ = f.update(z);
                prop_assert!(f.state().iter().all(|v| v.is_finite()));
                prop_assert!(f.covariance().iter().all(|v| v.is_finite()));
            }
        }
    }
}

/// `PvbConfig::from_allan`: σ_a = N/√dt and σ_bw = K (IEEE 952 densities to the filter's
/// per-step terms), refused for a non-positive dt.
#[test]
fn pvb_config_from_allan_terms() {
    use wiical_core::kalman::PvbConfig;
    let c = PvbConfig::from_allan(0.01, 0.05, 2e-4, 0.005, [0.005, 0.02, 0.5]).unwrap();
    assert!((c.accel_noise - 0.5).abs() < 1e-6);
    assert_eq!(c.bias_walk, 2e-4);
    assert!(PvbConfig::from_allan(0.0, 0.05, 0.0, 0.005, [1.0; 3]).is_err());
}
