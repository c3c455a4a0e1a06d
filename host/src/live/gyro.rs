//! `wiical live`'s gyro view: a MotionPlus's rates as the adapter streams them (protocol 8's
//! `GyroSample`), in °/s along its count axes `[yaw, roll, pitch]`.
//!
//! The rates are the adapter's corrected ones when it holds a committed gyro calibration;
//! without one, the raw counts read on the ideal MotionPlus's nominal scales
//! (`wiical_adapter::IdealGyroScale`: zero 8192, 8192/440 counts per °/s slow and 8192/2000
//! fast), which is what a reader with fixed scales makes of them.
//!
//! The samples are cut into blocks of a quarter second. A block whose per-axis spread (max −
//! min) is within [`STEADY_SPREAD_DPS`] is steady: at rest when every axis's mean is within
//! [`REST_LIMIT_DPS`], else a steady turn. Consecutive rest blocks make a rest stretch, whose
//! mean is what the rates read at rest: **the bias that remains** (the calibration's error plus
//! the drift the adapter's zero-rate tracker has not followed yet). Consecutive steady-turn
//! blocks with means within [`SAME_TURN_DPS`] make a steady turn, whose mean is the rate a
//! turntable or a record player turned it at. Blocks that are neither (starting, stopping, a
//! hand) end the stretch.

use serde::Serialize;
use wiical_adapter::IdealGyroScale;
use wiical_wire::GyroSample;

/// Largest per-axis spread of a steady block, °/s (the slow range's noise is ≈ 0.1 °/s and a
/// fast count is ≈ 0.25 °/s: a hand never holds a turn this steady, a turntable does).
pub const STEADY_SPREAD_DPS: f64 = 3.0;
/// Largest |mean| per axis of a block at rest, °/s (an uncalibrated MotionPlus's bias is
/// within a few °/s).
pub const REST_LIMIT_DPS: f64 = 8.0;
/// Two steady blocks whose means differ by less than this per axis belong to one turn, °/s.
pub const SAME_TURN_DPS: f64 = 2.0;
/// Steady turns kept (the newest).
pub const TURNS_KEPT: usize = 6;

/// A stretch of steady blocks: their mean and how many samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stretch {
    /// Mean rate `[yaw, roll, pitch]`, °/s.
    pub mean_dps: [f64; 3],
    /// Samples in it.
    pub samples: u64,
    #[serde(skip)]
    sum: [f64; 3],
}

impl Stretch {
    fn new(sum: [f64; 3], n: u64) -> Self {
        let mut s = Self {
            mean_dps: [0.0; 3],
            samples: 0,
            sum: [0.0; 3],
        };
        s.add(sum, n);
        s
    }

    fn add(&mut self, sum: [f64; 3], n: u64) {
        for (a, b) in self.sum.iter_mut().zip(sum) {
            *a += b;
        }
        self.samples += n;
        let n = self.samples.max(1) as f64;
        self.mean_dps = self.sum.map(|s| s / n);
    }
}

/// What the page shows (the snapshot's `gyro`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GyroSnapshot {
    /// Gyro samples received.
    pub samples: u64,
    /// The rates are the adapter's corrected ones (`false`: raw counts on nominal scales).
    pub calibrated: bool,
    /// The latest rates `[yaw, roll, pitch]`, °/s.
    pub rates_dps: [f64; 3],
    /// The latest range bits `[yaw, roll, pitch]` (`true`: slow range).
    pub slow: [bool; 3],
    /// The latest rest stretch (ongoing or the last one): its mean is the bias that remains.
    pub rest: Option<Stretch>,
    /// The newest steady turns, oldest first.
    pub steady_turns: Vec<Stretch>,
    /// One line of words for the page.
    pub line: String,
}

/// What is being gathered now.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Current {
    Nothing,
    Rest,
    Turn,
}

/// The view; see the module docs.
#[derive(Debug, Clone)]
pub struct GyroView {
    block: usize,
    buf: Vec<[f64; 3]>,
    scale: IdealGyroScale,
    snap: GyroSnapshot,
    current: Current,
}

impl GyroView {
    /// A view of a stream at `rate_hz` (blocks of a quarter second, at least 5 samples).
    pub fn new(rate_hz: f64) -> Self {
        let block = ((rate_hz / 4.0).round() as usize).max(5);
        Self {
            block,
            buf: Vec::with_capacity(block),
            scale: IdealGyroScale::default(),
            snap: GyroSnapshot {
                samples: 0,
                calibrated: false,
                rates_dps: [0.0; 3],
                slow: [true; 3],
                rest: None,
                steady_turns: Vec::new(),
                line: String::new(),
            },
            current: Current::Nothing,
        }
    }

    /// The rates of a sample, °/s `[yaw, roll, pitch]`, and whether they are the adapter's
    /// corrected ones.
    pub fn rates_dps(&self, s: &GyroSample) -> ([f64; 3], bool) {
        match s.corrected {
            Some(w) => (w.map(|x| f64::from(x).to_degrees()), true),
            None => {
                let slow = s.slow_axes();
                (
                    std::array::from_fn(|i| f64::from(self.scale.decode(s.raw[i], slow[i]))),
                    false,
                )
            }
        }
    }

    /// One sample.
    pub fn push(&mut self, s: &GyroSample) {
        let (rates, calibrated) = self.rates_dps(s);
        if calibrated != self.snap.calibrated {
            // A calibration committed (or removed) mid-stream: what was gathered is in the
            // other units.
            self.buf.clear();
            self.snap.rest = None;
            self.snap.steady_turns.clear();
            self.current = Current::Nothing;
        }
        self.snap.samples += 1;
        self.snap.calibrated = calibrated;
        self.snap.rates_dps = rates;
        self.snap.slow = s.slow_axes();
        self.buf.push(rates);
        if self.buf.len() >= self.block {
            self.end_block();
        }
    }

