//! Hostile inputs (docs/bad-inputs.md), one test per item that has a CLI face: each gives one sentence
//! naming the flag, file or line and a non-zero exit, or is accepted correctly.

mod common;
use common::{data_dir, wiical};

fn fails_with(args: &[&str], words: &[&str]) {
    let (ok, _, err) = wiical(args);
    assert!(!ok, "{args:?} succeeded");
    for w in words {
        assert!(err.contains(w), "{args:?}: {err}");
    }
}

/// Item 3 and 7: numeric flags are checked where they are parsed, naming the flag.
#[test]
fn absurd_numeric_flags_are_refused_naming_the_flag() {
    let xsens = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let f = xsens.to_str().unwrap();
    for v in ["0", "-1", "NaN", "1e-300", "inf"] {
        let flag = format!("--window-s={v}");
        fails_with(&["fit", f, &flag], &["--window-s"]);
    }
    fails_with(&["fit", f, "--rate-hz=NaN"], &["--rate-hz"]);
    fails_with(&["fit", f, "--threshold=-3"], &["--threshold"]);
    fails_with(&["device-sim", "--pty", "--seconds=NaN"], &["--seconds"]);
    fails_with(&["kalman-demo", "--accel-noise=0"], &["--accel-noise"]);
    fails_with(
        &["simulate", "--out", "x.csv", "--poses", "20000"],
        &["--poses", "5000"],
    );
    fails_with(
        &["simulate", "--out", "x.csv", "--rate", "5"],
        &["--rate", "20 to 2000"],
    );
    fails_with(
        &["simulate", "--out", "x.csv", "--profile", "quick"],
        &["--profile", "brisk"],
    );
}

