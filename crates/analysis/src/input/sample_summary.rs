//! What one pass over a recording's samples says about all of them, for a file whose samples
//! are streamed rather than held ([`crate::input::text_source`]): the count, whether every
//! value is an integer, the extremes, each axis's distinct values (the quantiser lattice's
//! evidence, up to [`MAX_DISTINCT`]), and the time column's first and last values. Each is
//! folded in sample order with the same operations as the whole-recording code
//! ([`crate::input::recording::Recording::is_integer`], `detect::detector::adc_range_of`,
//! `bounded::check_reading_scale`), so it gives the same values bit for bit.

use std::collections::HashSet;
use std::hash::{BuildHasherDefault, Hasher};

/// Most distinct values per axis kept: past it the values are not on a quantiser lattice the
/// detector maps back to levels (`detect::detector::MAX_LATTICE_LEVELS`), so they are dropped.
pub const MAX_DISTINCT: usize = 1 << 17;

/// A hasher for float bits: one multiply and a shift (the set of distinct values sees every
/// sample's three values, and std's SipHash would cost more than the parse; no crate of the
/// tree offers a fast one).
#[derive(Default)]
pub struct BitsHasher(u64);

impl Hasher for BitsHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
    }
    fn write_u64(&mut self, v: u64) {
        let h = (v ^ self.0).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 = h ^ (h >> 29);
    }
}

type BitsSet = HashSet<u64, BuildHasherDefault<BitsHasher>>;

/// Whole numbers of magnitude below this are kept in a bitmap, not hashed.
const SMALL: i64 = 1 << 20;

/// One axis's distinct values (their bits): whole numbers of magnitude below [`SMALL`] (but
/// `-0.0`) as bits of a bitmap — raw counts, the common case, at the cost of a bit test rather
/// than a hash — the rest in a hash set.
#[derive(Debug, Default)]
struct Keys {
    small: Vec<u64>,
    others: BitsSet,
    len: usize,
}

/// `v.fract() == 0.0` without the library call `fract` makes on targets without a rounding
/// instruction, and without a branch (it is asked of every value, in a loop the compiler can
/// then run on several values at once): at or above 2⁵² in magnitude every finite value is
/// whole; below it, adding 2⁵² rounds `|v|` to an integer (round to nearest, the only mode
/// Rust runs in) and subtracting it again gives `|v|` back exactly when `|v|` was one. NaN
/// and the infinities are neither (their `fract` is NaN).
#[inline]
pub(crate) fn is_whole(v: f64) -> bool {
    const P52: f64 = (1u64 << 52) as f64;
    let a = v.abs();
    (P52..=f64::MAX).contains(&a) | ((a < P52) & ((a + P52) - P52 == a))
}

/// The bitmap index of `v` when it is a whole number of magnitude below [`SMALL`] but `-0.0`
/// (the bitmap's keys), else `None`.
#[inline]
fn small_index(v: f64) -> Option<usize> {
    // One conversion for the test and the index (saturating; NaN gives 0).
    let i = v as i64;
    let small = v.abs() < SMALL as f64 && i as f64 == v && v.to_bits() != (-0.0f64).to_bits();
    small.then(|| (i + SMALL) as usize)
}

impl Keys {
    /// The value of `bits` kept.
    #[cfg(test)]
    fn insert(&mut self, bits: u64) {
        match small_index(f64::from_bits(bits)) {
            Some(i) => self.mark(i),
            None => self.insert_other(bits),
        }
    }

    /// The small whole number of bitmap index `i` kept (no branch on whether it was new: most
    /// are not, and which are is not predictable).
    #[inline]
    fn mark(&mut self, i: usize) {
        if self.small.is_empty() {
            self.small = vec![0; (2 * SMALL / 64) as usize];
        }
        let word = &mut self.small[i / 64];
        self.len += ((*word >> (i % 64)) & 1 ^ 1) as usize;
        *word |= 1u64 << (i % 64);
    }

    /// The value of `bits`, not a [`small_index`] one, kept.
    fn insert_other(&mut self, bits: u64) {
        if self.others.insert(bits) {
            self.len += 1;
        }
    }

    /// Every key as its value.
    fn values(self) -> Vec<f64> {
        let small = self.small.iter().enumerate().flat_map(|(w, &word)| {
            (0..64)
                .filter(move |b| word >> b & 1 == 1)
                .map(move |b| ((w * 64 + b) as i64 - SMALL) as f64)
        });
        let mut v: Vec<f64> = small.collect();
        v.extend(self.others.into_iter().map(f64::from_bits));
        v
    }
}

