//! The gyro's bias step (a knock between two rests, `gyro::bias_step`): put into a simulated
//! recording (`wiical_sim::gyro`) and into a real one (MPU-9150 unit 0) during a turn, it is named
//! as a step at the gap between the rests around it, its three components within 3 of their
//! stated standard errors of the truth (the raw step through the true scale, °/s), and not
//! taken for a drift; clean recordings name no step.

mod common;

use common::data_dir;
use wiical_analysis::gyro::{run, GyroOptions, GyroReport};
use wiical_analysis::{LoadOptions, Recording};
use wiical_sim::gyro::{simulate_gyro, GyroSimOptions};

/// The true nominal of the default simulated gyro (16.4 counts per °/s).
fn nominal() -> GyroOptions {
    GyroOptions {
        nominal_source: "--scale".into(),
        ..GyroOptions::new([1f64.to_radians() / 16.4; 3])
    }
}

/// Adds `step` (counts) to every gyro sample at or after `t0` (s; the accelerometer's clock,
/// the same rows).
fn inject(acc: &Recording, gyro: &mut Recording, rate_hz: f64, t0: f64, step: [f64; 3]) {
    for (g, t) in gyro.xyz.iter_mut().zip(acc.times(rate_hz)) {
        if t >= t0 {
            for (v, s) in g.iter_mut().zip(step) {
                *v += s;
            }
        }
    }
}

/// The step rows of a report.
fn steps(r: &GyroReport) -> Vec<&wiical_analysis::gyro::report::GyroEffect> {
    r.effects
        .iter()
        .filter(|e| e.name.starts_with("bias-step"))
        .collect()
}

/// The gap's times from a step's name `bias-step (between windows k and k+1 (t = a–b s))`.
fn gap_times(name: &str) -> (f64, f64) {
    let inner = name.split("t = ").nth(1).expect("a time in the name");
    let (a, rest) = inner.split_once('–').expect("a range");
    let b = rest.split(' ').next().expect("its end");
    (a.parse().unwrap(), b.parse().unwrap())
}

/// One step named at the gap holding `t0`, each component within 3 σ of `truth_dps`, no drift.
fn check(r: &GyroReport, t0: f64, truth_dps: [f64; 3]) {
    let names: Vec<&str> = r.effects.iter().map(|e| e.name.as_str()).collect();
    let found = steps(r);
    assert_eq!(found.len(), 1, "{names:?}");
    let e = found[0];
    let (a, b) = gap_times(&e.name);
    assert!(a < t0 && t0 < b, "{} does not hold t0 = {t0}", e.name);
    assert!(
        !names.contains(&"bias-drift"),
        "absorbed by a drift: {names:?}"
    );
    for (ax, truth) in truth_dps.iter().enumerate() {
        let (v, se) = (e.values[ax], e.std_errors[ax]);
        assert!(se > 0.0 && se.is_finite(), "{e:?}");
        assert!(
            (v - truth).abs() <= 3.0 * se,
            "axis {ax}: {v} ± {se} °/s, truth {truth}: {}",
            e.evidence
        );
    }
    eprintln!(
        "{}: {:?} ± {:?}, truth {truth_dps:?}",
        e.name, e.values, e.std_errors
    );
}

/// The raw step through a gyro matrix (rad/s per count), °/s.
fn through(matrix: &[[f64; 3]; 3], step: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| {
        (0..3)
            .map(|c| matrix[r][c] * step[c])
            .sum::<f64>()
            .to_degrees()
    })
}

/// 24 rests of 3 s, a step of (1.6, −1.2, 0.8) counts (about 0.1 °/s) in the middle of the
/// 12th turn (seeds 1–3): named at the gap between the 12th and 13th rests within 3 σ; the same
/// recordings without it name no step.
#[test]
fn a_simulated_gyro_step_is_named_with_its_size_and_place() {
    for seed in 1..=3u64 {
        let o = GyroSimOptions {
            seed,
            ..Default::default()
        };
        let sim = simulate_gyro(&o);
        let clean = run(&sim.accel, &sim.gyro, &nominal()).unwrap();
        assert!(steps(&clean).is_empty(), "seed {seed}: {:?}", clean.effects);
        let t0 = 11.0 * (o.rest_s + o.turn_s) + o.rest_s + 0.5 * o.turn_s;
        let step = [1.6, -1.2, 0.8];
        let mut gyro = sim.gyro.clone();
        inject(&sim.accel, &mut gyro, o.rate_hz, t0, step);
        let r = run(&sim.accel, &gyro, &nominal()).unwrap();
        check(&r, t0, through(&o.truth.matrix, step));
    }
}

/// Clean simulations name no step: 10 seeds.
#[test]
fn clean_gyro_simulations_name_no_step() {
    for seed in 20..30u64 {
        let o = GyroSimOptions {
            seed,
            ..Default::default()
        };
        let sim = simulate_gyro(&o);
        let r = run(&sim.accel, &sim.gyro, &nominal()).unwrap();
        assert!(steps(&r).is_empty(), "seed {seed}: {:?}", r.effects);
    }
}

/// The real MPU-9150 unit 0 (`wiical gyrofit` at default settings: good, no effect): a step
/// of (3, −2, 2) counts put in halfway between its 11th and 12th rests is named there within
/// 3 σ (the truth through the fitted matrix); the recording as it is names none.
#[test]
fn a_step_injected_into_a_real_gyro_recording_is_named() {
    let path = data_dir().join("mpu9150_mikoff_5units/imu0.csv");
    let (acc, gyro) =
        wiical_analysis::input::front_door::load_imu(&path, &LoadOptions::default(), None).unwrap();
    let opts = match wiical_analysis::gyro::nominal_from_columns(&gyro) {
        Some((s, source)) => GyroOptions {
            nominal_source: source,
            ..GyroOptions::new(s)
        },
        None => GyroOptions::estimated(),
    };
    let clean = run(&acc, &gyro, &opts).unwrap();
    assert!(steps(&clean).is_empty(), "{:?}", clean.effects);
    let ws = wiical_analysis::detect::windows::detect_windows(&acc, &opts.detect).unwrap();
    let w = &ws.stats;
    let t0 = 0.5 * (w[10].t_last + w[11].t_first);
    let step = [3.0, -2.0, 2.0];
    let mut stepped = gyro.clone();
    inject(&acc, &mut stepped, 100.0, t0, step);
    let r = run(&acc, &stepped, &opts).unwrap();
    check(&r, t0, through(&clean.matrix, step));
}
