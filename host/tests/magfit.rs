//! `wiical magfit` on every real magnetometer recording at default settings: the verdict (or
//! the one-sentence refusal) pinned, the loop's contract keys present, and every candidate not
//! accepted carrying a detection limit. The table is in docs/magnetometer.md.

mod common;
use common::{data_dir, wiical};
use serde_json::Value;

/// (file, extra arguments, verdict or the refusal's words).
const CASES: [(&str, &[&str], &str); 9] = [
    ("qmc5883l_mag_tomisuarez/noisy_raw_data.csv", &[], "good"),
    ("qmc5883l_mag_tomisuarez/filtered_raw_data.csv", &[], "good"),
    ("mag_ellipsoid_fit_python/mag_out.txt", &[], "good"),
    (
        "acc_mag_ck_explorer/acc_mag_log.csv",
        &["--columns", "mx,my,mz"],
        "good",
    ),
    (
        "mpu6050_hmc5883l_sunsided_set2/full-sphere_hmc5883l.csv",
        &[],
        "good",
    ),
    (
        "mpu6050_hmc5883l_sunsided_set2/roll-and-tilt-at-45-90_hmc5883l.csv",
        &[],
        "unexplained-residual",
    ),
    (
        "mpu6050_hmc5883l_sunsided_set2/unmoved-with-x-pointing-forward_hmc5883l.csv",
        &[],
        "do not span the sphere",
    ),
    (
        "mpu6050_hmc5883l_sunsided_set2/unmoved-with-z-pointing-front-and-x-up_hmc5883l.csv",
        &[],
        "do not span the sphere",
    ),
    (
        "mpu6050_hmc5883l_sunsided_set2/unmoved-with-z-pointing-front-and-y-down_hmc5883l.csv",
        &[],
        "do not span the sphere",
    ),
];

#[test]
fn every_real_recording_has_its_verdict_or_one_refusal() {
    for (file, extra, want) in CASES {
        let path = data_dir().join(file);
        let mut args = vec!["magfit", path.to_str().unwrap(), "--json"];
        args.extend(extra);
        let (ok, out, err) = wiical(&args);
        if want.contains(' ') {
            assert!(!ok && err.contains(want), "{file}: {err}");
            assert_eq!(
                err.lines().filter(|l| l.starts_with("error")).count(),
                1,
                "{err}"
            );
            continue;
        }
        assert!(ok, "{file}: {err}");
        let v: Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v["verdict"], want, "{file}: {}", v["reasons"]);
        for key in [
            "center",
            "fit_error_pct",
            "noise_floor",
            "base",
            "effects",
            "final",
            "steps",
            "reasons",
            "diagnostics",
        ] {
            assert!(v.get(key).is_some(), "{file}: {key} missing");
        }
        let last = v["steps"].as_array().unwrap().last().unwrap();
        if last["accepted"].is_null() {
            for c in last["candidates"].as_array().unwrap() {
                assert!(
                    c["detection_limit"].as_f64().is_some_and(|l| l > 0.0),
                    "{file}: {c}"
                );
            }
        }
    }
}
