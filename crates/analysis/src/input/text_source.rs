//! A large plain text file as a re-readable source of samples, never held as a recording:
//! memory is one piece of text and its parsed rows, and the rows kept for the later passes.
//!
//! [`TextSource::open`] is the one pass over the text: the file read in pieces by the loop
//! that reads a held file in pieces (`text_file::parse_pieces`: the same
//! pieces, the same row parser, the time check joined across pieces, the same sentences with
//! line and column, the same files handed back to be read whole), each piece's rows folded
//! into a [`SampleSummary`] and a [`StepTally`] and kept (`input::text_spill`: in memory while
//! they fit, else in a temporary file). Every later pass ([`TextSource::rows`],
//! `TextSource::each_piece`, …) reads the kept rows back: the values the text gave, bit
//! for bit; the text is never parsed again. A pass is an iterator whose clone goes on from
//! the same row (the core's detector takes an `Iterator + Clone` and passes over it several
//! times).
//!
//! A file whose size, modification time or sampled content differ after the first pass from
//! before it is refused (its summary may mix two versions); a change after it changes
//! nothing (the passes read the rows it kept). When the rows cannot be kept — they are bound
//! for the temporary directory and it does not exist, is not writable or its disk is full —
//! the file is refused with one sentence naming it and the directory, saying to set
//! `TMPDIR` or free space ([`InputError::RowsNotKept`]); a kept file that cannot be read back
//! ends the pass with the same sentence, which [`TextSource::check`] gives. The pass parses
//! each piece while the one before is folded and written, on threads of their own.

use crate::error::input::InputError;
use crate::error::{Error, Result};
use crate::input::bounded::check_largest_reading;
use crate::input::columns::LoadOptions;
use crate::input::read_options::SpillMode;
use crate::input::recording::Recording;
use crate::input::sample_summary::{SampleSummary, SummaryFold};
use crate::input::text_csv::check_axis_columns;
use crate::input::text_file::{parse_pieces, read_head, row_error, Head, Pieces, PIECE_BYTES};
pub(crate) use crate::input::text_rows::Columns;
pub(crate) use crate::input::text_spill::Want;
use crate::input::text_spill::{Spill, SpillWriter, MEMORY_SPILL_BYTES};
use crate::input::timecheck::{time_notes_given, StepTally, TimeSteps};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// One sample as a pass reads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// The time column's value, s (`None` without one).
    pub t: Option<f64>,
    /// x, y, z as read.
    pub xyz: [f64; 3],
    /// The temperature column's value, °C (`None` without one).
    pub temp: Option<f64>,
}

/// What identifies the file's content across the first pass, cheaply: its size, its
/// modification time, and a checksum of [`SAMPLED_PIECES`] pieces of [`SAMPLED_PIECE_BYTES`]
/// spread over it (the first and the last among them). The size and time catch a file still
/// being written; the checksum a rewrite in place that keeps the size within the time's
/// resolution, or puts the time back. A change between the sampled pieces with the time put
/// back passes: the identity is a check on accidents (a logger still writing, a file
/// replaced), not a proof.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stamp {
    len: u64,
    modified: Option<std::time::SystemTime>,
    sampled: u64,
}

/// Pieces of the file read for [`Stamp`]'s checksum (before and after the first pass, a few
/// dozen kilobytes from the page cache against the pass's whole file).
const SAMPLED_PIECES: u64 = 16;

/// Bytes of each piece read for [`Stamp`]'s checksum.
const SAMPLED_PIECE_BYTES: u64 = 4096;

