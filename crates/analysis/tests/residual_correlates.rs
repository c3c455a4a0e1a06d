//! What the final residual correlates with: with a simulated effect left
//! out of the candidates the residual stays above the floor and its strongest correlate is
//! the pattern that effect leaves (truth known); on clean recordings the residual agrees with
//! the floor and nothing is reported.

mod common;

use common::correlates::{correlates_run, strongest};
use wiical_analysis::search::candidate::Candidate;
use wiical_sim::{EffectSpec, SimEffect};

const AXES: [&str; 3] = ["x", "y", "z"];

/// A 30 mg quadratic on one axis, with the quadratic candidate withheld: the strongest
/// correlate is that axis' cube (what `q·u²` leaves in ‖a‖ − 1), significant after
/// Bonferroni, and its slope is the simulated 30 mg within 15 %.
#[test]
fn a_withheld_quadratic_is_traced_to_its_axis() {
    let others = [Candidate::Cubic, Candidate::BiasDrift, Candidate::Outliers];
    for seed in 1..=2u64 {
        let axis = seed as usize % 3;
        let spec = EffectSpec::on_axis(SimEffect::Quadratic, Some(30.0), axis);
        let (_, r) = correlates_run(vec![spec], seed, false, &others);
        let c = strongest(&r, seed, &format!("g_{}^3", AXES[axis]));
        assert!(
            (c.slope.abs() - 30.0).abs() < 4.5,
            "seed {seed}: {}",
            c.slope
        );
    }
}

/// A temperature scale on one axis with the temperature candidates withheld: the strongest
/// correlate is temperature times that axis's square (what `σ·ϑ·u_a` leaves in ‖a‖ − 1),
/// significant after Bonferroni.
#[test]
fn a_withheld_temperature_scale_is_traced_to_its_axis() {
    let others = [
        Candidate::Quadratic,
        Candidate::Cubic,
        Candidate::BiasDrift,
        Candidate::Outliers,
    ];
    for seed in 1..=2u64 {
        let axis = seed as usize % 3;
        let spec = EffectSpec::on_axis(SimEffect::TemperatureScale, Some(20.0), axis);
        let (_, r) = correlates_run(vec![spec], seed, true, &others);
        strongest(&r, seed, &format!("temperature*g_{}^2", AXES[axis]));
    }
}

/// A bias drift with the drift candidates withheld (no temperature column, so nothing else
/// can stand in for time): the strongest correlate is time times an axis of g, significant.
#[test]
fn a_withheld_drift_is_traced_to_time() {
    let others = [Candidate::Quadratic, Candidate::Cubic, Candidate::Outliers];
    for seed in 1..=2u64 {
        let spec = EffectSpec::new(SimEffect::BiasDrift, Some(10.0));
        let (_, r) = correlates_run(vec![spec], seed, false, &others);
        let c = r
            .residual_correlates
            .as_ref()
            .expect("residual above the floor");
        assert!(c[0].regressor.starts_with("time*g_"), "seed {seed}: {c:?}");
        assert!(c[0].significant, "seed {seed}: {:?}", c[0]);
    }
}

/// Clean recordings (and an effect the analysis is free to find): the final residual agrees
/// with the floor and `residual_correlates` is absent.
#[test]
fn nothing_is_reported_when_the_residual_agrees_with_the_floor() {
    for seed in 1..=3u64 {
        let (_, r) = correlates_run(Vec::new(), seed, true, &[]);
        assert!(
            r.residual_correlates.is_none(),
            "seed {seed}: {:?}",
            r.residual_correlates
        );
    }
    let spec = EffectSpec::on_axis(SimEffect::Quadratic, Some(30.0), 1);
    let (_, r) = correlates_run(vec![spec], 4, false, &[]);
    assert!(
        r.residual_correlates.is_none(),
        "{:?}\n{}",
        r.residual_correlates,
        r.verdict
    );
}
