//! Simulated warm-ups with known bias polynomials (independent truth), the range check, and
//! the parameter files read back.

use super::params::{about, ardupilot, parse, px4, ARDUPILOT_SCALE, G};
use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A simulated static warm-up: 100 Hz, temperature rising exponentially from `t_from` towards
/// `t_to` (time constant a third of the record), bias `Σ truth[j][k]·(T − 35)^(k+1)` on axis j
/// (g), each pose held for an equal share with 2 s of motion between, white noise `sigma` g.
struct Sim {
    seed: u64,
    truth: [[f64; 3]; 3],
    poses: Vec<[f64; 3]>,
    t_from: f64,
    t_to: f64,
    minutes: f64,
    sigma: f64,
}

impl Sim {
    fn new(seed: u64, truth: [[f64; 3]; 3]) -> Self {
        Self {
            seed,
            truth,
            poses: vec![[0.05, -0.1, 0.9937]],
            t_from: 18.0,
            t_to: 39.0,
            minutes: 30.0,
            sigma: 0.002,
        }
    }

    fn recording(&self) -> Recording {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let noise = Normal::new(0.0, self.sigma).unwrap();
        let moving = Normal::new(0.0, 0.3).unwrap();
        let n = (self.minutes * 60.0 * 100.0) as usize;
        let per_pose = n / self.poses.len();
        let tau = n as f64 / 100.0 / 3.0;
        let (mut t, mut xyz, mut temp) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let time = i as f64 / 100.0;
            let temp_c = self.t_to - (self.t_to - self.t_from) * (-time / tau).exp();
            let dt = temp_c - TEMP_REF_C;
            let p = (i / per_pose).min(self.poses.len() - 1);
            let in_motion = p > 0 && i % per_pose < 200;
            let v: [f64; 3] = std::array::from_fn(|j| {
                let bias: f64 = (0..3)
                    .map(|k| self.truth[j][k] * dt.powi(k as i32 + 1))
                    .sum();
                let m = if in_motion {
                    moving.sample(&mut rng)
                } else {
                    0.0
                };
                self.poses[p][j] + bias + noise.sample(&mut rng) + m
            });
            t.push(time);
            xyz.push(v);
            temp.push(temp_c);
        }
        Recording {
            t: Some(t),
            xyz,
            temp: Some(temp),
            axis_columns: ["x".into(), "y".into(), "z".into()],
            ..Default::default()
        }
    }
}

/// Cubic truth on every axis (mg/°C, mg/°C², mg/°C³ scale, different per axis).
const CUBIC: [[f64; 3]; 3] = [
    [1.0e-3, 5.0e-5, 4.0e-6],
    [-0.5e-3, -8.0e-5, -5.0e-6],
    [2.0e-3, 3.0e-5, 3.0e-6],
];

fn assert_within_3se(rep: &TempcalReport, truth: &[[f64; 3]; 3]) {
    for (j, (a, t)) in rep.axes.iter().zip(truth).enumerate() {
        assert_eq!(a.order, 3, "axis {j}: {a:?}");
        for (k, want) in t.iter().enumerate() {
            let z = (a.coefficients[k] - want) / a.std_errors[k];
            assert!(
                z.abs() < 3.0,
                "axis {j} c{}: {} vs {} (se {}, z {z:.2})",
                k + 1,
                a.coefficients[k],
                want,
                a.std_errors[k]
            );
            assert!(a.std_errors[k] > 0.0 && a.std_errors[k] < want.abs());
        }
    }
}

#[test]
fn cubic_truth_is_recovered_within_three_standard_errors_and_order_3_chosen() {
    for seed in [1, 2, 3] {
        let rep = fit_warmup(&Sim::new(seed, CUBIC).recording(), &Default::default()).unwrap();
        assert_within_3se(&rep, &CUBIC);
        assert_eq!(rep.poses, 1);
        assert!(rep.t_max_c - rep.t_min_c > 18.0, "{rep:?}");
        for a in &rep.axes {
            let r = &a.heldout_rms;
            // The cubic's held-out error is the noise of a block mean (0.2 mg); the linear's is
            // far above it.
            assert!(r[2].unwrap() < 1.3 * 0.0002, "{r:?}");
            assert!(r[0].unwrap() > 2.0 * r[2].unwrap(), "{r:?}");
            // Still and explained by temperature: the residual is the block noise.
            let ratio = a.noise_ratio.unwrap();
            assert!((0.8..1.2).contains(&ratio), "{ratio}");
        }
    }
}

