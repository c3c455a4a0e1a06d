//! Samples held in memory in consecutive pieces (a recording's, or a streamed file's spill),
//! as the detector takes them (`f32`): the pieces' positions, a range of samples gathered
//! across pieces or read in place, the pieces fed to a detector in order, and the rule that
//! picks one error of two detectors run side by side. Shared by the detection's passes
//! ([`super::windows`]) and the span pair ([`super::spans`]).

type CoreError = wiical_core::Error;

/// A held sample as the detector takes it (`f32`).
pub(crate) trait DetectorSample: Copy + Send + Sync {
    /// The sample in `f32`.
    fn f32s(&self) -> [f32; 3];
    /// The samples as they are, when they already are `f32` (no copy).
    fn as_f32s(_samples: &[Self]) -> Option<&[[f32; 3]]> {
        None
    }
}

impl DetectorSample for [f32; 3] {
    #[inline]
    fn f32s(&self) -> [f32; 3] {
        *self
    }

    fn as_f32s(samples: &[Self]) -> Option<&[[f32; 3]]> {
        Some(samples)
    }
}

impl DetectorSample for [f64; 3] {
    #[inline]
    fn f32s(&self) -> [f32; 3] {
        self.map(|v| v as f32)
    }
}

/// The first sample index of each piece, and the total after the last.
pub(crate) fn piece_starts<S>(pieces: &[&[S]]) -> Vec<usize> {
    std::iter::once(0)
        .chain(pieces.iter().scan(0, |n, p| {
            *n += p.len();
            Some(*n)
        }))
        .collect()
}

/// Samples `from..to` of `pieces`, whose first samples are at `starts`.
pub(crate) fn samples_between<'a, S>(
    pieces: &'a [&'a [S]],
    starts: &'a [usize],
    from: usize,
    to: usize,
) -> impl Iterator<Item = &'a S> + 'a {
    let first = starts.partition_point(|&s| s <= from).saturating_sub(1);
    pieces[first..]
        .iter()
        .zip(&starts[first..])
        .take_while(move |(_, &s)| s < to)
        .flat_map(move |(p, &s)| {
            let clamp = |i: usize| i.saturating_sub(s).min(p.len());
            &p[clamp(from)..clamp(to)]
        })
}

/// The samples of up to four `ranges` (`from..to` of `pieces`, whose first samples are at
/// `starts`) as the detector takes them: in place when a range lies in one piece of `f32`
/// samples, else gathered into its buffer of `bufs`; empty slices after the last range.
pub(crate) fn four_slices<'a, S: DetectorSample>(
    pieces: &[&'a [S]],
    starts: &[usize],
    ranges: impl Iterator<Item = (usize, usize)>,
    bufs: &'a mut [Vec<[f32; 3]>; 4],
) -> [&'a [[f32; 3]]; 4] {
    let mut slices: [&[[f32; 3]]; 4] = [&[]; 4];
    for ((slice, buf), (from, to)) in slices.iter_mut().zip(bufs.iter_mut()).zip(ranges) {
        let k = starts.partition_point(|&s| s <= from).saturating_sub(1);
        let in_one = pieces.get(k).filter(|_| to <= starts[k + 1]);
        match in_one.and_then(|p| S::as_f32s(&p[from - starts[k]..to - starts[k]])) {
            Some(xs) => *slice = xs,
            None => {
                buf.clear();
                buf.extend(samples_between(pieces, starts, from, to).map(S::f32s));
                *slice = buf;
            }
        }
    }
    slices
}

/// Samples per chunk when held samples are cast to `f32` for a detector.
const CAST_CHUNK: usize = 4096;

/// Held samples in consecutive pieces given to `feed` in order: as they are when already
/// `f32`, else cast a chunk at a time; `feed`'s error with its index in the whole.
pub(crate) fn feed_held<S: DetectorSample>(
    pieces: &[&[S]],
    mut feed: impl FnMut(&[[f32; 3]]) -> std::result::Result<(), (usize, CoreError)>,
) -> std::result::Result<(), (usize, CoreError)> {
    let (mut at, mut buf) = (0, Vec::new());
    for samples in pieces {
        if let Some(xs) = S::as_f32s(samples) {
            feed(xs).map_err(|(i, e)| (at + i, e))?;
        } else {
            for (c, chunk) in samples.chunks(CAST_CHUNK).enumerate() {
                buf.clear();
                buf.extend(chunk.iter().map(S::f32s));
                feed(&buf).map_err(|(i, e)| (at + c * CAST_CHUNK + i, e))?;
            }
        }
        at += samples.len();
    }
    Ok(())
}

/// A pair's two results, or the error met first in sample order of the two (each with the
/// index of the sample that met it; the first setting's on the same sample).
pub(crate) fn both_or_first_error<A, B>(
    a: std::result::Result<A, (usize, CoreError)>,
    b: std::result::Result<B, (usize, CoreError)>,
) -> std::result::Result<(A, B), CoreError> {
    match (a, b) {
        (Ok(a), Ok(b)) => Ok((a, b)),
        (Err((i, e)), Err((j, _))) if i <= j => Err(e),
        (Err((_, e)), Ok(_)) | (_, Err((_, e))) => Err(e),
    }
}
