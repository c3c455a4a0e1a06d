//! `wiical-io`: how wiical reads its input files and writes its output files, without the
//! analysis engine — so that `wiical-capture` and `wiical-device-sim`, which only read a log
//! or a flash image and write a file atomically, do not build the engine for it.
//!
//! | module | what |
//! |---|---|
//! | [`bounded`] | input read with bounds: only a regular file or `-` (standard input), never more than a cap, gzip decompressed to the same cap, UTF-8 checked with the line and column named |
//! | [`mod@write`] | atomic output: a temporary file beside the target, `fsync`, rename (no half-written file, no input overwritten) |
//! | [`error`] | why: [`InputError`] (a file not read), [`OutputError`] (a file not written), joined in [`enum@Error`] |
//!
//! `wiical-analysis` re-exports these where its callers found them (`input::bounded`,
//! `output::write`, `error::input`, `error::output`), and its `Error` holds an [`InputError`]
//! or [`OutputError`] as the same variants (`Error::Input`, `Error::Output`).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bounded;
pub mod error;
pub mod write;

pub use error::{Error, InputError, OutputError, Result};
