//! Host-side correction (`wiical correct`): a calibration file's core calibration
//! and its host-only time and temperature terms ([`crate::output::host_term_checks`]) applied to
//! readings, for a host that has a clock and a thermometer.
//!
//! There is no second copy of the model: per sample, the host terms are folded into a copy
//! of the core [`Calibration`] ([`adjusted`]) and the core's own `Calibration::correct`
//! does the rest. A bias term's `value·X` (raw units) is added to `bias` on its axis; a scale
//! term's factor `1 + Σ value·X` multiplies row `j` of `matrix`, which scales
//! `u_j = (K·(m − b))_j` before the temperature scale and the nonlinearities, exactly as the
//! analysis model's scale slots scale `v_j` (`fit::model`). The regressors per sample
//! (`regress`): the time since the first sample; the temperature; the temperature
//! through the first-order lag of the analysis ([`crate::search::thermal::lagged`], started at the first
//! sample); and dT/dt, the least-squares slope over ±15 s about the sample
//! ([`crate::search::thermal::sample_rates`]).
//!
//! **What is refused**, in this order (`checks`: the units, `checks::bad_output`,
//! `checks::check_plausible_within`): readings whose linear correction has a median magnitude outside
//! ½–2 g where gravity gives 1 g, which is what a calibration made in other units (counts,
//! mg, m/s²) than the recording does; a corrected value that is not finite; a calibration
//! that fails the acceptance predicate `device put` applies (`Acceptance::check`: usable, `θ₀` plausible,
//! corrected output within ±16 g) with the limits taken from the recording itself — its
//! readings' range as the input box, its duration and temperatures as the conditions — since
//! `correct` serves any accelerometer, not only the Nunchuk whose offset and sensitivity
//! limits the adapter adds; and a corrected value beyond ±16 g at any sample (host terms
//! included, which the predicate does not see).
//!
//! **One path.** Every sample is corrected by one pass in order (`pass::correct_pass`):
//! a large plain text file (streamed by [`crate::input::front_door::load_samples`]) as it is read
//! ([`pass::correct_streamed`]), in memory bounded by a piece of the file and ±15 s of
//! samples, written straight to a temporary file beside the output that replaces it only when
//! every check passed; a recording held in memory ([`correct_recording`]) as the one-chunk
//! case of the same pass, its corrected samples kept. Both give the same file byte for byte
//! ([`csv`]) and refuse the same recordings with the same sentence.

pub(crate) mod checks;
pub mod csv;
pub mod pass;
pub(crate) mod regress;

pub use crate::error::correct::CorrectError;
use crate::input::recording::Recording;
use crate::output::calfile::{adapter_terms, CalibrationFile};
use crate::output::host_term_checks::{HostTerm, Regressor};
pub use checks::check_units;
use wiical_core::{Calibration, Conditions};

/// Corrected readings whose median magnitude lies outside this range (g) are taken for a
/// units mismatch: gravity alone gives 1 g, a hand-held or worn recording stays near it,
/// while counts read as g or g read as counts are off by a factor of 100 or more.
pub const PLAUSIBLE_MEDIAN_G: (f64, f64) = (0.5, 2.0);

/// The core calibration with the host terms folded in for one sample whose regressor values
/// (raw: s, °C, °C/s; one per term, in order) are `xs` (module docs). Terms of an unknown
/// family (refused when a file is read) change nothing.
pub fn adjusted(cal: &Calibration, terms: &[HostTerm], xs: &[f64]) -> Calibration {
    let mut bias = cal.bias.map(f64::from);
    let mut scale = [1.0f64; 3];
    for (t, &x) in terms.iter().zip(xs) {
        let (Some(c), Some(j)) = (t.contribution(x), Some(t.axis as usize).filter(|j| *j < 3))
        else {
            continue;
        };
        if t.is_scale() {
            scale[j] += c;
        } else {
            bias[j] += c;
        }
    }
    let mut out = *cal;
    for j in 0..3 {
        out.bias[j] = bias[j] as f32;
        for k in out.matrix[j].iter_mut() {
            *k = (f64::from(*k) * scale[j]) as f32;
        }
    }
    out
}

