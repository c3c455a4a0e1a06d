//! The six candidate models of the multi-position fit, each judged by its leave-one-motion-out
//! error, and the per-motion table of the chosen one.

use super::options::{deg, GyroError, GyroOptions, Result};
use super::samples::Collected;
use super::segment::Segmentation;
use serde::Serialize;
use wiical_core::gyro::{GyroCalibration, MotionResidual};
use wiical_core::gyro_fit::{
    self, fit_keeping_from_nominal, leave_one_out, leave_one_out_one_step, nominal_pass,
    GyroFitConfig, GyroModel, Motion, NominalPass,
};

/// One candidate model's numbers.
#[derive(Debug, Clone, Serialize)]
pub struct GyroModelRow {
    /// Model name (see the module docs).
    pub name: &'static str,
    /// Fitted parameters.
    pub parameters: usize,
    /// In-sample RMS angle error over the motions, degrees (null if the fit failed).
    pub rms_deg: Option<f64>,
    /// Leave-one-motion-out RMS angle error, degrees (null if a fit failed).
    pub cv_rms_deg: Option<f64>,
    /// Smallest eigenvalue of the unit-diagonal normal matrix (near 0: badly determined).
    pub identifiability: Option<f64>,
    /// Why the fit failed, if it did.
    pub error: Option<String>,
}

/// One motion between two static windows.
#[derive(Debug, Clone, Serialize)]
pub struct MotionRow {
    /// Time of the motion's first sample, s.
    pub t_start: f64,
    /// Time of its last sample, s.
    pub t_end: f64,
    /// Angle between the gravity directions of the two windows, degrees (how much the motion
    /// tilted the sensor).
    pub tilt_deg: f64,
    /// Angle error with the uncalibrated gyro, degrees.
    pub error_before_deg: f64,
    /// With the chosen calibration (fitted with this motion), degrees.
    pub error_after_deg: f64,
    /// With the chosen model fitted without this motion, degrees.
    pub held_out_deg: f64,
}

/// The six models: name, what the core fits, whether the bias is fitted (module docs).
const CANDIDATES: [(&str, GyroModel, bool); 6] = [
    ("uncalibrated", GyroModel::BiasOnly, false),
    ("bias", GyroModel::BiasOnly, true),
    ("scale", GyroModel::Scale, false),
    ("scale+bias", GyroModel::Scale, true),
    ("full", GyroModel::Full, false),
    ("full+bias", GyroModel::Full, true),
];
/// The core's free parameters of the model named `name` (none for an unknown name).
pub(super) fn mask_of(name: &str) -> [bool; wiical_core::gyro::NPARAM] {
    CANDIDATES
        .iter()
        .find(|c| c.0 == name)
        .map_or([false; wiical_core::gyro::NPARAM], |c| c.1.mask(c.2))
}

/// Remarks on the choice: a full model that generalises worse than none, or no fitted model
/// at all.
pub(super) fn choice_notes(rows: &[GyroModelRow], name: &str) -> Vec<String> {
    let uncal_cv = rows[0].cv_rms_deg.unwrap_or(f64::NAN);
    let mut notes = Vec::new();
    if let Some(c) = rows
        .iter()
        .find(|r| r.name == "full")
        .and_then(|r| r.cv_rms_deg)
    {
        if c > uncal_cv {
            notes.push(format!(
                "the full 9-parameter fit does worse on held-out motions ({c:.3}°) than the uncalibrated gyro ({uncal_cv:.3}°): these motions do not determine it; {name} was chosen instead"
            ));
        }
    }
    if name == "uncalibrated" {
        notes.push("no fitted model beats the nominal scale on held-out motions: the calibration is the nominal one with the bias from rest".into());
    }
    notes
}

