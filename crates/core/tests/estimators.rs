//! Static-acquisition estimators (`stats`) and offset-only calibration (`offset`), checked
//! against f64 references written here, seeded simulations with known truth, and the real
//! IMU-TK Xsens recording.
// Loops over the three axes index several parallel arrays; ranges read best here.
#![allow(clippy::needless_range_loop)]

mod common;
use common::data_dir;

use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_core::estimators::{ConstantKalman, ConstantKalman3, Welford, Welford3};
use wiical_core::offset::{
    accel_offset, gyro_offset, AccelOffsetConfig, GyroOffsetConfig, OffsetAccumulator, RawRange,
};
use wiical_core::Error;

// ---------------------------------------------------------------- f64 references

/// Two-pass mean and unbiased variance in f64.
fn two_pass(xs: &[[f32; 3]]) -> ([f64; 3], [f64; 3]) {
    let n = xs.len() as f64;
    let mut mean = [0.0; 3];
    for x in xs {
        for i in 0..3 {
            mean[i] += x[i] as f64;
        }
    }
    for m in &mut mean {
        *m /= n;
    }
    let mut var = [0.0; 3];
    for x in xs {
        for i in 0..3 {
            let d = x[i] as f64 - mean[i];
            var[i] += d * d;
        }
    }
    for v in &mut var {
        *v /= n - 1.0;
    }
    (mean, var)
}

/// Simulated raw counts of a still 16-bit sensor: integer-rounded `centre + N(0, sd²)`.
fn raw_counts(rng: &mut ChaCha8Rng, n: usize, centre: [f64; 3], sd: f64) -> Vec<[f32; 3]> {
    let noise = Normal::new(0.0, sd).unwrap();
    (0..n)
        .map(|_| {
            let mut s = [0.0f32; 3];
            for i in 0..3 {
                s[i] = (centre[i] + noise.sample(rng)).round() as f32;
            }
            s
        })
        .collect()
}

// ---------------------------------------------------------------- Welford

/// Standard error of the mean for 10⁵ samples of sd 3 is 3/√10⁵ ≈ 0.0095 count. The f32
/// result must add much less than that: the final `shift + mean` is rounded once to the
/// f32 grid (spacing 0.0039 near 33 000, so ≤ 0.002), plus accumulated rounding of the
/// small deviations (≪ 0.001). Tolerance 0.003 count = 1/3 of the statistical uncertainty.
const MEAN_TOL_COUNTS: f64 = 0.003;

#[test]
fn welford3_matches_f64_two_pass_on_large_raw_counts() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let xs = raw_counts(&mut rng, 100_000, [33_102.3, 33_330.6, 36_433.8], 3.0);
    let (mean_ref, var_ref) = two_pass(&xs);
    let mut w = Welford3::new();
    for x in &xs {
        w.push(*x).unwrap();
    }
    assert_eq!(w.count(), 100_000);
    let mean = w.mean().unwrap();
    let var = w.variance().unwrap();
    let sd = w.std_dev().unwrap();
    for i in 0..3 {
        let e = (mean[i] as f64 - mean_ref[i]).abs();
        assert!(e < MEAN_TOL_COUNTS, "axis {i}: mean err {e}");
        // Relative variance error: M2 ≈ 9·10⁵ is a sum of 10⁵ terms ≈ 9. Uncompensated f32
        // addition loses ~3e-4 of it on integer counts (systematic rounding); the
        // implementation's Kahan summation brings that to ~1e-8. Allow 1e-5.
        let rel = (var[i] as f64 - var_ref[i]).abs() / var_ref[i];
        assert!(rel < 1e-5, "axis {i}: variance rel err {rel}");
        assert!((sd[i] as f64 - var_ref[i].sqrt()).abs() / var_ref[i].sqrt() < 1e-5);
    }
}

