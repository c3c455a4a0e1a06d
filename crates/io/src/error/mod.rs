//! The I/O crate's errors: [`InputError`] (a file could not be read), [`OutputError`] (a
//! file was not written, or not written because it was refused first), and [`enum@Error`]
//! joining them with the one refusal both sides share: a path that is not a regular file.
//!
//! Messages describe the file by its path and the bound by its number, never by a
//! command-line flag: a program using this crate has no flags. `wiical-analysis`'s `Error`
//! takes each variant as its own variant of the same name (`From<wiical_io::Error>`), so a
//! match on `wiical_analysis::Error::Input(InputError::…)` sees these errors unchanged.

pub mod input;
pub mod output;

pub use input::InputError;
pub use output::OutputError;

use std::path::PathBuf;

/// Why a file was not read or not written.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or parsed ([`InputError`]).
    #[error(transparent)]
    Input(#[from] InputError),
    /// An output could not be written, or is refused before writing ([`OutputError`]).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// An input or output path names something other than a regular file (a device, a
    /// directory, a pipe): `/dev/zero` would never end.
    #[error("{} is not a regular file (give a file, or - for standard input)", path.display())]
    NotRegularFile {
        /// The path.
        path: PathBuf,
    },
}

/// Result with the I/O [`enum@Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
