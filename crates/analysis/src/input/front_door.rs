//! The one front door for every input file: a file is sniffed once ([`open`]: a regular raw
//! file (`.cwa`, `.bin`) by its magic, gzip by its magic — decompressed and sniffed again —, a raw
//! Axivity / GENEActiv file by its first bytes, else UTF-8 text) into an [`Opened`] kind, and
//! each kind has one reader: [`load`] (every sample), [`load_imu`] (an accelerometer and a
//! gyroscope from one read), [`load_input`] (what `fit`, `analyze` and `batch` need: samples,
//! or a table whose rows are windows already — a window-mean text table or a raw file's still
//! epochs; a large plain text file streamed, [`Input::Stream`]), [`load_samples`] (the same
//! reading for `correct`: samples only). A regular text file of any size is read by one piece
//! loop ([`crate::input::text_file`]: a small file is its one piece), not held as a string first.
//!
//! Why one door: the kind decides the reader, and each door used to decide it again (and
//! standard input can be read only once). Errors are the readers' own, with the file named.

use crate::error::gyro::GyroError;
use crate::error::input::InputError;
use crate::error::{Error, Result};
use crate::input::bounded::{
    check_text_head, decompressed, free_bytes, read_bounded, read_full, text_of, KEEP_FREE_BYTES,
    MAX_RECORDING_BYTES,
};
use crate::input::columns::{LoadOptions, Sensor};
use crate::input::raw::{self, Raw, RawFormat};
pub use crate::input::read_options::{ReadOptions, MAX_SPOOL_BYTES, STREAM_FROM_BYTES};
use crate::input::recording::Recording;
use crate::input::table::WindowTable;
use crate::input::temp_files::{self, OwnTemp};
use crate::input::text::parse;
use crate::input::text_file;
use crate::input::text_source::TextSource;
use crate::input::window_means::{parse_window_table, WindowInputOptions};
use std::ops::Not;
use std::path::Path;
use std::sync::Arc;

/// What a file is, decided from its first bytes.
#[derive(Debug)]
pub enum Opened {
    /// A regular file starting with a raw format's magic (Axivity `.cwa`, GENEActiv `.bin`):
    /// read block by block ([`raw::load`]), never held whole: its still epochs, or every
    /// sample into arrays allocated once.
    RawFile(RawFormat),
    /// A raw file held in memory (a `.cwa` or `.bin` from gzip or standard input:
    /// [`Raw::Held`]), its header read.
    Raw(Raw),
    /// UTF-8 text held whole (byte-order mark removed): standard input, or a file that is not
    /// a regular one. The text reader tells CSV, whitespace-separated numbers, GRT and a
    /// window-mean table apart by the first lines.
    Text(String),
    /// A regular text file (plain, or gzip'd text) of any size: read in pieces by
    /// [`crate::input::text_file`] when it is plain delimited text (a small file is its one
    /// piece), else whole.
    TextFile,
    /// Standard input too long to hold, copied to a temporary file (deleted when this is
    /// dropped, or by the binary's signal handler: [`crate::input::temp_files`]): read from
    /// there as a regular file.
    Spooled(OwnTemp),
}

/// Sniffs `path` (`-`: standard input, read once) and reads what its kind needs up front: a
/// regular file only its first bytes, anything else whole, at most
/// [`MAX_RECORDING_BYTES`] (gzip decompressed to the same limit). Standard input longer than
/// [`ReadOptions::stream_from_bytes`] (or than its content may be held, gzip'd) is copied to a
/// temporary file ([`Opened::Spooled`]) of at most [`ReadOptions::max_spool_bytes`].
pub fn open(path: &Path, read: &ReadOptions) -> Result<Opened> {
    if path.as_os_str() == "-" {
        return open_stdin(read);
    }
    if let Some(format) = raw::load::raw_file_format(path) {
        return Ok(Opened::RawFile(format));
    }
    if text_file_size(path).is_some() {
        // Not a raw file by its first bytes: a `.cwa` or `.bin` name on it is refused, as
        // when it is read whole (one sentence, not a text reader's).
        raw::detect(&[], path).map_err(|e| e.in_file(path))?;
        return Ok(Opened::TextFile);
    }
    Ok(match read_whole(path)? {
        Ok(raw) => Opened::Raw(raw),
        Err(text) => Opened::Text(text),
    })
}