/// The same data through a textbook f32 Welford without the shift: it loses the mean by
/// more than the tolerance above, which shows the accuracy test is able to fail and why the
/// implementation shifts the data.
#[test]
fn unshifted_f32_welford_would_fail_the_accuracy_test() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let xs = raw_counts(&mut rng, 100_000, [33_102.3, 33_330.6, 36_433.8], 3.0);
    let (mean_ref, _) = two_pass(&xs);
    let mut worst: f64 = 0.0;
    for i in 0..3 {
        let mut m = 0.0f32;
        for (k, x) in xs.iter().enumerate() {
            m += (x[i] - m) / (k + 1) as f32;
        }
        worst = worst.max((m as f64 - mean_ref[i]).abs());
    }
    assert!(worst > MEAN_TOL_COUNTS, "naive error {worst}");
}

#[test]
fn welford_scalar_matches_two_pass_on_continuous_data() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let noise = Normal::new(-1234.5, 0.7).unwrap();
    let xs: Vec<f32> = (0..50_000).map(|_| noise.sample(&mut rng) as f32).collect();
    let n = xs.len() as f64;
    let mean_ref = xs.iter().map(|x| *x as f64).sum::<f64>() / n;
    let var_ref = xs
        .iter()
        .map(|x| (*x as f64 - mean_ref).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let mut w = Welford::new();
    for x in &xs {
        w.push(*x).unwrap();
    }
    // f32 spacing near 1234 is 1.2e-4; the sampling error is 0.7/√5e4 ≈ 3e-3.
    assert!((w.mean().unwrap() as f64 - mean_ref).abs() < 2e-4);
    assert!((w.variance().unwrap() as f64 - var_ref).abs() / var_ref < 1e-4);
}

#[test]
fn merge_equals_pushing_everything() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // Two chunks with different levels (so different shifts) and sizes.
    let a = raw_counts(&mut rng, 30_000, [32_777.0, 32_459.4, 32_511.8], 27.0);
    let b = raw_counts(&mut rng, 7_000, [32_790.0, 32_440.0, 32_530.0], 27.0);
    let all: Vec<[f32; 3]> = a.iter().chain(b.iter()).copied().collect();
    let (mean_ref, var_ref) = two_pass(&all);
    let (mut wa, mut wb) = (Welford3::new(), Welford3::new());
    a.iter().for_each(|x| wa.push(*x).unwrap());
    b.iter().for_each(|x| wb.push(*x).unwrap());
    let mut merged = wa;
    merged.merge(&wb).unwrap();
    assert_eq!(merged.count(), 37_000);
    let (m, v) = (merged.mean().unwrap(), merged.variance().unwrap());
    for i in 0..3 {
        // Standard error here is 27/√37000 ≈ 0.14; f32 grid spacing near 32 500 is 0.004.
        assert!((m[i] as f64 - mean_ref[i]).abs() < 0.004, "axis {i}");
        assert!(
            (v[i] as f64 - var_ref[i]).abs() / var_ref[i] < 1e-4,
            "axis {i}"
        );
    }
    // Merging into / from an empty accumulator is the identity.
    let mut empty = Welford3::new();
    empty.merge(&wa).unwrap();
    assert_eq!(empty, wa);
    let before = wa;
    wa.merge(&Welford3::new()).unwrap();
    assert_eq!(wa, before);
    // Reset forgets everything.
    wa.reset();
    assert_eq!(wa, Welford3::new());
}

#[test]
fn non_finite_sample_is_refused_and_leaves_accumulator_unchanged() {
    let mut w = Welford3::new();
    w.push([1.0, 2.0, 3.0]).unwrap();
    w.push([2.0, 3.0, 5.0]).unwrap();
    let before = w;
    for bad in [
        [f32::NAN, 0.0, 0.0],
        [0.0, f32::INFINITY, 0.0],
        [0.0, 0.0, f32::NEG_INFINITY],
    ] {
        assert_eq!(w.push(bad), Err(Error::NonFinite));
        assert_eq!(w, before);
    }
    let mut s = Welford::new();
    assert_eq!(s.push(f32::NAN), Err(Error::NonFinite));
    assert_eq!(s.count(), 0);
}