/// Each axis's distinct values, as the summary of a pass has them.
#[derive(Debug, Clone, PartialEq)]
pub enum Distinct {
    /// Each axis's distinct values, ascending (sorted by `total_cmp` and deduplicated as the
    /// whole-recording lattice check does).
    Values([Vec<f64>; 3]),
    /// An axis has more than [`MAX_DISTINCT`]: not on a lattice.
    TooMany,
    /// Not kept: every value is whole (whole numbers are not mapped to a lattice: they are
    /// their own levels), or the first rows' values all were and later ones were not (a pass
    /// of their own finds them: [`SummaryFold::keeping`]).
    NotKept,
}

/// The one-pass summary of a recording's samples.
#[derive(Debug, Clone)]
pub struct SampleSummary {
    /// Samples.
    pub count: usize,
    /// Every axis value an integer (raw counts).
    pub integer: bool,
    /// Smallest and largest axis value (`f64::min`/`max` folds, NaN ignored).
    pub lo: f64,
    /// See `lo`.
    pub hi: f64,
    /// Largest |value| (`check_reading_scale`'s fold).
    pub largest: f64,
    /// Every axis value finite.
    pub finite: bool,
    /// Each axis's distinct values, when kept.
    pub distinct: Distinct,
    /// Per axis: every value compares equal to the first (`==`: `−0` and `0` do, NaN does
    /// not); false without samples.
    pub constant: [bool; 3],
    /// First and last time (the time column's, when there is one).
    pub t_first: Option<f64>,
    /// See `t_first`.
    pub t_last: Option<f64>,
    /// Every time and temperature value finite.
    pub finite_t_temp: bool,
}

/// The extremes (`lo`, `hi`, `largest`), `finite` and `constant` of `s` folded over `xyz`,
/// each axis in its own accumulators (three independent chains rather than one: the fold is
/// bound by the latency of `min`/`max`); whether every value of `xyz` is whole. The order
/// does not change a result: `min`/`max` ignore NaN, and values that compare equal are the
/// same bits but for `0`/`−0`, which only `lo`/`hi` can be and which their one use,
/// `detect::detector::adc_range_of`, compares as equal (as the held path, whose fold runs on
/// all cores).
fn fold_extremes(s: &mut SampleSummary, first: &[f64; 3], xyz: &[[f64; 3]]) -> bool {
    let (mut lo, mut hi, mut largest) = ([s.lo; 3], [s.hi; 3], [s.largest; 3]);
    let (mut finite, mut whole, mut same) = (true, true, s.constant);
    for x in xyz {
        for a in 0..3 {
            lo[a] = lo[a].min(x[a]);
            hi[a] = hi[a].max(x[a]);
            largest[a] = largest[a].max(x[a].abs());
            finite &= x[a].is_finite();
            whole &= is_whole(x[a]);
            same[a] &= x[a] == first[a];
        }
    }
    s.lo = lo[0].min(lo[1]).min(lo[2]);
    s.hi = hi[0].max(hi[1]).max(hi[2]);
    s.largest = largest[0].max(largest[1]).max(largest[2]);
    s.finite &= finite;
    s.constant = same;
    whole
}

/// Whether a fold keeps each axis's distinct values ([`Distinct`]).
#[derive(Debug)]
enum Sets {
    /// Not yet: every value so far is whole. A file of counts, the common case, keeps none
    /// (a bit per value in a bitmap was a tenth of the first pass).
    Waiting,
    /// Kept from the first rows on (a value of theirs was not whole).
    Kept([Keys; 3]),
    /// Past [`MAX_DISTINCT`] on an axis.
    TooMany,
    /// Values that are not whole came after rows whose values all were, which were not kept.
    NotKept,
}

/// [`SampleSummary`] as it is being folded.
#[derive(Debug)]
pub struct SummaryFold {
    sum: SampleSummary,
    sets: Sets,
    first: Option<[f64; 3]>,
    last: [u64; 3],
}

impl Default for SummaryFold {
    fn default() -> Self {
        Self::new()
    }
}

impl SummaryFold {
    /// No samples yet.
    pub fn new() -> Self {
        Self {
            sum: SampleSummary {
                count: 0,
                integer: true,
                lo: f64::INFINITY,
                hi: f64::NEG_INFINITY,
                largest: 0.0,
                finite: true,
                distinct: Distinct::NotKept,
                constant: [true; 3],
                t_first: None,
                t_last: None,
                finite_t_temp: true,
            },
            sets: Sets::Waiting,
            first: None,
            last: [u64::MAX; 3],
        }
    }

    /// No samples yet, each axis's distinct values kept whatever they are (the pass that
    /// finds them when the first one did not keep them: [`Distinct::NotKept`]).
    pub fn keeping() -> Self {
        Self {
            sets: Sets::Kept(Default::default()),
            ..Self::new()
        }
    }