/// Item 2: an output that cannot be written stops the command before any output is written.
#[test]
fn no_output_is_written_when_one_cannot_be() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cal.json");
    std::fs::write(&out, "old").unwrap();
    let xsens = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let (ok, _, err) = wiical(&[
        "analyze",
        xsens.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--plot",
        "/nonexistent-dir/p.svg",
    ]);
    assert!(!ok && err.contains("its directory does not exist"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old");
}

/// Item 9: `--out -` is refused with a sentence (standard output carries the report) instead
/// of creating a file named "-".
#[test]
fn out_dash_is_refused_not_a_file_named_dash() {
    let dir = tempfile::tempdir().unwrap();
    let xsens = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(["fit", xsens.to_str().unwrap(), "--out", "-"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("standard output carries the report"));
    assert!(!dir.path().join("-").exists());
}

/// Item 9: writing to a closed standard output is an error exit, not success.
#[test]
fn a_closed_stdout_is_an_error_exit() {
    use std::process::{Command, Stdio};
    let xsens = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let mut child = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(["analyze", xsens.to_str().unwrap(), "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away before anything is written
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("standard output was closed"));
}

/// Item 1: a file that is one 8 MB line is refused by its line length, without splitting it
/// into millions of fields (the memory it once took: 3.4 GB for 50 MB; docs/bad-inputs.md).
#[test]
fn a_file_without_line_breaks_is_refused_by_its_line_length() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("one-line.csv");
    std::fs::write(&f, format!("t,x,y,z,{}", "a,".repeat(4 << 20))).unwrap();
    for cmd in ["fit", "magfit", "analyze"] {
        fails_with(&[cmd, f.to_str().unwrap()], &["line 1 is", "bytes long"]);
    }
}

/// Item 8: a path that is no terminal device is named as such.
#[test]
fn dev_null_is_not_a_serial_port() {
    fails_with(
        &["device", "info", "--port", "/dev/null"],
        &["/dev/null is not a serial port"],
    );
}

/// Item 4: gyrofit pairs two files only when their clocks agree and the gyro spans the
/// recording; a "gyro" that turns with the pose like gravity is refused.
#[test]
fn gyrofit_refuses_shifted_cut_short_and_gravity_gyros() {
    let dir = tempfile::tempdir().unwrap();
    let xsens = data_dir().join("imu_tk_xsens");
    let acc = xsens.join("xsens_acc.mat");
    let gyro_text = std::fs::read_to_string(xsens.join("xsens_gyro.mat")).unwrap();
    let shifted: String = gyro_text
        .lines()
        .map(|l| {
            let mut f: Vec<String> = l.split_whitespace().map(String::from).collect();
            if let Ok(t) = f[0].parse::<f64>() {
                f[0] = format!("{}", t + 0.5);
            }
            f.join(" ") + "\n"
        })
        .collect();
    let shifted_path = dir.path().join("shifted.mat");
    std::fs::write(&shifted_path, shifted).unwrap();
    let a = acc.to_str().unwrap();
    fails_with(
        &[
            "gyrofit",
            a,
            shifted_path.to_str().unwrap(),
            "--scale",
            "1.6e-4",
        ],
        &["times differ by up to 0.5"],
    );
    let lines: Vec<&str> = gyro_text.lines().collect();
    let cut_path = dir.path().join("cut.mat");
    std::fs::write(&cut_path, lines[..lines.len() * 6 / 10].join("\n") + "\n").unwrap();
    fails_with(
        &[
            "gyrofit",
            a,
            cut_path.to_str().unwrap(),
            "--scale",
            "1.6e-4",
        ],
        &["the gyro file is cut short"],
    );
    fails_with(&["gyrofit", a, a, "--scale", "1.6e-4"], &["like gravity"]);
    let unit = data_dir().join("mpu9150_mikoff_5units/imu0.csv");
    fails_with(
        &["gyrofit", unit.to_str().unwrap(), "--gyro-columns", "x,y,z"],
        &["like gravity", "x,y,z"],
    );
}

/// Item 8: messages name the problem. A corrupt cell (1e308, 1e17) names its line and column;
/// data scaled to nothing (×1e-30) says so instead of "not enough orientations"; a bad `Fs`
/// line names the line; out-of-range rates and noise flags name the flag.
#[test]
fn absurd_values_are_named_where_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data_dir().join("imu_tk_xsens/xsens_acc.mat")).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    let edit = |name: &str, f: &dyn Fn(usize, &str) -> String| {
        let body: Vec<String> = rows.iter().enumerate().map(|(i, l)| f(i, l)).collect();
        let p = dir.path().join(name);
        std::fs::write(&p, body.join("\n") + "\n").unwrap();
        p
    };
    let cell = |v: &'static str| {
        move |i: usize, l: &str| {
            let mut f: Vec<&str> = l.split_whitespace().collect();
            if i == 500 {
                f[2] = v;
            }
            f.join(" ")
        }
    };
    for v in ["1e308", "1e17", "-2e12"] {
        let p = edit("big.mat", &cell(v));
        fails_with(
            &["fit", p.to_str().unwrap()],
            &["line 501, column y:", v, "beyond ±1e12"],
        );
    }
    let tiny = edit("tiny.mat", &|_, l| {
        let f: Vec<String> = l.split_whitespace().map(String::from).collect();
        let scaled = f[1..]
            .iter()
            .map(|v| format!("{:e}", v.parse::<f64>().unwrap() * 1e-30));
        std::iter::once(f[0].clone())
            .chain(scaled)
            .collect::<Vec<_>>()
            .join(" ")
    });
    fails_with(
        &["fit", tiny.to_str().unwrap()],
        &["smaller than 1e-9", "unit or scale"],
    );
    let csv: String = rows
        .iter()
        .map(|l| l.split_whitespace().collect::<Vec<_>>()[1..].join(",") + "\n")
        .collect();
    for fs in ["abc", "-5", "1e300"] {
        let p = dir.path().join("fs.csv");
        std::fs::write(&p, format!("Fs,{fs}\nx,y,z\n{csv}")).unwrap();
        fails_with(
            &["fit", p.to_str().unwrap()],
            &["line 1:", fs, "sample rate"],
        );
    }
    let sim = dir.path().join("sim.csv");
    let s = sim.to_str().unwrap();
    assert!(wiical(&["simulate", "--out", s, "--seed", "3"]).0);
    fails_with(
        &["fit", s, "--rate-hz", "1e300"],
        &["--rate-hz", "1000000 Hz"],
    );
    fails_with(&["noise", s, "--rate-hz=-1"], &["--rate-hz"]);
    fails_with(
        &["kalman-demo", "--accel-noise", "1e300"],
        &["--accel-noise", "100 m/s²"],
    );
    fails_with(&["kalman-demo", "--pos-noise", "-1"], &["--pos-noise"]);
    fails_with(&["kalman-demo", "--runs", "0"], &["--runs"]);
    fails_with(
        &["device-sim", "--pty", "--seconds", "1e300"],
        &["--seconds"],
    );
    fails_with(
        &["fit", s, "--threshold", "0.5"],
        &["--threshold", "above 1"],
    );
}

