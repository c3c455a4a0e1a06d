//! Which path a recording to correct takes: held in memory ([`Samples::Held`], the loader's
//! [`crate::load`]), or — a plain text file (gzip'd too) of at least
//! [`crate::input::read_options::ReadOptions::stream_from_bytes`], or standard input long enough to be
//! spooled to a temporary file — read in passes from the file ([`Samples::Streamed`],
//! [`crate::input::text_source::TextSource`]) and corrected as it is read
//! ([`super::pass`]). The same threshold as `fit`, `analyze` and `noise`.

use crate::error::Result;
use crate::input::columns::LoadOptions;
use crate::input::front_door::{self, is_text_file_from, Opened};
use crate::input::recording::Recording;
use crate::input::text::parse;
use crate::input::text_source::TextSource;
use std::path::Path;

/// A recording to correct.
// One value per command, moved once: its size does not matter, boxing either variant moves
// the lint to the other.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Samples {
    /// Every sample in memory.
    Held(Recording),
    /// Read in passes from a file, never held.
    Streamed(TextSource),
}

impl Samples {
    /// The recording as read (for a streamed file: without samples), for its notes.
    pub fn recording(&self) -> &Recording {
        match self {
            Samples::Held(rec) => rec,
            Samples::Streamed(src) => &src.meta,
        }
    }
}

/// [`open_samples_from`] with the threshold of `opts.read` (default 128 MiB).
/// A recording that must be held (a raw file) is refused beyond
/// [`front_door::MAX_HELD_SAMPLES`] ([`front_door::load_held`]).
pub fn open_samples(path: &Path, opts: &LoadOptions) -> Result<Samples> {
    let limit = front_door::HoldLimit::of(
        "correct",
        "a text file (plain or gzip'd) of any length is read in passes: cut the raw recording shorter or convert it to text",
    );
    open_samples_within(path, opts, opts.read.stream_from_bytes, Some(limit))
}

/// Opens `path` (`-`: standard input) as [`Samples`]: streamed when it is a regular text file
/// of at least `stream_from` bytes (a gzip file's content counted) that is plain delimited
/// text, or standard input spooled to a temporary file; held otherwise, as [`crate::load`]
/// reads it. Errors name the file.
pub fn open_samples_from(path: &Path, opts: &LoadOptions, stream_from: u64) -> Result<Samples> {
    open_samples_within(path, opts, stream_from, None)
}

/// [`open_samples_from`], a held recording refused beyond `limit`.
fn open_samples_within(
    path: &Path,
    opts: &LoadOptions,
    stream_from: u64,
    limit: Option<front_door::HoldLimit>,
) -> Result<Samples> {
    if path.as_os_str() == "-" {
        return open_stdin(path, opts, limit);
    }
    if is_text_file_from(path, stream_from) {
        let src = TextSource::open(path, opts, |_| true).map_err(|e| e.in_file(path))?;
        if let Some(src) = src {
            return Ok(Samples::Streamed(src));
        }
    }
    front_door::load_within(path, opts, limit).map(Samples::Held)
}

/// Standard input, read once: spooled (longer than the threshold) it is streamed from the
/// temporary file, which lives as long as the source; else read as [`crate::load`] reads it.
fn open_stdin(
    path: &Path,
    opts: &LoadOptions,
    limit: Option<front_door::HoldLimit>,
) -> Result<Samples> {
    Ok(Samples::Held(match front_door::open(path, &opts.read)? {
        Opened::Spooled(tmp) => {
            // Errors name `-`, the input the user gave, not the copy's temporary name.
            let src = TextSource::open(&tmp, opts, |_| true).map_err(|e| e.in_file(path))?;
            if let Some(mut src) = src {
                src.keep(tmp, path);
                return Ok(Samples::Streamed(src));
            }
            front_door::load_within(&tmp, opts, limit).map_err(|e| e.renaming(&tmp, path))?
        }
        Opened::Raw(raw) => {
            crate::input::raw::load::load_raw(raw.blocks(), opts).map_err(|e| e.in_file(path))?
        }
        Opened::Text(text) => parse(&text, opts).map_err(|e| e.in_file(path))?,
        // A regular file's kinds: not standard input's.
        Opened::RawFile(_) | Opened::TextFile => front_door::load_within(path, opts, limit)?,
    }))
}
