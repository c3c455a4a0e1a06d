//! Sanity of a recording's time column: it must increase from row to row (time that goes
//! backwards or repeats means reordered, merged or duplicated rows, and the drift and rate
//! estimates built on it would be wrong without a word); jumps are reported as notes (a
//! logger that dropped samples is common and harmless for static poses, but the user should
//! know). A rate that suggests millisecond times is named where it makes a setting fail
//! (`windows::detect`).

use crate::error::{Error, Result};
use crate::input::quote;

/// A gap is a step longer than this many median steps.
pub const GAP_FACTOR: f64 = 5.0;

/// At most this many gaps are listed in the notes (the count is always given).
const MAX_LISTED_GAPS: usize = 3;

/// Checks time values row by row as the loader reads them (so that an error names the line).
#[derive(Debug, Clone)]
pub struct TimeCheck {
    column: String,
    prev: Option<f64>,
}

impl TimeCheck {
    /// A check of the column named `column` (for messages).
    pub fn new(column: &str) -> Self {
        Self {
            column: quote(column),
            prev: None,
        }
    }

    /// The next row's time `t` (seconds by contract), read on 1-based `line`.
    pub fn push(&mut self, t: f64, line: usize) -> Result<()> {
        if let Some(prev) = self.prev {
            if t <= prev {
                return Err(Error::TimeNotIncreasing {
                    line,
                    column: self.column.clone(),
                    previous: prev,
                    value: t,
                });
            }
        }
        self.prev = Some(t);
        Ok(())
    }
}

/// Notes on a strictly increasing time column: gaps (steps over [`GAP_FACTOR`] × the median
/// step). Empty when all is regular.
pub fn time_notes(column: &str, t: &[f64]) -> Vec<String> {
    let mut notes = Vec::new();
    if t.len() < 3 {
        return notes;
    }
    let steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = steps.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let median = sorted[sorted.len() / 2];
    if !(median.is_finite() && median > 0.0) {
        return notes;
    }
    let gaps: Vec<usize> = steps
        .iter()
        .enumerate()
        .filter(|(_, d)| **d > GAP_FACTOR * median)
        .map(|(i, _)| i)
        .collect();
    // Rounded for the message (a median of 0.009999999999990905 s reads as 0.01 s).
    let median_shown = (median * 1e9).round() / 1e9;
    if !gaps.is_empty() {
        let listed: Vec<String> = gaps
            .iter()
            .take(MAX_LISTED_GAPS)
            .map(|&i| format!("{} s → {} s", t[i], t[i + 1]))
            .collect();
        let more = if gaps.len() > MAX_LISTED_GAPS {
            ", …"
        } else {
            ""
        };
        notes.push(format!(
            "column '{}': time jumps {} time(s) by more than {GAP_FACTOR}× the median step of {median_shown} s ({}{more}); samples are missing there",
            quote(column),
            gaps.len(),
            listed.join(", ")
        ));
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backwards_and_repeated_times_name_the_line() {
        let mut c = TimeCheck::new("t");
        c.push(0.0, 2).unwrap();
        c.push(0.01, 3).unwrap();
        let e = c.push(0.005, 4).unwrap_err().to_string();
        assert_eq!(
            e,
            "line 4: column 't': time goes from 0.01 back to 0.005 (or repeats); rows must be in increasing time order"
        );
        let mut c = TimeCheck::new("time");
        c.push(1.0, 2).unwrap();
        assert!(matches!(
            c.push(1.0, 3),
            Err(Error::TimeNotIncreasing { line: 3, .. })
        ));
    }

    #[test]
    fn gaps_are_noted() {
        let regular: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
        assert!(time_notes("t", &regular).is_empty());
        let mut gap = regular.clone();
        for v in gap.iter_mut().skip(50) {
            *v += 3.0;
        }
        let notes = time_notes("t", &gap);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains("jumps 1 time(s)"), "{}", notes[0]);
        assert!(notes[0].contains("0.49 s → 3.5 s"), "{}", notes[0]);
    }
}
