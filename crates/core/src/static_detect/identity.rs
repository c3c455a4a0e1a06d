//! The detector's `push`, `push_slice` and `finish`, the survey's block measurement and
//! `Welford3` against the implementation they replaced ([`super::reference`], kept verbatim):
//! the same intervals (bounds, means and variances bit for bit), the same errors at the same
//! samples, the same threshold and reference variance, on generated streams (motion, holds,
//! quantised counts, huge offsets, non-finite samples) and on a few made by hand.

extern crate std;
use super::reference::{reference_measure_block, ReferenceDetector, ReferenceWelford3};
use super::*;
use proptest::prelude::*;
use std::vec::Vec;

/// Ring capacity of the detectors under test (windows up to 63 samples).
const CAP: usize = 64;

/// What a detector reports, with every float as its bits.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    /// An interval: start, end, mean bits, variance bits.
    Interval(u32, u32, [u32; 3], [u32; 3]),
    /// A sample refused or failed on: its index in the stream and the error.
    Refused(usize, Error),
    /// The state after a stretch: samples seen, still, threshold and reference bits, and
    /// the window sums' bits (shift, s1, s2, peak) and age.
    State(u32, bool, Option<u32>, Option<[u32; 3]>, [u32; 10], u32),
}

fn interval(iv: StaticInterval) -> Event {
    Event::Interval(
        iv.start,
        iv.end,
        iv.mean.map(f32::to_bits),
        iv.variance.map(f32::to_bits),
    )
}

/// The detector settings of one case: the config, and a reference variance given up front
/// (`with_reference`) or none (an initial rest period, `new`).
#[derive(Debug, Clone, Copy)]
struct Setup {
    cfg: StaticDetectorConfig,
    given: Option<[f32; 3]>,
}

impl Setup {
    fn reference(&self) -> ReferenceDetector<CAP> {
        match self.given {
            Some(r) => ReferenceDetector::with_reference(self.cfg, r).unwrap(),
            None => ReferenceDetector::new(self.cfg).unwrap(),
        }
    }

    fn detector(&self) -> StaticDetector<CAP> {
        match self.given {
            Some(r) => StaticDetector::with_reference(self.cfg, r).unwrap(),
            None => StaticDetector::new(self.cfg).unwrap(),
        }
    }
}

fn ref_state(d: &ReferenceDetector<CAP>) -> Event {
    Event::State(
        d.samples_seen(),
        d.is_still(),
        d.threshold.map(f32::to_bits),
        d.reference_variance().map(|v| v.map(f32::to_bits)),
        sums_bits(&d.sums.shift, &d.sums.s1, &d.sums.s2, d.sums.peak),
        d.sums.since,
    )
}

fn sums_bits(shift: &[f32; 3], s1: &[f32; 3], s2: &[f32; 3], peak: f32) -> [u32; 10] {
    let mut out = [peak.to_bits(); 10];
    for a in 0..3 {
        out[a] = shift[a].to_bits();
        out[3 + a] = s1[a].to_bits();
        out[6 + a] = s2[a].to_bits();
    }
    out
}

fn state(d: &StaticDetector<CAP>) -> Event {
    Event::State(
        d.samples_seen(),
        d.is_still(),
        d.threshold.map(f32::to_bits),
        d.reference_variance().map(|v| v.map(f32::to_bits)),
        sums_bits(&d.sums.shift, &d.sums.s1, &d.sums.s2, d.sums.peak),
        d.sums.since,
    )
}

/// The reference fed one sample at a time (going on after a refused sample), its state
/// after every sample.
fn by_reference(setup: &Setup, xs: &[[f32; 3]]) -> Vec<Event> {
    let mut d = setup.reference();
    let mut out = Vec::new();
    for (i, m) in xs.iter().enumerate() {
        match d.push(*m) {
            Ok(Some(iv)) => out.push(interval(iv)),
            Ok(None) => {}
            Err(e) => out.push(Event::Refused(i, e)),
        }
        out.push(ref_state(&d));
    }
    out.extend(d.finish().map(interval));
    out.push(ref_state(&d));
    out
}

/// The detector under test fed by `push`, as [`by_reference`].
fn by_push(setup: &Setup, xs: &[[f32; 3]]) -> Vec<Event> {
    let mut d = setup.detector();
    let mut out = Vec::new();
    for (i, m) in xs.iter().enumerate() {
        match d.push(*m) {
            Ok(Some(iv)) => out.push(interval(iv)),
            Ok(None) => {}
            Err(e) => out.push(Event::Refused(i, e)),
        }
        out.push(state(&d));
    }
    out.extend(d.finish().map(interval));
    out.push(state(&d));
    out
}

