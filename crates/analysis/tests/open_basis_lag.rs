//! The open basis's thermal-lag and temperature-rate terms (issue 19 item 3): a simulated
//! recording whose bias follows the temperature through a first-order lag (τ = 300 s, the
//! simulator's [`THERMAL_LAG_TAU_S`]) or its rate of change is analysed blind.

use wiical_analysis::simulate::{
    self, open_basis::THERMAL_LAG_TAU_S, Device, EffectSpec, SimConfig, SimEffect, SimOutput,
};
use wiical_analysis::{analyze, AnalyzeOptions, AnalyzeReport};

/// A recording of `device` at its usual rate with `effects` (effect, mg).
fn sim(effects: &[(SimEffect, f64)], seed: u64, device: Device) -> SimOutput {
    simulate::simulate(&SimConfig {
        effects: effects
            .iter()
            .map(|(e, m)| EffectSpec::new(*e, Some(*m)))
            .collect(),
        seed,
        device,
        rate_hz: device.typical_rate_hz(),
        ..Default::default()
    })
    .unwrap()
}

fn run(effects: &[(SimEffect, f64)], seed: u64) -> (SimOutput, AnalyzeReport) {
    let s = sim(effects, seed, Device::Mems16);
    let r = analyze(&s.recording, &AnalyzeOptions::default()).unwrap();
    (s, r)
}

/// The τ in a `thermal-lag (x, τ = N s)` name.
fn tau_of(name: &str) -> Option<f64> {
    let rest = name.strip_prefix("thermal-lag (")?;
    let t = rest.split("τ = ").nth(1)?;
    t.split(' ').next()?.parse().ok()
}

#[test]
#[ignore]
fn probe() {
    for seed in 1..=6u64 {
        for (e, m) in [
            (SimEffect::ThermalLag, 20.0),
            (SimEffect::TemperatureRate, 20.0),
            (SimEffect::None, 0.0),
        ] {
            let set: Vec<(SimEffect, f64)> = if m > 0.0 { vec![(e, m)] } else { vec![] };
            let (s, r) = run(&set, seed);
            let t = s.recording.t.as_ref().unwrap();
            eprintln!(
                "seed {seed} {} dur {:.0} s: base CV {:?} final {:?} floor {:?}: {:?}",
                e.name(),
                t.last().unwrap() - t[0],
                r.base.cv_rms_mg,
                r.final_model.cv_rms_mg,
                r.noise_floor_mg,
                r.effects
                    .iter()
                    .map(|e| (&e.name, &e.evidence))
                    .collect::<Vec<_>>()
            );
        }
    }
    let _ = tau_of("");
    let _ = THERMAL_LAG_TAU_S;
}
