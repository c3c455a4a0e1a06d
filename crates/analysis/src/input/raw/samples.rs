//! The one pass structure every raw file (`.cwa`, `.bin`, on disk or held in memory) is read by, and
//! its array sink for callers that want every sample (`wiical.read`): the
//! [`Recording`](crate::Recording) ([`load_raw`](super::load::load_raw)) is the f64 case of
//! the same arrays, the still-epoch table ([`raw_epoch_table`](super::load::raw_epoch_table))
//! a sink fed sample by sample from the same second pass.
//!
//! Two passes: the first ([`plan`]) checks every block and keeps, per block whose samples are
//! kept, its index in the file and its times' span, so that the output's length and each
//! block's rows are known (a `.cwa` file's blocks are only checked, checksum and fields, not
//! decoded); the caller allocates the arrays (the Python package: vectors that numpy then
//! takes over without a copy), and the second ([`RawPlan::fill`]) reads the blocks again, a
//! chunk at a time, each kept block copied into its own rows on all cores. [`read`] of a
//! `.cwa` fuses both in one pass, chunk by chunk (the blocks checked, placed, then decoded
//! straight into the output), into output it allocates at the file's upper bound of samples,
//! and can give the times as block spans ([`Spans`]) instead of a value a sample: the same
//! samples, times, temperatures and notes as the two passes, value for value.
//!
//! The values can be written as f32: every `.cwa` value is exact in f32 (a 16-bit count, or
//! a 10-bit one shifted by at most 3, times a power of two for the accelerometer; the
//! gyroscope's `count / 32768 · 8000 / 2ⁿ` is `count · 125 / 2^(9+n)`, 23 bits of
//! significand; a magnetometer's raw count), and so is its block temperature
//! (`(v·75 − 12800) / 256`, 17 bits). A `.bin` value (a 12-bit count calibrated by the
//! header's gain and offset) and its page temperature are rounded to f32's 24 bits (7 significant digits). Times are f64:
//! seconds since 1970 need its 53 bits to resolve a millisecond.

use super::blocks::{Blocks, Reader};
use super::cwa::{self, Checked, Head, BLOCK_BYTES};
use super::{
    choose_channels, describe, no_data, skip_notes, Block, BlockSpan, GoodBlock, RawFormat, Tally,
    TimePlan,
};
use crate::error::input::InputError;
use crate::error::Result;
use crate::input::columns::LoadOptions;
use crate::input::timecheck::{time_notes_given, TimeSteps, GAP_FACTOR};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// The value types the samples can be written as (f32, f64), cast from the decoder's f64.
pub trait Real: Copy + Send + Sync + Default {
    /// `v` as this type (f32: rounded to nearest).
    fn of(v: f64) -> Self;
}

impl Real for f32 {
    fn of(v: f64) -> Self {
        v as f32
    }
}

impl Real for f64 {
    fn of(v: f64) -> Self {
        v
    }
}

/// A block whose samples are kept: where it is in the file and its samples' times.
#[derive(Debug, Clone, Copy)]
pub(super) struct Kept {
    /// Its index among the file's data blocks (pages).
    index: usize,
    /// Its samples' times.
    pub(super) span: BlockSpan,
}

/// The first pass's state: the blocks counted ([`Tally`]) and their spans as [`TimePlan`]
/// closes them, each with its block's index.
#[derive(Default)]
struct Planner {
    times: TimePlan,
    tally: Tally,
    /// The index of the block [`TimePlan`] holds open.
    open: Option<usize>,
    kept: Vec<Kept>,
    rows: usize,
    left_out: usize,
}

impl Planner {
    /// The next block, decoded (its samples of `nch` channels).
    fn block(&mut self, b: &Block, nch: usize) {
        match b {
            Block::Good(g) => self.good(g.index, g.start_s, g.rate_hz, g.len(nch)),
            skipped => self.tally.push(skipped, nch),
        }
    }