    /// The next rows: their axis values, times (empty without a time column) and
    /// temperatures (empty without a temperature column).
    pub fn push(&mut self, xyz: &[[f64; 3]], t: &[f64], temp: &[f64]) {
        let s = &mut self.sum;
        let before = s.count;
        s.count += xyz.len();
        if self.first.is_none() {
            self.first = xyz.first().copied();
        }
        // Without a first row yet, there are no rows to compare.
        let whole = fold_extremes(s, &self.first.unwrap_or_default(), xyz);
        s.integer &= whole;
        self.sets = match std::mem::replace(&mut self.sets, Sets::TooMany) {
            Sets::Waiting if whole => Sets::Waiting,
            Sets::Waiting if before == 0 => keep(Default::default(), &mut self.last, xyz),
            Sets::Waiting => Sets::NotKept,
            Sets::Kept(sets) => keep(sets, &mut self.last, xyz),
            other => other,
        };
        if let (Some(&a), Some(&b)) = (t.first(), t.last()) {
            s.t_first.get_or_insert(a);
            s.t_last = Some(b);
        }
        s.finite_t_temp &= t.iter().chain(temp).all(|v| v.is_finite());
    }

    /// The summary of every row pushed.
    pub fn finish(self) -> SampleSummary {
        let mut sum = self.sum;
        // A value that is not finite is not whole.
        sum.integer &= sum.finite;
        sum.constant = sum.constant.map(|c| c && sum.count > 0);
        sum.distinct = match self.sets {
            Sets::Kept(sets) => Distinct::Values(sets.map(|set| {
                let mut v = set.values();
                v.sort_by(f64::total_cmp);
                v.dedup();
                v
            })),
            Sets::TooMany => Distinct::TooMany,
            Sets::Waiting | Sets::NotKept => Distinct::NotKept,
        };
        sum
    }
}

