//! Single-axis effects: a recording too short for a whole 3-parameter block
//! can still test one axis of it, and `analyze` names the axis (`quadratic (z)`), stores the
//! term in the same `Effects` field with the other axes zero, and invents nothing on clean
//! recordings. The sweep behind the table of docs/residuals.md is the ignored test at the end.

use wiical_analysis::{analyze, AnalyzeOptions, AnalyzeReport};
use wiical_sim::{Device, EffectSpec, SimConfig, SimEffect};

/// `windows` windows (the initial rest and `windows − 1` poses) with `effect` of `magnitude`
/// mg on axis `axis` alone.
fn run(
    effect: SimEffect,
    magnitude: f64,
    axis: usize,
    windows: usize,
    seed: u64,
) -> (AnalyzeReport, wiical_sim::SimOutput) {
    let sim = wiical_sim::simulate(&SimConfig {
        effects: vec![EffectSpec::on_axis(effect, Some(magnitude), axis)],
        seed,
        device: device(seed),
        poses: windows - 1,
        ..Default::default()
    })
    .unwrap();
    let r = analyze(&sim.recording, &AnalyzeOptions::default()).unwrap();
    (r, sim)
}

fn device(seed: u64) -> Device {
    if seed.is_multiple_of(2) {
        Device::Wiimote
    } else {
        Device::Nunchuk
    }
}

