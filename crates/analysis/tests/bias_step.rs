//! The bias step (a knock): a step of one axis's bias put into a simulated recording and into
//! a real one at a known moment between two holds is named as a step (`bias-step (x, between
//! windows k and k+1 …)`, the windows the moment falls between), its size within 3 of its
//! stated standard errors of the truth, and not taken for a drift; clean simulations name no
//! step. The accelerometer's side (`search::bias_step`); the gyro's is in `gyro_bias_step.rs`.

mod common;

use common::data_dir;
use common::sim::sim;
use wiical_analysis::{analyze, load, AnalyzeOptions, AnalyzeReport, LoadOptions, Recording};
use wiical_sim::Device;

/// Adds `step` (file units) to axis `axis` of every sample at or after `t0` (s, the
/// recording's clock).
fn inject(rec: &mut Recording, default_rate_hz: f64, axis: usize, t0: f64, step: f64) {
    let times = rec.times(default_rate_hz);
    for (x, t) in rec.xyz.iter_mut().zip(times) {
        if t >= t0 {
            x[axis] += step;
        }
    }
}

/// The 1-based window `k` such that `t0` falls between windows `k` and `k + 1` of the report's
/// window table (`None` when it falls inside a window).
fn gap_of(r: &AnalyzeReport, t0: f64) -> Option<usize> {
    r.windows
        .windows(2)
        .position(|w| w[0].t_end < t0 && t0 < w[1].t_start)
        .map(|i| i + 1)
}

/// The step rows of a report.
fn steps(r: &AnalyzeReport) -> Vec<&wiical_analysis::report::contract::EffectReport> {
    r.effects
        .iter()
        .filter(|e| e.name.starts_with("bias-step"))
        .collect()
}

/// Checks the report names one step on `axis` at the gap holding `t0`, of size `truth` (file
/// units) within 3 standard errors, and no bias drift; returns (value, se).
fn check_step(r: &AnalyzeReport, axis: usize, t0: f64, truth: f64) -> (f64, f64) {
    let names: Vec<&str> = r.effects.iter().map(|e| e.name.as_str()).collect();
    let found = steps(r);
    assert_eq!(found.len(), 1, "{names:?}");
    let e = found[0];
    let k = gap_of(r, t0).expect("the step falls between two windows");
    let axis_name = ["x", "y", "z"][axis];
    assert!(
        e.name.starts_with(&format!(
            "bias-step ({axis_name}, between windows {k} and {}",
            k + 1
        )),
        "{} (expected the gap after window {k})",
        e.name
    );
    assert!(
        !names.contains(&"bias-drift"),
        "absorbed by a drift: {names:?}"
    );
    let (v, se) = (e.values.unwrap()[axis], e.std_errors.unwrap()[axis]);
    assert!(se > 0.0 && se.is_finite(), "{e:?}");
    assert!(
        (v - truth).abs() <= 3.0 * se,
        "step {v} ± {se}, truth {truth}: {}",
        e.evidence
    );
    assert!(e.evidence.starts_with("step of "), "{}", e.evidence);
    (v, se)
}

/// A 16-bit MEMS, 30 holds, a 15 mg step of x's bias in the gap after hold 12 (sim seeds 1–3):
/// named at that gap, within 3 σ; the same recording without the step names none.
#[test]
fn a_simulated_step_is_named_with_its_size_and_place() {
    for seed in 1..=3u64 {
        let s = sim(&[], seed, Device::Mems16);
        let rate = s.truth.rate_hz;
        let k_per_g = f64::from(s.truth.calibration.matrix[0][0]);
        let truth = 0.015 / k_per_g;
        let p = &s.truth.poses;
        let t0 = 0.5 * (p[11].t_end + p[12].t_start);
        let clean = analyze(&s.recording, &AnalyzeOptions::default()).unwrap();
        assert!(steps(&clean).is_empty(), "seed {seed}: {:?}", clean.effects);
        let mut rec = s.recording.clone();
        inject(&mut rec, rate, 0, t0, truth);
        let r = analyze(&rec, &AnalyzeOptions::default()).unwrap();
        let (v, se) = check_step(&r, 0, t0, truth);
        eprintln!("seed {seed}: step {v:.6} ± {se:.6}, truth {truth:.6} (file units)");
    }
}

/// Clean simulations (no step) on a Nunchuk and a 16-bit MEMS name no step: 8 seeds each.
#[test]
fn clean_simulations_name_no_step() {
    for device in [Device::Nunchuk, Device::Mems16] {
        for seed in 40..48u64 {
            let s = sim(&[], seed, device);
            let r = analyze(&s.recording, &AnalyzeOptions::default()).unwrap();
            assert!(
                steps(&r).is_empty(),
                "{device:?} seed {seed}: {:?}",
                r.effects
            );
        }
    }
}

/// A real recording (MPU-9150 unit 0, 22 holds, judged good with no effect): a step of y's
/// bias of 12 mg between its 11th and 12th holds is named there within 3 σ, and the recording
/// as it is names none.
#[test]
fn a_step_injected_into_a_real_recording_is_named() {
    let path = data_dir().join("mpu9150_mikoff_5units/imu0.csv");
    let rec = load(&path, &LoadOptions::default()).unwrap();
    let clean = analyze(&rec, &AnalyzeOptions::default()).unwrap();
    assert!(steps(&clean).is_empty(), "{:?}", clean.effects);
    let w = &clean.windows;
    let t0 = 0.5 * (w[10].t_end + w[11].t_start);
    let k_per_g = f64::from(clean.calibration.matrix[1][1]);
    let truth = 0.012 / k_per_g;
    let mut stepped = rec.clone();
    inject(&mut stepped, 100.0, 1, t0, truth);
    let r = analyze(&stepped, &AnalyzeOptions::default()).unwrap();
    let (v, se) = check_step(&r, 1, t0, truth);
    eprintln!("imu0: step {v:.4} ± {se:.4}, truth {truth:.4}");
}