proptest! {
    /// Arbitrary f32 data (NaN, ±inf, huge magnitudes included) never panics; whatever is
    /// accepted yields finite statistics.
    #[test]
    fn welford3_never_panics(data in prop::collection::vec(prop::array::uniform3(any::<f32>()), 0..40)) {
        let mut w = Welford3::new();
        for x in &data {
            let _ = w.push(*x);
        }
        if let Ok(m) = w.mean() {
            prop_assert!(m.iter().all(|v| v.is_finite()));
        }
        if let Ok(v) = w.variance() {
            prop_assert!(v.iter().all(|v| v.is_finite()));
        }
        let mut other = w;
        let _ = other.merge(&w);
    }

    #[test]
    fn constant_kalman_never_panics(
        x0 in any::<f32>(), p0 in any::<f32>(), s2 in any::<f32>(),
        ys in prop::collection::vec(any::<f32>(), 0..30),
    ) {
        if let Ok(mut k) = ConstantKalman::new(x0, p0, s2) {
            for y in ys {
                if k.update(y).is_ok() {
                    prop_assert!(k.estimate().is_finite() && k.variance().is_finite());
                }
            }
        }
    }
}

// ---------------------------------------------------------------- ConstantKalman

/// The appendix recursion in f64, unshifted, exactly as printed.
struct ScalarRef {
    x: f64,
    p: f64,
    s2: f64,
}

impl ScalarRef {
    fn update(&mut self, y: f64) {
        let k = self.p / (self.s2 + self.p);
        self.x = (1.0 - k) * self.x + k * y;
        self.p = (1.0 - k).powi(2) * self.p + self.s2 * k * k;
    }
}

#[test]
fn constant_kalman_follows_the_appendix_recursion_in_f64() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let noise = Normal::new(0.0, 2.0).unwrap();
    let (x0, p0, s2) = (128.0f32, 4.0f32, 4.0f32);
    let mut k = ConstantKalman::new(x0, p0, s2).unwrap();
    let mut r = ScalarRef {
        x: x0 as f64,
        p: p0 as f64,
        s2: s2 as f64,
    };
    for step in 0..10_000 {
        let y = (153.3 + noise.sample(&mut rng)) as f32;
        let est = k.update(y).unwrap();
        r.update(y as f64);
        // The estimate is an average of values ~150 (f32 spacing 1.5e-5); measured drift
        // from f64 ≤ 5e-6 over 10⁴ steps: allow 1e-4, ~1/200 of the final sd √p ≈ 0.02.
        assert!(
            (est as f64 - r.x).abs() < 1e-4,
            "step {step}: {est} vs {}",
            r.x
        );
        // p_{k+1} = f(p_k) with f' = (1 − K)² ≈ 1 − 2/k, so per-step rounding (~1e-7
        // relative) is barely damped and accumulates: measured 4e-5 at 10⁴ steps; allow 1e-4.
        assert!(
            (k.variance() as f64 - r.p).abs() <= 1e-4 * r.p,
            "step {step}"
        );
    }
    assert_eq!(k.count(), 10_000);
    // Closed form: p_n = 1/(1/p0 + n/σ²).
    let pn = 1.0 / (1.0 / 4.0 + 10_000.0 / 4.0);
    assert!((k.variance() as f64 - pn).abs() < 1e-4 * pn);
}

