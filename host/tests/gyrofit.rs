//! `wiical gyrofit`'s CLI contract: the JSON keys, `--out`, and readable errors. The numbers
//! themselves are tested against an independent implementation in
//! `crates/analysis/tests/gyro.rs`.

mod common;
use common::data_dir;
use common::wiical;

use serde_json::Value;

#[test]
fn json_contract_and_out_file_on_an_mpu9150_unit() {
    let file = data_dir().join("mpu9150_mikoff_5units/imu1.csv");
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-gyrofit-{}.json", std::process::id()));
    let (ok, stdout, stderr) = wiical(&[
        "gyrofit",
        file.to_str().unwrap(),
        "--counts-per-dps",
        "16.384",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    for key in [
        "static_windows",
        "motions",
        "bias",
        "matrix",
        "rms_deg_before",
        "rms_deg_after",
        "cv_rms_deg",
        // The loop's keys, in `analyze`'s shape.
        "noise_floor_deg",
        "noise_floor_window_dps",
        "base",
        "effects",
        "final",
        "steps",
        "quality",
        "verdict",
        "diagnostics",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    // Every candidate not accepted carries its detection limit in its unit.
    for step in v["steps"].as_array().unwrap() {
        for c in step["candidates"].as_array().unwrap() {
            if !c["passed"].as_bool().unwrap() {
                assert!(c["detection_limit"].as_f64().unwrap() > 0.0, "{c}");
                assert!(!c["unit"].as_str().unwrap().is_empty());
            }
        }
    }
    assert_eq!(v["bias"].as_array().unwrap().len(), 3);
    assert!(v["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r.as_array().unwrap().len() == 3));
    assert!(v["cv_rms_deg"].as_f64().unwrap() <= v["rms_deg_before"].as_f64().unwrap());
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(saved["model"], v["model"]);
    assert_eq!(saved["matrix"], v["matrix"]);
    assert_eq!(saved["units"], "rad/s");
    // --scale with the same sensitivity gives the same result.
    let s = format!("{}", 1f64.to_radians() / 16.384);
    let (ok, stdout2, _) = wiical(&["gyrofit", file.to_str().unwrap(), "--scale", &s, "--json"]);
    assert!(ok);
    let v2: Value = serde_json::from_str(&stdout2).unwrap();
    assert_eq!(v2["matrix"], v["matrix"]);
}

#[test]
fn readable_errors() {
    let file = data_dir().join("mpu9150_mikoff_5units/imu1.csv");
    let f = file.to_str().unwrap();
    // No datasheet number and no unit in the names: the nominal comes from the motions.
    let (ok, out, err) = wiical(&["gyrofit", f, "--json"]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(v["nominal_source"]
        .as_str()
        .unwrap()
        .starts_with("estimated from the motions"));
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3,2e-3"]);
    assert!(
        !ok && err.contains("--scale takes one value or three"),
        "{err}"
    );
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "0"]);
    assert!(!ok && err.contains("non-zero"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--counts-per-dps", "16"]);
    assert!(
        !ok && err.contains("give either --scale or --counts-per-dps, not both"),
        "{err}"
    );
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--gyro-columns", "a,b,c"]);
    assert!(!ok && err.contains("column 'a' not found"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--gyro-columns", "gx,gy"]);
    assert!(
        !ok && err.contains("--gyro-columns needs exactly three"),
        "{err}"
    );
}

/// `wiical fit --json`'s windows as (t_start, t_end).
fn fit_windows(args: &[&str]) -> Vec<(f64, f64)> {
    let mut all = vec!["fit"];
    all.extend_from_slice(args);
    all.push("--json");
    let (ok, stdout, stderr) = wiical(&all);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    v["windows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| (w["t_start"].as_f64().unwrap(), w["t_end"].as_f64().unwrap()))
        .collect()
}

/// gyrofit's windows are fit's: as many, and every motion runs from the last sample of one of
/// fit's windows to the first of the next.
fn assert_same_windows(gyro: &Value, fit: &[(f64, f64)], what: &str) {
    assert_eq!(
        gyro["static_windows"].as_u64().unwrap() as usize,
        fit.len(),
        "{what}"
    );
    let motions = gyro["motion_table"].as_array().unwrap();
    assert_eq!(motions.len() + 1, fit.len(), "{what}");
    for (i, m) in motions.iter().enumerate() {
        let (t0, t1) = (m["t_start"].as_f64().unwrap(), m["t_end"].as_f64().unwrap());
        assert_eq!((t0, t1), (fit[i].1, fit[i + 1].0), "{what}: motion {i}");
    }
}

#[test]
fn sunsided_full_sphere_needs_no_flags_and_uses_fits_windows() {
    let file = data_dir().join("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv");
    let f = file.to_str().unwrap();
    let (ok, stdout, stderr) = wiical(&["gyrofit", f, "--json"]);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_same_windows(&v, &fit_windows(&[f]), "sunsided");
    assert_eq!(v["static_windows"], 30);
    // The unit comes from the names: 1 count = 1 °/s, and the JSON says so.
    let s0 = 1f64.to_radians();
    assert!(v["nominal_rad_per_count"]
        .as_array()
        .unwrap()
        .iter()
        .all(|x| (x.as_f64().unwrap() - s0).abs() < 1e-15));
    assert!(v["nominal_source"].as_str().unwrap().contains("deg/s"));
    // Each warning once (the file is read once for both sensors).
    assert_eq!(
        stderr.matches("timestamps come in bursts").count(),
        1,
        "{stderr}"
    );
    assert_eq!(stderr.matches("took gyro_x_dps").count(), 1, "{stderr}");
    // The author's README says the gyro's X axis has a flipped sign: the fit finds it.
    assert!(v["matrix"][0][0].as_f64().unwrap() < 0.0);
    assert!(v["notes"]
        .to_string()
        .contains("x gyro axis turns the other way"));
    // Before/after and held out, like the Xsens run.
    let (before, cv) = (
        v["rms_deg_before"].as_f64().unwrap(),
        v["cv_rms_deg"].as_f64().unwrap(),
    );
    assert!(cv < before, "{cv} vs {before}");
    let (ok, text, _) = wiical(&["gyrofit", f]);
    assert!(ok && text.contains("from the columns' unit") && text.contains("held-out"));
}

#[test]
fn xsens_pair_uses_fits_windows() {
    let dir = data_dir().join("imu_tk_xsens");
    let (acc, gyro) = (dir.join("xsens_acc.mat"), dir.join("xsens_gyro.mat"));
    let (a, g) = (acc.to_str().unwrap(), gyro.to_str().unwrap());
    let (ok, stdout, stderr) = wiical(&["gyrofit", a, g, "--scale", "1.598e-4", "--json"]);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_same_windows(&v, &fit_windows(&[a]), "xsens");
    assert_eq!(v["nominal_source"], "--scale");
}

#[test]
fn mpu9150_units_use_fits_windows() {
    for unit in 0..5 {
        let file = data_dir().join(format!("mpu9150_mikoff_5units/imu{unit}.csv"));
        let f = file.to_str().unwrap();
        let (ok, stdout, stderr) = wiical(&["gyrofit", f, "--counts-per-dps", "16.384", "--json"]);
        assert!(ok, "{stderr}");
        let v: Value = serde_json::from_str(&stdout).unwrap();
        assert_same_windows(&v, &fit_windows(&[f]), &format!("imu{unit}"));
        assert_eq!(v["static_windows"], 22);
    }
}

#[test]
fn an_accelerometer_only_file_is_not_taken_for_a_gyro() {
    let file = data_dir().join("acc_mag_ck_explorer/acc_log.csv");
    let (ok, _, err) = wiical(&["gyrofit", file.to_str().unwrap(), "--scale", "1e-3"]);
    assert!(!ok && err.contains("no gyroscope columns"), "{err}");
}
