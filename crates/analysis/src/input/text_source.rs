//! A large plain text file as a re-readable source of samples: memory is one piece of text
//! and its parsed rows, never the file's rows, whatever its length.
//!
//! [`TextSource::open`] is the first pass: the file read in pieces exactly as
//! [`crate::input::text_file`] reads it (the same pieces, the same row parser, the time check
//! joined across pieces, the same sentences with line and column, the same files handed back
//! to be read whole), but each piece's rows are folded into a [`SampleSummary`] and a
//! [`StepTally`] and dropped. [`TextSource::rows`] is every later pass: the file reopened and
//! its pieces parsed again, as an iterator whose clone reads the file afresh from the same
//! row (the core's detector takes an `Iterator + Clone` and passes over it several times).
//! A file whose size or modification time differs from the first pass's, or whose pieces no
//! longer parse, stops the pass; [`TextSource::check`] then says so in one sentence.
//!
//! The first pass also keeps the rows it parsed (`input::text_spill`: in memory when they
//! fit, else in a temporary file), and every later pass reads them back from there instead
//! of parsing the text again: the same values bit for bit, at the cost of a copy instead of a
//! parse. Without it (no temporary directory, a full disk, or [`SpillMode::Off`]) the
//! passes re-read the text as described above. The first pass parses each piece while the
//! one before is folded and written, on threads of their own.

use crate::error::input::InputError;
use crate::error::{Error, Result};
use crate::input::bounded::check_largest_reading;
use crate::input::columns::LoadOptions;
use crate::input::read_options::SpillMode;
use crate::input::recording::Recording;
use crate::input::sample_summary::{SampleSummary, SummaryFold};
use crate::input::text::{check_axis_columns, CsvState, Delimiter};
use crate::input::text_file::{first_piece_head, read_piece_head, Pieces, PIECE_BYTES};
pub(crate) use crate::input::text_rows::Columns;
use crate::input::text_rows::RowLayout;
pub(crate) use crate::input::text_spill::Want;
use crate::input::text_spill::{Spill, SpillWriter, MEMORY_SPILL_BYTES};
use crate::input::timecheck::{time_notes_given, StepTally, TimeSteps};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
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

/// What identifies the file's content between passes, cheaply: its size, its modification
/// time, and a checksum of [`SAMPLED_PIECES`] pieces of [`SAMPLED_PIECE_BYTES`] spread over
/// it (the first and the last among them). The size and time catch a file still being
/// written; the checksum a rewrite in place that keeps the size within the time's
/// resolution, or puts the time back. A change between the sampled pieces with the time put
/// back passes: the identity is a check on accidents (a logger still writing, a file
/// replaced), not a proof.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stamp {
    len: u64,
    modified: Option<std::time::SystemTime>,
    sampled: u64,
}

/// Pieces of the file read for [`Stamp`]'s checksum (at every check: before each pass and
/// after it, a few dozen kilobytes from the page cache against the pass's whole file).
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

/// A large plain text file read once for its summary, re-read for every later pass.
#[derive(Debug)]
pub struct TextSource {
    path: PathBuf,
    stamp: Stamp,
    layout: RowLayout,
    delim: u8,
    piece_bytes: usize,
    /// Byte offset of the first data row in the first piece (its byte-order mark removed).
    data_offset: usize,
    /// Line number of the first data row's line.
    data_line: usize,
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
    /// The rows of the first pass, for the later passes to read back (`None`: they re-read
    /// the text).
    spill: Option<Spill>,
    /// Set when the spill could not be read back: later passes re-read the text.
    spill_failed: AtomicBool,
    /// A later pass parses its next piece on a thread of its own ([`Feed`];
    /// [`crate::input::read_options::ReadOptions::parse_ahead`]).
    parse_ahead: bool,
}

/// Where the first pass writes its rows ([`crate::input::text_spill`]).
#[derive(Debug, Clone)]
pub(crate) struct SpillTo {
    /// Write them at all.
    pub on: bool,
    /// The temporary directory (`None`: the system's, `$TMPDIR`).
    pub dir: Option<PathBuf>,
    /// Most bytes written (past it the spill is dropped, as on a full disk).
    pub limit: u64,
    /// Most bytes kept in memory (past them, or when the file's size says they will pass
    /// them, the rows go to the temporary directory).
    pub memory: u64,
}

