//! Issue 25's hostile inputs, one test per item that has a CLI face: each gives one sentence
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
