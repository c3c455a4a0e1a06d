//! Applying the live calibration to the Nunchuk's accelerometer, and re-encoding the result
//! so that an unmodified Wii Remote sees corrected acceleration.
//!
//! The Wii Remote converts a Nunchuk sample to g with the extension's own calibration block:
//! `g = (raw − zero) / (one_g − zero)` per axis. The adapter therefore
//! 1. corrects the raw 10-bit counts with the user calibration, `a = K·(m − b)` (in g), and
//! 2. re-encodes `a` on an **ideal scale** — `counts = zero + a·counts_per_g`, rounded and
//!    saturated to 0..=1023 — while the emulated register map holds the ideal block
//!    (`zero`, `zero + counts_per_g`, valid checksums). The Wii Remote's own conversion then
//!    yields `a` back, to within the 1-count quantisation (5 mg at 200 counts/g).
//!
//! Without a usable user calibration the adapter is transparent (**pass-through**): raw
//! counts go out unchanged with the Nunchuk's own calibration block, and the reported
//! "live" calibration is the one equivalent to that block, so that the corrected values
//! streamed to the host are what the Wii Remote computes.

use libm::roundf;
use wiical_core::{Calibration, PreparedCalibration};
use wiical_extbus::nunchuk::StickAxisCalibration;
use wiical_extbus::CalibrationBlock;

use crate::poller::NunchukInfo;

/// The ideal scale corrected samples are re-encoded on (10-bit counts).
///
/// The defaults, zero = 512 and one-g = 712, have their two low bits clear, so the emulated
/// calibration block reads the same whichever order a reader assumes for the packed low bits
/// of a Nunchuk block, and 8-bit readers see exactly 128 and 178.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdealScale {
    /// Count for 0 g.
    pub zero: u16,
    /// Counts per g (one-g count = `zero + counts_per_g`).
    pub counts_per_g: u16,
}

impl Default for IdealScale {
    fn default() -> Self {
        Self {
            zero: 512,
            counts_per_g: 200,
        }
    }
}

/// Joystick calibration used in the ideal block when the Nunchuk's own block is unusable:
/// the typical range of a genuine stick (WiiBrew).
pub const DEFAULT_STICK: StickAxisCalibration = StickAxisCalibration {
    max: 0xE0,
    min: 0x20,
    centre: 0x80,
};

impl IdealScale {
    /// Encode an acceleration (g) as a 10-bit count: `zero + g·counts_per_g`, rounded to
    /// nearest and saturated to 0..=1023. NaN (an undefined result) encodes as `zero`
    /// (0 g), ±∞ as the rails.
    #[inline]
    pub fn encode(&self, g: f32) -> u16 {
        if g.is_nan() {
            return self.zero.min(1023);
        }
        let c = roundf(f32::from(self.zero) + g * f32::from(self.counts_per_g));
        // `as` saturates (and the NaN case is excluded above); clamp to the 10-bit range.
        (c.clamp(0.0, 1023.0)) as u16
    }

    /// Encode on the even counts only, `2·round((zero + g·counts_per_g)/2)` saturated to
    /// 0..=1022: for a layout that drops bit 0 (a Nunchuk passed through a MotionPlus), the
    /// nearest count it can carry. NaN encodes as `zero` with bit 0 cleared.
    pub fn encode_even(&self, g: f32) -> u16 {
        if g.is_nan() {
            return self.zero.min(1023) & !1;
        }
        let c = roundf((f32::from(self.zero) + g * f32::from(self.counts_per_g)) / 2.0) * 2.0;
        (c.clamp(0.0, 1022.0)) as u16
    }

    /// The acceleration (g) an ideal-block reader computes from a count.
    pub fn decode(&self, count: u16) -> f32 {
        (f32::from(count) - f32::from(self.zero)) / f32::from(self.counts_per_g.max(1))
    }

    /// The calibration block describing this scale, with the given stick calibration.
    /// `None` if the scale does not fit 10 bits.
    pub fn block(
        &self,
        stick_x: StickAxisCalibration,
        stick_y: StickAxisCalibration,
    ) -> Option<CalibrationBlock> {
        let one_g = self.zero.checked_add(self.counts_per_g)?;
        if one_g > 1023 || self.counts_per_g == 0 {
            return None;
        }
        Some(CalibrationBlock {
            zero: [self.zero; 3],
            one_g: [one_g; 3],
            stick_x,
            stick_y,
        })
    }
}