/// One reading `m` (raw) corrected to g at `time_s` (s since the first sample) and
/// `temperature_c`, the host terms' regressors being `xs` ([`adjusted`]).
pub fn correct_at(
    file: &CalibrationFile,
    m: [f32; 3],
    time_s: f64,
    temperature_c: Option<f64>,
    xs: &[f64],
) -> [f32; 3] {
    let cond = Conditions {
        time_s: time_s as f32,
        temperature_c: temperature_c.map(|t| t as f32),
    };
    adjusted(&file.calibration, &file.host_terms, xs).correct(m, &cond)
}

/// What a term's regressor is, as text (`wiical correct`'s summary).
pub fn needs(r: Regressor) -> &'static str {
    match r {
        Regressor::Time => "time",
        Regressor::Temperature => "temperature",
        Regressor::LaggedTemperature(_) => "lagged temperature",
        Regressor::TemperatureRate => "temperature rate",
    }
}

/// A recording corrected by [`correct_recording`].
#[derive(Debug, Clone, PartialEq)]
pub struct Corrected {
    /// Sample times as the recording gives them, s.
    pub times: Vec<f64>,
    /// Corrected acceleration per sample, g.
    pub accel: Vec<[f32; 3]>,
    /// The terms applied: the core's (`bias and K`, `cubic`, `bias_drift (time)`, …), then
    /// each host term as `<name> [<regressor>]`.
    pub applied: Vec<String>,
}

/// Corrects every sample of `rec` with the file's core calibration and host terms. Sample
/// times are the time column, else `i / rate` (the file's rate, else `default_rate_hz`,
/// as the analysis takes them); `Conditions::time_s` counts from the first sample. A term
/// that needs a temperature the recording lacks, the core's `bias_temp` / `scale_temp`
/// included, is refused, naming the term (the core would silently skip it). The one-chunk
/// case of the pass a large file is corrected by (`pass::correct_pass`): the same code,
/// the corrected samples kept instead of written. Errors are [`CorrectError`]s.
pub fn correct_recording(
    file: &CalibrationFile,
    rec: &Recording,
    default_rate_hz: f64,
) -> crate::Result<Corrected> {
    let (mut times, mut accel) = (Vec::with_capacity(rec.len()), Vec::with_capacity(rec.len()));
    let mut keep = |t: f64, a: &[f32; 3]| -> crate::Result<()> {
        times.push(t);
        accel.push(*a);
        Ok(())
    };
    pass::correct_pass(file, rec, default_rate_hz, &mut keep)?;
    Ok(Corrected {
        times,
        accel,
        applied: applied(file),
    })
}

/// Refuses the core's temperature terms (`bias_temp`, `scale_temp`) for a recording without
/// a temperature (`has_temp` false), naming the term: the core would silently skip them.
pub fn check_core_temperature(file: &CalibrationFile, has_temp: bool) -> Result<(), CorrectError> {
    let e = &file.calibration.effects;
    for (name, c) in [
        ("bias_temp (temperature)", e.bias_temp),
        ("scale_temp (temperature)", e.scale_temp),
    ] {
        if !has_temp && c.iter().any(|x| *x != 0.0) {
            return Err(CorrectError::NeedsTemperature { term: name.into() });
        }
    }
    Ok(())
}

