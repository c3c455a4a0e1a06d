//! Zero-rate tracking while the sensor is in use: the gyro's bias drifts (temperature, age),
//! so it is re-estimated whenever the sensor is still, as Dolphin does for the MotionPlus.
//!
//! The stream is cut into blocks of [`ZeroRateConfig::block`] samples. A block is *still* when,
//! on every axis, the spread of its raw readings (max − min) stays within
//! [`ZeroRateConfig::max_spread`] counts and the caller's own stillness hint (e.g. "the
//! accelerometer is still", or always `true`) held for every sample. The mean of a still
//! block becomes the new bias (blended with the old one by [`ZeroRateConfig::blend`]); a
//! block that moves is dropped and a new block starts at the next sample.
//!
//! The test looks at the spread, not at the distance from the current bias, so a bias that
//! has drifted far is still caught up with in one block. The price: a perfectly constant
//! rotation rate would look still to the gyro alone; the accelerometer hint rules that out
//! (a turning sensor sees gravity move).
//!
//! Sums are taken relative to the block's first sample, so `f32` keeps full precision on
//! 16-bit counts. Generic over the float type.

use crate::Error;
use nalgebra::{RealField, Vector3};

/// Settings of the zero-rate tracker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZeroRateConfig<T: RealField + Copy> {
    /// Samples per stillness block (e.g. 0.5 s worth). At least 2.
    pub block: u32,
    /// Largest accepted per-axis spread (max − min) within a still block, raw counts: a few
    /// times the noise standard deviation (the range of `n` Gaussian samples is ≈ 4–6 σ for
    /// `n` = 50–500).
    pub max_spread: T,
    /// Weight of a new still block's mean, in (0, 1]: 1 replaces the bias, smaller values
    /// average over several blocks (less noise, slower to follow a drift).
    pub blend: T,
}

impl<T: RealField + Copy> ZeroRateConfig<T> {
    fn validate(&self) -> Result<(), Error> {
        let ok = self.block >= 2
            && self.max_spread.is_finite()
            && self.max_spread > T::zero()
            && self.blend.is_finite()
            && self.blend > T::zero()
            && self.blend <= T::one();
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidParameter)
        }
    }
}

/// Streaming re-estimation of the gyro bias whenever the sensor is still.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZeroRateTracker<T: RealField + Copy> {
    cfg: ZeroRateConfig<T>,
    bias: Vector3<T>,
    shift: Vector3<T>,
    sum: Vector3<T>,
    min: Vector3<T>,
    max: Vector3<T>,
    n: u32,
    updates: u32,
}

impl<T: RealField + Copy> ZeroRateTracker<T> {
    /// A tracker starting from `initial_bias` (raw counts, e.g. the calibration's bias).
    pub fn new(cfg: ZeroRateConfig<T>, initial_bias: [T; 3]) -> Result<Self, Error> {
        cfg.validate()?;
        if !initial_bias.iter().all(|x| x.is_finite()) {
            return Err(Error::NonFinite);
        }
        Ok(Self {
            cfg,
            bias: Vector3::from(initial_bias),
            shift: Vector3::zeros(),
            sum: Vector3::zeros(),
            min: Vector3::zeros(),
            max: Vector3::zeros(),
            n: 0,
            updates: 0,
        })
    }

    /// The current bias estimate, raw counts.
    pub fn bias(&self) -> [T; 3] {
        self.bias.into()
    }

    /// How many still blocks have updated the bias.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// Adds a raw sample with the caller's stillness hint. Returns the new bias when this
    /// sample completed a still block. A non-finite sample is refused and restarts the block.
    pub fn push(&mut self, m: [T; 3], still_hint: bool) -> Result<Option<[T; 3]>, Error> {
        let m = Vector3::from(m);
        if !m.iter().all(|x| x.is_finite()) {
            self.n = 0;
            return Err(Error::NonFinite);
        }
        if !still_hint {
            self.n = 0;
            return Ok(None);
        }
        if self.n == 0 {
            self.shift = m;
            self.sum = Vector3::zeros();
            self.min = m;
            self.max = m;
        }
        self.min = self.min.inf(&m);
        self.max = self.max.sup(&m);
        if (self.max - self.min).amax() > self.cfg.max_spread {
            // Moving: restart the block at this sample.
            self.n = 1;
            self.shift = m;
            self.sum = Vector3::zeros();
            self.min = m;
            self.max = m;
            return Ok(None);
        }
        self.sum += m - self.shift;
        self.n += 1;
        if self.n < self.cfg.block {
            return Ok(None);
        }
        let mean = self.shift + self.sum / nalgebra::convert::<f64, T>(f64::from(self.n));
        self.bias += (mean - self.bias) * self.cfg.blend;
        self.n = 0;
        self.updates = self.updates.saturating_add(1);
        Ok(Some(self.bias.into()))
    }
}
