//! The accelerometer's method chosen by its protocol: free poses keep the multi-position fit;
//! faces get the seed's six-position method; one pose gets offsets. The result is the `fit`
//! report either way, with a `protocol` object when the method is not today's.

use super::face_fit::{fit_faces, FaceMean};
use super::offsets::{not_identified, offsets};
use super::{recognise, AccelProtocol, AccelRecognition, ProtocolReport};
use crate::detect::windows::Windows;
use crate::error::fit::FitError;
use crate::fit::base::{run_windows, window_reports, FitOptions, FitReport};
use crate::report::verdict::Quality;
use wiical_core::acceptance::CoverageRule;
use wiical_core::Calibration;

/// A fit report and the verdict its method calls for.
pub struct AccelResult {
    /// The report (`fit --json`'s keys).
    pub report: FitReport,
    /// Judged by the method's own promise: a six-position set by the six-position rule, one
    /// pose as offsets only.
    pub quality: Quality,
}

/// Fits the windows `ws` with the method their protocol calls for.
pub fn fit_by_protocol(ws: &Windows, opts: &FitOptions) -> Result<AccelResult, crate::Error> {
    let rec = recognise(ws);
    match rec.protocol {
        AccelProtocol::Faces => faces(ws, &rec),
        AccelProtocol::OnePose => one_pose(ws, &rec),
        AccelProtocol::None | AccelProtocol::FreePoses => Ok(judged_free(run_windows(ws, opts)?)),
    }
}

/// A free-pose fit report judged on its poses by the default coverage rule (the
/// multi-position fit's verdict, also for a window-mean table's rows).
pub fn judged_free(report: FitReport) -> AccelResult {
    let means: Vec<[f64; 3]> = report
        .windows
        .iter()
        .map(|w| w.mean.map(f64::from))
        .collect();
    let quality = Quality::assess(&report.calibration, &means, f64::from(report.rms_mg));
    AccelResult { report, quality }
}

/// The six-position family.
fn faces(ws: &Windows, rec: &AccelRecognition) -> Result<AccelResult, crate::Error> {
    let means: Vec<FaceMean> = ws
        .stats
        .iter()
        .zip(&rec.faces)
        .filter_map(|(w, f)| {
            Some(FaceMean {
                pose: f.pose?,
                mean: w.mean,
                samples: w.count,
            })
        })
        .collect();
    let fit = fit_faces(&means, &rec.set).map_err(|e| FitError::Protocol {
        summary: rec.summary(),
        why: e.to_string(),
    })?;
    let face_means: Vec<[f64; 3]> = fit.faces.iter().map(|(_, m)| *m).collect();
    let mut report = report_of(ws, &fit.calibration, fit.identifiability);
    let quality = Quality::assess_with(
        &fit.calibration,
        &face_means,
        f64::from(report.rms_mg),
        CoverageRule::six_position(),
    );
    report.protocol = Some(ProtocolReport {
        summary: rec.summary(),
        kind: rec.protocol,
        method: fit.method,
        faces: rec.set.clone(),
        face_fit: Some(fit.report()),
        offsets: None,
        not_identified: fit.not_identified.clone(),
    });
    Ok(AccelResult { report, quality })
}

/// One pose: offsets only; the verdict says scale and misalignment were not measured.
fn one_pose(ws: &Windows, rec: &AccelRecognition) -> Result<AccelResult, crate::Error> {
    let (cal, off) =
        offsets(&ws.stats, &rec.faces[0], ws.units, rec.zero).map_err(|e| FitError::Protocol {
            summary: rec.summary(),
            why: e.to_string(),
        })?;
    let mut report = report_of(ws, &cal, 0.0);
    let mean = [off.offsets[0], off.offsets[1], off.offsets[2]];
    let mut quality = Quality::assess_with(
        &cal,
        &[mean],
        f64::from(report.rms_mg),
        CoverageRule::six_position(),
    );
    quality.coverage_gap =
        Some("one pose: offsets only, scale and misalignment were not measured".into());
    quality.verdict = crate::report::verdict::Verdict::Poor;
    report.protocol = Some(ProtocolReport {
        summary: rec.summary(),
        kind: rec.protocol,
        method: "one-pose-offsets",
        faces: rec.set.clone(),
        face_fit: None,
        offsets: Some(off),
        not_identified: not_identified(ws.units),
    });
    Ok(AccelResult { report, quality })
}

/// The `fit` report of a calibration not found by the multi-position solver.
fn report_of(ws: &Windows, cal: &Calibration, identifiability: f64) -> FitReport {
    let windows = window_reports(ws, cal);
    let sq: f32 = windows.iter().map(|w| w.residual_mg * w.residual_mg).sum();
    let rms_mg = (sq / windows.len().max(1) as f32).sqrt();
    let max_abs_mg = windows
        .iter()
        .map(|w| w.residual_mg.abs())
        .fold(0.0, f32::max);
    FitReport {
        static_windows: windows.len(),
        bias: cal.bias,
        matrix: cal.matrix,
        rms_mg,
        max_abs_mg,
        iterations: 0,
        identifiability: identifiability as f32,
        noise_std: ws.reference_variance.map(f32::sqrt),
        windows,
        window_input: None,
        calibration: *cal,
        protocol: None,
        polling: ws.polling.clone(),
    }
}
