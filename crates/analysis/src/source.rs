//! The one way a pipeline reads a recording's samples: [`SampleSource`], in order and as often
//! as it needs, whether they are held in memory (a slice) or read again from a large file in
//! passes ([`TextSource`]); [`RowSource`], the rows with their time and temperature as the
//! window detection, `magfit` and `gyrofit` read them (a window's rows read where they are
//! kept besides). A fold written against them is the held and the large-file path at once, so the
//! two cannot drift apart.

use crate::detect::detector::all_whole;
use crate::input::recording::Recording;
use crate::input::sample_summary::{Distinct, SummaryFold};
use crate::input::text_source::{Columns, Row, TextSource, Want};
use crate::input::timecheck::TimeSteps;

/// Samples read in passes: a held recording's, or a large file's rows.
pub trait SampleSource {
    /// Calls `f` with every sample in order; a file's error (changed, unreadable) ends it.
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()>;
}

impl SampleSource for [[f64; 3]] {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.iter().for_each(f);
        Ok(())
    }
}

impl SampleSource for Vec<[f64; 3]> {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.as_slice().each(f)
    }
}

impl SampleSource for Recording {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.xyz.each(f)
    }
}

impl SampleSource for TextSource {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.rows().for_each(|r| f(&r.xyz));
        self.check()
    }
}

/// A recording's rows as the static-window detection ([`crate::detect::windows`]), `magfit`
/// ([`crate::magnetometer::pass`]) and `gyrofit` ([`crate::gyro`]) read them, whether held in
/// memory or a large file read in passes ([`TextSource`]): each is written once against it,
/// and a held recording is the case of one chunk in place (its passes read its slices; a
/// window's rows are a slice of them).
///
/// A file's pass may end early (changed, unreadable): the reader then goes on with what it
/// read, and [`RowSource::check`] after it says so.
pub trait RowSource: Sync {
    /// A pass over every row.
    type Rows<'a>: Iterator<Item = Row> + Clone
    where
        Self: 'a;
    /// A fresh pass.
    fn rows(&self) -> Self::Rows<'_>;
    /// Rows.
    fn len(&self) -> usize;
    /// No rows.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The first failure of a pass (a file changed or unreadable), asked after it: held rows
    /// never fail.
    fn check(&self) -> crate::Result<()> {
        Ok(())
    }
    /// The names of the axes' columns (a field's unit is read off them).
    fn axis_columns(&self) -> &[String; 3];
    /// Every value a whole number (raw counts: levels of their own, ADC limits inferred).
    fn integer(&self) -> bool;
    /// The sample rate from the metadata, else the time column (`Recording::estimated_rate_hz`).
    fn estimated_rate_hz(&self) -> Option<f64>;
    /// The metadata's sample rate alone (`Fs`, Hz): the clock of rows without a time column.
    fn metadata_rate_hz(&self) -> Option<f64>;
    /// The rows carry a time (the file has a time column).
    fn has_time(&self) -> bool;
    /// The file has a temperature column.
    fn has_temp(&self) -> bool;
    /// The time column's first and last values (`None` without one).
    fn time_ends(&self) -> (Option<f64>, Option<f64>);
    /// The time column's steps (`None` without a time column or a usable step).
    fn time_steps(&self) -> Option<TimeSteps>;
    /// Per axis, one value on every row (all compare equal: `−0` and `0` do, NaN does not),
    /// when known without a pass (a file's first pass): held rows say `None`.
    fn constant(&self) -> Option<[bool; 3]> {
        None
    }
    /// The smallest and the largest value of any axis (asked of whole numbers only).
    fn extremes(&self) -> (f64, f64);
    /// Each axis's distinct values, ascending (`total_cmp`, deduplicated); `None` when an
    /// axis has more than [`crate::input::sample_summary::MAX_DISTINCT`] (no lattice).
    fn distinct(&self) -> Option<[Vec<f64>; 3]>;
    /// Every row's values in place, when held.
    fn held(&self) -> Option<&[[f64; 3]]> {
        None
    }
    /// Every row's values as `f32` in place, in pieces (a spill in memory of `f32` axes).
    fn f32_in_place(&self) -> Option<Vec<&[[f32; 3]]>> {
        None
    }
    /// A pass over the values a piece at a time (`f` stops it by returning `false`): held,
    /// one piece.
    fn each_piece(&self, f: &mut dyn FnMut(&[[f64; 3]]) -> bool) {
        f(self.held().unwrap_or(&[]));
    }
    /// A pass over the values as `f32` a piece at a time (`f` stops it by returning `false`).
    fn each_piece_f32(&self, f: &mut dyn FnMut(&[[f32; 3]]) -> bool) {
        self.each_piece(&mut |xyz| f(&xyz.iter().map(|s| s.map(|v| v as f32)).collect::<Vec<_>>()));
    }
    /// Rows `from..to`, or their first part, read where they are kept (`buf` holds them when
    /// not in place); `None` when the read failed (which [`RowSource::check`] then says).
    fn span<'a>(&'a self, from_to: (usize, usize), buf: &'a mut RowBuf) -> Option<RowChunk<'a>>;
}

