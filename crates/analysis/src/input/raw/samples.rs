//! Every sample of a raw file (`.cwa`, `.bin`) written once into arrays the caller allocates,
//! for callers that want them all (`wiical.read`): the [`Recording`](crate::Recording) path
//! ([`load_raw`](super::stream::load_raw)) pushes rows of f64 one by one, 40 bytes a sample with
//! the time and the temperature, which for a week of wear is gigabytes of memory written in
//! order on one core.
//!
//! Two passes, as [`super::stream`]: the first ([`plan`]) checks every block and keeps, per
//! block whose samples are kept, its index in the file and its times' span, so that the
//! output's length and each block's rows are known; the caller allocates the arrays (the
//! Python package: vectors that numpy then takes over without a copy), and the second
//! ([`RawPlan::fill`]) decodes the blocks again, each into its own rows, on all cores. A
//! `.cwa` block's first pass only checks it (checksum and fields), its samples are decoded
//! once, straight into the output. The samples, times, temperatures and notes are the ones
//! [`load_raw`](super::stream::load_raw) gives, value for value.
//!
//! The values can be written as f32: every `.cwa` value is exact in f32 (a 16-bit count, or
//! a 10-bit one shifted by at most 3, times a power of two for the accelerometer; the
//! gyroscope's `count / 32768 · 8000 / 2ⁿ` is `count · 125 / 2^(9+n)`, 23 bits of
//! significand; a magnetometer's raw count), and so is its block temperature
//! (`(v·75 − 12800) / 256`, 17 bits). A `.bin` value (a 12-bit count calibrated by the
//! header's gain and offset) and its page temperature are rounded to f32's 24 bits (7 significant digits). Times are f64:
//! seconds since 1970 need its 53 bits to resolve a millisecond.

use super::cwa::{self, Checked, Head, BLOCK_BYTES};
use super::stream::Reader;
use super::{
    choose_channels, describe, no_data, skip_notes, Block, BlockSpan, RawFormat, Tally, TimePlan,
};
use crate::error::input::InputError;
use crate::error::Result;
use crate::input::columns::LoadOptions;
use crate::input::timecheck::{time_notes_given, TimeSteps, GAP_FACTOR};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The value types the samples can be written as (f32, f64), cast from the decoder's f64.
pub trait Real: Copy + Send + Sync {
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
struct Kept {
    /// Its index among the file's data blocks (pages).
    index: usize,
    /// Its samples' times.
    span: BlockSpan,
}

/// The blocks' spans as [`TimePlan`] closes them, each with its block's index.
#[derive(Default)]
struct Planner {
    times: TimePlan,
    /// The index of the block [`TimePlan`] holds open.
    open: Option<usize>,
    kept: Vec<Kept>,
    rows: usize,
    left_out: usize,
}

impl Planner {
    /// The next decoded block.
    fn push(&mut self, index: usize, start_s: f64, rate_hz: f64, n: usize) {
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

    fn finish(&mut self) {
        if let Some(closed) = self.times.finish() {
            self.close(closed);
        }
    }
}

/// What the first pass learnt of a raw file: the output's length and where each kept block's
/// samples go.
pub struct RawPlan {
    path: PathBuf,
    format: RawFormat,
    /// The chosen channels among the file's.
    cols: [usize; 3],
    channels: Vec<String>,
    /// The `.cwa` channel layout (channels, packed).
    layout: Option<(u8, bool)>,
    tally: Tally,
    reader_notes: Vec<String>,
    device: String,
    header_rate_hz: f64,
    kept: Vec<Kept>,
    rows: usize,
    left_out: usize,
}

/// What the second pass gives besides the arrays: the recording's description.
#[derive(Debug, Clone, PartialEq)]
pub struct RawMeta {
    /// The chosen channels' names (`ax, ay, az`, or the gyroscope's).
    pub columns: [String; 3],
    /// The notes [`load_raw`](super::stream::load_raw) gives (skipped blocks, time gaps).
    pub notes: Vec<String>,
    /// The reader's sentence on the file.
    pub info: String,
    /// The samples' rate measured from their times, Hz (as
    /// [`Recording::estimated_rate_hz`](crate::Recording::estimated_rate_hz)).
    pub rate_hz: Option<f64>,
}

/// First pass over the raw file at `path` (in `format`, see
/// [`raw_file_format`](super::stream::raw_file_format)): every block checked and counted,
/// the channels chosen by `opts`. Errors as [`load_raw`](super::stream::load_raw)'s (without
/// the file's name: the caller adds it).
pub fn plan(path: &Path, format: RawFormat, opts: &LoadOptions) -> Result<RawPlan> {
    let mut planner = Planner::default();
    let mut tally = Tally::default();
    let mut reader = Reader::open(path, format)?;
    let mut layout = None;
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
                match c {
                    Checked::Good(h) => {
                        tally.push_good(h.n);
                        planner.push(first + k, h.start_s, h.rate_hz, h.n);
                    }
                    Checked::Corrupt => tally.push(&Block::Corrupt, 0),
                    Checked::Invalid(why) => tally.push_invalid(why),
                }
            }
            if !more {
                break;
            }
        }
        layout = cwa.layout();
    } else {
        reader.for_each_chunk(|reader, chunk| {
            let nch = reader.channels().len();
            for b in chunk {
                tally.push(b, nch);
                if let Block::Good(g) = b {
                    planner.push(g.index, g.start_s, g.rate_hz, g.len(nch));
                }
            }
        })?;
    }
    planner.finish();
    let channels = reader.channels();
    let cols = choose_channels(&channels, opts)?;
    if planner.rows == 0 {
        return Err(no_data(&tally, planner.left_out).into());
    }
    Ok(RawPlan {
        path: path.into(),
        format,
        cols,
        layout,
        tally,
        reader_notes: reader.notes(),
        device: reader.device(),
        header_rate_hz: reader.header_rate_hz(),
        channels,
        kept: planner.kept,
        rows: planner.rows,
        left_out: planner.left_out,
    })
}

