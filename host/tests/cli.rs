//! The CLI contract: JSON keys and values of each command, and readable errors on bad input.

mod common;
use common::{data_dir, json, temp_file, wiical};

use serde_json::Value;

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn six_position_reproduces_the_seed() {
    let file = data_dir().join("seed_six_position/wiimote_M.csv");
    let v = json(&["six-position", file.to_str().unwrap(), "--json"]);
    let t = &v["t_hat"];
    // Seed: T̂ row 1 = 25.175, 0.041, 0, 128.058 (3 decimals; see the core's unit tests for
    // why 0.001 is the tolerance the printed inputs allow).
    let want = [
        [25.175, 0.041, 0.0, 128.058],
        [-0.403, 26.023, 0.402, 127.465],
        [0.0, 0.297, 24.583, 129.625],
    ];
    for r in 0..3 {
        for c in 0..4 {
            assert!((f(&t[r][c]) - want[r][c]).abs() <= 0.00102, "T̂[{r}][{c}]");
        }
    }
    assert!((f(&v["d_inv"][0][0]) - 0.039719).abs() < 1.5e-6);
    assert!((f(&v["d_inv"][2][2]) - 0.040684).abs() < 1.5e-6);
    assert_eq!(v["residual"].as_array().unwrap().len(), 3);
    assert_eq!(v["residual"][0].as_array().unwrap().len(), 6);
    assert_eq!(v["bias"].as_array().unwrap().len(), 3);
}

