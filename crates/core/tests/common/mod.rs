//! Test support shared by the core's integration tests: where the real recordings are.

use std::path::PathBuf;

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`. Fails loudly when
/// missing, so a test on real data can never pass by skipping its data.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("WIICAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    assert!(
        dir.is_dir(),
        "data directory {} is missing: set WIICAL_DATA to the shared/data folder",
        dir.display()
    );
    dir
}
