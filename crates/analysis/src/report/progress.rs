//! Progress of a long analysis, for a display the caller owns (the CLI draws an `indicatif`
//! bar on stderr; the library draws nothing and depends on no terminal crate).
//!
//! The analysis of a recording with thousands of windows takes seconds: reading the windows
//! (passes of the static detector over every sample), the base fit, then per greedy step one
//! fit and one cross-validation per candidate effect. [`Progress`] says which stage runs and,
//! where the amount of work is known in advance (the candidates of a step), how much of it is
//! done.

use std::fmt;
use std::sync::Arc;

/// A stage of the analysis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Static-window detection over the samples (several passes; no known total).
    Windows,
    /// The `f64` refinement of the base model and its leave-one-window-out errors.
    BaseFit,
    /// Greedy step `step` (1-based): fitting and cross-validating each candidate.
    Candidates {
        /// The step, from 1.
        step: usize,
    },
}

/// One progress report: `done` of `total` units of `stage` (`total` 0: unknown, e.g. the
/// detection's passes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// What runs.
    pub stage: Stage,
    /// Units done (candidates fitted).
    pub done: usize,
    /// Units in the stage (0 when not known).
    pub total: usize,
}

impl fmt::Display for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.stage {
            Stage::Windows => write!(f, "detecting static windows"),
            Stage::BaseFit => write!(f, "base fit and cross-validation"),
            Stage::Candidates { step } => write!(f, "step {step}: candidate effects"),
        }
    }
}

/// A progress callback, shared so that the options holding it stay `Clone`; the default
/// reports nowhere. Called from the thread running the analysis, a few times per stage (once
/// per candidate), so it may be slow-ish (it draws a terminal line) without costing time.
#[derive(Clone, Default)]
pub struct ProgressHook(Option<Arc<dyn Fn(Progress) + Send + Sync>>);

impl ProgressHook {
    /// Reports to `f`.
    pub fn new(f: impl Fn(Progress) + Send + Sync + 'static) -> Self {
        Self(Some(Arc::new(f)))
    }

    /// Passes `p` on (nothing without a callback).
    pub fn report(&self, p: Progress) {
        if let Some(f) = &self.0 {
            f(p);
        }
    }
}

impl fmt::Debug for ProgressHook {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "ProgressHook(set)"
        } else {
            "ProgressHook(none)"
        })
    }
}