#[test]
fn fit_on_imu_tk_xsens() {
    let file = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-xsens-{}.json", std::process::id()));
    let v = json(&[
        "fit",
        file.to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let n = v["static_windows"].as_u64().unwrap();
    let rms = f(&v["rms_mg"]);
    assert!(n >= 35, "static windows {n}");
    assert!(rms < 0.5, "rms {rms} mg");
    assert_eq!(v["matrix"].as_array().unwrap().len(), 3);
    // The written calibration loads back and matches the printed one.
    let cal: wiical_core::Calibration =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(cal.validate().is_ok());
    assert_eq!(cal.bias[0], f(&v["bias"][0]) as f32);
    // The human-readable table works too.
    let (ok, text, _) = wiical(&["fit", file.to_str().unwrap()]);
    assert!(ok && text.contains("static windows") && text.contains("RMS"));
}

/// A Wiimote-like 10-bit recording: rest, then poses with motion between them.
fn synthetic_recording(directions: &[[f64; 3]], saturate: bool) -> String {
    let mut s = String::from("t,x,y,z\n");
    let mut i = 0usize;
    let mut noise = 0x1234_5678u32;
    let mut rnd = || {
        noise ^= noise << 13;
        noise ^= noise >> 17;
        noise ^= noise << 5;
        noise as f64 / u32::MAX as f64 - 0.5
    };
    for (k, d) in directions.iter().enumerate() {
        let len = if k == 0 { 400 } else { 300 };
        for _ in 0..len {
            let mut v = [0.0; 3];
            for a in 0..3 {
                v[a] = (512.0 + 105.0 * d[a] + 1.5 * rnd()).round();
                if saturate && k == 3 && a == 0 {
                    v[a] = 1023.0;
                }
            }
            s += &format!("{:.2},{},{},{}\n", i as f64 * 0.01, v[0], v[1], v[2]);
            i += 1;
        }
        for m in 0..80 {
            let ph = m as f64 * 0.25;
            s += &format!(
                "{:.2},{},{},{}\n",
                i as f64 * 0.01,
                (512.0 + 300.0 * ph.sin()).round(),
                (512.0 + 250.0 * ph.cos()).round(),
                512
            );
            i += 1;
        }
    }
    s
}

#[test]
fn bad_inputs_give_readable_errors() {
    let check = |args: &[&str], needle: &str| {
        let (ok, _, err) = wiical(args);
        assert!(!ok, "{args:?} should fail");
        assert!(
            err.contains(needle) && err.starts_with("error:") && !err.contains("panicked"),
            "{args:?}: stderr was {err:?}, expected it to mention {needle:?}"
        );
    };
    let empty = temp_file("cli", "empty.csv", "");
    check(&["fit", empty.to_str().unwrap()], "empty");
    let nan = temp_file("cli", "nan.csv", "t,x,y,z\n0,1,NaN,3\n");
    check(&["fit", nan.to_str().unwrap()], "not finite");
    let cols = temp_file("cli", "cols.csv", "time,a,b,c\n0,1,2,3\n");
    check(&["fit", cols.to_str().unwrap()], "no x/y/z columns");
    let short = temp_file("cli", "short.csv", "t,x,y,z\n0,1,2,3\n0.01,1,2,3\n");
    check(&["fit", short.to_str().unwrap()], "too short");
    check(&["fit", "/nonexistent/file.csv"], "cannot read");

    let dup = temp_file("cli", 
        "dup.csv",
        "pose,x,y,z\nx+,153,127,130\nx-,103,128,130\ny+,128,153,130\nx+,153,127,130\ny-,128,101,129\nz+,128,128,154\nz-,128,127,105\n",
    );
    check(&["six-position", dup.to_str().unwrap()], "more than once");
    let missing = temp_file("cli", 
        "missing.csv",
        "pose,x,y,z\nx+,153,127,130\nx-,103,128,130\ny+,128,153,130\ny-,128,101,129\nz+,128,128,154\n",
    );
    check(&["six-position", missing.to_str().unwrap()], "'z-'");
    let label = temp_file("cli", "label.csv", "pose,x,y,z\nup,1,2,3\n");
    check(
        &["six-position", label.to_str().unwrap()],
        "unknown pose label",
    );

    // Coplanar poses: every gravity direction in the x–y plane.
    let planar: Vec<[f64; 3]> = (0..12)
        .map(|k| {
            let th = k as f64 * 0.5;
            [th.cos(), th.sin(), 0.0]
        })
        .collect();
    let p = temp_file("cli", "planar.csv", &synthetic_recording(&planar, false));
    check(&["fit", p.to_str().unwrap()], "one plane");

    // Well spread poses fit; the same with one pose at the ADC rail is refused.
    let spread: Vec<[f64; 3]> = (0..14)
        .map(|k| {
            let z = -1.0 + 2.0 * (k as f64 + 0.5) / 14.0;
            let r = (1.0 - z * z).sqrt();
            let th = k as f64 * 2.399_963;
            [r * th.cos(), r * th.sin(), z]
        })
        .collect();
    let good = temp_file("cli", "good.csv", &synthetic_recording(&spread, false));
    let v = json(&["fit", good.to_str().unwrap(), "--json"]);
    assert_eq!(v["static_windows"].as_u64().unwrap(), 14);
    assert!(f(&v["rms_mg"]) < 5.0, "{v}");
    let sat = temp_file("cli", "sat.csv", &synthetic_recording(&spread, true));
    check(&["fit", sat.to_str().unwrap()], "saturated");
}

#[test]
fn magfit_contract_and_model_ranking() {
    let file = data_dir().join("qmc5883l_mag_tomisuarez/noisy_raw_data.csv");
    let fit = |model: &str| json(&["magfit", file.to_str().unwrap(), "--model", model, "--json"]);
    let (s, a, e) = (fit("sphere"), fit("axis"), fit("ellipsoid"));
    for v in [&s, &a, &e] {
        assert_eq!(v["center"].as_array().unwrap().len(), 3);
        assert_eq!(v["matrix"].as_array().unwrap().len(), 3);
        assert!(f(&v["radius"]) > 0.0);
    }
    // This data set is strongly anisotropic (SOURCE.md): each richer model fits better.
    assert!(f(&e["fit_error_pct"]) < f(&a["fit_error_pct"]));
    assert!(f(&a["fit_error_pct"]) < 0.5 * f(&s["fit_error_pct"]));
    let small = data_dir().join("mag_ellipsoid_fit_python/mag_out.txt");
    let v = json(&[
        "magfit",
        small.to_str().unwrap(),
        "--model",
        "sphere",
        "--json",
    ]);
    assert!((f(&v["radius"]) - 173.0).abs() < 5.0, "{v}");
    let (ok, _, err) = wiical(&["magfit", small.to_str().unwrap(), "--model", "cube"]);
    assert!(!ok && err.contains("cube"));
}

#[test]
fn kalman_demo_contract_and_acceptance() {
    let v = json(&["kalman-demo", "--runs", "400", "--seed", "3", "--json"]);
    assert_eq!(f(&v["true_bias"]), 0.25);
    assert_eq!(v["runs"].as_u64().unwrap(), 400);
    assert!(f(&v["median_abs_bias_error_1s"]) < 0.01, "{v}");
    assert!(f(&v["p95_abs_bias_error_1s"]) > f(&v["median_abs_bias_error_1s"]));
    let nees = f(&v["nees_mean"]);
    assert!((2.5..3.5).contains(&nees), "NEES {nees}");
    // Same seed, same numbers.
    let again = json(&["kalman-demo", "--runs", "400", "--seed", "3", "--json"]);
    assert_eq!(v, again);
}

#[test]
fn decode_cal_contract() {
    let v = json(&[
        "decode-cal",
        "--device",
        "wiimote",
        "82 82 82 15 9C 9C 9E 38 40 3E",
        "--json",
    ]);
    assert_eq!(v["zero"], serde_json::json!([521, 521, 521]));
    assert_eq!(v["one_g"], serde_json::json!([627, 626, 632]));
    assert_eq!(v["checksum_ok"], Value::Bool(true));
    // A corrupted checksum byte is reported, not hidden: the block is still printed, and
    // the exit status says it is bad.
    let (ok, out, err) = wiical(&[
        "decode-cal",
        "--device",
        "wiimote",
        "82 82 82 15 9C 9C 9E 38 40 3F",
        "--json",
    ]);
    assert!(!ok, "a bad checksum must fail the command");
    assert!(err.contains("checksum is wrong"), "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["checksum_ok"], Value::Bool(false));
    let (ok, _, err) = wiical(&["decode-cal", "--device", "wiimote", "82 ZZ"]);
    assert!(!ok && err.starts_with("error:"), "{err}");
}

#[test]
fn columns_option_selects_a_triplet() {
    // mag_out.txt rewritten as a CSV with a decoy triplet first: --columns must pick the real one.
    let text =
        std::fs::read_to_string(data_dir().join("mag_ellipsoid_fit_python/mag_out.txt")).unwrap();
    let mut csv = String::from("x,y,z,bx,by,bz\n");
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let v: Vec<&str> = line.split_whitespace().collect();
        csv += &format!("0,0,1,{},{},{}\n", v[0], v[1], v[2]);
    }
    let file = temp_file("cli", "decoy.csv", &csv);
    let plain = data_dir().join("mag_ellipsoid_fit_python/mag_out.txt");
    let a = json(&[
        "magfit",
        plain.to_str().unwrap(),
        "--model",
        "sphere",
        "--json",
    ]);
    let b = json(&[
        "magfit",
        file.to_str().unwrap(),
        "--model",
        "sphere",
        "--columns",
        "bx,by,bz",
        "--json",
    ]);
    assert_eq!(a["center"], b["center"]);
    let (ok, _, err) = wiical(&["magfit", file.to_str().unwrap(), "--columns", "bx,by"]);
    assert!(!ok && err.contains("exactly three"), "{err}");
}

/// Every hold a window, through the CLI: a brisk 16-bit MEMS recording at 400 Hz (m/s²) gets a
/// window for every hold of its truth (31: the rest and 30 poses of 2–4 s).
#[test]
fn simulate_brisk_mems16_and_fit_finds_every_hold() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("brisk.csv");
    let o = out.to_str().unwrap();
    let (ok, _, err) = wiical(&[
        "simulate",
        "--out",
        o,
        "--device",
        "mems16",
        "--profile",
        "brisk",
        "--seed",
        "2",
    ]);
    assert!(ok, "{err}");
    let truth: Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{o}.truth.json")).unwrap()).unwrap();
    assert_eq!(truth["rate_hz"], 400.0);
    let poses = truth["poses"].as_array().unwrap().len();
    let v = json(&["fit", o, "--json"]);
    assert_eq!(v["static_windows"].as_u64().unwrap() as usize, poses);
}

/// The open basis through the CLI: the open-basis families are accepted by name (the names
/// of `effect_names`), their truth states the value, unit and (thermal lag) time constant,
/// and a cross term is held by the calibration (`cross_quadratic`, on the `--axis` row).
#[test]
fn simulate_puts_open_basis_families_in_with_their_truth() {
    use wiical_analysis::report::effect_names as names;
    let dir = tempfile::tempdir().unwrap();
    let read = |o: &str| -> Value {
        serde_json::from_str(&std::fs::read_to_string(format!("{o}.truth.json")).unwrap()).unwrap()
    };
    let lag = dir.path().join("lag.csv");
    let o = lag.to_str().unwrap();
    let (ok, _, err) = wiical(&[
        "simulate",
        "--out",
        o,
        "--effect",
        names::THERMAL_LAG,
        "--magnitude",
        "5",
        "--no-temp",
    ]);
    assert!(ok, "{err}");
    let t = read(o);
    let term = &t["open_basis"][0];
    assert_eq!(term["family"], names::THERMAL_LAG);
    assert_eq!(term["acts_on"], "bias");
    assert_eq!(term["unit"], "counts per °C");
    assert_eq!(term["time_constant_s"], 300.0);
    assert_eq!(term["in_calibration"], false);
    // The family needs the temperature: the column is written despite --no-temp.
    let head = std::fs::read_to_string(&lag).unwrap();
    assert!(head.starts_with("t,x,y,z,temp\n"), "{}", &head[..40]);

    let cross = dir.path().join("cross.csv");
    let o = cross.to_str().unwrap();
    let (ok, _, err) = wiical(&[
        "simulate",
        "--out",
        o,
        "--effect",
        names::CROSS_QUADRATIC,
        "--axis",
        "z",
    ]);
    assert!(ok, "{err}");
    let t = read(o);
    let term = &t["open_basis"][0];
    assert_eq!(term["unit"], "1/g");
    assert_eq!(term["in_calibration"], true);
    let name = term["terms"][0].as_str().unwrap();
    assert!(name.starts_with("cross-quadratic (z: "), "{name}");
    let row = t["calibration"]["effects"]["cross_quadratic"][2]
        .as_array()
        .unwrap();
    assert_eq!(row.iter().filter(|c| f(c) != 0.0).count(), 1, "{row:?}");

    let (ok, _, err) = wiical(&["simulate", "--out", o, "--effect", "cross-quartic"]);
    assert!(!ok);
    assert!(err.contains(names::TEMPERATURE_RATE), "{err}");
}