impl SpillTo {
    /// In memory up to [`MEMORY_SPILL_BYTES`], else the system's temporary directory; none
    /// with [`SpillMode::Off`], none in memory with [`SpillMode::Disk`].
    fn of(spill: SpillMode) -> Self {
        Self {
            on: spill != SpillMode::Off,
            dir: None,
            limit: u64::MAX,
            memory: if spill == SpillMode::Disk {
                0
            } else {
                MEMORY_SPILL_BYTES
            },
        }
    }

    fn writer(&self) -> Option<SpillWriter> {
        self.on
            .then(|| SpillWriter::create(self.dir.as_deref(), self.limit, self.memory))
            .flatten()
    }
}

/// The first pass's reading of the head: `None` hands the file back to be read whole.
struct Head {
    layout: RowLayout,
    delim: Delimiter,
    state_meta: Recording,
    data_offset: usize,
    data_line: usize,
}

impl TextSource {
    /// The first pass over the regular text file `path` (see the module docs); `head_ok` is
    /// asked about the first piece's text as by [`crate::input::text_file::load_pieces`].
    /// `Ok(None)`: the file is to be read whole (not plain text, a pose-label column, …).
    /// Errors carry no file name (the caller adds it).
    pub fn open(
        path: &Path,
        opts: &LoadOptions,
        head_ok: impl Fn(&str) -> bool,
    ) -> Result<Option<Self>> {
        Self::open_in(path, opts, PIECE_BYTES, head_ok)
    }

    /// [`TextSource::open`] with pieces of `piece_bytes`.
    pub(crate) fn open_in(
        path: &Path,
        opts: &LoadOptions,
        piece_bytes: usize,
        head_ok: impl Fn(&str) -> bool,
    ) -> Result<Option<Self>> {
        Self::open_with(
            path,
            opts,
            piece_bytes,
            &SpillTo::of(opts.read.spill),
            head_ok,
        )
    }