/// Item 8: an absurd gyro nominal (`--scale` 10^±300, a rad/deg mix-up, `--counts-per-dps`
/// 10^±300) is named by its flag and the angle ratio it implies, instead of "matrix is
/// singular"; the right nominals of real logs pass.
#[test]
fn absurd_gyro_nominals_are_named_and_right_ones_pass() {
    let xsens = data_dir().join("imu_tk_xsens");
    let (a, g) = (xsens.join("xsens_acc.mat"), xsens.join("xsens_gyro.mat"));
    let (a, g) = (a.to_str().unwrap(), g.to_str().unwrap());
    for s in ["1e300", "1e-300", "1e-30", "1.2e-2"] {
        fails_with(
            &["gyrofit", a, g, "--scale", s],
            &[
                "nominal from --scale",
                "the tilt the accelerometer sees",
                "check the value and its unit",
            ],
        );
    }
    assert!(wiical(&["gyrofit", a, g, "--scale", "2.09e-4"]).0);
    let unit = data_dir().join("mpu9150_mikoff_5units/imu0.csv");
    let u = unit.to_str().unwrap();
    for c in ["1e300", "1e-300"] {
        fails_with(
            &["gyrofit", u, "--counts-per-dps", c],
            &["--counts-per-dps", "the tilt the accelerometer sees"],
        );
    }
    assert!(wiical(&["gyrofit", u, "--counts-per-dps", "16.384"]).0);
}

// ---- the doors of `correct`, calibration files and `batch` ----

/// A still recording in Nunchuk counts (z up: 512, 512, 712 ± 2; x offset to 600 so a scale
/// term on x shows), `n` samples 0.1 s apart, with a temperature column.
fn counts_recording(tag: &str, n: usize) -> std::path::PathBuf {
    let mut text = String::from("t,x,y,z,temp\n");
    for i in 0..n {
        let wobble = (i % 5) as f64 - 2.0;
        let t = 0.1 * i as f64;
        text.push_str(&format!(
            "{t},{},{},{},25\n",
            600.0 + wobble,
            512.0,
            712.0 + wobble
        ));
    }
    common::temp_file(tag, "counts.csv", &text)
}

/// A counts calibration (bias 512, 200 counts/g) with `effects` and `hosts` JSON spliced in.
fn counts_cal(tag: &str, name: &str, effects: &str, hosts: &str) -> std::path::PathBuf {
    let schema = if hosts.is_empty() { "1" } else { "3" };
    let text = format!(
        r#"{{"schema": "wiical-calibration/{schema}", "bias": [512, 512, 512],
           "matrix": [[0.005, 0, 0], [0, 0.005, 0], [0, 0, 0.005]],
           "effects": {{{effects}}}{hosts}}}"#
    );
    common::temp_file(tag, name, &text)
}