    /// The next `.cwa` block, checked only (at `index` in the file).
    fn checked(&mut self, index: usize, c: &Checked) {
        match c {
            Checked::Good(h) => self.good(index, h.start_s, h.rate_hz, h.n),
            Checked::Corrupt => self.tally.push(&Block::Corrupt, 0),
            Checked::Invalid(why) => self.tally.push_invalid(why),
        }
    }

    /// The next readable block: counted, its span planned.
    fn good(&mut self, index: usize, start_s: f64, rate_hz: f64, n: usize) {
        self.tally.push_good(n);
        if let Some(closed) = self.times.push(index, start_s, rate_hz, n) {
            self.close(closed);
        }
        self.open = Some(index);
    }

    fn close(&mut self, closed: Option<BlockSpan>) {
        match (closed, self.open) {
            (Some(span), Some(index)) => {
                self.kept.push(Kept { index, span });
                self.rows += span.n as usize;
            }
            _ => self.left_out += 1,
        }
    }

    /// The plan once `reader` has given every block of `blocks`: the channels chosen by
    /// `opts`, then an error for a file without one kept sample.
    fn plan<'a>(
        mut self,
        blocks: Blocks<'a>,
        reader: &Reader<'_>,
        opts: &LoadOptions,
    ) -> Result<RawPlan<'a>> {
        if let Some(closed) = self.times.finish() {
            self.close(closed);
        }
        self.tally.note_ahead(&self.times);
        let channels = reader.channels();
        let cols = choose_channels(&channels, opts)?;
        if self.rows == 0 {
            return Err(no_data(&self.tally, self.left_out).into());
        }
        Ok(RawPlan {
            blocks,
            cols,
            channels,
            tally: self.tally,
            reader_notes: reader.notes(),
            device: reader.device(),
            header_rate_hz: reader.header_rate_hz(),
            kept: self.kept,
            rows: self.rows,
            left_out: self.left_out,
        })
    }
}

/// What the first pass learnt of a raw file: the output's length and where each kept block's
/// samples go.
pub struct RawPlan<'a> {
    blocks: Blocks<'a>,
    /// The chosen channels among the file's.
    pub(super) cols: [usize; 3],
    pub(super) channels: Vec<String>,
    pub(super) tally: Tally,
    reader_notes: Vec<String>,
    device: String,
    pub(super) header_rate_hz: f64,
    pub(super) kept: Vec<Kept>,
    rows: usize,
    pub(super) left_out: usize,
}

/// What the second pass gives besides the arrays: the recording's description.
#[derive(Debug, Clone, PartialEq)]
pub struct RawMeta {
    /// The chosen channels' names (`ax, ay, az`, or the gyroscope's).
    pub columns: [String; 3],
    /// The notes [`load_raw`](super::load::load_raw) gives (skipped blocks, time gaps).
    pub notes: Vec<String>,
    /// The reader's sentence on the file.
    pub info: String,
    /// The samples' rate measured from their times, Hz (as
    /// [`Recording::estimated_rate_hz`](crate::Recording::estimated_rate_hz)).
    pub rate_hz: Option<f64>,
}

/// First pass over a raw file's `blocks`: every block checked and counted, the channels
/// chosen by `opts`. Errors without the file's name (the caller adds it).
pub fn plan<'a>(blocks: Blocks<'a>, opts: &LoadOptions) -> Result<RawPlan<'a>> {
    let mut planner = Planner::default();
    let mut reader = blocks.open()?;
    if let Reader::Cwa(cwa) = &mut reader {
        let mut checked = Vec::new();
        loop {
            checked.clear();
            let (first, more) = cwa.next_bytes(|first, bytes, layout| {
                cwa::each_block(bytes, first, layout, &mut checked, |b, _, l| {
                    cwa::head_block(b, l)
                });
            })?;
            for (k, c) in checked.iter().enumerate() {
                planner.checked(first + k, c);
            }
            if !more {
                break;
            }
        }
    } else {
        reader.for_each_chunk(|reader, chunk| {
            // The channel count is the first good block's.
            let nch = reader.channels().len();
            chunk.iter().for_each(|b| planner.block(b, nch));
        })?;
    }
    planner.plan(blocks, &reader, opts)
}

