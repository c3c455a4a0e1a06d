//! The adapter as a MotionPlus: the gyro rates of a real MotionPlus corrected with the gyro
//! calibration and the zero-rate tracker, re-encoded as an ideal MotionPlus's 14-bit counts
//! with their slow/fast bits, and the Nunchuk's pass-through frames corrected as the adapter
//! corrects a Nunchuk; the register map the Wii Remote reads is
//! [`wiical_extbus::MotionPlusRegisters`].
//!
//! ## Units and axes
//! A MotionPlus report carries per axis (yaw, roll, pitch) a 14-bit count and a range bit.
//! The calibration ([`GyroCorrection`]) applies to **slow-range counts**: a fast-range reading
//! is first mapped onto the slow scale with the real device's calibration block (per axis
//! `m = zero_slow + (raw − zero_fast)·(c_slow / c_fast)`, `c` its counts per °/s; the nominal
//! ratio when its block is unusable), so that one matrix and one bias describe both ranges, as
//! a `gyrofit` of a slow-range capture does. Its output is rad/s **along the MotionPlus's count
//! axes** `[yaw, roll, pitch]`, positive where the counts rise above the zero: that is the
//! frame the re-encoding writes, so a calibration fitted in another frame (the Wii Remote's
//! accelerometer's) is turned into this one before it is installed.
//!
//! ## The ideal MotionPlus
//! Corrected rates are encoded on an [`IdealGyroScale`]: zero 8192, and per range a number of
//! counts per °/s that the emulated calibration block states exactly (default slow 8192/440
//! and fast 8192/2000, the hid-wiimote driver's scales: docs/gyro.md). The range rule, per axis:
//! the slow count `round(8192 + r·c_slow)` is sent with the slow bit when it lies in
//! `0..=16383` (|r| up to about 440 °/s), else the fast count `round(8192 + r·c_fast)`,
//! saturated to `0..=16383`, without it. A reader of the emulated block (or of these nominal
//! scales) therefore gets `r` back to within half a count of the range it was sent in.
//!
//! ## Not applied
//! The g-sensitivity (`G` of [`GyroCorrection::correct`]) needs the accelerometer fixed to the
//! gyro, which is in the Wii Remote and never seen by the adapter: only `K·(m − b)` is applied
//! ([`GyroCorrector::ignores_g_sensitivity`] says when a calibration carries a `G`).

use libm::roundf;
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::gyro_zero::{ZeroRateConfig, ZeroRateTracker};
use wiical_extbus::motionplus::{PassthroughNunchuk, RangeCalibration, MAX_14BIT, NOMINAL_ZERO};
use wiical_extbus::motionplus_registers::Target;
use wiical_extbus::{Checked, Frame, MotionPlusCalibration, MotionPlusRegisters, MotionPlusReport};

use crate::corrector::{CorrectionMode, Corrector};

const DEG_PER_RAD: f32 = 180.0 / core::f32::consts::PI;

/// One range of the ideal scale as its half of the calibration block states it: the reading at
/// `degrees_div_6 · 6` °/s lies `span16` above the zero (16-bit values, 14-bit × 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdealRange {
    /// Reading at the reference rate minus the zero, 16-bit (≤ 32767).
    pub span16: u16,
    /// The reference rate divided by 6, °/s (> 0).
    pub degrees_div_6: u8,
}

impl IdealRange {
    /// 14-bit counts per °/s.
    pub fn counts_per_dps(&self) -> f32 {
        f32::from(self.span16) / 4.0 / (f32::from(self.degrees_div_6) * 6.0)
    }
}

/// The scale corrected rates are sent on; see the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdealGyroScale {
    /// The slow (high-resolution) range.
    pub slow: IdealRange,
    /// The fast range.
    pub fast: IdealRange,
}

impl Default for IdealGyroScale {
    /// 8192/440 counts per °/s slow (6144 counts at 330 °/s) and 8192/2000 fast (3072 at
    /// 750 °/s): both exact in the block's integers.
    fn default() -> Self {
        Self {
            slow: IdealRange {
                span16: 24576,
                degrees_div_6: 55,
            },
            fast: IdealRange {
                span16: 12288,
                degrees_div_6: 125,
            },
        }
    }
}

