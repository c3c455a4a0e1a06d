//! Test support shared by the CLI's integration tests: where the real recordings are.

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
