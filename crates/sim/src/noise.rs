//! Still-sensor noise with known IEEE 952 coefficients: white rate noise `N`, bias instability
//! (flicker) `B` and rate random walk `K`, the truth `wiical noise` is checked against.
//!
//! * White: independent samples of standard deviation `N·√fs` (two-sided PSD `N²`).
//! * Flicker: Gaussian noise shaped in the frequency domain to the one-sided PSD
//!   `B²/(π·f)` (IEEE 952's two-sided `B²/(2π f)`), whose Allan variance is `(2 ln 2/π)·B²`;
//!   synthesised by an inverse FFT of random complex amplitudes (rustfft).
//! * Rate random walk: the running sum of independent steps of standard deviation `K·√τ₀`
//!   (two-sided PSD `K²/(2πf)²`, Allan variance `K²τ/3`).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::num_complex::Complex;

/// The truth of a simulated still recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseTruth {
    /// White rate noise, unit/√Hz.
    pub n: f64,
    /// Bias instability, unit.
    pub b: f64,
    /// Rate random walk, unit/√s.
    pub k: f64,
}

/// `samples` (rounded up to a power of two for the FFT) of one axis at `rate_hz`.
pub fn simulate_noise(truth: NoiseTruth, rate_hz: f64, samples: usize, seed: u64) -> Vec<f64> {
    let n = samples.next_power_of_two();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut gauss = move || -> f64 { StandardNormal.sample(&mut rng) };
    let flicker = flicker(truth.b, rate_hz, n, &mut gauss);
    let white_sd = truth.n * rate_hz.sqrt();
    let step_sd = truth.k / rate_hz.sqrt();
    let mut walk = 0.0;
    (0..n)
        .map(|i| {
            walk += step_sd * gauss();
            white_sd * gauss() + flicker[i] + walk
        })
        .collect()
}

/// Flicker (1/f) noise of bias instability `b` (see the module docs), `n` samples (a power of
/// two).
fn flicker(b: f64, rate_hz: f64, n: usize, gauss: &mut impl FnMut() -> f64) -> Vec<f64> {
    let mut spec = vec![Complex::new(0.0, 0.0); n];
    for k in 1..=n / 2 {
        let f = k as f64 * rate_hz / n as f64;
        let psd = b * b / (std::f64::consts::PI * f);
        // E|X_k|² = G(f)·n·fs/2 for the one-sided PSD G (unnormalised forward DFT).
        let amp = (psd * n as f64 * rate_hz / 4.0).sqrt();
        let z = Complex::new(amp * gauss(), amp * gauss());
        if k == n / 2 {
            spec[k] = Complex::new(z.re * std::f64::consts::SQRT_2, 0.0);
        } else {
            spec[k] = z;
            spec[n - k] = z.conj();
        }
    }
    rustfft::FftPlanner::new()
        .plan_fft_inverse(n)
        .process(&mut spec);
    spec.iter().map(|c| c.re / n as f64).collect()
}
