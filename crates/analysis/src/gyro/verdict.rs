//! The gyro calibration's verdict, by the accelerometer's rules: **good** when the held-out
//! angle error agrees with the noise floor, **unexplained residual** when it is above it
//! (held-out RMS more than [`UNEXPLAINED_CV_FACTOR`] × the floor with χ² p below
//! [`UNEXPLAINED_P`], the same test as `analyze`'s), **not usable** with its reasons when the
//! numbers show the calibration cannot be right.

use super::report::GyroQuality;
use crate::report::verdict::{UNEXPLAINED_CV_FACTOR, UNEXPLAINED_P};
use crate::stats as st;

/// Held-out error this many times the floor is not a residual a missing term explains but a
/// calibration that does not hold: ten times the unexplained-residual factor.
pub const NOT_USABLE_FLOOR_FACTOR: f64 = 30.0;

/// A held-out angle error above this is not usable whatever the floor says, degrees: an
/// uncalibrated MEMS gyro's nominal scale (a few % off) misses a quarter turn by a few degrees,
/// so a calibration that misses by more predicts turns worse than none. (A floor inflated by
/// the very fault that spoils the fit, such as a gyro seconds late, once let 87° be called
/// "usable with that error".)
pub const NOT_USABLE_ANGLE_DEG: f64 = 10.0;

/// A fitted bias this many standard deviations of the rest means away from them is not the
/// gyro's bias (the fit has absorbed something else: lost samples, a wrong rate).
pub const BIAS_SIGMAS: f64 = 5.0;

/// Below this identifiability (smallest eigenvalue of the unit-diagonal normal matrix) the
/// motions do not separate the scale from the bias.
pub const MIN_IDENTIFIABILITY: f64 = 1e-4;

/// Fewer motions than this cannot test a fit: each gives two constraints and the
/// leave-one-out needs spares.
pub const MIN_MOTIONS: usize = 4;

/// What the verdict is judged from.
pub struct Evidence<'a> {
    /// Held-out angle per motion, rad.
    pub held_out: &'a [f64],
    /// Noise floor per motion, rad.
    pub floor: &'a [f64],
    /// Fitted bias minus the rest means' mean, per axis, and the rest means' uncertainty
    /// (their spread over the windows), raw counts; `None` when the bias is not fitted.
    pub bias_offset: Option<([f64; 3], [f64; 3])>,
    /// The chosen model fits the scale and the bias, with this identifiability.
    pub scale_and_bias: Option<f64>,
    /// Why the timestamps cannot be integrated at one rate, if they cannot.
    pub timestamps: Option<String>,
    /// The gyro's clock seconds away from the accelerometer's, if it is (`lag`).
    pub clock: Option<String>,
    /// Counts per °/s of the bias, to say it in °/s (rad/s per count × 180/π).
    pub dps_per_count: [f64; 3],
}

/// The verdict's class, its reasons and its paragraph.
pub fn judge(e: &Evidence<'_>) -> (GyroQuality, Vec<String>, String) {
    let cv = st::rms(e.held_out).to_degrees();
    let floor = st::rms(e.floor).to_degrees();
    let chi2: f64 = e
        .held_out
        .iter()
        .zip(e.floor)
        .map(|(h, f)| 2.0 * (h / f.max(1e-300)).powi(2))
        .sum();
    let dof = 2.0 * e.held_out.len() as f64;
    let p = st::chi2_sf(chi2, dof);
    let reasons = reasons(e, cv, floor);
    let quality = if !reasons.is_empty() {
        GyroQuality::NotUsable
    } else if cv > UNEXPLAINED_CV_FACTOR * floor && p < UNEXPLAINED_P {
        GyroQuality::UnexplainedResidual
    } else {
        GyroQuality::Good
    };
    let text = match quality {
        GyroQuality::Good if p < UNEXPLAINED_P => format!(
            "good: the held-out angle error {cv:.3}° is within {UNEXPLAINED_CV_FACTOR}× the noise floor {floor:.3}° over the motions (some motions are above their own floor: χ² p {})",
            st::fmt_p(p)
        ),
        GyroQuality::Good => format!(
            "good: the held-out angle error {cv:.3}° agrees with the noise floor {floor:.3}° (χ² p {})",
            st::fmt_p(p)
        ),
        GyroQuality::UnexplainedResidual => format!(
            "unexplained residual: the held-out angle error {cv:.3}° is {:.1}× the noise floor {floor:.4}° (χ² p {}): the model lacks something the motions show; usable with that error",
            cv / floor,
            st::fmt_p(p)
        ),
        GyroQuality::NotUsable => format!("not usable: {}", reasons.join("; ")),
    };
    (quality, reasons, text)
}