/// Per motion: its times, tilt, angle error before (`angles.0`, the nominal) and after
/// (`angles.1`, the chosen calibration), rad, and held out.
pub(super) fn motion_table(
    seg: &Segmentation,
    col: &Collected,
    motions: &[Motion<'_, f64>],
    held: &[f64],
    angles: (&[f64], &[f64]),
) -> Vec<MotionRow> {
    seg.spans
        .iter()
        .zip(motions)
        .zip(held)
        .zip(angles.0.iter().zip(angles.1))
        .enumerate()
        .map(|(k, (((s, m), h), (before, after)))| {
            let t = |i: u32| col.time(k, i as usize);
            MotionRow {
                t_start: t(s.start),
                t_end: t(s.end.saturating_sub(1)),
                tilt_deg: deg(m.g_start.angle(&m.g_end)),
                error_before_deg: deg(*before),
                error_after_deg: deg(*after),
                held_out_deg: deg(*h),
            }
        })
        .collect()
}

/// The chosen candidate: name, fit, held-out RMS (degrees), held-out angle per motion (rad),
/// in-sample angle per motion (rad).
pub(super) type Best = (
    &'static str,
    gyro_fit::GyroFit<f64>,
    f64,
    Vec<f64>,
    Vec<f64>,
);

/// One candidate's outcome: its fit on every motion, its held-out RMS (rad), its held-out and
/// in-sample angles per motion (rad).
type Outcome = (gyro_fit::GyroFit<f64>, f64, Vec<f64>, Vec<f64>);

/// One candidate: its fit on every motion (from the shared nominal pass: `pass` and the
/// motions it kept, `shared`) and its held-out angle per motion (one Gauss–Newton step from the
/// fit, or exact refits with [`GyroOptions::exact_held_out`]).
fn evaluate_one(
    motions: &[Motion<'_, f64>],
    nominal: &GyroCalibration<f64>,
    dt: f64,
    (pass, shared): (&NominalPass<f64>, &[MotionResidual<f64>]),
    opts: &GyroOptions,
    (model, fit_bias): (GyroModel, bool),
) -> core::result::Result<Outcome, wiical_core::Error> {
    let cfg = GyroFitConfig {
        model,
        fit_bias,
        dt,
        max_iterations: opts.max_iterations,
    };
    let mut kept = shared.to_vec();
    let f = fit_keeping_from_nominal(motions, &cfg, pass, &mut kept)?;
    let mut held = vec![0.0; motions.len()];
    let record = |i: usize, a: f64| held[i] = a;
    let cv = if opts.exact_held_out {
        leave_one_out(motions, nominal, &f.adjustment, &cfg, record)?
    } else {
        leave_one_out_one_step(motions, nominal, &f, &cfg, &kept, record)?
    };
    Ok((f, cv, held, kept.iter().map(|k| k.angle).collect()))
}

/// What one candidate's thread gives: its outcome, or why the core's fit failed on it (a row
/// of the table, not an error of the whole fit).
type CandidateResult = core::result::Result<Outcome, wiical_core::Error>;

/// `work` run for every candidate of [`CANDIDATES`] (its model and whether the bias is fitted),
/// one thread each (the candidates are independent; the machine's cores share them), the
/// results in the candidates' order. Every thread is joined before any result is looked at,
/// so that a panic in one is never left for the scope to re-raise without its message.
///
/// A thread that panicked is a bug, not a model that failed to converge: it is
/// [`GyroError::WorkerPanicked`] for the whole fit (naming the candidate and carrying the
/// panic's message), never a row saying the model did not converge. `work` is a parameter
/// so that a test can make a candidate's thread panic.
fn run_candidates<F>(work: F) -> Result<Vec<CandidateResult>>
where
    F: Fn((GyroModel, bool)) -> CandidateResult + Sync,
{
    let work = &work;
    let joins: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = CANDIDATES
            .iter()
            .map(|&(_, model, fit_bias)| scope.spawn(move || work((model, fit_bias))))
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    CANDIDATES
        .iter()
        .zip(joins)
        .map(|(&(name, ..), joined)| {
            joined.map_err(|panic| GyroError::WorkerPanicked {
                candidate: name,
                message: panic_message(panic.as_ref()),
            })
        })
        .collect()
}

/// The message a panic was raised with: the `&str` or `String` payload `panic!` gives, or a
/// note that it carried none that can be shown (a payload of another type).
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(a panic without a text message)".to_string()
    }
}

