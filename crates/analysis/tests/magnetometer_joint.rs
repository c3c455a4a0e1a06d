//! The magnetometer's column-following effect (`interference:<column>`, ArduPilot
//! COMPASS_MOT's `offset = k·current`) is fitted jointly with the hard/soft-iron model (its
//! centre columns beside the base columns in one least squares, `magnetometer::design`), so
//! its stated standard errors mean what they say: over seeds and magnitudes the reported
//! coefficients sit within 3 of their standard errors of the truth, and the scaled errors
//! scatter like a unit normal.

use wiical_analysis::magnetometer::{self, MagAnalysis, MagModel};
use wiical_analysis::search::select::ALPHA;
use wiical_sim::magnetometer::{simulate_mag, MagEffectTruth, MagSimConfig};

fn run(k: [f64; 3], seed: u64) -> MagAnalysis {
    let sim = simulate_mag(&MagSimConfig {
        effect: MagEffectTruth::Interference(k),
        seed,
        ..Default::default()
    });
    let (rec, current) = sim.recording();
    let prep = magnetometer::fit_source(&rec, MagModel::Ellipsoid).expect("fit");
    magnetometer::analyze_source(&rec, &prep, &[current], MagModel::Ellipsoid, ALPHA)
        .expect("analysis")
}

/// Three magnitudes (the centre moving by up to 2 %, 4 % and 10 % of R over the current's
/// 0–10 A) × 4 seeds × 3 axes: every coefficient within 3 σ of the truth and the RMS of the
/// scaled errors between 0.5 and 2. At 10 % a single linear step about the core's fit (made
/// without the current) was 2.5 % off, 10 σ; the loop's second pass about its first estimate
/// (`magnetometer::KnownShift`) is what passes it (docs/magnetometer.md).
#[test]
fn interference_coefficients_are_within_three_sigma() {
    let mut z = Vec::new();
    for (m, k) in [[1.0, -0.5, 0.75], [2.0, -1.0, 1.5], [5.0, 2.0, -3.0]]
        .into_iter()
        .enumerate()
    {
        for seed in 0..4u64 {
            let a = run(k, 500 + 10 * m as u64 + seed);
            let e = a
                .effects
                .iter()
                .find(|e| e.name == "interference:current")
                .unwrap_or_else(|| panic!("{k:?} seed {seed}: {:?}", a.effects));
            for ax in 0..3 {
                let zi = (e.values[ax] - k[ax]) / e.std_errors[ax];
                eprintln!(
                    "k {:?} seed {seed} axis {ax}: {:.4} ± {:.4} (z {zi:+.2})",
                    k, e.values[ax], e.std_errors[ax]
                );
                assert!(zi.abs() <= 3.0, "{k:?} seed {seed} axis {ax}: {e:?}");
                z.push(zi);
            }
        }
    }
    let rms = (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt();
    eprintln!("{} coefficients: RMS z {rms:.2}", z.len());
    assert!((0.5..=2.0).contains(&rms), "RMS z {rms}: {z:?}");
}
