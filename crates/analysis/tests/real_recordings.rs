//! Every accelerometer recording in the shared data at default settings: `fit` and `analyze`
//! take the same windows where a calibration is possible, and where it is not the error says
//! why in terms of the recording (a single pose, too few still moments, a six-position table).
//! The expectations come from each file's SOURCE.md (what was recorded), not from our output.

mod common;

use common::data_dir;
use wiical_analysis::fit::base as fit;
use wiical_analysis::fit::FitError;
use wiical_analysis::{analyze, load, AnalyzeOptions, Error, LoadOptions, Recording};

fn load_file(rel: &str) -> Recording {
    load(&data_dir().join(rel), &LoadOptions::default()).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// `fit` and `analyze` on the same file: the same windows, the same base fit to well below the
/// noise (the f32 core and its f64 refinement).
fn fit_and_analyze_agree(rel: &str) -> (usize, f64) {
    let rec = load_file(rel);
    let f = fit::run(&rec, &Default::default()).unwrap_or_else(|e| panic!("{rel}: fit: {e}"));
    let a = analyze(&rec, &AnalyzeOptions::default()).unwrap_or_else(|e| panic!("{rel}: {e}"));
    assert_eq!(f.static_windows, a.static_windows, "{rel}");
    for (w, aw) in f.windows.iter().zip(&a.windows) {
        assert_eq!(
            (w.t_start, w.samples.map(|n| n as usize)),
            (aw.t_start, aw.samples),
            "{rel}"
        );
    }
    assert!(
        (f64::from(f.rms_mg) - a.base.rms_mg).abs() < 0.01 * a.base.rms_mg.max(0.1),
        "{rel}: fit {} vs analyze base {}",
        f.rms_mg,
        a.base.rms_mg
    );
    (a.static_windows, a.base.rms_mg)
}

/// sunsided full-sphere: ~106 s of continuous rotation, timestamps stamped per FIFO read
/// (bursts 1–2 ms apart, then ~30 ms waits). Read at its real ~99 Hz (rows over span), the
/// adaptive detector finds the brief pauses; at the median step's ~480 Hz it found 6.
#[test]
fn sunsided_full_sphere_at_its_real_rate() {
    let rec = load_file("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv");
    let rate = rec.estimated_rate_hz().unwrap();
    assert!((rate - 99.0).abs() < 1.0, "{rate}");
    assert!(
        rec.notes.iter().any(|n| n.contains("bursts")),
        "{:?}",
        rec.notes
    );
    assert!(
        rec.info.iter().any(|n| n.contains("acc_x_g")),
        "which triplet was taken: {:?}",
        rec.info
    );
    let (windows, rms) =
        fit_and_analyze_agree("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv");
    assert!(windows >= 20, "{windows}");
    // A ±8 g MPU-6050 at 4096 LSB/g holding pauses in a hand: a few mg, not tens.
    assert!(rms < 15.0, "{rms}");
}

/// The other sunsided recordings are one pose each, or sweeps with fewer still moments than
/// the 9-parameter model has unknowns: the multi-position fit refuses them with the count and
/// the advice to re-record (no setting can help once the adaptive detector tried its shortest
/// holds); the residual analysis names the protocol it recognised instead (one pose, three
/// faces), which `fit` calibrates as far as it goes (`protocols_real.rs`).
#[test]
fn sunsided_single_poses_and_sweeps_are_refused_with_a_reason() {
    for (rel, most, protocol) in [
        (
            "roll-and-tilt-at-45-90_mpu6050.csv",
            8,
            "three faces (x+ y+ z-)",
        ),
        (
            "unmoved-with-x-pointing-forward_mpu6050.csv",
            2,
            "one pose (z- up",
        ),
        (
            "unmoved-with-z-pointing-front-and-x-up_mpu6050.csv",
            2,
            "one pose (x- up",
        ),
        (
            "unmoved-with-z-pointing-front-and-y-down_mpu6050.csv",
            2,
            "one pose (y+ up",
        ),
    ] {
        let rel = format!("mpu6050_hmc5883l_sunsided_set2/{rel}");
        let rec = load_file(&rel);
        match fit::run(&rec, &Default::default()).err() {
            Some(
                ref e @ Error::Fit(FitError::TooFewWindows {
                    found,
                    adaptive: true,
                    ..
                }),
            ) => {
                assert!(found <= most, "{rel}: {found}");
                assert!(e.to_string().contains("record again"), "{e}");
            }
            other => panic!("{rel}: {other:?}"),
        }
        match analyze(&rec, &AnalyzeOptions::default()).err() {
            Some(Error::Fit(FitError::Protocol { summary, why })) => {
                assert!(summary.starts_with(protocol), "{rel}: {summary}");
                assert!(why.contains("needs free poses or all six faces"), "{why}");
            }
            other => panic!("{rel}: {other:?}"),
        }
    }
}

/// GRT's Wii Remote files (normalised values, one orientation or five tilt classes): read as
/// recordings without time, refused for too few orientations (or named as one tilted pose).
#[test]
fn grt_wiimote_files_are_read_and_refused_for_too_few_poses() {
    for rel in [
        "wiimote_grt/acc-orientation.grt",
        "wiimote_grt/WiiAccShakeData.grt",
    ] {
        let rec = load_file(rel);
        assert!(rec.len() > 1400, "{rel}: {}", rec.len());
        assert!(rec.t.is_none());
        // Too few orientations for the multi-position fit; one pose (tilted 50° off every
        // axis: no offsets either) or too few windows for the analysis.
        let e = analyze(&rec, &AnalyzeOptions::default()).unwrap_err();
        assert!(
            matches!(
                &e,
                Error::Fit(FitError::TooFewWindows { adaptive: true, .. })
                    | Error::Fit(FitError::Protocol { .. })
            ),
            "{rel}: {e:?}"
        );
    }
}

/// The seed's six-position table goes to the six-position method in `analyze`; `fit`, which
/// searches samples for static windows, says what the file is instead of "too short".
#[test]
fn six_position_table_is_named_by_fit() {
    let rec = load_file("seed_six_position/wiimote_M.csv");
    let e = fit::run(&rec, &Default::default()).unwrap_err();
    assert!(
        matches!(e, Error::Fit(FitError::PoseTable { rows: 6 })),
        "{e:?}"
    );
    let a = analyze(&rec, &AnalyzeOptions::default()).unwrap();
    assert_eq!(a.mode, "six-position");
}

/// MPU-9150 units (accel + gyro columns `x,y,z,gx,gy,gz`): the accelerometer triplet is
/// taken and said, the windows agree, and nothing is invented (SOURCE.md: factory-calibrated
/// units on a turntable rig, residual at the noise).
#[test]
fn mpu9150_units_take_the_accelerometer_and_invent_nothing() {
    for k in 0..5 {
        let rel = format!("mpu9150_mikoff_5units/imu{k}.csv");
        let rec = load_file(&rel);
        assert!(
            rec.info.iter().any(|n| n.contains("gx,gy,gz")),
            "{rel}: {:?}",
            rec.info
        );
        assert_eq!(rec.axis_columns, ["x", "y", "z"]);
        fit_and_analyze_agree(&rel);
        let a = analyze(&rec, &AnalyzeOptions::default()).unwrap();
        assert!(
            a.effects.is_empty(),
            "{rel}: {:?}",
            a.effects.iter().map(|e| &e.name).collect::<Vec<_>>()
        );
    }
}

/// CK-Explorer's `acc_mag_log.csv` is continuous tumbling (SOURCE.md: recorded for the
/// magnetometer, with an already calibrated accelerometer): the detector's quietest moments
/// still move, and the analysis says the windows are not still (their means shortened by the
/// arc they average over, the residual following it). Its stepwise `acc_log.csv` and the
/// Xsens recording are still and get no such diagnostic.
#[test]
fn continuous_tumbling_is_diagnosed_as_not_still() {
    let moving = analyze(
        &load_file("acc_mag_ck_explorer/acc_mag_log.csv"),
        &AnalyzeOptions::default(),
    )
    .unwrap();
    assert!(
        moving.diagnostics.iter().any(|d| d.contains("not still")),
        "{:?}",
        moving.diagnostics
    );
    for rel in [
        "acc_mag_ck_explorer/acc_log.csv",
        "imu_tk_xsens/xsens_acc.mat",
    ] {
        let still = analyze(&load_file(rel), &AnalyzeOptions::default()).unwrap();
        assert!(
            !still.diagnostics.iter().any(|d| d.contains("not still")),
            "{rel}: {:?}",
            still.diagnostics
        );
    }
}

/// Every hold a window: filling the gaps of the long-hold setting with the 0.5 s setting's holds
/// never loses a window on a real recording. The counts are those of the detector before the
/// change (release binary of 89be00d, `scripts/windows-table`), the floor each must keep.
#[test]
fn real_recordings_keep_their_windows() {
    for (rel, before) in [
        ("imu_tk_xsens/xsens_acc.mat", 38),
        ("acc_mag_ck_explorer/acc_log.csv", 100),
        ("acc_mag_ck_explorer/acc_mag_log.csv", 18),
        ("mpu9150_mikoff_5units/imu0.csv", 22),
        ("mpu9150_mikoff_5units/imu1.csv", 22),
        ("mpu9150_mikoff_5units/imu2.csv", 22),
        ("mpu9150_mikoff_5units/imu3.csv", 22),
        ("mpu9150_mikoff_5units/imu4.csv", 22),
        ("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv", 30),
        (
            "mpu6050_hmc5883l_sunsided_set2/full-sphere_hmc5883l.csv",
            24,
        ),
        ("qmc5883l_mag_tomisuarez/filtered_raw_data.csv", 36),
        (
            "mpu6050_multipos_tomisuarez/example_data_calibration.csv",
            11,
        ),
    ] {
        let rec = load_file(rel);
        let ws = wiical_analysis::detect::windows::detect_windows(&rec, &Default::default())
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
        assert!(
            ws.stats.len() >= before,
            "{rel}: {} windows, {before} before",
            ws.stats.len()
        );
    }
}

/// Single terms: with single-axis nonlinearities among the candidates (and the Bonferroni
/// level over every hypothesis tested), every real recording keeps the quality verdict and the
/// named effects it had before (release binary of d3e0ac6, `scripts/windows-table`; the
/// recordings' SOURCE.md: CK-Explorer's stepwise `acc_log.csv` is a hobby MEMS whose quadratic
/// the block search found, the MPU-9150 units are factory-calibrated, the others have nothing
/// the library describes or too few poses to say).
#[test]
fn real_recordings_keep_their_verdicts_and_effects() {
    use wiical_analysis::input::front_door::load_input;
    use wiical_analysis::input::window_means::WindowInputOptions;
    for (rel, verdict, named) in [
        ("imu_tk_xsens/xsens_acc.mat", "unexplained-residual", ""),
        ("acc_mag_ck_explorer/acc_log.csv", "good", "quadratic"),
        (
            "acc_mag_ck_explorer/acc_mag_log.csv",
            "unexplained-residual",
            "",
        ),
        ("mpu9150_mikoff_5units/imu0.csv", "good", ""),
        ("mpu9150_mikoff_5units/imu1.csv", "good", ""),
        ("mpu9150_mikoff_5units/imu2.csv", "good", ""),
        ("mpu9150_mikoff_5units/imu3.csv", "good", ""),
        ("mpu9150_mikoff_5units/imu4.csv", "good", ""),
        (
            "mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv",
            "poor",
            "",
        ),
        (
            "mpu6050_hmc5883l_sunsided_set2/full-sphere_hmc5883l.csv",
            "poor",
            "",
        ),
        ("qmc5883l_mag_tomisuarez/filtered_raw_data.csv", "poor", ""),
        (
            "mpu6050_multipos_tomisuarez/example_data_calibration.csv",
            "poor",
            "",
        ),
        ("seed_six_position/wiimote_M.csv", "good", ""),
    ] {
        let input = load_input(&data_dir().join(rel), &WindowInputOptions::default())
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
        let j = wiical_analysis::pipeline::analyze_judged(&input, &AnalyzeOptions::default())
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
        let got = serde_json::to_value(j.quality.verdict).unwrap();
        assert_eq!(got, verdict, "{rel}: {}", j.report.verdict);
        let names: Vec<&str> = j.report.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names.join(","), named, "{rel}: {}", j.report.verdict);
    }
}
