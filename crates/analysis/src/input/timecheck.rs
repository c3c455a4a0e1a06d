//! Sanity of a recording's time column: it must not go back from row to row (time that goes
//! backwards means reordered or merged rows, and the drift and rate estimates built on it
//! would be wrong without a word). A time that repeats the previous row's is read: many
//! loggers print times coarser than the sample period (a 200 Hz log with times to 10 ms has
//! each time twice); the rate then comes from the whole span and one note says how many rows
//! repeat. Jumps are reported as notes (a logger that dropped samples is common and harmless
//! for static poses, but the user should know). A rate that suggests millisecond times is named where it makes a setting fail
//! (`windows::detect`).

use crate::error::input::InputError;

/// This module's errors are all the input stage's.
type Result<T, E = InputError> = std::result::Result<T, E>;
use crate::input::bounded::quote;
use crate::stats::OrderCounts;

/// A gap is a step longer than this many median steps.
pub const GAP_FACTOR: f64 = 5.0;

/// At most this many gaps are listed in the notes (the count is always given).
const MAX_LISTED_GAPS: usize = 3;

/// Checks time values row by row as the loader reads them (so that an error names the line).
#[derive(Debug, Clone)]
pub struct TimeCheck {
    column: String,
    prev: Option<f64>,
}

impl TimeCheck {
    /// A check of the column named `column` (for messages).
    pub fn new(column: &str) -> Self {
        Self {
            column: quote(column),
            prev: None,
        }
    }

    /// A check that goes on from `prev`, the last time read before (the chunk before, when
    /// the rows are read in chunks): its first [`TimeCheck::push`] is checked against it.
    pub fn after(column: &str, prev: f64) -> Self {
        Self {
            column: quote(column),
            prev: Some(prev),
        }
    }

    /// The next row's time `t` (seconds by contract), read on 1-based `line`: an error when it
    /// is earlier than the previous row's (equal is accepted: coarse timestamps).
    pub fn push(&mut self, t: f64, line: usize) -> Result<()> {
        if let Some(prev) = self.prev {
            if t < prev {
                return Err(InputError::TimeNotIncreasing {
                    line,
                    column: self.column.clone(),
                    previous: prev,
                    value: t,
                });
            }
        }
        self.prev = Some(t);
        Ok(())
    }
}

/// A time column is read as bursts when more than this fraction of its steps are gaps
/// (over [`GAP_FACTOR`] × the median step): a logger that timestamps FIFO reads on arrival
/// writes a few samples 1–2 ms apart, then waits for the next read. A logger that dropped
/// samples a few times stays far below this fraction.
pub const BURST_GAP_FRACTION: f64 = 0.1;

/// What the steps of a strictly increasing time column say about the sample rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeSteps {
    /// Median step, s.
    pub median_s: f64,
    /// Mean step over the whole span, (t_last − t_first)/(rows − 1), s.
    pub mean_s: f64,
    /// Steps over [`GAP_FACTOR`] × the median step.
    pub gaps: usize,
    /// Steps in all (rows − 1).
    pub steps: usize,
    /// Rows whose time repeats the previous row's (timestamps coarser than the sample
    /// period).
    pub repeats: usize,
}

impl TimeSteps {
    /// The summary of `t` (`None` with fewer than 3 rows or no time elapsed). With repeated
    /// times the step statistics are those of the positive steps. One pass while the positive
    /// steps take few distinct values (a time column printed to fixed decimals has a few dozen
    /// to a few hundred), else the selection's passes over the slice.
    pub fn of(t: &[f64]) -> Option<Self> {
        Self::of_times(|| t.iter().copied())
    }

    /// [`TimeSteps::of`] on times that `times` yields afresh on every call (the times of a
    /// file read block by block are regenerated, never held): a few passes, memory constant.
    /// The median is selected exactly (by the bits of the positive steps, 16 at a time), so
    /// the result is the one of a sort.
    pub fn of_times<I: Iterator<Item = f64>>(times: impl Fn() -> I) -> Option<Self> {
        let mut tally = StepTally::counting(0);
        times().for_each(|t| tally.push(t));
        let pass = |key: &mut dyn FnMut(u64)| {
            for (a, b) in pairs(times()) {
                if b - a > 0.0 {
                    key((b - a).to_bits());
                }
            }
            Ok::<(), std::convert::Infallible>(())
        };
        let Ok(steps) = tally.summary(pass);
        steps
    }

    /// True when the timestamps come in bursts ([`BURST_GAP_FRACTION`]): the median step is
    /// the spacing inside a burst, not the sample period.
    pub fn bursty(&self) -> bool {
        self.gaps as f64 > BURST_GAP_FRACTION * self.steps as f64
    }