/// True for a gzip file's content over the size limit of files read whole.
fn gzip_too_large(e: &Error) -> bool {
    matches!(e, Error::Input(InputError::GzipTooLarge { .. }))
}

/// A file read whole: `Ok(raw file)` or `Err(text)`.
type Whole = std::result::Result<Raw, String>;

/// The file read whole (capped) and sniffed: gzip decompressed, a raw format by its magic,
/// else UTF-8 text.
/// A text file over the limit (read in pieces when it could be) is refused with what stopped
/// its pieces, by line ([`text_file::why_not_in_pieces`]: a byte that is not UTF-8, a quote in
/// a row…), where there is such a thing, rather than with its size alone.
fn read_whole(path: &Path) -> Result<Whole> {
    let bytes = read_bounded(path, MAX_RECORDING_BYTES).map_err(|e| {
        let e = Error::from(e);
        // (Not `e @ …{ limit_mib, .. }`: the workspace's rust-version, 1.89, refuses a
        // binding inside a pattern whose whole value `e @` moves.)
        let limit_mib = match &e {
            Error::Input(
                InputError::TooLarge { limit_mib, .. } | InputError::GzipTooLarge { limit_mib, .. },
            ) => *limit_mib,
            _ => return e,
        };
        let text = text_file_size(path).is_some();
        text.then(|| text_file::why_not_in_pieces(path, limit_mib))
            .flatten()
            .unwrap_or(e)
    })?;
    whole_of(path, bytes)
}

/// The content of `path` (decompressed) sniffed: a raw format by its magic, else UTF-8 text.
fn whole_of(path: &Path, bytes: Vec<u8>) -> Result<Whole> {
    if let Some(format) = raw::detect(&bytes, path).map_err(|e| e.in_file(path))? {
        return Ok(Ok(header_read(Raw::Held(bytes, format), path)?));
    }
    Ok(Err(text_of(path, bytes)?))
}

/// Standard input read once: held as any file read whole when it ends within
/// [`ReadOptions::stream_from_bytes`] (at most [`MAX_RECORDING_BYTES`]) and its content may be held;
/// else copied to a temporary file ([`spool`]) and read from there as a regular file — a
/// week's recording piped in (`zcat week.csv.gz | wiical fit -`) is streamed as the file
/// itself would be, where holding it would take memory in proportion to it.
fn open_stdin(read: &ReadOptions) -> Result<Opened> {
    let hold = read.stream_from_bytes.min(MAX_RECORDING_BYTES);
    open_input(&mut std::io::stdin().lock(), hold, read.max_spool_bytes)
}

/// [`open_stdin`] of `stdin`, held when it ends within `hold` bytes, else copied (at most
/// `most_copied` bytes; the fuzz target `streamed_reader` drives the copy with it).
#[doc(hidden)]
pub fn open_input(stdin: &mut dyn std::io::Read, hold: u64, most_copied: u64) -> Result<Opened> {
    use std::io::Read;
    let path = Path::new("-");
    let mut bytes = Vec::new();
    let read = (&mut *stdin).take(hold + 1).read_to_end(&mut bytes);
    read.map_err(|source| InputError::Read {
        path: path.into(),
        source,
    })?;
    if bytes.len() as u64 > hold {
        return spool(bytes, stdin, most_copied).map(Opened::Spooled);
    }
    // Gzip'd input whose content passes the limit is spooled (its content streamed) too.
    let gzip = bytes.starts_with(&GZIP_MAGIC);
    let content = decompressed(path, bytes.clone(), MAX_RECORDING_BYTES).map_err(Error::from);
    let content = match content {
        Err(e) if gzip && gzip_too_large(&e) => {
            return spool(bytes, &mut std::io::empty(), most_copied).map(Opened::Spooled)
        }
        other => other?,
    };
    drop(bytes);
    Ok(match whole_of(path, content)? {
        Ok(raw) => Opened::Raw(raw),
        Err(text) => Opened::Text(text),
    })
}