fn stamp_of(path: &Path) -> Option<Stamp> {
    use std::hash::Hasher;
    use std::io::{Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let m = file.metadata().ok()?;
    let len = m.len();
    // A fixed-key hasher: the same bytes give the same checksum at every check.
    let mut hash = std::hash::DefaultHasher::new();
    let mut buf = vec![0u8; SAMPLED_PIECE_BYTES as usize];
    let last = len.saturating_sub(SAMPLED_PIECE_BYTES);
    for k in 0..SAMPLED_PIECES {
        // Evenly spaced from the first byte to the last piece's start (no overflow in u128).
        let at = u128::from(last) * u128::from(k) / u128::from(SAMPLED_PIECES - 1);
        let at = u64::try_from(at).unwrap_or(last);
        file.seek(SeekFrom::Start(at)).ok()?;
        let n = crate::input::bounded::read_full(&mut file, &mut buf).ok()?;
        hash.write(&buf[..n]);
    }
    Some(Stamp {
        len,
        modified: m.modified().ok(),
        sampled: hash.finish(),
    })
}

/// A large plain text file read once for its summary and its rows, which every later pass
/// reads back.
#[derive(Debug)]
pub struct TextSource {
    path: PathBuf,
    has_time: bool,
    has_temp: bool,
    /// The recording without its samples: rate, axis columns, notes, the loader's choices,
    /// skipped rows (`t`, `temp` and `labels` are `None`, `xyz` empty).
    pub meta: Recording,
    /// The first pass's summary of the samples.
    pub summary: SampleSummary,
    /// The time column's steps (`None` without a time column or a usable step).
    pub steps: Option<TimeSteps>,
    /// The first failure of a later pass.
    failed: Mutex<Option<Error>>,
    /// The temporary file standard input was copied to, when this reads one (deleted when
    /// this is dropped).
    spool: Option<crate::input::temp_files::OwnTemp>,
    /// The name the user gave the file, when it is not `path` (`-`: standard input).
    shown: Option<PathBuf>,
    /// The rows of the first pass, which the later passes read.
    spill: Spill,
    /// Where they were kept (named when they cannot be read back).
    spill_to: SpillTo,
}

/// Where the first pass keeps its rows ([`crate::input::text_spill`]).
#[derive(Debug, Clone)]
pub(crate) struct SpillTo {
    /// The temporary directory (`None`: the system's, `$TMPDIR`).
    pub dir: Option<PathBuf>,
    /// Most bytes written (past it a write fails, as on a full disk).
    pub limit: u64,
    /// Most bytes kept in memory (past them, or when the file's size says they will pass
    /// them, the rows go to the temporary directory).
    pub memory: u64,
}

impl SpillTo {
    /// In memory up to [`MEMORY_SPILL_BYTES`], else the system's temporary directory; none
    /// in memory with [`SpillMode::Disk`].
    fn of(spill: SpillMode) -> Self {
        Self {
            dir: None,
            limit: u64::MAX,
            memory: match spill {
                SpillMode::Auto => MEMORY_SPILL_BYTES,
                SpillMode::Disk => 0,
            },
        }
    }

    /// [`InputError::RowsNotKept`]: `doing` (writing the rows, reading them back) failed with `e`.
    fn error(&self, doing: &str, e: &std::io::Error) -> Error {
        InputError::RowsNotKept {
            dir: self.dir.clone().unwrap_or_else(std::env::temp_dir),
            from_tmpdir: self.dir.is_none() && std::env::var_os("TMPDIR").is_some(),
            why: format!("{doing} failed ({e})"),
        }
        .into()
    }
}

/// True when `path` is a regular file (not standard input) of at least `min_bytes`.
pub fn large(path: &Path, min_bytes: u64) -> bool {
    path.as_os_str() != "-"
        && std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() >= min_bytes)
}

impl TextSource {
    /// The first pass over the regular text file `path` (see the module docs); `head_ok` is
    /// asked about the first piece's text as by [`crate::input::text_file::load_pieces_within`].
    /// `Ok(None)`: the file is to be read whole (not plain text, a pose-label column, …).
    /// Errors carry no file name (the caller adds it).
    pub fn open(
        path: &Path,
        opts: &LoadOptions,
        head_ok: impl Fn(&str) -> bool,
    ) -> Result<Option<Self>> {
        Self::open_in(path, opts, PIECE_BYTES, head_ok)
    }

    /// [`TextSource::open`] of `path` when it is a regular file (not standard input) of at
    /// least `min_bytes` (what a command reads in passes, `--stream-from-bytes`), every head
    /// taken, errors naming the file; `Ok(None)`: it is to be read whole.
    pub fn open_from(path: &Path, opts: &LoadOptions, min_bytes: u64) -> Result<Option<Self>> {
        if !large(path, min_bytes) {
            return Ok(None);
        }
        Self::open(path, opts, |_| true).map_err(|e| e.in_file(path))
    }