impl IdealGyroScale {
    /// True when both ranges are representable in a block (span below 2¹⁵, non-zero reference
    /// rate) and the slow range is the finer one.
    pub fn is_valid(&self) -> bool {
        let ok = |r: &IdealRange| r.span16 > 0 && r.span16 <= 0x7FFF && r.degrees_div_6 > 0;
        ok(&self.slow) && ok(&self.fast) && self.slow.counts_per_dps() > self.fast.counts_per_dps()
    }

    /// Encode a rate (°/s along a count axis) as `(count, slow)` by the range rule of the
    /// module docs. NaN encodes as zero rate in the slow range; ±∞ as the fast range's rails.
    pub fn encode(&self, rate_dps: f32) -> (u16, bool) {
        let zero = f32::from(NOMINAL_ZERO);
        let max = f32::from(MAX_14BIT);
        if rate_dps.is_nan() {
            return (NOMINAL_ZERO, true);
        }
        let slow = roundf(zero + rate_dps * self.slow.counts_per_dps());
        if (0.0..=max).contains(&slow) {
            return (slow as u16, true);
        }
        let fast = roundf(zero + rate_dps * self.fast.counts_per_dps());
        (fast.clamp(0.0, max) as u16, false)
    }

    /// The rate (°/s) a reader of this scale computes from a count and its range bit.
    pub fn decode(&self, count: u16, slow: bool) -> f32 {
        let range = if slow { &self.slow } else { &self.fast };
        (f32::from(count) - f32::from(NOMINAL_ZERO)) / range.counts_per_dps()
    }

    /// The calibration block stating this scale: zero 8192 (×4) on every axis, each axis's span
    /// negative where `negative` says (the sign pattern of the real device's block, so that a
    /// reader gets the sign it would from the real device), and the given UID bytes.
    pub fn block(&self, negative: [bool; 3], uid: [u8; 2]) -> MotionPlusCalibration {
        let zero16 = NOMINAL_ZERO * 4;
        let half = |r: &IdealRange| RangeCalibration {
            zero: [zero16; 3],
            scale: negative.map(|n| {
                if n {
                    zero16 - r.span16
                } else {
                    zero16 + r.span16
                }
            }),
            degrees_div_6: r.degrees_div_6,
        };
        MotionPlusCalibration {
            fast: half(&self.fast),
            slow: half(&self.slow),
            uid,
        }
    }
}

/// How a real MotionPlus's fast-range counts map onto its slow scale (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeMap {
    /// Slow-range zero per axis, 14-bit counts.
    pub zero_slow: [f32; 3],
    /// Fast-range zero per axis, 14-bit counts.
    pub zero_fast: [f32; 3],
    /// Slow counts per fast count per axis (c_slow / c_fast; nominally 2000/440).
    pub fast_to_slow: [f32; 3],
}

/// Smallest and largest plausible ratio of the slow to the fast sensitivity: the sources give
/// 2000/440 ≈ 4.5 (hid-wiimote, WiiBrew) and 1200/270 ≈ 4.4 (Dolphin's block).
const RATIO_RANGE: core::ops::RangeInclusive<f32> = 2.0..=10.0;

impl RangeMap {
    /// The nominal map of a scale: zero 8192 in both ranges, the scale's ratio.
    pub fn nominal(scale: &IdealGyroScale) -> Self {
        let z = f32::from(NOMINAL_ZERO);
        Self {
            zero_slow: [z; 3],
            zero_fast: [z; 3],
            fast_to_slow: [scale.slow.counts_per_dps() / scale.fast.counts_per_dps(); 3],
        }
    }

    /// The map a device's block states; `None` when its CRC fails, a range is degenerate, or
    /// an axis's two sensitivities differ in sign or in ratio beyond 2–10.
    pub fn from_block(block: &Checked<MotionPlusCalibration>) -> Option<Self> {
        if !block.checksum_ok {
            return None;
        }
        let b = &block.value;
        let (slow, fast) = (b.slow.counts_per_dps()?, b.fast.counts_per_dps()?);
        let ratio: [f32; 3] = core::array::from_fn(|i| slow[i] / fast[i]);
        if !ratio.iter().all(|r| RATIO_RANGE.contains(r)) {
            return None;
        }
        Some(Self {
            zero_slow: b.slow.zero_14bit(),
            zero_fast: b.fast.zero_14bit(),
            fast_to_slow: ratio,
        })
    }

