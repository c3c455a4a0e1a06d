//! Settings of the analysis.

use crate::fit::base::FitOptions;
use crate::report::progress::ProgressHook;
use crate::search::candidate::Candidate;
use crate::search::select::{ALPHA, CV_FACTOR, MAX_EFFECTS, MAX_OUTLIER_FRACTION};

/// Settings of the analysis; the defaults are the selection rule's constants
/// ([`crate::search::select`]).
#[derive(Debug, Clone)]
pub struct AnalyzeOptions {
    /// Detection and base-fit settings (as `wiical fit`).
    pub fit: FitOptions,
    /// Family-wise significance level per greedy step (Bonferroni over the candidates tried).
    pub alpha: f64,
    /// A candidate must divide the cross-validated RMS by at least this factor.
    pub cv_factor: f64,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// At most this fraction of the windows may be rejected as outliers.
    pub max_outlier_fraction: f64,
    /// Restrict the candidates to these (`None`: all, and the open basis after them,
    /// [`crate::search::open_basis_screening`]; a restricted list turns the open basis off).
    pub candidates: Option<Vec<Candidate>>,
    /// Where progress goes (a terminal bar in the CLI; nowhere by default).
    pub progress: ProgressHook,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        Self {
            fit: FitOptions::default(),
            alpha: ALPHA,
            cv_factor: CV_FACTOR,
            max_effects: MAX_EFFECTS,
            max_outlier_fraction: MAX_OUTLIER_FRACTION,
            candidates: None,
            progress: ProgressHook::default(),
        }
    }
}

impl AnalyzeOptions {
    /// True when `c` may be tried.
    pub fn allows(&self, c: Candidate) -> bool {
        self.candidates
            .as_ref()
            .is_none_or(|list| list.contains(&c))
    }
}
