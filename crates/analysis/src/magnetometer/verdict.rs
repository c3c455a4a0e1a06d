//! The magnetometer loop's verdict, by the accelerometer's rules
//! ([`crate::report::verdict::residual_unexplained`]): `good` when the final model's held-out
//! RMS is within [`UNEXPLAINED_CV_FACTOR`] × the noise floor measured from the data,
//! `unexplained-residual` when it is above it with the χ² p-value below [`UNEXPLAINED_P`],
//! and `not-usable` when the points cannot carry a fit (a band or cap of the sphere).

use super::contract::MagModelSummary;
use crate::report::verdict::{residual_unexplained, UNEXPLAINED_CV_FACTOR, UNEXPLAINED_P};

/// Smallest coverage (smallest eigenvalue of the mean `n̂n̂ᵀ`; a full sphere gives 1/3) for
/// which the soft iron is determined in every direction: below it the points are a band or
/// a cap (a sensor turned about one axis only), and the fit's shape along the missing
/// direction is a guess.
pub const MIN_COVERAGE: f64 = 0.05;

/// `(verdict, reasons)`.
pub fn verdict(
    fin: &MagModelSummary,
    floor: f64,
    coverage: f64,
    unit: &str,
) -> (String, Vec<String>) {
    // Below the minimum, or NaN.
    if coverage
        .partial_cmp(&MIN_COVERAGE)
        .is_none_or(|o| o.is_lt())
    {
        return (
            "not-usable".into(),
            vec![format!(
                "the points cover a band or cap of the sphere only (direction spread {coverage:.3}, \
                 a full sphere gives 0.333, at least {MIN_COVERAGE} is needed): rotate the sensor \
                 through all orientations"
            )],
        );
    }
    let cv = fin.cv_rms.unwrap_or(f64::NAN);
    if residual_unexplained(cv, floor, fin.chi2_p) {
        return (
            "unexplained-residual".into(),
            vec![format!(
                "the held-out RMS {cv:.4e} {unit} is {:.1}× the noise floor {floor:.4e} {unit} \
                 (χ² p = {}): something none of the candidates describes remains (a field that \
                 changes while the sensor turns, an interference without its column, motion \
                 faster than the sample rate); give the column it follows, or record again \
                 away from iron and currents",
                cv / floor,
                crate::stats::fmt_p(fin.chi2_p)
            )],
        );
    }
    if !cv.is_finite() {
        return (
            "not-usable".into(),
            vec!["the held-out error could not be computed (a time block without samples)".into()],
        );
    }
    let mut reasons = vec![format!(
        "the held-out RMS {cv:.4e} {unit} is within {UNEXPLAINED_CV_FACTOR}× the noise floor \
         {floor:.4e} {unit} (or χ² p ≥ {UNEXPLAINED_P})"
    )];
    if fin.rms < 0.5 * floor {
        reasons.push(format!(
            "the residual ({:.4e} {unit}) is below half the floor: the samples are too far apart \
             for a smooth track, so the floor is an upper bound and a smaller effect could hide \
             under it; record faster for a sharper test",
            fin.rms
        ));
    }
    ("good".into(), reasons)
}