/// Consecutive rows read by [`RowSource::span`].
#[derive(Clone, Copy)]
pub struct RowChunk<'a> {
    /// x, y, z.
    pub xyz: &'a [[f64; 3]],
    /// Times, when there is a time column.
    pub t: Option<&'a [f64]>,
    /// Temperatures, when there is a temperature column.
    pub temp: Option<&'a [f64]>,
}

/// Where [`RowSource::span`] reads rows that are not in place to.
#[derive(Default)]
pub struct RowBuf {
    cols: Columns,
    scratch: Vec<u8>,
    /// The rows `cols` holds.
    at: Option<(usize, usize)>,
}

/// Rows a file's [`RowSource::span`] reads from its spill at a time.
const SPAN_READ_ROWS: usize = 1 << 16;

impl RowSource for Recording {
    type Rows<'a> = HeldRows<'a>;

    fn rows(&self) -> Self::Rows<'_> {
        HeldRows { rec: self, next: 0 }
    }

    fn len(&self) -> usize {
        self.xyz.len()
    }

    fn axis_columns(&self) -> &[String; 3] {
        &self.axis_columns
    }

    fn integer(&self) -> bool {
        all_whole(&self.xyz)
    }

    fn estimated_rate_hz(&self) -> Option<f64> {
        Recording::estimated_rate_hz(self)
    }

    fn metadata_rate_hz(&self) -> Option<f64> {
        self.sample_rate_hz
    }

    fn has_time(&self) -> bool {
        self.t.is_some()
    }

    fn has_temp(&self) -> bool {
        self.temp.is_some()
    }

    fn time_ends(&self) -> (Option<f64>, Option<f64>) {
        let t = self.t.as_deref().unwrap_or(&[]);
        (t.first().copied(), t.last().copied())
    }

    fn time_steps(&self) -> Option<TimeSteps> {
        TimeSteps::of(self.t.as_deref()?)
    }

    /// On all cores (`min`/`max` do not depend on the order; a `−0` for a `0` compares equal
    /// in the ADC ranges).
    fn extremes(&self) -> (f64, f64) {
        use rayon::prelude::*;
        let none = || (f64::INFINITY, f64::NEG_INFINITY);
        let widen = |(l, h): (f64, f64), v: f64| (l.min(v), h.max(v));
        self.xyz
            .par_iter()
            .fold(none, |lh, s| s.iter().copied().fold(lh, widen))
            .reduce(none, |a, b| (a.0.min(b.0), a.1.max(b.1)))
    }

    /// Sorted on all cores (a sort of values equal under `total_cmp` is the same stable or
    /// not: they are the same bits).
    fn distinct(&self) -> Option<[Vec<f64>; 3]> {
        use crate::input::sample_summary::MAX_DISTINCT;
        use rayon::prelude::*;
        let axis = |a: usize| {
            let mut v: Vec<f64> = self.xyz.par_iter().map(|s| s[a]).collect();
            v.par_sort_unstable_by(f64::total_cmp);
            v.dedup();
            (v.len() <= MAX_DISTINCT).then_some(v)
        };
        Some([axis(0)?, axis(1)?, axis(2)?])
    }

    fn held(&self) -> Option<&[[f64; 3]]> {
        Some(&self.xyz)
    }

    fn span<'a>(&'a self, (s, e): (usize, usize), _: &'a mut RowBuf) -> Option<RowChunk<'a>> {
        Some(RowChunk {
            xyz: self.xyz.get(s..e)?,
            t: self.t.as_deref().map(|t| &t[s..e]),
            temp: self.temp.as_deref().map(|t| &t[s..e]),
        })
    }
}

