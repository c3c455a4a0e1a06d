//! `gyrofit`'s loop: noise floor, static-window candidates with detection limits, verdict, on
//! simulations with known truth (`wiical_sim::gyro`) and on the degenerate inputs a user can
//! give (wrong-sign nominal, swapped files, a gyro that reads nothing).
//!
//! The sweep (`#[ignore]`d, minutes):
//! `cargo test --release -p wiical-analysis --test gyro_loop sweep -- --ignored --nocapture`.

mod common;
use common::data_dir;

use wiical_analysis::gyro::{run, GyroError, GyroOptions, GyroQuality, GyroReport};
use wiical_analysis::{load, LoadOptions, Recording};
use wiical_sim::gyro::{simulate_gyro, GyroSimOptions, GyroTruth};

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

/// Names of the accepted effects: the windows', then the motions'.
fn named(r: &GyroReport) -> Vec<String> {
    let motion = r.motion_loop.iter().flat_map(|m| &m.effects);
    r.effects
        .iter()
        .map(|e| e.name.clone())
        .chain(motion.map(|e| e.name.clone()))
        .collect()
}

/// Terms the open bases found: the windows', then the motions'.
fn basis_found(r: &GyroReport) -> Vec<String> {
    let motion = r
        .motion_loop
        .iter()
        .flat_map(|m| m.open_basis.iter())
        .flat_map(|b| &b.found);
    r.open_basis
        .iter()
        .flat_map(|b| &b.found)
        .chain(motion)
        .map(|e| e.name.clone())
        .collect()
}

/// The detection limit of window basis term `name` on the basis's first round.
fn basis_limit(r: &GyroReport, name: &str) -> f64 {
    r.open_basis
        .as_ref()
        .and_then(|b| b.steps.first())
        .and_then(|s| s.candidates.iter().find(|c| c.name == name))
        .and_then(|c| c.detection_limit)
        .unwrap_or_else(|| panic!("no basis limit for {name}"))
}

/// The detection limit of motion candidate `name` on the motions' first step.
fn motion_limit(r: &GyroReport, name: &str) -> f64 {
    r.motion_loop
        .as_ref()
        .and_then(|m| m.steps.first())
        .and_then(|s| s.candidates.iter().find(|c| c.name == name))
        .and_then(|c| c.detection_limit)
        .unwrap_or_else(|| panic!("no motion detection limit for {name}"))
}

/// The motion model's held-out RMS angle before and after its effects, degrees.
fn motion_cv(r: &GyroReport) -> (f64, f64) {
    r.motion_loop.as_ref().map_or((f64::NAN, f64::NAN), |m| {
        (m.base.cv_rms_deg, m.final_model.cv_rms_deg)
    })
}

/// Sets motion effect `name` of `t` to `v` (in the report's unit: %, % at 100 °/s, s) on one
/// axis.
fn set_motion(name: &str, t: &mut GyroTruth, v: f64) {
    match name {
        "scale-asymmetry" => t.asymmetry[0] = v / 100.0,
        "scale-nonlinearity" => t.nonlinearity[2] = v / 100.0,
        _ => t.time_offset = v,
    }
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
        assert!(
            basis_found(&r).is_empty(),
            "seed {seed}: {:?}",
            basis_found(&r)
        );
        // Both bases ran and state their limits when they find nothing.
        let window = r.open_basis.as_ref().expect("window basis");
        assert!(window
            .summary
            .contains("no other term of the form g_i·g_j above"));
        let motion = r.motion_loop.as_ref().and_then(|m| m.open_basis.as_ref());
        assert!(motion
            .expect("motion basis")
            .summary
            .contains("ω_i·ω_j above"));
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
            assert!(
                (v - 2.0 * lim).abs() < 4.0 * s,
                "G_xz {v} ± {s}, truth {}",
                2.0 * lim
            );
        }
    }
    assert!(found >= 4, "found {found} of 5 at 2× the limit {lim} °/s/g");
}