pub(super) fn evaluate_candidates(
    motions: &[Motion<'_, f64>],
    nominal: &GyroCalibration<f64>,
    dt: f64,
    opts: &GyroOptions,
) -> Result<(Vec<GyroModelRow>, Best, Vec<f64>)> {
    let mut rows = Vec::new();
    let mut best: Option<Best> = None;
    let mut before = Vec::new();
    // Every candidate starts at the nominal: one pass with all sensitivities serves them all.
    let blank = MotionResidual {
        residual: nalgebra::Vector3::zeros(),
        jacobian: nalgebra::SMatrix::zeros(),
        angle: 0.0,
        rotation: nalgebra::Vector4::zeros(),
    };
    let mut shared = vec![blank; motions.len()];
    let pass = nominal_pass(motions, nominal, dt, &mut shared).map_err(GyroError::GyroFitFailed)?;
    let start = (&pass, shared.as_slice());
    let outcomes =
        run_candidates(|candidate| evaluate_one(motions, nominal, dt, start, opts, candidate))?;
    for ((name, model, fit_bias), outcome) in CANDIDATES.into_iter().zip(outcomes) {
        let parameters = model.mask(fit_bias).iter().filter(|f| **f).count();
        match outcome {
            Ok((f, cv, held, angles)) => {
                rows.push(GyroModelRow {
                    name,
                    parameters,
                    rms_deg: Some(deg(f.rms_after)),
                    cv_rms_deg: Some(deg(cv)),
                    identifiability: Some(f.identifiability),
                    error: None,
                });
                if parameters == 0 {
                    before.clone_from(&angles);
                }
                if best.as_ref().is_none_or(|b| deg(cv) < b.2) {
                    best = Some((name, f, deg(cv), held, angles));
                }
            }
            // The uncalibrated candidate fits nothing: its failure is a data error.
            Err(e) if parameters == 0 => return Err(GyroError::GyroFitFailed(e)),
            Err(e) => rows.push(GyroModelRow {
                name,
                parameters,
                rms_deg: None,
                cv_rms_deg: None,
                identifiability: None,
                error: Some(e.to_string()),
            }),
        }
    }
    let best = best.ok_or(GyroError::GyroFitFailed(wiical_core::Error::NotConverged))?;
    Ok((rows, best, before))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A candidate's thread that panics makes the whole fit an error naming the candidate and
    /// carrying the panic's message. Before, the join's panic became `NotConverged`: the
    /// candidate showed as a model that failed and another was chosen as if nothing happened.
    #[test]
    fn a_panicking_candidate_is_an_error_not_a_failed_model() {
        let err = run_candidates(|(model, fit_bias)| {
            if model == GyroModel::Scale && fit_bias {
                panic!("candidate {} broke", 3);
            }
            Err(wiical_core::Error::NotConverged)
        })
        .expect_err("a panicking candidate must fail the fit");
        match err {
            GyroError::WorkerPanicked { candidate, message } => {
                assert_eq!(candidate, "scale+bias");
                assert_eq!(message, "candidate 3 broke");
            }
            other => panic!("expected WorkerPanicked, got {other:?}"),
        }
    }

    /// The message of a `panic!` with a literal (`&str` payload) is kept too, and a payload
    /// that is not text is still an error (with a note instead of a message).
    #[test]
    fn panic_payloads_give_their_text_or_a_note() {
        let literal = run_candidates(|(model, _)| {
            if model == GyroModel::Full {
                panic!("literal");
            }
            Err(wiical_core::Error::NotConverged)
        });
        assert!(
            matches!(&literal, Err(GyroError::WorkerPanicked { candidate: "full", message }) if message == "literal"),
            "{literal:?}"
        );
        let opaque = run_candidates(|(model, _)| {
            if model == GyroModel::BiasOnly {
                std::panic::panic_any(42_u32);
            }
            Err(wiical_core::Error::NotConverged)
        });
        assert!(
            matches!(&opaque, Err(GyroError::WorkerPanicked { candidate: "uncalibrated", message }) if message.contains("without a text message")),
            "{opaque:?}"
        );
    }

    /// Without a panic every candidate's own result comes back, in the candidates' order (a
    /// failed fit stays a row of the table, not an error of the whole fit).
    #[test]
    fn results_come_back_in_the_candidates_order() {
        let got = run_candidates(|(model, fit_bias)| {
            Err(if fit_bias {
                wiical_core::Error::NotConverged
            } else if model == GyroModel::Full {
                wiical_core::Error::Diverged
            } else {
                wiical_core::Error::NonFinite
            })
        })
        .expect("no candidate panicked");
        let errors: Vec<_> = got.into_iter().map(|r| r.expect_err("all fail")).collect();
        use wiical_core::Error::{Diverged, NonFinite, NotConverged};
        assert_eq!(
            errors,
            [
                NonFinite,
                NotConverged,
                NonFinite,
                NotConverged,
                Diverged,
                NotConverged
            ]
        );
    }
}