/// One kept block's share of the output: its rows of values, temperatures and times.
struct Rows<'a, T> {
    span: BlockSpan,
    xyz: &'a mut [T],
    temp: &'a mut [T],
    t: &'a mut [f64],
}

/// `out` cut into each kept block's rows (`width` values a row; an empty `out`: empty shares).
fn cut<'a, T>(mut out: &'a mut [T], kept: &[Kept], width: usize) -> Vec<&'a mut [T]> {
    kept.iter()
        .map(|k| {
            let len = if out.is_empty() {
                0
            } else {
                k.span.n as usize * width
            };
            let (mine, rest) = std::mem::take(&mut out).split_at_mut(len);
            out = rest;
            mine
        })
        .collect()
}

impl RawPlan<'_> {
    /// Samples the file holds after the first pass: the rows to allocate.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Second pass: the chosen triplet of every kept sample into `xyz` (`3·rows`, row-major),
    /// its block's temperature (°C) into `temp` (`rows`), and its time (s) into `t` when
    /// given (`rows`), each chunk's blocks copied into their rows on all cores.
    ///
    /// # Panics
    /// When the slices' lengths are not the plan's (a caller's mistake, not the file's).
    pub fn fill<T: Real>(
        &self,
        xyz: &mut [T],
        temp: &mut [T],
        t: Option<&mut [f64]>,
    ) -> Result<RawMeta> {
        assert_eq!(xyz.len(), 3 * self.rows, "xyz holds 3 values a row");
        assert_eq!(temp.len(), self.rows, "temp holds a value a row");
        let t: &mut [f64] = t.unwrap_or_default();
        assert!(t.is_empty() || t.len() == self.rows, "t holds a time a row");
        let with_t = !t.is_empty();
        let mut shares = cut(xyz, &self.kept, 3)
            .into_iter()
            .zip(cut(temp, &self.kept, 1))
            .zip(cut(&mut *t, &self.kept, 1))
            .zip(&self.kept)
            .map(|(((xyz, temp), t), k)| Rows {
                span: k.span,
                xyz,
                temp,
                t,
            });
        let (nch, cols) = (self.channels.len(), self.cols);
        let (mut steps, mut got) = (Vec::with_capacity(self.kept.len()), Vec::new());
        self.pass(|mine| {
            let mine: Vec<_> = mine.into_iter().zip(shares.by_ref()).collect();
            mine.into_par_iter()
                .map(|((g, _), s)| {
                    for (row, out) in g.data.chunks_exact(nch).zip(s.xyz.chunks_exact_mut(3)) {
                        for k in 0..3 {
                            out[k] = T::of(row[cols[k]]);
                        }
                    }
                    s.temp.fill(T::of(g.temp_c));
                    times_into(s.span, s.t)
                })
                .collect_into_vec(&mut got);
            steps.append(&mut got);
        })?;
        Ok(self.meta(Some(&steps), with_t.then_some(&*t)))
    }

    /// Every kept sample's time into `t` when given (`rows`), each block's on all cores; the
    /// blocks' steps.
    fn times_into(&self, t: Option<&mut [f64]>) -> Vec<Steps> {
        let t: &mut [f64] = t.unwrap_or_default();
        cut(t, &self.kept, 1)
            .into_par_iter()
            .zip(self.kept.par_iter())
            .with_min_len(64)
            .map(|(t, k)| times_into(k.span, t))
            .collect()
    }

    /// The second pass: the blocks read again a chunk at a time, each chunk's kept blocks
    /// (decoded) with their plan given to `each` in file order; an error, naming the block,
    /// when one is no longer the block the first pass kept (the file changed in between).
    pub(super) fn pass(&self, mut each: impl FnMut(Vec<(&GoodBlock, Kept)>)) -> Result<()> {
        let mut reader = self.blocks.open()?;
        let mut kept = self.kept.iter().peekable();
        let nch = self.channels.len();
        let mut changed = None;
        reader.for_each_chunk(|_, chunk| {
            let mut mine = Vec::new();
            for b in chunk {
                let Block::Good(g) = b else { continue };
                if let Some(&k) = kept.next_if(|k| k.index == g.index) {
                    if g.len(nch) == k.span.n as usize && g.start_s == k.span.start_s {
                        mine.push((g, k));
                    } else {
                        changed.get_or_insert(k.index);
                    }
                }
            }
            each(mine);
        })?;
        let Some(index) = changed.or_else(|| kept.next().map(|k| k.index)) else {
            return Ok(());
        };
        let (format, why) = match self.blocks.format() {
            RawFormat::Cwa => ("Axivity .cwa", format!("data block #{index} changed")),
            RawFormat::GeneActiv => ("GENEActiv .bin", "its pages changed".into()),
        };
        let why = format!("{why} while the file was read (is it still being written?)");
        Err(InputError::RawHeader { format, why }.into())
    }

    /// The notes, description and rate, as [`load_raw`](super::load::load_raw) computes
    /// them: the times' summary from the blocks' `steps` (else, without them or when a
    /// block's steps were too varied to count, from the times `t` when they were written, or
    /// regenerated from the spans), the times themselves only to list gaps.
    pub(super) fn meta(&self, steps: Option<&[Steps]>, t: Option<&[f64]>) -> RawMeta {
        let format = self.blocks.format();
        let mut notes = skip_notes(format, &self.reader_notes, &self.tally, self.left_out);
        let regenerated = || self.kept.iter().flat_map(|k| k.span.times());
        let summary = steps
            .and_then(|s| self.time_steps(s))
            .unwrap_or_else(|| match t {
                Some(t) => TimeSteps::of(t),
                None => TimeSteps::of_times(regenerated),
            });
        // Without gaps or repeated times the notes' own pass over the times finds nothing.
        let quiet = summary.is_none_or(|s| s.gaps == 0 && s.repeats == 0);
        if !quiet {
            notes.extend(match t {
                Some(t) => time_notes_given("time", summary, || t.iter().copied()),
                None => time_notes_given("time", summary, regenerated),
            });
        }
        RawMeta {
            columns: self.cols.map(|c| self.channels[c].clone()),
            notes,
            info: describe(
                format,
                &self.device,
                self.tally.blocks,
                self.header_rate_hz,
                &self.channels,
            ),
            rate_hz: summary.map(|s| s.rate_hz()),
        }
    }

    /// [`TimeSteps::of`] the kept samples' times from each block's distinct steps and the
    /// steps between blocks, exactly (the median selected among the distinct steps by their
    /// counts); `None` when a block's steps were too varied to be counted.
    fn time_steps(&self, steps: &[Steps]) -> Option<Option<TimeSteps>> {
        if steps.iter().any(|s| s.overflow) {
            return None;
        }
        let mut all: Vec<(f64, usize)> = self
            .step_counts(steps)
            .into_iter()
            .map(|(bits, c)| (f64::from_bits(bits), c))
            .collect();
        let pairs: usize = all.iter().map(|e| e.1).sum();
        all.retain(|e| e.0 > 0.0);
        let positive: usize = all.iter().map(|e| e.1).sum();
        if pairs < 2 || positive == 0 {
            return Some(None);
        }
        // Positive floats order as their bits; `total_cmp` is that order.
        all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut k = positive / 2;
        let median_s = all
            .iter()
            .find(|e| {
                let here = k < e.1;
                k = k.saturating_sub(e.1);
                here
            })
            .map_or(f64::NAN, |e| e.0);
        if !(median_s.is_finite() && median_s > 0.0) {
            return Some(None);
        }
        let (first, last) = (self.kept.first()?.span, self.kept.last()?.span);
        Some(Some(TimeSteps {
            median_s,
            mean_s: (last.time(last.n - 1) - first.time(0)) / pairs as f64,
            gaps: all
                .iter()
                .filter(|e| e.0 > GAP_FACTOR * median_s)
                .map(|e| e.1)
                .sum(),
            steps: pairs,
            repeats: pairs - positive,
        }))
    }
}

