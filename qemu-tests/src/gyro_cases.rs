//! The gyro's correction with its g-sensitivity (`wiical_core::gyro_correct`) as a test vector:
//! included by `cases.rs` (so compiled for the target and, through the build script, for the
//! host), and used by the benchmark ([`crate::gyro_bench`]).

use super::{Error, Out};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Real;

/// An MPU-like gyro: 16.4 counts per °/s (1.0642e-3 rad/s per count), a few per mille of
/// scale error and misalignment, a bias of tens of counts, and a g-sensitivity of
/// 0.02–0.17 °/s/g (rad/s/g below), the size datasheets give for consumer MEMS gyros.
pub fn gyro_calibration() -> GyroCorrection<f32> {
    let s = 1.0642e-3f32;
    GyroCorrection {
        bias: [-31.0, 12.5, 7.25],
        matrix: [
            [s, 2e-3 * s, -1e-3 * s],
            [-1.5e-3 * s, 1.01 * s, 3e-3 * s],
            [0.5e-3 * s, -2e-3 * s, -0.99 * s],
        ],
        effects: wiical_core::gyro_correct::GyroEffects {
            g_sensitivity: [
                [1.7e-3, -3.5e-4, 8.7e-4],
                [1.7e-4, -2.1e-3, 5.2e-4],
                [-7.0e-4, 3.5e-4, 2.9e-3],
            ],
        },
    }
}

/// Raw gyro sample `i` (counts, from integers) and the specific force beside it (g: a unit
/// direction from `libm`, scaled by 0.9–1.1 for motion).
pub fn gyro_sample(i: u32) -> ([f32; 3], [f32; 3]) {
    let m = [
        (i as f32) * 37.0 - 900.0,
        400.0 - (i as f32) * 11.0,
        ((i * i) % 1500) as f32 - 700.0,
    ];
    let (th, ph) = (0.37 * i as f32, 0.23 * i as f32 + 0.1);
    let r = 0.9 + 0.0125 * (i % 17) as f32;
    let a = [
        r * libm::sinf(th) * libm::cosf(ph),
        r * libm::sinf(th) * libm::sinf(ph),
        r * libm::cosf(th),
    ];
    (m, a)
}

/// Samples in the vector.
const N: u32 = 24;

/// Largest accepted `|ω_f32 − ω_f64| / (ε_f32 · Σ|terms|)` per axis: each output is two
/// three-term dot products and a difference, 7 roundings of at most ½ ulp of a partial sum
/// bounded by `Σ|terms|`, so 4 is the rounding bound (the usual `n·ε` bound for the sums).
pub const F64_TOLERANCE: f64 = 4.0;

/// `GyroCorrection::correct` (f32) of [`N`] samples, each checked against the same
/// correction in `f64` of the same parameters (the analysis's instantiation) within
/// [`F64_TOLERANCE`]; records the f32 results, then the worst ratio found. The target must
/// match the host bit for bit.
pub fn gyro_correct_g_sensitivity(o: &mut Out) -> Result<(), Error> {
    let c32 = gyro_calibration();
    let c64 = c32.cast(f64::from_f32);
    let mut worst = 0.0f64;
    for i in 0..N {
        let (m, a) = gyro_sample(i);
        let w32 = c32.correct(m, a);
        let w64 = c64.correct(m.map(f64::from), a.map(f64::from));
        for r in 0..3 {
            let mut mag = 0.0;
            for j in 0..3 {
                mag += libm::fabs(c64.matrix[r][j] * (f64::from(m[j]) - c64.bias[j]));
                mag += libm::fabs(c64.effects.g_sensitivity[r][j] * f64::from(a[j]));
            }
            let ratio = libm::fabs(f64::from(w32[r]) - w64[r]) / (f64::from(f32::EPSILON) * mag);
            worst = worst.max(ratio);
        }
        o.extend(&w32)?;
    }
    if worst > F64_TOLERANCE {
        return Err(Error::NotConverged);
    }
    o.push(worst as f32)
}
