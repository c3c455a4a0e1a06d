//! The simulated MotionPlus (`--extension motionplus`): a real MotionPlus alone on the
//! adapter's extension bus, with a known truth, turned by a known program.
//!
//! The device is `wiical-extbus`'s MotionPlus register state machine (found at `0x53` while
//! inactive, at `0x52` once the adapter's poller activated it, its 32-byte block at `0x20`),
//! so the adapter's own `MotionPlusPoller` finds, activates and polls it as on the board.
//!
//! ## Truth
//! Along each count axis `[yaw, roll, pitch]` (the frame the adapter corrects in) the
//! slow-range count is `m = GYRO_TRUE_BIAS + GYRO_TRUE_CPD·ω + noise` (`ω` in °/s, noise
//! [`GYRO_NOISE_COUNTS`] per sample), so the calibration that corrects it exactly is
//! [`true_gyro_calibration`]: bias [`GYRO_TRUE_BIAS`], matrix `diag(π/180 / GYRO_TRUE_CPD)`.
//! Above [`GYRO_SLOW_LIMIT_DPS`] an axis reports in the fast range: the fast count is the
//! one the device's block maps back onto `m` (`m = zero_slow + (raw − zero_fast)·c_slow/c_fast`,
//! the adapter's `RangeMap`), so the adapter's range mapping is exact up to rounding. The
//! block's slow zeros are not the true bias (a factory block is a few counts off).
//!
//! ## Motion ([`gyro_rate_dps`])
//! A program of [`GYRO_PERIOD_S`] repeated from the first poll: at rest, then a steady turn
//! of [`GYRO_TURN_SLOW_DPS`] (yaw and pitch, both in the slow range), at rest, then a steady
//! turn of [`GYRO_TURN_FAST_DPS`] (roll, in the fast range), at rest. Each turn ramps up and
//! down linearly in [`GYRO_RAMP_S`].

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_extbus::motionplus::RangeCalibration;
use wiical_extbus::motionplus_registers::Target;
use wiical_extbus::{MotionPlusCalibration, MotionPlusRegisters, MotionPlusReport};
use wiical_wire::WireGyroCalibration;

/// True slow-range counts per °/s along `[yaw, roll, pitch]` (not the nominal 8192/440 =
/// 18.6: the calibration must find these).
pub const GYRO_TRUE_CPD: [f64; 3] = [19.7, 18.1, 20.4];
/// True zero-rate slow-range counts `[yaw, roll, pitch]`.
pub const GYRO_TRUE_BIAS: [f64; 3] = [8233.0, 8135.0, 8215.0];
/// Gyro noise per sample, slow-range counts (1 count ≈ 0.05 °/s).
pub const GYRO_NOISE_COUNTS: f64 = 1.0;
/// Above this rate (°/s, magnitude) an axis reports in the fast range.
pub const GYRO_SLOW_LIMIT_DPS: f64 = 400.0;
/// Length of the motion program, s.
pub const GYRO_PERIOD_S: f64 = 12.0;
/// The slow steady turn `[yaw, roll, pitch]`, °/s, from 4 s to 6 s of each period.
pub const GYRO_TURN_SLOW_DPS: [f64; 3] = [90.0, 0.0, -45.0];
/// The fast steady turn `[yaw, roll, pitch]`, °/s, from 8 s to 9.5 s of each period.
pub const GYRO_TURN_FAST_DPS: [f64; 3] = [0.0, -600.0, 0.0];
/// Ramp time at both ends of each turn, s.
pub const GYRO_RAMP_S: f64 = 0.2;

/// The device's block: slow zeros a few counts off the true bias, fast zeros 10 counts off
/// 8192, slow spans at 270 °/s with the true sensitivities, fast spans at 1200 °/s with a ratio
/// of 4.55 (about 2000/440); yaw and pitch stored negative as a real block stores them (the
/// counts still rise with the rate: the adapter takes the ratio, not the sign).
pub fn device_block() -> MotionPlusCalibration {
    let slow_zero = [8236.0, 8131.0, 8219.0];
    let fast_zero = [8202.0; 3];
    let sign = [-1.0, 1.0, -1.0];
    let range = |zero: [f64; 3], cpd: [f64; 3], deg: f64| RangeCalibration {
        zero: zero.map(|z| (z * 4.0).round() as u16),
        scale: core::array::from_fn(|i| ((zero[i] + sign[i] * cpd[i] * deg) * 4.0).round() as u16),
        degrees_div_6: (deg / 6.0) as u8,
    };
    MotionPlusCalibration {
        fast: range(fast_zero, GYRO_TRUE_CPD.map(|c| c / 4.55), 1200.0),
        slow: range(slow_zero, GYRO_TRUE_CPD, 270.0),
        uid: [0x5A, 0xC3],
    }
}

/// The gyro calibration that corrects the simulated MotionPlus exactly (slow-range counts →
/// rad/s along the count axes), as `wiical device put` would upload it.
pub fn true_gyro_calibration() -> WireGyroCalibration {
    let k = GYRO_TRUE_CPD.map(|c| (1f64.to_radians() / c) as f32);
    WireGyroCalibration {
        bias: GYRO_TRUE_BIAS.map(|b| b as f32),
        matrix: [[k[0], 0.0, 0.0], [0.0, k[1], 0.0], [0.0, 0.0, k[2]]],
    }
}

