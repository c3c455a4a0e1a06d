//! The gyro's effect terms on the way to a device: the g-sensitivity `gyrofit` accepts becomes
//! the core's correction (`wiical_core::gyro_correct::GyroCorrection`, `ω = K(m − b) − G·a`),
//! judged against the simulation's truth and by what it does to the samples at rest, in `f64`
//! and in the device's `f32`; the gyro calibration file round-trips it.

mod common;

use wiical_analysis::gyro::{run, GyroOptions, GyroReport};
use wiical_analysis::output::gyrocal::{parse, to_text, GyroCalFile};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Real;
use wiical_sim::gyro::{simulate_gyro, GyroSim, GyroSimOptions, GyroTruth};

/// The simulated gyro's true nominal (16.4 counts per °/s).
fn nominal() -> GyroOptions {
    GyroOptions {
        nominal_source: "--scale".into(),
        ..GyroOptions::new([1f64.to_radians() / 16.4; 3])
    }
}

/// The true G, °/s/g (row = gyro axis), of the size datasheets give (≈ 0.1–0.3 °/s/g).
const G_DPS: [[f64; 3]; 3] = [[0.3, -0.1, 0.2], [0.0, 0.25, -0.15], [0.1, 0.0, -0.3]];

fn simulate(seed: u64) -> (GyroSim, GyroReport) {
    let truth = GyroTruth {
        g_sensitivity: G_DPS.map(|r| r.map(f64::to_radians)),
        ..Default::default()
    };
    let sim = simulate_gyro(&GyroSimOptions {
        seed,
        truth,
        ..Default::default()
    });
    let rep = run(&sim.accel, &sim.gyro, &nominal()).expect("simulated gyro fits");
    (sim, rep)
}

/// Mean corrected rate over the samples where the simulated body rests (accelerometer
/// exactly still in the simulation: the gyro's truth is zero there), °/s, per axis, and the
/// RMS of those per-window means.
fn rest_means(sim: &GyroSim, correct: impl Fn([f64; 3], [f64; 3]) -> [f64; 3]) -> f64 {
    // Rests are runs of samples whose true rate is zero; the simulator's rests are its
    // `rest_s` blocks, found here as runs of ≥ 1 s where the accelerometer's mean moves less
    // than its noise (the samples themselves carry noise, so take 1-s block means).
    let per_block = sim.accel.sample_rate_hz.unwrap_or(100.0).round() as usize;
    let mut sq = Vec::new();
    for (acc, gyr) in sim
        .accel
        .xyz
        .chunks_exact(per_block)
        .zip(sim.gyro.xyz.chunks_exact(per_block))
    {
        let spread = (0..3)
            .map(|a| {
                let (lo, hi) = acc
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(l, h), s| (l.min(s[a]), h.max(s[a])));
                hi - lo
            })
            .fold(0.0, f64::max);
        if spread > 0.05 {
            continue; // a turn
        }
        let mut mean = [0.0; 3];
        for (a, m) in acc.iter().zip(gyr) {
            let w = correct(*m, *a);
            for i in 0..3 {
                mean[i] += w[i].to_degrees() / per_block as f64;
            }
        }
        sq.extend(mean.map(|x| x * x));
    }
    assert!(sq.len() > 30, "rest blocks found: {}", sq.len() / 3);
    (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
}

/// The accepted G lands in the correction within 4 standard errors of the truth, the bias
/// moves by the window model's constant, and the samples at rest corrected with it (the
/// accelerometer's reading as `a`) average to the gyro's noise, where without G they keep the
/// g-sensitivity's ≈ 0.2 °/s. The device's `f32` copy does the same.
#[test]
fn accepted_g_sensitivity_corrects_the_rests() {
    let (sim, rep) = simulate(11);
    let g = rep
        .effects
        .iter()
        .find(|e| e.name == "g-sensitivity")
        .expect("g-sensitivity accepted at 0.1–0.3 °/s/g");
    let c = rep.correction;
    for (r, row) in G_DPS.iter().enumerate() {
        for (j, truth) in row.iter().enumerate() {
            let got = c.effects.g_sensitivity[r][j].to_degrees();
            let se = g.std_errors[3 * r + j];
            assert!(
                (got - truth).abs() < 4.0 * se + 1e-3,
                "G[{r}][{j}] = {got} °/s/g, truth {truth} (se {se})"
            );
        }
    }
    let linear = GyroCorrection {
        effects: Default::default(),
        bias: rep.bias,
        matrix: rep.matrix,
    };
    let with_g = rest_means(&sim, |m, a| c.correct(m, a));
    let without = rest_means(&sim, |m, _| linear.correct_linear(m));
    let c32 = c.cast(f64::to_f32);
    let with_g32 = rest_means(&sim, |m, a| {
        c32.correct(m.map(|x| x as f32), a.map(|x| x as f32))
            .map(f64::from)
    });
    // The default simulation's gyro noise, 0.05 °/s per sample over 100-sample means, is
    // 0.005 °/s; the fitted G and bias add an error below it.
    assert!(with_g < 0.01, "rests with G: {with_g} °/s RMS");
    assert!(without > 3.0 * with_g, "without G {without}, with {with_g}");
    assert!(
        (with_g32 - with_g).abs() < 1e-4,
        "f32 {with_g32} vs f64 {with_g}"
    );
}