/// One kept block's share of the output: its rows of values, temperatures and times.
struct Rows<'a, T> {
    kept: Kept,
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

impl RawPlan {
    /// Samples the file holds after the first pass: the rows to allocate.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Second pass: the chosen triplet of every kept sample into `xyz` (`3·rows`, row-major),
    /// its block's temperature (°C) into `temp` (`rows`), and its time (s) into `t` when
    /// given (`rows`), each block's rows decoded on all cores.
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
        let shares: Vec<Rows<'_, T>> = cut(xyz, &self.kept, 3)
            .into_iter()
            .zip(cut(temp, &self.kept, 1))
            .zip(cut(&mut *t, &self.kept, 1))
            .zip(&self.kept)
            .map(|(((xyz, temp), t), &kept)| Rows { kept, xyz, temp, t })
            .collect();
        let steps = match self.format {
            RawFormat::Cwa => self.fill_cwa(shares)?,
            RawFormat::GeneActiv => self.fill_pages(shares)?,
        };
        Ok(self.meta(&steps, with_t.then_some(&*t)))
    }

    /// The `.cwa` blocks read again a chunk at a time, each kept one decoded into its rows.
    fn fill_cwa<T: Real>(&self, shares: Vec<Rows<'_, T>>) -> Result<Vec<Steps>> {
        let mut reader = cwa::BlockReader::open(&self.path)?;
        let mut shares = shares.into_iter().peekable();
        let layout = self.layout;
        let changed = |index: usize| InputError::RawHeader {
            format: "Axivity .cwa",
            why: format!(
                "data block #{index} changed while the file was read (is it still being written?)"
            ),
        };
        let mut steps = Vec::with_capacity(self.kept.len());
        loop {
            let mut mine = Vec::new();
            let mut got = Vec::new();
            let (_, more) = reader.next_bytes(|first, bytes, _| {
                let end = first + bytes.len() / BLOCK_BYTES;
                while let Some(s) = shares.next_if(|s| s.kept.index < end) {
                    mine.push(s);
                }
                mine.par_iter_mut()
                    .map(|s| {
                        let at = (s.kept.index - first) * BLOCK_BYTES;
                        decode_into(&bytes[at..at + BLOCK_BYTES], layout, self.cols, s)
                            .map_err(|()| s.kept.index)
                    })
                    .collect_into_vec(&mut got);
            })?;
            for r in got {
                steps.push(r.map_err(changed)?);
            }
            if !more {
                return match shares.next() {
                    Some(s) => Err(changed(s.kept.index).into()),
                    None => Ok(steps),
                };
            }
        }
    }

    /// The `.bin` pages read again a chunk at a time (decoded by the page reader), each kept
    /// one's values copied into its rows.
    fn fill_pages<T: Real>(&self, shares: Vec<Rows<'_, T>>) -> Result<Vec<Steps>> {
        let mut reader = Reader::open(&self.path, self.format)?;
        let mut shares = shares.into_iter().peekable();
        let nch = self.channels.len();
        let cols = self.cols;
        let mut steps = Vec::with_capacity(self.kept.len());
        let mut got = Vec::new();
        reader.for_each_chunk(|_, chunk| {
            let mut mine = Vec::new();
            for b in chunk {
                let Block::Good(g) = b else { continue };
                if let Some(s) = shares.next_if(|s| s.kept.index == g.index) {
                    mine.push((g, s));
                }
            }
            mine.par_iter_mut()
                .map(|(g, s)| {
                    for (row, out) in g.data.chunks_exact(nch).zip(s.xyz.chunks_exact_mut(3)) {
                        for k in 0..3 {
                            out[k] = T::of(row[cols[k]]);
                        }
                    }
                    s.temp.fill(T::of(g.temp_c));
                    times_into(s.kept.span, s.t)
                })
                .collect_into_vec(&mut got);
            steps.append(&mut got);
        })?;
        if steps.len() != self.kept.len() {
            return Err(InputError::RawHeader {
                format: "GENEActiv .bin",
                why: "its pages changed while the file was read (is it still being written?)"
                    .into(),
            }
            .into());
        }
        Ok(steps)
    }

    /// The notes, description and rate, as [`load_raw`](super::stream::load_raw) computes
    /// them: the times' summary from the blocks' `steps` (else, when a block's steps were too
    /// varied to count, from the times `t` when they were written, or regenerated from the
    /// spans), the times themselves only to list gaps.
    fn meta(&self, steps: &[Steps], t: Option<&[f64]>) -> RawMeta {
        let mut notes = skip_notes(self.format, &self.reader_notes, &self.tally, self.left_out);
        let regenerated = || self.kept.iter().flat_map(|k| k.span.times());
        let summary = self.time_steps(steps).unwrap_or_else(|| match t {
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
                self.format,
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
        let mut all: Vec<(f64, usize)> = Vec::with_capacity(4 * steps.len());
        for (k, s) in steps.iter().enumerate() {
            if s.overflow {
                return None;
            }
            all.extend(s.vals[..s.len].iter().map(|&(d, c)| (d, c as usize)));
            if k > 0 {
                let (a, b) = (self.kept[k - 1].span, self.kept[k].span);
                all.push((b.time(0) - a.time(a.n - 1), 1));
            }
        }
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

/// A block's steps between consecutive times: the distinct ones (at most four; rounding
/// makes two or three of a block's even spacing) and how often each occurs.
#[derive(Debug, Clone, Copy, Default)]
struct Steps {
    vals: [(f64, u32); 4],
    len: usize,
    /// More than four distinct steps: not counted.
    overflow: bool,
}

impl Steps {
    fn push(&mut self, d: f64) {
        if let Some(e) = self.vals[..self.len]
            .iter_mut()
            .find(|e| e.0.to_bits() == d.to_bits())
        {
            e.1 += 1;
        } else if self.len < self.vals.len() {
            self.vals[self.len] = (d, 1);
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }
}

/// One `.cwa` block's samples, temperature and times into its rows; `Err` when the block is
/// no longer the one the first pass kept (its fields or sample count changed).
fn decode_into<T: Real>(
    b: &[u8],
    layout: Option<(u8, bool)>,
    cols: [usize; 3],
    s: &mut Rows<'_, T>,
) -> std::result::Result<Steps, ()> {
    let head = match cwa::head_block(b, &mut { layout }) {
        Checked::Good(h) if h.n == s.kept.span.n as usize && h.start_s == s.kept.span.start_s => h,
        _ => return Err(()),
    };
    head.samples_into(b, cols, T::of, s.xyz);
    s.temp.fill(T::of(Head::temp_c(b)));
    Ok(times_into(s.kept.span, s.t))
}

/// A block's sample times into `t` (nothing stored when `t` is empty: times not asked for);
/// the steps between them.
fn times_into(span: BlockSpan, t: &mut [f64]) -> Steps {
    let mut steps = Steps::default();
    let mut prev = span.time(0);
    if let Some(first) = t.first_mut() {
        *first = prev;
    }
    for i in 1..span.n {
        let ti = span.time(i);
        steps.push(ti - prev);
        prev = ti;
        if let Some(o) = t.get_mut(i as usize) {
            *o = ti;
        }
    }
    steps
}