    /// [`TextSource::open_in`] writing the first pass's rows as `spill_to` says.
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
            Ok(Some(h)) => h,
            Ok(None) => return Ok(None),
            Err(e) => return pieces.rest_is_plain().then_some(Err(e)).transpose(),
        };
        let mut writer = spill_to.writer();
        let (fold, tally, skipped) =
            match first_pass(&mut pieces, (&head, path), &mut writer, stamp.len) {
                Ok(Some(x)) => x,
                Ok(None) => return Ok(None),
                // A row that does not parse in a file that changed meanwhile is the change's.
                Err(_) if stamp_of(path) != Some(stamp) => {
                    return Err(InputError::ChangedWhileRead.into())
                }
                Err(e) => return pieces.rest_is_plain().then_some(Err(e)).transpose(),
            };
        let summary = fold.finish();
        if summary.count == 0 {
            return Err(InputError::HeaderOnly.into());
        }
        if stamp_of(path) != Some(stamp) {
            // Changed during the first pass: its summary may mix two versions.
            return Err(InputError::ChangedWhileRead.into());
        }
        let mut meta = head.state_meta;
        meta.skipped_empty_rows = skipped;
        let mut src = Self {
            path: path.to_path_buf(),
            stamp,
            layout: head.layout,
            delim: head.delim.byte(),
            piece_bytes,
            data_offset: head.data_offset,
            data_line: head.data_line,
            meta,
            summary,
            steps: None,
            failed: Mutex::new(None),
            spool: None,
            shown: None,
            spill: writer.map(SpillWriter::finish),
            spill_failed: AtomicBool::new(false),
            parse_ahead: opts.read.parse_ahead,
        };
        if let Some(i) = src.layout.time {
            let steps = tally
                .finish()
                .unwrap_or_else(|| TimeSteps::of_times(|| src.times()));
            let notes = time_notes_given(&src.layout.names[i], steps, || src.times());
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

    /// Whether the later passes read the first pass's rows back, from memory or a temporary
    /// file (else they parse the text again).
    pub fn is_spilled(&self) -> bool {
        self.spill.is_some() && !self.spill_failed.load(Ordering::Relaxed)
    }

    /// Whether the first pass's rows are kept in memory (else on disk, or not at all).
    pub fn is_spill_in_memory(&self) -> bool {
        self.is_spilled() && self.spill.as_ref().is_some_and(Spill::in_memory)
    }

    /// Drops the first pass's rows: every later pass parses the text again (the same values:
    /// for comparisons).
    pub fn forget_spill(&mut self) {
        self.spill = None;
    }

    /// Empties the spill's file: a spill that can no longer be read back.
    #[cfg(test)]
    pub(crate) fn truncate_spill(&self) {
        if let Some(s) = &self.spill {
            s.truncate();
        }
    }

    /// Whether the file has a time column.
    pub fn has_time(&self) -> bool {
        self.layout.time.is_some()
    }

    /// Whether the file has a temperature column.
    pub fn has_temp(&self) -> bool {
        self.layout.temp.is_some()
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

    /// A pass over every sample, from the file (see the module docs); it ends early when the
    /// file changed or could not be read: [`TextSource::check`] after the pass says so.
    pub fn rows(&self) -> Rows<'_> {
        Rows {
            src: self,
            reader: None,
            skip: 0,
            consumed: 0,
            done: false,
            want: Want::ALL,
        }
    }

    /// A pass over every sample a piece (or a block of the spill) at a time: `f` is given
    /// each piece's rows in order, and may stop the pass by returning `false`. As
    /// [`TextSource::rows`], the pass ends early when the file changed or could not be read:
    /// [`TextSource::check`] after it says so.
    /// Read from the spill, the rows hold the columns `want` asks for (and the axes); from
    /// the text, all of them.
    pub(crate) fn each_piece(&self, want: Want, f: impl FnMut(&Columns) -> bool) {
        let mut rows = self.rows();
        rows.want = want;
        self.pieces_from(rows, f);
    }

    /// [`TextSource::each_piece`] from the row `rows` is at.
    fn pieces_from(&self, mut rows: Rows<'_>, mut f: impl FnMut(&Columns) -> bool) {
        loop {
            match rows.next_piece() {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return self.fail(e),
            }
            let Some(r) = rows.reader.as_mut() else {
                break;
            };
            if rows.skip > 0 {
                // Rows given before the spill failed and the pass went on from the text.
                let k = rows.skip.min(r.cols.xyz.len());
                r.cols.xyz.drain(..k);
                r.cols.t.drain(..k.min(r.cols.t.len()));
                r.cols.temp.drain(..k.min(r.cols.temp.len()));
                rows.skip -= k;
            }
            rows.consumed += r.cols.xyz.len();
            if !f(&r.cols) {
                return;
            }
        }
        if rows.consumed != self.summary.count {
            self.fail(self.changed());
        }
    }

    /// A pass over every sample's axes as `f32` (`v as f32`: the detector's view of values on
    /// no lattice), a piece (or a block of the spill, read straight to `f32`) at a time, as
    /// [`TextSource::each_piece`]: `f` may stop it by returning `false`; a spill that cannot
    /// be read back ends its use, the pass going on from the text at the same row.
    pub(crate) fn each_piece_f32(&self, mut f: impl FnMut(&[[f32; 3]]) -> bool) {
        let mut view = Vec::new();
        let mut consumed = 0;
        if let Some(spill) = self.spill.as_ref().filter(|_| self.is_spilled()) {
            if !self.unchanged() {
                return self.fail(self.changed());
            }
            let mut scratch = Vec::new();
            for (k, (from, to)) in spill.block_rows().enumerate() {
                let axes = match spill.axes_f32(k) {
                    Some(axes) => axes,
                    None if spill.read_f32(from, to, &mut view, &mut scratch).is_ok() => &view,
                    None => {
                        self.spill_failed.store(true, Ordering::Relaxed);
                        break;
                    }
                };
                consumed = to;
                if !f(axes) {
                    return;
                }
            }
            if self.is_spilled() {
                if consumed != self.summary.count {
                    self.fail(self.changed());
                }
                return;
            }
        }
        let mut rows = self.rows();
        (rows.want, rows.skip, rows.consumed) = (Want::AXES, consumed, consumed);
        self.pieces_from(rows, |cols| {
            view.clear();
            view.extend(cols.xyz.iter().map(|x| x.map(|v| v as f32)));
            f(&view)
        });
    }

    /// Every sample's axes as `f32` in place, a block of the spill after another, when the
    /// spill is in memory and every block's axes are `f32` ([`Spill::axes_f32`]): a pass over
    /// them with no copy, in pieces any core may read at once. `None` otherwise, and when the
    /// file has changed since the first pass (a pass then goes by
    /// [`TextSource::each_piece_f32`], which says so).
    pub(crate) fn axes_f32_in_place(&self) -> Option<Vec<&[[f32; 3]]>> {
        let spill = self.spill.as_ref().filter(|_| self.is_spilled())?;
        if !self.unchanged() {
            return None;
        }
        let blocks = spill.block_rows().count();
        let axes: Option<Vec<_>> = (0..blocks).map(|k| spill.axes_f32(k)).collect();
        axes.filter(|a| a.iter().map(|b| b.len()).sum::<usize>() == self.summary.count)
    }

    /// Whether the file is still the one of the first pass ([`Stamp`]: its size, modification
    /// time and sampled pieces).
    pub(crate) fn unchanged(&self) -> bool {
        stamp_of(&self.path) == Some(self.stamp)
    }

    /// Rows `from..to` of the spill into `cols` (with `scratch` for the bytes read), when the
    /// later passes read it; `false` (nothing read) otherwise, or when it could not be read.
    pub(crate) fn read_spilled(
        &self,
        (from, to): (usize, usize),
        cols: &mut Columns,
        scratch: &mut Vec<u8>,
    ) -> bool {
        let Some(spill) = self.spill.as_ref().filter(|_| self.is_spilled()) else {
            return false;
        };
        if to > spill.len() || spill.read_rows(from, to, Want::ALL, cols, scratch).is_err() {
            return false;
        }
        true
    }

    /// The time column, from the file.
    pub fn times(&self) -> impl Iterator<Item = f64> + '_ {
        self.rows().filter_map(|r| r.t)
    }

    /// The first failure of a pass since the file was opened (`Ok` when every pass read the
    /// whole file as the first did).
    ///
    /// The file's identity is checked here too, after the pass: a pass that read every row
    /// as many as the first did may still have read some of them from a rewrite in place (same
    /// size), an answer mixed from two versions.
    pub fn check(&self) -> Result<()> {
        if !self.unchanged() {
            self.fail(self.changed());
        }
        match self.failed.lock().map(|mut f| f.take()) {
            Ok(Some(e)) => Err(e),
            _ => Ok(()),
        }
    }

    /// [`InputError::ChangedWhileRead`] in this file (by the name the user gave it: `-` for
    /// standard input copied to a temporary file).
    fn changed(&self) -> Error {
        let shown = self.shown.as_deref().unwrap_or(&self.path);
        Error::from(InputError::ChangedWhileRead).in_file(shown)
    }

    /// Keeps `e` as the first failure (a file that changed named, as the user gave it).
    fn fail(&self, e: Error) {
        let e = match e {
            Error::Input(InputError::ChangedWhileRead) => self.changed(),
            e => e,
        };
        if let Ok(mut f) = self.failed.lock() {
            f.get_or_insert(e);
        }
    }

    /// A pass's reader, at the block holding row `*skip` of the spill (`*skip` then counted
    /// from the block's first row), else at the text's first data row ([`TextSource::reopen`]).
    /// A file changed since the first pass is refused either way (a pass of the spill would
    /// read the rows it had).
    fn reader_at(&self, skip: &mut usize) -> Result<Reader> {
        if let Some(spill) = self.spill.as_ref().filter(|_| self.is_spilled()) {
            if !self.unchanged() {
                return Err(self.changed());
            }
            let (k, first) = spill.block_holding(*skip);
            *skip -= first;
            return Ok(Reader {
                feed: Feed::Spilled {
                    next: k,
                    scratch: Vec::new(),
                },
                cols: Columns::default(),
                at: 0,
            });
        }
        self.reopen()
    }

    /// The file reopened at its first data row, when it is still the file of the first pass:
    /// its pieces parsed ahead of the pass ([`Feed`]).
    fn reopen(&self) -> Result<Reader> {
        if !self.unchanged() {
            return Err(self.changed());
        }
        let pieces = Pieces::open(&self.path, self.piece_bytes)?;
        let parser = Parser {
            pieces,
            layout: self.layout.clone(),
            delim: self.delim,
            data_offset: Some(self.data_offset),
            line: self.data_line,
            prev_t: None,
        };
        Ok(Reader {
            feed: Feed::start(parser, &self.path, self.parse_ahead)?,
            cols: Columns::default(),
            at: 0,
        })
    }
}