fn correct(cal: &std::path::Path, rec: &std::path::Path) -> (bool, String, std::path::PathBuf) {
    let out = rec.with_file_name(format!(
        "corrected-{}-{}.csv",
        cal.file_stem().unwrap().to_string_lossy(),
        rec.file_stem().unwrap().to_string_lossy()
    ));
    let (ok, _, err) = wiical(&[
        "correct",
        cal.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    (ok, err, out)
}

/// `correct` refuses what `device put` refuses (the acceptance predicate: a cubic of 1e20 is
/// named by the output it reaches), a host term that pushes one sample beyond ±16 g (named
/// by sample and time), and a calibration in other units than the recording (counts on g,
/// g on counts); the good calibration corrects to 1 g. Nothing is written when refused.
#[test]
fn correct_refuses_implausible_and_wrong_unit_calibrations() {
    let tag = "hostile-correct";
    let rec = counts_recording(tag, 40);
    let good = counts_cal(tag, "good.json", "", "");
    let (ok, err, out) = correct(&good, &rec);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // Sample 0: (600 − 2 − 512)/200, 0, (712 − 2 − 512)/200 g.
    assert!(
        (row[1] - 0.43).abs() < 1e-6 && row[2].abs() < 1e-9 && (row[3] - 0.99).abs() < 1e-6,
        "{row:?}"
    );

    let cubic = counts_cal(tag, "cubic.json", r#""cubic": [0, 0, 1e20]"#, "");
    let (ok, err, out) = correct(&cubic, &rec);
    assert!(!ok && !out.exists(), "{err}");
    assert!(
        err.contains("implausible calibration") && err.contains("corrected z output reaches"),
        "{err}"
    );
    // The same file is refused by `device put` for the same reason (before any port is opened).
    let (ok, _, put) = wiical(&[
        "device",
        "put",
        cubic.to_str().unwrap(),
        "--port",
        "/dev/does-not-exist",
    ]);
    assert!(!ok && put.contains("corrected z output reaches"), "{put}");

    // Scale drift of 1000/s on x from t = 0: sample 2 (t = 0.1 s, x = 599) has
    // x = (599 − 512)/200 · (1 + 1000·0.1) = 43.935 g.
    let drift = r#", "host_terms": [{"name": "scale-drift (x)", "family": "scale-drift", "axis": 0,
        "value": 1000.0, "unit": "1/s", "reference": {"time_s": 0.0}}]"#;
    let drifting = counts_cal(tag, "drift.json", "", drift);
    let (ok, err, out) = correct(&drifting, &rec);
    assert!(!ok && !out.exists(), "{err}");
    assert!(
        err.contains("corrected sample 2 (t = 0.1 s) has x = 43.93")
            && err.contains("beyond ±16 g"),
        "{err}"
    );

    // A calibration in g (bias 0, unit matrix) on counts: ≈ 940 g median.
    let in_g = common::temp_file(
        tag,
        "in_g.json",
        r#"{"bias": [0, 0, 0], "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}"#,
    );
    let (ok, err, out) = correct(&in_g, &rec);
    assert!(!ok && !out.exists(), "{err}");
    assert!(
        err.contains("different units")
            && err.contains("expects readings near 0 with about 1 units per g"),
        "{err}"
    );
    // The counts calibration on a recording in g: (−512)/200 on each axis, 4.4 g median.
    let g_rec = common::temp_file(
        tag,
        "g.csv",
        "t,x,y,z\n0,0.01,0,1\n0.1,0,0.02,0.99\n0.2,0,0,1.01\n",
    );
    let (ok, err, out) = correct(&good, &g_rec);
    assert!(!ok && !out.exists(), "{err}");
    assert!(
        err.contains("different units") && err.contains("median magnitude is 4.4"),
        "{err}"
    );
}

/// A temperature far outside anything real with a temperature-squared term makes the bias
/// infinite: the first such sample is named, and nothing is written.
#[test]
fn correct_refuses_non_finite_output_naming_the_sample() {
    let tag = "hostile-nonfinite";
    let text = "t,x,y,z,temp\n0,600,512,712,25\n0.1,600,512,712,25\n0.2,600,512,712,1e30\n0.3,600,512,712,25\n";
    let rec = common::temp_file(tag, "hot.csv", text);
    let hosts = r#", "host_terms": [{"name": "temperature-squared (z)", "family": "temperature-squared",
        "axis": 2, "value": 0.01, "unit": "raw/°C²", "reference": {"temperature_c": 25.0}}]"#;
    let cal = counts_cal(tag, "tsq.json", "", hosts);
    let (ok, err, out) = correct(&cal, &rec);
    assert!(!ok && !out.exists(), "{err}");
    // If the loader refuses the temperature itself, that names the line instead.
    assert!(
        err.contains("corrected sample 3 (t = 0.2 s) has z") && err.contains("not a finite number")
            || err.contains("line 4"),
        "{err}"
    );
}

