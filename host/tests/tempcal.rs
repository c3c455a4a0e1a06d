//! `wiical tempcal` end to end: a simulated warm-up CSV with a known cubic bias (the truth
//! the coefficients must come within 3 standard errors of), the ArduPilot and PX4 parameter
//! files read back line by line, the calibration-file form, refusals in one sentence, and the
//! GGIR wrist file (real temperatures, but not a still warm-up: the tool must say so).

mod common;
use common::{data_dir, temp_file, wiical};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;

const G: f64 = 9.80665;
/// Bias truth per axis, g per °C^k about 35 °C (k = 1, 2, 3).
const TRUTH: [[f64; 3]; 3] = [
    [1.0e-3, 5.0e-5, 4.0e-6],
    [-0.5e-3, -8.0e-5, -5.0e-6],
    [2.0e-3, 3.0e-5, 3.0e-6],
];

/// 30 min at 100 Hz of a still accelerometer (g) warming from `from` towards `to` °C, bias
/// `TRUTH`, 2 mg white noise; CSV `t,x,y,z,temp`.
fn warmup_csv(seed: u64, from: f64, to: f64) -> String {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.002).unwrap();
    let pose = [0.05, -0.1, 0.9937];
    let mut s = String::from("t,x,y,z,temp\n");
    let n = 180_000;
    for i in 0..n {
        let t = i as f64 / 100.0;
        let temp = to - (to - from) * (-t / 600.0).exp();
        let dt = temp - 35.0;
        let v: Vec<String> = (0..3)
            .map(|j| {
                let bias: f64 = (0..3).map(|k| TRUTH[j][k] * dt.powi(k as i32 + 1)).sum();
                format!("{:.6}", pose[j] + bias + noise.sample(&mut rng))
            })
            .collect();
        s.push_str(&format!("{t:.2},{},{temp:.3}\n", v.join(",")));
    }
    s
}