/// Whether a user calibration is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CorrectionMode {
    /// A valid user calibration is live: corrected data on the ideal scale.
    Calibrated,
    /// No (usable) user calibration: raw data and the Nunchuk's own block pass through.
    PassThrough,
}

/// One corrected sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corrected {
    /// Acceleration in g from the live calibration (see [`Corrector::live_calibration`]).
    pub g: [f32; 3],
    /// Counts to present to the Wii Remote: on the ideal scale when calibrated, the raw
    /// counts unchanged in pass-through.
    pub counts: [u16; 3],
}

/// The nominal calibration used when neither a user calibration nor a valid factory block
/// is available: zero 512, 200 counts per g on every axis (a typical Nunchuk).
pub fn nominal_calibration() -> Calibration {
    let k = 1.0 / 200.0;
    Calibration {
        bias: [512.0; 3],
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
        effects: Default::default(),
    }
}

/// The calibration equivalent to a factory block: `b = zero`, `K = diag(1/(one_g − zero))`.
/// `None` if an axis has `one_g == zero` (the block is then unusable).
pub fn factory_calibration(block: &CalibrationBlock) -> Option<Calibration> {
    let span = block.counts_per_g();
    if span.contains(&0) {
        return None;
    }
    let k = span.map(|s| 1.0 / s as f32);
    let cal = Calibration {
        bias: block.zero.map(f32::from),
        matrix: [[k[0], 0.0, 0.0], [0.0, k[1], 0.0], [0.0, 0.0, k[2]]],
        effects: Default::default(),
    };
    cal.validate().ok().map(|_| cal)
}

/// Applies the live calibration; see the module docs.
#[derive(Debug, Clone)]
pub struct Corrector {
    scale: IdealScale,
    /// The user calibration, its effect terms found once at install rather than per sample.
    user: Option<PreparedCalibration>,
    /// Calibration equivalent to the Nunchuk's own block (or nominal).
    factory: Calibration,
    factory_bytes: Option<[u8; 16]>,
    stick: (StickAxisCalibration, StickAxisCalibration),
    ideal_bytes: [u8; 16],
    /// The sensor's temperature, °C, when the board measures one (the MCU's on-chip sensor,
    /// next to the Nunchuk's cable): feeds the calibration's temperature terms.
    temperature_c: Option<f32>,
}

impl Default for Corrector {
    fn default() -> Self {
        Self::new(IdealScale::default())
    }
}

impl Corrector {
    /// A corrector in pass-through mode with the nominal calibration. A scale that does not
    /// fit 10 bits is replaced by the default one.
    pub fn new(scale: IdealScale) -> Self {
        let scale = if scale.block(DEFAULT_STICK, DEFAULT_STICK).is_some() {
            scale
        } else {
            IdealScale::default()
        };
        let mut c = Self {
            scale,
            user: None,
            factory: nominal_calibration(),
            factory_bytes: None,
            stick: (DEFAULT_STICK, DEFAULT_STICK),
            ideal_bytes: [0; 16],
            temperature_c: None,
        };
        c.refresh_ideal_bytes();
        c
    }

    fn refresh_ideal_bytes(&mut self) {
        let block = self
            .scale
            .block(self.stick.0, self.stick.1)
            .or_else(|| IdealScale::default().block(DEFAULT_STICK, DEFAULT_STICK));
        if let Some(bytes) = block.and_then(|b| b.encode().ok()) {
            self.ideal_bytes = bytes;
        }
    }

    /// The temperature (°C) the calibration's temperature terms use from now on; `None` (no
    /// reading, or a non-finite one) leaves them out.
    pub fn set_temperature(&mut self, temperature_c: Option<f32>) {
        self.temperature_c = temperature_c.filter(|t| t.is_finite());
    }

    /// The temperature the corrector uses, °C.
    pub fn temperature(&self) -> Option<f32> {
        self.temperature_c
    }