/// Calibration files with the wrong shape are told in the file's own terms, naming the
/// field and row, by `correct` and `device put` alike.
#[test]
fn calibration_shape_errors_name_the_field() {
    let tag = "hostile-shape";
    let rec = counts_recording(tag, 5);
    let unit = r#"[[0.005, 0, 0], [0, 0.005, 0], [0, 0, 0.005]]"#;
    for (name, text, want) in [
        (
            "bias4",
            format!(r#"{{"bias": [1, 2, 3, 4], "matrix": {unit}}}"#),
            "bias has 4 values, expected 3",
        ),
        (
            "biasobj",
            format!(r#"{{"bias": {{"x": 1}}, "matrix": {unit}}}"#),
            "bias is an object, expected a list of 3 numbers",
        ),
        (
            "row2",
            r#"{"bias": [1, 2, 3], "matrix": [[1, 0, 0], [0, 1], [0, 0, 1]]}"#.to_string(),
            "matrix row 2 has 2 values, expected 3",
        ),
        (
            "text",
            format!(
                r#"{{"bias": [512, 512, 512], "matrix": {unit}, "effects": {{"cubic": ["a", 0, 0]}}}}"#
            ),
            "effects.cubic[0] is the text \"a\", expected a number",
        ),
        (
            "huge",
            format!(r#"{{"bias": [1e39, 512, 512], "matrix": {unit}}}"#),
            "bias[0] is 1e+39, beyond the largest value",
        ),
        (
            "nomatrix",
            r#"{"bias": [1, 2, 3]}"#.to_string(),
            "the file has no \"matrix\"",
        ),
        (
            "list",
            "[1, 2, 3]".to_string(),
            "the file holds a list of 3 values, expected an object",
        ),
        (
            "cross",
            format!(
                r#"{{"schema": "wiical-calibration/2", "bias": [512, 512, 512], "matrix": {unit}, "effects": {{"cross_quadratic": [[0, 0, 0, 0], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0]]}}}}"#
            ),
            "effects.cross_quadratic row 1 has 4 values, expected 5",
        ),
    ] {
        let cal = common::temp_file(tag, &format!("{name}.json"), &text);
        let (ok, err, _) = correct(&cal, &rec);
        assert!(!ok && err.contains(want), "{name}: {err}");
        assert!(
            !err.contains("invalid type") && !err.contains("expected a tuple"),
            "{name}: {err}"
        );
        let (ok, _, put) = wiical(&[
            "device",
            "put",
            cal.to_str().unwrap(),
            "--port",
            "/dev/does-not-exist",
        ]);
        assert!(!ok && put.contains(want), "{name}: {put}");
    }
}

/// An output that is a directory or a device is refused as an output, not with the input
/// sentence about standard input.
#[test]
fn a_refused_out_is_told_as_an_output() {
    let tag = "hostile-out";
    let rec = counts_recording(tag, 5);
    let cal = counts_cal(tag, "good.json", "", "");
    let dir = rec.parent().unwrap().to_str().unwrap().to_string();
    for out in ["/dev/null", dir.as_str()] {
        let (ok, _, err) = wiical(&[
            "correct",
            cal.to_str().unwrap(),
            rec.to_str().unwrap(),
            "--out",
            out,
        ]);
        assert!(!ok, "{out}");
        assert!(
            err.contains(&format!(
                "refusing to write {out}: it is not a regular file"
            )),
            "{err}"
        );
        assert!(!err.contains("standard input"), "{err}");
    }
}

/// Runs `wiical batch INPUTS --out OUT` with a time limit (a FIFO must not block it).
fn batch(inputs: &[&std::path::Path], out: &std::path::Path) -> (bool, String, String) {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_wiical"));
    c.arg("batch").args(inputs).arg("--out").arg(out);
    c.stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    let mut child = c.spawn().unwrap();
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("batch --out {} did not finish within 60 s", out.display());
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn batch_lines(out: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// `batch --out` never writes over a file it did not create: an input, an unrelated file, a
/// FIFO (refused at once, not blocking) and a directory are refused with their bytes
/// unchanged; its own results file is appended to.
#[test]
fn batch_never_writes_over_what_it_did_not_create() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("notes.csv");
    std::fs::write(&rec, "not a recording\n").unwrap();
    let other = dir.path().join("thesis.txt");
    std::fs::write(&other, "chapter 1\n").unwrap();
    for out in [&rec, &other] {
        let (ok, _, err) = batch(&[&rec], out);
        assert!(!ok && err.contains("is not a batch results file"), "{err}");
    }
    assert_eq!(std::fs::read_to_string(&rec).unwrap(), "not a recording\n");
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "chapter 1\n");
    let fifo = dir.path().join("pipe");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    for out in [fifo.as_path(), dir.path()] {
        let (ok, _, err) = batch(&[&rec], out);
        assert!(!ok && err.contains("it is not a regular file"), "{err}");
    }
    // Its own results file: created, then appended to on a new input.
    let results = dir.path().join("results.jsonl");
    assert!(batch(&[&rec], &results).0);
    let second = dir.path().join("more.csv");
    std::fs::write(&second, "x\n").unwrap();
    assert!(batch(&[&rec, &second], &results).0);
    assert_eq!(batch_lines(&results).len(), 2);
}

/// Resume is keyed by the file, not its spelling: the same file under another spelling or
/// through a link is skipped, two non-UTF-8 names that print alike are two files.
#[cfg(unix)]
#[test]
fn batch_resume_is_keyed_by_the_file() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.csv");
    std::fs::write(&a, "not a recording\n").unwrap();
    let results = dir.path().join("results.jsonl");
    assert!(batch(&[&a], &results).0);
    let respelt = dir.path().join(".").join("a.csv");
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&a, &link).unwrap();
    let (ok, out, err) = batch(&[&respelt, &link], &results);
    assert!(ok, "{err}");
    assert!(out.contains("1 already in"), "{out}");
    assert_eq!(batch_lines(&results).len(), 1);
    // Two names that are not UTF-8 and print alike (a\u{FFFD}.csv).
    let names = [b"u\xff.csv".as_slice(), b"u\xfe.csv".as_slice()];
    let paths: Vec<std::path::PathBuf> = names
        .iter()
        .map(|n| dir.path().join(std::ffi::OsStr::from_bytes(n)))
        .collect();
    for p in &paths {
        std::fs::write(p, "not a recording\n").unwrap();
    }
    let refs: Vec<&std::path::Path> = paths.iter().map(|p| p.as_path()).collect();
    assert!(batch(&refs, &results).0);
    assert_eq!(batch_lines(&results).len(), 3);
    let (ok, out, _) = batch(&refs, &results);
    assert!(ok && out.contains("2 already in"), "{out}");
    assert_eq!(batch_lines(&results).len(), 3);
}

/// Walking a directory follows links to files (as a pattern does) without looping on a link
/// to an ancestor, and an unreadable subdirectory is a line of its own, not a stop.
#[cfg(unix)]
#[test]
fn batch_walks_links_and_survives_an_unreadable_directory() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let elsewhere = dir.path().join("elsewhere.csv");
    std::fs::write(&elsewhere, "not a recording\n").unwrap();
    std::fs::write(data.join("own.csv"), "not a recording\n").unwrap();
    std::os::unix::fs::symlink(&elsewhere, data.join("linked.csv")).unwrap();
    std::os::unix::fs::symlink(&data, data.join("loop")).unwrap();
    let locked = data.join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::write(locked.join("hidden-from-us.csv"), "x\n").unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o000)).unwrap();
    // Root reads any directory: then only the link cases can be checked.
    let can_lock = std::fs::read_dir(&locked).is_err();
    let results = dir.path().join("results.jsonl");
    let (ok, out, err) = batch(&[&data], &results);
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert!(ok, "{err}");
    let lines = batch_lines(&results);
    let files: Vec<&str> = lines.iter().map(|l| l["file"].as_str().unwrap()).collect();
    assert!(files.iter().any(|f| f.ends_with("linked.csv")), "{files:?}");
    assert!(files.iter().any(|f| f.ends_with("own.csv")), "{files:?}");
    let looped = lines
        .iter()
        .find(|l| l["file"].as_str().unwrap().ends_with("loop"));
    let why = looped.map(|l| l["error"].as_str().unwrap().to_string());
    assert!(
        why.as_deref().is_some_and(|w| w.contains("link loop")),
        "{lines:?}"
    );
    if can_lock {
        let locked_line = lines
            .iter()
            .find(|l| l["file"].as_str().unwrap().ends_with("locked"))
            .unwrap_or_else(|| panic!("no line for the locked directory: {lines:?}"));
        assert_eq!(locked_line["ok"], false);
        assert!(out.contains("could not be listed"), "{out}");
    }
}

