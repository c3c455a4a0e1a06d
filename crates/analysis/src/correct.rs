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
//! ([`regressors`]): the time since the first sample; the temperature; the temperature
//! through the first-order lag of the analysis ([`thermal::lagged`], started at the first
//! sample); and dT/dt, the least-squares slope over ±15 s about the sample
//! ([`thermal::sample_rates`]).
//!
//! **What is refused**, in this order ([`check_units`], [`check_output`],
//! [`check_plausible`]): readings whose linear correction has a median magnitude outside
//! ½–2 g where gravity gives 1 g, which is what a calibration made in other units (counts,
//! mg, m/s²) than the recording does; a corrected value that is not finite; a calibration
//! that fails the acceptance predicate `device put` applies (`Acceptance::check`: usable, `θ₀` plausible,
//! corrected output within ±16 g) with the limits taken from the recording itself — its
//! readings' range as the input box, its duration and temperatures as the conditions — since
//! `correct` serves any accelerometer, not only the Nunchuk whose offset and sensitivity
//! limits the adapter adds; and a corrected value beyond ±16 g at any sample (host terms
//! included, which the predicate does not see).

pub use crate::error::correct::CorrectError;
use crate::input::recording::Recording;
use crate::output::calfile::{adapter_terms, CalibrationFile};
use crate::output::host_term_checks::{HostTerm, Regressor};
use crate::search::thermal;
use std::borrow::Cow;
use wiical_core::acceptance::{Acceptance, ConditionRange};
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

/// The host terms' regressors per sample, one column per term (module docs), from the
/// sample times (s since the first sample) and temperatures.
pub fn regressors<'a>(
    terms: &[HostTerm],
    times: &'a [f64],
    temp: Option<&'a [f64]>,
) -> Result<Vec<Cow<'a, [f64]>>, CorrectError> {
    let mut rates: Option<Vec<Option<f64>>> = None;
    let mut out = Vec::with_capacity(terms.len());
    for t in terms {
        let needs_temp = || CorrectError::NeedsTemperature {
            term: t.name.clone(),
        };
        let Some((regressor, _, _)) = t.shape() else {
            out.push(Cow::Owned(vec![0.0; times.len()]));
            continue;
        };
        out.push(match regressor {
            Regressor::Time => Cow::Borrowed(times),
            Regressor::Temperature => Cow::Borrowed(temp.ok_or_else(needs_temp)?),
            Regressor::LaggedTemperature(tau) => {
                Cow::Owned(thermal::lagged(times, temp.ok_or_else(needs_temp)?, tau))
            }
            Regressor::TemperatureRate => {
                let temp = temp.ok_or_else(needs_temp)?;
                let r = rates.get_or_insert_with(|| thermal::sample_rates(times, temp));
                let col: Option<Vec<f64>> = r.iter().copied().collect();
                Cow::Owned(col.ok_or_else(|| CorrectError::RateUndefined {
                    term: t.name.clone(),
                    sample: r.iter().position(Option::is_none).unwrap_or(0),
                })?)
            }
        });
    }
    Ok(out)
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
/// included, is refused, naming the term (the core would silently skip it).
pub fn correct_recording(
    file: &CalibrationFile,
    rec: &Recording,
    default_rate_hz: f64,
) -> Result<Corrected, CorrectError> {
    let times = rec.times(default_rate_hz);
    let t0 = *times.first().ok_or(CorrectError::Empty)?;
    let since: Vec<f64> = times.iter().map(|t| t - t0).collect();
    let temp = rec.temp.as_deref();
    let e = &file.calibration.effects;
    for (name, c) in [
        ("bias_temp (temperature)", e.bias_temp),
        ("scale_temp (temperature)", e.scale_temp),
    ] {
        if temp.is_none() && c.iter().any(|x| *x != 0.0) {
            return Err(CorrectError::NeedsTemperature { term: name.into() });
        }
    }
    let core = adapter_terms(&file.calibration);
    let mut applied: Vec<String> = core.applied.iter().map(|s| s.to_string()).collect();
    applied.extend(core.host_only);
    let cols = regressors(&file.host_terms, &since, temp)?;
    check_units(&file.calibration, rec)?;
    applied.extend(file.host_terms.iter().map(|t| {
        let what = t.shape().map_or("nothing", |s| needs(s.0));
        format!("{} [{what}]", t.name)
    }));
    let mut xs = vec![0.0; cols.len()];
    let accel: Vec<[f32; 3]> = rec
        .xyz
        .iter()
        .enumerate()
        .map(|(i, m)| {
            for (x, c) in xs.iter_mut().zip(&cols) {
                *x = c[i];
            }
            let theta = temp.map(|t| t[i]);
            correct_at(file, m.map(|v| v as f32), since[i], theta, &xs)
        })
        .collect();
    // Units first (they explain everything else), then what no calibration may give.
    check_output(&times, &accel, false)?;
    check_plausible(&file.calibration, rec, &since)?;
    check_output(&times, &accel, true)?;
    Ok(Corrected {
        times,
        accel,
        applied,
    })
}

