//! Offset-only calibration of an accelerometer and a gyroscope (seed: *AHRS Sensor
//! Calibration*), the quick calibration that assumes the scale factors are right and only
//! the zero point is wrong.
//!
//! * **Accelerometer**: hold the sensor still with one axis along the local vertical,
//!   average many samples, then the vertical axis reads `±1 g` plus its offset while the two
//!   horizontal axes read their offset alone. The vertical axis is the one whose mean (minus
//!   the nominal zero-g level) has the largest magnitude, and that magnitude must be at least
//!   0.9 g (the seed's test, `> acc_1G_FS · 0.9`), otherwise no axis is vertical enough and
//!   [`Error::NoVerticalAxis`] is returned. Its offset is the mean minus `+1 g` if the axis
//!   points up and minus `−1 g` if it points down (an accelerometer measures the specific
//!   force, so a still axis pointing **up** reads **+1 g**, the crate-wide convention).
//! * **Gyroscope**: at rest the true rate is zero (Earth's rotation, 15 °/h, is far below
//!   a consumer gyro's noise), so the offset is the mean.
//!
//! The seed averages 256 samples with integer sums; here the mean comes from
//! [`Welford3`], in `f32` without loss on 16-bit counts.
//!
//! Samples are raw sensor units. Sensors with an unsigned ADC (the Wiimote's 8/10-bit
//! counts, an Xsens MTi's 16-bit counts around 32 768) put zero acceleration near mid-scale,
//! so the vertical-axis test needs the nominal zero-g reading, [`AccelOffsetConfig::zero_g`]
//! (0 for signed sensors such as the MPU-9250 of the seed). It is used only to find the
//! vertical axis; the returned offset is the measured one.

use crate::estimators::Welford3;
use crate::{Calibration, Error};

/// Inclusive raw range of the ADC. A sample on (or beyond) a rail is saturated: it does
/// not measure the true value, so averaging it would bias the offset.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RawRange {
    /// Lowest raw value the ADC can output (e.g. 0 for unsigned, −32768 for `i16`).
    pub min: f32,
    /// Highest raw value the ADC can output (e.g. 255, 1023, 65535, 32767).
    pub max: f32,
}

impl RawRange {
    fn validate(&self) -> Result<(), Error> {
        if !self.min.is_finite() || !self.max.is_finite() {
            return Err(Error::NonFinite);
        }
        if self.min >= self.max {
            return Err(Error::InvalidParameter);
        }
        Ok(())
    }

    /// True when any component sits at or beyond a rail.
    pub fn is_saturated(&self, x: &[f32; 3]) -> bool {
        x.iter().any(|v| *v <= self.min || *v >= self.max)
    }
}

/// Default minimum number of samples: the seed averages 256.
pub const DEFAULT_MIN_SAMPLES: u32 = 256;

/// Settings of an accelerometer offset calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AccelOffsetConfig {
    /// Sensitivity: raw counts per g (the seed's `acc_1G_FS`), the same on every axis. Must
    /// be finite and > 0.
    pub counts_per_g: f32,
    /// Nominal raw reading at 0 g on each axis (mid-scale for an unsigned ADC, 0 for a signed
    /// one), used only to decide which axis is vertical.
    pub zero_g: [f32; 3],
    /// Optional ADC range; a sample touching a rail gives [`Error::Saturated`].
    pub range: Option<RawRange>,
    /// Minimum number of samples (at least 2 are always required, for the spread).
    pub min_samples: u32,
}

impl AccelOffsetConfig {
    /// Config for a signed sensor (0 g reads 0) with sensitivity `counts_per_g`, no range
    /// check and the seed's 256-sample minimum.
    pub const fn signed(counts_per_g: f32) -> Self {
        Self {
            counts_per_g,
            zero_g: [0.0; 3],
            range: None,
            min_samples: DEFAULT_MIN_SAMPLES,
        }
    }

    fn validate(&self) -> Result<(), Error> {
        if !self.counts_per_g.is_finite() || !crate::all_finite(&self.zero_g) {
            return Err(Error::NonFinite);
        }
        if self.counts_per_g <= 0.0 {
            return Err(Error::InvalidParameter);
        }
        match &self.range {
            Some(r) => r.validate(),
            None => Ok(()),
        }
    }
}

