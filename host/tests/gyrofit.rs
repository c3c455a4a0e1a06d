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
    let out = std::env::temp_dir().join(format!("wiical-gyrofit-{}.json", std::process::id()));
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
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
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
    let (ok, _, err) = wiical(&["gyrofit", f]);
    assert!(
        !ok && err.contains("--scale") && err.contains("--counts-per-dps"),
        "{err}"
    );
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3,2e-3"]);
    assert!(!ok && err.contains("one value or three"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "0"]);
    assert!(!ok && err.contains("non-zero"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--counts-per-dps", "16"]);
    assert!(!ok && err.contains("not both"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--gyro-columns", "a,b,c"]);
    assert!(!ok && err.contains("column 'a' not found"), "{err}");
    let (ok, _, err) = wiical(&["gyrofit", f, "--scale", "1e-3", "--gyro-columns", "gx,gy"]);
    assert!(
        !ok && err.contains("--gyro-columns needs exactly three"),
        "{err}"
    );
}
