//! The calibration file's host-only terms (issue 19): terms the open basis
//! (`search::open_basis::host_terms`) selects that depend on the time since the start of the
//! recording or on the temperature. The core's `Effects` has no field for them and the
//! adapter has no clock origin or thermometer, so they are kept in the file for hosts that
//! have both (`crate::correct` applies them).
//!
//! Each term is one coefficient `value` on output axis `j` times a power of one raw
//! regressor `x` taken about its origin `x₀` (the term's `reference`):
//! `X = (x − x₀)^n`. The power and the regressor are implied by the family:
//!
//! | family | x | x₀ (`reference`) | n | kind | unit of `value` |
//! |---|---|---|---|---|---|
//! | `scale-drift` | t, s since the first sample | `time_s` (mean window time) | 1 | scale | 1/s |
//! | `scale-drift-curved` | t | `time_s` | 2 | scale | 1/s² |
//! | `temperature-squared` | θ, °C | `temperature_c` (mean window temperature, the core's `temp_ref_c`) | 2 | bias | units/°C² |
//! | `temperature-cubed` | θ | `temperature_c` | 3 | bias | units/°C³ |
//! | `temperature-scale-squared` | θ | `temperature_c` | 2 | scale | 1/°C² |
//! | `temperature-scale-cubed` | θ | `temperature_c` | 3 | scale | 1/°C³ |
//! | `thermal-lag` | θ through a first-order lag of `time_constant_s` (started at the first sample's temperature) | `temperature_c` (mean of the windows' lagged means) | 1 | bias | units/°C |
//! | `temperature-rate` | dθ/dt, °C/s (least-squares slope over 30 s about the sample) | `rate_c_per_s` (mean window rate) | 1 | bias | units/(°C/s) |
//!
//! A **bias** term adds `value·X` (the recording's raw units) to the core calibration's bias
//! on axis `j`; a **scale** term multiplies axis `j`'s calibrated reading `u_j = (K·(m − b))_j`
//! by `1 + value·X` (all scale terms of one axis add inside the one factor), before the
//! per-axis and cross nonlinearities: exactly the analysis model's open slots
//! (`fit::model::Slot`). At the origins every term vanishes.

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

/// The origin a host term's regressor is taken about (module docs): seconds since the
/// start of the recording for the time families, °C for the temperature and thermal-lag
/// families, °C/s for the temperature rate. Exactly the one field of its family is present.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostReference {
    /// Time origin of the term, s since the start of the recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<f64>,
    /// Temperature origin of the term, °C.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    /// Temperature-rate origin of the term, °C/s (`temperature-rate` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_c_per_s: Option<f64>,
}

/// What a host term's regressor `x` is (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Regressor {
    /// Time since the first sample, s.
    Time,
    /// The temperature, °C.
    Temperature,
    /// The temperature through a first-order lag of this time constant (s), °C.
    LaggedTemperature(f64),
    /// The temperature rate, °C/s.
    TemperatureRate,
}

impl HostTerm {
    /// The regressor, power and kind (`true`: scale) of the term's family; `None` for a
    /// family that is not one of [`HOST_FAMILIES`] (refused by [`validate`]).
    pub fn shape(&self) -> Option<(Regressor, i32, bool)> {
        let lag = Regressor::LaggedTemperature(self.time_constant_s.unwrap_or(f64::NAN));
        Some(match self.family.as_str() {
            names::SCALE_DRIFT => (Regressor::Time, 1, true),
            names::SCALE_DRIFT_CURVED => (Regressor::Time, 2, true),
            names::TEMPERATURE_SQUARED => (Regressor::Temperature, 2, false),
            names::TEMPERATURE_CUBED => (Regressor::Temperature, 3, false),
            names::TEMPERATURE_SCALE_SQUARED => (Regressor::Temperature, 2, true),
            names::TEMPERATURE_SCALE_CUBED => (Regressor::Temperature, 3, true),
            names::THERMAL_LAG => (lag, 1, false),
            names::TEMPERATURE_RATE => (Regressor::TemperatureRate, 1, false),
            _ => return None,
        })
    }

    /// The regressor's origin `x₀` (the reference field of its family).
    pub fn origin(&self) -> Option<f64> {
        let r = self.reference;
        match self.shape()?.0 {
            Regressor::Time => r.time_s,
            Regressor::Temperature | Regressor::LaggedTemperature(_) => r.temperature_c,
            Regressor::TemperatureRate => r.rate_c_per_s,
        }
    }

    /// `value·(x − x₀)^n` for the regressor value `x`: a bias in the recording's raw units or
    /// a relative scale (module docs). `None` for an unknown family.
    pub fn contribution(&self, x: f64) -> Option<f64> {
        let (_, n, _) = self.shape()?;
        Some(self.value * (x - self.origin()?).powi(n))
    }

    /// Whether the term scales its axis (else it is a bias).
    pub fn is_scale(&self) -> bool {
        self.shape().is_some_and(|s| s.2)
    }
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
    /// The regressor's origin `x₀` (time, temperature or rate; module docs).
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
