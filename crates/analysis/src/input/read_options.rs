//! How the front door reads a file: the size from which plain text is streamed, the bound on
//! a copy of standard input, and where a streamed file's rows are kept for its later passes. These
//! were environment variables; they are options now, set by the CLI's (hidden) flags and the
//! Python package's keyword arguments, so that a library call does what its arguments say and
//! nothing in the environment changes it. The defaults are the reading every command does.

/// Plain text files at least this large (bytes) are streamed ([`ReadOptions::stream_from_bytes`]):
/// `fit` and `analyze` read them in passes with memory bounded by a piece and the windows,
/// where holding the rows would take ~1.5× the file. Smaller files are held: one read,
/// no re-parse per pass.
pub const STREAM_FROM_BYTES: u64 = 128 << 20;

/// The most of standard input copied to a temporary file (bytes; 64 GiB: a month of 100 Hz
/// CSV is ~9 GB): an endless stream (`yes 1,2,3`) must end in a sentence, not in a full disk.
pub const MAX_SPOOL_BYTES: u64 = 64 << 30;

/// Where the first pass over a streamed text file keeps the rows it parsed, for the later
/// passes to read back (the text is parsed once). When they are bound for the temporary
/// directory and it cannot take them (none, not writable, a full disk), the file is refused
/// with a sentence naming it and the directory, saying to set `TMPDIR` or free space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpillMode {
    /// In memory while they fit (`text_spill`'s memory bound), else in a temporary file.
    #[default]
    Auto,
    /// Always in the temporary file, whatever their size (benchmarks, tests).
    Disk,
}

/// How [`crate::input::front_door`] reads: carried by [`crate::LoadOptions::read`] to every
/// reader. `ReadOptions::default()` is what every command does unless told otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadOptions {
    /// Size, in bytes, from which a plain text file is streamed (read in passes) rather than
    /// held, and up to which standard input is held (at most the size limit of files read
    /// whole) rather than copied to a temporary file. `0` streams every plain text file,
    /// `u64::MAX` none (tests and benchmarks that compare the two paths on one file).
    /// Default [`STREAM_FROM_BYTES`] (128 MiB).
    pub stream_from_bytes: u64,
    /// The most bytes of standard input copied to a temporary file before the read is
    /// refused with a sentence. Default [`MAX_SPOOL_BYTES`] (64 GiB).
    pub max_spool_bytes: u64,
    /// Where a streamed file's first pass keeps its rows. Default [`SpillMode::Auto`].
    pub spill: SpillMode,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            stream_from_bytes: STREAM_FROM_BYTES,
            max_spool_bytes: MAX_SPOOL_BYTES,
            spill: SpillMode::Auto,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The defaults are the values the environment variables fell back to.
    #[test]
    fn defaults_are_todays_reading() {
        let d = ReadOptions::default();
        assert_eq!(d.stream_from_bytes, 128 * 1024 * 1024);
        assert_eq!(d.max_spool_bytes, 64 * 1024 * 1024 * 1024);
        assert_eq!(d.spill, SpillMode::Auto);
    }
}
