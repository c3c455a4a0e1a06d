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