    /// The sample rate, Hz: one over the median step, or over the mean step for bursty
    /// timestamps (whose median step is the arrival spacing inside a burst) and for coarse
    /// ones (repeated times: the median step is the timestamps' resolution).
    pub fn rate_hz(&self) -> f64 {
        if self.bursty() || self.repeats > 0 {
            1.0 / self.mean_s
        } else {
            1.0 / self.median_s
        }
    }
}

/// Most distinct positive steps a [`StepTally`] counts by value before it gives up (a time
/// column printed to fixed decimals has a few dozen; 2¹⁸ keys are ~10 MB).
pub const MAX_TALLIED_STEPS: usize = 1 << 18;

/// [`TimeSteps::of`] in one pass over times fed one at a time (a file read in pieces, never
/// held): the positive steps are counted by value, so the median is selected exactly as a
/// sort would, and the gap count follows from the counts. Gives up (`finish` → `None`) past
/// [`MAX_TALLIED_STEPS`] distinct steps; [`TimeSteps::of_times`] then re-reads the times.
#[derive(Debug)]
pub struct StepTally {
    prev: Option<f64>,
    first: f64,
    last: f64,
    steps: usize,
    positive: usize,
    /// Positive steps by their bits while they take few values ([`FewTable`]: a multiply, a
    /// shift and a compare per step, where a general map costs several times the whole
    /// pass); `None` past its room.
    few: Option<Box<FewTable>>,
    /// The positive steps past the table's room ([`OrderCounts`]: by value up to its
    /// `max_distinct`, then by their top bits for the selection's passes).
    many: Option<OrderCounts>,
    max_distinct: usize,
}

impl Default for StepTally {
    fn default() -> Self {
        Self::new()
    }
}

impl StepTally {
    /// An empty tally.
    pub fn new() -> Self {
        Self::counting(MAX_TALLIED_STEPS)
    }

    /// An empty tally, counting in the small table, then by value up to `max_distinct`
    /// distinct steps (0: at once by their top bits, for the selection's passes).
    fn counting(max_distinct: usize) -> Self {
        Self {
            prev: None,
            first: f64::NAN,
            last: f64::NAN,
            steps: 0,
            positive: 0,
            few: Some(Box::new(FewTable::new())),
            many: None,
            max_distinct,
        }
    }

    /// The next time.
    pub fn push(&mut self, t: f64) {
        if let Some(prev) = self.prev.replace(t) {
            if self.steps == 0 {
                self.first = prev;
            }
            self.steps += 1;
            self.last = t;
            let d = t - prev;
            if d > 0.0 {
                self.positive += 1;
                self.count(d.to_bits());
            }
        }
    }

    /// One more positive step of these bits: in the small table while it has room, then
    /// (the table's counts moved over once) in the order counts.
    fn count(&mut self, bits: u64) {
        if let Some(few) = &mut self.few {
            if few.add(bits) {
                return;
            }
            self.many = Some(few.counts(self.max_distinct));
            self.few = None;
        }
        if let Some(many) = &mut self.many {
            many.push(bits);
        }
    }

    /// The next times, in order.
    pub fn push_all(&mut self, t: &[f64]) {
        t.iter().for_each(|&t| self.push(t));
    }

    /// What [`TimeSteps::of`] gives for the times pushed (`Some(None)`: no summary), or
    /// `None` when the tally gave up.
    pub fn finish(self) -> Option<Option<TimeSteps>> {
        self.summary(|_| Err(())).ok()
    }

    /// The summary of the times pushed, `pass` giving every positive step's bits again when
    /// the counts by value were given up (the median then selected in passes,
    /// [`OrderCounts::keys`]).
    fn summary<E>(
        self,
        mut pass: impl FnMut(&mut dyn FnMut(u64)) -> Result<(), E>,
    ) -> Result<Option<TimeSteps>, E> {
        if self.steps < 2 || self.positive == 0 {
            return Ok(None);
        }
        let counts = match (self.few, self.many) {
            (Some(few), _) => few.counts(usize::MAX),
            (None, many) => many.unwrap_or_else(|| OrderCounts::new(0)),
        };
        let median_s = f64::from_bits(counts.keys(&[self.positive / 2], &mut pass)?[0]);
        if !(median_s.is_finite() && median_s > 0.0) {
            return Ok(None);
        }
        let mut gaps = 0usize;
        let mut gap = |bits: u64, c: usize| {
            if f64::from_bits(bits) > GAP_FACTOR * median_s {
                gaps += c;
            }
        };
        match counts.sorted() {
            Some(sorted) => sorted.into_iter().for_each(|(bits, c)| gap(bits, c)),
            None => pass(&mut |bits| gap(bits, 1))?,
        }
        Ok(Some(TimeSteps {
            median_s,
            mean_s: (self.last - self.first) / self.steps as f64,
            gaps,
            steps: self.steps,
            repeats: self.steps - self.positive,
        }))
    }
}