impl RawPlan<'_> {
    /// How often each distinct step between consecutive kept times occurs (keyed by its
    /// bits), the blocks' own steps and those between blocks, counted on all cores: a few
    /// distinct values however long the file, where listing every block's (four a block) and
    /// sorting them took a serial tenth of a second for a week of wear.
    fn step_counts(&self, steps: &[Steps]) -> HashMap<u64, usize> {
        let add = |mut m: HashMap<u64, usize>, (d, c): (f64, usize)| {
            *m.entry(d.to_bits()).or_default() += c;
            m
        };
        steps
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .fold(HashMap::new, |mut m, (k, s)| {
                for &(d, c) in &s.vals[..s.len] {
                    m = add(m, (d, c as usize));
                }
                if k > 0 {
                    let (a, b) = (self.kept[k - 1].span, self.kept[k].span);
                    m = add(m, (b.time(0) - a.time(a.n - 1), 1));
                }
                m
            })
            .reduce(HashMap::new, |a, b| {
                b.into_iter()
                    .fold(a, |m, (bits, c)| add(m, (f64::from_bits(bits), c)))
            })
    }
}

/// A block's steps between consecutive times: the distinct ones (at most four; rounding
/// makes two or three of a block's even spacing) and how often each occurs.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Steps {
    vals: [(f64, u32); 4],
    len: usize,
    /// More than four distinct steps: not counted.
    overflow: bool,
}

