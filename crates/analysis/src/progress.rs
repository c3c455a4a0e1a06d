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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{simulate, EffectSpec, SimConfig, SimEffect};
    use std::sync::Mutex;

    /// An analysis reports its stages in order — detection, base fit, then each step's
    /// candidates counted from 0 to the step's total — and the same result as without a hook.
    #[test]
    fn analysis_reports_stages_in_order_and_counts_to_the_total() {
        let rec = simulate(&SimConfig {
            effects: vec![EffectSpec::new(SimEffect::Quadratic, None)],
            poses: 40,
            seed: 4,
            ..Default::default()
        })
        .unwrap()
        .recording;
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&seen);
        let opts = crate::AnalyzeOptions {
            progress: ProgressHook::new(move |p| sink.lock().unwrap().push(p)),
            ..Default::default()
        };
        let with = crate::analyze(&rec, &opts).unwrap();
        let without = crate::analyze(&rec, &Default::default()).unwrap();
        assert_eq!(with.final_model.rms_mg, without.final_model.rms_mg);
        let seen = seen.lock().unwrap().clone();
        assert_eq!(seen[0].stage, Stage::Windows);
        assert_eq!(
            seen[1..3].iter().map(|p| p.done).collect::<Vec<_>>(),
            [0, 1]
        );
        let steps: Vec<usize> = seen
            .iter()
            .filter_map(|p| match p.stage {
                Stage::Candidates { step } => Some(step),
                _ => None,
            })
            .collect();
        assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
        assert_eq!(steps.last().copied(), Some(with.steps.len()));
        for step in 1..=with.steps.len() {
            let of_step: Vec<&Progress> = seen
                .iter()
                .filter(|p| p.stage == Stage::Candidates { step })
                .collect();
            let total = of_step[0].total;
            assert!(total > 0 && of_step.iter().all(|p| p.total == total));
            assert!(of_step.windows(2).all(|w| w[0].done <= w[1].done));
            assert_eq!((of_step[0].done, of_step.last().unwrap().done), (0, total));
        }
    }
}