/// The header read from the first piece as [`crate::input::text_file`] reads it.
fn read_head(
    pieces: &mut Pieces,
    opts: &LoadOptions,
    head_ok: impl Fn(&str) -> bool,
) -> Result<Option<Head>> {
    let Some((head, delim, plain)) = first_piece_head(pieces, head_ok) else {
        return Ok(None);
    };
    let mut st = CsvState::new(opts, delim);
    let Some((offset, header_line)) = read_piece_head(&mut st, head, delim, plain)? else {
        return Ok(None);
    };
    if pieces.data_after_bom(offset).is_none() {
        return Ok(None); // marks past the head: read whole
    }
    let Some(layout) = st.layout.clone() else {
        return Ok(None);
    };
    if layout.label.is_some() {
        return Ok(None); // a pose table: read in memory (six-position files are short)
    }
    Ok(Some(Head {
        layout,
        delim,
        state_meta: st.into_meta(),
        data_offset: offset,
        data_line: header_line + 1,
    }))
}

/// The summary folds of the first pass; `Ok(None)` when a piece is not plain text.
type Folds = (SummaryFold, StepTally, usize);

/// Every piece's rows (the first piece's after the header) folded, written to `spill` (which
/// is dropped when a write fails, and moved to disk when the file's `file_bytes` say its rows
/// will not fit in memory) and dropped. The pieces are parsed (on the pool's cores) while the
/// piece before is folded into the summary on a thread of its own and tallied and written on
/// another: the same folds in the same order as one piece after another. A thread the system
/// cannot start is an error reading `path` (as for a pass's parse-ahead thread), not a panic.
fn first_pass(
    pieces: &mut Pieces,
    (head, path): (&Head, &Path),
    spill: &mut Option<SpillWriter>,
    file_bytes: u64,
) -> Result<Option<Folds>> {
    use std::sync::{mpsc::sync_channel, Arc};
    let thread = |name: &str| std::thread::Builder::new().name(format!("wiical-{name}"));
    let not_started = |source| {
        Error::from(InputError::Read {
            path: path.into(),
            source,
        })
    };
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
        let writer = thread("spill")
            .spawn_scoped(s, move || write_pieces(write_rx, spill, file_bytes))
            .map_err(not_started)?;
        let parsed = parse_pieces(pieces, head, |cols, done| {
            let cols = Arc::new(cols);
            to_fold.send(Arc::clone(&cols)).is_ok() && to_write.send((cols, done)).is_ok()
        });
        drop((to_fold, to_write));
        let fold = joined(folder);
        let (tally, skipped) = joined(writer);
        Ok(parsed?.then_some((fold, tally, skipped)))
    })
}

