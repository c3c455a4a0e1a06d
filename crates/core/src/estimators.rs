//! Estimators for a static acquisition: the mean (and spread) of a sensor held still.
//!
//! The six-position test (seed: *Calibrazione del Wiimote*, "Acquisizione delle misure")
//! needs, for every pose, the value the sensor would read without noise. With the noise
//! assumed white, zero-mean and uncorrelated the seed offers two estimators, both here:
//!
//! * the arithmetic mean of many (~10 000) samples, computed in streaming form by
//!   [`Welford`] / [`Welford3`] (Welford's update, Chan's formula to merge partial results),
//!   which also give the unbiased sample variance, a by-product useful to detect motion and
//!   to report the noise level;
//! * the Kalman observer for a constant (appendix, "Stima di una grandezza scalare costante"),
//!   scalar [`ConstantKalman`] and 3-vector [`ConstantKalman3`] (eq. 3, 4.1, 4.2 and the
//!   observer A.4 with `A = C = I`). With a large initial variance `p0` it reproduces the
//!   running mean; with a finite `p0` it is the Bayesian posterior mean given the prior
//!   `x0 ± √p0`.
//!
//! ## Precision in `f32`
//! Raw counts are large (an unsigned 16-bit ADC sits near 33 000) while the noise is a few
//! counts. An `f32` near 33 000 has a spacing of 0.0039, so a naive running mean
//! `m += (x − m)/n` stops moving once `|x − m|/n` falls below half of that spacing (after a
//! few thousand samples) and the result is wrong by ~0.1 count. Every estimator here
//! therefore works on deviations from a *shift* `s`, the first sample it sees:
//! `x − s` is exact for integer counts below 2²⁴, the accumulated quantities stay small and
//! keep full relative precision, and the result is `s + mean(x − s)`, rounded once. The
//! shift is invisible in the API and changes nothing in exact arithmetic (both the mean and
//! the constant-state Kalman recursion commute with a translation of the data).

use crate::{Error, Mat3, Vec3};

mod four;

/// Streaming mean and unbiased variance of a scalar (Welford's algorithm on shifted data).
///
/// See the [module docs](self) for why the data are shifted by the first sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Welford {
    n: u32,
    shift: f32,
    /// Mean of `x − shift`.
    mean: f32,
    /// Sum of squared deviations from the mean (Kahan-compensated, see `m2_c`).
    m2: f32,
    /// Kahan compensation of `m2`: the low-order part lost by the last additions, so that
    /// the sum is `m2 − m2_c`.
    m2_c: f32,
}

