//! One entry per pipeline: what `wiical fit --json` and `wiical analyze --json` print, as
//! library calls, so that the CLI and the Python package return the same contract from the
//! same types.
//!
//! Each takes the file's content as the loader read it ([`Input`]: samples, or a table whose
//! rows are still windows already) and returns the report with the quality verdict that
//! `device put` checks ([`Judged`]: the report's own keys, then `quality`).

use crate::autocal;
use crate::detect::windows::Windows;
use crate::error::Result;
use crate::input::front_door::Input;
use crate::input::table::WindowTable;
use crate::protocol::sensor_kind::explain;
use crate::report::verdict::Quality;
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
    let judged = |r: crate::protocol::accel::AccelResult| Judged {
        report: r.report,
        quality: r.quality,
    };
    match input {
        Input::Table(table) => judged_free(fit_table(table, opts)?),
        Input::Samples(rec) => {
            if rec.labels.is_some() {
                return Err(crate::error::fit::FitError::PoseTable { rows: rec.len() }.into());
            }
            let ws = crate::detect::windows::detect_windows_untimed(rec, &opts.detect)?;
            crate::protocol::accel::fit_by_protocol(&ws, opts)
                .map(judged)
                .map_err(|e| explain(e, &rec.axis_columns, rec.xyz.as_slice(), &ws))
        }
        Input::Stream(src) => {
            let ws = crate::detect::windows::detect_windows_untimed(&**src, &opts.detect)?;
            crate::protocol::accel::fit_by_protocol(&ws, opts)
                .map(judged)
                .map_err(|e| explain(e, &src.meta.axis_columns, &**src, &ws))
        }
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
        // On a refusal, the windows again (only then) to say whether the samples look like
        // another sensor's.
        Input::Samples(rec) => crate::analyze(rec, opts).map_err(|e| {
            match crate::detect::windows::detect_windows_untimed(rec, &opts.fit.detect) {
                Ok(ws) => explain(e, &rec.axis_columns, rec.xyz.as_slice(), &ws),
                Err(_) => e,
            }
        })?,
        Input::Stream(src) => crate::search::analyze::analyze_streamed(src, opts).map_err(|e| {
            match crate::detect::windows::detect_windows_untimed(&**src, &opts.fit.detect) {
                Ok(ws) => explain(e, &src.meta.axis_columns, &**src, &ws),
                Err(_) => e,
            }
        })?,
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
    let mut rep = crate::search::analyze::analyze_windows(&table.recording, ws, opts)?;
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
