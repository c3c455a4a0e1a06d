//! Noise characterisation of a still sensor by the overlapping Allan deviation (IEEE Std
//! 952-1997, annex C; the method Kalibr's users and allan_variance_ros apply): the engine of
//! `wiical noise`.
//!
//! **The curve.** For a rate signal `y` sampled every `τ₀`, with `θ` its running integral
//! (`θₖ = τ₀·Σ_{i<k} yᵢ`), the overlapping Allan variance at `τ = m·τ₀` is
//! `σ²(τ) = Σₖ (θ_{k+2m} − 2θ_{k+m} + θₖ)² / (2τ²(n − 2m + 1))`. With `θ` computed once, each
//! `τ` costs one pass (O(n)); `τ` doubles from `τ₀` while at least 9 independent clusters
//! remain, so a whole curve is O(n·log n) time and O(n) memory. The relative uncertainty of a
//! point is `1/√(2(n/m − 1))` (independent clusters; the overlapping estimator does a little
//! better), the `adev_rel_err` of the report.
//!
//! **The five terms.** Each noise process adds its own power of `τ` to the Allan variance
//! (IEEE 952 table C.1): quantisation `3Q²/τ²` (slope −1 in σ), white rate noise (angle or
//! velocity random walk) `N²/τ` (slope −½: `N` is σ at τ = 1 s on that line), bias instability
//! `(2 ln 2/π)·B²` (flat: σ = 0.664·B at the minimum), rate random walk `K²τ/3` (slope +½), rate
//! ramp `R²τ²/2` (slope +1). The five coefficients are fitted together to the whole curve by
//! weighted non-negative least squares on σ² (each point weighted by its uncertainty; every
//! subset of terms tried, the best feasible kept), and a term is reported only where its slope
//! is seen: where it is more than half of the model at two or more points of the curve.
//! Elsewhere it is `None` (null in the JSON): not measured, not zero.
//!
//! Units: `N` in unit/√Hz (= unit·√s), `B` in unit, `K` in unit/√s, `Q` in unit·s, `R` in
//! unit/s, where unit is the column's (°/s, g, …).

use serde::Serialize;
use std::collections::VecDeque;

/// Fewest independent clusters a point of the curve is computed with (its relative
/// uncertainty is then at most 1/√16 = 25 %).
pub const MIN_CLUSTERS: usize = 9;

/// An Allan deviation curve.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct AllanCurve {
    /// Cluster times, s (octave-spaced: `τ₀·2ᵏ`).
    pub tau_s: Vec<f64>,
    /// Overlapping Allan deviation at each `τ`, in the signal's unit.
    pub adev: Vec<f64>,
    /// Relative uncertainty of each point (one standard deviation).
    pub adev_rel_err: Vec<f64>,
}

/// The overlapping Allan deviation of `y` sampled at `rate_hz`, at octave-spaced `τ` (see the
/// module docs). Fewer than `2·MIN_CLUSTERS` samples give an empty curve. The noise pass's
/// stream with every cluster kept ([`AllanStream`]): one estimator, fed
/// from a slice.
pub fn overlapping_adev(y: &[f64], rate_hz: f64) -> AllanCurve {
    let mut stream = AllanStream::new(y.len(), rate_hz, usize::MAX);
    y.iter().for_each(|v| stream.push(*v));
    stream.finish()
}

/// One octave's running sum.
#[derive(Debug)]
struct Octave {
    /// Cluster size, samples.
    m: usize,
    /// Step between the cluster starts used (1 up to the full-overlap size).
    stride: usize,
    /// θ at the last `2m/stride + 1` multiples of the stride; empty for a stride of 1, whose
    /// octaves read the stream's shared ring of recent θ instead.
    ring: VecDeque<f64>,
    sum: f64,
    terms: usize,
}

/// The overlapping Allan deviation of one axis, fed sample by sample ([`crate::noise::pass`]'s
/// module docs: every cluster, or cluster starts stepped beyond `full_m` samples).
#[derive(Debug)]
pub struct AllanStream {
    tau0: f64,
    n: usize,
    pushed: usize,
    theta: f64,
    octaves: Vec<Octave>,
    /// θ of the recent samples, indexed by the sample number masked by `mask` (a power of two
    /// of at least `2m + BLOCK` for the widest octave with a stride of 1): the fully
    /// overlapping octaves read their three values from it.
    recent: Vec<f64>,
    mask: usize,
    /// Samples pushed but not yet summed by the fully overlapping octaves: they are summed a
    /// block at a time, octave by octave, so that each octave walks the ring in order (per
    /// sample and octave, the ring's far ends missed the cache: 35 % of `noise`'s time).
    pending: usize,
}

/// Samples summed at once by the fully overlapping octaves ([`AllanStream::pending`]).
const BLOCK: usize = 4096;