impl Welford {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            n: 0,
            shift: 0.0,
            mean: 0.0,
            m2: 0.0,
            m2_c: 0.0,
        }
    }

    /// Adds one sample. A NaN or infinite sample is refused with [`Error::NonFinite`] and
    /// leaves the accumulator unchanged; so does a full counter ([`Error::CapacityExceeded`]
    /// after `u32::MAX` samples).
    pub fn push(&mut self, x: f32) -> Result<(), Error> {
        if !x.is_finite() {
            return Err(Error::NonFinite);
        }
        let n = self.n.checked_add(1).ok_or(Error::CapacityExceeded)?;
        if self.n == 0 {
            self.shift = x;
        }
        let d = x - self.shift;
        let delta = d - self.mean;
        let mean = self.mean + delta / n as f32;
        // Kahan summation of the squared deviations: the increments (≈ σ²) are tiny next to
        // the sum (≈ n·σ²) and plain f32 addition loses ~3e-4 of the variance over 10⁵
        // samples of integer counts; compensated, the loss is ~1e-8.
        let inc = delta * (d - mean) - self.m2_c;
        let m2 = self.m2 + inc;
        let m2_c = (m2 - self.m2) - inc;
        if !mean.is_finite() || !m2.is_finite() || !m2_c.is_finite() {
            // Only reachable with values near f32::MAX (overflow of the squares).
            return Err(Error::NonFinite);
        }
        self.n = n;
        self.mean = mean;
        self.m2 = m2;
        self.m2_c = m2_c;
        Ok(())
    }

    /// [`Welford::push`]'s new `(mean, m2, m2_c)` for `x` at count `n` (`first`: no sample
    /// yet, `x` becomes the shift), not stored: [`Welford3::push`] stores the three axes'
    /// only when all are finite.
    #[inline(always)]
    fn next(&self, x: f32, n: f32, first: bool) -> (f32, f32, f32) {
        let shift = if first { x } else { self.shift };
        let d = x - shift;
        let delta = d - self.mean;
        let mean = self.mean + delta / n;
        let inc = delta * (d - mean) - self.m2_c;
        let m2 = self.m2 + inc;
        let m2_c = (m2 - self.m2) - inc;
        (mean, m2, m2_c)
    }

    /// The accumulator after [`Welford::next`].
    #[inline(always)]
    fn with(&self, n: u32, x: f32, first: bool, (mean, m2, m2_c): (f32, f32, f32)) -> Self {
        Self {
            n,
            shift: if first { x } else { self.shift },
            mean,
            m2,
            m2_c,
        }
    }

    /// Number of samples accumulated.
    pub const fn count(&self) -> u32 {
        self.n
    }

    /// The whole state as bits (count, shift, mean, `m2`, `m2_c`), for tests that compare
    /// two ways of accumulating bit for bit.
    #[cfg(test)]
    pub(crate) fn bits_for_tests(&self) -> [u32; 5] {
        [
            self.n,
            self.shift.to_bits(),
            self.mean.to_bits(),
            self.m2.to_bits(),
            self.m2_c.to_bits(),
        ]
    }

    /// Sets the counter, for tests of the full counter.
    #[cfg(test)]
    pub(crate) fn force_count_for_tests(&mut self, n: u32) {
        self.n = n;
    }

    /// Arithmetic mean; needs at least one sample.
    pub fn mean(&self) -> Result<f32, Error> {
        if self.n == 0 {
            return Err(Error::TooFewSamples { needed: 1, got: 0 });
        }
        Ok(self.shift + self.mean)
    }

    /// Unbiased sample variance `Σ(x − x̄)²/(n − 1)`; needs at least two samples.
    pub fn variance(&self) -> Result<f32, Error> {
        if self.n < 2 {
            return Err(Error::TooFewSamples {
                needed: 2,
                got: self.n,
            });
        }
        Ok(self.sum_sq() / (self.n - 1) as f32)
    }

    /// Sum of squared deviations from the mean, `Σ(x − x̄)²`.
    fn sum_sq(&self) -> f32 {
        self.m2 - self.m2_c
    }

    /// Unbiased sample standard deviation (square root of [`Self::variance`]).
    pub fn std_dev(&self) -> Result<f32, Error> {
        self.variance().map(libm::sqrtf)
    }

    /// Combines another accumulator into this one (Chan et al.'s parallel formula), as if
    /// all of `other`'s samples had been pushed here.
    pub fn merge(&mut self, other: &Self) -> Result<(), Error> {
        if other.n == 0 {
            return Ok(());
        }
        if self.n == 0 {
            *self = *other;
            return Ok(());
        }
        let n = self.n.checked_add(other.n).ok_or(Error::CapacityExceeded)?;
        // Other's mean expressed relative to our shift.
        let other_mean = (other.shift - self.shift) + other.mean;
        let delta = other_mean - self.mean;
        let (na, nb, nf) = (self.n as f32, other.n as f32, n as f32);
        let mean = self.mean + delta * (nb / nf);
        let m2 = self.sum_sq() + other.sum_sq() + delta * delta * (na * (nb / nf));
        if !mean.is_finite() || !m2.is_finite() {
            return Err(Error::NonFinite);
        }
        self.n = n;
        self.mean = mean;
        self.m2 = m2;
        self.m2_c = 0.0;
        Ok(())
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// True when the three values are finite (bitwise `&`: no branch per value).
#[inline(always)]
fn finite3(&(a, b, c): &(f32, f32, f32)) -> bool {
    a.is_finite() & b.is_finite() & c.is_finite()
}

/// Streaming per-axis mean and unbiased variance of 3-vectors (three [`Welford`]s sharing
/// one counter): the arithmetic-mean acquisition of the seed, in raw sensor units.
///
/// A sample is accepted or refused as a whole, so the three axes always hold the same
/// samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Welford3 {
    axes: [Welford; 3],
}

