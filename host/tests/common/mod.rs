//! Test support shared by the CLI's integration tests: where the real recordings are, running
//! the binary (with arguments, or with a file on standard input), its JSON, scratch files.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`. Fails loudly when
/// missing, so a test on real data can never pass by skipping its data.
#[allow(dead_code)] // not every test file reads the shared recordings
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("WIICAL_DATA")
        .map(Into::into)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    assert!(
        dir.is_dir(),
        "shared data not found at {} (set WIICAL_DATA)",
        dir.display()
    );
    dir
}

/// Runs the `wiical` binary under test: (exit status success, stdout, stderr).
#[allow(dead_code)] // not every test file runs the binary
pub fn wiical(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(args)
        .output()
        .expect("run wiical");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `wiical` with `file` on standard input: (exit status success, stdout, stderr).
#[allow(dead_code)]
pub fn wiical_stdin(args: &[&str], file: &Path) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(args)
        .stdin(std::fs::File::open(file).expect("open stdin file"))
        .output()
        .expect("run wiical");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `wiical` and parses its stdout as JSON; a failed run or bad JSON fails the test with
/// the command's stderr or output.
#[allow(dead_code)]
pub fn json(args: &[&str]) -> serde_json::Value {
    let (ok, out, err) = wiical(args);
    assert!(ok, "wiical {args:?} failed: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("bad JSON ({e}): {out}"))
}

/// Writes `contents` to `name` in this test process's scratch directory
/// (`$TMPDIR/wiical-<tag>-<pid>`) and returns its path.
#[allow(dead_code)]
pub fn temp_file(tag: &str, name: &str, contents: &str) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}