/// `correct` holds another sensor's calibration to physics, not to the Nunchuk's limits: the
/// Xsens calibration (offset ~33 000 counts, ~4 000 counts/g: far outside a Nunchuk's 512 ±
/// 100 and 200 counts/g) corrects its recording to 1 g, while the same calibration with an
/// absurd cubic is refused by the ±16 g output bound every accelerometer here shares.
#[test]
fn correct_judges_another_sensors_calibration_by_physics_not_nunchuk_limits() {
    let rec = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("xsens.json");
    let (ok, _, err) = wiical(&["fit", rec.to_str().unwrap(), "--out", cal.to_str().unwrap()]);
    assert!(ok, "{err}");
    let c: serde_json::Value = serde_json::from_slice(&std::fs::read(&cal).unwrap()).unwrap();
    let bias0 = c["bias"][0].as_f64().unwrap();
    assert!(
        (bias0 - 512.0).abs() > 100.0,
        "not a Nunchuk-like offset: {bias0}"
    );
    let out = dir.path().join("corrected.csv");
    let args = [
        "correct",
        cal.to_str().unwrap(),
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let (ok, _, err) = wiical(&args);
    assert!(ok, "{err}");
    // The corrected magnitude of the first still sample is 1 g within 1 %.
    let text = std::fs::read_to_string(&out).unwrap();
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let g = (row[1] * row[1] + row[2] * row[2] + row[3] * row[3]).sqrt();
    assert!((g - 1.0).abs() < 0.01, "|a| = {g}");
    let mut bad = c.clone();
    bad["effects"]["cubic"] = serde_json::json!([0.0, 0.0, 1e20]);
    std::fs::write(&cal, serde_json::to_string(&bad).unwrap()).unwrap();
    let (ok, _, err) = wiical(&args);
    assert!(!ok && err.contains("implausible calibration"), "{err}");
}

/// `live --device` with a port that is missing or not a serial port is refused before the
/// page is served (it used to serve an empty page until Ctrl-C).
#[test]
fn live_refuses_a_device_that_is_not_a_port_before_serving() {
    for port in ["/dev/null", "/dev/does-not-exist"] {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_wiical"));
        c.args(["live", "--device", port, "--port", "0"]);
        c.stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped());
        let mut child = c.spawn().unwrap();
        let start = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() {
            if start.elapsed() > std::time::Duration::from_secs(30) {
                child.kill().unwrap();
                panic!("live --device {port} kept serving");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("--device"), "{err}");
        assert!(o.stdout.is_empty(), "no address printed: {:?}", o.stdout);
    }
}

/// A pipe given to `batch` by name is refused saying what it is (it was "no such file");
/// found in a directory it is a line, and the batch does not block on it.
#[cfg(unix)]
#[test]
fn batch_names_a_pipe_and_does_not_block_on_one() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir(&data).unwrap();
    std::fs::write(data.join("notes.csv"), "not a recording\n").unwrap();
    let fifo = data.join("pipe.csv");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let results = dir.path().join("results.jsonl");
    let (ok, _, err) = batch(&[&fifo], &results);
    assert!(!ok && err.contains("a pipe, device or socket"), "{err}");
    let (ok, _, err) = batch(&[&data], &results);
    assert!(ok, "{err}");
    let lines = batch_lines(&results);
    let pipe = lines
        .iter()
        .find(|l| l["file"].as_str().unwrap().ends_with("pipe.csv"));
    assert!(pipe.is_some_and(|l| l["ok"] == false), "{lines:?}");
}

