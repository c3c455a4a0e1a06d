//! Test support: where the real recordings are ([`data_dir`]), simulated recordings
//! ([`sim`]) and the residual correlates' recording and check ([`correlates`]).

// Each test binary includes this module with `mod common;` and uses a part of it.
#![allow(dead_code)]

pub mod correlates;
pub mod sim;

use std::path::{Path, PathBuf};
use wiical_analysis::input::columns::LoadOptions;
use wiical_analysis::input::raw::load;

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`. Fails loudly when
/// missing, so a test on real data can never pass by skipping its data.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("WIICAL_DATA")
        .map(Into::into)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    assert!(
        dir.is_dir(),
        "shared data not found at {} (set WIICAL_DATA)",
        dir.display()
    );
    dir
}

/// Calls `f` with every raw file of GGIRread's test set (3 `.cwa`, 1 `.bin`) and the load
/// options to read it with: the accelerometer, and for the AX6 its gyroscope too. Fails unless
/// all 4 files were there, so a reader's test cannot pass on fewer.
pub fn each_ggirread_raw_file(mut f: impl FnMut(&Path, &LoadOptions)) {
    let dir = data_dir().join("ggirread_testfiles");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if load::raw_file_format(&path).is_none() {
            continue;
        }
        f(&path, &LoadOptions::default());
        if path.to_string_lossy().contains("ax6") {
            let gyro = LoadOptions {
                columns: Some(["gx", "gy", "gz"].map(String::from)),
                ..Default::default()
            };
            f(&path, &gyro);
        }
        seen += 1;
    }
    assert_eq!(
        seen,
        4,
        "GGIRread's 3 .cwa and 1 .bin files in {}",
        dir.display()
    );
}

/// Writes `bytes` to `name` in this test binary's scratch folder `wiical-<folder>-<pid>` under
/// the temporary directory (scripts/test points it at a folder it deletes) and returns the path.
pub fn scratch(folder: &str, name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wiical-{folder}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}