/// One step of [`in_pieces`]: samples `from..to` of the stream taken, the sample at an
/// index refused with an error, or a piece `from..to` over.
enum Fed {
    Taken(usize, usize),
    Refused(usize, Error),
    PieceOver(usize, usize),
}

/// Feeds `xs` to `push` (a `push_slice` on `state`) in pieces of the given lengths (cycled),
/// going on after a refused sample with the rest of its piece; tells `on` what was taken and
/// refused (indices in `xs`) and when each piece is over.
fn in_pieces<T>(
    state: &mut T,
    xs: &[[f32; 3]],
    pieces: &[usize],
    push: impl Fn(&mut T, &[[f32; 3]]) -> Result<(), (usize, Error)>,
    on: impl Fn(&mut T, Fed),
) {
    let mut at = 0;
    for len in pieces.iter().cycle() {
        if at >= xs.len() {
            break;
        }
        let end = (at + len.max(&1)).min(xs.len());
        let mut from = at;
        while from < end {
            match push(state, &xs[from..end]) {
                Ok(()) => {
                    on(state, Fed::Taken(from, end));
                    from = end;
                }
                Err((k, e)) => {
                    on(state, Fed::Taken(from, from + k));
                    on(state, Fed::Refused(from + k, e));
                    from += k + 1;
                }
            }
        }
        on(state, Fed::PieceOver(at, end));
        at = end;
    }
}

/// The detector under test fed by `push_slice` in pieces of the given lengths (cycled),
/// going on after a refused sample with the rest of its piece; the state after each piece.
/// Returns the events without the per-sample states, and the reference's the same way.
fn by_slices(setup: &Setup, xs: &[[f32; 3]], pieces: &[usize]) -> (Vec<Event>, Vec<Event>) {
    let mut st = (setup.detector(), setup.reference(), Vec::new(), Vec::new());
    let push = |(d, _, got, _): &mut (StaticDetector<CAP>, _, Vec<Event>, _), xs: &[_]| {
        d.push_slice(xs, |iv| got.push(interval(iv)))
    };
    in_pieces(
        &mut st,
        xs,
        pieces,
        push,
        |(d, r, got, want), fed| match fed {
            Fed::Taken(..) => {}
            Fed::Refused(i, e) => got.push(Event::Refused(i, e)),
            Fed::PieceOver(at, end) => {
                got.push(state(d));
                for (i, m) in xs.iter().enumerate().take(end).skip(at) {
                    match r.push(*m) {
                        Ok(Some(iv)) => want.push(interval(iv)),
                        Ok(None) => {}
                        Err(e) => want.push(Event::Refused(i, e)),
                    }
                }
                want.push(ref_state(r));
            }
        },
    );
    let (mut d, mut r, mut got, mut want) = st;
    got.extend(d.finish().map(interval));
    got.push(state(&d));
    want.extend(r.finish().map(interval));
    want.push(ref_state(&r));
    (got, want)
}

/// Both feeds of the detector under test against the reference.
fn check(setup: &Setup, xs: &[[f32; 3]], pieces: &[usize]) {
    let want = by_reference(setup, xs);
    let got = by_push(setup, xs);
    assert_eq!(got.len(), want.len(), "{setup:?}");
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w, "event {k}, {setup:?}");
    }
    let (got, want) = by_slices(setup, xs, pieces);
    assert_eq!(got, want, "{setup:?}, pieces {pieces:?}");
}

/// Deterministic xorshift noise in [−1, 1).
struct Noise(u32);
impl Noise {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 23) as f32 - 1.0
    }
}

/// One stretch of a generated stream.
#[derive(Debug, Clone, Copy)]
enum Stretch {
    /// A hold at `offset` with noise ±`amp`, rounded to whole counts or not.
    Hold {
        len: usize,
        offset: f32,
        amp: f32,
        whole: bool,
    },
    /// A swing of amplitude `amp` about `offset`.
    Motion { len: usize, offset: f32, amp: f32 },
    /// One NaN or infinite sample (axis, value).
    Bad(usize, f32),
}