/// The acceptance limits `device put` uses ([`Acceptance::nunchuk`]: the ±16 g output bound
/// and the `θ₀` range) with the sensor-specific ones (offset from 512 counts, sensitivity near
/// 200 counts/g, cross-axis share) opened up and the input box and conditions taken from the
/// recording: its readings' smallest and largest value, its duration (s since the first
/// sample) and its temperature range, if it has one. `None` for a recording without a finite
/// reading (refused by the loader before this).
pub fn limits_for(rec: &Recording, since: &[f64]) -> Option<Acceptance> {
    let finite = rec.xyz.iter().flatten().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if lo > hi {
        return None;
    }
    let span = |v: &[f64]| {
        let f = v.iter().copied().filter(|x| x.is_finite());
        f.fold(None, |acc: Option<(f64, f64)>, x| {
            Some(acc.map_or((x, x), |(a, b)| (a.min(x), b.max(x))))
        })
    };
    let max_time_s = since.last().copied().filter(|t| t.is_finite() && *t >= 0.0);
    let nunchuk = Acceptance::nunchuk();
    Some(Acceptance {
        input_range: (lo as f32, hi as f32),
        conditions: ConditionRange {
            max_time_s: max_time_s.unwrap_or(0.0) as f32,
            temperature_c: rec
                .temp
                .as_deref()
                .and_then(span)
                .map(|(a, b)| (a as f32, b as f32)),
        },
        nominal_zero: 0.0,
        max_offset: f32::MAX,
        nominal_sensitivity: 1.0,
        sensitivity_ratio: (f32::MIN, f32::MAX),
        max_cross_axis: f32::MAX,
        ..nunchuk
    })
}

/// Refuses a calibration that fails the acceptance predicate over the recording
/// ([`limits_for`]): corrected output beyond ±16 g somewhere in the recording's input
/// range and conditions, or an implausible `θ₀`.
pub fn check_plausible(
    cal: &Calibration,
    rec: &Recording,
    since: &[f64],
) -> Result<(), CorrectError> {
    let Some(limits) = limits_for(rec, since) else {
        return Ok(());
    };
    limits
        .check(cal, None)
        .map_err(|why| CorrectError::Implausible {
            why,
            lo: limits.input_range.0,
            hi: limits.input_range.1,
        })
}

/// Refuses a recording whose readings, corrected by the calibration's linear part alone
/// (`K·(m − b)`: units are a linear matter, whatever the effect terms), have a median `‖a‖`
/// outside [`PLAUSIBLE_MEDIAN_G`]: the calibration was made from readings in other units
/// (described from its zero point and sensitivity and the raw readings' median magnitude).
pub fn check_units(cal: &Calibration, rec: &Recording) -> Result<(), CorrectError> {
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let linear = |m: &[f64; 3]| {
        let u = cal.correct_linear(m.map(|v| v as f32));
        norm(u.map(f64::from))
    };
    let Some(median_g) = median(rec.xyz.iter().map(linear).collect()) else {
        return Ok(());
    };
    let (lo, hi) = PLAUSIBLE_MEDIAN_G;
    if (lo..=hi).contains(&median_g) {
        return Ok(());
    }
    let per_g = wiical_core::model::invert3(&cal.k()).map_or(f64::NAN, |d| {
        (0..3).map(|i| f64::from(d[(i, i)])).sum::<f64>() / 3.0
    });
    let raw = median(rec.xyz.iter().map(|m| norm(*m)).collect());
    Err(CorrectError::UnitsMismatch {
        median_g: round3(median_g),
        zero: round3(cal.bias.iter().map(|b| f64::from(*b)).sum::<f64>() / 3.0),
        per_g: round3(per_g),
        median_raw: round3(raw.unwrap_or(f64::NAN)),
    })
}

/// Refuses the first corrected value (1-based sample, its time) that is not finite, or,
/// with `bounded`, beyond the ±16 g output bound of the acceptance limits (host terms can
/// push a sample there, which the acceptance predicate does not see).
pub fn check_output(times: &[f64], accel: &[[f32; 3]], bounded: bool) -> Result<(), CorrectError> {
    let bound = Acceptance::nunchuk().output_bound;
    for (i, a) in accel.iter().enumerate() {
        for (j, v) in a.iter().enumerate() {
            let why = if !v.is_finite() {
                "not a finite number".to_string()
            } else if bounded && v.abs() > bound {
                format!("beyond ±{bound} g")
            } else {
                continue;
            };
            return Err(CorrectError::BadOutput {
                sample: i + 1,
                time_s: times.get(i).copied().unwrap_or(f64::NAN),
                axis: ["x", "y", "z"][j],
                value: *v,
                why,
            });
        }
    }
    Ok(())
}

/// The median of `v` (the mean of the middle two for an even count); `None` when empty.
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    let n = v.len();
    (n > 0).then(|| (v[(n - 1) / 2] + v[n / 2]) / 2.0)
}

/// Three significant figures, for a sentence.
fn round3(x: f64) -> f64 {
    format!("{x:.2e}").parse().unwrap_or(x)
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
        let e = regressors(&file.host_terms, &[0.0, 1.0], None).unwrap_err();
        assert!(e.to_string().contains("temperature-squared (1)"), "{e}");
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
        // Samples 0 and 1 are 1 s apart (a slope), sample 2 is alone 100 s later.
        let (times, temp) = ([0.0, 1.0, 101.0], [20.0, 20.5, 21.0]);
        let e = regressors(std::slice::from_ref(&rate), &times, Some(&temp)).unwrap_err();
        assert!(
            matches!(&e, CorrectError::RateUndefined { sample: 2, term } if term == &rate.name),
            "{e:?}"
        );
        assert!(e.to_string().contains("sample 2"), "{e}");
        let ok = regressors(std::slice::from_ref(&rate), &times[..2], Some(&temp[..2])).unwrap();
        assert!((ok[0][0] - 0.5).abs() < 1e-12, "{:?}", ok[0]);
        let file = CalibrationFile {
            calibration: Calibration::default(),
            quality: None,
            host_terms: vec![rate],
        };
        let e = correct_recording(&file, &Recording::default(), 100.0).unwrap_err();
        assert!(matches!(e, CorrectError::Empty), "{e:?}");
    }
}