#[test]
fn constant_kalman_with_large_p0_is_the_running_mean() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let xs = raw_counts(&mut rng, 100_000, [33_102.3, 33_330.6, 36_433.8], 3.0);
    let mut k = ConstantKalman::new(0.0, 1e30, 9.0).unwrap();
    let mut sum = 0.0f64;
    for (n, x) in xs.iter().enumerate() {
        let est = k.update(x[2]).unwrap();
        sum += x[2] as f64;
        let mean = sum / (n + 1) as f64;
        // Same budget as the Welford test: the running mean to 0.003 count (1/3 of the
        // final standard error, < 1 f32 spacing near 36 000 plus accumulated rounding).
        assert!((est as f64 - mean).abs() < MEAN_TOL_COUNTS, "n={n}");
    }
    // And its variance is σ²/n (accumulated rounding of p, see above: allow 3e-4 relative
    // after 10⁵ steps).
    assert!((k.variance() as f64 - 9.0 / 1e5).abs() < 3e-4 * 9.0 / 1e5);
}

#[test]
fn constant_kalman3_with_diagonal_p0_r_equals_three_scalar_filters() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let xs = raw_counts(&mut rng, 5_000, [153.3, 127.2, 130.0], 1.5);
    let x0 = [128.0, 128.0, 128.0];
    let p0 = [50.0, 20.0, 1e4];
    let s2 = [2.25, 1.0, 4.0];
    let mut m = ConstantKalman3::new(x0, p0, s2).unwrap();
    let mut s: Vec<ConstantKalman> = (0..3)
        .map(|i| ConstantKalman::new(x0[i], p0[i], s2[i]).unwrap())
        .collect();
    for x in &xs {
        let e = m.update(*x).unwrap();
        let p = m.covariance();
        for i in 0..3 {
            let ei = s[i].update(x[i]).unwrap();
            // The Cholesky solve of a diagonal R + P (p/√s/√s) differs from the scalar
            // p/(σ² + p) by a few f32 ulps; the estimates near 150 then agree to a few
            // spacings (1.5e-5).
            assert!(
                (e[i] - ei).abs() <= 8.0 * f32::EPSILON * ei.abs(),
                "{e:?} vs {ei}"
            );
            let pi = s[i].variance();
            assert!((p[(i, i)] - pi).abs() <= 1e-5 * pi);
            for j in 0..3 {
                if i != j {
                    assert_eq!(p[(i, j)], 0.0, "P stays diagonal");
                }
            }
        }
    }
}

#[test]
fn constant_kalman3_converges_to_the_arithmetic_mean() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    // The seed's acquisition: ~10 000 samples of one pose.
    let xs = raw_counts(&mut rng, 10_000, [33_102.3, 33_330.6, 36_433.8], 3.0);
    let (mean_ref, _) = two_pass(&xs);
    let mut k = ConstantKalman3::new([0.0; 3], [1e30; 3], [9.0; 3]).unwrap();
    for x in &xs {
        k.update(*x).unwrap();
    }
    let e = k.estimate();
    for i in 0..3 {
        assert!(
            (e[i] as f64 - mean_ref[i]).abs() < MEAN_TOL_COUNTS,
            "axis {i}"
        );
        let p = k.covariance()[(i, i)] as f64;
        assert!((p - 9.0 / 1e4).abs() < 3e-4 * 9.0 / 1e4);
    }
}