    /// A report's rates as slow-range counts.
    pub fn slow_counts(&self, r: &MotionPlusReport) -> [f32; 3] {
        core::array::from_fn(|i| {
            let raw = f32::from(r.rate[i]);
            if r.slow[i] {
                raw
            } else {
                self.zero_slow[i] + (raw - self.zero_fast[i]) * self.fast_to_slow[i]
            }
        })
    }
}

/// Settings of the zero-rate tracking on the adapter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tracking {
    /// The core tracker's blocks, spread (slow-range counts) and blend.
    pub config: ZeroRateConfig<f32>,
    /// Largest corrected rate, rad/s, on any axis at which a sample may count as still: the
    /// adapter does not see the Wii Remote's accelerometer, so this gate is what keeps a slow
    /// steady turn from being taken for a bias (the core tracker itself only tests the spread).
    pub rest_limit: f32,
}

impl Default for Tracking {
    /// Blocks of 100 samples (0.5 s at the adapter's 200 Hz), spread ≤ 16 slow counts
    /// (≈ 0.9 °/s), blend 0.5, still only below 10 °/s. Not measured on a MotionPlus (no
    /// recording of one is in the data): starting values for a board.
    fn default() -> Self {
        Self {
            config: ZeroRateConfig {
                block: 100,
                max_spread: 16.0,
                blend: 0.5,
            },
            rest_limit: 10.0 / DEG_PER_RAD,
        }
    }
}

/// One corrected MotionPlus report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroCorrected {
    /// Corrected rates, rad/s along the count axes; `None` in pass-through.
    pub rate: Option<[f32; 3]>,
    /// The report to present (the real one unchanged in pass-through).
    pub report: MotionPlusReport,
}

/// Corrects a real MotionPlus's reports; see the module docs.
#[derive(Debug, Clone)]
pub struct GyroCorrector {
    scale: IdealGyroScale,
    input: RangeMap,
    device_block: Option<[u8; 32]>,
    negative: [bool; 3],
    uid: [u8; 2],
    calibration: Option<GyroCorrection<f32>>,
    tracking: Option<Tracking>,
    tracker: Option<ZeroRateTracker<f32>>,
}

impl Default for GyroCorrector {
    fn default() -> Self {
        Self::new(IdealGyroScale::default(), Some(Tracking::default()))
    }
}

/// The sign pattern of Dolphin's emulated block, which it says matches a real MotionPlus:
/// yaw and pitch spans negative.
const DOCUMENTED_NEGATIVE: [bool; 3] = [true, false, true];

impl GyroCorrector {
    /// A corrector in pass-through with the nominal range map. An invalid scale is replaced by
    /// the default one; invalid tracking settings turn tracking off.
    pub fn new(scale: IdealGyroScale, tracking: Option<Tracking>) -> Self {
        let scale = if scale.is_valid() {
            scale
        } else {
            IdealGyroScale::default()
        };
        let tracking = tracking
            .filter(|t| ZeroRateTracker::new(t.config, [0.0; 3]).is_ok() && t.rest_limit > 0.0);
        Self {
            scale,
            input: RangeMap::nominal(&scale),
            device_block: None,
            negative: DOCUMENTED_NEGATIVE,
            uid: [0; 2],
            calibration: None,
            tracking,
            tracker: None,
        }
    }

    /// The ideal scale.
    pub fn scale(&self) -> IdealGyroScale {
        self.scale
    }

    /// The range map in use (the device block's when it was usable, else nominal).
    pub fn range_map(&self) -> RangeMap {
        self.input
    }

    /// Take the real MotionPlus's calibration block: replayed in pass-through, its range map
    /// used when usable (else the nominal one), its sign pattern and UID kept in the ideal block.
    pub fn set_device_block(&mut self, bytes: &[u8; 32]) {
        self.device_block = Some(*bytes);
        let block = MotionPlusCalibration::from_bytes(bytes);
        match RangeMap::from_block(&block) {
            Some(map) => {
                self.input = map;
                let s = block.value.slow;
                self.negative = core::array::from_fn(|i| s.scale[i] < s.zero[i]);
                self.uid = block.value.uid;
            }
            None => {
                self.input = RangeMap::nominal(&self.scale);
                self.negative = DOCUMENTED_NEGATIVE;
                self.uid = [0; 2];
            }
        }
    }