/// The CLI flag that sets [`ReadOptions::max_spool_bytes`], named when the copy passes it.
const MAX_SPOOL_BYTES_FLAG: &str = "--max-spool-bytes";

/// Free space the copy of standard input ([`Opened::Spooled`]) leaves on the temporary
/// directory's disk, bytes: the copy stops before the disk is full, for this command's own
/// output and for everything else on it.
pub const SPOOL_RESERVE_BYTES: u64 = KEEP_FREE_BYTES;

/// `head` and the rest of `input` copied to a temporary file in the temporary directory
/// (`$TMPDIR`, named `wiical-stdin-<pid>-…`), deleted when the returned path is dropped (when
/// the command ends, or the stream reading it is dropped) or by the binary's signal handler;
/// the copies a killed run left there are deleted first ([`temp_files::remove_stale`]).
/// Bounded: text that no recording starts with is refused before a byte is copied
/// ([`check_text_head`]), and the copy stops past `most` bytes
/// ([`ReadOptions::max_spool_bytes`]) or when the disk would keep less than
/// [`SPOOL_RESERVE_BYTES`]. A directory that cannot take the copy is named with what is wrong
/// with it ([`InputError::StdinCopy`]).
fn spool(head: Vec<u8>, input: &mut dyn std::io::Read, most: u64) -> Result<OwnTemp> {
    if !head.starts_with(&GZIP_MAGIC) && !is_raw(&head) {
        check_text_head(Path::new("-"), &head)?;
    }
    let dir = std::env::temp_dir();
    temp_files::remove_stale(&dir);
    let (copy, mut file) = OwnTemp::stdin_copy_in(&dir).map_err(|e| stdin_copy_error(&dir, &e))?;
    let bound = SpoolBound {
        dir,
        most,
        reserve: SPOOL_RESERVE_BYTES,
    };
    bound.check(&file, head.len() as u64)?;
    match copy_bounded(&head, input, &mut file, &bound) {
        Ok(()) => Ok(copy),
        Err(SpoolFailure::Bound(e)) => Err(e),
        Err(SpoolFailure::Io(source)) => Err(InputError::StdinCopy {
            dir: bound.dir,
            from_tmpdir: std::env::var_os("TMPDIR").is_some(),
            why: format!("writing the copy failed: {}", io_reason(&source)),
        }
        .into()),
    }
}

/// [`InputError::StdinCopy`] for a temporary directory `dir` where the copy could not be
/// created (`e`): what is wrong with the directory, in words.
fn stdin_copy_error(dir: &Path, e: &std::io::Error) -> Error {
    use std::io::ErrorKind as K;
    let why = match std::fs::metadata(dir) {
        Err(m) if m.kind() == K::NotFound => "that directory does not exist".to_string(),
        Ok(m) if !m.is_dir() => "it is not a directory".to_string(),
        _ => match e.kind() {
            K::PermissionDenied => "that directory is not writable (permission denied)".into(),
            K::ReadOnlyFilesystem => "that directory is on a read-only file system".into(),
            _ => format!("the copy cannot be created there: {}", io_reason(e)),
        },
    };
    InputError::StdinCopy {
        dir: dir.to_path_buf(),
        from_tmpdir: std::env::var_os("TMPDIR").is_some(),
        why,
    }
    .into()
}

/// An I/O error's reason without the path `tempfile` adds to it (the sentence names the
/// directory already).
fn io_reason(e: &std::io::Error) -> String {
    let inner = e
        .get_ref()
        .and_then(|i| i.source())
        .and_then(|s| s.downcast_ref::<std::io::Error>());
    match inner.or_else(|| e.raw_os_error().map(|_| e)) {
        Some(io) => io.to_string(),
        None => e.kind().to_string(),
    }
}

/// Why [`copy_bounded`] stopped.
enum SpoolFailure {
    /// A bound of [`SpoolBound`].
    Bound(Error),
    /// Reading standard input or writing the copy failed.
    Io(std::io::Error),
}

