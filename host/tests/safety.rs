//! "Nothing lost, nothing absurd": every case a hostile user tried, through the
//! command line (or the library where a failure must be injected). Data-loss cases check that
//! the old file's bytes are intact after the failure.
mod common;
use common::{wiical, wiical_stdin};

use std::path::{Path, PathBuf};
use std::process::Command;

use embassy_futures::block_on;
use wiical::cmd::device::judge_for_put;
use wiical::device_sim::{SimFlash, FLASH_SIZE};
use wiical_adapter::store::Loaded;
use wiical_adapter::CalibrationStore;
use wiical_analysis::output::calfile::adapter_terms;
use wiical_analysis::output::calfile::{self, CalibrationFile};
use wiical_analysis::report::verdict::{Quality, Verdict};
use wiical_core::Calibration;

fn scratch(tag: &str) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-safety-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A recording `wiical fit` accepts: a simulated one.
fn simulated(dir: &Path) -> PathBuf {
    let rec = dir.join("victim.csv");
    let (ok, _, err) = wiical(&["simulate", "--out", s(&rec), "--seed", "3", "--poses", "14"]);
    assert!(ok, "{err}");
    rec
}

#[test]
fn an_output_equal_to_an_input_or_to_another_output_is_refused_and_nothing_changes() {
    let dir = scratch("collide");
    let rec = simulated(&dir);
    let before = std::fs::read(&rec).unwrap();
    let respelled = dir.join(".").join("victim.csv");
    for args in [
        vec!["fit", s(&rec), "--out", s(&rec)],
        vec!["fit", s(&rec), "--out", s(&respelled)],
        vec!["analyze", s(&rec), "--out", s(&rec), "--plot", s(&rec)],
        vec!["six-position", s(&rec), "--out", s(&rec)],
        vec!["magfit", s(&rec), "--out", s(&rec)],
        vec!["gyrofit", s(&rec), "--scale", "1", "--out", s(&rec)],
    ] {
        let (ok, _, err) = wiical(&args);
        assert!(!ok, "{args:?}");
        assert!(err.contains("it is the input"), "{args:?}: {err}");
        assert_eq!(std::fs::read(&rec).unwrap(), before, "{args:?}");
    }
    let same = dir.join("out.json");
    let (ok, _, err) = wiical(&["analyze", s(&rec), "--out", s(&same), "--plot", s(&same)]);
    assert!(!ok && err.contains("twice"), "{err}");
    assert!(!same.exists(), "nothing written");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn a_write_failure_leaves_the_old_calibration_intact() {
    // A file-size limit of 0 blocks makes every write fail (EFBIG; SIGXFSZ ignored so the
    // process sees the error): the good calibration must survive byte for byte.
    let dir = scratch("fsize");
    let rec = simulated(&dir);
    let good = dir.join("good_cal.json");
    let (ok, _, err) = wiical(&["fit", s(&rec), "--out", s(&good)]);
    assert!(ok, "{err}");
    let before = std::fs::read(&good).unwrap();
    let script = format!(
        "trap '' XFSZ; ulimit -f 0; exec '{}' fit '{}' --out '{}'",
        env!("CARGO_BIN_EXE_wiical"),
        s(&rec),
        s(&good)
    );
    let out = Command::new("sh").arg("-c").arg(&script).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("cannot write"), "{err}");
    assert_eq!(std::fs::read(&good).unwrap(), before);
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.ends_with(".tmp")),
        "temporary file left: {names:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn devices_and_endless_inputs_are_refused_quickly() {
    for args in [
        vec!["fit", "/dev/zero"],
        vec!["magfit", "/dev/zero"],
        vec!["six-position", "/dev/zero"],
        vec!["analyze", "/dev/zero"],
        vec![
            "device",
            "put",
            "/dev/zero",
            "--port",
            "/dev/does-not-exist",
        ],
    ] {
        let (ok, _, err) = wiical(&args);
        assert!(!ok, "{args:?}");
        assert!(err.contains("is not a regular file"), "{args:?}: {err}");
    }
    let (ok, _, err) = wiical(&[
        "device-sim",
        "--pty",
        "--flash",
        "/dev/zero",
        "--seconds",
        "1",
    ]);
    assert!(!ok && err.contains("not a regular file"), "{err}");
}

