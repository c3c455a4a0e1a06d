//! What one pass over a recording's samples says about all of them, for a file whose samples
//! are streamed rather than held ([`crate::input::text_source`]): the count, whether every
//! value is an integer, the extremes, each axis's distinct values (the quantiser lattice's
//! evidence, up to [`MAX_DISTINCT`]), and the time column's first and last values. Each is
//! folded in sample order with the same operations as the whole-recording code
//! ([`crate::input::recording::Recording::is_integer`], `detect::windows::infer_adc_range`,
//! `bounded::check_reading_scale`), so it gives the same values bit for bit.

use std::collections::HashSet;
use std::hash::{BuildHasherDefault, Hasher};

/// Most distinct values per axis kept: past it the values are not on a quantiser lattice the
/// detector maps back to levels (`detect::windows::MAX_LATTICE_LEVELS`), so they are dropped.
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

type Distinct = HashSet<u64, BuildHasherDefault<BitsHasher>>;

/// Whole numbers of magnitude below this are kept in a bitmap, not hashed.
const SMALL: i64 = 1 << 20;

/// One axis's distinct values (their bits): whole numbers of magnitude below [`SMALL`] (but
/// `-0.0`) as bits of a bitmap — raw counts, the common case, at the cost of a bit test rather
/// than a hash — the rest in a hash set.
#[derive(Debug, Default)]
struct Keys {
    small: Vec<u64>,
    others: Distinct,
    len: usize,
}

/// `v.fract() == 0.0` without the library call `fract` makes on targets without a rounding
/// instruction (it is asked of every value): below 2⁵² in magnitude a truncation to an
/// integer and back is exact, at or above it every finite value is whole; NaN and the
/// infinities are not (their `fract` is NaN).
fn is_whole(v: f64) -> bool {
    if v.abs() < (1u64 << 52) as f64 {
        (v as i64) as f64 == v
    } else {
        v.is_finite()
    }
}

impl Keys {
    /// The value of `bits` kept; whether it is whole ([`is_whole`]).
    fn insert(&mut self, bits: u64) -> bool {
        let v = f64::from_bits(bits);
        // One conversion for the bitmap's test and index (saturating; NaN gives 0).
        let i = v as i64;
        let small = v.abs() < SMALL as f64 && i as f64 == v;
        if small && bits != (-0.0f64).to_bits() {
            if self.small.is_empty() {
                self.small = vec![0; (2 * SMALL / 64) as usize];
            }
            let i = (i + SMALL) as usize;
            let (word, bit) = (&mut self.small[i / 64], 1u64 << (i % 64));
            if *word & bit == 0 {
                *word |= bit;
                self.len += 1;
            }
            return true;
        }
        if self.others.insert(bits) {
            self.len += 1;
        }
        small || is_whole(v)
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
    /// Each axis's distinct values, ascending (sorted by `total_cmp` and deduplicated as the
    /// whole-recording lattice check does); `None` when an axis has more than
    /// [`MAX_DISTINCT`].
    pub distinct: Option<[Vec<f64>; 3]>,
    /// First and last time (the time column's, when there is one).
    pub t_first: Option<f64>,
    /// See `t_first`.
    pub t_last: Option<f64>,
    /// Every time and temperature value finite.
    pub finite_t_temp: bool,
}

/// [`SampleSummary`] as it is being folded.
#[derive(Debug)]
pub struct SummaryFold {
    sum: SampleSummary,
    sets: Option<[Keys; 3]>,
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
                distinct: None,
                t_first: None,
                t_last: None,
                finite_t_temp: true,
            },
            sets: Some(Default::default()),
            last: [u64::MAX; 3],
        }
    }

    /// The next rows: their axis values, times (empty without a time column) and
    /// temperatures (empty without a temperature column).
    pub fn push(&mut self, xyz: &[[f64; 3]], t: &[f64], temp: &[f64]) {
        let s = &mut self.sum;
        s.count += xyz.len();
        for x in xyz {
            for &v in x {
                s.lo = s.lo.min(v);
                s.hi = s.hi.max(v);
                s.largest = s.largest.max(v.abs());
                s.finite &= v.is_finite();
            }
        }
        if let Some(sets) = &mut self.sets {
            // Whether each value is whole is asked as it is kept: a value skipped repeats the
            // bits of the one before it (or is `last`'s first pattern, a NaN, which `finite`
            // holds: `finish` takes both).
            let mut full = false;
            for x in xyz {
                for a in 0..3 {
                    let bits = x[a].to_bits();
                    if bits != self.last[a] {
                        self.last[a] = bits;
                        s.integer &= sets[a].insert(bits);
                    }
                }
            }
            for set in sets.iter() {
                // +1: `0.0` and `-0.0` are two keys and one value.
                full |= set.len > MAX_DISTINCT + 1;
            }
            if full {
                self.sets = None;
            }
        } else if s.integer {
            s.integer = xyz.iter().flatten().all(|&v| is_whole(v));
        }
        if let (Some(&a), Some(&b)) = (t.first(), t.last()) {
            s.t_first.get_or_insert(a);
            s.t_last = Some(b);
        }
        s.finite_t_temp &= t.iter().chain(temp).all(|v| v.is_finite());
    }

    /// The summary of every row pushed.
    pub fn finish(self) -> SampleSummary {
        let mut sum = self.sum;
        // A value that is not finite is not whole (see `push`).
        sum.integer &= sum.finite;
        sum.distinct = self.sets.map(|sets| {
            sets.map(|set| {
                let mut v = set.values();
                v.sort_by(f64::total_cmp);
                v.dedup();
                v
            })
        });
        sum
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
            assert_eq!(keys.insert(v.to_bits()), v.fract() == 0.0, "{v}");
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
            let d = s.distinct.unwrap();
            assert_eq!(d[0].len(), 17);
            assert_eq!(d[1], vec![-0.0]);
            assert_eq!(d[2].len(), 100);
            assert_eq!((s.t_first, s.t_last), (Some(0.0), Some(9.99)));
        }
    }
}
