//! The detector pair over samples held in memory, by spans: each setting's static runs found by
//! the core's [`SpanDetector`] (the detector's decisions without its per-run statistics), then
//! every run's mean and variance measured from the samples, four runs at a time
//! ([`Welford3::of_four`]) on all cores: the core detector's intervals bit for bit, in about
//! half its time.
//!
//! Why: the detector's own loop updates the open run's statistics at every static sample, a
//! chain of dependent operations (a division among them) that it waits on sample after
//! sample. Measured apart, four runs keep four such chains in flight. The span detector's
//! result is the detector's only while no run's statistics can overflow, which every sample
//! within [`EXACT_SPAN_ABS`] guarantees: samples beyond it (never a real sensor's) take the
//! detector itself (`windows::run_held`).

use crate::detect::held::{
    both_or_first_error, feed_held, four_slices, piece_starts, DetectorSample,
};
use rayon::prelude::*;
use wiical_core::estimators::Welford3;
use wiical_core::static_detect::{
    spans_are_exact, SpanDetector, StaticDetectorConfig, StaticInterval, StaticSpan, EXACT_SPAN_ABS,
};

type CoreError = wiical_core::Error;

/// The intervals of two detector settings with the same reference over held samples in
/// consecutive pieces (the detector's ring `N` samples long), by spans, the two settings on
/// two cores at once; the error the one met first in sample order (the first setting's on the
/// same sample). `None` when a sample is beyond [`EXACT_SPAN_ABS`]: the detector itself then
/// gives the result.
pub(crate) fn pair<const N: usize, S: DetectorSample>(
    pieces: &[&[S]],
    cfgs: [StaticDetectorConfig; 2],
    reference: [f32; 3],
) -> Option<Result<[Vec<StaticInterval>; 2], CoreError>> {
    if !all_exact(pieces) {
        return None;
    }
    let starts = piece_starts(pieces);
    // Each setting's runs measured as soon as its spans are found (the other core may still
    // be finding the other's).
    let intervals =
        |cfg| spans_held::<N, S>(pieces, cfg, reference).map(|s| measured(pieces, &starts, &s));
    let (a, b) = rayon::join(|| intervals(cfgs[0]), || intervals(cfgs[1]));
    Some(both_or_first_error(a, b).and_then(|(a, b)| Ok([a?, b?])))
}

/// True when every sample, as the detector takes it, is within [`EXACT_SPAN_ABS`] (checked on
/// all cores).
fn all_exact<S: DetectorSample>(pieces: &[&[S]]) -> bool {
    pieces.par_iter().all(|p| {
        p.par_chunks(1 << 16).all(|chunk| match S::as_f32s(chunk) {
            Some(xs) => spans_are_exact(xs),
            None => chunk
                .iter()
                .all(|s| s.f32s().iter().all(|v| v.abs() <= EXACT_SPAN_ABS)),
        })
    })
}

/// One setting's spans over held samples in consecutive pieces ([`feed_held`]); the error
/// with the index of the sample that met it.
fn spans_held<const N: usize, S: DetectorSample>(
    pieces: &[&[S]],
    cfg: StaticDetectorConfig,
    reference: [f32; 3],
) -> Result<Vec<StaticSpan>, (usize, CoreError)> {
    let mut det = SpanDetector::<N>::with_reference(cfg, reference).map_err(|e| (0, e))?;
    let mut out = Vec::new();
    feed_held(pieces, |xs| det.push_slice(xs, |s| out.push(s)))?;
    out.extend(det.finish());
    Ok(out)
}

/// The interval of each span: its samples' statistics ([`StaticInterval::of_run`]), runs of
/// similar length measured four at a time, on all cores; the first error in span order (only
/// for samples beyond [`EXACT_SPAN_ABS`], which [`pair`] leaves to the detector).
fn measured<S: DetectorSample>(
    pieces: &[&[S]],
    starts: &[usize],
    spans: &[StaticSpan],
) -> Result<Vec<StaticInterval>, CoreError> {
    // By length, so that the four runs measured together end close to each other.
    let mut order: Vec<usize> = (0..spans.len()).collect();
    order.sort_by_key(|&k| spans[k].len());
    let found: Vec<(usize, Result<Option<StaticInterval>, CoreError>)> = order
        .par_chunks(4)
        .map_init(
            || [(); 4].map(|_| Vec::new()),
            |bufs, group| measure_group(pieces, starts, spans, group, bufs),
        )
        .flatten_iter()
        .collect();
    let mut out: Vec<Result<Option<StaticInterval>, CoreError>> = vec![Ok(None); spans.len()];
    for (k, iv) in found {
        out[k] = iv;
    }
    // A run with no sample gives no interval, as the detector's `close` gives none.
    out.into_iter().filter_map(Result::transpose).collect()
}