impl AllanStream {
    /// A stream for `n` samples at `rate_hz`, with full overlap up to `full_m` samples.
    pub fn new(n: usize, rate_hz: f64, full_m: usize) -> Self {
        let mut octaves = Vec::new();
        let mut m = 1usize;
        let mut widest_full = 0;
        // The held path's octaves: τ doubles while at least MIN_CLUSTERS clusters remain.
        while n / m >= MIN_CLUSTERS && 2 * m <= n {
            let stride = (m / full_m.max(1)).max(1);
            let mut ring = VecDeque::new();
            if stride == 1 {
                widest_full = m;
            } else {
                ring.reserve(2 * m / stride + 1);
                ring.push_back(0.0); // θ₀
            }
            octaves.push(Octave {
                m,
                stride,
                ring,
                sum: 0.0,
                terms: 0,
            });
            m *= 2;
        }
        // θ₀ = 0 sits at index 0 of the zeroed ring.
        let len = (2 * widest_full + BLOCK + 1).next_power_of_two();
        Self {
            tau0: 1.0 / rate_hz,
            n,
            pushed: 0,
            theta: 0.0,
            octaves,
            recent: vec![0.0; len],
            mask: len - 1,
            pending: 0,
        }
    }

    /// The next sample.
    pub fn push(&mut self, y: f64) {
        self.theta += y * self.tau0;
        self.pushed += 1;
        let (i, theta) = (self.pushed, self.theta);
        self.recent[i & self.mask] = theta;
        self.pending += 1;
        if self.pending == BLOCK {
            self.sum_pending();
        }
        for o in self.octaves.iter_mut().filter(|o| o.stride > 1) {
            if i % o.stride != 0 {
                continue;
            }
            let span = 2 * o.m / o.stride;
            if o.ring.len() > span {
                o.ring.pop_front();
            }
            o.ring.push_back(theta);
            if o.ring.len() == span + 1 {
                let d = o.ring[span] - 2.0 * o.ring[span / 2] + o.ring[0];
                o.sum += d * d;
                o.terms += 1;
            }
        }
    }

    /// The pending samples summed by every fully overlapping octave, in sample order.
    fn sum_pending(&mut self) {
        let (r, mask) = (&self.recent, self.mask);
        let last = self.pushed;
        let first = last + 1 - self.pending;
        for o in self.octaves.iter_mut().filter(|o| o.stride == 1) {
            let m = o.m;
            let mut i = first.max(2 * m);
            // In runs where none of θᵢ, θᵢ₋ₘ, θᵢ₋₂ₘ wraps round the ring: three slices
            // walked together, summed in sample order.
            while i <= last {
                let at = [i & mask, (i - m) & mask, (i - 2 * m) & mask];
                let run = at.iter().fold(last + 1 - i, |n, a| n.min(r.len() - a));
                let (now, mid, old) = (
                    &r[at[0]..at[0] + run],
                    &r[at[1]..at[1] + run],
                    &r[at[2]..at[2] + run],
                );
                for ((x, y), z) in now.iter().zip(mid).zip(old) {
                    let d = x - 2.0 * y + z;
                    o.sum += d * d;
                }
                o.terms += run;
                i += run;
            }
        }
        self.pending = 0;
    }

    /// The curve, as [`crate::noise::allan::overlapping_adev`] lays it out (the uncertainty
    /// of each point is the held path's formula).
    pub fn finish(mut self) -> AllanCurve {
        if self.pending > 0 {
            self.sum_pending();
        }
        let n = self.pushed.min(self.n);
        let mut curve = AllanCurve::default();
        for o in self.octaves.iter().filter(|o| o.terms > 0) {
            let tau = o.m as f64 * self.tau0;
            curve.tau_s.push(tau);
            curve
                .adev
                .push((o.sum / (2.0 * tau * tau * o.terms as f64)).sqrt());
            curve
                .adev_rel_err
                .push(1.0 / (2.0 * ((n / o.m) as f64 - 1.0)).sqrt());
        }
        curve
    }
}

/// The IEEE 952 coefficients fitted to a curve; `None` where the term's slope is not seen.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct NoiseTerms {
    /// White rate noise (angle / velocity random walk), unit/√Hz: σ(1 s) on the −½ line.
    pub n: Option<f64>,
    /// Bias instability, unit: the flat part's σ / 0.664.
    pub b: Option<f64>,
    /// Where the curve is lowest, s (the bias-instability reading's τ).
    pub b_tau_s: Option<f64>,
    /// Rate random walk, unit/√s (the +½ line: σ = K·√(τ/3)).
    pub k: Option<f64>,
    /// Quantisation, unit·s (the −1 line: σ = √3·Q/τ).
    pub q: Option<f64>,
    /// Rate ramp, unit/s (the +1 line: σ = R·τ/√2).
    pub r: Option<f64>,
}