    /// The ideal scale.
    pub fn scale(&self) -> IdealScale {
        self.scale
    }

    /// Install (or with `None` remove) the user calibration. A calibration that fails
    /// [`Calibration::validate`] is refused and the previous state kept.
    pub fn set_user_calibration(
        &mut self,
        cal: Option<Calibration>,
    ) -> Result<(), wiical_core::Error> {
        if let Some(c) = &cal {
            c.validate()?;
        }
        self.user = cal.map(PreparedCalibration::new);
        Ok(())
    }

    /// The user calibration, if one is live.
    pub fn user_calibration(&self) -> Option<&Calibration> {
        self.user.as_ref().map(PreparedCalibration::calibration)
    }

    /// Take the factory data of a (re)connected Nunchuk: its block is replayed in
    /// pass-through mode, and its stick calibration is kept in the ideal block.
    pub fn set_factory(&mut self, info: &NunchukInfo) {
        self.factory_bytes = Some(info.calibration_bytes);
        let (factory, stick) = match &info.calibration {
            Some((block, _)) => (
                factory_calibration(block).unwrap_or_else(nominal_calibration),
                (block.stick_x, block.stick_y),
            ),
            None => (nominal_calibration(), (DEFAULT_STICK, DEFAULT_STICK)),
        };
        self.factory = factory;
        self.stick = stick;
        self.refresh_ideal_bytes();
    }

    /// Calibrated or pass-through.
    pub fn mode(&self) -> CorrectionMode {
        if self.user.is_some() {
            CorrectionMode::Calibrated
        } else {
            CorrectionMode::PassThrough
        }
    }

    /// The calibration that produces [`Corrected::g`]: the user calibration, else the one
    /// equivalent to the Nunchuk's factory block, else [`nominal_calibration`].
    pub fn live_calibration(&self) -> Calibration {
        self.user.map_or(self.factory, |p| *p.calibration())
    }

    /// The 16 bytes the emulated register map must hold at `0x20` and `0x30`: the ideal
    /// block when calibrated; in pass-through the Nunchuk's own bytes (or, before any
    /// Nunchuk was seen, the ideal block, which then matches nothing better).
    pub fn calibration_block_bytes(&self) -> [u8; 16] {
        match (self.mode(), self.factory_bytes) {
            (CorrectionMode::PassThrough, Some(b)) => b,
            _ => self.ideal_bytes,
        }
    }

    /// Correct one raw sample (10-bit counts).
    ///
    /// With a user calibration whose effect terms are all zero, `g` is exactly
    /// [`Calibration::correct_linear`]; otherwise the terms that depend on the acceleration
    /// alone are applied too — the per-axis nonlinearity and the orientation-dependent cross
    /// terms —, and the temperature terms when [`Corrector::set_temperature`] gave a reading
    /// (time drift terms are not: the adapter has no recording's time origin).
    #[inline]
    pub fn correct(&self, raw: [u16; 3]) -> Corrected {
        let m = raw.map(f32::from);
        match &self.user {
            Some(cal) => {
                let g = if cal.terms().linear_only {
                    cal.correct_linear(m)
                } else {
                    correct_at_temperature(cal, raw, self.temperature_c)
                };
                Corrected {
                    g,
                    counts: g.map(|x| self.scale.encode(x)),
                }
            }
            None => Corrected {
                g: self.factory.correct_linear(m),
                counts: raw.map(|c| c.min(1023)),
            },
        }
    }
}

/// [`PreparedCalibration::correct`] with no clock and the board's temperature, if any (the
/// adapter's case). Out of line, taking the raw counts (passed in registers) rather than the converted sample, so
/// that the linear path of [`Corrector::correct`] does not spill the sample for it (on a
/// Cortex-M33 under QEMU, a linear calibration's report update: 205 instructions and 84 B of
/// stack rather than 209 and 108 B).
#[inline(never)]
fn correct_at_temperature(
    cal: &PreparedCalibration,
    raw: [u16; 3],
    temperature_c: Option<f32>,
) -> [f32; 3] {
    let at = wiical_core::Conditions {
        temperature_c,
        ..Default::default()
    };
    cal.correct(raw.map(f32::from), &at)
}
