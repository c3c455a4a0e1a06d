//! Test support: where the real recordings are ([`data_dir`]), simulated recordings
//! ([`sim`]) and the residual correlates' recording and check ([`correlates`]).

// Each test binary includes this module with `mod common;` and uses a part of it.
#![allow(dead_code)]

pub mod correlates;
pub mod sim;

use std::path::{Path, PathBuf};

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