    /// Install (or with `None` remove) the gyro calibration, in the units of the module docs.
    /// One that fails [`GyroCorrection::validate`] is refused and the previous state kept. The
    /// tracker restarts from its bias.
    pub fn set_calibration(
        &mut self,
        calibration: Option<GyroCorrection<f32>>,
    ) -> Result<(), wiical_core::Error> {
        if let Some(c) = &calibration {
            c.validate()?;
        }
        self.calibration = calibration;
        self.tracker = match (&self.calibration, &self.tracking) {
            (Some(c), Some(t)) => ZeroRateTracker::new(t.config, c.bias).ok(),
            _ => None,
        };
        Ok(())
    }

    /// The calibration in use, its bias as the tracker last left it.
    pub fn calibration(&self) -> Option<&GyroCorrection<f32>> {
        self.calibration.as_ref()
    }

    /// True when the installed calibration has a g-sensitivity, which is not applied.
    pub fn ignores_g_sensitivity(&self) -> bool {
        self.calibration
            .is_some_and(|c| c.effects.needs_specific_force())
    }

    /// Calibrated or pass-through.
    pub fn mode(&self) -> CorrectionMode {
        if self.calibration.is_some() {
            CorrectionMode::Calibrated
        } else {
            CorrectionMode::PassThrough
        }
    }

    /// How many still blocks have moved the bias since the calibration was installed.
    pub fn bias_updates(&self) -> u32 {
        self.tracker.as_ref().map_or(0, ZeroRateTracker::updates)
    }

    /// The 32 bytes the emulated map holds at `0x20`: the ideal block when calibrated; in
    /// pass-through the device's own (or the ideal one before any device was seen).
    pub fn calibration_block_bytes(&self) -> [u8; 32] {
        match (self.mode(), self.device_block) {
            (CorrectionMode::PassThrough, Some(b)) => b,
            _ => self.scale.block(self.negative, self.uid).to_bytes(),
        }
    }

    /// Correct one report. `still_hint` is the caller's own stillness evidence (`true` when it
    /// has none); a sample counts as still for the tracker only when also every corrected rate
    /// is within [`Tracking::rest_limit`].
    pub fn correct(&mut self, report: &MotionPlusReport, still_hint: bool) -> GyroCorrected {
        let Some(cal) = self.calibration.as_mut() else {
            return GyroCorrected {
                rate: None,
                report: *report,
            };
        };
        let m = self.input.slow_counts(report);
        let mut w = cal.correct_linear(m);
        if let (Some(tracker), Some(t)) = (self.tracker.as_mut(), &self.tracking) {
            let hint = still_hint && w.iter().all(|x| x.abs() <= t.rest_limit);
            if let Ok(Some(bias)) = tracker.push(m, hint) {
                cal.bias = bias;
                w = cal.correct_linear(m);
            }
        }
        let mut out = MotionPlusReport {
            extension_connected: report.extension_connected,
            ..MotionPlusReport::default()
        };
        for (i, wi) in w.iter().enumerate() {
            (out.rate[i], out.slow[i]) = self.scale.encode(wi * DEG_PER_RAD);
        }
        GyroCorrected {
            rate: Some(w),
            report: out,
        }
    }
}

/// A Nunchuk's pass-through frame corrected as [`Corrector::correct`] corrects a Nunchuk, the
/// corrected counts rounded to the nearest **even** count (the pass-through layout drops bit 0,
/// so rounding to even is what keeps the result within one count; truncating the odd ones would
/// bias every axis by half a count). In pass-through the frame is unchanged. The frame's raw
/// values have bit 0 clear (the real MotionPlus dropped it) and are corrected as they are.
pub fn passthrough_nunchuk(
    corrector: &Corrector,
    frame: &PassthroughNunchuk,
) -> PassthroughNunchuk {
    if corrector.mode() == CorrectionMode::PassThrough {
        return *frame;
    }
    let c = corrector.correct(frame.report.accel);
    let mut out = *frame;
    out.report.accel = c.g.map(|g| corrector.scale().encode_even(g));
    out
}

/// The emulated MotionPlus: the register map the Wii Remote reads, fed with corrected frames.
/// As with the emulated Nunchuk, the firmware serves a whole read transaction at once and feeds
/// frames between transactions.
#[derive(Debug, Clone)]
pub struct EmulatedMotionPlus {
    regs: MotionPlusRegisters,
    gyro: GyroCorrector,
}

