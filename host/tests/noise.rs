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
        assert!(a["joint_fit"].get("n").is_some(), "{a}");
    }
    // The same log through allantools (PyPI), the curve and the IEEE 952 reading.
    peer_curve_and_reading(&file, &axes[3..]);
}

/// allantools' `oadev` on the gyro columns, read by numpy from the same file: the curve
/// must equal ours to 5 digits at every τ, and the terms must be what the reading rules give
/// on allantools' own curve, computed here: N = σ at τ = 1 s (interpolated in log-log; this
/// log's −½ line spans 0.08–5 s, so that is the line's value), B = σ_min / 0.664 at its τ.
fn peer_curve_and_reading(file: &std::path::Path, gyro: &[Value]) {
    const SCRIPT: &str = r#"
import sys, json, gzip
try:
    import numpy as np, allantools
except ImportError as e:
    sys.exit(f"allantools (PyPI) is missing: run scripts/setup or pip install allantools ({e})")
d = np.loadtxt(gzip.open(sys.argv[1], 'rt'), delimiter=',', skiprows=1, usecols=(1, 2, 3))
taus = np.array(json.loads(sys.argv[2]))
out = []
for i in range(3):
    t, ad, _, _ = allantools.oadev(d[:, i], rate=100.0, data_type='freq', taus=taus)
    out.append({'tau_s': list(t), 'adev': list(ad)})
print(json.dumps(out))
"#;
    let taus = gyro[0]["tau_s"].to_string();
    let out = std::process::Command::new("python3")
        .args(["-c", SCRIPT, file.to_str().unwrap(), &taus])
        .output()
        .expect("python3 is needed for the allantools comparison");
    assert!(
        out.status.success(),
        "allantools comparison failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let peer: Vec<Value> = serde_json::from_slice(&out.stdout).unwrap();
    let f = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    for (ours, theirs) in gyro.iter().zip(&peer) {
        let col = &ours["column"];
        let (tau, adev) = (f(&theirs["tau_s"]), f(&theirs["adev"]));
        for (a, b) in f(&ours["tau_s"]).iter().zip(&tau) {
            assert!((a / b - 1.0).abs() < 1e-9, "{col}: τ {a} vs allantools {b}");
        }
        for (a, b) in f(&ours["adev"]).iter().zip(&adev) {
            assert!((a / b - 1.0).abs() < 1e-5, "{col}: {a} vs allantools {b}");
        }
        // N: σ(1 s) by log-log interpolation between the points around it.
        let i = tau.iter().position(|t| *t > 1.0).unwrap();
        let w = (1f64.ln() - tau[i - 1].ln()) / (tau[i].ln() - tau[i - 1].ln());
        let n_rule = (adev[i - 1].ln() * (1.0 - w) + adev[i].ln() * w).exp();
        let n = ours["n"].as_f64().unwrap();
        assert!(
            (n / n_rule - 1.0).abs() < 0.03,
            "{col}: N {n} vs σ(1 s) {n_rule}"
        );
        // B: the minimum of the curve over 0.664, at its τ.
        let (k, min) = adev
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap();
        // gz's curve turns up into a random walk at its end: its B may be unread (null).
        if let Some(b) = ours["b"].as_f64() {
            assert!(
                (b * 0.664 / min - 1.0).abs() < 1e-5,
                "{col}: B {b} vs σ_min {min}"
            );
            let bt = ours["b_tau_s"].as_f64().unwrap();
            assert!(
                (bt / tau[k] - 1.0).abs() < 1e-9,
                "{col}: B at {bt} vs {}",
                tau[k]
            );
        }
    }
    // The issue's numbers for gx: N ≈ 0.041 °/s/√Hz, B = σ_min/0.664 ≈ 0.0092–0.0106 °/s.
    // gx's curve still falls at its last τ (655 s), so the reading withholds B (an upper
    // bound only); σ_min/0.664 there is the issue's figure.
    let n = gyro[0]["n"].as_f64().unwrap();
    assert!((0.0395..0.0420).contains(&n), "gx N = {n}");
    let adev = f(&peer[0]["adev"]);
    let bound = adev.iter().copied().fold(f64::MAX, f64::min) / 0.664;
    assert!(gyro[0]["b"].is_null(), "gx B = {}", gyro[0]["b"]);
    assert_eq!(adev.last().copied().map(|x| x / 0.664), Some(bound));
    assert!(
        (0.0092..0.0106).contains(&bound),
        "gx σ_min/0.664 = {bound}"
    );
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

/// A hand-held full-sphere rotation is refused as not still, in one sentence naming the
/// columns and what moved.
#[test]
fn a_moving_recording_gets_no_noise_terms() {
    let file = data_dir().join("mpu6050_hmc5883l_sunsided_set2/full-sphere_mpu6050.csv");
    let (ok, _, err) = wiical(&["noise", file.to_str().unwrap()]);
    assert!(
        !ok && err.contains("not still") && err.contains("acc_x_g"),
        "{err}"
    );
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error")).count(),
        1,
        "{err}"
    );
}

/// A constant column and a time column with a hole are refused, each in one sentence.
#[test]
fn constant_and_uneven_recordings_get_no_noise_terms() {
    let rows = |f: &dyn Fn(usize) -> String| (0..400).map(f).collect::<String>();
    let constant = temp_file(
        "noise",
        "constant.csv",
        &format!(
            "t,x,y,z\n{}",
            rows(&|i| format!("{},{},{},5\n", i as f64 * 0.01, (i * 7 % 5), (i * 3 % 7)))
        ),
    );
    let (ok, _, err) = wiical(&["noise", constant.to_str().unwrap()]);
    assert!(!ok && err.contains("column z is constant"), "{err}");
    let holes = temp_file(
        "noise",
        "holes.csv",
        &format!(
            "t,x,y,z\n{}",
            rows(&|i| {
                let t = i as f64 * 0.01 + if i >= 200 { 1.0 } else { 0.0 };
                format!("{t},{},{},{}\n", i * 7 % 5, i * 3 % 7, i * 5 % 11)
            })
        ),
    );
    let (ok, _, err) = wiical(&["noise", holes.to_str().unwrap()]);
    assert!(!ok && err.contains("time column is uneven"), "{err}");
    let errors = err.lines().filter(|l| l.starts_with("error")).count();
    assert_eq!(errors, 1, "{err}");
}
