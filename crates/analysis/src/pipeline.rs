//! One entry per pipeline: what `wiical fit --json` and `wiical analyze --json` print, as
//! library calls, so that the CLI and the Python package return the same contract from the
//! same types.
//!
//! Each takes the file's content as the loader read it ([`Input`]: samples, or a table whose
//! rows are still windows already) and returns the report with the quality verdict that
//! `device put` checks ([`Judged`]: the report's own keys, then `quality`).

use crate::autocal;
use crate::detect::windows::{detect_windows, Windows};
use crate::error::Result;
use crate::input::front_door::Input;
use crate::input::table::WindowTable;
use crate::protocol::sensor_kind::explain;
use crate::report::verdict::Quality;
use crate::search::analyze::{analyze_rows, analyze_windows};
use crate::source::{RowSource, SampleSource};
use crate::{AnalyzeOptions, AnalyzeReport, FitOptions, FitReport};
use serde::Serialize;
use wiical_core::acceptance::CoverageRule;

/// A report and its quality verdict; serialises as the report's keys followed by
/// `quality` (the `--json` contract of `fit` and `analyze`).
#[derive(Debug, Clone, Serialize)]
pub struct Judged<R> {
    /// The pipeline's report.
    #[serde(flatten)]
    pub report: R,
    /// Fit RMS and pose coverage, judged.
    pub quality: Quality,
}

/// `wiical fit`: static windows (or the table's rows) → the 9- or 6-parameter calibration,
/// judged on its poses.
pub fn fit_judged(input: &Input, opts: &FitOptions) -> Result<Judged<FitReport>> {
    match input {
        Input::Table(table) => judged_free(fit_table(table, opts)?),
        Input::Samples(rec) if rec.labels.is_some() => {
            Err(crate::error::fit::FitError::PoseTable { rows: rec.len() }.into())
        }
        Input::Samples(rec) => fit_rows(rec, opts),
        Input::Stream(src) => fit_rows(&**src, opts),
    }
}

/// [`fit_judged`] on the rows of `src`, held or a large file read in passes (one code).
fn fit_rows<R: RowSource + ?Sized>(src: &R, opts: &FitOptions) -> Result<Judged<FitReport>> {
    let ws = detect_windows(src, &opts.detect);
    src.check()?;
    let ws = ws?;
    let r = crate::protocol::accel::fit_by_protocol(&ws, opts)
        .map_err(|e| explain(e, src.axis_columns(), &Axes(src), &ws))?;
    Ok(Judged {
        report: r.report,
        quality: r.quality,
    })
}

/// `result` of the analysis of the rows of `src`, a refusal with the windows found again
/// (only then) to say whether the rows look like another sensor's ([`explain`]).
fn explained<R: RowSource + ?Sized>(
    src: &R,
    opts: &AnalyzeOptions,
    result: Result<AnalyzeReport>,
) -> Result<AnalyzeReport> {
    result.map_err(|e| match detect_windows(src, &opts.fit.detect) {
        Ok(ws) if src.check().is_ok() => explain(e, src.axis_columns(), &Axes(src), &ws),
        _ => e,
    })
}

/// The axes of the rows of `src` as [`explain`] reads them (a [`SampleSource`]).
struct Axes<'a, R: ?Sized>(&'a R);

impl<R: RowSource + ?Sized> SampleSource for Axes<'_, R> {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> Result<()> {
        self.0.rows().for_each(|r| f(&r.xyz));
        self.0.check()
    }
}

/// A free-pose fit report judged on its poses by the default coverage rule.
fn judged_free(report: FitReport) -> Result<Judged<FitReport>> {
    let r = crate::protocol::accel::judged_free(report);
    Ok(Judged {
        report: r.report,
        quality: r.quality,
    })
}

/// `wiical analyze`: the residual analysis, judged on its poses (a six-position table on its
/// six poses, by the six-position coverage rule).
pub fn analyze_judged(input: &Input, opts: &AnalyzeOptions) -> Result<Judged<AnalyzeReport>> {
    let report = match input {
        Input::Table(t) => analyze_table(t, opts)?,
        Input::Samples(rec) => explained(rec, opts, crate::analyze(rec, opts))?,
        Input::Stream(src) => explained(&**src, opts, analyze_rows(&**src, opts))?,
    };
    let quality = match &report.six_position {
        Some(six) => Quality::assess_with(
            &report.calibration,
            &six.pose_means_raw,
            report.final_model.rms_mg,
            CoverageRule::six_position(),
        ),
        None => {
            let means: Vec<[f64; 3]> = report.windows.iter().map(|w| w.mean).collect();
            Quality::assess(&report.calibration, &means, report.final_model.rms_mg)
        }
    };
    let quality = quality.with_residual(
        report.final_model.cv_rms_mg,
        report.noise_floor_mg,
        report.final_model.chi2_p,
    );
    Ok(Judged { report, quality })
}

/// `fit` on a window-mean table: the rows are the windows ([`crate::fit::base::run_windows`]).
fn fit_table(table: &WindowTable, opts: &crate::fit::base::FitOptions) -> Result<crate::FitReport> {
    let mut rep = crate::fit::base::run_windows(&Windows::of_table(table), opts)?;
    rep.window_input = Some(table.info.clone());
    Ok(rep)
}

/// `analyze` on a window-mean table: the standard pipeline on the rows as windows
/// ([`crate::search::analyze::analyze_windows`]: full model, effects by the usual rule; its
/// `calibration` is what `--out` writes) plus, for comparison, the van Hees et al. 2014
/// autocalibration of the same windows ([`crate::autocal`], when the means are in g).
fn analyze_table(
    table: &WindowTable,
    opts: &crate::AnalyzeOptions,
) -> Result<crate::AnalyzeReport> {
    let ws = Windows::of_table(table);
    let units = ws.units;
    let mut rep = analyze_windows(&table.recording, ws, opts)?;
    rep.window_input = Some(table.info.clone());
    let rec = &table.recording;
    let run = |opts: &autocal::AutocalOptions| {
        let fit = if units == "g" {
            autocal::autocalibrate(&rec.xyz, rec.temp.as_deref(), opts)
        } else {
            Err(autocal::AutocalError::NotInG { units })
        };
        match fit {
            Ok(fit) => fit.report(),
            Err(e) => autocal::AutocalReport::not_done(rec.len(), &e),
        }
    };
    rep.autocalibration = Some(run(&autocal::AutocalOptions::default()));
    rep.autocalibration_converged = Some(run(&autocal::AutocalOptions::converged()));
    Ok(rep)
}