    fn end_block(&mut self) {
        let n = self.buf.len() as u64;
        let mut sum = [0.0; 3];
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for r in &self.buf {
            for i in 0..3 {
                sum[i] += r[i];
                lo[i] = lo[i].min(r[i]);
                hi[i] = hi[i].max(r[i]);
            }
        }
        self.buf.clear();
        let mean = sum.map(|s| s / n as f64);
        let steady = (0..3).all(|i| hi[i] - lo[i] <= STEADY_SPREAD_DPS);
        let at_rest = mean.iter().all(|m| m.abs() <= REST_LIMIT_DPS);
        self.current = match (steady, at_rest, self.current) {
            (false, _, _) => Current::Nothing,
            (true, true, Current::Rest) => {
                if let Some(r) = self.snap.rest.as_mut() {
                    r.add(sum, n);
                }
                Current::Rest
            }
            (true, true, _) => {
                self.snap.rest = Some(Stretch::new(sum, n));
                Current::Rest
            }
            (true, false, c) => {
                let same = c == Current::Turn
                    && self.snap.steady_turns.last().is_some_and(|t| {
                        (0..3).all(|i| (t.mean_dps[i] - mean[i]).abs() < SAME_TURN_DPS)
                    });
                match self.snap.steady_turns.last_mut() {
                    Some(t) if same => t.add(sum, n),
                    _ => {
                        self.snap.steady_turns.push(Stretch::new(sum, n));
                        if self.snap.steady_turns.len() > TURNS_KEPT {
                            self.snap.steady_turns.remove(0);
                        }
                    }
                }
                Current::Turn
            }
        };
    }

    /// The view now.
    pub fn snapshot(&self) -> GyroSnapshot {
        let mut snap = self.snap.clone();
        let f = |v: [f64; 3]| {
            format!(
                "yaw {:+.2}, roll {:+.2}, pitch {:+.2} °/s",
                v[0], v[1], v[2]
            )
        };
        let mut line = format!(
            "MotionPlus ({}): {}",
            if snap.calibrated {
                "corrected by the adapter's gyro calibration"
            } else {
                "no gyro calibration committed: raw counts on the nominal scales"
            },
            f(snap.rates_dps)
        );
        if let Some(r) = &snap.rest {
            line.push_str(&format!(
                "; at rest (the bias that remains): {} over {} samples",
                f(r.mean_dps),
                r.samples
            ));
        }
        if let Some(t) = snap.steady_turns.last() {
            line.push_str(&format!("; last steady turn: {}", f(t.mean_dps)));
        }
        snap.line = line;
        snap
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(corrected_dps: [f64; 3]) -> GyroSample {
        GyroSample {
            seq: 0,
            raw: [8192; 3],
            slow: 0b111,
            corrected: Some(corrected_dps.map(|d| d.to_radians() as f32)),
        }
    }

    #[test]
    fn rest_and_steady_turns_are_told_apart_and_averaged() {
        let mut v = GyroView::new(200.0);
        // 1 s at rest with a bias of 0.3 °/s on yaw and ±0.2 °/s of alternating noise, a
        // ramp, 1 s at 90 °/s yaw, a ramp down, 1 s at rest again at 0.1 °/s.
        let noise = |k: usize| if k.is_multiple_of(2) { 0.2 } else { -0.2 };
        for k in 0..200 {
            v.push(&sample([0.3 + noise(k), noise(k), 0.0]));
        }
        for k in 0..50 {
            v.push(&sample([90.0 * k as f64 / 50.0, 0.0, 0.0]));
        }
        for k in 0..200 {
            v.push(&sample([90.0 + noise(k), 0.0, -45.0]));
        }
        for k in 0..50 {
            v.push(&sample([90.0 * (1.0 - k as f64 / 50.0), 0.0, 0.0]));
        }
        for k in 0..200 {
            v.push(&sample([0.1 + noise(k), 0.0, 0.0]));
        }
        let s = v.snapshot();
        assert!(s.calibrated);
        assert_eq!(s.samples, 700);
        // The wire carries f32 rad/s: 90 °/s comes back to within ≈ 1e-5 °/s.
        let tol = 1e-4;
        let rest = s.rest.unwrap();
        assert_eq!(rest.samples, 200);
        assert!((rest.mean_dps[0] - 0.1).abs() < tol, "{rest:?}");
        assert_eq!(s.steady_turns.len(), 1, "{:?}", s.steady_turns);
        let t = s.steady_turns[0];
        assert_eq!(t.samples, 200);
        assert!(
            (t.mean_dps[0] - 90.0).abs() < tol && (t.mean_dps[2] + 45.0).abs() < tol,
            "{t:?}"
        );
        assert!(s.line.contains("at rest"), "{}", s.line);
    }

    #[test]
    fn without_a_calibration_the_counts_are_read_on_the_nominal_scales() {
        let v = GyroView::new(200.0);
        let s = GyroSample {
            seq: 0,
            raw: [8192 + 186, 8192 - 41, 8192 + 4096],
            slow: GyroSample::SLOW_YAW | GyroSample::SLOW_ROLL,
            corrected: None,
        };
        let (r, calibrated) = v.rates_dps(&s);
        assert!(!calibrated);
        // 186 / (8192/440) = 9.99 °/s; −41 → −2.20; 4096 fast / (8192/2000) = 1000 °/s.
        assert!((r[0] - 186.0 * 440.0 / 8192.0).abs() < 1e-3, "{r:?}");
        assert!((r[1] + 41.0 * 440.0 / 8192.0).abs() < 1e-3, "{r:?}");
        assert!((r[2] - 1000.0).abs() < 1e-2, "{r:?}");
    }
}
