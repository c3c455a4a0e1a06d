//! The calibration file's host-only terms (issue 19): terms the open basis
//! (`search::open_basis::host_terms`) selects that depend on the time since the start of the
//! recording or on the temperature. The core's `Effects` has no field for them and the
//! adapter has no clock origin or thermometer, so they are kept in the file for hosts that
//! have both. Each is one coefficient on one axis about a reference (the mean window time,
//! or the calibration's `temp_ref_c`).

use crate::report::effect_names as names;
use serde::{Deserialize, Serialize};

/// At most this many host terms in a file (6 families × 3 axes, plus the lag and rate
/// families, with room to spare).
pub const MAX_HOST_TERMS: usize = 64;

/// Longest `name` / `unit` string accepted.
const MAX_TEXT: usize = 64;

/// The families a host term may belong to (the open basis's time and temperature names).
pub const HOST_FAMILIES: [&str; 8] = [
    names::SCALE_DRIFT,
    names::SCALE_DRIFT_CURVED,
    names::TEMPERATURE_SQUARED,
    names::TEMPERATURE_CUBED,
    names::TEMPERATURE_SCALE_SQUARED,
    names::TEMPERATURE_SCALE_CUBED,
    names::THERMAL_LAG,
    names::TEMPERATURE_RATE,
];

/// The reference a host term is taken about: seconds since the start of the recording for
/// the time families, °C for the temperature families.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostReference {
    /// Time origin of the term, s since the start of the recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<f64>,
    /// Temperature origin of the term, °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
}

/// One host-only term: `value` (in `unit`) on output `axis` of `family`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostTerm {
    /// The report name, `<family> (<axis>)`.
    pub name: String,
    /// One of [`HOST_FAMILIES`].
    pub family: String,
    /// Output axis, 0–2.
    pub axis: u8,
    /// The coefficient, in `unit`.
    pub value: f64,
    /// Its unit (`1/s`, `raw/°C²`, …).
    pub unit: String,
    /// The time or temperature origin.
    pub reference: HostReference,
    /// The lag's time constant, s (`thermal-lag` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_constant_s: Option<f64>,
}

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
    if !finite(r.time_s) || !finite(r.temperature_c) || !finite(t.time_constant_s) {
        return Err("reference or time_constant_s is not a finite number".into());
    }
    if r.time_s.is_none() && r.temperature_c.is_none() {
        return Err("reference has neither time_s nor temperature_c".into());
    }
    if t.time_constant_s.is_some_and(|tau| tau <= 0.0) {
        return Err("time_constant_s is not positive".into());
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
                temperature_c: None,
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
        bad(|t| t.reference.time_s = None, "neither");
        bad(|t| t.time_constant_s = Some(-1.0), "time_constant_s");
        bad(|t| t.unit = "x".repeat(65), "longer");
        let many = vec![term(); MAX_HOST_TERMS + 1];
        assert!(validate(&many).unwrap_err().contains("more than"));
    }
}
