//! Golden outputs: every command on the real recordings (and on simulations with fixed seeds)
//! gives the same output as the release binary did when the goldens were captured
//! (`host/tests/golden/cases.tsv`, regenerated only on purpose with `scripts/golden`).
//!
//! JSON is compared structurally: the same keys in the same places, strings and booleans
//! equal, numbers within 1e-9 relative. Text output and error messages (with their exit
//! status) are compared exactly, after replacing the data and temporary directories by
//! `@DATA` and `@TMP`.

mod common;
use common::data_dir;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Relative tolerance on numbers. Values this close are the same computation up to
/// floating-point reassociation; anything that changes a result is far larger.
const REL_TOL: f64 = 1e-9;
/// Absolute floor for values that should be zero but come out as ±1e-17 rounding noise.
const ABS_FLOOR: f64 = 1e-12;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// Compares `got` with `want` at `path`, pushing one line per difference.
fn compare(path: &str, got: &Value, want: &Value, diffs: &mut Vec<String>) {
    match (got, want) {
        (Value::Number(a), Value::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
            let tol = REL_TOL * a.abs().max(b.abs()) + ABS_FLOOR;
            if (a - b).abs() > tol {
                diffs.push(format!("{path}: {a} != golden {b}"));
            }
        }
        (Value::Object(a), Value::Object(b)) => {
            let ka: Vec<&String> = a.keys().collect();
            let kb: Vec<&String> = b.keys().collect();
            if ka != kb {
                diffs.push(format!("{path}: keys {ka:?} != golden {kb:?}"));
                return;
            }
            for (k, v) in a {
                compare(&format!("{path}.{k}"), v, &b[k], diffs);
            }
        }
        (Value::Array(a), Value::Array(b)) => {
            if a.len() != b.len() {
                diffs.push(format!("{path}: length {} != golden {}", a.len(), b.len()));
                return;
            }
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                compare(&format!("{path}[{i}]"), x, y, diffs);
            }
        }
        (a, b) => {
            if a != b {
                diffs.push(format!("{path}: {a} != golden {b}"));
            }
        }
    }
}

/// Runs one case; returns its differences from the golden (empty: identical).
fn run_case(name: &str, line: &str, data: &str) -> Vec<String> {
    let tmp = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-golden-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let tmp_s = tmp.to_str().unwrap().to_string();
    let line = line.replace("@DATA", data).replace("@TMP", &tmp_s);
    let cmds: Vec<&str> = line.split(" ;; ").collect();
    let mut diffs = Vec::new();
    for (i, cmd) in cmds.iter().enumerate() {
        let args: Vec<&str> = cmd.split_whitespace().collect();
        let last = i + 1 == cmds.len();
        if args[0] == "cat" {
            let got = std::fs::read_to_string(args[1]).unwrap();
            let want = std::fs::read_to_string(golden_dir().join(format!("{name}.json"))).unwrap();
            let got: Value = serde_json::from_str(&got).unwrap();
            let want: Value = serde_json::from_str(&want).unwrap();
            compare(name, &got, &want, &mut diffs);
            continue;
        }
        let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
            .args(&args)
            .output()
            .expect("run wiical");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        let scrub = |s: &str| s.replace(data, "@DATA").replace(&tmp_s, "@TMP");
        if !last {
            assert!(out.status.success(), "{name}: step {i} failed: {stderr}");
            continue;
        }
        let g = |ext: &str| golden_dir().join(format!("{name}.{ext}"));
        if !out.status.success() {
            let got = format!(
                "exit {}\n{}",
                out.status.code().unwrap_or(-1),
                scrub(&stderr)
            );
            let want = std::fs::read_to_string(g("err")).unwrap_or_default();
            if got.trim_end() != want.trim_end() {
                diffs.push(format!("{name}: error {got:?} != golden {want:?}"));
            }
        } else if args.last() == Some(&"--json") {
            let want = std::fs::read_to_string(g("json"))
                .unwrap_or_else(|_| panic!("{name}: no golden JSON (it failed when captured?)"));
            let got: Value = serde_json::from_str(&stdout).unwrap();
            let want: Value = serde_json::from_str(&want).unwrap();
            compare(name, &got, &want, &mut diffs);
        } else {
            let want = std::fs::read_to_string(g("txt"))
                .unwrap_or_else(|_| panic!("{name}: no golden text (it failed when captured?)"));
            if scrub(&stdout).trim_end() != want.trim_end() {
                diffs.push(format!("{name}: text output differs from the golden"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    diffs
}

#[test]
fn outputs_match_the_goldens() {
    let data = std::fs::canonicalize(data_dir()).unwrap();
    let data = data.to_str().unwrap();
    let cases = std::fs::read_to_string(golden_dir().join("cases.tsv")).unwrap();
    let mut diffs = Vec::new();
    let mut ran = 0;
    for line in cases.lines() {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (name, cmd) = line.split_once('\t').expect("name<TAB>command");
        diffs.extend(run_case(name, cmd, data));
        ran += 1;
    }
    assert!(ran >= 60, "only {ran} golden cases");
    assert!(
        diffs.is_empty(),
        "{} differences:\n{}",
        diffs.len(),
        diffs.join("\n")
    );
}

#[test]
fn comparison_catches_a_changed_number_key_or_string() {
    let want: Value = serde_json::json!({"a": 1.0, "b": [2.0, "x"], "c": {"d": true}});
    let mut diffs = Vec::new();
    compare("t", &want.clone(), &want, &mut diffs);
    assert!(diffs.is_empty());
    for got in [
        serde_json::json!({"a": 1.0 + 1e-6, "b": [2.0, "x"], "c": {"d": true}}),
        serde_json::json!({"a": 1.0, "b": [2.0, "y"], "c": {"d": true}}),
        serde_json::json!({"a": 1.0, "b": [2.0, "x"], "c": {"e": true}}),
        serde_json::json!({"a": 1.0, "b": [2.0], "c": {"d": true}}),
    ] {
        let mut diffs = Vec::new();
        compare("t", &got, &want, &mut diffs);
        assert_eq!(diffs.len(), 1, "{got}");
    }
}