    /// [`TextSource::open`] with pieces of `piece_bytes`.
    pub(crate) fn open_in(
        path: &Path,
        opts: &LoadOptions,
        piece_bytes: usize,
        head_ok: impl Fn(&str) -> bool,
    ) -> Result<Option<Self>> {
        let spill_to = SpillTo::of(opts.read.spill);
        Self::open_with(path, opts, piece_bytes, &spill_to, head_ok)
    }

    /// [`TextSource::open_in`] keeping the first pass's rows as `spill_to` says.
    pub(crate) fn open_with(
        path: &Path,
        opts: &LoadOptions,
        piece_bytes: usize,
        spill_to: &SpillTo,
        head_ok: impl Fn(&str) -> bool,
    ) -> Result<Option<Self>> {
        let Some(stamp) = stamp_of(path) else {
            return Ok(None);
        };
        let Ok(mut pieces) = Pieces::open(path, piece_bytes) else {
            return Ok(None);
        };
        let head = match read_head(&mut pieces, opts, head_ok) {
            // A pose table: read in memory (six-position files are short).
            Ok(Some(h)) if h.layout.label.is_some() => return Ok(None),
            Ok(Some(h)) => h,
            Ok(None) => return Ok(None),
            Err(e) => return row_error(&mut pieces, e),
        };
        let (fold, tally, spill) = match first_pass(&mut pieces, (&head, path), spill_to, stamp.len)
        {
            Ok(Some(x)) => x,
            Ok(None) => return Ok(None),
            // A row that does not parse in a file that changed meanwhile is the change's.
            Err(_) if stamp_of(path) != Some(stamp) => {
                return Err(InputError::ChangedWhileRead.into())
            }
            Err(Pass::Rows(e)) => return row_error(&mut pieces, e),
            Err(Pass::Kept(e)) => return Err(e),
        };
        let summary = fold.finish();
        if summary.count == 0 {
            return Err(InputError::HeaderOnly.into());
        }
        if stamp_of(path) != Some(stamp) {
            // Changed during the first pass: its summary may mix two versions.
            return Err(InputError::ChangedWhileRead.into());
        }
        let Head { st, layout, .. } = head;
        let mut meta = st.into_meta();
        meta.skipped_empty_rows = tally.1;
        let mut src = Self {
            path: path.to_path_buf(),
            has_time: layout.time.is_some(),
            has_temp: layout.temp.is_some(),
            meta,
            summary,
            steps: None,
            failed: Mutex::new(None),
            spool: None,
            shown: None,
            spill,
            spill_to: spill_to.clone(),
        };
        if let Some(i) = layout.time {
            let steps = (tally.0)
                .finish()
                .unwrap_or_else(|| TimeSteps::of_times(|| src.times()));
            let notes = time_notes_given(&layout.names[i], steps, || src.times());
            src.check()?;
            src.steps = steps;
            src.meta.notes = notes;
        }
        check_axis_columns(&src.meta)?;
        check_largest_reading(true, src.summary.largest)?;
        Ok(Some(src))
    }

    /// Keeps `file` (the temporary file this reads, a copy of `shown`) until this is dropped.
    pub(crate) fn keep(&mut self, file: crate::input::temp_files::OwnTemp, shown: &Path) {
        self.spool = Some(file);
        self.shown = Some(shown.to_path_buf());
    }

    /// Whether the first pass's rows are kept in memory (else in a temporary file).
    pub fn is_spill_in_memory(&self) -> bool {
        self.spill.in_memory()
    }

    /// Empties the spill's file: a spill that can no longer be read back.
    #[cfg(test)]
    pub(crate) fn truncate_spill(&self) {
        self.spill.truncate();
    }

    /// Whether the file has a time column.
    pub fn has_time(&self) -> bool {
        self.has_time
    }

    /// Whether the file has a temperature column.
    pub fn has_temp(&self) -> bool {
        self.has_temp
    }

    /// Samples in the file.
    pub fn len(&self) -> usize {
        self.summary.count
    }