/// A bias quadratic in the gravity direction (`g_x·g_z` on the gyro's y axis, a term no named
/// candidate models) at twice the limit a clean recording states: found by the window open
/// basis under that name in at least 4 of 5 runs, the value within 4 standard errors.
#[test]
fn a_quadratic_g_sensitivity_is_found_by_the_open_basis() {
    let name = "g_x·g_z on y";
    let lim = basis_limit(&run_sim(51, GyroTruth::default()), name); // °/s/g²
    let mut truth = GyroTruth::default();
    truth.g_quadratic[1][4] = (2.0 * lim).to_radians();
    let mut found = 0;
    for seed in 51..56 {
        let r = run_sim(seed, truth.clone());
        let b = r.open_basis.expect("window basis");
        if let Some(e) = b.found.iter().find(|e| e.name == name) {
            found += 1;
            assert!(
                (e.value - 2.0 * lim).abs() < 4.0 * e.std_error,
                "{} ± {}, truth {}",
                e.value,
                e.std_error,
                2.0 * lim
            );
            assert!(b
                .summary
                .contains("something of the form g_x·g_z on the gyro's y axis"));
        }
    }
    assert!(
        found >= 4,
        "found {found} of 5 at 2× the limit {lim} °/s/g²"
    );
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

/// Each motion effect at twice the limit a clean recording states: found by name in at least
/// 4 of 5 runs, with the held-out angle error down.
#[test]
fn motion_effects_at_twice_the_limit_are_found() {
    let clean = run_sim(31, GyroTruth::default());
    for name in ["scale-asymmetry", "scale-nonlinearity"] {
        let lim = motion_limit(&clean, name);
        let mut truth = GyroTruth::default();
        set_motion(name, &mut truth, 2.0 * lim);
        let runs: Vec<GyroReport> = (31..36).map(|seed| run_sim(seed, truth.clone())).collect();
        let found = runs
            .iter()
            .filter(|r| named(r).contains(&name.to_string()))
            .count();
        assert!(
            found >= 4,
            "{name}: found {found} of 5 at 2× the limit {lim}"
        );
        for r in runs.iter().filter(|r| named(r).contains(&name.to_string())) {
            let (before, after) = motion_cv(r);
            assert!(after * 1.1 <= before, "{name}: {before} → {after}");
        }
    }
}

/// A gyro lagging by 0.3 s (more than the gap the window detector leaves between a motion's
/// end and the next window): named in at least 3 of 5 runs (0 of 5 at 0.4 s, where the rotation left in the windows spoils the calibration itself). The fitted offset is the part of
/// the lag that carries rotation past the window's start, so it is below the truth; a lag
/// inside that gap leaves no trace in rest-to-rest motions (docs/gyro.md).
#[test]
fn a_time_offset_past_the_window_gap_is_found() {
    let truth = GyroTruth {
        time_offset: 0.3,
        ..Default::default()
    };
    let found = (41..46)
        .filter(|&seed| {
            let r = run_sim(seed, truth.clone());
            let m = r.motion_loop.expect("motions fitted");
            m.effects
                .iter()
                .any(|e| e.name == "time-offset" && e.values[0] > 0.0 && e.values[0] < 0.3)
        })
        .count();
    assert!(found >= 3, "found {found} of 5 at 0.3 s");
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
            assert!(
                msg.contains("--scale 1.5980e-4,1.5980e-4,1.5980e-4"),
                "{msg}"
            );
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

/// One row of the sweep: effect, magnitude (× its limit), named / named as something else /
/// nothing, mean held-out window RMS before → after.
fn sweep_effect(name: &str, set: impl Fn(&mut GyroTruth, f64), lim: f64, unit: &str) {
    for factor in [1.0, 2.0, 4.0] {
        let (mut right, mut other, mut none) = (0, 0, 0);
        let (mut before, mut after) = (0.0, 0.0);
        for seed in 0..10 {
            let mut truth = GyroTruth::default();
            set(&mut truth, factor * lim);
            let r = run_sim(1000 + seed, truth);
            let n = named(&r);
            if n.iter().any(|x| x == name) {
                right += 1;
            } else if n.is_empty() {
                none += 1;
            } else {
                other += 1;
            }
            before += r.base.cv_rms_dps.unwrap_or(f64::NAN) / 10.0;
            after += r.final_model.cv_rms_dps.unwrap_or(f64::NAN) / 10.0;
        }
        println!(
            "| {name} | {factor}× = {:.4} {unit} | {right}/10 | {other}/10 | {none}/10 | {before:.4} → {after:.4} |",
            factor * lim
        );
    }
}

/// The motion candidates, in the order tried.
const MOTION: [&str; 3] = ["scale-asymmetry", "scale-nonlinearity", "time-offset"];

/// One row of the sweep for a motion effect: as [`sweep_effect`], with the motions' held-out
/// RMS angle before → after.
fn sweep_motion(name: &str, lim: f64, unit: &str) {
    for factor in [1.0, 2.0, 4.0] {
        let (mut right, mut other, mut none, mut refused) = (0, 0, 0, 0);
        let (mut before, mut after) = (0.0, 0.0);
        for seed in 0..10 {
            let mut truth = GyroTruth::default();
            set_motion(name, &mut truth, factor * lim);
            let sim = simulate_gyro(&GyroSimOptions {
                seed: 2000 + seed,
                truth,
                ..Default::default()
            });
            // A lag of a second leaves the turns' rotation in the still windows: refused as a
            // gyro that moves like gravity, counted as nothing found.
            let Ok(r) = run(&sim.accel, &sim.gyro, &nominal()) else {
                refused += 1;
                none += 1;
                continue;
            };
            let n = named(&r);
            if n.iter().any(|x| x == name) {
                right += 1;
            } else if n.is_empty() {
                none += 1;
            } else {
                other += 1;
            }
            let (b, a) = motion_cv(&r);
            before += b;
            after += a;
        }
        let fitted = (10 - refused).max(1) as f64;
        println!(
            "| {name} | {factor}× = {:.4} {unit} | {right}/10 | {other}/10 | {none}/10{} | {:.4} → {:.4} |",
            factor * lim,
            if refused > 0 { format!(" ({refused} refused)") } else { String::new() },
            before / fitted,
            after / fitted
        );
    }
}

/// The detection limit of motion basis term `name` on its first round.
fn motion_basis_limit(r: &GyroReport, name: &str) -> Option<f64> {
    r.motion_loop
        .as_ref()
        .and_then(|m| m.open_basis.as_ref())
        .and_then(|b| b.steps.first())
        .and_then(|s| s.candidates.iter().find(|c| c.name == name))
        .and_then(|c| c.detection_limit)
}

/// The open bases' rows: a term outside the named list injected at 1×, 2×, 4× the mean limit
/// clean recordings state for it (20 of them), 10 runs each: found under its name / something
/// else found or named / nothing.
fn sweep_basis() {
    type Set = fn(&mut GyroTruth, f64);
    let cases: [(&str, Set, &str, bool); 2] = [
        (
            "g_x·g_z on y",
            |t, v| t.g_quadratic[1][4] = v.to_radians(),
            "°/s/g²",
            true,
        ),
        (
            "ω_x·ω_y on z",
            |t, v| t.rate_product[2][3] = v / 100.0,
            "% of 100 °/s at 100 °/s",
            false,
        ),
    ];
    println!("| term (open basis) | injected | found | something else | nothing | held-out before → after |");
    println!("|---|---|---|---|---|---|");
    for (name, set, unit, window) in cases {
        let lims: Vec<f64> = (0..20)
            .filter_map(|s| {
                let r = run_sim(6000 + s, GyroTruth::default());
                if window {
                    Some(basis_limit(&r, name))
                } else {
                    motion_basis_limit(&r, name)
                }
            })
            .collect();
        let lim = lims.iter().sum::<f64>() / lims.len().max(1) as f64;
        for factor in [1.0, 2.0, 4.0] {
            let (mut right, mut other, mut none) = (0, 0, 0);
            let (mut before, mut after) = (0.0, 0.0);
            for seed in 0..10 {
                let mut truth = GyroTruth::default();
                set(&mut truth, factor * lim);
                let r = run_sim(3000 + seed, truth);
                let found = basis_found(&r);
                if found.iter().any(|x| x == name) {
                    right += 1;
                } else if found.is_empty() && named(&r).is_empty() {
                    none += 1;
                } else {
                    other += 1;
                }
                let b = if window {
                    r.open_basis.clone()
                } else {
                    r.motion_loop.and_then(|m| m.open_basis)
                };
                if let Some(b) = b {
                    before += b.cv_rms_start / 10.0;
                    after += b.cv_rms_final / 10.0;
                }
            }
            println!(
                "| {name} | {factor}× = {:.4} {unit} | {right}/10 | {other}/10 | {none}/10 | {before:.4} → {after:.4} |",
                factor * lim
            );
        }
    }
}

/// The sweep behind docs/gyro.md's table: clean simulations (false positives) and each
/// effect at 1×, 2×, 4× the limit a clean recording states.
#[test]
#[ignore]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn sweep() {
    let mut false_pos = 0;
    let mut not_good = 0;
    let mut limits = [(0.0, 0usize); 2];
    let mut motion_limits = [(0.0, 0usize); 3];
    let runs = 400;
    let mut basis_pos = 0;
    for seed in 0..runs {
        let r = run_sim(5000 + seed, GyroTruth::default());
        if !named(&r).is_empty() {
            false_pos += 1;
            println!("seed {}: named {:?}", 5000 + seed, named(&r));
        }
        if !basis_found(&r).is_empty() {
            basis_pos += 1;
            println!("seed {}: open basis {:?}", 5000 + seed, basis_found(&r));
        }
        for (l, name) in motion_limits.iter_mut().zip(MOTION) {
            if let Some(v) = r
                .motion_loop
                .as_ref()
                .and_then(|m| m.steps.first())
                .and_then(|s| s.candidates.iter().find(|c| c.name == name))
                .and_then(|c| c.detection_limit)
            {
                l.0 += v;
                l.1 += 1;
            }
        }
        not_good += usize::from(r.quality != GyroQuality::Good);
        // The limits a clean recording states (first step: before anything is accepted).
        for (l, name) in limits.iter_mut().zip(["g-sensitivity", "bias-drift"]) {
            if let Some(v) = r.steps[0]
                .candidates
                .iter()
                .find(|c| c.name == name)
                .and_then(|c| c.detection_limit)
            {
                l.0 += v;
                l.1 += 1;
            }
        }
    }
    println!("clean: effects named in {false_pos}/{runs}, open-basis terms found in {basis_pos}/{runs}, verdict not good in {not_good}/{runs}");
    sweep_basis();
    let limits = limits.map(|(sum, n)| sum / n.max(1) as f64);
    println!(
        "mean limits: g-sensitivity {:.4} °/s/g, bias drift {:.4} °/s/h",
        limits[0], limits[1]
    );
    println!("| effect | injected | named | named as something else | nothing | window CV before → after, °/s |");
    println!("|---|---|---|---|---|---|");
    sweep_effect(
        "g-sensitivity",
        |t, v| t.g_sensitivity[0][2] = v.to_radians(),
        limits[0],
        "°/s/g",
    );
    sweep_effect(
        "bias-drift",
        |t, v| t.drift[1] = v.to_radians() / 3600.0,
        limits[1],
        "°/s/h",
    );
    let motion_limits = motion_limits.map(|(sum, n)| sum / n.max(1) as f64);
    println!(
        "mean motion limits: asymmetry {:.4} %, nonlinearity {:.4} % at 100 °/s, time offset {:.4} s",
        motion_limits[0], motion_limits[1], motion_limits[2]
    );
    println!("| effect | injected | named | named as something else | nothing | motion CV before → after, ° |");
    println!("|---|---|---|---|---|---|");
    for (name, lim) in MOTION.into_iter().zip(motion_limits) {
        let unit = ["%", "% at 100 °/s", "s"][MOTION.iter().position(|m| *m == name).unwrap_or(0)];
        sweep_motion(name, lim, unit);
    }
    let ramp = GyroTruth {
        temp_ramp: 10.0,
        ..Default::default()
    };
    let lim_t = run_sim(7, ramp).steps[0]
        .candidates
        .iter()
        .find(|c| c.name == "temperature")
        .and_then(|c| c.detection_limit)
        .expect("a temperature that changes is tested");
    sweep_effect(
        "temperature",
        |t, v| {
            t.temp_ramp = 10.0;
            t.temp_coef[2] = v.to_radians();
        },
        lim_t,
        "°/s/°C",
    );
}

/// What `wiical gyrofit FILE` does at default settings: both triplets from one file, the
/// nominal from the columns' unit or estimated.
fn default_run(path: &std::path::Path) -> GyroReport {
    default_try(path).unwrap()
}

/// [`default_run`], keeping the refusal.
fn default_try(path: &std::path::Path) -> Result<GyroReport, GyroError> {
    let (acc, gyro) =
        wiical_analysis::input::front_door::load_imu(path, &LoadOptions::default(), None).unwrap();
    let opts = match wiical_analysis::gyro::nominal_from_columns(&gyro) {
        Some((s, source)) => GyroOptions {
            nominal_source: source,
            ..GyroOptions::new(s)
        },
        None => GyroOptions::estimated(),
    };
    run(&acc, &gyro, &opts)
}

/// The verdicts of the real recordings at default settings (docs/gyro.md's table): the
/// sunsided full sphere is not usable (bursty timestamps), the Xsens pair has g-sensitivity
/// and a residual above its floor, the MPU-9150 units agree with their floors.
#[test]
fn real_recordings_verdicts() {
    let d = data_dir();
    let sun = default_run(&d.join("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv"));
    assert_eq!(sun.quality, GyroQuality::NotUsable, "{}", sun.verdict);
    assert!(
        sun.reasons.iter().any(|r| r.contains("bursts")),
        "{:?}",
        sun.reasons
    );
    let (acc, gyro) = xsens();
    let x = run(&acc, &gyro, &GyroOptions::estimated()).unwrap();
    assert_eq!(x.quality, GyroQuality::UnexplainedResidual, "{}", x.verdict);
    assert_eq!(named(&x), ["g-sensitivity"]);
    for unit in 0..5 {
        let r = default_run(&d.join(format!("mpu9150_mikoff_5units/imu{unit}.csv")));
        assert_eq!(r.quality, GyroQuality::Good, "imu{unit}: {}", r.verdict);
        assert!(r.effects.is_empty(), "imu{unit}: {:?}", named(&r));
    }
    let t = default_run(&d.join("mpu6050_multipos_tomisuarez/example_data_calibration.csv"));
    assert_eq!(t.quality, GyroQuality::UnexplainedResidual, "{}", t.verdict);
    // The Xsens residual: with its g-sensitivity applied to the motions the held-out error
    // falls to within 3× the floor, and the verdict says so.
    let m = x.motion_loop.as_ref().expect("motions fitted");
    assert_eq!(m.window_effects_applied, ["g-sensitivity"]);
    assert!(m.final_model.cv_rms_deg < 3.0 * x.noise_floor_deg, "{m:?}");
    assert!(
        x.verdict.contains("they account for the residual"),
        "{}",
        x.verdict
    );
    // Static logs: one refusal pointing to `noise`.
    for f in [
        "adis16405_static_smac/imu1.csv.gz",
        "mpu6050_hmc5883l_sunsided_set2/unmoved-with-x-pointing-forward_mpu6050.csv",
        "mpu6050_multipos_tomisuarez/example_data_tinit_calc.csv",
    ] {
        match default_try(&d.join(f)) {
            Err(e @ GyroError::GyroStaticOnly { .. }) => {
                assert!(e.to_string().contains("wiical noise"), "{f}: {e}")
            }
            other => panic!("{f}: expected the static refusal, got {:?}", other.err()),
        }
    }
}