impl Steps {
    /// Counts the steps `ds` as pushing them one by one would: each stored step's count
    /// first, then each new one's, in the order they first occur. Each count is one pass
    /// over the run comparing bits (it vectorises); a block has two or three distinct steps,
    /// which alternate too unpredictably for a branch a step.
    fn push_all(&mut self, ds: &[f64]) {
        let count = |bits: u64| ds.iter().map(|d| u32::from(d.to_bits() == bits)).sum();
        let mut counted = 0;
        for e in &mut self.vals[..self.len] {
            let c: u32 = count(e.0.to_bits());
            e.1 += c;
            counted += c as usize;
        }
        while counted < ds.len() {
            let stored = &self.vals[..self.len];
            let new = ds
                .iter()
                .find(|d| stored.iter().all(|e| e.0.to_bits() != d.to_bits()));
            let Some(&d) = new else { break };
            if self.len == self.vals.len() {
                self.overflow = true;
                break;
            }
            let c: u32 = count(d.to_bits());
            self.vals[self.len] = (d, c);
            self.len += 1;
            counted += c as usize;
        }
    }
}

/// A block's sample times into `t` (nothing stored when `t` is empty: times not asked for);
/// the steps between them. The times are computed a run at a time into a slice of their own
/// (`t`'s, or a local one), each as [`BlockSpan::time`] computes it, then their steps, then
/// the steps counted: three loops that vectorise, where one loop doing all three did not.
fn times_into(span: BlockSpan, t: &mut [f64]) -> Steps {
    const RUN: usize = 128;
    let mut steps = Steps::default();
    let (mut local, mut ds) = ([0.0; RUN], [0.0; RUN]);
    let n = span.n as usize;
    let mut prev = None;
    let mut at = 0;
    while at < n {
        let len = (n - at).min(RUN);
        let out = match t.get_mut(at..at + len) {
            Some(mine) => mine,
            None => &mut local[..len],
        };
        for (j, o) in out.iter_mut().enumerate() {
            // `at + j < n ≤ u32::MAX`: the index is exact as u32, as `time` takes it.
            *o = span.time((at + j) as u32);
        }
        let mut k = 0;
        if let Some(p) = prev {
            ds[0] = out[0] - p;
            k = 1;
        }
        for (d, w) in ds[k..].iter_mut().zip(out.windows(2)) {
            *d = w[1] - w[0];
        }
        steps.push_all(&ds[..k + len - 1]);
        prev = Some(out[len - 1]);
        at += len;
    }
    steps
}

