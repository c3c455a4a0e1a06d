//! `wiical magfit`'s fit and loop in passes over a recording's rows ([`RowSource`]: a held
//! [`crate::Recording`], or a large plain text file read again each pass, with memory that does
//! not grow with it): the held and the large-file path are this one code.
//!
//! Every sum is a fold fed the rows in file order (`super::fit::FitFold`,
//! `super::floor::StepFold`, `super::floor::AxisSums`, `super::candidates::ScalarFold`,
//! `super::LoopPass`). The passes:
//!
//! 1. the core's fit, the axes' differences, the means, the times and temperature;
//! 2. the axes' spread about their means and the fit's quality (and the first digit of any
//!    median still to select);
//! 3. up to two more for the medians of the |second differences| when an axis has more
//!    than [`MAX_COUNTED`] distinct values: selected by their bits, 16 at a time
//!    (`crate::stats::medians`), every axis and both middle ranks in the same passes;
//! 4. each `--follow` column's own pass (its mean), then the loop's pass: each sample's
//!    geometry into the floor, the coverage and the blocks' normal equations
//!    (`super::design::Normal`), dropped.
//!
//! The medians are exact order statistics either way (counted by value, or selected by bits),
//! as a sort gives them.

use super::candidates::{ColumnFold, ScalarFold};
use super::fit::{FitFold, MagFitReport, QualityFold};
use super::floor::{blob, AxisSums, StepFold};
use super::{LoopPass, MagAnalysis, MagModel, MagnetometerError};
use crate::error::Result;
use crate::input::columns::{triplet_unit, LoadOptions};
use crate::input::read_options::ReadOptions;
use crate::input::text_source::Row;
use crate::source::RowSource;
use crate::stats::OrderCounts;

/// A column the field's centre may follow (`--follow`), read in step with the field's rows
/// (the first axis of its rows: [`follow_options`]) and the way they are (held, or a large
/// file in passes: the same [`RowSource`] `R`).
pub type Follow<R> = (String, R);

/// Most distinct |second differences| per axis counted by value before the median is
/// selected by bits instead (2¹⁸ keys: a few MB per axis at most). Quantised sensors have a
/// handful; a file in gauss with many decimals may pass it.
pub const MAX_COUNTED: usize = 1 << 18;

/// How a `--follow` column `name` is read beside a field whose axes are `field_axes`: as the
/// first of three columns, the other two the field's own (the loader reads a triplet, and
/// refuses one column named for two axes), so that its rows are the field's rows; the file
/// read as `read` says.
pub fn follow_options(name: &str, field_axes: &[String; 3], read: &ReadOptions) -> LoadOptions {
    let mut others = field_axes.iter().filter(|a| a.as_str() != name).cloned();
    let mut next = || others.next().unwrap_or_default();
    LoadOptions {
        columns: Some([name.to_string(), next(), next()]),
        sensor: None,
        read: *read,
    }
}

/// The field's unit as its columns name it (`raw` when the header does not say).
pub fn unit_of<R: RowSource + ?Sized>(src: &R) -> &'static str {
    triplet_unit(src.axis_columns()).unwrap_or("raw")
}

/// The fit and what the loop needs from the first passes.
#[derive(Debug)]
pub struct Prepared {
    /// The fit, as [`super::fit_points`] reports it for the same points.
    pub report: MagFitReport,
    sigma: [f64; 3],
    scalars: ScalarFold,
}

/// Sample `i`'s time: the time column, else `i / Fs`, else `i`.
fn time_of<R: RowSource + ?Sized>(src: &R, i: usize, row: &Row) -> f64 {
    match (row.t, src.metadata_rate_hz()) {
        (Some(t), _) => t,
        (None, Some(fs)) => i as f64 / fs,
        (None, None) => i as f64,
    }
}

/// The fit of `src` with `model` (passes 1–3 of the module docs), refused when the points
/// never leave a blob of their own noise (`super::floor::blob`: an ellipsoid fitted to them
/// would be a shape of the noise, not of the field), then for the fit's own errors.
pub fn fit_source<R: RowSource + ?Sized>(src: &R, model: MagModel) -> Result<Prepared> {
    fit_source_counting(src, model, MAX_COUNTED)
}

/// [`fit_source`] counting at most `max_counted` distinct |second differences| per axis by
/// value (tests: the selection by bits on a small file).
pub fn fit_source_counting<R: RowSource + ?Sized>(
    src: &R,
    model: MagModel,
    max_counted: usize,
) -> Result<Prepared> {
    let n = src.len();
    let mut fit = FitFold::new(model);
    let mut steps = StepFold::new();
    let mut counts: [OrderCounts; 3] = std::array::from_fn(|_| OrderCounts::new(max_counted));
    let mut sums = AxisSums::new();
    let mut scalars = ScalarFold::new(n, src.has_temp());
    for (i, row) in src.rows().enumerate() {
        fit.push(&row.xyz);
        if let Some(d) = steps.push(&row.xyz) {
            (0..3).for_each(|a| counts[a].push(d[a].to_bits()));
        }
        sums.push(&row.xyz);
        scalars.push(time_of(src, i, &row), row.temp.unwrap_or(f64::NAN));
    }
    src.check()?;
    let fit = fit.solve();
    let mean = sums.mean();
    let mut dev = AxisSums::new();
    let mut quality = fit.as_ref().ok().map(|f| QualityFold::new(*f));
    let median = medians(src, &counts, |row| {
        dev.push_dev(&row.xyz, &mean);
        if let Some(q) = &mut quality {
            q.push(&row.xyz);
        }
    })?;
    let sigma = steps.noise(median);
    if n >= 3 {
        if let Some((spread, noise)) = blob(dev.spread(), sigma) {
            return Err(MagnetometerError::NotRotated { spread, noise }.into());
        }
    }
    fit?;
    let report = quality.map_or(Err(MagnetometerError::NoMagSamples), |q| q.report(model, n))?;
    Ok(Prepared {
        report,
        sigma,
        scalars,
    })
}

