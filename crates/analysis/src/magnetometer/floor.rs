//! The magnetometer's noise floor, measured from the recording itself: the short-term scatter
//! of each axis about a smooth track.
//!
//! Why second differences: a hand-held rotation moves the field by much more than the noise
//! between samples, but smoothly; `m[i+1] − 2·m[i] + m[i−1]` cancels a track that is locally a
//! straight line and leaves `6σ²` of white noise. Its median absolute value (÷ 0.6745 for a
//! Gaussian) ignores the few samples where the motion jerks. A quantised axis whose steps are
//! mostly zero has at least the rounding's `q/√12` (`q` its smallest step).

use super::design::Geo;

/// Each axis's white-noise standard deviation (see the module docs) but the median, one point
/// at a time in file order: the last two points, the squared second differences and the
/// smallest non-zero first difference per axis ([`StepFold::noise`] given the median).
#[derive(Debug, Clone)]
pub struct StepFold {
    last: Option<[f64; 3]>,
    before: Option<[f64; 3]>,
    /// `Σ d²` per axis (`-0.0` to start, as `Iterator::sum` does).
    sum_sq: [f64; 3],
    /// Second differences seen.
    pub count: usize,
    min_step: [f64; 3],
}

impl Default for StepFold {
    fn default() -> Self {
        Self::new()
    }
}

impl StepFold {
    /// Nothing seen.
    pub fn new() -> Self {
        Self {
            last: None,
            before: None,
            sum_sq: [-0.0; 3],
            count: 0,
            min_step: [f64::INFINITY; 3],
        }
    }

    /// The next point; its `|m[i] − 2·m[i−1] + m[i−2]|` per axis once there are three.
    pub fn push(&mut self, p: &[f64; 3]) -> Option<[f64; 3]> {
        if let Some(l) = self.last {
            for a in 0..3 {
                let d = (p[a] - l[a]).abs();
                if d > 0.0 {
                    self.min_step[a] = self.min_step[a].min(d);
                }
            }
        }
        let out = match (self.before, self.last) {
            (Some(b), Some(l)) => {
                let d: [f64; 3] = std::array::from_fn(|a| (p[a] - 2.0 * l[a] + b[a]).abs());
                for (s, x) in self.sum_sq.iter_mut().zip(d) {
                    *s += x * x;
                }
                self.count += 1;
                Some(d)
            }
            _ => None,
        };
        self.before = self.last.replace(*p);
        out
    }

    /// Each axis's noise given the median of its |second differences| (`NaN` without any):
    /// the median's Gaussian σ, the RMS's when the median is 0, at least the rounding.
    pub fn noise(&self, median: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| {
            let med = median[a];
            let robust = if med > 0.0 {
                med / 0.6745 / 6f64.sqrt()
            } else {
                let rms = if self.count == 0 {
                    0.0
                } else {
                    (self.sum_sq[a] / self.count as f64).sqrt()
                };
                rms / 6f64.sqrt()
            };
            let q = self.min_step[a];
            let rounding = if q.is_finite() { q / 12f64.sqrt() } else { 0.0 };
            if robust.is_finite() {
                robust.max(rounding)
            } else {
                rounding
            }
        })
    }
}

/// The residual's floor and the directions' coverage, one point's geometry at a time (sums
/// start at `-0.0`, as `Iterator::sum` does).
#[derive(Debug, Clone)]
pub struct GeoFold {
    sigma: [f64; 3],
    radial: f64,
    uu: [[f64; 3]; 3],
    n: usize,
}

impl GeoFold {
    /// Nothing seen, with the axes' noise `sigma`.
    pub fn new(sigma: [f64; 3]) -> Self {
        Self {
            sigma,
            radial: -0.0,
            uu: [[-0.0; 3]; 3],
            n: 0,
        }
    }

    /// One point's geometry.
    pub fn push(&mut self, g: &Geo) {
        self.radial += (0..3)
            .map(|a| (g.grad[a] * self.sigma[a]).powi(2))
            .sum::<f64>();
        for i in 0..3 {
            for j in 0..3 {
                self.uu[i][j] += g.u[i] * g.u[j];
            }
        }
        self.n += 1;
    }

    /// The residual's noise floor, raw units: the axes' noise seen along each sample's radial
    /// direction (`Wᵀn̂`), as an RMS over the samples.
    pub fn floor(&self) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        (self.radial / self.n as f64).sqrt()
    }

    /// How well the fitted directions cover the sphere: the smallest eigenvalue of the mean
    /// `n̂·n̂ᵀ` (1/3 for a full sphere, 0 for a plane or a line).
    pub fn coverage(&self) -> f64 {
        let n = self.n.max(1) as f64;
        let m = nalgebra::Matrix3::from_fn(|i, j| self.uu[i][j] / n);
        m.symmetric_eigenvalues().min()
    }
}

/// Fewest noise standard deviations the points must spread over on some axis for a fit to
/// mean anything: a still sensor's blob spreads over ~1 (1.4 on the unmoved HMC5883L logs),
/// the noisiest and the sparsest real rotations here over 14 and 17.
pub const MIN_SPREAD_OVER_NOISE: f64 = 5.0;

/// `(largest axis spread, its noise)` when the points never leave a blob of their own noise
/// (the sensor was not rotated), `None` otherwise, from each axis's standard deviation
/// `spread` and noise `sigma`.
pub fn blob(spread: [f64; 3], sigma: [f64; 3]) -> Option<(f64, f64)> {
    let (a, s) = spread.iter().enumerate().max_by(|x, y| {
        (x.1 / sigma[x.0].max(f64::MIN_POSITIVE))
            .total_cmp(&(y.1 / sigma[y.0].max(f64::MIN_POSITIVE)))
    })?;
    (*s < MIN_SPREAD_OVER_NOISE * sigma[a]).then_some((*s, sigma[a]))
}

/// Per-axis sums in file order (from `-0.0`, as `Iterator::sum`): of the points for their
/// mean, or of their squared deviations from a mean for their spread.
#[derive(Debug, Clone)]
pub struct AxisSums {
    sum: [f64; 3],
    n: usize,
}

impl Default for AxisSums {
    fn default() -> Self {
        Self::new()
    }
}

impl AxisSums {
    /// Nothing seen.
    pub fn new() -> Self {
        Self {
            sum: [-0.0; 3],
            n: 0,
        }
    }

    /// Adds a point.
    pub fn push(&mut self, p: &[f64; 3]) {
        for (s, x) in self.sum.iter_mut().zip(p) {
            *s += x;
        }
        self.n += 1;
    }

    /// Adds a point's squared deviation from `mean`.
    pub fn push_dev(&mut self, p: &[f64; 3], mean: &[f64; 3]) {
        for a in 0..3 {
            self.sum[a] += (p[a] - mean[a]).powi(2);
        }
        self.n += 1;
    }

    /// The mean of the points pushed.
    pub fn mean(&self) -> [f64; 3] {
        let n = self.n as f64;
        self.sum.map(|s| s / n)
    }

    /// The standard deviation, from squared deviations pushed.
    pub fn spread(&self) -> [f64; 3] {
        self.mean().map(f64::sqrt)
    }
}