impl Welford3 {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            axes: [Welford::new(); 3],
        }
    }

    /// Adds one sample `[x, y, z]`. If any component is NaN or infinite the sample is
    /// refused with [`Error::NonFinite`] and the accumulator is unchanged.
    ///
    /// The same arithmetic as three [`Welford::push`]es, in place: the three axes share one
    /// counter (so one overflow test), and one test of the results stands for the test of the
    /// input, since a NaN or infinite component always makes its axis's new mean NaN or
    /// infinite (`d = x − shift` is, and so is `mean + (d − mean)/n`).
    #[inline]
    pub fn push(&mut self, x: [f32; 3]) -> Result<(), Error> {
        self.push_inlined(x)
    }

    /// [`Welford3::push`], always inlined: for the per-sample loops of the static detector
    /// and the noise survey, where a call per sample costs as much as the arithmetic.
    #[inline(always)]
    pub(crate) fn push_inlined(&mut self, x: [f32; 3]) -> Result<(), Error> {
        let [a, b, c] = &self.axes;
        let n0 = a.n;
        let Some(n) = n0.checked_add(1) else {
            // The input test first, as for a sample that is refused whatever the count.
            return Err(if crate::all_finite(&x) {
                Error::CapacityExceeded
            } else {
                Error::NonFinite
            });
        };
        let nf = n as f32;
        let first = n0 == 0;
        let ra = a.next(x[0], nf, first);
        let rb = b.next(x[1], nf, first);
        let rc = c.next(x[2], nf, first);
        if !(finite3(&ra) & finite3(&rb) & finite3(&rc)) {
            return Err(Error::NonFinite);
        }
        // The whole state stored at once: stored field by field, the next push's wider loads
        // of it could not be forwarded from the stores (a stall per sample).
        self.axes = [
            a.with(n, x[0], first, ra),
            b.with(n, x[1], first, rb),
            c.with(n, x[2], first, rc),
        ];
        Ok(())
    }

    /// Pushes `xs` in order, as many [`Welford3::push`]es (bit for bit); stops at the first
    /// sample `push` refuses, `Err((its index in xs, the error))`, the samples before it kept.
    pub fn push_slice(&mut self, xs: &[[f32; 3]]) -> Result<(), (usize, Error)> {
        for (i, x) in xs.iter().enumerate() {
            self.push_inlined(*x).map_err(|e| (i, e))?;
        }
        Ok(())
    }

    /// Number of samples accumulated.
    pub const fn count(&self) -> u32 {
        self.axes[0].count()
    }

    /// Sets the counter of the three axes, for tests of the full counter.
    #[cfg(test)]
    pub(crate) fn force_count_for_tests(&mut self, n: u32) {
        for a in &mut self.axes {
            a.n = n;
        }
    }

    /// Per-axis arithmetic mean (raw units); needs at least one sample.
    pub fn mean(&self) -> Result<Vec3, Error> {
        let [a, b, c] = &self.axes;
        Ok(Vec3::new(a.mean()?, b.mean()?, c.mean()?))
    }

    /// Per-axis unbiased sample variance (raw units²); needs at least two samples.
    pub fn variance(&self) -> Result<Vec3, Error> {
        let [a, b, c] = &self.axes;
        Ok(Vec3::new(a.variance()?, b.variance()?, c.variance()?))
    }

    /// Per-axis unbiased sample standard deviation (raw units); needs at least two samples.
    pub fn std_dev(&self) -> Result<Vec3, Error> {
        self.variance().map(|v| v.map(libm::sqrtf))
    }

    /// The scalar accumulator of one axis (0 = x, 1 = y, 2 = z), `None` for another index.
    pub fn axis(&self, i: usize) -> Option<&Welford> {
        self.axes.get(i)
    }

    /// Combines another accumulator into this one (Chan's parallel formula per axis). On
    /// error (counter overflow, overflowing values) this accumulator is unchanged.
    pub fn merge(&mut self, other: &Self) -> Result<(), Error> {
        let mut next = self.axes;
        for (a, b) in next.iter_mut().zip(other.axes.iter()) {
            a.merge(b)?;
        }
        self.axes = next;
        Ok(())
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

/// The seed's Kalman observer for a scalar constant (appendix, "Stima di una grandezza
/// scalare costante"): model `x_{k+1} = x_k`, `y_k = x_k + v_k`, `E[(x_0 − x̃_0)²] = p_0`,
/// `E[v_k²] = σ²`, and the recursion, exactly as printed,
///
/// ```text
/// K_k     = p_k / (σ² + p_k)
/// x̃_{k+1} = (1 − K_k)·x̃_k + K_k·y_k
/// p_{k+1} = (1 − K_k)²·p_k + σ²·K_k²
/// ```
///
/// `p_k` is the variance of the estimation error after `k` measurements (in units²). The
/// recursion runs on data shifted by the first measurement (see the [module docs](self));
/// that is a translation of `x̃` and `y`, under which the recursion is invariant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantKalman {
    /// Estimate minus `shift`.
    x: f32,
    p: f32,
    sigma2: f32,
    shift: f32,
    n: u32,
}

