//! `wiical batch` killed halfway and run again: every file appears exactly once in the
//! results file, and a file that is not a recording is a line.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_wiical");

fn lines(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

#[test]
fn killed_halfway_and_rerun_every_file_appears_exactly_once() {
    let dir = tempfile::tempdir().unwrap();
    let n = 40;
    for seed in 0..n {
        let out = dir.path().join(format!("rec{seed:02}.csv"));
        let st = Command::new(BIN)
            .args([
                "simulate",
                "--poses",
                "20",
                "--seed",
                &seed.to_string(),
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
    }
    std::fs::write(dir.path().join("rec99.csv"), "not,a\nrecording\n").unwrap();
    let pattern = dir.path().join("rec*.csv");
    let results = dir.path().join("results.jsonl");
    let batch = || {
        let mut c = Command::new(BIN);
        c.arg("batch").arg(&pattern).arg("--out").arg(&results);
        c
    };
    // First run: killed once a few lines are in.
    let mut child = batch().arg("--jobs").arg("2").spawn().unwrap();
    let started = Instant::now();
    while lines(&results).len() < 5 && started.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let after_kill = lines(&results).len();
    assert!(
        (5..=n).contains(&after_kill),
        "killed with {after_kill} lines of {}",
        n + 1
    );
    // Second run: the rest.
    let out = batch().output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("(skipped)"), "{summary}");
    let all = lines(&results);
    let text = std::fs::read_to_string(&results).unwrap();
    assert_eq!(text.lines().count(), all.len(), "every line is whole JSON");
    let mut count: HashMap<String, usize> = HashMap::new();
    for l in &all {
        *count
            .entry(l["file"].as_str().unwrap().to_string())
            .or_default() += 1;
    }
    assert_eq!(count.len(), n + 1);
    assert!(count.values().all(|&c| c == 1), "{count:?}");
    let bad: Vec<_> = all.iter().filter(|l| l["ok"] == false).collect();
    assert_eq!(bad.len(), 1);
    assert!(bad[0]["file"].as_str().unwrap().ends_with("rec99.csv"));
    let good = all.iter().find(|l| l["ok"] == true).unwrap();
    assert!(good["result"]["quality"]["verdict"].is_string());
}
