//! Checks of the calibration file's host-only terms when a file is read or
//! written: the types and their formulas are the report's (`crate::report::host_term`),
//! re-exported here.

use crate::report::effect_names as names;
pub use crate::report::host_term::{HostReference, HostTerm, Regressor, HOST_FAMILIES};

/// At most this many host terms in a file (6 families × 3 axes, plus the lag and rate
/// families, with room to spare).
pub const MAX_HOST_TERMS: usize = 64;

/// Longest `name` / `unit` string accepted.
const MAX_TEXT: usize = 64;

/// Why a host-term list is refused: one sentence naming the field.
pub fn validate(terms: &[HostTerm]) -> Result<(), String> {
    if terms.len() > MAX_HOST_TERMS {
        return Err(format!(
            "host_terms has {} entries, more than the {MAX_HOST_TERMS} accepted",
            terms.len()
        ));
    }
    for (i, t) in terms.iter().enumerate() {
        validate_one(t).map_err(|e| format!("host_terms[{i}]: {e}"))?;
    }
    Ok(())
}

/// Checks one term (see [`validate`]).
fn validate_one(t: &HostTerm) -> Result<(), String> {
    if !HOST_FAMILIES.contains(&t.family.as_str()) {
        return Err(format!(
            "family '{}' is not one of {}",
            crate::input::bounded::quote(&t.family),
            HOST_FAMILIES.join(", ")
        ));
    }
    if t.axis > 2 {
        return Err(format!("axis is {}, not 0, 1 or 2", t.axis));
    }
    if t.name.len() > MAX_TEXT || t.unit.len() > MAX_TEXT {
        return Err(format!("name or unit is longer than {MAX_TEXT} bytes"));
    }
    if !t.value.is_finite() {
        return Err("value is not a finite number".into());
    }
    let r = t.reference;
    let finite = |x: Option<f64>| x.is_none_or(f64::is_finite);
    if !finite(r.time_s)
        || !finite(r.temperature_c)
        || !finite(r.rate_c_per_s)
        || !finite(t.time_constant_s)
    {
        return Err("reference or time_constant_s is not a finite number".into());
    }
    let Some((regressor, _, _)) = t.shape() else {
        return Err("family has no regressor".into());
    };
    let (want, fields) = match regressor {
        Regressor::Time => ("time_s", [true, false, false]),
        Regressor::Temperature | Regressor::LaggedTemperature(_) => {
            ("temperature_c", [false, true, false])
        }
        Regressor::TemperatureRate => ("rate_c_per_s", [false, false, true]),
    };
    if [r.time_s, r.temperature_c, r.rate_c_per_s].map(|x| x.is_some()) != fields {
        return Err(format!(
            "reference of a {} term must have {want} and nothing else",
            t.family
        ));
    }
    let is_lag = t.family == names::THERMAL_LAG;
    if is_lag != t.time_constant_s.is_some() || t.time_constant_s.is_some_and(|tau| tau <= 0.0) {
        return Err(format!(
            "time_constant_s must be a positive number for thermal-lag and absent otherwise \
             ({} term)",
            t.family
        ));
    }
    Ok(())
}

/// The names of the terms, `<name> (host)`, for `device put`'s "stays in the file" list.
pub fn labels(terms: &[HostTerm]) -> Vec<String> {
    terms.iter().map(|t| t.name.clone()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term() -> HostTerm {
        HostTerm {
            name: "scale-drift (x)".into(),
            family: names::SCALE_DRIFT.into(),
            axis: 0,
            value: 1e-6,
            unit: "1/s".into(),
            reference: HostReference {
                time_s: Some(120.0),
                ..Default::default()
            },
            time_constant_s: None,
        }
    }

    #[test]
    fn bad_terms_are_refused_naming_the_field() {
        assert!(validate(&[term()]).is_ok());
        let bad = |f: fn(&mut HostTerm), want: &str| {
            let mut t = term();
            f(&mut t);
            let e = validate(&[term(), t]).unwrap_err();
            assert!(e.starts_with("host_terms[1]: ") && e.contains(want), "{e}");
        };
        bad(|t| t.family = "warp".into(), "family 'warp'");
        bad(|t| t.axis = 3, "axis is 3");
        bad(|t| t.value = f64::NAN, "value");
        bad(
            |t| t.reference.time_s = None,
            "must have time_s and nothing else",
        );
        bad(|t| t.reference.temperature_c = Some(20.0), "nothing else");
        bad(|t| t.reference.rate_c_per_s = Some(f64::INFINITY), "finite");
        bad(|t| t.time_constant_s = Some(10.0), "absent otherwise");
        // A thermal-lag term needs its temperature origin and a positive time constant; a
        // rate term its rate origin.
        fn lag(t: &mut HostTerm) {
            t.family = names::THERMAL_LAG.into();
            t.reference = HostReference {
                temperature_c: Some(25.0),
                ..Default::default()
            };
            t.time_constant_s = Some(120.0);
        }
        let mut ok = term();
        lag(&mut ok);
        assert!(validate(&[ok]).is_ok());
        bad(
            |t| {
                lag(t);
                t.time_constant_s = Some(-1.0);
            },
            "time_constant_s must be a positive",
        );
        bad(
            |t| {
                lag(t);
                t.time_constant_s = None;
            },
            "time_constant_s",
        );
        bad(
            |t| t.family = names::TEMPERATURE_RATE.into(),
            "must have rate_c_per_s",
        );
        bad(|t| t.unit = "x".repeat(65), "longer");
        let mut rate = term();
        rate.family = names::TEMPERATURE_RATE.into();
        rate.reference = HostReference {
            rate_c_per_s: Some(0.01),
            ..Default::default()
        };
        assert!(validate(&[rate]).is_ok());
        let many = vec![term(); MAX_HOST_TERMS + 1];
        assert!(validate(&many).unwrap_err().contains("more than"));
    }

    /// The formulas of the module docs: `value·(x − x₀)^n` with the family's power, the
    /// family's origin field, and the kind.
    #[test]
    fn contributions_follow_the_family() {
        let mut t = term();
        assert_eq!(t.contribution(130.0), Some(1e-6 * 10.0));
        assert!(t.is_scale());
        t.family = names::SCALE_DRIFT_CURVED.into();
        assert_eq!(t.contribution(110.0), Some(1e-6 * 100.0));
        t.family = names::TEMPERATURE_CUBED.into();
        t.reference = HostReference {
            temperature_c: Some(25.0),
            ..Default::default()
        };
        assert_eq!(t.contribution(23.0), Some(1e-6 * -8.0));
        assert!(!t.is_scale());
        t.family = names::TEMPERATURE_RATE.into();
        assert_eq!(t.origin(), None, "a rate term's origin is rate_c_per_s");
        t.family = "warp".into();
        assert_eq!(t.contribution(1.0), None);
    }
}