#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn simulated_cubic_warmup_is_recovered_and_both_parameter_files_read_back() {
    let f = temp_file("tempcal", "warm.csv", &warmup_csv(5, 18.0, 39.0));
    let file = f.to_str().unwrap();
    let dir = f.parent().unwrap();
    let (parm, params, svg) = (
        dir.join("tcal.parm"),
        dir.join("tcal.params"),
        dir.join("tcal.svg"),
    );
    let (ok, out, err) = wiical(&["tempcal", file, "--json", "--plot", svg.to_str().unwrap()]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["units"], "g");
    assert_eq!(v["t_ref_c"], 35.0);
    assert!(v["t_max_c"].as_f64().unwrap() - v["t_min_c"].as_f64().unwrap() > 18.0);
    let axes = v["axes"].as_array().unwrap();
    for (j, a) in axes.iter().enumerate() {
        assert_eq!(a["order"], 3, "{a}");
        assert_eq!(a["heldout_rms"].as_array().unwrap().len(), 3);
        for k in 0..3 {
            let c = a["coefficients"][k].as_f64().unwrap();
            let se = a["std_errors"][k].as_f64().unwrap();
            assert!(
                (c - TRUTH[j][k]).abs() < 3.0 * se,
                "axis {j} c{}: {c} ± {se}",
                k + 1
            );
        }
    }
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));

    for (format, path) in [("ardupilot", &parm), ("px4", &params)] {
        let (ok, _, err) = wiical(&[
            "tempcal",
            file,
            "--format",
            format,
            "--out",
            path.to_str().unwrap(),
        ]);
        assert!(ok, "{err}");
    }
    // ArduPilot: `NAME VALUE` per line (tempcal_IMU.py's tcal.parm), m/s² × 1e6.
    let ap = std::fs::read_to_string(&parm).unwrap();
    let ap: Vec<(String, f64)> = ap
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            assert_eq!(f.len(), 2, "{l}");
            (f[0].to_string(), f[1].parse().unwrap())
        })
        .collect();
    assert_eq!(ap[0], ("INS_TCAL1_ENABLE".to_string(), 1.0));
    assert_eq!(ap[1].0, "INS_TCAL1_TMIN");
    assert_eq!(ap[2].0, "INS_TCAL1_TMAX");
    assert_eq!(ap.len(), 12);
    for k in 1..=3 {
        for (j, axis) in ["X", "Y", "Z"].iter().enumerate() {
            let name = format!("INS_TCAL1_ACC{k}_{axis}");
            let got = ap.iter().find(|(n, _)| *n == name).unwrap().1;
            let want = axes[j]["coefficients"][k - 1].as_f64().unwrap() * G * 1e6;
            assert!(
                (got - want).abs() <= 1e-6 * want.abs() + 1e-6,
                "{name}: {got} vs {want}"
            );
        }
    }
    // PX4 / QGroundControl: `1 1 NAME VALUE TYPE`, tab-separated; m/s², X0 = 0.
    let px = std::fs::read_to_string(&params).unwrap();
    let px: Vec<Vec<String>> = px
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split('\t').map(String::from).collect())
        .collect();
    assert!(
        px.iter()
            .all(|f| f.len() == 5 && f[0] == "1" && f[1] == "1"),
        "{px:?}"
    );
    let value = |name: &str| -> f64 {
        px.iter()
            .find(|f| f[2] == name)
            .unwrap_or_else(|| panic!("{name}"))[3]
            .parse()
            .unwrap()
    };
    assert_eq!(value("TC_A_ENABLE"), 1.0);
    assert_eq!(value("TC_A0_TREF"), 35.0);
    for (j, a) in axes.iter().enumerate() {
        assert_eq!(value(&format!("TC_A0_X0_{j}")), 0.0);
        for k in 1..=3 {
            let want = a["coefficients"][k - 1].as_f64().unwrap() * G;
            let got = value(&format!("TC_A0_X{k}_{j}"));
            assert!(
                (got - want).abs() <= 1e-9 * want.abs(),
                "X{k}_{j}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn calibration_file_form_takes_the_linear_term() {
    let f = temp_file("tempcal", "warm-lin.csv", &warmup_csv(6, 15.0, 37.0));
    let cal = temp_file(
        "tempcal",
        "cal.json",
        r#"{"schema":"wiical-calibration/1","bias":[0.01,-0.02,0.03],"matrix":[[1,0,0],[0,1,0],[0,0,1]]}"#,
    );
    let out = cal.with_file_name("cal-t.json");
    let file = f.to_str().unwrap();
    let (ok, report, err) = wiical(&["tempcal", file, "--json"]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&report).unwrap();
    let (ok, _, err) = wiical(&[
        "tempcal",
        file,
        "--format",
        "calfile",
        "--calibration",
        cal.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("linear temperature term only"), "{err}");
    let c: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(c["bias"][1].as_f64().unwrap() as f32, -0.02);
    assert_eq!(c["effects"]["temp_ref_c"], 35.0);
    for j in 0..3 {
        let want = v["axes"][j]["linear"][0].as_f64().unwrap() as f32;
        assert_eq!(c["effects"]["bias_temp"][j].as_f64().unwrap() as f32, want);
    }
}

/// A calibration in other units than the warm-up (raw counts, where the warm-up is in g) is
/// refused in one sentence by `correct`'s units check, nothing written: its temperature term
/// would be in g per °C inside a counts calibration, wrong by the counts per g.
#[test]
fn calibration_file_form_refuses_a_calibration_in_other_units() {
    let f = temp_file("tempcal", "warm-g.csv", &warmup_csv(6, 15.0, 37.0));
    let cal = temp_file(
        "tempcal",
        "counts-cal.json",
        r#"{"schema":"wiical-calibration/1","bias":[33000,33000,33000],"matrix":[[0.00025,0,0],[0,0.00025,0],[0,0,0.00025]]}"#,
    );
    let out = cal.with_file_name("counts-cal-t.json");
    let (ok, _, err) = wiical(&[
        "tempcal",
        f.to_str().unwrap(),
        "--format",
        "calfile",
        "--calibration",
        cal.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("counts-cal.json does not suit") && err.contains("different units"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out.exists());
}

/// A temperature column in kelvin is refused in one sentence saying so, for every output
/// (no autopilot file with TMIN 293 "°C").
#[test]
fn a_temperature_column_in_kelvin_is_refused() {
    let mut rows = String::from("t,x,y,z,temp\n");
    for i in 0..6000 {
        let t = i as f64 / 10.0;
        let wobble = 1e-3 * ((i * 7919 % 13) as f64 - 6.0);
        rows.push_str(&format!(
            "{t},{},-0.1,0.99,{}\n",
            0.05 + wobble,
            293.2 + t / 30.0
        ));
    }
    let f = temp_file("tempcal", "kelvin.csv", &rows);
    let out = f.with_file_name("kelvin.parm");
    let (ok, _, err) = wiical(&[
        "tempcal",
        f.to_str().unwrap(),
        "--format",
        "ardupilot",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("from 293.2 to 313.2") && err.contains("kelvin"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out.exists());
}

#[test]
fn refusals_are_one_sentence() {
    let f = temp_file("tempcal", "warm-small.csv", &warmup_csv(7, 26.0, 33.0));
    let file = f.to_str().unwrap();
    let (ok, _, err) = wiical(&["tempcal", file]);
    assert!(!ok);
    assert!(
        err.contains("spans only 6.") && err.contains("at least 10 °C"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    let (ok, _, err) = wiical(&["tempcal", file, "--out", "x.parm"]);
    assert!(!ok && err.contains("give --format"), "{err}");
    let (ok, _, err) = wiical(&["tempcal", file, "--json", "--format", "px4"]);
    assert!(!ok && err.contains("give --out"), "{err}");
    // A different pose label on every row (100 000 of them, read in linear time): every
    // block straddles two poses.
    let mut rows = String::from("t,x,y,z,temp,pose\n");
    for i in 0..100_000 {
        rows.push_str(&format!(
            "{},0,0,1,{},p{i}\n",
            i as f64 / 100.0,
            10.0 + i as f64 * 2e-4
        ));
    }
    let h = temp_file("tempcal", "labels.csv", &rows);
    let (ok, _, err) = wiical(&["tempcal", h.to_str().unwrap()]);
    assert!(
        !ok && err.contains("(of 1000 blocks, 1000 moving)"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    let g = temp_file("tempcal", "notemp.csv", "t,x,y,z\n0,0,0,1\n0.01,0,0,1\n");
    let (ok, _, err) = wiical(&["tempcal", g.to_str().unwrap()]);
    assert!(!ok && err.contains("no temperature column"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// The GGIR wrist epochs: 84 h of a worn accelerometer, still epochs only, 14.9–31.9 °C. Its
/// temperature follows wearing (warm on the wrist, cool on a table), and the wrist turns
/// slowly within what looks like one pose: the residual is far above the epoch-to-epoch
/// noise and the tool says so.
#[test]
fn ggir_wrist_file_is_flagged_as_not_a_still_warmup() {
    let file = data_dir().join("ggir_wrist_sphere_temp/spheredata.csv");
    let (ok, out, err) = wiical(&["tempcal", file.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!((v["t_min_c"].as_f64().unwrap() - 14.9).abs() < 0.01);
    assert!((v["t_max_c"].as_f64().unwrap() - 31.9).abs() < 0.01);
    let worst = v["axes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|a| a["noise_ratio"].as_f64())
        .fold(0.0f64, f64::max);
    // Still sensors give 1.0–1.7 (STILL_RATIO = 2 in the engine); this file 2.4–2.6.
    assert!(worst > 2.0, "{worst}");
    assert!(err.contains("the poses were not still"), "{err}");
}