/// The bounds of a spool: the most bytes copied, and the free space kept on `dir`'s disk.
struct SpoolBound {
    dir: std::path::PathBuf,
    most: u64,
    reserve: u64,
}

impl SpoolBound {
    /// Refuses a copy that has written `copied` bytes to `file`.
    fn check(&self, file: &std::fs::File, copied: u64) -> Result<()> {
        let size = |b: u64| match b {
            b if b >= 1 << 30 => format!("{:.1} GiB", b as f64 / f64::from(1u32 << 30)),
            b if b >= 1 << 20 => format!("{:.1} MiB", b as f64 / f64::from(1u32 << 20)),
            b => format!("{b} bytes"),
        };
        let why = if copied > self.most {
            format!(
                "it passed {}, the most copied ({MAX_SPOOL_BYTES_FLAG} sets it)",
                size(self.most)
            )
        } else {
            match free_bytes(file) {
                Some(free) if free < self.reserve => format!(
                    "its disk had {} free after {}, and the copy leaves {} free (TMPDIR \
                     chooses the directory)",
                    size(free),
                    size(copied),
                    size(self.reserve)
                ),
                _ => return Ok(()),
            }
        };
        Err(InputError::SpoolBound {
            path: "-".into(),
            dir: self.dir.clone(),
            why,
        }
        .into())
    }
}

/// `head`, then the rest of `input`, written to `file` in 8 MiB reads, `bound` checked after
/// each (a `statvfs` per 8 MiB costs nothing beside the copy).
fn copy_bounded(
    head: &[u8],
    input: &mut dyn std::io::Read,
    file: &mut std::fs::File,
    bound: &SpoolBound,
) -> std::result::Result<(), SpoolFailure> {
    use std::io::Write;
    file.write_all(head).map_err(SpoolFailure::Io)?;
    let mut buf = vec![0u8; 8 << 20];
    let mut copied = head.len() as u64;
    loop {
        let n = read_full(&mut &mut *input, &mut buf).map_err(SpoolFailure::Io)?;
        if n == 0 {
            return file.flush().map_err(SpoolFailure::Io);
        }
        file.write_all(&buf[..n]).map_err(SpoolFailure::Io)?;
        copied += n as u64;
        bound.check(file, copied).map_err(SpoolFailure::Bound)?;
    }
}

/// True when `path` is a regular text file (plain, or gzip'd) of at least `min_bytes`
/// ([`text_file_size`]).
pub(crate) fn is_text_file_from(path: &Path, min_bytes: u64) -> bool {
    text_file_size(path).is_some_and(|n| n >= min_bytes)
}

/// The size of a regular file's text, bytes, when the file is not raw: a plain file's
/// length; for a gzip file whose content is not raw, the larger of its length and the
/// content's size its trailer gives (ISIZE, RFC 1952: the last member's size modulo 2³²).
/// That is a hint only (a file of several members, or of 4 GiB or more, may say less, and is
/// then read in pieces, not streamed). `None` for standard input, anything not a regular
/// file, raw files.
fn text_file_size(path: &Path) -> Option<u64> {
    use std::io::{Read, Seek, SeekFrom};
    let meta = std::fs::metadata(path).ok()?;
    if path.as_os_str() == "-" || !meta.is_file() {
        return None;
    }
    let mut file = std::fs::File::open(path).ok()?;
    let mut head = [0u8; 64];
    let n = file.read(&mut head).ok()?;
    if !head[..n].starts_with(&GZIP_MAGIC) {
        return is_raw(&head[..n]).not().then_some(meta.len());
    }
    // The content's first bytes, for its magic (a `.cwa.gz` is read whole, as before).
    file.seek(SeekFrom::Start(0)).ok()?;
    let mut content = [0u8; 64];
    let mut gz = flate2::read::MultiGzDecoder::new(std::io::BufReader::new(&file)).take(64);
    let mut got = 0;
    while let Ok(k @ 1..) = gz.read(&mut content[got..]) {
        got += k;
    }
    if is_raw(&content[..got]) {
        return None;
    }
    let mut trailer = [0u8; 4];
    file.seek(SeekFrom::End(-4)).ok()?;
    file.read_exact(&mut trailer).ok()?;
    Some(meta.len().max(u64::from(u32::from_le_bytes(trailer))))
}

