//! `gyrofit`'s loop: noise floor, static-window candidates with detection limits, verdict, on
//! simulations with known truth (`simulate::gyro`) and on the degenerate inputs a user can
//! give (wrong-sign nominal, swapped files, a gyro that reads nothing).
//!
//! The sweep (`#[ignore]`d, minutes):
//! `cargo test --release -p wiical-analysis --test gyro_loop sweep -- --ignored --nocapture`.

mod common;
use common::data_dir;

use wiical_analysis::gyro::{run, GyroError, GyroOptions, GyroQuality, GyroReport};
use wiical_analysis::simulate::gyro::{simulate_gyro, GyroSimOptions, GyroTruth};
use wiical_analysis::{load, LoadOptions, Recording};

/// The true nominal of the default simulated gyro (16.4 counts per °/s).
fn nominal() -> GyroOptions {
    GyroOptions {
        nominal_source: "--scale".into(),
        ..GyroOptions::new([1f64.to_radians() / 16.4; 3])
    }
}

fn run_sim(seed: u64, truth: GyroTruth) -> GyroReport {
    let o = GyroSimOptions {
        seed,
        truth,
        ..Default::default()
    };
    let sim = simulate_gyro(&o);
    run(&sim.accel, &sim.gyro, &nominal()).expect("simulated gyro fits")
}

/// Names of the accepted effects.
fn named(r: &GyroReport) -> Vec<String> {
    r.effects.iter().map(|e| e.name.clone()).collect()
}

/// The detection limit of `name` on the last step.
fn limit(r: &GyroReport, name: &str) -> f64 {
    r.steps
        .last()
        .and_then(|s| s.candidates.iter().find(|c| c.name == name))
        .and_then(|c| c.detection_limit)
        .unwrap_or_else(|| panic!("no detection limit for {name}: {:?}", r.steps))
}

#[test]
fn clean_simulations_are_good_with_nothing_named() {
    for seed in 1..=3 {
        let r = run_sim(seed, GyroTruth::default());
        assert!(r.effects.is_empty(), "seed {seed}: {:?}", named(&r));
        assert_eq!(r.quality, GyroQuality::Good, "seed {seed}: {}", r.verdict);
        // The floor is the noise a right calibration leaves: the held-out error is of its
        // order, not far below (a floor too high would call anything good).
        assert!(
            r.cv_rms_deg > 0.3 * r.noise_floor_deg && r.cv_rms_deg < 3.0 * r.noise_floor_deg,
            "seed {seed}: held out {} against floor {}",
            r.cv_rms_deg,
            r.noise_floor_deg
        );
        assert!(r
            .diagnostics
            .iter()
            .any(|d| d.starts_with("no g-sensitivity above")));
    }
}

/// g-sensitivity on one element at twice the limit a clean recording states: found with the
/// true value within its standard errors, by name.
#[test]
fn g_sensitivity_at_twice_the_limit_is_found() {
    let clean = run_sim(11, GyroTruth::default());
    let lim = limit(&clean, "g-sensitivity"); // °/s/g
    let mut truth = GyroTruth::default();
    truth.g_sensitivity[0][2] = (2.0 * lim).to_radians();
    let mut found = 0;
    for seed in 11..16 {
        let r = run_sim(seed, truth.clone());
        if let Some(e) = r.effects.iter().find(|e| e.name == "g-sensitivity") {
            found += 1;
            // values row-major: G[x][z] is index 2.
            let (v, s) = (e.values[2], e.std_errors[2]);
            assert!((v - 2.0 * lim).abs() < 4.0 * s, "G_xz {v} ± {s}, truth {}", 2.0 * lim);
        }
    }
    assert!(found >= 4, "found {found} of 5 at 2× the limit {lim} °/s/g");
}

#[test]
fn bias_drift_at_twice_the_limit_is_found() {
    let clean = run_sim(21, GyroTruth::default());
    let lim = limit(&clean, "bias-drift"); // °/s/h
    let mut truth = GyroTruth::default();
    truth.drift[1] = (2.0 * lim).to_radians() / 3600.0;
    let found = (21..26)
        .filter(|&seed| named(&run_sim(seed, truth.clone())).contains(&"bias-drift".into()))
        .count();
    assert!(found >= 4, "found {found} of 5 at 2× the limit {lim} °/s/h");
}

fn xsens() -> (Recording, Recording) {
    let dir = data_dir().join("imu_tk_xsens");
    let acc = load(&dir.join("xsens_acc.mat"), &LoadOptions::default()).unwrap();
    let gyro = load(&dir.join("xsens_gyro.mat"), &LoadOptions::default()).unwrap();
    (acc, gyro)
}

#[test]
fn a_wrong_sign_nominal_is_refused_naming_the_axes() {
    let (acc, gyro) = xsens();
    let opts = GyroOptions {
        nominal_source: "--scale".into(),
        ..GyroOptions::new([-1.5979546e-4; 3])
    };
    match run(&acc, &gyro, &opts) {
        Err(e @ GyroError::GyroNominalSign { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("x, y, z axis"), "{msg}");
            assert!(msg.contains("--scale 1.5980e-4,1.5980e-4,1.5980e-4"), "{msg}");
        }
        other => panic!("expected a sign refusal, got {other:?}"),
    }
    // One axis wrong: that axis alone is named.
    let opts = GyroOptions {
        nominal_source: "--scale".into(),
        ..GyroOptions::new([1.5979546e-4, -1.5979546e-4, 1.5979546e-4])
    };
    let err = run(&acc, &gyro, &opts).unwrap_err().to_string();
    assert!(err.contains("on the y axis"), "{err}");
}

#[test]
fn swapped_files_are_named_as_swapped() {
    let (acc, gyro) = xsens();
    let err = run(&gyro, &acc, &GyroOptions::new([1.5979546e-4; 3])).unwrap_err();
    assert!(
        matches!(err, GyroError::GyroFilesSwapped { .. }),
        "{err:?}: {err}"
    );
}

#[test]
fn an_all_zero_gyro_says_it_reads_nothing() {
    let (acc, mut gyro) = xsens();
    gyro.xyz.iter_mut().for_each(|v| *v = [0.0; 3]);
    let err = run(&acc, &gyro, &GyroOptions::estimated()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, GyroError::GyroReadsNothing { .. }), "{msg}");
    assert!(msg.contains("the gyro reads nothing"), "{msg}");
}