/// Runs `wiical args` with `input` on standard input and `env` set: (success, stdout, stderr).
fn wiical_piped(args: &[&str], input: &[u8], env: &[(&str, &str)]) -> (bool, String, String) {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(args)
        .envs(env.iter().copied())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    // A refusal may close the pipe before all is written: that is the point of it.
    let _ = stdin.write_all(input);
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.success(), text(&out.stdout), text(&out.stderr))
}

/// Standard input too long to hold (here: over 4 kB) is copied to a temporary file in
/// `$TMPDIR` and read from there: the same report as held, the copy deleted after, errors
/// naming `-` (not the copy), and bounded — text no recording starts with (no digit, not
/// UTF-8) is refused before the copy, and the copy stops at `--max-spool-bytes`.
#[test]
fn standard_input_too_long_to_hold_is_spooled_within_bounds() {
    let tmp = tempfile::tempdir().unwrap();
    let tmpdir = tmp.path().to_str().unwrap();
    let small = [("TMPDIR", tmpdir)];
    let leftovers = || std::fs::read_dir(tmp.path()).unwrap().count();
    let xsens = std::fs::read(data_dir().join("imu_tk_xsens/xsens_acc.mat")).unwrap();
    let held_args = ["fit", "-", "--json"];
    let args = ["fit", "-", "--json", "--stream-from-bytes", "4096"];
    let (ok, held, err) = wiical_piped(&held_args, &xsens, &small);
    assert!(ok, "{err}");
    let (ok, spooled, err) = wiical_piped(&args, &xsens, &small);
    assert!(ok, "{err}");
    assert_eq!(held, spooled, "the spooled standard input's report");
    assert_eq!(leftovers(), 0, "the copy is deleted");

    // A bad number far down a spooled input: named in `-`, at its line.
    let mut bad = xsens.clone();
    let line_start = bad.len() - 200 + memchr_back(&bad[bad.len() - 200..]);
    bad.splice(line_start..line_start, b"1.0 2.0 x 4.0\n".iter().copied());
    let (ok, _, err) = wiical_piped(&args, &bad, &small);
    assert!(
        !ok && err.contains("in -") && !err.contains("wiical-stdin"),
        "{err}"
    );

    let refusals: [(&[u8], &str); 2] = [
        (&b"y\n".repeat(10_000), "hold no digit"),
        (&[0xFFu8; 20_000], "not UTF-8"),
    ];
    for (input, words) in refusals {
        let (ok, _, err) = wiical_piped(&args, input, &small);
        assert!(!ok && err.contains(words), "{words}: {err}");
    }
    let capped = [&args[..], &["--max-spool-bytes", "100000"]].concat();
    let (ok, _, err) = wiical_piped(&capped, &xsens, &small);
    assert!(!ok && err.contains("--max-spool-bytes"), "{err}");
    assert_eq!(leftovers(), 0, "nothing left after a refusal");
}

