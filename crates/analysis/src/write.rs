//! Writing output files. Every file the engine or the CLI writes goes through
//! [`write_file`], so that how files are written (today a plain `std::fs::write`) is decided
//! in one place.

use crate::error::{Error, Result};
use std::path::Path;

/// Writes `bytes` to `path` (created or replaced).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|source| Error::Write {
        path: path.into(),
        source,
    })
}