impl ConstantKalman {
    /// A filter with prior estimate `x0`, prior error variance `p0 ≥ 0` and measurement noise
    /// variance `sigma2 > 0` (all finite, else [`Error::NonFinite`] / [`Error::InvalidParameter`]).
    /// A very large `p0` (e.g. `1e30`) means "no prior": the estimate is then the running
    /// arithmetic mean of the measurements.
    pub fn new(x0: f32, p0: f32, sigma2: f32) -> Result<Self, Error> {
        if !x0.is_finite() || !p0.is_finite() || !sigma2.is_finite() {
            return Err(Error::NonFinite);
        }
        if p0 < 0.0 || sigma2 <= 0.0 {
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            x: x0,
            p: p0,
            sigma2,
            shift: 0.0,
            n: 0,
        })
    }

    /// Processes one measurement `y` and returns the new estimate. A non-finite `y` is refused
    /// with [`Error::NonFinite`] and the filter is unchanged.
    pub fn update(&mut self, y: f32) -> Result<f32, Error> {
        if !y.is_finite() {
            return Err(Error::NonFinite);
        }
        let (mut x, shift) = if self.n == 0 {
            // Re-express the prior relative to the first measurement (one rounding).
            (self.x - y, y)
        } else {
            (self.x, self.shift)
        };
        let yd = y - shift;
        let k = self.p / (self.sigma2 + self.p);
        let one_k = 1.0 - k;
        x = one_k * x + k * yd;
        let p = one_k * one_k * self.p + self.sigma2 * k * k;
        if !x.is_finite() || !p.is_finite() {
            return Err(Error::NonFinite);
        }
        self.x = x;
        self.p = p;
        self.shift = shift;
        self.n = self.n.saturating_add(1);
        Ok(self.estimate())
    }

    /// Current estimate `x̃_k`.
    pub fn estimate(&self) -> f32 {
        self.shift + self.x
    }

    /// Current error variance `p_k` (units²).
    pub fn variance(&self) -> f32 {
        self.p
    }

    /// Number of measurements processed (saturating).
    pub fn count(&self) -> u32 {
        self.n
    }
}

/// The seed's matrix Kalman observer for a constant 3-vector (eq. 3 with the diagonal `P0`
/// of eq. 4.1 and `R` of eq. 4.2), i.e. the observer A.4 with `A = C = I`, implemented as
/// the matrix recursion (Joseph form, as printed):
///
/// ```text
/// K_k     = P_k (R + P_k)⁻¹
/// x̃_{k+1} = (I − K_k)·x̃_k + K_k·y_k
/// P_{k+1} = (I − K_k) P_k (I − K_k)ᵀ + K_k R K_kᵀ
/// ```
///
/// With diagonal `P0` and `R` every matrix stays diagonal and this equals three
/// [`ConstantKalman`]s; the matrix form is kept because it is what the seed writes and it
/// accepts a full (correlated) `R` through [`ConstantKalman3::with_covariances`]. As in the
/// scalar case the recursion runs on data shifted by the first measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantKalman3 {
    x: Vec3,
    p: Mat3,
    r: Mat3,
    shift: Vec3,
    n: u32,
}