/// Settings of a gyroscope offset calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GyroOffsetConfig {
    /// Output units per raw count on each axis (e.g. `1/6258` rad/s per count for the Xsens
    /// MTi of IMU-TK); `[1, 1, 1]` keeps raw units. Finite and non-zero.
    pub scale: [f32; 3],
    /// Optional ADC range; a sample touching a rail gives [`Error::Saturated`].
    pub range: Option<RawRange>,
    /// Minimum number of samples (at least 2 are always required, for the spread).
    pub min_samples: u32,
}

impl Default for GyroOffsetConfig {
    fn default() -> Self {
        Self {
            scale: [1.0; 3],
            range: None,
            min_samples: DEFAULT_MIN_SAMPLES,
        }
    }
}

impl GyroOffsetConfig {
    fn validate(&self) -> Result<(), Error> {
        if !crate::all_finite(&self.scale) {
            return Err(Error::NonFinite);
        }
        if self.scale.contains(&0.0) {
            return Err(Error::InvalidParameter);
        }
        match &self.range {
            Some(r) => r.validate(),
            None => Ok(()),
        }
    }
}

/// The sensor axis found vertical during an accelerometer offset calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct VerticalAxis {
    /// Axis index: 0 = x, 1 = y, 2 = z.
    pub axis: u8,
    /// True when the axis points up (it reads +1 g), false when it points down (−1 g).
    pub up: bool,
}

impl VerticalAxis {
    /// The expected reading of the vertical axis in g: `+1` (up) or `−1` (down).
    pub fn sign(&self) -> f32 {
        if self.up {
            1.0
        } else {
            -1.0
        }
    }
}

/// Result of an accelerometer offset calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AccelOffset {
    /// Offset (bias) per axis, raw units: the mean with `±1 g` removed from the vertical axis.
    pub offset: [f32; 3],
    /// Which axis was vertical, and its direction.
    pub vertical: VerticalAxis,
    /// Mean of the samples, raw units.
    pub mean: [f32; 3],
    /// Unbiased per-axis standard deviation of the samples, raw units (noise, or motion if
    /// large).
    pub std_dev: [f32; 3],
    /// Number of samples averaged.
    pub count: u32,
    /// Sensitivity used, raw counts per g.
    pub counts_per_g: f32,
}

impl AccelOffset {
    /// The calibration: bias = offset, matrix = `diag(1/counts_per_g)`, so corrected
    /// readings are in g.
    pub fn calibration(&self) -> Calibration {
        let s = 1.0 / self.counts_per_g;
        let mut c = Calibration::identity();
        c.bias = self.offset;
        c.matrix = [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
        c
    }
}

/// Result of a gyroscope offset calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GyroOffset {
    /// Offset (bias) per axis, raw units: the mean at rest.
    pub offset: [f32; 3],
    /// Unbiased per-axis standard deviation of the samples, raw units.
    pub std_dev: [f32; 3],
    /// Number of samples averaged.
    pub count: u32,
    /// Output units per raw count used for the calibration matrix.
    pub scale: [f32; 3],
}

impl GyroOffset {
    /// The calibration: bias = offset, matrix = `diag(scale)`.
    pub fn calibration(&self) -> Calibration {
        let s = self.scale;
        let mut c = Calibration::identity();
        c.bias = self.offset;
        c.matrix = [[s[0], 0.0, 0.0], [0.0, s[1], 0.0], [0.0, 0.0, s[2]]];
        c
    }
}

/// Streaming accumulator of a static set, with the saturation check. Feed it with
/// [`OffsetAccumulator::push`] (e.g. sample by sample on a microcontroller), then call
/// [`OffsetAccumulator::finish_accel`] or [`OffsetAccumulator::finish_gyro`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OffsetAccumulator {
    stats: Welford3,
    range: Option<RawRange>,
    saturated: u32,
}

impl OffsetAccumulator {
    /// An empty accumulator; `range` enables the saturation check.
    pub fn new(range: Option<RawRange>) -> Self {
        Self {
            stats: Welford3::new(),
            range,
            saturated: 0,
        }
    }