/// How [`read`] gives the samples' times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Times {
    /// Not at all (the notes and the rate are still computed from them).
    Omit,
    /// One f64 a sample.
    Full,
    /// Each kept block's start, duration and rows ([`Spans`]), a few bytes a block instead of
    /// 8 a sample; [`Spans::times_into`] expands them into the same f64 values.
    Spans,
}

/// The samples' times as each kept block's span: sample `i` of block `k` (row `rows[k] + i`,
/// of `n = rows[k + 1] − rows[k]`) at `start_s[k] + i · dur_s[k] / n` seconds, evaluated in
/// that order in f64 (the block's `n / dur_s[k]` is its rate, Hz, as the device's own clock
/// sets it: see [`TimePlan`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Spans {
    /// Each block's first sample's time, s.
    pub start_s: Vec<f64>,
    /// The time each block's samples are spread over, s.
    pub dur_s: Vec<f64>,
    /// The blocks' first rows, and the row count last (one more than the blocks).
    pub rows: Vec<u64>,
}

impl Spans {
    fn of(kept: &[Kept]) -> Self {
        let mut rows = Vec::with_capacity(kept.len() + 1);
        let mut row = 0u64;
        rows.push(row);
        for k in kept {
            row += u64::from(k.span.n);
            rows.push(row);
        }
        Self {
            start_s: kept.iter().map(|k| k.span.start_s).collect(),
            dur_s: kept.iter().map(|k| k.span.dur).collect(),
            rows,
        }
    }

    /// Every sample's time into `t` (as many as the last row), the value [`Times::Full`]
    /// gives bit for bit, on all cores; `None` when the spans are inconsistent (rows not
    /// increasing, a block of more than `u32::MAX` samples, lengths that differ, `t` of
    /// another length).
    pub fn times_into(&self, t: &mut [f64]) -> Option<()> {
        let k = self.start_s.len();
        if self.dur_s.len() != k || self.rows.len() != k + 1 || self.rows[k] != t.len() as u64 {
            return None;
        }
        let mut jobs = Vec::with_capacity(k);
        let mut rest = t;
        for j in 0..k {
            let n = self.rows[j + 1].checked_sub(self.rows[j])?;
            let n32 = u32::try_from(n).ok()?;
            let (mine, more) = std::mem::take(&mut rest).split_at_mut_checked(n as usize)?;
            rest = more;
            let span = BlockSpan {
                start_s: self.start_s[j],
                dur: self.dur_s[j],
                n: n32,
            };
            jobs.push((span, mine));
        }
        jobs.into_par_iter().for_each(|(span, t)| {
            for (i, o) in t.iter_mut().enumerate() {
                *o = span.time(i as u32);
            }
        });
        Some(())
    }
}

/// Every sample of a raw file as [`read`] gives them: the chosen triplet (`3·rows`,
/// row-major), the block temperature (°C), the times as asked, the description.
#[derive(Debug, Clone)]
pub struct Samples<T> {
    /// Three values a row.
    pub xyz: Vec<T>,
    /// The block's temperature, °C, a row.
    pub temp: Vec<T>,
    /// The times, s, a row ([`Times::Full`]).
    pub t: Option<Vec<f64>>,
    /// The times as block spans ([`Times::Spans`]).
    pub spans: Option<Spans>,
    /// The notes, columns, rate and description.
    pub meta: RawMeta,
}