/// A pass over a held recording's rows ([`RowSource::rows`]).
#[derive(Clone)]
pub struct HeldRows<'a> {
    rec: &'a Recording,
    next: usize,
}

impl Iterator for HeldRows<'_> {
    type Item = Row;

    #[inline]
    fn next(&mut self) -> Option<Row> {
        let i = self.next;
        let xyz = *self.rec.xyz.get(i)?;
        self.next += 1;
        Some(Row {
            t: self.rec.t.as_ref().map(|t| t[i]),
            xyz,
            temp: self.rec.temp.as_ref().map(|t| t[i]),
        })
    }
}

impl RowSource for TextSource {
    type Rows<'a> = crate::input::text_source::Rows<'a>;

    fn rows(&self) -> Self::Rows<'_> {
        TextSource::rows(self)
    }

    fn len(&self) -> usize {
        TextSource::len(self)
    }

    fn check(&self) -> crate::Result<()> {
        TextSource::check(self)
    }

    fn axis_columns(&self) -> &[String; 3] {
        &self.meta.axis_columns
    }

    fn integer(&self) -> bool {
        self.summary.integer
    }

    fn estimated_rate_hz(&self) -> Option<f64> {
        TextSource::estimated_rate_hz(self)
    }

    fn metadata_rate_hz(&self) -> Option<f64> {
        self.meta.sample_rate_hz
    }

    fn has_time(&self) -> bool {
        TextSource::has_time(self)
    }

    fn has_temp(&self) -> bool {
        TextSource::has_temp(self)
    }

    fn time_ends(&self) -> (Option<f64>, Option<f64>) {
        (self.summary.t_first, self.summary.t_last)
    }

    fn time_steps(&self) -> Option<TimeSteps> {
        self.has_time().then_some(self.steps).flatten()
    }

    fn constant(&self) -> Option<[bool; 3]> {
        Some(self.summary.constant)
    }

    fn extremes(&self) -> (f64, f64) {
        (self.summary.lo, self.summary.hi)
    }

    /// From the first pass's summary, else in a pass of their own.
    fn distinct(&self) -> Option<[Vec<f64>; 3]> {
        match &self.summary.distinct {
            Distinct::Values(v) => Some(v.clone()),
            Distinct::TooMany => None,
            Distinct::NotKept => distinct_in_a_pass(self),
        }
    }

    fn f32_in_place(&self) -> Option<Vec<&[[f32; 3]]>> {
        self.axes_f32_in_place()
    }

    fn each_piece(&self, f: &mut dyn FnMut(&[[f64; 3]]) -> bool) {
        TextSource::each_piece(self, Want::AXES, |cols| f(&cols.xyz));
    }

    fn each_piece_f32(&self, f: &mut dyn FnMut(&[[f32; 3]]) -> bool) {
        TextSource::each_piece_f32(self, f);
    }

    /// From the spill, `SPAN_READ_ROWS` at a time (rows `buf` holds already not read again).
    fn span<'a>(&'a self, (s, e): (usize, usize), buf: &'a mut RowBuf) -> Option<RowChunk<'a>> {
        let span = (s, e.min(s + SPAN_READ_ROWS));
        if buf.at != Some(span) {
            buf.at = None;
            if !self.read_spilled(span, &mut buf.cols, &mut buf.scratch) {
                return None;
            }
            buf.at = Some(span);
        }
        let c = &buf.cols;
        Some(RowChunk {
            xyz: &c.xyz,
            t: (!c.t.is_empty()).then_some(&c.t[..]),
            temp: (!c.temp.is_empty()).then_some(&c.temp[..]),
        })
    }
}

/// Each axis's distinct values in a pass of their own (the first pass did not keep them:
/// [`Distinct::NotKept`]); `None` past `MAX_DISTINCT`, or when the pass ended early (which
/// [`TextSource::check`] after the detection reports).
fn distinct_in_a_pass(src: &TextSource) -> Option<[Vec<f64>; 3]> {
    let mut fold = SummaryFold::keeping();
    TextSource::each_piece(src, Want::AXES, |cols| {
        fold.push(&cols.xyz, &[], &[]);
        true
    });
    let complete = src.check().is_ok();
    match fold.finish().distinct {
        Distinct::Values(v) if complete => Some(v),
        _ => None,
    }
}