/// Consistency: draw the true constant from the prior N(x0, p0) and the noise from
/// N(0, σ²); the error after k updates has variance p_k, so mean(e²/p_k) over many runs is
/// 1 (χ²(1) has variance 2, so the mean of 4000 runs has sd 0.022: accept ±0.1, > 4 sd).
#[test]
fn constant_kalman_error_matches_reported_variance() {
    let runs = 4000;
    let (x0, p0, s2) = (100.0f32, 25.0f32, 4.0f32);
    let checkpoints = [1usize, 3, 10, 100, 1000];
    let mut sums = [0.0f64; 5];
    let mut sums3 = [0.0f64; 5];
    let prior = Normal::new(x0 as f64, (p0 as f64).sqrt()).unwrap();
    let noise = Normal::new(0.0, (s2 as f64).sqrt()).unwrap();
    for run in 0..runs {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + run);
        let truth = prior.sample(&mut rng);
        let truth3 = [truth, prior.sample(&mut rng), prior.sample(&mut rng)];
        let mut k = ConstantKalman::new(x0, p0, s2).unwrap();
        let mut k3 = ConstantKalman3::new([x0; 3], [p0; 3], [s2; 3]).unwrap();
        let mut c = 0;
        for step in 1..=1000 {
            let y = (truth + noise.sample(&mut rng)) as f32;
            k.update(y).unwrap();
            let y3 = truth3.map(|t| (t + noise.sample(&mut rng)) as f32);
            k3.update(y3).unwrap();
            if checkpoints.get(c) == Some(&step) {
                let e = k.estimate() as f64 - truth;
                sums[c] += e * e / k.variance() as f64;
                let est3 = k3.estimate();
                let p3 = k3.covariance();
                for i in 0..3 {
                    let e = est3[i] as f64 - truth3[i];
                    sums3[c] += e * e / p3[(i, i)] as f64;
                }
                c += 1;
            }
        }
    }
    for c in 0..checkpoints.len() {
        let nees = sums[c] / runs as f64;
        let nees3 = sums3[c] / (3 * runs) as f64;
        assert!((nees - 1.0).abs() < 0.1, "k={}: {nees}", checkpoints[c]);
        // 3 axes per run: the mean of 12 000 χ²(1) has sd 0.013.
        assert!((nees3 - 1.0).abs() < 0.06, "k={}: {nees3}", checkpoints[c]);
    }
}

#[test]
fn constant_kalman_validates_parameters_and_input() {
    assert_eq!(
        ConstantKalman::new(0.0, -1.0, 1.0),
        Err(Error::InvalidParameter)
    );
    assert_eq!(
        ConstantKalman::new(0.0, 1.0, 0.0),
        Err(Error::InvalidParameter)
    );
    assert_eq!(
        ConstantKalman::new(f32::NAN, 1.0, 1.0),
        Err(Error::NonFinite)
    );
    assert_eq!(
        ConstantKalman::new(0.0, f32::INFINITY, 1.0),
        Err(Error::NonFinite)
    );
    assert_eq!(
        ConstantKalman3::new([0.0; 3], [1.0, -1.0, 1.0], [1.0; 3]),
        Err(Error::InvalidParameter)
    );
    assert_eq!(
        ConstantKalman3::new([0.0; 3], [1.0; 3], [1.0, 1.0, 0.0]),
        Err(Error::InvalidParameter)
    );
    let mut k = ConstantKalman::new(0.0, 1.0, 1.0).unwrap();
    k.update(2.0).unwrap();
    let before = k;
    assert_eq!(k.update(f32::NAN), Err(Error::NonFinite));
    assert_eq!(k, before);
    let mut k3 = ConstantKalman3::new([0.0; 3], [1.0; 3], [1.0; 3]).unwrap();
    k3.update([1.0, 2.0, 3.0]).unwrap();
    let before = k3;
    assert_eq!(k3.update([1.0, f32::INFINITY, 3.0]), Err(Error::NonFinite));
    assert_eq!(k3, before);
}

// ---------------------------------------------------------------- offset, simulated