/// The intervals of the spans `group` (at most four, indices into `spans`), with their
/// indices; `bufs` hold the samples of a run that crosses pieces or is not `f32`.
fn measure_group<S: DetectorSample>(
    pieces: &[&[S]],
    starts: &[usize],
    spans: &[StaticSpan],
    group: &[usize],
    bufs: &mut [Vec<[f32; 3]>; 4],
) -> Vec<(usize, Result<Option<StaticInterval>, CoreError>)> {
    let ranges = group
        .iter()
        .map(|&k| (spans[k].start as usize, spans[k].end as usize));
    let stats = Welford3::of_four(four_slices(pieces, starts, ranges, bufs));
    group
        .iter()
        .zip(stats)
        .map(|(&k, w)| {
            let s = spans[k];
            (k, w.map(|w| StaticInterval::of_run(s.start, s.end, &w)))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use wiical_core::static_detect::StaticDetector;

    /// Holds of a few counts' noise at 24 orientations, with swings between them, 100 Hz.
    fn poses(seed: u64) -> Vec<[f32; 3]> {
        let mut s = seed | 1;
        let mut noise = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let mut out = Vec::new();
        for k in 0..24u32 {
            let g = [k % 3, (k / 3) % 3, (k / 9) % 3].map(|a| a as f32 * 4000.0 - 4000.0);
            let hold = 150 + (k as usize * 37) % 400;
            for _ in 0..hold {
                out.push(g.map(|v| (33_000.0 + v + 6.0 * noise()).round()));
            }
            for i in 0..60 {
                let ph = i as f32 * 0.2;
                out.push(g.map(|v| 33_000.0 + v + 3_000.0 * ph.sin() + noise()));
            }
        }
        out
    }

    fn cfgs() -> [StaticDetectorConfig; 2] {
        [
            StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0),
            StaticDetectorConfig::for_rate(100.0, 0.5, 1.0, 1.0),
        ]
    }

    /// Each interval with its floats as bits.
    fn bits(ivs: &[StaticInterval]) -> Vec<(u32, u32, [u32; 3], [u32; 3])> {
        ivs.iter()
            .map(|iv| {
                let b = |v: [f32; 3]| v.map(f32::to_bits);
                (iv.start, iv.end, b(iv.mean), b(iv.variance))
            })
            .collect()
    }

    /// The detection's ring (`windows::MAX_WINDOW`).
    const RING: usize = 511;

    type Pair = Result<[Vec<StaticInterval>; 2], CoreError>;

    /// One setting's intervals by the detector itself, fed as the pair feeds it.
    fn detector<S: DetectorSample>(
        pieces: &[&[S]],
        cfg: StaticDetectorConfig,
    ) -> Result<Vec<StaticInterval>, (usize, CoreError)> {
        let mut det = StaticDetector::<RING>::with_reference(cfg, REFERENCE).unwrap();
        let mut out = Vec::new();
        feed_held(pieces, |xs| det.push_slice(xs, |iv| out.push(iv)))?;
        out.extend(det.finish());
        Ok(out)
    }

    /// The detector's own pair over the same pieces.
    fn by_detector<S: DetectorSample>(pieces: &[&[S]]) -> Pair {
        let [a, b] = cfgs();
        both_or_first_error(detector(pieces, a), detector(pieces, b)).map(|(a, b)| [a, b])
    }

    const REFERENCE: [f32; 3] = [1.0, 1.2, 0.8];

    /// [`pair`] with the detection's ring.
    fn by_spans<S: DetectorSample>(pieces: &[&[S]]) -> Option<Pair> {
        pair::<RING, S>(pieces, cfgs(), REFERENCE)
    }

    /// Spans then measured runs give the detector's intervals bit for bit: samples in one
    /// piece and in pieces cut through runs, `f32` in place and `f64` cast.
    #[test]
    fn the_pair_by_spans_is_the_detectors_pair() {
        let xs = poses(7);
        let wide: Vec<[f64; 3]> = xs.iter().map(|m| m.map(f64::from)).collect();
        for cuts in [&[][..], &[1usize, 999, 5000][..], &[4321][..]] {
            let mut pieces: Vec<&[[f32; 3]]> = Vec::new();
            let mut pieces64: Vec<&[[f64; 3]]> = Vec::new();
            let mut at = 0;
            for &c in cuts.iter().chain([&xs.len()]) {
                pieces.push(&xs[at..c]);
                pieces64.push(&wide[at..c]);
                at = c;
            }
            let want = by_detector(&pieces).unwrap();
            assert!(
                want[0].len() >= 12 && want[1].len() >= 12,
                "{}",
                want[0].len()
            );
            let got = by_spans(&pieces).unwrap().unwrap();
            let got64 = by_spans(&pieces64).unwrap().unwrap();
            for k in 0..2 {
                assert_eq!(bits(&got[k]), bits(&want[k]), "setting {k}, cuts {cuts:?}");
                assert_eq!(
                    bits(&got64[k]),
                    bits(&want[k]),
                    "f64, setting {k}, cuts {cuts:?}"
                );
            }
        }
    }

    /// A sample beyond the exact range, or not finite, is left to the detector itself.
    #[test]
    fn samples_out_of_range_are_left_to_the_detector() {
        let mut xs = poses(3);
        assert!(by_spans(&[&xs[..]]).is_some());
        for bad in [3.0e37, -1.2e12, f32::NAN, f32::INFINITY] {
            xs[2000] = [0.0, bad, 0.0];
            assert!(by_spans(&[&xs[..]]).is_none(), "{bad}");
        }
    }
}