#[test]
fn several_poses_share_the_polynomial() {
    let mut sim = Sim::new(7, CUBIC);
    sim.poses = vec![
        [0.05, -0.1, 0.9937],
        [0.9937, 0.05, -0.1],
        [-0.1, 0.9937, 0.05],
    ];
    sim.minutes = 45.0;
    let rep = fit_warmup(&sim.recording(), &Default::default()).unwrap();
    assert_eq!(rep.poses, 3, "{rep:?}");
    assert!(rep.blocks_moving >= 2, "the motions are left out: {rep:?}");
    assert_within_3se(&rep, &CUBIC);
}

#[test]
fn pose_labels_give_the_poses() {
    let mut sim = Sim::new(8, CUBIC);
    // Two poses only 3° apart: the direction test would take them as one; the labels do not.
    sim.poses = vec![[0.05, -0.1, 0.9937], [0.05, -0.1523, 0.9870]];
    let mut rec = sim.recording();
    let half = rec.len() / 2;
    rec.labels = Some(
        (0..rec.len())
            .map(|i| if i < half { "a" } else { "b" }.to_string())
            .collect(),
    );
    let rep = fit_warmup(&rec, &Default::default()).unwrap();
    assert_eq!(rep.poses, 2, "{rep:?}");
    assert_within_3se(&rep, &CUBIC);
    let unlabelled = fit_warmup(&sim.recording(), &Default::default()).unwrap();
    assert_eq!(unlabelled.poses, 1);
}

#[test]
fn linear_truth_chooses_order_1() {
    let linear = [[1.0e-3, 0.0, 0.0], [-0.7e-3, 0.0, 0.0], [0.4e-3, 0.0, 0.0]];
    let mut chosen = [0usize; 4];
    for seed in 10..20 {
        let rep = fit_warmup(&Sim::new(seed, linear).recording(), &Default::default()).unwrap();
        for (j, a) in rep.axes.iter().enumerate() {
            chosen[a.order] += 1;
            if a.order == 1 {
                let z = (a.coefficients[0] - linear[j][0]) / a.std_errors[0];
                assert!(z.abs() < 4.0, "seed {seed} axis {j}: z {z:.2}");
            }
        }
    }
    // 30 axis fits: order 1 in all but at most two (a cross-validation can be fooled by noise).
    assert!(chosen[1] >= 28, "orders chosen (index = order): {chosen:?}");
}

#[test]
fn a_small_range_is_refused_saying_how_much_was_seen() {
    let mut sim = Sim::new(3, CUBIC);
    sim.t_from = 25.0;
    sim.t_to = 33.0;
    let e = fit_warmup(&sim.recording(), &Default::default()).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, TempcalError::RangeTooSmall { seen_c, .. } if seen_c < 8.0 && seen_c > 7.0),
        "{text}"
    );
    assert!(text.contains("spans only 7."), "{text}");
    assert!(text.contains("at least 10 °C"), "{text}");
}

/// A warm-up logged in kelvin (291–311 K) is refused naming its range and kelvin, never
/// fitted as °C (which wrote TMIN 293 °C and coefficients extrapolated 258 °C to T_ref).
#[test]
fn a_temperature_column_in_kelvin_is_refused() {
    let mut rec = Sim::new(3, CUBIC).recording();
    for t in rec.temp.as_mut().unwrap() {
        *t += 273.15;
    }
    let e = fit_warmup(&rec, &Default::default()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, TempcalError::Kelvin { .. }), "{text}");
    assert!(text.contains("from 291.1 to 311.1"), "{text}");
    assert!(text.contains("kelvin") && text.contains("273.15"), "{text}");
}

#[test]
fn no_temperature_column_is_refused() {
    let mut rec = Sim::new(3, CUBIC).recording();
    rec.temp = None;
    let e = fit_warmup(&rec, &Default::default()).unwrap_err();
    assert!(matches!(e, TempcalError::NoTemperature), "{e}");
}

#[test]
fn reexpansion_keeps_the_polynomial_up_to_a_constant() {
    let c = [1.3e-3, -2.0e-4, 7.0e-6];
    let moved = about(&c, 20.0, 35.0);
    let eval = |c: &[f64], t: f64, r: f64| -> f64 {
        c.iter()
            .enumerate()
            .map(|(k, v)| v * (t - r).powi(k as i32 + 1))
            .sum()
    };
    let d0 = eval(&c, 10.0, 20.0) - eval(&moved, 10.0, 35.0);
    for t in [0.0, 15.0, 27.5, 60.0] {
        let d = eval(&c, t, 20.0) - eval(&moved, t, 35.0);
        assert!((d - d0).abs() < 1e-12, "{t}: {d} vs {d0}");
    }
}