#[test]
fn accel_offset_recovers_known_offsets_for_every_orientation() {
    let counts_per_g = 3980.0;
    // Nominal zero-g levels, ~100 counts from the truth (as a datasheet value would be).
    let zero_g = [33_000.0f32, 33_200.0, 32_500.0];
    let bias = [33_120.4, 33_279.7, 32_360.2];
    let sd = 3.0;
    let n = 2000;
    // 4 standard errors of the mean, 4·3/√2000 ≈ 0.27 count, plus the 0.5 count the
    // integer rounding of each sample can bias a pose whose mean sits between counts (it
    // averages out with noise sd 3 ≫ 1 count, so this is generous).
    let tol = 4.0 * sd / (n as f64).sqrt() + 0.05;
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for axis in 0..3 {
        for up in [true, false] {
            let mut centre = bias;
            let sign = if up { 1.0 } else { -1.0 };
            centre[axis] += sign * counts_per_g;
            let xs = raw_counts(&mut rng, n, centre, sd);
            let cfg = AccelOffsetConfig {
                counts_per_g: counts_per_g as f32,
                zero_g,
                range: Some(RawRange {
                    min: 0.0,
                    max: 65_535.0,
                }),
                min_samples: 256,
            };
            let r = accel_offset(xs.iter().copied(), &cfg).unwrap();
            assert_eq!(r.vertical.axis as usize, axis);
            assert_eq!(r.vertical.up, up);
            assert_eq!(r.count, n as u32);
            for i in 0..3 {
                assert!(
                    (r.offset[i] as f64 - bias[i]).abs() < tol,
                    "axis {axis} up {up}: {:?}",
                    r.offset
                );
                assert!((r.std_dev[i] as f64 - sd).abs() < 0.3);
            }
            // The calibration maps the still reading to ±1 g on the vertical axis.
            let cal = r.calibration();
            let g = cal.correct_linear(r.mean);
            for (i, gi) in g.iter().enumerate() {
                let want = if i == axis { sign } else { 0.0 };
                assert!((*gi as f64 - want).abs() < 1e-4, "{g:?}");
            }
        }
    }
}

#[test]
fn accel_offset_signed_sensor_like_the_seed() {
    // MPU-9250 at ±2 g: 16384 LSB/g, signed, z up, offsets of a few hundred LSB.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let bias = [-312.0, 145.0, 520.0];
    let xs = raw_counts(&mut rng, 256, [bias[0], bias[1], bias[2] + 16_384.0], 8.0);
    let r = accel_offset(xs, &AccelOffsetConfig::signed(16_384.0)).unwrap();
    assert_eq!((r.vertical.axis, r.vertical.up), (2, true));
    for i in 0..3 {
        // 4 standard errors: 4·8/√256 = 2 LSB.
        assert!((r.offset[i] as f64 - bias[i]).abs() < 2.0, "{:?}", r.offset);
    }
}

#[test]
fn accel_offset_refuses_bad_sets() {
    let cfg = AccelOffsetConfig::signed(1000.0);
    // Tilted 45° between x and z: no axis reaches 0.9 g.
    let tilted = vec![[707.0f32, 0.0, 707.0]; 300];
    assert_eq!(
        accel_offset(tilted, &cfg).unwrap_err(),
        Error::NoVerticalAxis
    );
    // Just above / below the 0.9 g threshold.
    assert!(accel_offset(vec![[0.0f32, 0.0, -901.0]; 300], &cfg).is_ok());
    assert_eq!(
        accel_offset(vec![[0.0f32, 0.0, 899.0]; 300], &cfg).unwrap_err(),
        Error::NoVerticalAxis
    );
    // Too few samples.
    assert_eq!(
        accel_offset(vec![[0.0f32, 0.0, 1000.0]; 255], &cfg).unwrap_err(),
        Error::TooFewSamples {
            needed: 256,
            got: 255
        }
    );
    let cfg0 = AccelOffsetConfig {
        min_samples: 0,
        ..cfg
    };
    assert_eq!(
        accel_offset(vec![[0.0f32, 0.0, 1000.0]; 1], &cfg0).unwrap_err(),
        Error::TooFewSamples { needed: 2, got: 1 }
    );
    // Saturation at a rail, in the batch and in the streaming form.
    let sat = AccelOffsetConfig {
        range: Some(RawRange {
            min: -2048.0,
            max: 2047.0,
        }),
        ..cfg
    };
    let mut xs = vec![[0.0f32, 0.0, 1000.0]; 300];
    xs[17] = [0.0, 2047.0, 1000.0];
    assert_eq!(
        accel_offset(xs.clone(), &sat).unwrap_err(),
        Error::Saturated
    );
    let mut acc = OffsetAccumulator::new(sat.range);
    let results: Vec<_> = xs.iter().map(|x| acc.push(*x)).collect();
    assert_eq!(results[17], Err(Error::Saturated));
    assert_eq!(acc.saturated_count(), 1);
    assert_eq!(acc.finish_accel(&sat).unwrap_err(), Error::Saturated);
    // Non-finite sample and invalid config.
    xs[17] = [0.0, f32::NAN, 1000.0];
    assert_eq!(accel_offset(xs, &cfg).unwrap_err(), Error::NonFinite);
    let bad = AccelOffsetConfig::signed(-1.0);
    assert_eq!(
        accel_offset(vec![[0.0f32; 3]; 300], &bad).unwrap_err(),
        Error::InvalidParameter
    );
}