impl ConstantKalman3 {
    /// Filter with prior `x0`, diagonal prior error variances `p0` (eq. 4.1, each ≥ 0) and
    /// diagonal measurement noise variances `sigma2` (eq. 4.2, each > 0), raw units².
    pub fn new(x0: [f32; 3], p0: [f32; 3], sigma2: [f32; 3]) -> Result<Self, Error> {
        if !crate::all_finite(&x0) || !crate::all_finite(&p0) || !crate::all_finite(&sigma2) {
            return Err(Error::NonFinite);
        }
        if p0.iter().any(|v| *v < 0.0) || sigma2.iter().any(|v| *v <= 0.0) {
            return Err(Error::InvalidParameter);
        }
        Self::with_covariances(
            Vec3::from(x0),
            Mat3::from_diagonal(&Vec3::from(p0)),
            Mat3::from_diagonal(&Vec3::from(sigma2)),
        )
    }

    /// General form: full symmetric prior covariance `p0` (positive semi-definite) and
    /// measurement covariance `r` (positive definite). Symmetry and definiteness are checked
    /// with a Cholesky factorisation (of `r`, and of `p0 + r` for `p0`'s semi-definiteness
    /// as far as `f32` can tell).
    pub fn with_covariances(x0: Vec3, p0: Mat3, r: Mat3) -> Result<Self, Error> {
        if !crate::all_finite(x0.as_slice())
            || !crate::all_finite(p0.as_slice())
            || !crate::all_finite(r.as_slice())
        {
            return Err(Error::NonFinite);
        }
        let sym = |m: &Mat3| (m - m.transpose()).amax() <= 1e-6 * m.amax();
        if !sym(&p0) || !sym(&r) || p0.diagonal().iter().any(|v| *v < 0.0) {
            return Err(Error::InvalidParameter);
        }
        if r.cholesky().is_none() || (p0 + r).cholesky().is_none() {
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            x: x0,
            p: p0,
            r,
            shift: Vec3::zeros(),
            n: 0,
        })
    }

    /// Processes one measurement `y` (raw units) and returns the new estimate. Non-finite
    /// input → [`Error::NonFinite`]; `R + P` not numerically positive definite →
    /// [`Error::Singular`];
    /// in both cases the filter is unchanged.
    pub fn update(&mut self, y: [f32; 3]) -> Result<Vec3, Error> {
        if !crate::all_finite(&y) {
            return Err(Error::NonFinite);
        }
        let y = Vec3::from(y);
        let (x, shift) = if self.n == 0 {
            (self.x - y, y)
        } else {
            (self.x, self.shift)
        };
        let yd = y - shift;
        // K = P (R + P)⁻¹. Both are symmetric, so Kᵀ = (R + P)⁻¹ P: solve with a Cholesky
        // factorisation rather than forming the inverse, whose cofactors overflow `f32` for
        // the "no prior" choice p0 ≈ 1e30.
        let k = (self.r + self.p)
            .cholesky()
            .ok_or(Error::Singular)?
            .solve(&self.p)
            .transpose();
        let i_k = Mat3::identity() - k;
        let x = i_k * x + k * yd;
        let p = i_k * self.p * i_k.transpose() + k * self.r * k.transpose();
        if !crate::all_finite(x.as_slice()) || !crate::all_finite(p.as_slice()) {
            return Err(Error::NonFinite);
        }
        self.x = x;
        self.p = p;
        self.shift = shift;
        self.n = self.n.saturating_add(1);
        Ok(self.estimate())
    }

    /// Current estimate `x̃_k` (raw units).
    pub fn estimate(&self) -> Vec3 {
        self.shift + self.x
    }

    /// Current error covariance `P_k` (raw units²).
    pub fn covariance(&self) -> Mat3 {
        self.p
    }

    /// Number of measurements processed (saturating).
    pub fn count(&self) -> u32 {
        self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_small_exact_example() {
        let mut w = Welford::new();
        for x in [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0] {
            w.push(x).unwrap();
        }
        assert_eq!(w.mean(), Ok(5.0));
        // Σ(x−5)² = 32, unbiased variance 32/7.
        assert!((w.variance().unwrap() - 32.0 / 7.0).abs() < 1e-6);
    }

    #[test]
    fn empty_and_single_sample_are_errors_not_panics() {
        let mut w = Welford3::new();
        assert_eq!(w.mean(), Err(Error::TooFewSamples { needed: 1, got: 0 }));
        w.push([1.0, 2.0, 3.0]).unwrap();
        assert_eq!(w.mean().unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            w.variance(),
            Err(Error::TooFewSamples { needed: 2, got: 1 })
        );
        assert!(w.axis(3).is_none());
    }
}