    /// True without samples (never, once opened: a header alone is an error).
    pub fn is_empty(&self) -> bool {
        self.summary.count == 0
    }

    /// The sample rate as [`Recording::estimated_rate_hz`] gives it: the metadata's, else
    /// the time column's.
    pub fn estimated_rate_hz(&self) -> Option<f64> {
        self.meta
            .sample_rate_hz
            .or_else(|| self.steps.map(|s| s.rate_hz()))
    }

    /// A pass over every sample, from the kept rows; it ends early when they cannot be read
    /// back: [`TextSource::check`] after the pass says so.
    pub fn rows(&self) -> Rows<'_> {
        Rows {
            src: self,
            next: 0,
            cols: Columns::default(),
            at: 0,
            skip: 0,
            scratch: Vec::new(),
            done: false,
        }
    }

    /// A pass over every sample a block of the kept rows (a piece's) at a time, with the
    /// columns `want` asks for (and the axes): `f` may stop it by returning `false`. As
    /// [`TextSource::rows`], it ends early when the rows cannot be read back:
    /// [`TextSource::check`] after it says so.
    pub(crate) fn each_piece(&self, want: Want, mut f: impl FnMut(&Columns) -> bool) {
        let (mut cols, mut scratch) = (Columns::default(), Vec::new());
        for (from, to) in self.spill.block_rows() {
            if let Err(e) = (self.spill).read_rows(from, to, want, &mut cols, &mut scratch) {
                return self.fail(self.spill_to.error("reading them back", &e));
            }
            if !f(&cols) {
                return;
            }
        }
    }

    /// A pass over every sample's axes as `f32` (`v as f32`: the detector's view of values on
    /// no lattice), a block at a time (read straight to `f32`, or as they lie in memory), as
    /// [`TextSource::each_piece`].
    pub(crate) fn each_piece_f32(&self, mut f: impl FnMut(&[[f32; 3]]) -> bool) {
        let (mut view, mut scratch) = (Vec::new(), Vec::new());
        for (k, (from, to)) in self.spill.block_rows().enumerate() {
            let axes = match self.spill.axes_f32(k) {
                Some(axes) => axes,
                None => match self.spill.read_f32(from, to, &mut view, &mut scratch) {
                    Ok(()) => &view,
                    Err(e) => return self.fail(self.spill_to.error("reading them back", &e)),
                },
            };
            if !f(axes) {
                return;
            }
        }
    }

    /// Every sample's axes as `f32` in place, a block of the spill after another, when the
    /// spill is in memory and every block's axes are `f32` ([`Spill::axes_f32`]): a pass over
    /// them with no copy, in pieces any core may read at once. `None` otherwise (a pass then
    /// goes by [`TextSource::each_piece_f32`]).
    pub(crate) fn axes_f32_in_place(&self) -> Option<Vec<&[[f32; 3]]>> {
        let blocks = self.spill.block_rows().count();
        let axes: Option<Vec<_>> = (0..blocks).map(|k| self.spill.axes_f32(k)).collect();
        axes.filter(|a| a.iter().map(|b| b.len()).sum::<usize>() == self.summary.count)
    }

    /// Rows `from..to` of the spill into `cols` (with `scratch` for the bytes read); `false`
    /// (nothing read) when they are past its end or could not be read back (which
    /// [`TextSource::check`] then says).
    pub(crate) fn read_spilled(
        &self,
        (from, to): (usize, usize),
        cols: &mut Columns,
        scratch: &mut Vec<u8>,
    ) -> bool {
        if to > self.spill.len() {
            return false;
        }
        match self.spill.read_rows(from, to, Want::ALL, cols, scratch) {
            Ok(()) => true,
            Err(e) => {
                self.fail(self.spill_to.error("reading them back", &e));
                false
            }
        }
    }

    /// The time column, from the kept rows.
    pub fn times(&self) -> impl Iterator<Item = f64> + '_ {
        self.rows().filter_map(|r| r.t)
    }

    /// The first failure of a pass since the file was opened (`Ok` when every pass read every
    /// row the first pass kept), the file named as the user gave it (`-` for standard input
    /// copied to a temporary file).
    pub fn check(&self) -> Result<()> {
        match self.failed.lock().map(|mut f| f.take()) {
            Ok(Some(e)) => Err(e.in_file(self.shown.as_deref().unwrap_or(&self.path))),
            _ => Ok(()),
        }
    }

    /// Keeps `e` as the first failure.
    fn fail(&self, e: Error) {
        if let Ok(mut f) = self.failed.lock() {
            f.get_or_insert(e);
        }
    }
}