#[test]
fn gyro_offset_is_the_mean_at_rest() {
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let bias = [32_777.1, 32_459.4, 32_511.8];
    let xs = raw_counts(&mut rng, 4500, bias, 27.0);
    let (mean_ref, _) = two_pass(&xs);
    let cfg = GyroOffsetConfig {
        scale: [1.0 / 6258.0; 3],
        ..Default::default()
    };
    let r = gyro_offset(xs.iter().copied(), &cfg).unwrap();
    for i in 0..3 {
        assert!((r.offset[i] as f64 - mean_ref[i]).abs() < MEAN_TOL_COUNTS);
        // Against the truth: 4 standard errors, 4·27/√4500 ≈ 1.6 counts.
        assert!((r.offset[i] as f64 - bias[i]).abs() < 1.6);
    }
    // Corrected rest readings are ~0 rad/s.
    let w = r.calibration().correct_linear(r.offset);
    assert!(w.iter().all(|v| v.abs() < 1e-6));
    let one_rad_s = [bias[0] as f32 + 6258.0, bias[1] as f32, bias[2] as f32];
    let w = r.calibration().correct_linear(one_rad_s);
    assert!((w[0] - 1.0).abs() < 1e-3, "{w:?}");
    assert_eq!(
        gyro_offset(xs.iter().copied().take(100), &cfg).unwrap_err(),
        Error::TooFewSamples {
            needed: 256,
            got: 100
        }
    );
}

// ---------------------------------------------------------------- offset, real data

/// Rows `t x y z` of an IMU-TK ASCII file with `t < t_max` seconds.
fn read_imu_tk(name: &str, t_max: f64) -> Vec<[f32; 3]> {
    let path = data_dir().join("imu_tk_xsens").join(name);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut out = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|s| s.parse().expect("number"))
            .collect();
        assert_eq!(v.len(), 4, "bad row in {name}: {line}");
        if v[0] < t_max {
            out.push([v[1] as f32, v[2] as f32, v[3] as f32]);
        }
    }
    out
}

/// The first 45 s of the IMU-TK Xsens recording are an initial rest (SOURCE.md: ~50 s).
const REST_S: f64 = 45.0;

#[test]
fn xsens_initial_rest_gyro_offset() {
    let xs = read_imu_tk("xsens_gyro.mat", REST_S);
    assert!(xs.len() > 4000, "{} rows", xs.len());
    let (mean_ref, var_ref) = two_pass(&xs);
    let cfg = GyroOffsetConfig {
        range: Some(RawRange {
            min: 0.0,
            max: 65_535.0,
        }),
        ..Default::default()
    };
    let r = gyro_offset(xs.iter().copied(), &cfg).unwrap();
    // The authors' nominal gyro offset (calibrate.m, SOURCE.md).
    let nominal = [32_768.0, 32_466.0, 32_485.0];
    for i in 0..3 {
        // Our mean equals the f64 mean of the same samples (f32 spacing near 32 500: 0.004).
        assert!((r.offset[i] as f64 - mean_ref[i]).abs() < MEAN_TOL_COUNTS);
        let sd = var_ref[i].sqrt();
        assert!((r.std_dev[i] as f64 - sd).abs() < 1e-3 * sd);
        // The nominal values are the authors' round settings, not estimated from this
        // segment (they differ from its mean by 9, −7 and 27 counts while the mean's own
        // standard error is 27/√4500 ≈ 0.4), so they can only be expected to agree to
        // within the gyro's per-sample noise: accept 1.5 σ (σ ≈ 27 counts ≈ 0.25 °/s at
        // IMU-TK's 1/6258 rad/s per count). A wrong axis order or a scale/sign slip would be
        // off by hundreds of counts.
        let d = r.offset[i] as f64 - nominal[i];
        assert!(
            d.abs() < 1.5 * sd,
            "axis {i}: {d} counts from nominal (σ {sd})"
        );
    }
}

