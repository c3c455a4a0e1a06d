//! Magnetometers: the hard/soft-iron fit of `wiical magfit` ([`fit`], on the core's streaming
//! `f32` fits) and the residual loop around it, as `analyze` has for the accelerometer: a
//! noise floor measured from the data ([`floor`]), the fit's residual linearised with every
//! candidate's columns ([`design`], [`candidates`]), candidates accepted by F and held-out
//! error ([`search`]) with a detection limit for each one not accepted, and a verdict
//! ([`verdict`]) in `analyze`'s contract shape ([`contract`]).
//!
//! **Detection limits.** For a candidate not accepted at the last step, the magnitude it
//! would need to pass both rules there: the extra residual sum of squares it must explain is
//! the larger of `q·F_crit·s²` (its F-test at the step's level, `s²` the reference variance)
//! and `(CV_FACTOR² − 1)·cv²·n` (the held-out RMS divided by the factor); a centre effect `k`
//! explains `kᵀ·S·k` (`S` the Schur complement of its columns against the model), so the
//! limit is `√(need/λ_min(S))`, the worst direction; for a scanned step the worst position.
//! Shape is measured as the RMS it adds, `√(need/n)`.

pub mod candidates;
pub mod contract;
pub mod design;
pub mod fit;
pub mod floor;
pub mod model;
pub mod search;
pub mod verdict;

pub use crate::error::magnetometer::MagnetometerError;
pub use candidates::MagInput;
pub use contract::MagAnalysis;
pub use fit::{fit_points, MagFitReport};
pub use model::MagModel;

use contract::MagModelSummary;
use design::{Fit, Shape};

/// The residual loop on `inp` around the fit `rep` (made with `model`) at family level
/// `alpha` (the accelerometer's [`crate::search::select::ALPHA`] by default). Refused when
/// the points are a still blob ([`floor::still_blob`]) or fewer than twice the columns.
pub fn analyze(
    inp: &MagInput,
    rep: &MagFitReport,
    model: MagModel,
    alpha: f64,
) -> Result<MagAnalysis, MagnetometerError> {
    check_spans(inp.xyz)?;
    let geos: Vec<design::Geo> = inp
        .xyz
        .iter()
        .map(|m| design::geo(m, &rep.center, &rep.matrix, rep.radius))
        .collect();
    let sigma = floor::axis_noise(inp.xyz);
    let noise = floor::residual_floor(&geos, &sigma);
    let coverage = floor::coverage(&geos);
    let shape = match model {
        MagModel::Sphere => Shape::Sphere,
        MagModel::Axis => Shape::Axis,
        MagModel::Ellipsoid => Shape::Ellipsoid,
    };
    let lay = candidates::layout(inp, &geos, shape);
    let found = search::search(&lay, noise, alpha);
    let n = geos.len();
    let base = summary(&found.base, n, noise);
    let final_model = summary(&found.last, n, noise);
    let (verdict, reasons) = verdict::verdict(&final_model, noise, coverage, inp.unit);
    let mut diagnostics = Vec::new();
    if inp.temp.is_none() {
        diagnostics.push(
            "temperature not tested: the file has no temperature column (log one beside the field)"
                .into(),
        );
    }
    if inp.follow.is_empty() {
        diagnostics.push(
            "interference not tested: no column named for it (give --follow current, throttle or \
             pwm when the file logs one)"
                .into(),
        );
    }
    Ok(MagAnalysis {
        noise_floor: noise,
        noise_floor_axes: sigma,
        coverage,
        base,
        effects: found.effects,
        final_model,
        steps: found.steps,
        verdict,
        reasons,
        diagnostics,
    })
}

/// Refuses points that never leave a blob of their own noise: an ellipsoid fitted to them
/// is a shape of the noise, not of the field.
pub fn check_spans(points: &[[f64; 3]]) -> Result<(), MagnetometerError> {
    match floor::still_blob(points) {
        Some((spread, noise)) => Err(MagnetometerError::NotRotated { spread, noise }),
        None => Ok(()),
    }
}

fn summary(f: &Fit, n: usize, floor: f64) -> MagModelSummary {
    let dof = n.saturating_sub(f.rank);
    let chi2 = if floor > 0.0 {
        f.rss / (floor * floor)
    } else {
        f64::INFINITY
    };
    MagModelSummary {
        params: f.rank,
        rms: (f.rss / n.max(1) as f64).sqrt(),
        cv_rms: f.cv,
        chi2,
        chi2_dof: dof,
        chi2_p: if dof > 0 {
            crate::stats::chi2_sf(chi2, dof as f64)
        } else {
            f64::NAN
        },
    }
}
