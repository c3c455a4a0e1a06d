//! `wiical noise` on the real 2.8-h static ADIS16405 log (gzip CSV, read as is) against the
//! datasheet figures quoted in its SOURCE.md, the JSON contract, and a short file refused in
//! one sentence. The estimator and term fit are checked against simulated noise with known
//! coefficients in `crates/analysis/src/noise/allan.rs`.

mod common;
use common::{data_dir, temp_file, wiical};
use serde_json::Value;

#[test]
fn adis16405_gyro_noise_density_is_the_datasheets_order_and_the_contract_holds() {
    let file = data_dir().join("adis16405_static_smac/imu1.csv.gz");
    let (ok, stdout, stderr) = wiical(&["noise", file.to_str().unwrap(), "--json"]);
    assert!(ok, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["samples"], 1_000_000);
    assert!((v["sample_rate_hz"].as_f64().unwrap() - 100.0).abs() < 1e-6);
    let axes = v["axes"].as_array().unwrap();
    let cols: Vec<&str> = axes.iter().map(|a| a["column"].as_str().unwrap()).collect();
    assert_eq!(cols, ["ax", "ay", "az", "gx", "gy", "gz"]);
    for a in axes {
        for key in [
            "column", "unit", "n", "b", "b_tau_s", "k", "q", "r", "tau_s", "adev",
        ] {
            assert!(a.get(key).is_some(), "{key} missing in {a}");
        }
        let (tau, adev) = (
            a["tau_s"].as_array().unwrap(),
            a["adev"].as_array().unwrap(),
        );
        assert_eq!(tau.len(), adev.len());
        assert!((tau[0].as_f64().unwrap() - 0.01).abs() < 1e-9);
    }
    // The accelerometer's magnitude says g; the gyro columns state no unit (°/s per SOURCE.md).
    assert_eq!(axes[0]["unit"], "g");
    assert!(axes[3]["unit"].is_null());
    // Datasheet: gyro noise density 0.05 °/s/√Hz (typical). The white-noise term of every
    // gyro axis is seen and within a factor of two of it.
    for a in &axes[3..] {
        let n = a["n"].as_f64().expect("N seen on every gyro axis");
        assert!((0.025..0.1).contains(&n), "{}: N = {n}", a["column"]);
    }
}

#[test]
fn a_recording_too_short_for_a_curve_is_one_sentence() {
    let f = temp_file(
        "noise",
        "short.csv",
        "t,x,y,z\n0,1,2,3\n0.01,1,2,3\n0.02,1,2,4\n",
    );
    let (ok, _, err) = wiical(&["noise", f.to_str().unwrap()]);
    assert!(
        !ok && err.contains("too few for an Allan deviation"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// `kalman-demo --noise`: σ_a = N/√dt from the noise file's noisiest accelerometer axis, in
/// m/s² (the ADIS16405's accelerometer is in g: ×9.80665), computed here from the JSON.
#[test]
fn kalman_demo_takes_its_noise_from_a_noise_file() {
    let file = data_dir().join("adis16405_static_smac/imu1.csv.gz");
    let (ok, noise, err) = wiical(&["noise", file.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noise.json");
    std::fs::write(&path, &noise).unwrap();
    let v: Value = serde_json::from_str(&noise).unwrap();
    let n_max = v["axes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["sensor"] == "accelerometer")
        .filter_map(|a| a["n"].as_f64())
        .fold(0.0f64, f64::max);
    let p = path.to_str().unwrap();
    let (ok, out, err) = wiical(&["kalman-demo", "--noise", p, "--runs", "20", "--json"]);
    assert!(ok, "{err}");
    let r: Value = serde_json::from_str(&out).unwrap();
    let dt = r["config"]["dt"].as_f64().unwrap();
    let sigma_a = r["config"]["accel_noise"].as_f64().unwrap();
    let want = n_max * 9.80665 / dt.sqrt();
    assert!((sigma_a / want - 1.0).abs() < 1e-5, "{sigma_a} vs {want}");
    // A gyro axis is not an accelerometer's noise: one sentence.
    let (ok, _, err) = wiical(&["kalman-demo", "--noise", p, "--noise-axis", "gx"]);
    assert!(!ok && err.contains("not g or m/s²"), "{err}");
}