#[test]
fn xsens_initial_rest_accel_offset_z_up() {
    let xs = read_imu_tk("xsens_acc.mat", REST_S);
    let (mean_ref, _) = two_pass(&xs);
    // SOURCE.md: ±1 g ≈ ±3980 counts; unsigned 16-bit ADC, so 0 g reads ≈ mid-scale.
    let cfg = AccelOffsetConfig {
        counts_per_g: 3980.0,
        zero_g: [32_768.0; 3],
        range: Some(RawRange {
            min: 0.0,
            max: 65_535.0,
        }),
        min_samples: 256,
    };
    let r = accel_offset(xs.iter().copied(), &cfg).unwrap();
    assert_eq!((r.vertical.axis, r.vertical.up), (2, true), "{r:?}");
    let expect = [mean_ref[0], mean_ref[1], mean_ref[2] - 3980.0];
    for i in 0..3 {
        assert!((r.offset[i] as f64 - expect[i]).abs() < MEAN_TOL_COUNTS);
    }
    // Against the authors' nominal accelerometer offsets (33123, 33276, 32360): an
    // offset-only calibration assumes the unit is level and every axis has the common
    // sensitivity. A hand-placed unit is level to ~2° (sin 2°·3980 ≈ 139 counts on the
    // horizontal axes) and the per-axis sensitivity differs from 3980 by a few % (the
    // seed's Wiimote: 24.6–26.0 counts/g, ±3 %; ≈ 120 counts here), so allow 150 counts —
    // still far below the ~4000 counts of a wrong vertical axis or sign.
    let nominal = [33_123.0, 33_276.0, 32_360.0];
    for i in 0..3 {
        let d = r.offset[i] as f64 - nominal[i];
        assert!(d.abs() < 150.0, "axis {i}: {d}");
    }
}

#[test]
fn xsens_streaming_and_merged_halves_agree_with_batch() {
    let xs = read_imu_tk("xsens_gyro.mat", REST_S);
    let batch = gyro_offset(xs.iter().copied(), &GyroOffsetConfig::default()).unwrap();
    let (a, b) = xs.split_at(xs.len() / 3);
    let (mut wa, mut wb) = (Welford3::new(), Welford3::new());
    a.iter().for_each(|x| wa.push(*x).unwrap());
    b.iter().for_each(|x| wb.push(*x).unwrap());
    wa.merge(&wb).unwrap();
    let m = wa.mean().unwrap();
    for i in 0..3 {
        assert!((m[i] - batch.offset[i]).abs() < 0.01);
    }
    // The rest really is static: the two parts' means differ by less than 5 standard errors
    // of their difference (white-noise assumption).
    let ma = {
        let mut w = Welford3::new();
        a.iter().for_each(|x| w.push(*x).unwrap());
        w.mean().unwrap()
    };
    let mb = wb.mean().unwrap();
    for i in 0..3 {
        let se = batch.std_dev[i] * (1.0 / a.len() as f32 + 1.0 / b.len() as f32).sqrt();
        assert!((ma[i] - mb[i]).abs() < 5.0 * se, "axis {i}");
    }
}
