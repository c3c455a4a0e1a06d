//! The orientation grid: a fixed set of bins over the sphere, each holding exponentially
//! weighted statistics of the still moments met in its orientation.
//!
//! ## Binning
//! A still moment's direction (its mean corrected with the live calibration) falls on one face
//! of a cube around the sensor (the axis of its largest component, and that component's
//! sign); the face is cut into [`CELLS`] × [`CELLS`] cells of equal angle (the face
//! coordinates go through `atan`, so cells near the face's edges are not smaller than
//! central ones). [`BINS`] = 54 bins of ≈ 30° each: fine enough that a bin's moments agree on
//! the direction, coarse enough that ordinary play fills a covering set within minutes.
//!
//! ## What a bin keeps, in raw counts
//! The weighted mean of the moments' means, their weighted covariance about it, and the
//! weighted mean temperature. Averaging raw means of *different* directions would shorten
//! the vector they stand for (the mean of unit vectors 15° apart is 1 % short of unit length:
//! a 10 mg bias on a sphere fit), so the fit uses the covariance too:
//! `E‖K(m − b)‖² = ‖K(m̄ − b)‖² + tr(K·C·Kᵀ)` holds exactly for the bin's moments, whatever
//! their spread.
//!
//! ## Following drift
//! A moment's weight is `max(1/n, newest_weight)` for the bin's `n`-th moment: plain averaging
//! at first, then exponential forgetting, so a bin follows a bias that moves. A bin not
//! visited for [`super::BackgroundSettings::max_bin_age_s`] is left out of fits (its
//! statistics describe a sensor that may have moved since).

use wiical_core::Calibration;

/// The bins' numbering is the wire protocol's (a host draws `BackgroundReport::bin_moments`
/// and `fresh_bins` by it), so it lives in `wiical-wire`, where the client reads it without
/// this crate.
pub use wiical_wire::bins::{bin_centre, bin_of, CELLS};

/// Bins in the grid (6 faces × [`CELLS`]²).
pub const BINS: usize = wiical_wire::BACKGROUND_BINS;

/// One bin: exponentially weighted statistics of the still moments in one orientation cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bin {
    /// Still moments ever added (saturating).
    pub count: u32,
    /// Weighted mean of the moments' means, raw counts.
    pub mean: [f32; 3],
    /// Weighted covariance of the moments' means about [`Bin::mean`], raw counts², packed
    /// `xx, xy, xz, yy, yz, zz`.
    pub cov: [f32; 6],
    /// Weighted mean temperature of the moments that had one, °C (NaN while none had).
    pub temperature_c: f32,
    /// Play time of the latest moment, s.
    pub last_s: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        count: 0,
        mean: [0.0; 3],
        cov: [0.0; 6],
        temperature_c: f32::NAN,
        last_s: 0,
    };

    /// Adds one moment with weight `w` (1 for the first): `mean += w·δ`,
    /// `C = (1 − w)(C + w·δδᵀ)`, the exponentially weighted mean and covariance.
    fn add(&mut self, m: [f32; 3], temperature_c: Option<f32>, w: f32, now_s: u32) {
        let d = [
            m[0] - self.mean[0],
            m[1] - self.mean[1],
            m[2] - self.mean[2],
        ];
        for (mean, di) in self.mean.iter_mut().zip(d) {
            *mean += w * di;
        }
        let outer = [
            d[0] * d[0],
            d[0] * d[1],
            d[0] * d[2],
            d[1] * d[1],
            d[1] * d[2],
            d[2] * d[2],
        ];
        for (c, o) in self.cov.iter_mut().zip(outer) {
            *c = (1.0 - w) * (*c + w * o);
        }
        self.temperature_c = match temperature_c {
            // The first temperature a bin meets is its temperature (NaN until then).
            Some(t) if self.temperature_c.is_nan() => t,
            Some(t) => self.temperature_c + w * (t - self.temperature_c),
            // A moment without one (the ADC failed for it) is taken at the bin's: one failed
            // reading must not leave the bin without a covariate, and every fit that trains
            // on it without a slope, for good.
            None => self.temperature_c,
        };
        self.count = self.count.saturating_add(1);
        self.last_s = now_s;
    }

    /// The covariance as a symmetric 3×3 matrix.
    pub fn cov_matrix(&self) -> [[f32; 3]; 3] {
        let c = &self.cov;
        [[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]]
    }

    /// True when the bin has moments no older than `max_age_s` at `now_s`.
    pub fn fresh(&self, now_s: u32, max_age_s: u32) -> bool {
        self.count > 0 && now_s.saturating_sub(self.last_s) <= max_age_s
    }
}

/// The grid of [`BINS`] bins; see the module docs.
#[derive(Debug, Clone)]
pub struct Grid {
    bins: [Bin; BINS],
    moments: u32,
}

impl Default for Grid {
    fn default() -> Self {
        Self {
            bins: [Bin::EMPTY; BINS],
            moments: 0,
        }
    }
}

impl Grid {
    /// The bins, in index order.
    pub fn bins(&self) -> &[Bin; BINS] {
        &self.bins
    }

    /// Still moments added since the grid was made (saturating).
    pub fn moments(&self) -> u32 {
        self.moments
    }

    /// Bins with moments no older than `max_age_s`.
    pub fn filled(&self, now_s: u32, max_age_s: u32) -> u8 {
        self.bins
            .iter()
            .filter(|b| b.fresh(now_s, max_age_s))
            .count() as u8
    }

    /// Adds a still moment (mean raw counts) seen at play time `now_s`, binned by its
    /// direction under `live`; `newest_weight` is the floor of a moment's weight (see the
    /// module docs). Returns the bin index, or `None` for a non-finite direction.
    pub fn add(
        &mut self,
        mean: [f32; 3],
        temperature_c: Option<f32>,
        live: &Calibration,
        newest_weight: f32,
        now_s: u32,
    ) -> Option<usize> {
        let i = bin_of(live.correct_linear(mean))?;
        let bin = &mut self.bins[i];
        let n = bin.count.saturating_add(1) as f32;
        let w = if bin.count == 0 {
            1.0
        } else {
            (1.0 / n).max(newest_weight.clamp(0.0, 1.0))
        };
        bin.add(mean, temperature_c.filter(|t| t.is_finite()), w, now_s);
        self.moments = self.moments.saturating_add(1);
        Some(i)
    }
}