/// True when `head` starts as a raw format does.
fn is_raw(head: &[u8]) -> bool {
    !raw::detect(head, Path::new("")).is_ok_and(|f| f.is_none())
}

/// The first two bytes of a gzip member (RFC 1952).
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// `raw` once its header is read (a header's error is told where the file is opened, as the
/// text's are); its blocks are read by whoever loads it.
fn header_read(raw: Raw, path: &Path) -> Result<Raw> {
    raw.blocks().open().map_err(|e| e.in_file(path))?;
    Ok(raw)
}

/// The file whole, for readers that need every sample: `Ok(raw file)` (a [`Opened::RawFile`]
/// its header read, its blocks read block by block by whoever loads it) or `Err(text)`.
pub fn open_whole(path: &Path, read: &ReadOptions) -> Result<Whole> {
    whole_from(open(path, read)?, path, read)
}

/// [`open_whole`] of a file opened already.
fn whole_from(opened: Opened, path: &Path, read: &ReadOptions) -> Result<Whole> {
    Ok(match opened {
        Opened::RawFile(format) => Ok(header_read(Raw::File(path.into(), format), path)?),
        Opened::Raw(raw) => Ok(raw),
        Opened::Text(text) => Err(text),
        Opened::TextFile => read_whole(path)?,
        Opened::Spooled(tmp) => open_whole(&tmp, read).map_err(|e| e.renaming(&tmp, path))?,
    })
}

/// Loads a recording from a file: every sample, with its time and temperature. Text is read
/// by [`crate::input::text`] (its module docs list the accepted shapes); raw accelerometer
/// files (Axivity `.cwa`, GENEActiv `.bin`, recognised by their first bytes) by
/// [`crate::input::raw`]. `path` may be `-` for standard input; only regular files are read:
/// a raw file block by block and a large plain text file in pieces, with no size cap; anything
/// else whole, at most [`MAX_RECORDING_BYTES`].
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Recording> {
    load_within(path, opts, None)
}

pub use crate::input::bounded::{HoldLimit, MAX_HELD_SAMPLES};

/// [`load`] for a command that holds the whole recording: refused (naming the file, the
/// bound and `limit.instead`) as soon as more than `limit.samples` samples are read.
pub fn load_held(path: &Path, opts: &LoadOptions, limit: HoldLimit) -> Result<Recording> {
    load_within(path, opts, Some(limit))
}

/// [`load`] within `limit` (`None`: no bound): [`load_samples`] that streams no file.
pub fn load_within(path: &Path, opts: &LoadOptions, limit: Option<HoldLimit>) -> Result<Recording> {
    match samples_from(path, opts, u64::MAX, limit)? {
        Input::Samples(rec) => Ok(rec),
        // Neither is read here (no file is streamed from u64::MAX bytes, nor a table for
        // samples); their recording is what they hold.
        other => Ok(other.recording().clone()),
    }
}

/// A plain text file's recording read in pieces (`head_ok` asked about its first
/// piece), `None` when the file is to be read whole; refused beyond `limit`.
fn pieces(
    path: &Path,
    opts: &LoadOptions,
    head_ok: impl Fn(&str) -> bool,
    limit: Option<HoldLimit>,
) -> Result<Option<Recording>> {
    text_file::load_pieces_within(path, opts, head_ok, limit).map_err(|e| e.in_file(path))
}

/// [`pieces`] when `path` is a regular text file, else `None`.
fn load_in_pieces(
    path: &Path,
    opts: &LoadOptions,
    limit: Option<HoldLimit>,
) -> Result<Option<Recording>> {
    if text_file_size(path).is_none() {
        return Ok(None);
    }
    pieces(path, opts, |_| true, limit)
}