#[test]
fn counts_are_bounded() {
    let (ok, _, err) = wiical(&["kalman-demo", "--runs", "4294967295"]);
    assert!(!ok && err.contains("at most 100000"), "{err}");
    let (ok, _, err) = wiical(&["kalman-demo", "--runs", "100000000"]);
    assert!(!ok && err.contains("at most 100000"), "{err}");
    let (ok, _, err) = wiical(&["device", "info", "--retries", "4294967295"]);
    assert!(!ok && err.contains("not in 0..=20"), "{err}");
    let (ok, _, err) = wiical(&["device", "info", "--timeout-ms", "0"]);
    assert!(!ok && err.contains("--timeout-ms"), "{err}");
}

#[test]
fn time_that_goes_backwards_and_time_as_an_axis_are_refused() {
    let dir = scratch("time");
    let rec = simulated(&dir);
    let text = std::fs::read_to_string(&rec).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    // Swap two data rows somewhere in the middle: time goes backwards there.
    let n = lines.len() / 2;
    lines.swap(n, n + 1);
    let bad = dir.join("reversed.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let (ok, _, err) = wiical(&["fit", s(&bad)]);
    assert!(!ok, "{err}");
    assert!(
        err.contains(&format!("line {}: column 't'", n + 2)),
        "{err}"
    );
    assert!(err.contains("time goes from"), "{err}");
    let (ok, _, err) = wiical(&["fit", s(&rec), "--columns", "t,x,y"]);
    assert!(!ok && err.contains("'t' is not a sensor axis"), "{err}");
    let (ok, _, err) = wiical(&["fit", s(&rec), "--init-s", "0"]);
    assert!(!ok && err.contains("--init-s"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fit_prints_a_quality_verdict_and_stores_it_in_the_calibration() {
    let dir = scratch("verdict");
    let rec = simulated(&dir);
    let cal = dir.join("cal.json");
    let (ok, out, err) = wiical(&["fit", s(&rec), "--out", s(&cal)]);
    assert!(ok, "{err}");
    assert!(out.contains("quality: good"), "{out}");
    let file = calfile::read_calibration_file(&cal).unwrap();
    assert_eq!(file.quality.unwrap().verdict, Verdict::Good);
    // A `fit --json` report is not a calibration file (unknown keys).
    let (ok, json, _) = wiical(&["fit", s(&rec), "--json"]);
    assert!(ok);
    let report = dir.join("report.json");
    std::fs::write(&report, json).unwrap();
    let (ok, _, err) = wiical(&["device", "put", s(&report), "--port", "/dev/does-not-exist"]);
    assert!(!ok && err.contains("is not a calibration JSON"), "{err}");
    assert!(err.contains("unknown field"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn nunchuk_cal() -> Calibration {
    let mut cal = Calibration {
        bias: [505.0, 498.0, 519.0],
        ..Default::default()
    };
    for (i, row) in cal.matrix.iter_mut().enumerate() {
        row[i] = 1.0 / 200.0;
    }
    cal
}

fn good_quality() -> Quality {
    Quality {
        verdict: Verdict::Good,
        fit_rms_mg: 4.0,
        max_fit_rms_mg: 30.0,
        poses: 14,
        coverage_gap: None,
        residual: None,
    }
}

#[test]
fn device_put_refuses_absurd_or_poor_calibrations_and_names_ignored_terms() {
    let file = |cal: Calibration, quality: Option<Quality>| CalibrationFile {
        calibration: cal,
        quality,
        host_terms: Vec::new(),
    };
    let ok = judge_for_put(&file(nunchuk_cal(), Some(good_quality())));
    assert!(ok.refusals.is_empty() && ok.warnings.is_empty(), "{ok:?}");
    // The values the issue found accepted.
    type Spoil = fn(&mut Calibration);
    let absurd: [(&str, Spoil); 4] = [
        ("quadratic 1e30", |c| c.effects.quadratic[0] = 1e30),
        ("cubic 3e38", |c| c.effects.cubic[1] = 3e38),
        ("bias 1e30", |c| c.bias[2] = 1e30),
        ("temp_ref 1e38", |c| c.effects.temp_ref_c = 1e38),
    ];
    for (name, spoil) in absurd {
        let mut cal = nunchuk_cal();
        spoil(&mut cal);
        let check = judge_for_put(&file(cal, Some(good_quality())));
        assert_eq!(check.refusals.len(), 1, "{name}: {check:?}");
        assert!(
            check.refusals[0].contains("not plausible for a Nunchuk"),
            "{name}"
        );
    }
    let mut poor = good_quality();
    poor.verdict = Verdict::Poor;
    poor.coverage_gap = Some("no pose with the −z axis pointing up".into());
    let check = judge_for_put(&file(nunchuk_cal(), Some(poor)));
    assert!(check.refusals[0].contains("quality: POOR"), "{check:?}");
    // An unexplained residual: refused like a poor fit, uploadable with --force.
    let unexplained = good_quality().with_residual(Some(13.6), Some(0.31), Some(1e-20));
    assert_eq!(unexplained.verdict, Verdict::UnexplainedResidual);
    let check = judge_for_put(&file(nunchuk_cal(), Some(unexplained)));
    assert!(
        check.refusals[0].contains("UNEXPLAINED RESIDUAL"),
        "{check:?}"
    );
    assert!(
        check.refusals[0].contains("44× the noise floor"),
        "{check:?}"
    );
    let mut drift = nunchuk_cal();
    drift.effects.bias_drift = [0.01, 0.0, 0.0];
    drift.effects.scale_temp = [1e-4, 0.0, 0.0];
    let check = judge_for_put(&file(drift, Some(good_quality())));
    assert!(check.refusals.is_empty(), "{check:?}");
    assert_eq!(check.warnings.len(), 2, "{check:?}");
    assert!(check.warnings[0].contains("does not apply the bias_drift terms"));
    // Host terms (schema 3): named in a warning, with where they are applied.
    let host = CalibrationFile {
        host_terms: vec![wiical_analysis::output::host_term_checks::HostTerm {
            name: "scale-drift (z)".into(),
            family: "scale-drift".into(),
            axis: 2,
            value: 1e-6,
            unit: "1/s".into(),
            reference: wiical_analysis::output::host_term_checks::HostReference {
                time_s: Some(100.0),
                ..Default::default()
            },
            time_constant_s: None,
        }],
        ..file(nunchuk_cal(), Some(good_quality()))
    };
    let check = judge_for_put(&host);
    assert!(check.refusals.is_empty(), "{check:?}");
    assert_eq!(check.warnings.len(), 1, "{check:?}");
    assert!(
        check.warnings[0].contains("host terms scale-drift (z)")
            && check.warnings[0].contains("wiical correct"),
        "{check:?}"
    );
}

#[test]
fn device_put_refuses_before_opening_the_port_unless_forced() {
    let dir = scratch("put");
    let path = dir.join("absurd.json");
    let mut cal = nunchuk_cal();
    cal.effects.quadratic = [1e30, 0.0, 0.0];
    calfile::write_calibration_with(&path, &cal, Some(&good_quality())).unwrap();
    let (ok, _, err) = wiical(&["device", "put", s(&path), "--port", "/dev/does-not-exist"]);
    assert!(!ok);
    assert!(err.contains("refusing to upload"), "{err}");
    assert!(err.contains("--force"), "{err}");
    // With --force the check only warns; the missing port is then the error.
    let (ok, _, err) = wiical(&[
        "device",
        "put",
        s(&path),
        "--force",
        "--port",
        "/dev/does-not-exist",
    ]);
    assert!(!ok && err.contains("uploading with --force"), "{err}");
    assert!(err.contains("/dev/does-not-exist"), "{err}");
    // A misspelt effect term is not silently dropped.
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("\"bias_drift\"", "\"bias-drift\"");
    std::fs::write(&path, text).unwrap();
    let (ok, _, err) = wiical(&["device", "put", s(&path), "--port", "/dev/does-not-exist"]);
    assert!(!ok && err.contains("unknown field `bias-drift`"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn capture_outputs_must_differ_from_the_replayed_log_and_each_other() {
    let dir = scratch("capture");
    let log = dir.join("session.log");
    std::fs::write(&log, "# a raw session log\n").unwrap();
    let before = std::fs::read(&log).unwrap();
    let other = dir.join("rec.csv");
    let other_cal = dir.join("rec.csv.cal.json");
    for args in [
        vec!["capture", "--replay", s(&log), "--out", s(&log)],
        vec![
            "capture",
            "--replay",
            s(&log),
            "--out",
            s(&other),
            "--raw-log",
            s(&log),
        ],
    ] {
        let (ok, _, err) = wiical(&args);
        assert!(!ok && err.contains("it is the input"), "{args:?}: {err}");
        assert_eq!(std::fs::read(&log).unwrap(), before);
    }
    for raw in [&other, &other_cal] {
        let (ok, _, err) = wiical(&[
            "capture",
            "--replay",
            s(&log),
            "--out",
            s(&other),
            "--raw-log",
            s(raw),
        ]);
        assert!(!ok && err.contains("twice"), "{err}");
    }
    assert!(!other.exists() && !other_cal.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The calibration store on a file-mirrored simulated flash, cut at every mirror write of a
/// commit: a restart from the file must find the old calibration or the new one, never
/// nothing or an error (like the adapter store's own power-cut test, one level up).
#[test]
fn flash_mirror_power_cut_at_every_write_leaves_old_or_new() {
    let dir = scratch("powercut");
    let path = dir.join("flash.bin");
    let old = nunchuk_cal();
    let mut new = nunchuk_cal();
    new.bias = [500.0, 500.0, 500.0];
    let range = 0..FLASH_SIZE as u32;
    // The reference: how many mirror writes a commit takes, on an image holding `old`
    // (a few commits in, so the store also has to migrate pages at some cuts).
    let prepare = |commits: u32| {
        let _ = std::fs::remove_file(&path);
        let flash = SimFlash::file(&path).unwrap();
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        for _ in 0..commits {
            block_on(store.save(&old)).unwrap();
        }
    };
    let mut checked = 0;
    for commits in [1u32, 3] {
        let mut cut = 0u32;
        loop {
            prepare(commits);
            let image_before = std::fs::read(&path).unwrap();
            let mut flash = SimFlash::file(&path).unwrap();
            flash.cut_power_after(cut);
            let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
            let finished = block_on(store.save(&new)).is_ok();
            drop(store);
            // Restart from the file alone.
            let image = std::fs::read(&path).unwrap();
            assert_eq!(image.len(), FLASH_SIZE, "torn mirror at cut {cut}");
            let flash = SimFlash::file(&path).unwrap();
            let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
            let loaded = block_on(store.load()).unwrap();
            match loaded {
                Loaded::Calibration(c) if c == old || c == new => {}
                other => panic!("cut after {cut} writes ({commits} commits before): {other:?}"),
            }
            if cut == 0 {
                assert_eq!(
                    image, image_before,
                    "the first write was cut: file unchanged"
                );
            }
            checked += 1;
            if finished {
                assert_eq!(loaded, Loaded::Calibration(new));
                break;
            }
            cut += 1;
            assert!(cut < 1000, "a commit never finishes");
        }
        assert!(cut >= 2, "a commit takes several flash writes, got {cut}");
    }
    assert!(checked > 4);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The gyro record (issue 50 item 2) on the same file-mirrored flash, beside an accelerometer
/// calibration, cut at every mirror write of a gyro commit: a restart from the file finds the
/// old gyro calibration or the new one, and the accelerometer's calibration unchanged.
#[test]
fn flash_mirror_power_cut_during_a_gyro_commit_leaves_old_or_new_and_the_accelerometers() {
    use wiical_adapter::LoadedGyro;
    use wiical_core::gyro_correct::GyroCorrection;
    let dir = scratch("gyro-powercut");
    let path = dir.join("flash.bin");
    let k = std::f32::consts::PI / 180.0 / 18.6;
    let gyro = |zero: f32| GyroCorrection {
        bias: [zero, zero + 50.0, zero - 20.0],
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
        effects: Default::default(),
    };
    let (old, new) = (gyro(8150.0), gyro(8230.5));
    let acc = nunchuk_cal();
    let range = 0..FLASH_SIZE as u32;
    let prepare = |commits: u32| {
        let _ = std::fs::remove_file(&path);
        let flash = SimFlash::file(&path).unwrap();
        let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
        block_on(store.save(&acc)).unwrap();
        for _ in 0..commits {
            block_on(store.save_gyro(&old)).unwrap();
        }
    };
    let mut checked = 0;
    for commits in [1u32, 3] {
        let mut cut = 0u32;
        loop {
            prepare(commits);
            let mut flash = SimFlash::file(&path).unwrap();
            flash.cut_power_after(cut);
            let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
            let finished = block_on(store.save_gyro(&new)).is_ok();
            drop(store);
            let flash = SimFlash::file(&path).unwrap();
            let mut store = CalibrationStore::new(flash, range.clone()).unwrap();
            let g = block_on(store.load_gyro()).unwrap();
            match g {
                LoadedGyro::Calibration(c) if c == old || c == new => {}
                other => panic!("cut after {cut} writes ({commits} before): {other:?}"),
            }
            assert_eq!(
                block_on(store.load()).unwrap(),
                Loaded::Calibration(acc),
                "cut {cut}"
            );
            checked += 1;
            if finished {
                assert_eq!(g, LoadedGyro::Calibration(new));
                break;
            }
            cut += 1;
            assert!(cut < 1000, "a gyro commit never finishes");
        }
        assert!(cut >= 2, "a commit takes several flash writes, got {cut}");
    }
    assert!(checked > 4);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn standard_input_is_read_when_asked_for_with_a_dash() {
    let dir = scratch("stdin");
    let rec = simulated(&dir);
    let (ok, out, err) = wiical_stdin(&["fit", "-", "--json"], &rec);
    assert!(ok, "{err}");
    let from_stdin: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (ok, json, _) = wiical(&["fit", s(&rec), "--json"]);
    assert!(ok);
    let from_file: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(from_stdin["bias"], from_file["bias"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `device put` names the terms the adapter applies (bias and K, per-axis and
/// orientation cross terms) and those it leaves to hosts (time and temperature).
#[test]
fn device_put_names_the_terms_the_adapter_applies() {
    let linear = adapter_terms(&nunchuk_cal());
    assert_eq!(linear.applied, vec!["bias and K"]);
    assert!(linear.host_only.is_empty());
    let mut cal = nunchuk_cal();
    cal.effects.cubic[1] = 1e-3;
    cal.effects.cross_cubic[2][8] = 2e-3;
    cal.effects.bias_temp = [0.0, 0.1, 0.0];
    cal.effects.bias_drift = [1e-3, 0.0, 0.0];
    let t = adapter_terms(&cal);
    assert_eq!(
        t.applied,
        vec!["bias and K", "cubic", "cross_cubic (orientation)"]
    );
    assert_eq!(
        t.host_only,
        vec!["bias_drift (time)", "bias_temp (temperature)"]
    );
    let mut o = String::new();
    wiical::render::device::fmt_terms(&mut o, &t).unwrap();
    assert!(
        o.contains("applied by the adapter: bias and K, cubic, cross_cubic (orientation)\n"),
        "{o}"
    );
    assert!(
        o.contains("not applied by the adapter: bias_drift (time), bias_temp (temperature)"),
        "{o}"
    );
    // Cross terms of a plausible size are accepted for the adapter; absurd ones refused.
    let file = |cal: Calibration| CalibrationFile {
        calibration: cal,
        quality: Some(good_quality()),
        host_terms: Vec::new(),
    };
    let mut ok = nunchuk_cal();
    ok.effects.cross_quadratic[0] = [1e-3, -2e-3, 5e-4, 0.0, 0.0];
    assert!(judge_for_put(&file(ok)).refusals.is_empty());
    let mut absurd = nunchuk_cal();
    absurd.effects.cross_quadratic[1][4] = 1e30;
    let check = judge_for_put(&file(absurd));
    assert!(
        check.refusals[0].contains("not plausible for a Nunchuk"),
        "{check:?}"
    );
}
