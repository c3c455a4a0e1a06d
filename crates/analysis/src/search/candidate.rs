//! The candidate effects the analysis can add to the base model.
//!
//! A candidate is an [`Effect`] of [`crate::report::effect_table`] (one enum for the
//! candidates, the open basis's families and the simulator's effects, named by one table): a
//! new candidate is its row there, its parameter block in [`crate::fit::model`] (residual and
//! derivatives) and, if the device should apply it, its term in the core's table
//! (`wiical_core::terms`).

use crate::error::search::SearchError;
pub use crate::report::effect_table::Effect;
use std::str::FromStr;

/// One candidate effect: the [`Effect`]s of [`Effect::CANDIDATES`]. `Display`/`FromStr` use
/// the names of the JSON contract (`effects[].name`, `steps[].candidates[].name`) and of
/// `--candidates`.
pub type Candidate = Effect;

/// Parses a candidate's name: the names of [`Effect::CANDIDATES`] only (the simulator's
/// names are [`Effect::parse_simulated`]'s).
impl FromStr for Effect {
    type Err = SearchError;

    fn from_str(s: &str) -> Result<Self, SearchError> {
        Effect::CANDIDATES
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| SearchError::UnknownCandidate {
                name: s.into(),
                known: Effect::candidate_names(),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::model::Term;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for c in Candidate::CANDIDATES {
            assert_eq!(c.to_string().parse::<Candidate>().unwrap(), c);
        }
        for t in Term::ALL {
            assert_eq!(t.effect().name(), t.name());
        }
        for e in ["wobble", "none", "thermal-lag"] {
            let msg = e.parse::<Candidate>().unwrap_err().to_string();
            assert_eq!(
                msg,
                format!(
                    "unknown candidate effect '{e}'; known: quadratic, cubic, bias-drift, \
                     temperature, temperature-scale, outliers, bias-drift-curved"
                )
            );
        }
    }
}