/// An accelerometer and a gyroscope from one file, read once (`wiical gyrofit FILE`, so each
/// note on the file is made once): the accelerometer's triplet by `acc`, the gyroscope's by
/// `gyro_columns` when given, else by the header's names — a gyroscope triplet must be named
/// (`gx,gy,gz`, `gyro_x_dps`, …): the loader's fallback to another sensor's triplet would
/// take gravity for rotation.
pub fn load_imu(
    path: &Path,
    acc: &LoadOptions,
    gyro_columns: Option<[String; 3]>,
) -> Result<(Recording, Recording)> {
    load_imu_within(path, acc, gyro_columns, None)
}

/// [`load_imu`] refused beyond `limit` samples ([`load_held`]).
pub fn load_imu_within(
    path: &Path,
    acc: &LoadOptions,
    gyro_columns: Option<[String; 3]>,
    limit: Option<HoldLimit>,
) -> Result<(Recording, Recording)> {
    // Standard input once, and when it was spooled, the file it was spooled to (in pieces).
    let stdin = match (path.as_os_str() == "-")
        .then(|| open(path, &acc.read))
        .transpose()?
    {
        Some(Opened::Spooled(tmp)) => {
            return load_imu_within(&tmp, acc, gyro_columns, limit)
                .map_err(|e| e.renaming(&tmp, path))
        }
        other => other,
    };
    let named = gyro_columns.is_none();
    let gyro_opts = LoadOptions {
        columns: gyro_columns,
        sensor: Some(Sensor::Gyroscope),
        read: acc.read,
    };
    if let Some(accel) = load_in_pieces(path, acc, limit)? {
        if let Some(gyro) = load_in_pieces(path, &gyro_opts, limit)? {
            return check_gyro_named(named, accel, gyro, path);
        }
    }
    let whole = match stdin {
        Some(opened) => whole_from(opened, path, &acc.read)?,
        None => open_whole(path, &acc.read)?,
    };
    let text = match whole {
        Ok(raw) => {
            // An AX6 file: its gyro is `gx,gy,gz` (crate::input::raw); the other formats have
            // none.
            let gyro_opts = LoadOptions {
                columns: Some(
                    gyro_opts
                        .columns
                        .unwrap_or_else(|| ["gx".into(), "gy".into(), "gz".into()]),
                ),
                ..gyro_opts
            };
            let accel = raw::load::load_raw(raw.blocks(), acc).map_err(|e| e.in_file(path))?;
            if let Some(l) = limit {
                l.check(accel.len())
                    .map_err(|e| Error::from(e).in_file(path))?;
            }
            let gyro =
                raw::load::load_raw(raw.blocks(), &gyro_opts).map_err(|e| e.in_file(path))?;
            return Ok((accel, gyro));
        }
        Err(text) => text,
    };
    let accel = parse(&text, acc).map_err(|e| e.in_file(path))?;
    if let Some(l) = limit {
        // Read whole (at most 256 MiB): checked once read, as `load_held` does.
        l.check(accel.len())
            .map_err(|e| Error::from(e).in_file(path))?;
    }
    let gyro = parse(&text, &gyro_opts).map_err(|e| e.in_file(path))?;
    check_gyro_named(named, accel, gyro, path)
}

/// The pair, unless the gyroscope's triplet was the loader's fallback (`named`: none was
/// asked for) and its columns are not named as a gyroscope's.
fn check_gyro_named(
    named: bool,
    accel: Recording,
    gyro: Recording,
    path: &Path,
) -> Result<(Recording, Recording)> {
    if named && !crate::input::columns::all_named(&gyro.axis_columns, Sensor::Gyroscope) {
        return Err(Error::from(GyroError::NoGyroColumns {
            taken: gyro.axis_columns.join(","),
        })
        .in_file(path));
    }
    Ok((accel, gyro))
}

/// What a file holds: samples for the detector, or a window-mean table.
#[derive(Debug, Clone)]
pub enum Input {
    /// An ordinary recording.
    Samples(Recording),
    /// Rows that are windows already.
    Table(WindowTable),
    /// A plain text file of at least [`STREAM_FROM_BYTES`], its samples read in passes from
    /// the file, never held ([`TextSource`]): `fit` and `analyze` in bounded memory.
    Stream(Arc<TextSource>),
}

