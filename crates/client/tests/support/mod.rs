//! Fixtures shared by the client ↔ simulated-adapter tests (this crate's, and the `wiical
//! device` command-line tests in host/tests, which include this file).
#![allow(dead_code)] // each test file uses a different part

use std::path::PathBuf;
use std::time::{Duration, Instant};

use nalgebra::Matrix3;
use wiical_client::ClientOptions;
use wiical_core::Calibration;
use wiical_device_sim::{TRUE_BIAS, TRUE_D};

/// The calibration a perfect fit of the simulated sensor gives: `K = D⁻¹`, `b`.
pub fn true_calibration() -> Calibration {
    let d = Matrix3::from_fn(|i, j| TRUE_D[i][j]);
    let k = d.try_inverse().expect("invertible");
    Calibration {
        bias: TRUE_BIAS.map(|x| x as f32),
        matrix: std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)] as f32)),
        effects: Default::default(),
    }
}

pub fn bits(c: &Calibration) -> Vec<u32> {
    let mut v: Vec<u32> = c.bias.iter().map(|x| x.to_bits()).collect();
    for r in &c.matrix {
        v.extend(r.iter().map(|x| x.to_bits()));
    }
    v
}

pub fn opts(timeout_ms: u64) -> ClientOptions {
    ClientOptions {
        timeout: Duration::from_millis(timeout_ms),
        retries: 3,
    }
}

pub fn port(p: &std::path::Path) -> String {
    p.display().to_string()
}

/// Wait (bounded) for a condition the simulator thread sets.
pub fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !cond() {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

pub fn temp_path(name: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-device-test-{}-{name}", std::process::id()))
}