/// The true rate `[yaw, roll, pitch]` (°/s) at `t` s of the motion program.
pub fn gyro_rate_dps(t: f64) -> [f64; 3] {
    let u = t.rem_euclid(GYRO_PERIOD_S);
    let plateau = |start: f64, end: f64| -> f64 {
        let up = ((u - start) / GYRO_RAMP_S).clamp(0.0, 1.0);
        let down = ((end - u) / GYRO_RAMP_S).clamp(0.0, 1.0);
        up.min(down)
    };
    let (slow, fast) = (plateau(4.0, 6.0), plateau(8.0, 9.5));
    core::array::from_fn(|i| slow * GYRO_TURN_SLOW_DPS[i] + fast * GYRO_TURN_FAST_DPS[i])
}

/// The simulated MotionPlus: its register map and its sensor.
pub struct SimMotionPlus {
    regs: MotionPlusRegisters,
    rng: ChaCha8Rng,
    noise: Normal<f64>,
}

impl SimMotionPlus {
    /// A freshly powered (inactive) MotionPlus with the [`device_block`].
    pub fn new(seed: u64) -> Self {
        Self {
            regs: fresh(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            noise: Normal::new(0.0, GYRO_NOISE_COUNTS).unwrap_or_else(|_| unreachable!()),
        }
    }

    /// Unplugged and plugged again: inactive, as after power-up.
    pub fn power_up(&mut self) {
        self.regs = fresh();
    }

    /// The report at time `t` of the motion program (see the module docs).
    pub fn report(&mut self, t: f64) -> MotionPlusReport {
        let rate = gyro_rate_dps(t);
        let block = device_block();
        let (zs, zf) = (block.slow.zero_14bit(), block.fast.zero_14bit());
        let mut r = MotionPlusReport::default();
        for i in 0..3 {
            let m =
                GYRO_TRUE_BIAS[i] + GYRO_TRUE_CPD[i] * rate[i] + self.noise.sample(&mut self.rng);
            let slow = rate[i].abs() < GYRO_SLOW_LIMIT_DPS;
            let count = if slow {
                m
            } else {
                f64::from(zf[i]) + (m - f64::from(zs[i])) / 4.55
            };
            r.rate[i] = count.round().clamp(0.0, 16383.0) as u16;
            r.slow[i] = slow;
        }
        r
    }

    /// Sets the report the adapter reads next.
    pub fn set_report(&mut self, r: &MotionPlusReport) {
        if let Ok(bytes) = r.to_bytes() {
            self.regs.set_gyro_bytes(&bytes);
        }
    }

    /// One bus transaction at `address`: `false` (NAK) where the device does not answer.
    pub fn transaction(
        &mut self,
        address: u8,
        operations: &mut [embedded_hal_async::i2c::Operation<'_>],
    ) -> bool {
        use embedded_hal_async::i2c::Operation;
        if self.regs.target(address) != Target::MotionPlus {
            return false;
        }
        for op in operations {
            match op {
                Operation::Write(b) => {
                    self.regs.write(address, b);
                }
                Operation::Read(b) => {
                    self.regs.read(address, b);
                }
            }
        }
        true
    }
}

fn fresh() -> MotionPlusRegisters {
    let mut regs = MotionPlusRegisters::new();
    regs.set_calibration_bytes(&device_block().to_bytes());
    regs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fast_range_maps_back_onto_the_slow_counts_with_the_block() {
        // The adapter's map, f32, from the block the device presents.
        let block = MotionPlusCalibration::from_bytes(&device_block().to_bytes());
        assert!(block.checksum_ok);
        let b = block.value;
        let (cs, cf) = (
            b.slow.counts_per_dps().unwrap(),
            b.fast.counts_per_dps().unwrap(),
        );
        let mut sim = SimMotionPlus::new(3);
        // 8.75 s: the middle of the fast roll turn.
        let r = sim.report(8.75);
        assert_eq!(r.slow, [true, false, true]);
        let slow_roll = f64::from(b.slow.zero_14bit()[1])
            + (f64::from(r.rate[1]) - f64::from(b.fast.zero_14bit()[1])) * f64::from(cs[1] / cf[1]);
        let want = GYRO_TRUE_BIAS[1] + GYRO_TRUE_CPD[1] * -600.0;
        // Rounding of the fast count (±0.5 × 4.55) and the noise (1 count, 5 σ).
        assert!(
            (slow_roll - want).abs() < 2.3 + 5.0,
            "{slow_roll} vs {want}"
        );
        // Yaw and pitch at rest.
        assert!((f64::from(r.rate[0]) - GYRO_TRUE_BIAS[0]).abs() < 5.0);
    }

    #[test]
    fn the_program_rests_turns_and_ramps() {
        assert_eq!(gyro_rate_dps(1.0), [0.0; 3]);
        assert_eq!(gyro_rate_dps(5.0), GYRO_TURN_SLOW_DPS);
        assert_eq!(gyro_rate_dps(8.75), GYRO_TURN_FAST_DPS);
        assert_eq!(gyro_rate_dps(12.0 + 5.0), GYRO_TURN_SLOW_DPS);
        let ramp = gyro_rate_dps(4.1);
        assert!((ramp[0] - 45.0).abs() < 1e-9, "{ramp:?}");
    }
}
