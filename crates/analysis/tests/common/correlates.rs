//! Test support for the residual correlates: the 40-pose 16-bit MEMS
//! recording at 400 Hz that `residual_correlates.rs` and `open_basis.rs` analyse blind, and
//! the check of its strongest correlate.

use wiical_analysis::report::correlate::ResidualCorrelate;
use wiical_analysis::search::candidate::Candidate;
use wiical_analysis::{analyze, AnalyzeOptions, AnalyzeReport};
use wiical_sim::{Device, EffectSpec, SimConfig, SimOutput};

/// The recording of [`correlates_run`] (the temperature column changes no draw).
pub fn correlates_sim(effects: Vec<EffectSpec>, seed: u64, temp: bool) -> SimOutput {
    wiical_sim::simulate(&SimConfig {
        effects,
        seed,
        device: Device::Mems16,
        poses: 40,
        rate_hz: 400.0,
        temp_column: temp,
        ..Default::default()
    })
    .unwrap()
}

/// A 40-pose 16-bit MEMS recording at 400 Hz with `effects` (and a temperature column when
/// `temp`), analysed blind with the candidates restricted to `allowed` (empty: all).
pub fn correlates_run(
    effects: Vec<EffectSpec>,
    seed: u64,
    temp: bool,
    allowed: &[Candidate],
) -> (SimOutput, AnalyzeReport) {
    let s = correlates_sim(effects, seed, temp);
    let opts = AnalyzeOptions {
        candidates: (!allowed.is_empty()).then(|| allowed.to_vec()),
        ..Default::default()
    };
    let r = analyze(&s.recording, &opts).unwrap();
    (s, r)
}

/// The strongest correlate of `r`'s final residual: the residual must stay above the floor,
/// and the strongest must be `regressor` and significant after Bonferroni.
pub fn strongest<'a>(r: &'a AnalyzeReport, seed: u64, regressor: &str) -> &'a ResidualCorrelate {
    let c = r
        .residual_correlates
        .as_ref()
        .expect("residual above the floor");
    assert_eq!(c[0].regressor, regressor, "seed {seed}: {c:?}");
    assert!(c[0].significant, "seed {seed}: {:?}", c[0]);
    &c[0]
}
