//! `wiical correct`: a recording corrected with a calibration file's core calibration and its
//! host terms; `analyze --out` writes the host terms it accepts.

mod common;
use common::{temp_file, wiical};

/// A hand-made version-3 file: unit matrix, bias (1, 2, 3), a temperature-squared bias on z
/// (0.01/°C² about 25 °C) and a scale drift on x (1e-3/s about t = 1 s).
const CAL: &str = r#"{
  "schema": "wiical-calibration/3",
  "bias": [1.0, 2.0, 3.0],
  "matrix": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
  "host_terms": [
    {"name": "temperature-squared (z)", "family": "temperature-squared", "axis": 2,
     "value": 0.01, "unit": "raw/°C²", "reference": {"temperature_c": 25.0}},
    {"name": "scale-drift (x)", "family": "scale-drift", "axis": 0,
     "value": 0.001, "unit": "1/s", "reference": {"time_s": 1.0}}
  ]
}
"#;

/// Every sample is corrected by the formulas of the file format, computed here by hand:
/// `a_x = (m_x − 1)·(1 + 1e-3·(t − t₀ − 1))`, `a_y = m_y − 2`, `a_z = m_z − 3 − 0.01·(θ − 25)²`.
#[test]
fn the_host_terms_are_applied_per_sample() {
    let cal = temp_file("correct", "cal.json", CAL);
    let rows: Vec<(f64, [f64; 3], f64)> = (0..50)
        .map(|i| {
            let t = 10.0 + 0.1 * i as f64;
            (t, [1.5 + 0.01 * i as f64, 2.25, 4.0], 20.0 + 0.2 * i as f64)
        })
        .collect();
    let mut text = String::from("t,x,y,z,temp\n");
    for (t, m, th) in &rows {
        text.push_str(&format!("{t},{},{},{},{th}\n", m[0], m[1], m[2]));
    }
    let rec = temp_file("correct", "rec.csv", &text);
    let out = rec.with_file_name("corrected.csv");
    let (ok, stdout, err) = wiical(&[
        "correct",
        cal.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(
        stdout.starts_with("50 samples corrected")
            && stdout.contains("temperature-squared (z) [temperature]")
            && stdout.contains("scale-drift (x) [time]"),
        "{stdout}"
    );
    let written = std::fs::read_to_string(&out).unwrap();
    let mut lines = written.lines();
    assert_eq!(lines.next(), Some("t,a_x,a_y,a_z"));
    for ((t, m, th), line) in rows.iter().zip(lines) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let want = [
            (m[0] - 1.0) * (1.0 + 1e-3 * (t - 10.0 - 1.0)),
            m[1] - 2.0,
            m[2] - 3.0 - 0.01 * (th - 25.0).powi(2),
        ];
        assert!((v[0] - t).abs() < 1e-9, "{line}");
        for j in 0..3 {
            assert!((v[j + 1] - want[j]).abs() < 1e-6, "{line} vs {want:?}");
        }
    }
    // The input is never overwritten.
    let (ok, _, err) = wiical(&[
        "correct",
        cal.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("it is the input"), "{err}");
}

/// A temperature term and a recording without a temperature column: one sentence naming
/// the recording and the term, and nothing written.
#[test]
fn a_temperature_term_needs_a_temperature_column() {
    let cal = temp_file("correct-bad", "cal.json", CAL);
    let rec = temp_file("correct-bad", "notemp.csv", "t,x,y,z\n0,1,2,3\n0.1,1,2,3\n");
    let out = rec.with_file_name("never.csv");
    let (ok, _, err) = wiical(&[
        "correct",
        cal.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert_eq!(
        err.trim(),
        format!(
            "error: in {}: the calibration's term temperature-squared (z) needs the temperature, and the recording has no temperature column",
            rec.display()
        )
    );
    assert!(!out.exists());
}

/// End to end: a simulated 16-bit MEMS recording with 30 mg of bias quadratic in
/// temperature (seed 2: the open basis names it), `analyze --out` writes the host term
/// (schema 3), and `correct` applies it.
#[test]
fn analyze_writes_host_terms_and_correct_applies_them() {
    let rec = temp_file("correct-e2e", "rec.csv", "");
    let cal = rec.with_file_name("cal.json");
    let out = rec.with_file_name("corrected.csv");
    let (r, c, o) = (
        rec.to_str().unwrap(),
        cal.to_str().unwrap(),
        out.to_str().unwrap(),
    );
    let sim = [
        "simulate",
        "--out",
        r,
        "--effect",
        "temperature-squared",
        "--magnitude",
        "30",
        "--device",
        "mems16",
        "--seed",
        "2",
    ];
    let (ok, _, err) = wiical(&sim);
    assert!(ok, "{err}");
    let (ok, _, err) = wiical(&["analyze", r, "--out", c]);
    assert!(ok, "{err}");
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(file["schema"], "wiical-calibration/3");
    let terms = file["host_terms"].as_array().unwrap();
    assert!(
        terms.iter().any(|t| t["family"] == "temperature-squared"),
        "{terms:?}"
    );
    let (ok, stdout, err) = wiical(&["correct", c, r, "--out", o]);
    assert!(ok, "{err}");
    assert!(stdout.contains("temperature-squared ("), "{stdout}");
    let samples = std::fs::read_to_string(&rec).unwrap().lines().count() - 1;
    let rows = std::fs::read_to_string(&out).unwrap().lines().count() - 1;
    assert_eq!(rows, samples);
    assert!(
        stdout.starts_with(&format!("{samples} samples corrected")),
        "{stdout}"
    );
}