/// What the thread `h` returned (its panic resumed).
fn joined<T>(h: std::thread::ScopedJoinHandle<'_, T>) -> T {
    h.join()
        .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// The rows of every piece handed to `give` in order with the text bytes read up to their end
/// (`give` returns false to stop); `Ok(false)` when a piece is not plain text.
fn parse_pieces(
    pieces: &mut Pieces,
    head: &Head,
    mut give: impl FnMut(Columns, u64) -> bool,
) -> Result<bool> {
    let mut line = head.data_line;
    let mut prev: Option<f64> = None;
    let mut first = true;
    let mut done = 0u64;
    loop {
        let text = if std::mem::take(&mut first) {
            // The first piece again, from its data rows (its head was read above).
            done += pieces.current().len() as u64;
            match pieces.data_after_bom(head.data_offset) {
                Some(t) => t,
                None => return Ok(false),
            }
        } else {
            match pieces.next_piece() {
                Ok(Some(p)) => done += p.len() as u64,
                Ok(None) => break,
                Err(()) => return Ok(false),
            }
            match pieces.plain() {
                Some(t) => t,
                None => return Ok(false),
            }
        };
        let (cols, newlines) = head
            .layout
            .read_plain_after(text, line, head.delim.byte(), prev)?;
        line += newlines;
        prev = cols.t.last().copied().or(prev);
        if !give(cols, done) {
            break;
        }
    }
    Ok(true)
}

/// The pieces' rows from `rx` tallied (their time steps and skipped rows) and written to
/// `spill` (see [`first_pass`]), until the sender is dropped; `done` with each piece: the bytes
/// of text up to its end.
fn write_pieces(
    rx: std::sync::mpsc::Receiver<(std::sync::Arc<Columns>, u64)>,
    spill: &mut Option<SpillWriter>,
    file_bytes: u64,
) -> (StepTally, usize) {
    let (mut tally, mut skipped) = (StepTally::new(), 0usize);
    for (cols, done) in rx {
        tally.push_all(&cols.t);
        skipped += cols.skipped;
        let written = spill.as_mut().is_some_and(|w| {
            w.push(&cols).is_ok()
                && (!w.in_memory()
                    || fits_in_memory(w.bytes(), done, file_bytes, w.memory())
                    || w.move_to_disk().is_ok())
        });
        if !written {
            *spill = None;
        }
    }
    (tally, skipped)
}

/// Whether a spill of `written` bytes for `done` bytes of the file's `file_bytes` will fit in
/// `memory` bytes at that rate (else it goes to disk now, before memory grows past what it
/// will hold: a file too large for memory never takes it). A gzip file's size is its
/// compressed size: its spill then goes to disk once past `memory`, when written.
fn fits_in_memory(written: u64, done: u64, file_bytes: u64, memory: u64) -> bool {
    let projected = u128::from(written) * u128::from(file_bytes) / u128::from(done.max(1));
    projected <= u128::from(memory)
}

/// A pass's position in the file.
struct Reader {
    feed: Feed,
    cols: Columns,
    at: usize,
}

/// A pass's pieces, parsed one after another from the file: the time check joined across
/// them, line numbers counted on.
struct Parser {
    pieces: Pieces,
    layout: RowLayout,
    delim: u8,
    /// Where the first piece's data rows start (`None` once it is read).
    data_offset: Option<usize>,
    /// Line number of the next piece's first line.
    line: usize,
    /// The last time read (the next piece's time check is joined to it).
    prev_t: Option<f64>,
}

impl Parser {
    /// The next piece's rows (`None` at the end of the file). Anything the first pass did not
    /// find (a piece that is not plain text, a row that does not parse) means the file changed.
    fn next(&mut self) -> Option<Result<Columns>> {
        let changed = || Error::from(InputError::ChangedWhileRead);
        match self.pieces.next_piece() {
            Ok(Some(_)) => {}
            Ok(None) if self.data_offset.is_none() => return None,
            _ => return Some(Err(changed())),
        };
        let text = match self.data_offset.take() {
            Some(offset) => self.pieces.data_after_bom(offset),
            None => self.pieces.plain(),
        };
        let Some(text) = text else {
            return Some(Err(changed()));
        };
        let read = (self.layout).read_plain_after(text, self.line, self.delim, self.prev_t);
        let Ok((cols, newlines)) = read else {
            return Some(Err(changed()));
        };
        self.line += newlines;
        self.prev_t = cols.t.last().copied().or(self.prev_t);
        Some(Ok(cols))
    }
}

/// Where a pass's parsed pieces come from: a thread of its own that parses the next piece
/// while the pass goes through the rows of the one before (a pass's consumer — the detector,
/// the window sums — runs on one thread, and the parse would otherwise wait for it), handing
/// them over one at a time (at most two pieces' rows held, in order); or, on a thread of
/// the parse's own pool (which a parse started from there could wait for), the pass itself.
/// Or, with a spill, its blocks read back one at a time (`next`: the next block).
///
/// `Ahead` keeps its thread's handle until the thread has hung up: a parse that panicked
/// there is raised again on the pass's thread ([`Feed::next`]), as it would be `Inline`,
/// never taken for the end of the file.
enum Feed {
    Ahead(
        std::sync::mpsc::Receiver<Result<Columns>>,
        Option<std::thread::JoinHandle<()>>,
    ),
    Inline(Box<Parser>),
    Spilled {
        next: usize,
        scratch: Vec<u8>,
    },
}

impl Feed {
    /// The feed of `parser`'s pieces, parsed ahead on a thread when `ahead` (and this is not a
    /// thread of the parse's pool); an error when no thread could be started (reading `path`).
    fn start(mut parser: Parser, path: &Path, ahead: bool) -> Result<Self> {
        if !ahead || rayon::current_thread_index().is_some() {
            return Ok(Feed::Inline(Box::new(parser)));
        }
        let (tx, rx) = std::sync::mpsc::sync_channel(0);
        let spawned = std::thread::Builder::new()
            .name("wiical-pieces".into())
            .spawn(move || {
                // Ends at the end of the file, or when the pass is dropped (send fails).
                while let Some(cols) = parser.next() {
                    if tx.send(cols).is_err() {
                        break;
                    }
                }
            });
        match spawned {
            Ok(thread) => Ok(Feed::Ahead(rx, Some(thread))),
            Err(source) => Err(InputError::Read {
                path: path.into(),
                source,
            }
            .into()),
        }
    }

    /// The next parsed piece (not for [`Feed::Spilled`], read by [`Rows::next_block`]).
    fn next(&mut self) -> Option<Result<Columns>> {
        match self {
            Feed::Ahead(rx, thread) => match rx.recv() {
                Ok(cols) => Some(cols),
                // The thread hung up: at the end of the file, or in a panic, raised here.
                Err(_) => {
                    if let Some(Err(panic)) = thread.take().map(std::thread::JoinHandle::join) {
                        std::panic::resume_unwind(panic);
                    }
                    None
                }
            },
            Feed::Inline(p) => p.next(),
            Feed::Spilled { .. } => None,
        }
    }
}

/// Every sample of a [`TextSource`], read from the file; a clone reads the file afresh to the
/// same row.
pub struct Rows<'a> {
    src: &'a TextSource,
    reader: Option<Reader>,
    /// Rows to pass over before the first one given (a clone's position).
    skip: usize,
    consumed: usize,
    done: bool,
    /// The columns a block of the spill is read with.
    want: Want,
}