/// Every sample of the raw file at `path` (in `format`) into vectors allocated once, the
/// values [`plan`] and [`RawPlan::fill`] give. A `.cwa` is read in one pass: each chunk's
/// blocks checked on all cores, their places set in file order, then decoded on all cores
/// straight into the output, which is allocated zeroed at the file's upper bound of samples
/// (its blocks times the most a block of its layout holds: pages never written are never
/// touched, and the vectors are cut to the samples found). A `.bin` is read in the two
/// passes. Errors as [`plan`]'s.
pub fn read<T: Real>(
    path: &Path,
    format: RawFormat,
    opts: &LoadOptions,
    times: Times,
) -> Result<Samples<T>> {
    read_from(path, format, None, opts, times)
}

/// [`read`] of the `.cwa` file at `path` whose bytes are `bytes` (the caller's mapping of
/// it: its blocks are decoded where they lie, not copied into a buffer first); the same
/// samples, times, notes and errors as [`read`] of the file. The bytes must not change while
/// they are read (a mapped file cut short meanwhile is the caller's to guard against).
pub fn read_cwa_bytes<T: Real>(
    path: &Path,
    bytes: cwa::Bytes,
    opts: &LoadOptions,
    times: Times,
) -> Result<Samples<T>> {
    read_from(path, RawFormat::Cwa, Some(bytes), opts, times)
}

/// [`read`], a `.cwa` from `bytes` when given.
fn read_from<T: Real>(
    path: &Path,
    format: RawFormat,
    bytes: Option<cwa::Bytes>,
    opts: &LoadOptions,
    times: Times,
) -> Result<Samples<T>> {
    let full = times == Times::Full;
    let (plan, xyz, temp, t, meta) = match format {
        RawFormat::Cwa => {
            let reader = match bytes {
                Some(b) => cwa::BlockReader::of_bytes(path, b)?,
                None => cwa::BlockReader::open(path)?,
            };
            let (plan, xyz, temp) = Sweep::run(reader, path, opts)?;
            let mut t = full.then(|| vec![0.0; plan.rows]);
            let steps = plan.times_into(t.as_deref_mut());
            let meta = plan.meta(Some(&steps), t.as_deref());
            (plan, xyz, temp, t, meta)
        }
        RawFormat::GeneActiv => {
            let plan = plan(Blocks::File(path, format), opts)?;
            let n = plan.rows;
            let (mut xyz, mut temp) = (vec![T::default(); 3 * n], vec![T::default(); n]);
            let mut t = full.then(|| vec![0.0; n]);
            let meta = plan.fill(&mut xyz, &mut temp, t.as_deref_mut())?;
            (plan, xyz, temp, t, meta)
        }
    };
    Ok(Samples {
        xyz,
        temp,
        t,
        spans: (times == Times::Spans).then(|| Spans::of(&plan.kept)),
        meta,
    })
}

/// One pass over a `.cwa`: the first pass's planning and the second's decoding per chunk.
struct Sweep<T> {
    planner: Planner,
    /// The chosen channels, once the layout is known.
    cols: Option<[usize; 3]>,
    xyz: Vec<T>,
    temp: Vec<T>,
    /// Rows placed so far.
    rows: usize,
    /// Samples of the block placed last (taken back if it turns out to be stamped ahead).
    last_placed: usize,
}

/// A block whose samples are placed: its bytes, fields and rows.
type Job<'a, T> = (&'a [u8], Head, &'a mut [T], &'a mut [T]);