/// The loop on `src` around `prep`'s fit (made with `model`) at family level `alpha`, with
/// the `--follow` columns `follow` (as many rows as the field). When the loop accepts an
/// `interference:<column>` effect, two more passes refit the base without it and a third runs
/// the loop again about that estimate (`super::KnownShift`).
pub fn analyze_source<R: RowSource>(
    src: &R,
    prep: &Prepared,
    follow: &[Follow<R>],
    model: MagModel,
    alpha: f64,
) -> Result<MagAnalysis> {
    let n = src.len();
    let mut folds = Vec::new();
    for (name, f) in follow {
        let mut fold = ColumnFold::new();
        f.rows().for_each(|r| fold.push(r.xyz[0]));
        f.check()?;
        folds.push((name.clone(), fold));
    }
    let time_unit = if src.has_time() || src.metadata_rate_hz().is_some() {
        "s"
    } else {
        "sample"
    };
    let unit = unit_of(src);
    let scalars = prep.scalars.scalars(&folds, unit, time_unit);
    let (has_temp, has_follow) = (src.has_temp(), !follow.is_empty());
    let first = LoopPass::new(&prep.report, prep.sigma, scalars.clone(), model, unit, n);
    let first = loop_pass(src, follow, first)?.finish(alpha, has_temp, has_follow);
    let known = super::known_shifts(&scalars, &first);
    if known.is_empty() {
        return Ok(first);
    }
    let mut fit = FitFold::new(model);
    each_row(src, follow, |_, row, values| {
        fit.push(&super::shifted(&row.xyz, values, &known))
    })?;
    let Ok(solved) = fit.solve() else {
        return Ok(first);
    };
    let mut quality = QualityFold::new(solved);
    each_row(src, follow, |_, row, values| {
        quality.push(&super::shifted(&row.xyz, values, &known))
    })?;
    let Ok(rep2) = quality.report(model, n) else {
        return Ok(first);
    };
    let second = LoopPass::new(&rep2, prep.sigma, scalars, model, unit, n).with_known(&known);
    Ok(loop_pass(src, follow, second)?.finish(alpha, has_temp, has_follow))
}

/// Every row of `src` into `pass` with its time, temperature and followed values.
fn loop_pass<'r, R: RowSource>(
    src: &R,
    follow: &[Follow<R>],
    mut pass: LoopPass<'r>,
) -> Result<LoopPass<'r>> {
    each_row(src, follow, |i, row, values| {
        let temp = row.temp.unwrap_or(f64::NAN);
        pass.push(&row.xyz, time_of(src, i, row), temp, values);
    })?;
    Ok(pass)
}

/// One pass over `src`'s rows, each with its index and the followed columns' values (`NaN`
/// past a column's end); the files checked unchanged after it.
fn each_row<R: RowSource>(
    src: &R,
    follow: &[Follow<R>],
    mut f: impl FnMut(usize, &Row, &[f64]),
) -> Result<()> {
    let mut rows: Vec<_> = follow.iter().map(|(_, f)| f.rows()).collect();
    let mut values = vec![0.0; follow.len()];
    for (i, row) in src.rows().enumerate() {
        for (v, r) in values.iter_mut().zip(&mut rows) {
            *v = r.next().map_or(f64::NAN, |r| r.xyz[0]);
        }
        f(i, &row, &values);
    }
    drop(rows);
    src.check()?;
    for (_, f) in follow {
        f.check()?;
    }
    Ok(())
}

/// The median |second difference| of each axis (`NaN` without any), as [`crate::stats::median`]
/// of them gives it ([`crate::stats::medians`]): the middle ranks counted by value, or
/// selected by bits in passes that serve every axis and rank at once. `first` is given every
/// row of the first pass made (there is always one).
fn medians<R: RowSource + ?Sized>(
    src: &R,
    counts: &[OrderCounts; 3],
    mut first: impl FnMut(&Row),
) -> Result<[f64; 3]> {
    let passes = std::cell::Cell::new(0);
    let mut pass = |key: &mut dyn FnMut(usize, u64)| {
        let mut steps = StepFold::new();
        for row in src.rows() {
            if passes.get() == 0 {
                first(&row);
            }
            if let Some(d) = steps.push(&row.xyz) {
                (0..3).for_each(|a| key(a, d[a].to_bits()));
            }
        }
        passes.set(passes.get() + 1);
        src.check()
    };
    let axes = [&counts[0], &counts[1], &counts[2]];
    let m = crate::stats::medians(&axes, f64::from_bits, &mut pass)?;
    if passes.get() == 0 {
        pass(&mut |_, _| {})?;
    }
    Ok([m[0], m[1], m[2]])
}