impl Clone for Rows<'_> {
    fn clone(&self) -> Self {
        Rows {
            src: self.src,
            reader: None,
            skip: self.consumed,
            consumed: self.consumed,
            done: self.done,
            want: self.want,
        }
    }
}

impl Rows<'_> {
    /// The next parsed piece (or block of the spill) into the reader; false at the end of the
    /// file.
    fn next_piece(&mut self) -> Result<bool> {
        if self.reader.is_none() {
            self.reader = Some(self.src.reader_at(&mut self.skip)?);
        }
        let Some(r) = self.reader.as_mut() else {
            return Ok(false);
        };
        if let Feed::Spilled { .. } = r.feed {
            return self.next_block();
        }
        match r.feed.next() {
            None => Ok(false),
            Some(cols) => {
                r.cols = cols?;
                r.at = 0;
                Ok(true)
            }
        }
    }
}

impl Rows<'_> {
    /// The next block of the spill into the reader; false after the last. A block that cannot
    /// be read back ends the spill's use: this pass goes on from the text, at the same row.
    fn next_block(&mut self) -> Result<bool> {
        let (Some(r), Some(spill)) = (self.reader.as_mut(), self.src.spill.as_ref()) else {
            return Ok(false);
        };
        let Feed::Spilled { next, scratch } = &mut r.feed else {
            return Ok(false);
        };
        let Some((from, to)) = spill.block_rows().nth(*next) else {
            return Ok(false);
        };
        if spill
            .read_rows(from, to, self.want, &mut r.cols, scratch)
            .is_ok()
        {
            *next += 1;
            r.at = 0;
            return Ok(true);
        }
        self.src.spill_failed.store(true, Ordering::Relaxed);
        self.reader = None;
        self.skip = self.consumed;
        self.next_piece()
    }
}