impl Input {
    /// The recording as read (for a streamed file: its metadata, without samples).
    pub fn recording(&self) -> &Recording {
        match self {
            Input::Samples(rec) => rec,
            Input::Table(t) => &t.recording,
            Input::Stream(src) => &src.meta,
        }
    }

    /// Samples (or rows of a table) read.
    pub fn len(&self) -> usize {
        match self {
            Input::Stream(src) => src.len(),
            other => other.recording().len(),
        }
    }

    /// True when nothing was read.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Reads `path` once (standard input can be read only once) as a window-mean table when its
/// header says so or `opts.force`, else as an ordinary recording ([`load`]).
///
/// A raw accelerometer file (Axivity `.cwa`, GENEActiv `.bin`) becomes the table of its still
/// 10-s epochs ([`crate::input::raw::epochs`]: GGIR's free-living autocalibration input); too
/// few of them is an error saying how many were found and needed. A regular raw file is
/// read block by block: memory is the still epochs, not the file (no size cap).
/// Plain text files of at least [`ReadOptions::stream_from_bytes`] (of `opts.load.read`) are
/// streamed ([`Input::Stream`]; a file the stream declines — not plain text, a pose column —
/// is read as a smaller one is).
pub fn load_input(path: &Path, opts: &WindowInputOptions) -> Result<Input> {
    let stream_from = opts.load.read.stream_from_bytes;
    load_input_in(path, opts, stream_from, text_file::PIECE_BYTES)
}

/// [`load_input`], streaming plain text files of at least `stream_from` bytes in pieces of
/// `piece_bytes` (tests: many pieces, and pieces in flight, from a small file).
pub fn load_input_in(
    path: &Path,
    opts: &WindowInputOptions,
    stream_from: u64,
    piece_bytes: usize,
) -> Result<Input> {
    let how = How {
        load: &opts.load,
        want: Want::Windows(opts),
        stream_from,
        piece_bytes,
    };
    read_input(path, &how)
}

/// [`load_input`] for a reader of samples only (`wiical correct`): a plain text file of at
/// least [`ReadOptions::stream_from_bytes`] (of `opts.read`; or standard input spooled to a
/// temporary file, which lives as long as the stream) streamed ([`Input::Stream`]), else every sample held
/// ([`Input::Samples`], as [`load`] reads them, refused beyond `limit`) — a raw file's
/// samples, not its still epochs, and never a window-mean table.
pub fn load_samples(path: &Path, opts: &LoadOptions, limit: Option<HoldLimit>) -> Result<Input> {
    samples_from(path, opts, opts.read.stream_from_bytes, limit)
}

/// [`load_samples`], streaming plain text files of at least `stream_from` bytes.
fn samples_from(
    path: &Path,
    opts: &LoadOptions,
    stream_from: u64,
    limit: Option<HoldLimit>,
) -> Result<Input> {
    let how = How {
        load: opts,
        want: Want::Samples(limit),
        stream_from,
        piece_bytes: text_file::PIECE_BYTES,
    };
    read_input(path, &how)
}

/// What a file read by [`read_input`] becomes when it is held.
#[derive(Clone, Copy)]
enum Want<'a> {
    /// A window-mean table when its header says so (or `force`), a raw file's still epochs,
    /// else samples ([`load_input`]).
    Windows(&'a WindowInputOptions),
    /// Samples only, refused beyond the limit ([`load_samples`]).
    Samples(Option<HoldLimit>),
}

/// How [`read_input`] reads a file.
struct How<'a> {
    load: &'a LoadOptions,
    want: Want<'a>,
    /// Plain text files of at least this many bytes are streamed.
    stream_from: u64,
    /// A streamed file's piece size.
    piece_bytes: usize,
}