/// `σ²` of each term with unit coefficient, in the order Q, N, B, K, R.
fn basis(tau: f64) -> [f64; 5] {
    [
        3.0 / (tau * tau),
        1.0 / tau,
        2.0 * std::f64::consts::LN_2 / std::f64::consts::PI,
        tau / 3.0,
        tau * tau / 2.0,
    ]
}

/// Solves the (≤ 5 × 5) system `a·x = b` by Gaussian elimination with partial pivoting;
/// `None` when singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        let pivot_row = a[c].clone();
        for r in c + 1..n {
            let f = a[r][c] / pivot_row[c];
            for (x, p) in a[r].iter_mut().zip(&pivot_row).skip(c) {
                *x -= f * p;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// Weighted least squares of σ² on the terms in `subset` (bit i: term i of [`basis`]), with
/// columns scaled to unit norm for conditioning. Returns the five coefficients (zero outside
/// the subset) and the weighted residual sum of squares.
fn fit_subset(curve: &AllanCurve, subset: u32) -> Option<([f64; 5], f64)> {
    let terms: Vec<usize> = (0..5).filter(|i| subset & (1 << i) != 0).collect();
    let rows: Vec<([f64; 5], f64, f64)> = curve
        .tau_s
        .iter()
        .zip(&curve.adev)
        .zip(&curve.adev_rel_err)
        .map(|((t, s), e)| {
            (
                basis(*t),
                s * s,
                1.0 / (2.0 * e * s * s).max(f64::MIN_POSITIVE),
            )
        })
        .collect();
    let scale: Vec<f64> = terms
        .iter()
        .map(|&j| {
            rows.iter()
                .map(|r| (r.0[j] * r.2).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    if scale.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
        return None;
    }
    let k = terms.len();
    let mut ata = vec![vec![0.0; k]; k];
    let mut atb = vec![0.0; k];
    for (phi, v, w) in &rows {
        let x: Vec<f64> = (0..k).map(|a| phi[terms[a]] * w / scale[a]).collect();
        for a in 0..k {
            atb[a] += x[a] * v * w;
            for b in 0..k {
                ata[a][b] += x[a] * x[b];
            }
        }
    }
    let sol = solve(ata, atb)?;
    let mut coef = [0.0; 5];
    for (a, &j) in terms.iter().enumerate() {
        coef[j] = sol[a] / scale[a];
    }
    let rss = rows
        .iter()
        .map(|(phi, v, w)| {
            let m: f64 = (0..5).map(|j| phi[j] * coef[j]).sum();
            ((m - v) * w).powi(2)
        })
        .sum();
    Some((coef, rss))
}

/// Fits the five IEEE 952 terms to `curve` (see the module docs). A curve of fewer than 3
/// points gives no term.
pub fn fit_terms(curve: &AllanCurve) -> NoiseTerms {
    if curve.tau_s.len() < 3 {
        return NoiseTerms::default();
    }
    // Non-negative least squares over five terms: every subset solved, the best feasible one
    // kept (32 small solves; exact, where an active-set iteration would only approach it).
    let best = (1u32..32)
        .filter_map(|s| fit_subset(curve, s))
        .filter(|(c, _)| c.iter().all(|v| *v >= 0.0 && v.is_finite()))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let Some((coef, _)) = best else {
        return NoiseTerms::default();
    };
    // A term is seen where it is more than half of the model, at two points or more.
    let seen: [bool; 5] = std::array::from_fn(|j| {
        curve
            .tau_s
            .iter()
            .filter(|t| {
                let phi = basis(**t);
                let total: f64 = (0..5).map(|i| phi[i] * coef[i]).sum();
                coef[j] > 0.0 && phi[j] * coef[j] > 0.5 * total
            })
            .count()
            >= 2
    });
    let value = |j: usize| seen[j].then(|| coef[j].sqrt());
    let min_at = curve
        .adev
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| curve.tau_s[i]);
    NoiseTerms {
        q: value(0),
        n: value(1),
        b: value(2),
        b_tau_s: value(2).and(min_at),
        k: value(3),
        r: value(4),
    }
}

/// The fitted model's Allan deviation at `tau` (for plotting the fitted lines).
pub fn model_adev(terms: &NoiseTerms, tau: f64) -> f64 {
    let phi = basis(tau);
    let c = [terms.q, terms.n, terms.b, terms.k, terms.r].map(|v| v.map_or(0.0, |x| x * x));
    (0..5).map(|i| phi[i] * c[i]).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimator against its definition computed directly (non-cumulative) on a short
    /// signal.
    #[test]
    fn overlapping_adev_matches_the_definition() {
        let y: Vec<f64> = (0..200).map(|i| ((i * 37 % 101) as f64).sin()).collect();
        let fs = 4.0;
        let c = overlapping_adev(&y, fs);
        assert_eq!(c.tau_s, vec![0.25, 0.5, 1.0, 2.0, 4.0]);
        for (i, tau) in c.tau_s.iter().enumerate() {
            let m = (tau * fs).round() as usize;
            let avg = |k: usize| y[k..k + m].iter().sum::<f64>() / m as f64;
            let terms = y.len() - 2 * m + 1;
            let s: f64 = (0..terms).map(|k| (avg(k + m) - avg(k)).powi(2)).sum();
            let want = (s / (2.0 * terms as f64)).sqrt();
            assert!(
                (c.adev[i] - want).abs() < 1e-12 * want,
                "{tau}: {} vs {want}",
                c.adev[i]
            );
        }
    }

    /// With a small `full_m` the strided points are the fully overlapping ones up to it bit
    /// for bit, and within a fraction of their uncertainty beyond.
    #[test]
    fn the_strided_stream_is_near_the_full_one() {
        let y: Vec<f64> = (0..5000)
            .map(|i| ((i * 7919 % 104_729) as f64).sin() + (i as f64 * 1e-3).cos())
            .collect();
        let held = overlapping_adev(&y, 50.0);
        let run = |full_m: usize| {
            let mut s = AllanStream::new(y.len(), 50.0, full_m);
            y.iter().for_each(|v| s.push(*v));
            s.finish()
        };
        let strided = run(8);
        assert_eq!(strided.tau_s, held.tau_s);
        assert_eq!(strided.adev_rel_err, held.adev_rel_err);
        for i in 0..held.adev.len() {
            let rel = strided.adev[i] / held.adev[i] - 1.0;
            if held.tau_s[i] * 50.0 <= 8.0 {
                assert_eq!(strided.adev[i], held.adev[i]);
            }
            assert!(rel.abs() < 0.5 * held.adev_rel_err[i], "{i}: {rel}");
        }
    }

    /// A curve made of the terms' own formulas gives the terms back, and leaves out the
    /// ones that are nowhere dominant.
    #[test]
    fn exact_curves_give_their_terms_back() {
        // Each term dominant somewhere: Q below 0.12 s, N to 116 s, B to 1620 s, K beyond.
        let tau: Vec<f64> = (0..25).map(|k| 0.01 * 2f64.powi(k)).collect();
        let truth = NoiseTerms {
            n: Some(0.05),
            b: Some(0.007),
            b_tau_s: None,
            k: Some(2e-4),
            q: Some(1e-2),
            r: None,
        };
        let curve = AllanCurve {
            adev: tau.iter().map(|t| model_adev(&truth, *t)).collect(),
            adev_rel_err: vec![0.05; tau.len()],
            tau_s: tau,
        };
        let got = fit_terms(&curve);
        for (g, w) in [
            (got.n, truth.n),
            (got.b, truth.b),
            (got.k, truth.k),
            (got.q, truth.q),
        ] {
            let (g, w) = (g.expect("seen"), w.unwrap());
            assert!((g / w - 1.0).abs() < 1e-6, "{g} vs {w}");
        }
        assert_eq!(got.r, None);
    }
}

#[cfg(test)]
mod simulated {
    use super::*;
    use wiical_sim::noise::{simulate_noise, NoiseTruth};

    /// White + flicker + rate random walk with known coefficients, 2²² samples at 10 Hz
    /// (116 h, so that the +½ slope spans several octaves): N, B and K come back within 10 %
    /// on three seeds, and nothing else is reported.
    #[test]
    fn simulated_noise_gives_its_coefficients_back() {
        let truth = NoiseTruth {
            n: 0.01,
            b: 0.001,
            k: 2.5e-5,
        };
        for seed in 1..=3 {
            let y = simulate_noise(truth, 10.0, 1 << 22, seed);
            let got = fit_terms(&overlapping_adev(&y, 10.0));
            for (name, g, w) in [
                ("N", got.n, truth.n),
                ("B", got.b, truth.b),
                ("K", got.k, truth.k),
            ] {
                let g = g.unwrap_or_else(|| panic!("seed {seed}: {name} not seen"));
                eprintln!(
                    "seed {seed}: {name} = {g:.4e} (truth {w:.4e}, {:+.1} %)",
                    100.0 * (g / w - 1.0)
                );
                assert!(
                    (g / w - 1.0).abs() < 0.10,
                    "seed {seed}: {name} {g:e} vs {w:e}"
                );
            }
            assert_eq!((got.q, got.r), (None, None), "seed {seed}: {got:?}");
        }
    }
}