/// Slots of [`FewTable`] (a power of two; 8 KB of keys, 4 KB of counts at most in use: it
/// stays in the first-level cache).
const FEW_SLOTS: usize = 512;

/// Counts of up to three quarters of [`FEW_SLOTS`] distinct positive steps (their bits), in
/// an open-addressing table.
#[derive(Debug, Clone)]
struct FewTable {
    /// 0: empty (a positive step's bits are never 0).
    keys: [u64; FEW_SLOTS],
    counts: [usize; FEW_SLOTS],
    distinct: usize,
}

impl FewTable {
    fn new() -> Self {
        Self {
            keys: [0; FEW_SLOTS],
            counts: [0; FEW_SLOTS],
            distinct: 0,
        }
    }

    /// One more step of these bits (not 0); false, and nothing counted, when it would be a
    /// new value past the table's three quarters.
    #[inline]
    fn add(&mut self, bits: u64) -> bool {
        let mut slot = (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 55) as usize;
        loop {
            if self.keys[slot] == bits {
                self.counts[slot] += 1;
                return true;
            }
            if self.keys[slot] == 0 {
                if self.distinct == FEW_SLOTS / 4 * 3 {
                    return false;
                }
                (self.keys[slot], self.counts[slot]) = (bits, 1);
                self.distinct += 1;
                return true;
            }
            slot = (slot + 1) & (FEW_SLOTS - 1);
        }
    }

    /// The counts as [`OrderCounts`] counting by value up to `max_distinct` keys.
    fn counts(&self, max_distinct: usize) -> OrderCounts {
        let mut counts = OrderCounts::new(max_distinct);
        for (&k, &c) in self.keys.iter().zip(&self.counts) {
            if k != 0 {
                counts.push_n(k, c);
            }
        }
        counts
    }
}

/// Consecutive pairs `(t[i], t[i+1])` of an iterator of times.
fn pairs<I: Iterator<Item = f64>>(mut it: I) -> impl Iterator<Item = (f64, f64)> {
    let mut prev = it.next();
    it.map_while(move |t| {
        let p = prev.replace(t)?;
        Some((p, t))
    })
}