/// A clean simulation accepts nothing: the saved calibration is the fit's, version 1, the
/// layout the file had before the terms.
#[test]
fn nothing_accepted_saves_the_linear_calibration() {
    let sim = simulate_gyro(&GyroSimOptions {
        seed: 2,
        ..Default::default()
    });
    let rep = run(&sim.accel, &sim.gyro, &nominal()).expect("simulated gyro fits");
    assert!(rep.effects.is_empty());
    assert_eq!(rep.correction.bias, rep.bias);
    assert_eq!(rep.correction.matrix, rep.matrix);
    assert!(rep.correction.effects.is_none());
    let file = GyroCalFile {
        model: rep.model.into(),
        correction: rep.correction,
        cv_rms_deg: rep.cv_rms_deg,
    };
    let text = to_text(&file).unwrap();
    assert!(text.contains("wiical-gyro-calibration/1") && !text.contains("effects"));
}

/// The file of a run with G: version 2, `effects.g_sensitivity` in rad/s/g equal to the
/// report's °/s/g values, read back to the same terms.
#[test]
fn the_file_carries_the_accepted_g_sensitivity() {
    let (_, rep) = simulate(11);
    let g = rep
        .effects
        .iter()
        .find(|e| e.name == "g-sensitivity")
        .unwrap();
    let file = GyroCalFile {
        model: rep.model.into(),
        correction: rep.correction,
        cv_rms_deg: rep.cv_rms_deg,
    };
    let text = to_text(&file).unwrap();
    assert!(text.contains("\"format\": \"wiical-gyro-calibration/2\""));
    let back = parse(&text).unwrap();
    for r in 0..3 {
        for j in 0..3 {
            let saved = back.correction.effects.g_sensitivity[r][j].to_degrees();
            assert!((saved - g.values[3 * r + j]).abs() < 1e-12);
        }
    }
}

/// The IMU-TK Xsens pair at default settings (g-sensitivity accepted, entries up to
/// 0.15 °/s/g, docs/gyro.md): the correction carries the report's `G`, the file is version 2
/// and reads back to it.
#[test]
fn the_xsens_pair_saves_its_g_sensitivity() {
    use wiical_analysis::{load, LoadOptions};
    let dir = common::data_dir().join("imu_tk_xsens");
    let acc = load(&dir.join("xsens_acc.mat"), &LoadOptions::default()).unwrap();
    let gyro = load(&dir.join("xsens_gyro.mat"), &LoadOptions::default()).unwrap();
    let rep = run(&acc, &gyro, &GyroOptions::estimated()).unwrap();
    let g = rep
        .effects
        .iter()
        .find(|e| e.name == "g-sensitivity")
        .expect("the Xsens pair's g-sensitivity is accepted");
    let saved = rep.correction.effects.g_sensitivity;
    for (k, v) in g.values.iter().enumerate() {
        assert!((saved[k / 3][k % 3].to_degrees() - v).abs() < 1e-12);
    }
    assert!(g.values.iter().all(|v| v.abs() < 0.2));
    let text = to_text(&GyroCalFile {
        model: rep.model.into(),
        correction: rep.correction,
        cv_rms_deg: rep.cv_rms_deg,
    })
    .unwrap();
    assert!(text.contains("wiical-gyro-calibration/2"));
    let back = parse(&text).unwrap().correction.effects.g_sensitivity;
    for r in 0..3 {
        for j in 0..3 {
            assert!((back[r][j] - saved[r][j]).abs() <= 1e-15);
        }
    }
}
