//! Test support: a simulated recording of a device at its usual rate with given effects.

use wiical_sim::{Device, EffectSpec, SimConfig, SimEffect, SimOutput};

/// A recording of `device` at its usual rate (the simulator's default 30 poses) with
/// `effects` (effect, mg).
pub fn sim(effects: &[(SimEffect, f64)], seed: u64, device: Device) -> SimOutput {
    wiical_sim::simulate(&SimConfig {
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
