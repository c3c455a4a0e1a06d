//! The correction, written once: one pass over a recording's rows in order ([`RowSource`]:
//! a large file's rows read from it, [`crate::input::text_source::TextSource::rows`], or a
//! recording held in memory, the one-chunk case [`super::correct_recording`] takes) corrects
//! every sample and gives it out — for a file, its line to a temporary file beside the
//! output ([`AtomicWriter`]) —, folding on the way what
//! the checks need (`super::checks`: the readings' and temperatures' extremes, where the
//! linear correction's magnitudes lie against ½–2 g, the first corrected value that is not
//! finite or beyond ±16 g). The temporary file replaces the output only when every check
//! passed, in the order of [`super`]'s module docs; nothing is written where they refuse.
//!
//! Memory: a piece of the file and its parsed rows (`TextSource`), the write buffer and,
//! with a temperature-rate term, the samples of ±15 s (`RateRing`) — not the samples.
//! Cost: the source's first pass plus this one; a units check the counts cannot settle
//! (a recording in other units: it is refused) selects the exact median by its bits in four
//! more passes per median (`stats::OrderCounts::median`).

use super::checks::{
    bad_output, check_plausible_within, linear_norm, norm, units_verdict, RangeFold, UnitsCount,
};
use super::regress::{RateRing, Ready, Regressors};
use super::{applied, check_core_temperature, correct_at, csv, CorrectError, PLAUSIBLE_MEDIAN_G};
use crate::error::{Error, Result};
use crate::input::text_source::TextSource;
use crate::output::calfile::CalibrationFile;
use crate::output::write::AtomicWriter;
use crate::source::RowSource;
use std::io::Write;
use std::path::Path;

/// What a streamed correction did: as [`super::Corrected`] without the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamedCorrection {
    /// Samples corrected and written.
    pub samples: usize,
    /// The terms applied ([`super::applied`]).
    pub applied: Vec<String>,
}

/// Corrects every sample of `src` with `file` and writes the CSV ([`csv`]) to `out`
/// atomically: created or replaced only when every check passed. Sample times as
/// [`super::correct_recording`] takes them (the time column, else `i / rate` with the file's
/// rate, else `default_rate_hz`). Errors about the recording (its checks, a pass that found
/// the file changed) name `named`; errors writing name `out`.
pub fn correct_streamed(
    file: &CalibrationFile,
    src: &TextSource,
    default_rate_hz: f64,
    out: &Path,
    named: &Path,
) -> Result<StreamedCorrection> {
    let in_file = |e: Error| match e {
        Error::Output(_) => e,
        other => other.in_file(named),
    };
    let mut w = AtomicWriter::create(out)?;
    w.write_all(csv::HEADER).map_err(|e| w.error(e))?;
    let samples = {
        let mut write = |t: f64, a: &[f32; 3]| -> Result<()> {
            csv::write_row(&mut w, t, a).map_err(|e| w.error(e).into())
        };
        correct_pass(file, src, default_rate_hz, &mut write).map_err(in_file)?
    };
    w.commit()?;
    Ok(StreamedCorrection {
        samples,
        applied: applied(file),
    })
}

/// One sample as read: its time as the recording gives it, readings, temperature.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    xyz: [f64; 3],
    temp: Option<f64>,
}

/// What the pass folds for the checks after it.
struct Pass<'a> {
    file: &'a CalibrationFile,
    regressors: Regressors,
    xs: Vec<f64>,
    range: RangeFold,
    units: UnitsCount,
    /// s since the first sample, of the last sample.
    last_since: Option<f64>,
    t0: Option<f64>,
    /// The first corrected value that is not finite, and the first that is not finite or
    /// is beyond ±16 g ([`bad_output`]).
    not_finite: Option<CorrectError>,
    unbounded: Option<CorrectError>,
}

impl Pass<'_> {
    /// One sample given out by the ring: corrected, folded, given to `out` while nothing is
    /// refused yet (once a sample is, the output is never used).
    fn take(&mut self, r: Ready<Sample>, out: &mut Sink<'_>) -> Result<()> {
        let Sample { t, xyz, temp } = r.payload;
        let since = t - self.t0.unwrap_or(t);
        self.regressors
            .next(r.index, since, temp, r.rate, &mut self.xs)?;
        let a = correct_at(self.file, xyz.map(|v| v as f32), since, temp, &self.xs);
        self.range.push_reading(&xyz);
        if let Some(x) = temp {
            self.range.push_temperature(x);
        }
        self.units.push(linear_norm(&self.file.calibration, &xyz));
        self.last_since = Some(since);
        if self.not_finite.is_none() {
            self.not_finite = bad_output(r.index, t, &a, false);
        }
        if self.unbounded.is_none() {
            self.unbounded = bad_output(r.index, t, &a, true);
            if self.unbounded.is_none() {
                out(t, &a)?;
            }
        }
        Ok(())
    }
}