/// Why the first pass failed: a row's error (the file may still be handed back to be read
/// whole, when a later piece is not plain text), or the rows could not be kept.
enum Pass {
    Rows(Error),
    Kept(Error),
}

/// The summary folds of the first pass and its rows kept: the summary, the time steps with
/// the rows skipped, and the spill.
type Folds = (SummaryFold, (StepTally, usize), Spill);

/// Every piece's rows (the first piece's after the header) folded and kept in a spill as
/// `spill_to` says (moved to disk when the file's `file_bytes` say its rows will not fit in
/// memory); `Ok(None)` when a piece is not plain text. The pieces are parsed (on the pool's
/// cores) while the piece before is folded into the summary on a thread of its own and
/// tallied and written on another: the same folds in the same order as one piece after
/// another. A thread the system cannot start is an error reading `path`, not a panic.
fn first_pass(
    pieces: &mut Pieces,
    (head, path): (&Head<'_>, &Path),
    spill_to: &SpillTo,
    file_bytes: u64,
) -> std::result::Result<Option<Folds>, Pass> {
    use std::sync::{mpsc::sync_channel, Arc};
    let thread = |name: &str| std::thread::Builder::new().name(format!("wiical-{name}"));
    let not_started = |source| {
        Pass::Kept(Error::from(InputError::Read {
            path: path.into(),
            source,
        }))
    };
    let kept_error = |e: std::io::Error| Pass::Kept(spill_to.error("writing them", &e));
    let mut spill = SpillWriter::create(spill_to.dir.as_deref(), spill_to.limit, spill_to.memory)
        .map_err(kept_error)?;
    std::thread::scope(|s| {
        // Each thread takes a piece when done with the one before (no piece waits in a queue):
        // at most three pieces' rows held.
        let (to_fold, fold_rx) = sync_channel::<Arc<Columns>>(0);
        let (to_write, write_rx) = sync_channel::<(Arc<Columns>, u64)>(0);
        // On an early return the senders are dropped: a thread already started ends.
        let folder = thread("summary")
            .spawn_scoped(s, move || {
                let mut fold = SummaryFold::new();
                fold_rx
                    .into_iter()
                    .for_each(|c| fold.push(&c.xyz, &c.t, &c.temp));
                fold
            })
            .map_err(not_started)?;
        let spill = &mut spill;
        let writer = thread("spill")
            .spawn_scoped(s, move || write_pieces(write_rx, spill, file_bytes))
            .map_err(not_started)?;
        let (delim, mut prev) = (head.delim.byte(), None);
        let parsed = parse_pieces(pieces, head, |text, line, done| {
            let (cols, newlines) = (head.layout).read_plain_after(text, line, delim, prev)?;
            prev = cols.t.last().copied().or(prev);
            let cols = Arc::new(cols);
            let sent =
                to_fold.send(Arc::clone(&cols)).is_ok() && to_write.send((cols, done)).is_ok();
            Ok(sent.then_some(newlines))
        });
        drop((to_fold, to_write));
        let fold = joined(folder);
        let written = joined(writer);
        let parsed = parsed.map_err(Pass::Rows)?;
        let tally = written.map_err(kept_error)?;
        Ok(parsed.then_some((fold, tally)))
    })
    .map(|folds| folds.map(|(fold, tally)| (fold, tally, spill.finish())))
}

/// What the thread `h` returned (its panic resumed).
fn joined<T>(h: std::thread::ScopedJoinHandle<'_, T>) -> T {
    h.join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// The pieces' rows from `rx` tallied (their time steps and skipped rows) and written to
/// `spill` (see [`first_pass`]), until the sender is dropped or a write fails (which ends
/// the pass); `done` with each piece: the bytes of text up to its end.
fn write_pieces(
    rx: std::sync::mpsc::Receiver<(std::sync::Arc<Columns>, u64)>,
    spill: &mut SpillWriter,
    file_bytes: u64,
) -> std::io::Result<(StepTally, usize)> {
    let (mut tally, mut skipped) = (StepTally::new(), 0usize);
    for (cols, done) in rx {
        tally.push_all(&cols.t);
        skipped += cols.skipped;
        spill.push(&cols)?;
        if spill.in_memory() && !fits_in_memory(spill.bytes(), done, file_bytes, spill.memory()) {
            spill.move_to_disk()?;
        }
    }
    Ok((tally, skipped))
}

/// Whether a spill of `written` bytes for `done` bytes of the file's `file_bytes` will fit in
/// `memory` bytes at that rate (else it goes to disk now, before memory grows past what it
/// will hold: a file too large for memory never takes it). A gzip file's size is its
/// compressed size: its spill then goes to disk once past `memory`, when written.
fn fits_in_memory(written: u64, done: u64, file_bytes: u64, memory: u64) -> bool {
    let projected = u128::from(written) * u128::from(file_bytes) / u128::from(done.max(1));
    projected <= u128::from(memory)
}

/// Every sample of a [`TextSource`], read back from its kept rows a block at a time; a clone
/// goes on from the same row.
pub struct Rows<'a> {
    src: &'a TextSource,
    /// The next block to read.
    next: usize,
    /// The block read last.
    cols: Columns,
    /// The next row of `cols`.
    at: usize,
    /// Rows of the next block to pass over (a clone's position in it).
    skip: usize,
    scratch: Vec<u8>,
    done: bool,
}

impl Clone for Rows<'_> {
    fn clone(&self) -> Self {
        // At the next row: the block holding it read again, from that row.
        let row = self.next_row();
        let (next, first) = self.src.spill.block_holding(row);
        Rows {
            src: self.src,
            next,
            cols: Columns::default(),
            at: 0,
            skip: row - first,
            scratch: Vec::new(),
            done: self.done,
        }
    }
}

