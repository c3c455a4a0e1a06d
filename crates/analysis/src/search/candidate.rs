//! The candidate effects the analysis can add to the base model.
//!
//! A new effect goes here (a variant, its name, its terms), in [`crate::fit::model`] (its parameter
//! block, residual and derivatives) and, if the device should apply it, in the core's
//! `Effects`.

use crate::error::search::SearchError;
use crate::fit::model::Term;
use crate::report::effect_names as names;
use std::fmt;
use std::str::FromStr;

/// One candidate effect. `Display`/`FromStr` use the names of the JSON contract
/// (`effects[].name`, `steps[].candidates[].name`) and of `--candidates`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Candidate {
    /// Per-axis quadratic nonlinearity `k2·u²`.
    Quadratic,
    /// Per-axis cubic nonlinearity `k3·u³`.
    Cubic,
    /// Bias linear in time.
    BiasDrift,
    /// Bias linear in temperature.
    Temperature,
    /// Scale linear in temperature.
    TemperatureScale,
    /// Windows that were not still (rejected, not modelled).
    Outliers,
    /// Bias linear + quadratic in time: a diagnostic only, the core cannot store it.
    BiasDriftCurved,
}

impl Candidate {
    /// Every candidate, in the order they are tried and listed.
    pub const ALL: [Candidate; 7] = [
        Candidate::Quadratic,
        Candidate::Cubic,
        Candidate::BiasDrift,
        Candidate::Temperature,
        Candidate::TemperatureScale,
        Candidate::Outliers,
        Candidate::BiasDriftCurved,
    ];

    /// The name of the JSON contract.
    pub fn name(self) -> &'static str {
        match self {
            Candidate::Quadratic => names::QUADRATIC,
            Candidate::Cubic => names::CUBIC,
            Candidate::BiasDrift => names::BIAS_DRIFT,
            Candidate::Temperature => names::TEMPERATURE,
            Candidate::TemperatureScale => names::TEMPERATURE_SCALE,
            Candidate::Outliers => names::OUTLIERS,
            Candidate::BiasDriftCurved => names::BIAS_DRIFT_CURVED,
        }
    }

    /// The candidate that adds this single parameter block.
    pub fn of_term(t: Term) -> Candidate {
        match t {
            Term::Quadratic => Candidate::Quadratic,
            Term::Cubic => Candidate::Cubic,
            Term::Drift => Candidate::BiasDrift,
            Term::BiasTemp => Candidate::Temperature,
            Term::ScaleTemp => Candidate::TemperatureScale,
            Term::Drift2 => Candidate::BiasDriftCurved,
        }
    }

    /// False for diagnostics the core's `Effects` cannot hold (never added).
    pub fn storable(self) -> bool {
        self != Candidate::BiasDriftCurved
    }

    /// The comma-separated list of all names (for messages).
    pub fn all_names() -> String {
        Candidate::ALL.map(Candidate::name).join(", ")
    }
}

impl fmt::Display for Candidate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Candidate {
    type Err = SearchError;

    fn from_str(s: &str) -> Result<Self, SearchError> {
        Candidate::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| SearchError::UnknownCandidate {
                name: s.into(),
                known: Candidate::all_names(),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for c in Candidate::ALL {
            assert_eq!(c.to_string().parse::<Candidate>().unwrap(), c);
        }
        for t in Term::ALL {
            assert_eq!(Candidate::of_term(t).name(), t.name());
        }
        let e = "wobble".parse::<Candidate>().unwrap_err().to_string();
        assert_eq!(
            e,
            "unknown candidate effect 'wobble'; known: quadratic, cubic, bias-drift, \
             temperature, temperature-scale, outliers, bias-drift-curved"
        );
    }
}