/// Where the pass gives each corrected sample: its time (s, as the recording gives it) and
/// acceleration (g).
pub(crate) type Sink<'a> = dyn FnMut(f64, &[f32; 3]) -> Result<()> + 'a;

/// The correction of every sample of `src` with `file`, each given to `out`, then the checks
/// in the order of [`super`]'s module docs; returns the samples corrected. Sample times as
/// [`super::correct_recording`] takes them (the time column, else `i / rate` with the
/// recording's rate, else `default_rate_hz`).
pub(crate) fn correct_pass(
    file: &CalibrationFile,
    src: &impl RowSource,
    default_rate_hz: f64,
    out: &mut Sink<'_>,
) -> Result<usize> {
    if src.len() == 0 {
        return Err(CorrectError::Empty.into());
    }
    check_core_temperature(file, src.has_temp())?;
    let regressors = Regressors::new(&file.host_terms, src.has_temp())?;
    let rate_term = regressors.rate_term().unwrap_or_default().to_string();
    let rate_term = || rate_term.clone();
    let rates = regressors.needs_rate();
    let mut ring: RateRing<Sample> = match src.held() {
        Some(_) => RateRing::unbounded(rates),
        None => RateRing::new(rates),
    };
    let mut pass = Pass {
        file,
        xs: vec![0.0; regressors.len()],
        regressors,
        range: RangeFold::new(),
        units: UnitsCount::default(),
        last_since: None,
        t0: None,
        not_finite: None,
        unbounded: None,
    };
    let fs = src.metadata_rate_hz().unwrap_or(default_rate_hz);
    for (i, row) in src.rows().enumerate() {
        let t = row.t.unwrap_or_else(|| i as f64 / fs);
        let t0 = *pass.t0.get_or_insert(t);
        let s = Sample {
            t,
            xyz: row.xyz,
            temp: row.temp,
        };
        ring.push(t - t0, row.temp.unwrap_or(0.0), s, &rate_term)?;
        while let Some(r) = ring.pop(false) {
            pass.take(r, out)?;
        }
    }
    while let Some(r) = ring.pop(true) {
        pass.take(r, out)?;
    }
    src.check()?;
    let n = src.len();
    check_after(pass, src)?;
    Ok(n)
}

/// The checks on what the pass folded, in the held path's order: units, a value that is not
/// finite, the acceptance predicate, a value beyond ±16 g.
fn check_after(pass: Pass<'_>, src: &impl RowSource) -> Result<()> {
    let cal = &pass.file.calibration;
    if !pass.units.surely_passes() {
        let median_g = streamed_median(src, |m| linear_norm(cal, m))?;
        let (lo, hi) = PLAUSIBLE_MEDIAN_G;
        let raw = match median_g {
            Some(m) if !(lo..=hi).contains(&m) => streamed_median(src, |m| norm(*m))?,
            _ => None,
        };
        units_verdict(cal, median_g, || raw)?;
    }
    if let Some(e) = pass.not_finite {
        return Err(e.into());
    }
    check_plausible_within(cal, pass.range.limits(pass.last_since))?;
    match pass.unbounded {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

/// The median of the finite values of `f` over the samples of `src` (the mean of the middle
/// two for an even count, as [`super::checks::median`] takes it), selected by the bits of
/// their order, none stored: a pass to count them, then [`crate::stats::OrderCounts::median`]
/// (three passes for both middle values).
fn streamed_median(src: &impl RowSource, f: impl Fn(&[f64; 3]) -> f64) -> Result<Option<f64>> {
    use crate::stats::{from_order_key, order_key, OrderCounts};
    let keys = |key: &mut dyn FnMut(u64)| {
        for row in src.rows() {
            let v = f(&row.xyz);
            if v.is_finite() {
                key(order_key(v));
            }
        }
        src.check()
    };
    // No count by value: the norms of a recording are all distinct.
    let mut counts = OrderCounts::new(0);
    keys(&mut |k| counts.push(k))?;
    if counts.len == 0 {
        return Ok(None);
    }
    counts.median(from_order_key, keys).map(Some)
}
