//! `wiical simulate --protocol`: each protocol written with its columns and its truth; the
//! flags of the multi-position simulation refused beside it, `--no-clock` refused without it.

mod common;
use common::wiical;
use serde_json::Value;

#[test]
fn protocols_write_their_columns_and_truth() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("turntable", false, "gx,gy,gz"),
        ("ferraris", true, "ax,ay,az,gx,gy,gz"),
        ("face-missing", false, "t,ax,ay,az,gx,gy,gz"),
    ];
    for (name, no_clock, header) in cases {
        let out = dir.path().join(format!("{name}.csv"));
        let o = out.to_str().unwrap();
        let mut args = vec!["simulate", "--protocol", name, "--out", o, "--seed", "3"];
        if no_clock {
            args.push("--no-clock");
        }
        let (ok, stdout, err) = wiical(&args);
        assert!(ok, "{err}");
        assert!(stdout.contains(&format!("protocol {name}")), "{stdout}");
        let text = std::fs::read_to_string(&out).unwrap();
        assert_eq!(text.lines().next(), Some(header));
        let truth: Value =
            serde_json::from_str(&std::fs::read_to_string(format!("{o}.truth.json")).unwrap())
                .unwrap();
        assert_eq!(truth["protocol"], name);
        assert_eq!(truth["seed"], 3);
        assert_eq!(truth["samples"], text.lines().count() - 1);
    }
}

#[test]
fn protocol_flags_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    let o = out.to_str().unwrap();
    let (ok, _, err) = wiical(&["simulate", "--protocol", "sixfaces", "--out", o]);
    assert!(
        !ok && err.contains("six-faces, one-pose, ferraris"),
        "{err}"
    );
    let (ok, _, err) = wiical(&[
        "simulate",
        "--protocol",
        "six-faces",
        "--effect",
        "cubic",
        "--out",
        o,
    ]);
    assert!(!ok && err.contains("cannot be used with"), "{err}");
    let (ok, _, err) = wiical(&["simulate", "--no-clock", "--out", o]);
    assert!(!ok && err.contains("--protocol"), "{err}");
    assert!(!out.exists());
}
