//! The calibration file's host-only terms: terms the open basis
//! (`search::open_basis_screening::host_terms`) selects that depend on the time since the start of the
//! recording or on the temperature. The core's `Effects` has no field for them and the
//! adapter has no clock origin or thermometer, so they are kept in the file for hosts that
//! have both (`crate::correct` applies them; `crate::output::host_term_checks` checks them when a file is read).
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
    /// family that is not one of [`HOST_FAMILIES`] (refused by `crate::output::host_term_checks::validate`).
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