impl EmulatedMotionPlus {
    /// An inactive MotionPlus presenting `gyro`'s calibration block.
    pub fn new(gyro: GyroCorrector) -> Self {
        let mut regs = MotionPlusRegisters::new();
        regs.set_calibration_bytes(&gyro.calibration_block_bytes());
        Self { regs, gyro }
    }

    /// Write transaction from the Wii Remote to `address`; the answer says who handles it
    /// ([`Target::Extension`] and [`Target::MotionPlusThenExtension`]: the caller forwards the
    /// write to the extension's emulation).
    pub fn on_write(&mut self, address: u8, bytes: &[u8]) -> Target {
        self.regs.write(address, bytes)
    }

    /// Read transaction from the Wii Remote at `address` (`buf` untouched unless the answer is
    /// [`Target::MotionPlus`]).
    pub fn on_read(&mut self, address: u8, buf: &mut [u8]) -> Target {
        self.regs.read(address, buf)
    }

    /// A frame polled from the real MotionPlus: its gyro report corrected (returned), or the
    /// extension's frame corrected with `nunchuk`. A gyro report's extension-connected flag is
    /// passed on; saying no extension is plugged in, it withdraws the extension's frame.
    pub fn on_frame(
        &mut self,
        frame: &Frame,
        nunchuk: &Corrector,
        still_hint: bool,
    ) -> Option<GyroCorrected> {
        match frame {
            Frame::MotionPlus(r) => {
                let c = self.gyro.correct(r, still_hint);
                if let Ok(bytes) = c.report.to_bytes() {
                    self.regs.set_gyro_bytes(&bytes);
                }
                self.regs.set_extension_connected(r.extension_connected);
                Some(c)
            }
            Frame::Nunchuk(p) => {
                let q = passthrough_nunchuk(nunchuk, p);
                self.regs.set_extension_bytes(Some(&q.to_bytes()));
                None
            }
            Frame::Classic(c) => {
                self.regs
                    .set_extension_bytes(Some(&classic_passthrough_bytes(c)));
                None
            }
        }
    }

    /// A (re)connected real MotionPlus: its block installed as [`Self::set_device_block`]
    /// does, and the register map back to a freshly powered MotionPlus's (inactive, pointer
    /// 0, no frame yet); the corrector's calibration and tracker are kept.
    pub fn restart(&mut self, device_block: &[u8; 32]) {
        self.regs = MotionPlusRegisters::new();
        self.set_device_block(device_block);
    }

    /// Install the real device's block ([`GyroCorrector::set_device_block`]) and present the
    /// block that goes with it.
    pub fn set_device_block(&mut self, bytes: &[u8; 32]) {
        self.gyro.set_device_block(bytes);
        self.regs
            .set_calibration_bytes(&self.gyro.calibration_block_bytes());
    }

    /// Install the gyro calibration ([`GyroCorrector::set_calibration`]) and present the block
    /// that goes with it.
    pub fn set_calibration(
        &mut self,
        calibration: Option<GyroCorrection<f32>>,
    ) -> Result<(), wiical_core::Error> {
        self.gyro.set_calibration(calibration)?;
        self.regs
            .set_calibration_bytes(&self.gyro.calibration_block_bytes());
        Ok(())
    }

    /// The gyro corrector.
    pub fn gyro(&self) -> &GyroCorrector {
        &self.gyro
    }

    /// The register state machine (for inspection and tests).
    pub fn registers(&self) -> &MotionPlusRegisters {
        &self.regs
    }
}

/// A Classic Controller frame (as [`Frame::Classic`] gives it, the MotionPlus's bit moves
/// undone) laid out again as the MotionPlus passes it through: byte 5 bits 0 and 1 moved to
/// bit 0 of bytes 0 and 1 (byte 4 bit 0 and byte 5 bits 1–0 are the register map's).
pub fn classic_passthrough_bytes(c: &[u8; 6]) -> [u8; 6] {
    let mut b = *c;
    b[0] = (c[0] & !1) | (c[5] & 1);
    b[1] = (c[1] & !1) | ((c[5] >> 1) & 1);
    b[5] = c[5] & !0b11;
    b
}
