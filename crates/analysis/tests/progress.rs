//! The progress hook seen from outside the crate (an integration test, so the module graph of
//! `src/` has no edge from `progress` back to the pipeline it reports on).

use std::sync::{Arc, Mutex};
use wiical_analysis::report::progress::{Progress, ProgressHook, Stage};
use wiical_sim::{simulate, EffectSpec, SimConfig, SimEffect};

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
    let opts = wiical_analysis::AnalyzeOptions {
        progress: ProgressHook::new(move |p| sink.lock().unwrap().push(p)),
        ..Default::default()
    };
    let with = wiical_analysis::analyze(&rec, &opts).unwrap();
    let without = wiical_analysis::analyze(&rec, &Default::default()).unwrap();
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
