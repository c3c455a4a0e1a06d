//! The simulated adapter with a MotionPlus (`wiical-device-sim --extension motionplus`, issue 50
//! item 3): the adapter's `ExtensionPoller` finds and polls the simulated MotionPlus, and the
//! stream carries its rates (protocol 8's `GyroSample`), corrected by the adapter's own
//! `GyroCorrector` once a gyro calibration is committed. Checked against the simulation's truth
//! (`wiical_device_sim::motionplus`): which sample is at rest or in which turn is told by the
//! truth's program, not by the rates read.
#![cfg(unix)]

mod support;
use support::*;

use wiical_client::{Device, Streamed};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_device_sim::motionplus::{
    gyro_rate_dps, true_gyro_calibration, GYRO_NOISE_COUNTS, GYRO_TRUE_BIAS, GYRO_TRUE_CPD,
    GYRO_TURN_FAST_DPS, GYRO_TURN_SLOW_DPS,
};
use wiical_device_sim::{spawn, SimExtension, SimOptions};
use wiical_wire::GyroSample;

/// Gyro samples of two program periods (and a bit), each with its time in the program. The
/// stream is placed in the program by the first sample whose raw yaw rises out of the rest
/// (the slow turn starts at 4 s): the truth's times, found once, not fitted.
fn period(dev: &mut Device) -> Vec<(f64, GyroSample)> {
    let rate_hz = f64::from(dev.start_stream(1).unwrap()) / 1000.0;
    let mut out = Vec::new();
    while out.len() < (rate_hz * 26.0) as usize {
        match dev.next_streamed().unwrap() {
            Streamed::Gyro(g) => out.push(g),
            Streamed::Accelerometer(s) => {
                panic!("an accelerometer sample from a MotionPlus: {s:?}")
            }
        }
    }
    dev.stop_stream().unwrap();
    let seq0 = out[0].seq;
    let t = |g: &GyroSample| f64::from(g.seq.wrapping_sub(seq0)) / rate_hz;
    // The first sample whose yaw count is 20 σ above the true bias: the slow turn's ramp has
    // reached 20 σ / (90 °/s · cpd) of its 0.2 s there.
    let high = |g: &GyroSample| f64::from(g.raw[0]) > GYRO_TRUE_BIAS[0] + 20.0 * GYRO_NOISE_COUNTS;
    let start = (1..out.len())
        .find(|&k| high(&out[k]) && !high(&out[k - 1]))
        .unwrap();
    let ramp_s = 20.0 * GYRO_NOISE_COUNTS / (GYRO_TURN_SLOW_DPS[0] * GYRO_TRUE_CPD[0]) * 0.2;
    let offset = 4.0 + ramp_s - t(&out[start]);
    out.iter().map(|g| (t(g) + offset, *g)).collect()
}

/// Mean corrected rate (°/s) of the samples whose program time lies well inside `[a, b]`.
fn mean_dps(samples: &[(f64, GyroSample)], a: f64, b: f64) -> [f64; 3] {
    let inside: Vec<[f64; 3]> = samples
        .iter()
        .filter(|(t, _)| (a + 0.1..b - 0.1).contains(&t.rem_euclid(12.0)))
        .map(|(_, g)| g.corrected.unwrap().map(|w| f64::from(w).to_degrees()))
        .collect();
    assert!(inside.len() > 100, "{} samples in [{a}, {b}]", inside.len());
    let n = inside.len() as f64;
    std::array::from_fn(|i| inside.iter().map(|r| r[i]).sum::<f64>() / n)
}

#[test]
fn the_simulated_motionplus_streams_its_rates_corrected_by_the_committed_calibration() {
    let (path, sim) = spawn(SimOptions {
        extension: SimExtension::MotionPlus,
        time_scale: 10.0,
        ..Default::default()
    })
    .unwrap();
    let (mut dev, _) = Device::connect(&port(&path), opts(3000)).unwrap();

    // No gyro calibration: the raw counts and range bits pass, nothing corrected. At rest
    // (the truth's program: 0–4 s) the counts sit at the true bias.
    let before = period(&mut dev);
    assert!(before.iter().all(|(_, g)| g.corrected.is_none()));
    // At rest and 0.1 s from any turn.
    let rest: Vec<&GyroSample> = before
        .iter()
        .filter(|(t, _)| {
            [-0.1, 0.0, 0.1]
                .iter()
                .all(|d| gyro_rate_dps(t + d) == [0.0; 3])
        })
        .map(|(_, g)| g)
        .collect();
    assert!(rest.len() > 1000);
    for (i, bias) in GYRO_TRUE_BIAS.iter().enumerate() {
        let mean = rest.iter().map(|g| f64::from(g.raw[i])).sum::<f64>() / rest.len() as f64;
        assert!((mean - bias).abs() < 0.5, "axis {i}: {mean}");
    }
    // The fast roll turn is sent in the fast range, the slow turn in the slow one.
    let at = |t0: f64| {
        before
            .iter()
            .find(|(t, _)| (t - t0).abs() < 0.01)
            .unwrap()
            .1
    };
    assert_eq!(at(8.75).slow_axes(), [true, false, true]);
    assert_eq!(at(5.0).slow_axes(), [true; 3]);

    // The calibration that inverts the simulated MotionPlus, committed over the wire.
    let cal = GyroCorrection::from(true_gyro_calibration());
    dev.put_gyro_judged(&cal).unwrap();
    dev.commit_gyro().unwrap();
    let after = period(&mut dev);
    let rest = mean_dps(&after, 0.0, 4.0);
    let slow = mean_dps(&after, 4.2, 5.8);
    let fast = mean_dps(&after, 8.2, 9.3);
    eprintln!("at rest {rest:?}, slow turn {slow:?}, fast turn {fast:?} °/s");
    for i in 0..3 {
        // At rest: within the noise of zero (1 count ≈ 0.05 °/s per sample, hundreds averaged).
        assert!(rest[i].abs() < 0.02, "rest {rest:?}");
        // The slow turn within its noise; the fast one within a fraction of a fast count
        // (≈ 0.25 °/s), its range mapped back onto the slow scale with the device's block.
        assert!(
            (slow[i] - GYRO_TURN_SLOW_DPS[i]).abs() < 0.05,
            "slow {slow:?}"
        );
        assert!(
            (fast[i] - GYRO_TURN_FAST_DPS[i]).abs() < 0.15,
            "fast {fast:?}"
        );
    }
    drop(dev);
    sim.stop().unwrap();
}