/// Why the calibration cannot hold (empty: nothing says so), the clock's reason first;
/// `cv` and `floor` are the held-out RMS and the floor's, degrees.
fn reasons(e: &Evidence<'_>, cv: f64, floor: f64) -> Vec<String> {
    let mut reasons = Vec::new();
    if e.held_out.len() < MIN_MOTIONS {
        reasons.push(format!(
            "only {} motions: too few to fit and test a gyro calibration (record at least {MIN_MOTIONS} turns between rests)",
            e.held_out.len()
        ));
    }
    if cv > NOT_USABLE_FLOOR_FACTOR * floor {
        reasons.push(format!(
            "the held-out angle error {cv:.3}° is {:.0}× the noise floor {floor:.4}° (the gyro's noise at rest and the accelerometer's tilt noise allow about 1×)",
            cv / floor
        ));
    }
    if cv > NOT_USABLE_ANGLE_DEG {
        reasons.push(format!(
            "the held-out angle error {cv:.1}° is above {NOT_USABLE_ANGLE_DEG}° (an uncalibrated gyro misses a quarter turn by a few degrees): the calibration predicts turns worse than none"
        ));
    }
    if let Some((d, s)) = e.bias_offset {
        let far: Vec<usize> = (0..3)
            .filter(|&a| d[a].abs() > BIAS_SIGMAS * s[a].max(1e-300))
            .collect();
        if !far.is_empty() {
            let fmt = |v: [f64; 3]| {
                v.iter()
                    .zip(e.dps_per_count)
                    .map(|(x, k)| format!("{:.2}", x * k))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            reasons.push(format!(
                "the fitted bias differs from the gyro's mean at rest by ({}) °/s, more than {BIAS_SIGMAS}× the rest means' spread ({}) °/s on the {} axis: the fit has absorbed something that is not a bias",
                fmt(d),
                fmt(s),
                far.iter().map(|a| ["x", "y", "z"][*a]).collect::<Vec<_>>().join(", ")
            ));
        }
    }
    if let Some(ident) = e.scale_and_bias.filter(|i| *i < MIN_IDENTIFIABILITY) {
        reasons.push(format!(
            "the motions do not separate the scale from the bias (identifiability {ident:.1e}): turn faster and about more axes between the rests"
        ));
    }
    if let Some(t) = &e.timestamps {
        reasons.push(t.clone());
    }
    if let Some(c) = &e.clock {
        reasons.insert(0, c.clone());
    }
    reasons
}

#[cfg(test)]
mod tests {
    use super::*;

    fn evidence<'a>(held: &'a [f64], floor: &'a [f64]) -> Evidence<'a> {
        Evidence {
            held_out: held,
            floor,
            bias_offset: None,
            scale_and_bias: None,
            timestamps: None,
            clock: None,
            dps_per_count: [1.0; 3],
        }
    }

    /// Issue 49's lagging gyro: 87° held out against a floor the lag inflated to 8.7° (10×,
    /// below the 30× of the floor rule) was "usable with that error"; the absolute bound
    /// makes it not usable. 5° against 0.5° (also 10×) stays an unexplained residual.
    #[test]
    fn a_held_out_error_of_tens_of_degrees_is_never_usable() {
        let deg = |d: f64| vec![d.to_radians(); 12];
        let (held, floor) = (deg(87.0), deg(8.7));
        let (q, reasons, text) = judge(&evidence(&held, &floor));
        assert_eq!(q, GyroQuality::NotUsable, "{text}");
        assert!(reasons[0].starts_with("the held-out angle error 87.0° is above 10°"));
        let (held, floor) = (deg(5.0), deg(0.5));
        let (q, _, text) = judge(&evidence(&held, &floor));
        assert_eq!(q, GyroQuality::UnexplainedResidual, "{text}");
        assert!(text.contains("usable with that error"));
    }

    /// A clock reason comes first and makes the verdict not usable.
    #[test]
    fn a_clock_lag_is_the_first_reason() {
        let deg = |d: f64| vec![d.to_radians(); 12];
        let (held, floor) = (deg(0.5), deg(0.5));
        let mut e = evidence(&held, &floor);
        assert_eq!(judge(&e).0, GyroQuality::Good);
        e.clock = Some("the gyro lags the accelerometer by 10.0 s".into());
        let (q, reasons, _) = judge(&e);
        assert_eq!(q, GyroQuality::NotUsable);
        assert_eq!(
            reasons,
            vec!["the gyro lags the accelerometer by 10.0 s".to_string()]
        );
    }
}