impl Iterator for Rows<'_> {
    type Item = Row;

    fn next(&mut self) -> Option<Row> {
        loop {
            if self.done {
                return None;
            }
            if let Some(r) = self.reader.as_mut() {
                if r.at < r.cols.xyz.len() {
                    let i = r.at;
                    r.at += 1;
                    let row = Row {
                        t: r.cols.t.get(i).copied(),
                        xyz: r.cols.xyz[i],
                        temp: r.cols.temp.get(i).copied(),
                    };
                    if self.skip > 0 {
                        self.skip -= 1;
                        continue;
                    }
                    self.consumed += 1;
                    return Some(row);
                }
            }
            match self.next_piece() {
                Ok(true) => {}
                Ok(false) => {
                    self.done = true;
                    if self.consumed != self.src.summary.count {
                        self.src.fail(self.src.changed());
                    }
                }
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

    /// A parse that panics on the thread that parses ahead of a pass is raised on the pass's
    /// thread, as it is when the pass parses the pieces itself (`Feed::Inline`): never taken
    /// for the end of the file (a recording silently cut short) nor for a file that changed.
    /// The panic comes from the pieces' own reading thread, raised on the parse's thread by
    /// [`Pieces::next_piece`] and from there on the pass's by [`Feed::next`]: without either,
    /// `next` returns instead of raising it.
    #[test]
    fn a_panic_ahead_of_the_pass_is_raised_on_its_thread() {
        struct Panicking;
        impl std::io::Read for Panicking {
            fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
                panic!("a parse that panics")
            }
        }
        let parser = Parser {
            pieces: Pieces::reading(Box::new(Panicking), 64).unwrap(),
            layout: RowLayout {
                names: vec!["x".into(), "y".into(), "z".into()],
                time: None,
                xyz: [0, 1, 2],
                temp: None,
                label: None,
                decimal_comma: false,
            },
            delim: b',',
            data_offset: Some(0),
            line: 1,
            prev_t: None,
        };
        let mut feed = Feed::start(parser, Path::new("r.csv"), true).unwrap();
        let raised = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            feed.next().map(|cols| cols.map(|c| c.xyz.len()))
        }));
        let payload = match raised {
            Ok(got) => panic!("the parse's panic became {got:?}"),
            Err(payload) => payload,
        };
        assert_eq!(payload.downcast_ref::<&str>(), Some(&"a parse that panics"));
    }

    /// A file rewritten in place during a pass — the same size, its modification time put back,
    /// so that only the sampled pieces' checksum tells — is refused after that pass (and
    /// before any later one), named, whether the passes read the spill or the text again;
    /// never taken with rows mixed from two versions. Untouched, the same file passes: the
    /// check is not one that always fails.
    #[test]
    fn a_file_rewritten_in_place_is_refused_whatever_the_spill() {
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
        let opts = LoadOptions::default();
        for spill in [false, true] {
            std::fs::write(&path, &text).unwrap();
            let to = SpillTo {
                on: spill,
                dir: None,
                limit: u64::MAX,
                memory: u64::MAX,
            };
            let src = TextSource::open_with(&path, &opts, 4096, &to, |_| true)
                .unwrap()
                .unwrap();
            assert_eq!(src.is_spilled(), spill);
            let first: Vec<Row> = src.rows().collect();
            assert_eq!(first.len(), 20_000);
            src.check().unwrap();
            let mut rows = src.rows();
            let head: Vec<Row> = rows.by_ref().take(10).collect();
            let modified = std::fs::metadata(&path).unwrap().modified().unwrap();
            let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
            (&file).write_all(other.as_bytes()).unwrap();
            file.set_modified(modified).unwrap();
            drop(file);
            let meta = std::fs::metadata(&path).unwrap();
            assert_eq!(
                (meta.len(), meta.modified().unwrap()),
                (text.len() as u64, modified)
            );
            let rest: Vec<Row> = rows.collect();
            let got = [head, rest].concat();
            // Read on to the end: from the spill the first version's rows, from the text the
            // other version's after the pieces parsed ahead (the mix the check must catch).
            assert_eq!(got.len(), first.len());
            assert_eq!(got == first, spill);
            let e = src.check().unwrap_err().full_message();
            assert!(
                e.contains("r.csv") && e.contains("changed while it was being read"),
                "{e}"
            );
            assert_eq!(src.rows().count(), 0, "a later pass read rows");
            assert!(src.check().is_err());
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