impl Rows<'_> {
    /// The number of the row `next` gives.
    fn next_row(&self) -> usize {
        let read = self.src.spill.block_rows().nth(self.next);
        read.map_or(self.src.spill.len(), |(first, _)| first) + self.skip
            - (self.cols.xyz.len() - self.at)
    }

    /// The next block into `cols` (from its row `skip`); false after the last.
    fn next_block(&mut self) -> Result<bool> {
        let Some((from, to)) = self.src.spill.block_rows().nth(self.next) else {
            return Ok(false);
        };
        let (cols, scratch) = (&mut self.cols, &mut self.scratch);
        (self.src.spill)
            .read_rows(from, to, Want::ALL, cols, scratch)
            .map_err(|e| self.src.spill_to.error("reading them back", &e))?;
        self.next += 1;
        self.at = std::mem::take(&mut self.skip);
        Ok(true)
    }
}

impl Iterator for Rows<'_> {
    type Item = Row;

    fn next(&mut self) -> Option<Row> {
        loop {
            if self.done {
                return None;
            }
            if self.at < self.cols.xyz.len() {
                let (i, c) = (self.at, &self.cols);
                self.at += 1;
                return Some(Row {
                    t: c.t.get(i).copied(),
                    xyz: c.xyz[i],
                    temp: c.temp.get(i).copied(),
                });
            }
            match self.next_block() {
                Ok(true) => {}
                Ok(false) => self.done = true,
                Err(e) => {
                    self.done = true;
                    self.src.fail(e);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// `bytes` as one gzip member.
    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        z.write_all(bytes).unwrap();
        z.finish().unwrap()
    }

    /// The summary and time steps of a recording held whole: its rows folded at once, its
    /// time column's steps as the whole-text path takes them.
    fn summary_of(r: &Recording) -> (String, Option<TimeSteps>) {
        let mut fold = SummaryFold::new();
        let (t, temp) = (
            r.t.clone().unwrap_or_default(),
            r.temp.clone().unwrap_or_default(),
        );
        fold.push(&r.xyz, &t, &temp);
        let steps = r.t.as_ref().and_then(|t| TimeSteps::of(t));
        (format!("{:?}", fold.finish()), steps)
    }

    /// `text` with `lines` put before the lines of their index (0: the first).
    fn with_lines(text: &str, lines: &[(usize, &str)]) -> String {
        let mut out = String::new();
        for (i, l) in text.split_inclusive('\n').enumerate() {
            for (_, extra) in lines.iter().filter(|(at, _)| *at == i) {
                out += extra;
                out.push('\n');
            }
            out += l;
        }
        assert_eq!(out.lines().count(), text.lines().count() + lines.len());
        out
    }

    /// A file rewritten in place — the same size, its modification time put back, so that
    /// only the sampled pieces' checksum tells — during the first pass is refused, named;
    /// rewritten after it, every later pass still reads the rows the first pass kept (never
    /// rows mixed from two versions), in memory or on disk.
    #[test]
    fn a_file_rewritten_in_place_is_refused_or_read_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        // The same times and length, other readings (three digits each in both): a version
        // whose rows all parse, so only the identity check can tell.
        let text_of = |base: u32| {
            let mut text = String::from("t,x,y,z\n");
            for i in 0..20_000u32 {
                let (x, y, z) = (base + i % 7, base + 100 + i % 5, base + 200 + i % 3);
                text += &format!("{i}.0,{x},{y},{z}\n");
            }
            text
        };
        let (text, other) = (text_of(100), text_of(500));
        assert_eq!(text.len(), other.len());
        let rewrite = || {
            let modified = std::fs::metadata(&path).unwrap().modified().unwrap();
            let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
            (&file).write_all(other.as_bytes()).unwrap();
            file.set_modified(modified).unwrap();
        };
        let opts = LoadOptions::default();
        for memory in [0, u64::MAX] {
            let to = SpillTo {
                dir: None,
                limit: u64::MAX,
                memory,
            };
            // During the first pass: `head_ok` is asked once its first piece is read.
            std::fs::write(&path, &text).unwrap();
            let during = TextSource::open_with(&path, &opts, 4096, &to, |_| {
                rewrite();
                true
            });
            let e = during.unwrap_err().to_string();
            assert!(e.contains("changed while it was being read"), "{e}");
            // After it.
            std::fs::write(&path, &text).unwrap();
            let src = TextSource::open_with(&path, &opts, 4096, &to, |_| true)
                .unwrap()
                .unwrap();
            assert_eq!(src.is_spill_in_memory(), memory > 0);
            let first: Vec<Row> = src.rows().collect();
            assert_eq!(first.len(), 20_000);
            let mut rows = src.rows();
            let head: Vec<Row> = rows.by_ref().take(10).collect();
            rewrite();
            assert_eq!([head, rows.collect()].concat(), first);
            assert_eq!(src.rows().collect::<Vec<_>>(), first);
            src.check().unwrap();
        }
    }

    /// A file's rows in memory when the first pieces' rate says they fit, else on disk.
    #[test]
    fn the_spill_is_kept_in_memory_when_its_projection_fits() {
        // 10 bytes of rows for 100 of a 1000-byte file: 100 bytes in all.
        assert!(fits_in_memory(10, 100, 1000, 100));
        assert!(!fits_in_memory(10, 100, 1000, 99));
        assert!(fits_in_memory(0, 0, 1000, 0));
        assert!(!fits_in_memory(u64::MAX, 1, u64::MAX, u64::MAX));
    }

    /// Every text, plain or gzip'd, read in pieces of every size, gives in each pass what the
    /// whole-text parse gives: the rows bit for bit, the notes, the summary (its pieces folded
    /// while the next is parsed: the folds of the whole recording at once) and the time steps
    /// — or the same sentence, or is handed back to be read whole; a clone taken mid-pass goes
    /// on from the same row.
    #[test]
    #[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
    fn passes_read_as_the_whole_text() {
        let mut rows = String::from("Fs,100\nt,x,y,z,temp\n");
        for i in 0..400 {
            let t = i as f64 * 0.01 + if i > 300 { 2.0 } else { 0.0 };
            rows += &format!(
                "{t},{},{}.5,-{}e-{},2{}.5\n",
                i % 97,
                i % 13,
                i % 7,
                i % 3,
                i % 9
            );
        }
        let texts = [
            rows.clone(),
            rows.replace('\n', "\r\n"),
            rows.replace("\n2.5,", "\n1.5,"),
            rows.replace("\n3.01,", "\n3.01,x"),
            rows.clone() + "1,2\n",
            "t;x;y;z\n0;1,5;2;3\n0,01;4;5;6\n".to_string(),
            "x,y,z\n".to_string(),
            rows.replace("t,x,y,z,temp", "x,y,z,pose")
                .replace(",2", ",a"),
            format!("\u{feff}{rows}"),
            rows.clone() + "# a comment\n",
            // Quotes in the head only, comment lines before it and among the rows: the rows
            // are still read by the fast splitter.
            rows.replace("t,x,y,z,temp", "\"t\",\"x\",\"y\",\"z\",\"temp\""),
            format!("# logger v2, 100 Hz\n% a note\n{rows}"),
            with_lines(&rows, &[(150, "% pause"), (230, "  # resumed, 100 Hz")]),
            // A quote among the rows: read whole.
            with_lines(&rows, &[(200, "\"1.99\",1,2,3,4")]),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let opts = LoadOptions::default();
        let gz_path = dir.path().join("r.csv.gz");
        for text in &texts {
            std::fs::write(&path, text).unwrap();
            // The same text gzip'd in two members (as `cat a.gz b.gz` makes): read alike.
            let half = text.len() / 2;
            let gz = [
                gzip(&text.as_bytes()[..half]),
                gzip(&text.as_bytes()[half..]),
            ]
            .concat();
            std::fs::write(&gz_path, gz).unwrap();
            let whole = crate::input::text::parse(text.trim_start_matches('\u{feff}'), &opts);
            let summary = whole.as_ref().ok().map(summary_of);
            let whole = whole.map(|r| {
                let t = r.t.clone().unwrap_or_default();
                let temp = r.temp.clone().unwrap_or_default();
                let rows: Vec<Row> = (0..r.len())
                    .map(|i| Row {
                        t: t.get(i).copied(),
                        xyz: r.xyz[i],
                        temp: temp.get(i).copied(),
                    })
                    .collect();
                format!("{rows:?} {:?} {}", r.notes, r.len())
            });
            let whole = whole.map_err(|e| e.to_string());
            let sizes = [1, 7, 64, 300, 4096, 1 << 20];
            for (size, path) in sizes.iter().flat_map(|&n| [(n, &path), (n, &gz_path)]) {
                let got = match TextSource::open_in(path, &opts, size, |_| true) {
                    Ok(None) => continue, // read whole by the caller
                    Ok(Some(src)) => {
                        let rows: Vec<Row> = src.rows().collect();
                        let mut it = src.rows();
                        let head: Vec<Row> = it.by_ref().take(5).collect();
                        let rest: Vec<Row> = it.clone().collect();
                        assert_eq!([head, rest].concat(), rows);
                        src.check().unwrap();
                        let got = (format!("{:?}", src.summary), src.steps);
                        assert_eq!(Some(got), summary, "{text:?} in pieces of {size}");
                        Ok(format!("{rows:?} {:?} {}", src.meta.notes, src.len()))
                    }
                    Err(e) => Err(e.to_string()),
                };
                assert_eq!(got, whole, "{text:?} in pieces of {size} from {path:?}");
            }
        }
        // The plain file is streamed, and so are comment lines and a quoted header; a pose
        // column, a quote in a row: read whole.
        for k in [0, 9, 10, 11, 12] {
            std::fs::write(&path, &texts[k]).unwrap();
            assert!(
                matches!(TextSource::open_in(&path, &opts, 64, |_| true), Ok(Some(_))),
                "{k}"
            );
        }
        for k in [7, 13] {
            std::fs::write(&path, &texts[k]).unwrap();
            assert!(matches!(
                TextSource::open_in(&path, &opts, 64, |_| true),
                Ok(None)
            ));
        }
    }
}