/// The one reading of [`load_input`] and [`load_samples`]: streamed when `path` is a plain
/// text file of at least `how.stream_from` bytes that the stream takes, else opened once
/// ([`open`]) and held as `how.want` says. Errors name the file.
fn read_input(path: &Path, how: &How<'_>) -> Result<Input> {
    let samples = |head: &str| match how.want {
        // A window-mean table is small: only samples are read in pieces.
        Want::Windows(o) => !o.force && matches!(parse_window_table(head, o), Ok(None)),
        Want::Samples(_) => true,
    };
    let limit = match how.want {
        Want::Samples(limit) => limit,
        Want::Windows(_) => None,
    };
    if is_text_file_from(path, how.stream_from) {
        let src = TextSource::open_in(path, how.load, how.piece_bytes, samples);
        if let Some(src) = src.map_err(|e| e.in_file(path))? {
            return Ok(Input::Stream(Arc::new(src)));
        }
    }
    let whole = match open(path, &how.load.read)? {
        Opened::RawFile(format) => {
            let blocks = raw::load::Blocks::File(path, format);
            return raw_input(blocks, how).map_err(|e| e.in_file(path));
        }
        Opened::TextFile => match pieces(path, how.load, samples, limit)? {
            Some(rec) => return Ok(Input::Samples(rec)),
            None => read_whole(path)?,
        },
        Opened::Spooled(tmp) => return spooled_input(tmp, path, how),
        Opened::Raw(raw) => Ok(raw),
        Opened::Text(text) => Err(text),
    };
    let parsed = match (whole, how.want) {
        (Ok(raw), _) => raw_input(raw.blocks(), how),
        (Err(text), Want::Windows(o)) => match parse_window_table(&text, o) {
            Ok(Some(table)) => Ok(Input::Table(table)),
            Ok(None) => parse(&text, how.load).map(Input::Samples),
            Err(e) => Err(e),
        },
        // Read whole (at most 256 MiB): checked at the end, so that every reader refuses alike.
        (Err(text), Want::Samples(limit)) => parse(&text, how.load)
            .and_then(|rec| within(rec, limit))
            .map(Input::Samples),
    };
    parsed.map_err(|e| e.in_file(path))
}

/// A raw file's input: its still epochs' table ([`Want::Windows`]), or its samples.
fn raw_input(blocks: raw::load::Blocks<'_>, how: &How<'_>) -> Result<Input> {
    match how.want {
        Want::Windows(_) => {
            raw::load::raw_epoch_table(blocks, how.load, &Default::default()).map(Input::Table)
        }
        Want::Samples(limit) => {
            raw::load::load_raw_within(blocks, how.load, limit).map(Input::Samples)
        }
    }
}

/// `rec` unless it holds more samples than `limit`.
fn within(rec: Recording, limit: Option<HoldLimit>) -> Result<Recording> {
    match limit {
        Some(l) => l.check(rec.len()).map(|()| rec).map_err(Into::into),
        None => Ok(rec),
    }
}

/// Standard input copied to `tmp`, read as a regular file: errors name `-`, the input the user
/// gave, and the temporary file lives as long as the stream reading it.
fn spooled_input(tmp: OwnTemp, path: &Path, how: &How<'_>) -> Result<Input> {
    Ok(
        match read_input(&tmp, how).map_err(|e| e.renaming(&tmp, path))? {
            Input::Stream(mut src) => {
                if let Some(s) = Arc::get_mut(&mut src) {
                    s.keep(tmp, path);
                }
                Input::Stream(src)
            }
            held => held,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The copy stops with a sentence at either bound: the most bytes, and the free space
    /// kept (a reserve larger than any disk stands for a full one); under both, it goes on.
    #[test]
    fn a_spool_stops_at_its_bounds_with_a_sentence() {
        let file = tempfile::tempfile().unwrap();
        let bound = |most, reserve| SpoolBound {
            dir: "/tmp".into(),
            most,
            reserve,
        };
        assert!(bound(1000, 0).check(&file, 1000).is_ok());
        let capped = bound(1000, 0).check(&file, 1001).unwrap_err().to_string();
        assert!(capped.contains("passed 1000 bytes"), "{capped}");
        assert!(capped.contains("--max-spool-bytes"), "{capped}");
        let full = bound(u64::MAX, u64::MAX).check(&file, 3 << 20).unwrap_err();
        let full = full.to_string();
        assert!(
            full.contains("free after 3.0 MiB") && full.contains("TMPDIR"),
            "{full}"
        );
        assert!(full.starts_with("- (standard input)"), "{full}");
    }
}