#[test]
fn parameter_files_read_back_with_the_autopilots_names_and_units() {
    let rep = fit_warmup(&Sim::new(1, CUBIC).recording(), &Default::default()).unwrap();
    assert_eq!(rep.units, "g");
    let ap = parse(&ardupilot(&rep, G)).unwrap();
    let names: Vec<&str> = ap.iter().map(|(n, _)| n.as_str()).collect();
    let mut want = vec!["INS_TCAL1_ENABLE", "INS_TCAL1_TMIN", "INS_TCAL1_TMAX"];
    let acc: Vec<String> = (1..=3)
        .flat_map(|k| ["X", "Y", "Z"].map(|a| format!("INS_TCAL1_ACC{k}_{a}")))
        .collect();
    want.extend(acc.iter().map(|s| s.as_str()));
    assert_eq!(names, want);
    let value = |n: &str| ap.iter().find(|(k, _)| k == n).unwrap().1;
    assert_eq!(value("INS_TCAL1_ENABLE"), 1.0);
    assert!((value("INS_TCAL1_TMIN") - rep.t_min_c).abs() <= 0.05);
    // Truth in g per °C^k about 35 °C → m/s² × 1e6; the fit is within 3 se of it.
    for (k, j) in [(1, 0), (2, 1), (3, 2)] {
        let got = value(&format!("INS_TCAL1_ACC{k}_Y"));
        let se = rep.axes[1].std_errors[k - 1] * G * ARDUPILOT_SCALE;
        assert!(
            (got - CUBIC[1][j] * G * ARDUPILOT_SCALE).abs() < 3.0 * se + 1e-6,
            "ACC{k}_Y {got}"
        );
    }
    let p = parse(&px4(&rep, G)).unwrap();
    let names: Vec<&str> = p.iter().map(|(n, _)| n.as_str()).collect();
    for n in [
        "TC_A_ENABLE",
        "TC_A0_TREF",
        "TC_A0_TMIN",
        "TC_A0_TMAX",
        "TC_A0_X0_0",
        "TC_A0_X3_2",
    ] {
        assert!(names.contains(&n), "{n} in {names:?}");
    }
    assert_eq!(p.len(), 4 + 12);
    let pv = |n: &str| p.iter().find(|(k, _)| k == n).unwrap().1;
    assert_eq!(pv("TC_A0_TREF"), 35.0);
    for (i, a) in rep.axes.iter().enumerate() {
        for k in 0..3 {
            let got = pv(&format!("TC_A0_X{}_{i}", k + 1));
            assert!(
                (got - a.coefficients[k] * G).abs() <= 1e-6 * got.abs(),
                "{got}"
            );
        }
    }
    // Every PX4 data line is the five tab-separated QGroundControl fields.
    for line in px4(&rep, G).lines().filter(|l| !l.starts_with('#')) {
        assert_eq!(line.split('\t').count(), 5, "{line}");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Any finite recording gives a report or a refusal, never a panic or a non-finite
    /// coefficient.
    #[test]
    fn arbitrary_recordings_never_panic(
        rows in proptest::collection::vec(
            (-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6, -50f64..150.0), 0..400),
        block_s in 0.01f64..0.05,
        pose_deg in 0.1f64..170.0,
        still in proptest::bool::ANY,
    ) {
        // `still`: values within ±0.01 of one direction, so poses, fits and order choices run.
        let xyz = |r: &(f64, f64, f64, f64)| if still {
            [r.0 * 1e-8, r.1 * 1e-8, 1.0 + r.2 * 1e-8]
        } else {
            [r.0, r.1, r.2]
        };
        let rec = Recording {
            xyz: rows.iter().map(xyz).collect(),
            temp: Some(rows.iter().map(|r| r.3).collect()),
            axis_columns: ["x".into(), "y".into(), "z".into()],
            ..Default::default()
        };
        let opts = TempcalOptions { block_s, pose_deg, ..Default::default() };
        if let Ok(rep) = fit_warmup(&rec, &opts) {
            for a in &rep.axes {
                proptest::prop_assert!(a.coefficients.iter().all(|c| c.is_finite()));
            }
        }
    }
}