fn names(r: &AnalyzeReport) -> Vec<String> {
    r.effects.iter().map(|e| e.name.clone()).collect()
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// The case: 14 windows are too few for a whole quadratic block (9 + 3 parameters and
/// 3 degrees of freedom), but one axis of it is tested, found, named with its axis and stored
/// in `effects.quadratic` with the other two axes zero; the value is the simulated one within
/// 4 standard errors. The verdict still lists the whole blocks it could not test.
#[test]
fn a_one_axis_quadratic_is_found_in_fourteen_windows() {
    for seed in 1..=3u64 {
        let axis = (seed % 3) as usize;
        let (r, sim) = run(SimEffect::Quadratic, 40.0, axis, 14, seed);
        assert_eq!(r.static_windows, 14, "seed {seed}");
        let want = format!("quadratic ({})", AXES[axis]);
        assert_eq!(
            names(&r),
            std::slice::from_ref(&want),
            "seed {seed}:\n{}",
            r.verdict
        );
        let e = &r.effects[0];
        assert_eq!(e.params, 1);
        assert!(e.evidence.contains("mg/g²"), "{}", e.evidence);
        let q = r.calibration.effects.quadratic;
        let truth = sim.truth.calibration.effects.quadratic;
        for a in 0..3 {
            if a == axis {
                let (v, se) = (e.values.unwrap()[a], e.std_errors.unwrap()[a]);
                let t = f64::from(truth[a]) * 1e3;
                assert!((v - t).abs() <= 4.0 * se, "seed {seed}: {v} ± {se} vs {t}");
                assert!((f64::from(q[a]) * 1e3 - v).abs() < 1e-3 * v.abs().max(1.0));
            } else {
                assert_eq!(q[a], 0.0, "seed {seed}: axis {a} stored {q:?}");
            }
        }
        // The whole block was not testable (one window short), the axis was; the verdict
        // says what could not be tested (the rest of the block, with the windows it needs).
        let step = &r.steps[0];
        let block = step
            .candidates
            .iter()
            .find(|c| c.name == "quadratic")
            .unwrap();
        assert_eq!(block.windows_short, Some(1), "seed {seed}: {}", block.note);
        assert!(step.candidates.iter().any(|c| c.name == want && c.passed));
        let rest: Vec<&str> = AXES.iter().filter(|a| **a != AXES[axis]).copied().collect();
        let untested = format!(
            "Not tested, too few windows: quadratic ({}) (needs 1 more window)",
            rest.join(", ")
        );
        assert!(r.verdict.contains(&untested), "seed {seed}: {}", r.verdict);
    }
}

/// Clean 14-window recordings: with single axes as candidates (more tests per step, each at
/// the Bonferroni level over all of them), nothing is named, and the verdict does not say that
/// nothing is missing (the whole blocks were not tested).
#[test]
fn clean_short_recordings_invent_nothing() {
    for seed in 0..12u64 {
        let sim = wiical_sim::simulate(&SimConfig {
            seed: 7000 + seed,
            device: device(seed),
            poses: 13,
            temp_column: seed % 3 != 0,
            ..Default::default()
        })
        .unwrap();
        let r = analyze(&sim.recording, &AnalyzeOptions::default()).unwrap();
        assert!(r.effects.is_empty(), "seed {seed}: {:?}", names(&r));
        assert!(!r
            .verdict
            .contains("nothing the candidates describe is missing"));
        assert!(r.verdict.contains("Not tested"), "{}", r.verdict);
    }
}

/// A whole-block quadratic in a full recording is still named as the block (the block explains
/// every axis, so its CV is the lowest), not as one of its axes.
#[test]
fn a_whole_block_is_still_named_as_the_block() {
    for seed in 1..=2u64 {
        let sim = wiical_sim::simulate(&SimConfig {
            effects: vec![EffectSpec::new(SimEffect::Quadratic, None)],
            seed,
            device: device(seed),
            ..Default::default()
        })
        .unwrap();
        let r = analyze(&sim.recording, &AnalyzeOptions::default()).unwrap();
        assert_eq!(names(&r), ["quadratic"], "seed {seed}:\n{}", r.verdict);
    }
}

/// Outcome counts of one row of the detection table.
#[derive(Default)]
struct Row {
    axis: usize,
    block: usize,
    wrong: usize,
    nothing: usize,
    cuts: Vec<f64>,
}

/// One row: `runs` recordings of `windows` windows with `effect` of `magnitude` mg on one
/// axis (x, y, z in turn; Wiimote and Nunchuk alternating; seeds 8000…).
fn row(effect: SimEffect, magnitude: f64, windows: usize, runs: u64) -> String {
    let mut row = Row::default();
    for seed in 0..runs {
        let axis = (seed % 3) as usize;
        let (r, _) = run(effect, magnitude, axis, windows, 8000 + seed);
        let got = names(&r);
        let one = format!("{} ({})", effect.name(), AXES[axis]);
        match got.as_slice() {
            [] => row.nothing += 1,
            [g] if *g == one => row.axis += 1,
            [g] if g == effect.name() => row.block += 1,
            _ => row.wrong += 1,
        }
        if let (Some(b), Some(f)) = (r.base.cv_rms_mg, r.final_model.cv_rms_mg) {
            row.cuts.push(b / f);
        }
    }
    row.cuts.sort_by(|a, b| a.total_cmp(b));
    let median = row
        .cuts
        .get(row.cuts.len() / 2)
        .copied()
        .unwrap_or(f64::NAN);
    format!(
        "| {} | {windows} | {magnitude} | {runs} | {} | {} | {} | {} | {median:.2} |\n",
        effect.name(),
        row.axis,
        row.block,
        row.wrong,
        row.nothing
    )
}

/// The single-term detection table of docs/residuals.md:
/// `cargo test -p wiical-analysis --release --test single_terms -- --ignored --nocapture single_term_sweep`
#[test]
#[ignore]
fn single_term_sweep() {
    let mut out = String::from(
        "| effect (one axis) | windows | magnitude (mg) | runs | named with its axis | named as the block | wrong | nothing | median CV cut |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for effect in [SimEffect::Quadratic, SimEffect::Cubic] {
        for windows in [14, 20, 28] {
            for magnitude in [10.0, 20.0, 40.0] {
                let line = row(effect, magnitude, windows, 30);
                eprint!("{line}");
                out += &line;
            }
        }
    }
    println!("{out}");
}