/// Rounded for messages (a median of 0.009999999999990905 s reads as 0.01 s).
fn shown(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

/// Notes on a strictly increasing time column: gaps (steps over [`GAP_FACTOR`] × the median
/// step), or, when there are so many that the timestamps come in bursts, how the rate is
/// taken instead. Empty when all is regular.
pub fn time_notes(column: &str, t: &[f64]) -> Vec<String> {
    time_notes_given(column, TimeSteps::of(t), || t.iter().copied())
}

/// [`time_notes`] on times that `times` yields afresh on every call, with the steps' summary
/// already computed ([`TimeSteps::of_times`] of the same times): a caller that needs the rate
/// too regenerates the times once less.
pub fn time_notes_given<I: Iterator<Item = f64>>(
    column: &str,
    steps: Option<TimeSteps>,
    times: impl Fn() -> I,
) -> Vec<String> {
    let Some(steps) = steps else {
        return Vec::new();
    };
    let median_shown = shown(steps.median_s);
    if steps.repeats > 0 {
        return vec![format!(
            "column '{}': {} of {} rows repeat the previous row's time (timestamps coarser than the sample period); the sample rate is taken from the whole span: {} Hz",
            quote(column),
            steps.repeats,
            steps.steps + 1,
            (steps.rate_hz() * 1e3).round() / 1e3,
        )];
    }
    if steps.bursty() {
        return vec![format!(
            "column '{}': timestamps come in bursts ({} of {} steps exceed {GAP_FACTOR}× the median step of {median_shown} s), as from a logger that stamps FIFO reads on arrival; the sample rate is taken from the whole span: {} Hz",
            quote(column),
            steps.gaps,
            steps.steps,
            (steps.rate_hz() * 1e3).round() / 1e3,
        )];
    }
    if steps.gaps == 0 {
        return Vec::new(); // counted by `TimeSteps::of_times`: no pass to list none
    }
    let mut gaps = 0usize;
    let mut listed: Vec<String> = Vec::new();
    for (a, b) in pairs(times()) {
        if b - a > GAP_FACTOR * steps.median_s {
            gaps += 1;
            if listed.len() < MAX_LISTED_GAPS {
                listed.push(format!("{a} s → {b} s"));
            }
        }
    }
    if gaps == 0 {
        return Vec::new();
    }
    let more = if gaps > MAX_LISTED_GAPS { ", …" } else { "" };
    vec![format!(
        "column '{}': time jumps {} time(s) by more than {GAP_FACTOR}× the median step of {median_shown} s ({}{more}); samples are missing there",
        quote(column),
        gaps,
        listed.join(", ")
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary as a sort of the positive steps gives it.
    fn sorted(t: &[f64]) -> Option<TimeSteps> {
        let steps = t.len().checked_sub(1)?;
        let mut pos: Vec<f64> = t
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .collect();
        pos.sort_by(f64::total_cmp);
        let median_s = *pos.get(pos.len() / 2)?;
        (steps >= 2 && median_s.is_finite()).then(|| TimeSteps {
            median_s,
            mean_s: (t[steps] - t[0]) / steps as f64,
            gaps: pos.iter().filter(|d| **d > GAP_FACTOR * median_s).count(),
            steps,
            repeats: steps - pos.len(),
        })
    }

    /// The one-pass count of few distinct steps gives what a sort gives: regular,
    /// with gaps, with repeats, bursts, times going back, NaN, too short; and so do the
    /// selection's passes when the steps take too many values.
    #[test]
    fn few_steps_agree_with_the_selection() {
        let regular: Vec<f64> = (0..5000).map(|i| i as f64 * 0.01).collect();
        let mut gaps = regular.clone();
        gaps.drain(1000..1100);
        gaps.drain(3000..3005);
        let repeats: Vec<f64> = (0..3000).map(|i| (i / 2) as f64 * 0.01).collect();
        let bursts: Vec<f64> = (0..3000)
            .map(|i| (i / 4) as f64 * 0.04 + (i % 4) as f64 * 0.001)
            .collect();
        let mut back = regular.clone();
        back[2000] = 1.0;
        let mut nan = regular.clone();
        nan[10] = f64::NAN;
        // Jitter of (i² mod 9973) ns: consecutive differences 2i + 1 (mod 9973), all distinct.
        let jitter: Vec<f64> = (0..5000u64)
            .map(|i| i as f64 * 0.01 + ((i * i) % 9973) as f64 * 1e-9)
            .collect();
        let cases: [&[f64]; 9] = [
            &regular,
            &gaps,
            &repeats,
            &bursts,
            &back,
            &nan,
            &jitter,
            &[0.0, 1.0],
            &[],
        ];
        for t in cases {
            assert_eq!(TimeSteps::of(t), sorted(t), "{:?}", &t[..t.len().min(5)]);
        }
        let mut few = StepTally::counting(0);
        few.push_all(&jitter);
        assert!(
            few.few.is_none(),
            "the table gave up on many distinct steps"
        );
    }

    /// A 200 Hz log with times printed to 10 ms (each time twice): read, the rate
    /// from the span, one note naming how many rows repeat; time that goes back stays an error.
    #[test]
    fn coarse_times_are_read_with_the_rate_from_the_span() {
        let t: Vec<f64> = (0..2000)
            .map(|i| ((i as f64 / 200.0) * 100.0).floor() / 100.0)
            .collect();
        let mut check = TimeCheck::new("t");
        for (i, v) in t.iter().enumerate() {
            check.push(*v, i + 2).unwrap();
        }
        let steps = TimeSteps::of(&t).unwrap();
        assert_eq!(steps.repeats, 1000);
        // Span 9.99 s over 1999 steps: 200.1 Hz (the last 10 ms tick is not a full period).
        assert!(
            (steps.rate_hz() - 1999.0 / 9.99).abs() < 1e-9,
            "{}",
            steps.rate_hz()
        );
        let notes = time_notes("t", &t);
        assert_eq!(notes.len(), 1);
        assert!(notes[0].contains("1000 of 2000 rows repeat"), "{notes:?}");
        let mut back = TimeCheck::new("t");
        back.push(0.02, 2).unwrap();
        let e = back.push(0.01, 3).unwrap_err();
        assert!(
            matches!(e, InputError::TimeNotIncreasing { line: 3, .. }),
            "{e}"
        );
    }

    /// The selection's median is a sort's, and a slice's summary is that of the same times
    /// generated afresh (the two ways the passes are made).
    #[test]
    fn median_step_is_a_sorts_and_both_passes_agree() {
        let mut t = vec![0.0f64];
        let mut x = 12345u64;
        for i in 1..5000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let step = match i % 17 {
                0 => 0.0,
                5 => 0.4,
                _ => 0.01 + (x >> 40) as f64 * 1e-12,
            };
            t.push(t[i - 1] + step);
        }
        let by_sort = sorted(&t).unwrap();
        let s = TimeSteps::of(&t).unwrap();
        assert_eq!(s.median_s.to_bits(), by_sort.median_s.to_bits());
        assert_eq!(Some(s), TimeSteps::of_times(|| t.iter().copied()));
        assert_eq!(s.repeats, (1..5000).filter(|i| i % 17 == 0).count());
        let regenerated = || t.iter().copied();
        assert_eq!(
            time_notes("t", &t),
            time_notes_given("t", TimeSteps::of_times(regenerated), regenerated)
        );
    }

    #[test]
    fn backwards_times_name_the_line_and_repeats_are_read() {
        let mut c = TimeCheck::new("t");
        c.push(0.0, 2).unwrap();
        c.push(0.01, 3).unwrap();
        let e = c.push(0.005, 4).unwrap_err().to_string();
        assert_eq!(
            e,
            "line 4: column 't': time goes from 0.01 back to 0.005; rows must be in time order"
        );
        let mut c = TimeCheck::new("time");
        c.push(1.0, 2).unwrap();
        assert!(c.push(1.0, 3).is_ok());
    }

    /// The one-pass tally gives what the whole-column summary gives: regular, coarse, gappy,
    /// bursty and too-short columns.
    #[test]
    fn the_tally_is_the_summary_of_the_column() {
        let columns: Vec<Vec<f64>> = vec![
            (0..1000).map(|i| i as f64 * 0.01).collect(),
            (0..2000)
                .map(|i| ((i as f64 / 200.0) * 100.0).floor() / 100.0)
                .collect(),
            (0..1000)
                .map(|i| (i / 5) as f64 * 0.05 + (i % 5) as f64 * 0.0015)
                .collect(),
            (0..300)
                .map(|i| i as f64 * 0.01 + if i > 150 { 3.0 } else { 0.0 })
                .collect(),
            vec![1.0, 2.0],
            vec![1.0, 1.0, 1.0],
            Vec::new(),
            // Jittered stamps: thousands of distinct steps, past the small table into the map.
            (0..5000)
                .map(|i| i as f64 * 0.01 + ((i * 7919) % 1000) as f64 * 1e-7)
                .collect(),
        ];
        for t in &columns {
            let mut tally = StepTally::new();
            t.iter().for_each(|&x| tally.push(x));
            assert_eq!(tally.finish(), Some(TimeSteps::of(t)), "{t:?}");
        }
        // More distinct steps than the tally keeps: it gives up (the times are then re-read).
        let many: Vec<f64> = (0..MAX_TALLIED_STEPS as u64 + 10)
            .map(|i| (i * i) as f64 * 1e-6)
            .collect();
        let mut tally = StepTally::new();
        many.iter().for_each(|&x| tally.push(x));
        assert_eq!(tally.finish(), None);
    }

    #[test]
    fn gaps_are_noted() {
        let regular: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
        assert!(time_notes("t", &regular).is_empty());
        let mut gap = regular.clone();
        for v in gap.iter_mut().skip(50) {
            *v += 3.0;
        }
        let notes = time_notes("t", &gap);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains("jumps 1 time(s)"), "{}", notes[0]);
        assert!(notes[0].contains("0.49 s → 3.5 s"), "{}", notes[0]);
        // A few gaps leave the rate at one over the median step.
        let s = TimeSteps::of(&gap).unwrap();
        assert!(!s.bursty());
        assert!((s.rate_hz() - 100.0).abs() < 1e-6, "{s:?}");
    }

    /// A 100 Hz sensor read through a FIFO every 50 ms, each read's five samples stamped on
    /// arrival 1.5 ms apart: the rate is the span's, 100 Hz, not the 667 Hz of the median
    /// step, and the note says why instead of reporting hundreds of "missing samples".
    #[test]
    fn bursty_timestamps_take_the_rate_from_the_span() {
        let t: Vec<f64> = (0..1000)
            .map(|i| (i / 5) as f64 * 0.05 + (i % 5) as f64 * 0.0015)
            .collect();
        let s = TimeSteps::of(&t).unwrap();
        assert!(s.bursty(), "{s:?}");
        let expected = 999.0 / t[999];
        assert!((s.rate_hz() - expected).abs() < 1e-9, "{s:?}");
        assert!((s.rate_hz() - 100.0).abs() < 1.0, "{s:?}");
        let notes = time_notes("t_s", &t);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("timestamps come in bursts"),
            "{}",
            notes[0]
        );
        assert!(!notes[0].contains("missing"), "{}", notes[0]);
    }
}