    /// Adds one raw sample. A non-finite sample gives [`Error::NonFinite`]; a sample on a
    /// rail gives [`Error::Saturated`], is not averaged, and is remembered so that the
    /// `finish_*` calls fail too (a saturated static set is not usable even if the caller
    /// ignores the error).
    pub fn push(&mut self, x: [f32; 3]) -> Result<(), Error> {
        if !crate::all_finite(&x) {
            return Err(Error::NonFinite);
        }
        if let Some(r) = &self.range {
            if r.is_saturated(&x) {
                self.saturated = self.saturated.saturating_add(1);
                return Err(Error::Saturated);
            }
        }
        self.stats.push(x)
    }

    /// Number of samples averaged so far.
    pub fn count(&self) -> u32 {
        self.stats.count()
    }

    /// Number of saturated samples seen.
    pub fn saturated_count(&self) -> u32 {
        self.saturated
    }

    /// The underlying mean/variance accumulator.
    pub fn stats(&self) -> &Welford3 {
        &self.stats
    }

    fn checked_stats(&self, min_samples: u32) -> Result<([f32; 3], [f32; 3], u32), Error> {
        if self.saturated > 0 {
            return Err(Error::Saturated);
        }
        let needed = min_samples.max(2);
        let got = self.stats.count();
        if got < needed {
            return Err(Error::TooFewSamples { needed, got });
        }
        let m = self.stats.mean()?;
        let s = self.stats.std_dev()?;
        Ok(([m.x, m.y, m.z], [s.x, s.y, s.z], got))
    }

    /// Accelerometer offset from the accumulated static set (see the [module docs](self)).
    /// The saturation check is the accumulator's (`cfg.range` is used by [`accel_offset`]).
    pub fn finish_accel(&self, cfg: &AccelOffsetConfig) -> Result<AccelOffset, Error> {
        cfg.validate()?;
        let (mean, std_dev, count) = self.checked_stats(cfg.min_samples)?;
        let mut best: Option<(usize, f32)> = None;
        for (i, (m, z)) in mean.iter().zip(cfg.zero_g.iter()).enumerate() {
            let d = m - z;
            if best.is_none_or(|(_, b)| libm::fabsf(d) > libm::fabsf(b)) {
                best = Some((i, d));
            }
        }
        let (axis, d) = best.ok_or(Error::NoVerticalAxis)?;
        if libm::fabsf(d) < 0.9 * cfg.counts_per_g {
            return Err(Error::NoVerticalAxis);
        }
        let vertical = VerticalAxis {
            axis: axis as u8,
            up: d > 0.0,
        };
        let mut offset = mean;
        if let Some(o) = offset.get_mut(axis) {
            *o -= vertical.sign() * cfg.counts_per_g;
        }
        Ok(AccelOffset {
            offset,
            vertical,
            mean,
            std_dev,
            count,
            counts_per_g: cfg.counts_per_g,
        })
    }

    /// Gyroscope offset (mean at rest) from the accumulated static set. The saturation check
    /// is the accumulator's (`cfg.range` is used by [`gyro_offset`]).
    pub fn finish_gyro(&self, cfg: &GyroOffsetConfig) -> Result<GyroOffset, Error> {
        cfg.validate()?;
        let (offset, std_dev, count) = self.checked_stats(cfg.min_samples)?;
        Ok(GyroOffset {
            offset,
            std_dev,
            count,
            scale: cfg.scale,
        })
    }
}

/// Accelerometer offset calibration of a static set of raw samples (all samples must be
/// finite and unsaturated; the first bad one aborts with its error).
pub fn accel_offset<I>(samples: I, cfg: &AccelOffsetConfig) -> Result<AccelOffset, Error>
where
    I: IntoIterator<Item = [f32; 3]>,
{
    cfg.validate()?;
    let mut acc = OffsetAccumulator::new(cfg.range);
    for s in samples {
        acc.push(s)?;
    }
    acc.finish_accel(cfg)
}

/// Gyroscope offset calibration of a set of raw samples taken at rest (all samples must be
/// finite and unsaturated; the first bad one aborts with its error).
pub fn gyro_offset<I>(samples: I, cfg: &GyroOffsetConfig) -> Result<GyroOffset, Error>
where
    I: IntoIterator<Item = [f32; 3]>,
{
    cfg.validate()?;
    let mut acc = OffsetAccumulator::new(cfg.range);
    for s in samples {
        acc.push(s)?;
    }
    acc.finish_gyro(cfg)
}