fn stream(stretches: &[Stretch], seed: u32) -> Vec<[f32; 3]> {
    let mut noise = Noise(seed | 1);
    let mut out = Vec::new();
    for s in stretches {
        match *s {
            Stretch::Hold {
                len,
                offset,
                amp,
                whole,
            } => {
                let pose = [offset, offset * 0.9 + 100.0, -offset * 0.5];
                for _ in 0..len {
                    let m = pose.map(|p| p + amp * noise.next());
                    out.push(if whole { m.map(libm::roundf) } else { m });
                }
            }
            Stretch::Motion { len, offset, amp } => {
                for k in 0..len {
                    let ph = k as f32 * 0.15;
                    out.push([
                        offset + amp * libm::sinf(ph),
                        offset - amp * libm::cosf(ph),
                        offset + 0.5 * amp * libm::sinf(2.0 * ph),
                    ]);
                }
            }
            Stretch::Bad(axis, v) => {
                let mut m = [1.0, 2.0, 3.0];
                m[axis % 3] = v;
                out.push(m);
            }
        }
    }
    out
}

fn offsets() -> impl Strategy<Value = f32> {
    prop::sample::select(std::vec![
        0.0f32, 1.0, 512.0, 33_000.0, -2.0e5, 1.0e7, 3.0e37
    ])
}

fn amps() -> impl Strategy<Value = f32> {
    prop::sample::select(std::vec![
        0.0f32, 1e-3, 0.4, 1.0, 3.0, 100.0, 5_000.0, 1.0e36
    ])
}

fn stretches() -> impl Strategy<Value = Vec<Stretch>> {
    let one = prop_oneof![
        5 => (1usize..400, offsets(), amps(), any::<bool>()).prop_map(|(len, offset, amp, whole)| {
            Stretch::Hold { len, offset, amp, whole }
        }),
        3 => (1usize..120, offsets(), amps())
            .prop_map(|(len, offset, amp)| Stretch::Motion { len, offset, amp }),
        1 => (0usize..3, prop::sample::select(std::vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]))
            .prop_map(|(a, v)| Stretch::Bad(a, v)),
    ];
    prop::collection::vec(one, 1..8)
}