/// The terms a correction with `file` applies, as [`Corrected::applied`] lists them: the
/// core's, then each host term as `<name> [<regressor>]`.
pub fn applied(file: &CalibrationFile) -> Vec<String> {
    let core = adapter_terms(&file.calibration);
    let mut applied: Vec<String> = core.applied.iter().map(|s| s.to_string()).collect();
    applied.extend(core.host_only);
    applied.extend(file.host_terms.iter().map(|t| {
        let what = t.shape().map_or("nothing", |s| needs(s.0));
        format!("{} [{what}]", t.name)
    }));
    applied
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::host_term_checks::HostReference;
    use crate::report::effect_names as names;

    fn term(family: &str, axis: u8, value: f64, reference: HostReference) -> HostTerm {
        HostTerm {
            name: format!("{family} ({axis})"),
            family: family.into(),
            axis,
            value,
            unit: String::new(),
            reference,
            time_constant_s: None,
        }
    }

    /// A bias term moves the bias by `value·X` and a scale term multiplies its axis's
    /// reading by `1 + value·X`, checked against the linear model by hand.
    #[test]
    fn bias_and_scale_terms_act_where_the_model_puts_them() {
        let cal = Calibration {
            bias: [100.0, 200.0, 300.0],
            matrix: [[0.01, 0.001, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.005]],
            ..Default::default()
        };
        let at_t = HostReference {
            time_s: Some(10.0),
            ..Default::default()
        };
        let at_c = HostReference {
            temperature_c: Some(20.0),
            ..Default::default()
        };
        let file = CalibrationFile {
            calibration: cal,
            quality: None,
            host_terms: vec![
                term(names::SCALE_DRIFT, 0, 1e-3, at_t),
                term(names::TEMPERATURE_SQUARED, 1, 0.5, at_c),
            ],
        };
        // t = 110 s: scale x by 1 + 1e-3·100 = 1.1; θ = 22 °C: bias y += 0.5·4 = 2.
        let m = [150.0, 260.0, 500.0];
        let a = correct_at(&file, m, 110.0, Some(22.0), &[110.0, 22.0]);
        let want = [
            1.1 * (0.01 * 50.0 + 0.001 * 58.0),
            0.02 * 58.0,
            0.005 * 200.0,
        ];
        for j in 0..3 {
            assert!(
                (f64::from(a[j]) - want[j]).abs() < 1e-6,
                "{a:?} vs {want:?}"
            );
        }
        // At the origins the terms vanish: the core calibration alone.
        let a0 = correct_at(&file, m, 10.0, Some(20.0), &[10.0, 20.0]);
        assert_eq!(
            a0,
            cal.correct(
                m,
                &Conditions {
                    time_s: 10.0,
                    temperature_c: Some(20.0)
                }
            )
        );
        // Without a temperature a temperature term is refused, naming it.
        let e = correct_recording(&file, &still(&[0.0, 1.0], None), 100.0).unwrap_err();
        assert!(e.to_string().contains("temperature-squared (1)"), "{e}");
    }

    /// A recording lying still at 1 g on z (raw counts of the default calibration) at the
    /// times `t` (s), with the temperatures `temp` (°C).
    fn still(t: &[f64], temp: Option<&[f64]>) -> Recording {
        Recording {
            xyz: vec![[0.0, 0.0, 1.0]; t.len()],
            t: Some(t.to_vec()),
            temp: temp.map(<[f64]>::to_vec),
            ..Default::default()
        }
    }

    /// A temperature-rate term at a sample with no neighbour within ±15 s is refused naming
    /// the term and the sample (the slope is undefined there), and an empty recording is
    /// refused rather than corrected to nothing.
    #[test]
    fn an_undefined_rate_and_an_empty_recording_are_refused() {
        let rate = term(
            names::TEMPERATURE_RATE,
            2,
            0.1,
            HostReference {
                rate_c_per_s: Some(0.0),
                ..Default::default()
            },
        );
        let file = CalibrationFile {
            calibration: Calibration::default(),
            quality: None,
            host_terms: vec![rate.clone()],
        };
        // Samples 0 and 1 are 1 s apart (a slope), sample 2 is alone 100 s later.
        let (times, temp) = ([0.0, 1.0, 101.0], [20.0, 20.5, 21.0]);
        let e = correct_recording(&file, &still(&times, Some(&temp)), 100.0).unwrap_err();
        assert!(
            matches!(&e, crate::Error::Correct(CorrectError::RateUndefined { sample: 2, term }) if term == &rate.name),
            "{e:?}"
        );
        assert!(e.to_string().contains("sample 2"), "{e}");
        // Two samples: the rate is 0.5 °C/s at both (the slope through them).
        let ok = correct_recording(&file, &still(&times[..2], Some(&temp[..2])), 100.0).unwrap();
        for (i, a) in ok.accel.iter().enumerate() {
            let want = correct_at(&file, [0.0, 0.0, 1.0], times[i], Some(temp[i]), &[0.5]);
            assert_eq!(a, &want, "sample {i}");
        }
        let e = correct_recording(&file, &Recording::default(), 100.0).unwrap_err();
        assert!(
            matches!(e, crate::Error::Correct(CorrectError::Empty)),
            "{e:?}"
        );
    }
}