/// The values of `xyz` added to `sets` (a value that repeats the bits of the last value of
/// its axis that was not a small whole number, `last`, is skipped: it is in the set), then
/// [`Sets::TooMany`] when an axis is past [`MAX_DISTINCT`].
fn keep(mut sets: [Keys; 3], last: &mut [u64; 3], xyz: &[[f64; 3]]) -> Sets {
    for x in xyz {
        for a in 0..3 {
            if let Some(i) = small_index(x[a]) {
                sets[a].mark(i);
                continue;
            }
            let bits = x[a].to_bits();
            if bits != last[a] {
                last[a] = bits;
                sets[a].insert_other(bits);
            }
        }
    }
    // +1: `0.0` and `-0.0` are two keys and one value.
    if sets.iter().any(|set| set.len > MAX_DISTINCT + 1) {
        Sets::TooMany
    } else {
        Sets::Kept(sets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The keys kept are the distinct bit patterns, whole or not, small or large, signed
    /// zeros and NaN included.
    #[test]
    fn the_keys_are_the_distinct_bits() {
        let values = [
            0.0,
            -0.0,
            3.0,
            -3.0,
            3.0,
            0.5,
            -1048575.0,
            -1048576.0,
            1048575.0,
            1048576.0,
            1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            7.0,
        ];
        let mut keys = Keys::default();
        for v in values {
            keys.insert(v.to_bits());
        }
        let want: HashSet<u64> = values.iter().map(|v| v.to_bits()).collect();
        assert_eq!(keys.len, want.len());
        let got: HashSet<u64> = keys.values().iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, want);
    }

    /// The test for whole numbers is `fract`'s, at the edges of exactness too.
    #[test]
    fn whole_is_a_zero_fraction() {
        let p52 = (1u64 << 52) as f64;
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1e-300,
            -3.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
            9.2e18,
            -9.3e18,
        ];
        for base in [p52, -p52, p52 / 2.0, 1.0, (1u64 << 53) as f64] {
            values.extend((0..4).map(|k| f64::from_bits(base.to_bits() + k)));
            values.extend((1..4).map(|k| f64::from_bits(base.to_bits() - k)));
        }
        for v in values {
            assert_eq!(is_whole(v), v.fract() == 0.0, "{v:e}");
        }
    }

    /// Whether every value is whole is `fract`'s verdict on each, whatever the repeats, the
    /// signed zeros, a NaN whose bits are all ones (the pattern no value is taken to repeat
    /// at the start), and the distinct values outgrowing their sets.
    #[test]
    fn integer_is_every_values_fract() {
        let all_ones = f64::from_bits(u64::MAX);
        let many: Vec<[f64; 3]> = (0..(MAX_DISTINCT + 3))
            .map(|i| [i as f64, 1.0, 2.0])
            .collect();
        let cases: Vec<Vec<[f64; 3]>> = vec![
            vec![[1.0, 2.0, 3.0]; 3],
            vec![[all_ones, 2.0, 3.0], [all_ones, 2.0, 3.0]],
            vec![[-0.0, 0.0, 5e15], [-0.0, 0.0, 5e15]],
            vec![[1.0, 2.0, 3.0], [1.0, 2.5, 3.0]],
            vec![[1.0, 2.0, 3.0], [1.0, f64::INFINITY, 3.0]],
            [many.clone(), vec![[0.5, 1.0, 2.0]]].concat(),
            [many, vec![[7.0, 1.0, 2.0]]].concat(),
        ];
        for rows in &cases {
            let want = rows.iter().flatten().all(|v| v.fract() == 0.0);
            for split in [1, 2, rows.len()] {
                let mut f = SummaryFold::new();
                rows.chunks(split).for_each(|c| f.push(c, &[], &[]));
                assert_eq!(f.finish().integer, want, "{:?}", &rows[..2]);
            }
        }
    }

    /// Pushed in any split, the summary is the whole recording's folds.
    #[test]
    fn the_summary_is_the_folds_of_every_sample() {
        let xyz: Vec<[f64; 3]> = (0..1000)
            .map(|i| [(i % 17) as f64 * 0.5 - 3.0, -0.0, (i * 7 % 100) as f64])
            .collect();
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        for split in [1, 7, 999] {
            let mut f = SummaryFold::new();
            for (c, tc) in xyz.chunks(split).zip(t.chunks(split)) {
                f.push(c, tc, &[]);
            }
            let s = f.finish();
            assert_eq!(s.count, 1000);
            assert!(!s.integer);
            assert_eq!((s.lo, s.hi, s.largest), (-3.0, 99.0, 99.0));
            // One row per piece: the first's values are all whole, and are not kept; a pass
            // that keeps them finds them.
            let d = match (s.distinct, split) {
                (Distinct::Values(d), 7 | 999) => d,
                (Distinct::NotKept, 1) => {
                    let mut f = SummaryFold::keeping();
                    xyz.chunks(split).for_each(|c| f.push(c, &[], &[]));
                    match f.finish().distinct {
                        Distinct::Values(d) => d,
                        other => panic!("{other:?}"),
                    }
                }
                (other, _) => panic!("split {split}: {other:?}"),
            };
            assert_eq!(s.constant, [false, true, false]);
            assert_eq!(d[0].len(), 17);
            assert_eq!(d[1], vec![-0.0]);
            assert_eq!(d[2].len(), 100);
            assert_eq!((s.t_first, s.t_last), (Some(0.0), Some(9.99)));
        }
    }

    /// Whole numbers keep no distinct values (they are their own levels); values that are
    /// not keep them from the first rows on, up to `MAX_DISTINCT`; an axis is constant when
    /// every value equals the first (`-0` equals `0`, NaN nothing).
    #[test]
    fn whole_numbers_keep_no_distinct_values() {
        let fold = |rows: &[[f64; 3]]| {
            let mut f = SummaryFold::new();
            rows.chunks(2).for_each(|c| f.push(c, &[], &[]));
            f.finish()
        };
        let counts = fold(&[[1.0, 0.0, 5.0], [2.0, -0.0, 5.0], [3.0, 0.0, 5.0]]);
        let mut after_none = SummaryFold::new();
        after_none.push(&[], &[], &[]);
        after_none.push(&[[1.0, 2.0, 3.0], [1.0, 2.0, 4.0]], &[], &[]);
        assert_eq!(after_none.finish().constant, [true, true, false]);
        assert!(counts.integer);
        assert_eq!(counts.distinct, Distinct::NotKept);
        assert_eq!(counts.constant, [false, true, true]);
        let g = fold(&[[0.5, 1.0, 2.0], [0.25, 1.0, 2.0], [0.5, 1.0, 3.0]]);
        let want = [vec![0.25, 0.5], vec![1.0], vec![2.0, 3.0]];
        assert_eq!(g.distinct, Distinct::Values(want));
        assert_eq!(g.constant, [false, true, false]);
        let nan = fold(&[[f64::NAN, 1.0, 0.5], [f64::NAN, 1.0, 0.5]]);
        assert_eq!(nan.constant, [false, true, true]);
        let many: Vec<[f64; 3]> = (0..=MAX_DISTINCT + 2)
            .map(|i| [i as f64 + 0.5, 1.0, 2.0])
            .collect();
        assert_eq!(fold(&many).distinct, Distinct::TooMany);
        assert_eq!(fold(&[]).constant, [false; 3]);
    }
}