fn setups() -> impl Strategy<Value = Setup> {
    (
        1u16..32,
        0u32..3,
        prop::sample::select(std::vec![0.5f32, 6.0, 40.0]),
        1u32..150,
        prop::sample::select(std::vec![0.0f32, 1.0 / 12.0, 2.0]),
        prop::option::of(prop::sample::select(std::vec![
            [0.0f32, 0.0, 0.0],
            [1.0 / 12.0, 0.3, 2.0],
            [1e-6, 1e-6, 1e-6],
            [9.0, 9.0, 9.0],
        ])),
    )
        .prop_map(|(half, init_extra, factor, min_static, floor, given)| {
            let window = 2 * half + 1;
            Setup {
                cfg: StaticDetectorConfig {
                    window,
                    init_samples: u32::from(window) * (1 + init_extra),
                    threshold_factor: factor,
                    min_static_samples: min_static,
                    min_variance: floor,
                },
                given,
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Generated streams: `push` and `push_slice` (in generated pieces) report what the
    /// reference reports, sample for sample.
    #[test]
    fn detector_matches_the_reference(
        setup in setups(),
        parts in stretches(),
        seed in any::<u32>(),
        pieces in prop::collection::vec(1usize..300, 1..5),
    ) {
        check(&setup, &stream(&parts, seed), &pieces);
    }

    /// `Welford3::push` and `push_slice` against three scalar pushes (the old `Welford3`),
    /// state compared bit for bit after every sample, on values from ordinary to overflowing.
    #[test]
    fn welford3_matches_the_reference(parts in stretches(), seed in any::<u32>()) {
        let xs = stream(&parts, seed);
        let (mut w, mut r, mut s) = (Welford3::new(), ReferenceWelford3::new(), Welford3::new());
        for (i, m) in xs.iter().enumerate() {
            prop_assert_eq!(w.push(*m), r.push(*m), "sample {}", i);
            for a in 0..3 {
                prop_assert_eq!(welford_bits(w.axis(a).unwrap()), welford_bits(&r.axes[a]));
            }
        }
        let mut from = 0;
        while from < xs.len() {
            match s.push_slice(&xs[from..]) {
                Ok(()) => from = xs.len(),
                Err((k, _)) => from += k + 1,
            }
        }
        for a in 0..3 {
            prop_assert_eq!(welford_bits(s.axis(a).unwrap()), welford_bits(w.axis(a).unwrap()));
        }
    }

    /// The survey's block measurement against the old one: the same variance bits, the same
    /// whole-number flag, the same error.
    #[test]
    fn measure_block_matches_the_reference(parts in stretches(), seed in any::<u32>(), len in 3usize..60) {
        let xs = stream(&parts, seed);
        for block in xs.chunks(len) {
            let bits = |r: Result<(crate::Vec3, bool), Error>| {
                r.map(|(v, w)| ([v.x, v.y, v.z].map(f32::to_bits), w))
            };
            prop_assert_eq!(
                bits(NoiseSurvey::measure_block(block)),
                bits(reference_measure_block(block))
            );
        }
    }
}

/// A scalar accumulator's whole state as bits.
fn welford_bits(w: &crate::estimators::Welford) -> [u32; 5] {
    w.bits_for_tests()
}

fn cfg(window: u16, min_static: u32) -> StaticDetectorConfig {
    StaticDetectorConfig {
        window,
        init_samples: 2 * u32::from(window),
        threshold_factor: 6.0,
        min_static_samples: min_static,
        min_variance: 1.0 / 12.0,
    }
}

/// The hand-made streams: a name, the window, the stretches.
fn hand_made() -> [(&'static str, u16, Vec<Stretch>); 6] {
    let hold = |len, offset, amp, whole| Stretch::Hold {
        len,
        offset,
        amp,
        whole,
    };
    let motion = |len, offset, amp| Stretch::Motion { len, offset, amp };
    [
        (
            "motion between holds",
            51,
            std::vec![
                hold(400, 33_000.0, 3.0, false),
                motion(100, 33_000.0, 3_000.0),
                hold(300, 29_000.0, 3.0, false),
                motion(100, 29_000.0, 2_000.0),
                hold(300, 33_100.0, 3.0, false),
            ],
        ),
        (
            "long hold (many periodic recomputations)",
            21,
            std::vec![hold(20_000, 33_000.0, 2.0, true)],
        ),
        (
            "quantised counts toggling by one",
            31,
            std::vec![
                hold(3_000, 512.0, 0.6, true),
                motion(80, 512.0, 300.0),
                hold(500, 500.0, 0.0, true)
            ],
        ),
        (
            "huge offsets (squares overflow)",
            11,
            std::vec![
                hold(300, 3.0e37, 1.0e36, false),
                hold(300, 1.0e7, 3.0, true),
                motion(60, 3.0e37, 1.0e37)
            ],
        ),
        (
            "NaN and infinities mid-stream",
            15,
            std::vec![
                hold(200, 33_000.0, 3.0, true),
                Stretch::Bad(1, f32::NAN),
                hold(100, 33_000.0, 3.0, true),
                Stretch::Bad(0, f32::INFINITY),
                Stretch::Bad(2, f32::NEG_INFINITY),
                motion(50, 33_000.0, 800.0),
                hold(100, 32_000.0, 3.0, true),
            ],
        ),
        (
            "exactly one window of samples",
            63,
            std::vec![hold(63, 512.0, 1.0, true)],
        ),
    ]
}

/// Hand-made streams, each through both constructors and several piece lengths.
#[test]
fn hand_made_streams_match_the_reference() {
    for (name, window, parts) in hand_made() {
        let xs = stream(&parts, 7);
        for given in [None, Some([0.5f32, 0.5, 0.5])] {
            let setup = Setup {
                cfg: cfg(window, 20),
                given,
            };
            for pieces in [&[1usize][..], &[63], &[1000, 7, 64], &[100_000]] {
                std::eprintln!("{name}: {given:?}, pieces {pieces:?}");
                check(&setup, &xs, pieces);
            }
        }
        // The last window's samples alone: finish() reports what the reference does.
        let setup = Setup {
            cfg: cfg(window, 1),
            given: None,
        };
        check(
            &setup,
            &xs[xs.len().saturating_sub(window as usize)..],
            &[window as usize],
        );
    }
}

/// A full counter: the next sample is refused as `push` refuses it (NaN: non-finite first,
/// else the capacity), by `push` and `push_slice` alike, at the index it has in the slice.
#[test]
fn full_counter_is_refused_at_the_same_sample() {
    let setup = Setup {
        cfg: cfg(5, 1),
        given: Some([1.0; 3]),
    };
    let xs: Vec<[f32; 3]> = (0..20).map(|k| [k as f32, 0.0, 0.0]).collect();
    let (mut d, mut r) = (setup.detector(), setup.reference());
    for m in &xs {
        d.push(*m).unwrap();
        r.push(*m).unwrap();
    }
    d.count = u32::MAX - 3;
    r.count = u32::MAX - 3;
    let mut want = Vec::new();
    for m in &xs[..5] {
        want.push(r.push(*m).map(|o| o.map(interval)));
    }
    assert_eq!(want[3], Err(Error::CapacityExceeded));
    let mut e = d.clone();
    assert_eq!(
        e.push_slice(&xs[..5], |_| {}),
        Err((3, Error::CapacityExceeded))
    );
    assert_eq!(e.samples_seen(), u32::MAX);
    let mut nan = xs[..5].to_vec();
    nan[3] = [f32::NAN, 0.0, 0.0];
    assert_eq!(
        d.clone().push_slice(&nan, |_| {}),
        Err((3, Error::NonFinite))
    );
    nan[3] = [0.0; 3];
    nan[4] = [f32::NAN, 0.0, 0.0];
    assert_eq!(
        d.clone().push_slice(&nan, |_| {}),
        Err((3, Error::CapacityExceeded))
    );
    for (m, w) in xs[..5].iter().zip(&want) {
        assert_eq!(&d.push(*m).map(|o| o.map(interval)), w);
    }
    let mut full = ReferenceWelford3::new();
    full.push([1.0; 3]).unwrap();
    let mut w = Welford3::new();
    w.push([1.0; 3]).unwrap();
    for a in 0..3 {
        full.axes[a] = *w.axis(a).unwrap();
    }
    // The counter of both at its limit through the scalar accumulators' own state.
    let mut wf = w;
    wf.force_count_for_tests(u32::MAX);
    let mut rf = full;
    for a in &mut rf.axes {
        a.force_count_for_tests(u32::MAX);
    }
    assert_eq!(wf.push([f32::NAN, 0.0, 0.0]), rf.push([f32::NAN, 0.0, 0.0]));
    assert_eq!(wf.push([0.0; 3]), rf.push([0.0; 3]));
    assert_eq!(wf.push([0.0; 3]), Err(Error::CapacityExceeded));
}

/// What a span detector and the measurement of its spans report: each span as the interval
/// [`StaticInterval::of_run`] makes of its samples (the samples the detector took, refused
/// ones left out), and the refusals; fed in pieces as [`by_slices`] feeds.
fn by_spans(setup: &Setup, xs: &[[f32; 3]], pieces: &[usize]) -> Vec<Event> {
    let reference = setup.given.unwrap_or([0.5; 3]);
    let d = SpanDetector::<CAP>::with_reference(setup.cfg, reference).unwrap();
    let mut st = (d, Vec::new(), Vec::new(), Vec::new());
    let push = |(d, spans, _, _): &mut (SpanDetector<CAP>, Vec<StaticSpan>, _, _), xs: &[_]| {
        d.push_slice(xs, |s| spans.push(s))
    };
    in_pieces(
        &mut st,
        xs,
        pieces,
        push,
        |(_, _, refused, taken), fed| match fed {
            Fed::Taken(from, to) => taken.extend_from_slice(&xs[from..to]),
            Fed::Refused(i, e) => refused.push(Event::Refused(i, e)),
            Fed::PieceOver(..) => {}
        },
    );
    let (mut d, mut spans, mut out, taken) = st;
    spans.extend(d.finish());
    assert_eq!(d.samples_seen() as usize, taken.len());
    for s in spans {
        let mut w = Welford3::new();
        w.push_slice(&taken[s.start as usize..s.end as usize])
            .unwrap();
        out.extend(StaticInterval::of_run(s.start, s.end, &w).map(interval));
    }
    out
}

/// The same setup's detector (its reference given) fed as [`by_spans`], its intervals and
/// refusals in the same order (refusals first).
fn by_detector(setup: &Setup, xs: &[[f32; 3]], pieces: &[usize]) -> Vec<Event> {
    let reference = setup.given.unwrap_or([0.5; 3]);
    let d = StaticDetector::<CAP>::with_reference(setup.cfg, reference).unwrap();
    let mut st = (d, Vec::new(), Vec::new());
    let push = |(d, intervals, _): &mut (StaticDetector<CAP>, Vec<Event>, _), xs: &[_]| {
        d.push_slice(xs, |iv| intervals.push(interval(iv)))
    };
    in_pieces(&mut st, xs, pieces, push, |(_, _, refused), fed| {
        if let Fed::Refused(i, e) = fed {
            refused.push(Event::Refused(i, e));
        }
    });
    let (mut d, intervals, mut refused) = st;
    refused.extend(intervals);
    refused.extend(d.finish().map(interval));
    refused
}

/// `Welford3::of_four`'s results as bits, or the error.
fn four_bits(ws: [Result<Welford3, Error>; 4]) -> Vec<Result<[[u32; 5]; 3], Error>> {
    ws.iter()
        .map(|w| w.map(|w| [0, 1, 2].map(|a| welford_bits(w.axis(a).unwrap()))))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// The span detector's spans, each measured from its samples, are the detector's
    /// intervals bit for bit, with the same refusals, whenever every sample the detectors
    /// take is within `EXACT_SPAN_ABS` (the generated streams also go beyond it, where the
    /// detector may fail on a run's statistics: those are left out).
    #[test]
    fn spans_measured_are_the_detectors_intervals(
        setup in setups(),
        parts in stretches(),
        seed in any::<u32>(),
        pieces in prop::collection::vec(1usize..300, 1..5),
    ) {
        let xs = stream(&parts, seed);
        let taken: Vec<[f32; 3]> = xs.iter().copied().filter(|m| crate::all_finite(m)).collect();
        prop_assume!(spans_are_exact(&taken));
        prop_assert_eq!(by_spans(&setup, &xs, &pieces), by_detector(&setup, &xs, &pieces));
    }

    /// Four slices measured in step are each `push_slice` into an empty accumulator: the same
    /// state bit for bit, or the same error (non-finite samples, overflowing squares, empty
    /// and unequal slices).
    #[test]
    fn of_four_is_push_slice_of_each(
        parts in stretches(),
        seed in any::<u32>(),
        cuts in prop::collection::vec(0usize..500, 8),
    ) {
        let xs = stream(&parts, seed);
        let slice = |k: usize| {
            let from = cuts[2 * k].min(xs.len());
            &xs[from..(from + cuts[2 * k + 1]).min(xs.len())]
        };
        let four = [slice(0), slice(1), slice(2), slice(3)];
        let one_by_one = four.map(|s| {
            let mut w = Welford3::new();
            w.push_slice(s).map(|()| w).map_err(|(_, e)| e)
        });
        prop_assert_eq!(four_bits(Welford3::of_four(four)), four_bits(one_by_one));
        let blocks = four.map(NoiseSurvey::measure_block);
        let bits = |r: &Result<(crate::Vec3, bool), Error>| {
            r.map(|(v, w)| ([v.x, v.y, v.z].map(f32::to_bits), w))
        };
        let in_step = NoiseSurvey::measure_four_blocks(four);
        prop_assert_eq!(in_step.iter().map(bits).collect::<Vec<_>>(), blocks.iter().map(bits).collect::<Vec<_>>());
    }
}

/// A sample beyond `EXACT_SPAN_ABS` is what the exactness check refuses, and one at it is not;
/// the hand-made streams (huge offsets among them) give the detector's intervals whenever
/// they are within it.
#[test]
fn spans_are_exact_at_the_bound_and_on_hand_made_streams() {
    assert!(spans_are_exact(&[[EXACT_SPAN_ABS, -EXACT_SPAN_ABS, 0.0]]));
    let beyond = f32::from_bits(EXACT_SPAN_ABS.to_bits() + 1);
    assert!(!spans_are_exact(&[[0.0, -beyond, 0.0]]));
    assert!(!spans_are_exact(&[[0.0, 0.0, f32::NAN]]));
    let mut checked = 0;
    for (name, window, parts) in hand_made() {
        let xs = stream(&parts, 7);
        let taken: Vec<[f32; 3]> = xs
            .iter()
            .copied()
            .filter(|m| crate::all_finite(m))
            .collect();
        if !spans_are_exact(&taken) {
            continue;
        }
        let setup = Setup {
            cfg: cfg(window, 20),
            given: Some([0.5; 3]),
        };
        for pieces in [&[1usize][..], &[63], &[1000, 7, 64], &[100_000]] {
            let want = by_detector(&setup, &xs, pieces);
            assert!(!want.is_empty() || name.contains("one window"), "{name}");
            assert_eq!(
                by_spans(&setup, &xs, pieces),
                want,
                "{name}, pieces {pieces:?}"
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 5);
}