/// Offset in `tail` just after its first line end.
fn memchr_back(tail: &[u8]) -> usize {
    tail.iter().position(|&b| b == b'\n').unwrap() + 1
}

/// The recording piped in with `<` is never replaced: `--out` naming the file standard input
/// reads (by its own name or as `/dev/stdin`) is refused before anything is read or written,
/// for `correct`, `analyze` and `fit` with `-` as the recording; another output still works.
#[test]
fn out_naming_the_file_on_standard_input_is_refused() {
    let tag = "hostile-stdin-out";
    let rec = counts_recording(tag, 40);
    let cal = counts_cal(tag, "good.json", "", "");
    let before = std::fs::read(&rec).unwrap();
    let (r, c) = (rec.to_str().unwrap(), cal.to_str().unwrap());
    for args in [
        vec!["correct", c, "-", "--out", r],
        vec!["correct", c, "-", "--out", "/dev/stdin"],
        vec!["analyze", "-", "--out", r],
        vec!["fit", "-", "--out", r],
        vec!["fit", "-", "--out", "/dev/stdin"],
    ] {
        let (ok, _, err) = common::wiical_stdin(&args, &rec);
        assert!(!ok, "{args:?} succeeded");
        assert!(
            err.contains("it is the file standard input reads"),
            "{args:?}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert_eq!(std::fs::read(&rec).unwrap(), before, "{args:?}");
    }
    let other = rec.with_file_name("corrected.csv");
    let (ok, _, err) =
        common::wiical_stdin(&["correct", c, "-", "--out", other.to_str().unwrap()], &rec);
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(&rec).unwrap(), before);
}