impl<T: Real> Sweep<T> {
    fn run<'a>(
        mut reader: cwa::BlockReader<'_>,
        path: &'a Path,
        opts: &LoadOptions,
    ) -> Result<(RawPlan<'a>, Vec<T>, Vec<T>)> {
        let blocks = reader.data_blocks()?;
        let mut sweep = Self {
            planner: Planner::default(),
            cols: None,
            xyz: Vec::new(),
            temp: Vec::new(),
            rows: 0,
            last_placed: 0,
        };
        let mut checked = Vec::new();
        loop {
            let mut res = Ok(());
            let (_, more) = reader.next_bytes(|first, bytes, layout| {
                res = sweep.chunk(first, bytes, layout, &mut checked, (blocks, opts));
            })?;
            res?;
            if !more {
                break;
            }
        }
        let blocks = Blocks::File(path, RawFormat::Cwa);
        let plan = sweep.planner.plan(blocks, &Reader::Cwa(reader), opts)?;
        debug_assert_eq!(plan.rows, sweep.rows, "every kept block placed");
        sweep.xyz.truncate(3 * plan.rows);
        sweep.temp.truncate(plan.rows);
        Ok((plan, sweep.xyz, sweep.temp))
    }

    /// One chunk's blocks (the first at index `first`): checked on all cores, counted and
    /// planned in order, the kept ones decoded on all cores into their rows. `size`: the
    /// file's data blocks when opened, and the options choosing the channels.
    fn chunk(
        &mut self,
        first: usize,
        bytes: &[u8],
        layout: &mut Option<(u8, bool)>,
        checked: &mut Vec<Checked>,
        (blocks, opts): (usize, &LoadOptions),
    ) -> Result<()> {
        checked.clear();
        cwa::each_block(bytes, first, layout, checked, |b, _, l| {
            cwa::head_block(b, l)
        });
        let mut placed = Vec::new();
        for (k, c) in checked.iter().enumerate() {
            let ahead = self.planner.times.ahead;
            self.planner.checked(first + k, c);
            let Checked::Good(h) = c else { continue };
            if self.planner.times.ahead > ahead {
                // The block placed last stands ahead of this one: its rows are given back (in
                // this chunk, before they are placed; else they are written over by the blocks
                // that follow).
                if placed.pop().is_none() {
                    self.rows -= self.last_placed;
                }
            }
            if self.planner.times.keeps_pending() {
                placed.push((k, *h));
            }
        }
        let (Some(l), false) = (*layout, placed.is_empty()) else {
            return Ok(());
        };
        let cols = match self.cols {
            Some(c) => c,
            None => self.allocate(l, blocks, opts)?,
        };
        let jobs = self.place(bytes, placed)?;
        jobs.into_par_iter().for_each(|(b, h, xyz, temp)| {
            h.samples_into(b, cols, T::of, xyz);
            temp.fill(T::of(Head::temp_c(b)));
        });
        Ok(())
    }

    /// The output at the file's upper bound of samples (zeroed: untouched pages cost
    /// nothing), once the first good block fixed the layout; the chosen channels.
    fn allocate(
        &mut self,
        layout: (u8, bool),
        blocks: usize,
        opts: &LoadOptions,
    ) -> Result<[usize; 3]> {
        let cols = choose_channels(&cwa::channel_names(Some(layout)), opts)?;
        let cap = blocks.saturating_mul(cwa::max_samples(layout));
        self.xyz = vec![T::default(); cap.saturating_mul(3)];
        self.temp = vec![T::default(); cap];
        self.cols = Some(cols);
        Ok(cols)
    }

    /// The rows of each placed block (`(k, head)`: its position in `bytes`), in order.
    fn place<'a>(
        &'a mut self,
        bytes: &'a [u8],
        placed: Vec<(usize, Head)>,
    ) -> Result<Vec<Job<'a, T>>> {
        let mut xyz = self.xyz.get_mut(3 * self.rows..).unwrap_or_default();
        let mut temp = self.temp.get_mut(self.rows..).unwrap_or_default();
        let mut jobs = Vec::with_capacity(placed.len());
        for (k, h) in placed {
            if temp.len() < h.n {
                return Err(InputError::RawHeader {
                    format: "Axivity .cwa",
                    why: "it grew while it was read (is it still being written?)".into(),
                }
                .into());
            }
            let (x, more_x) = std::mem::take(&mut xyz).split_at_mut(3 * h.n);
            let (t, more_t) = std::mem::take(&mut temp).split_at_mut(h.n);
            (xyz, temp) = (more_x, more_t);
            self.rows += h.n;
            self.last_placed = h.n;
            jobs.push((&bytes[k * BLOCK_BYTES..(k + 1) * BLOCK_BYTES], h, x, t));
        }
        Ok(jobs)
    }
}
