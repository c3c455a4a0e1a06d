//! The samples: the IMU drawn, and every sample of the motion read by it (white noise,
//! rounding to whole counts, the signed 16-bit range).

use nalgebra::{Matrix3, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::imu::{draw_axes, draw_g_sensitivity, rows, AxesDraw, AxesTruth};
use super::path::Seg;
use super::ProtocolSimOptions;

/// A signed 16-bit converter's range, counts.
const ADC: (f64, f64) = (-32768.0, 32767.0);

/// The simulated IMU.
pub(super) struct Imu {
    pub(super) accel: AxesTruth,
    pub(super) gyro: AxesTruth,
    /// g-sensitivity `G`, rad/s per g (row = gyro axis, column = fixture axis of `a`).
    pub(super) g_sensitivity: [[f64; 3]; 3],
}

impl Imu {
    /// Draws the IMU: scale errors of 1–3 %, misalignments of 0.5–1°, an accelerometer bias
    /// of 20–300 counts and a gyro bias of 0.5–3 °/s per axis (signs drawn), and the
    /// g-sensitivity asked for.
    pub(super) fn draw(rng: &mut ChaCha8Rng, o: &ProtocolSimOptions) -> Self {
        let cpg = o.accel_counts_per_g;
        let accel = draw_axes(
            rng,
            &AxesDraw {
                unit: "g",
                counts_per_unit: cpg,
                scale: (0.01, 0.03),
                misalign_deg: (0.5, 1.0),
                bias: (20.0, 300.0),
                noise_counts: o.accel_noise_mg * 1e-3 * cpg,
            },
        );
        let cpd = o.gyro_counts_per_dps;
        let gyro = draw_axes(
            rng,
            &AxesDraw {
                unit: "rad/s",
                counts_per_unit: cpd.to_degrees(),
                scale: (0.01, 0.03),
                misalign_deg: (0.5, 1.0),
                bias: (0.5 * cpd, 3.0 * cpd),
                noise_counts: o.gyro_noise_dps * cpd,
            },
        );
        let g_sensitivity = draw_g_sensitivity(rng, o.g_sensitivity_dps_per_g);
        Self {
            accel,
            gyro,
            g_sensitivity,
        }
    }
}

/// The samples and where each segment's are.
pub(super) struct Readings {
    /// Accelerometer, whole counts.
    pub(super) accel: Vec<[f64; 3]>,
    /// Gyro, whole counts.
    pub(super) gyro: Vec<[f64; 3]>,
    /// Each segment's samples, `first..end` (sample `i` is at `i / fs`).
    pub(super) ranges: Vec<(usize, usize)>,
}

/// The first sample at or after time `t` (s) at `fs` Hz.
fn sample_at(t: f64, fs: f64) -> usize {
    (t * fs - 1e-9).ceil().max(0.0) as usize
}

/// One sensor's reading of `x`: `D·x + b` plus white noise, rounded, within the ADC's range.
fn read(
    d: &Matrix3<f64>,
    b: &Vector3<f64>,
    x: Vector3<f64>,
    noise: f64,
    rng: &mut ChaCha8Rng,
) -> [f64; 3] {
    let clean = d * x + b;
    std::array::from_fn(|j| {
        let z: f64 = StandardNormal.sample(rng);
        (clean[j] + noise * z).round().clamp(ADC.0, ADC.1)
    })
}

/// Every sample of the motion `segs` at `fs` Hz as `imu` reads it: the accelerometer
/// `D_a·a + b_a`, the gyro `D_g·(ω + G·a) + b_g` (module docs of `imu`).
pub(super) fn record(segs: &[Seg], fs: f64, imu: &Imu, rng: &mut ChaCha8Rng) -> Readings {
    let ranges: Vec<(usize, usize)> = segs
        .iter()
        .map(|s| (sample_at(s.t0, fs), sample_at(s.t1(), fs)))
        .collect();
    let n = ranges.last().map_or(0, |r| r.1);
    let (da, ba) = (
        rows(&imu.accel.forward_matrix),
        Vector3::from(imu.accel.bias),
    );
    let (dg, bg) = (rows(&imu.gyro.forward_matrix), Vector3::from(imu.gyro.bias));
    let g = rows(&imu.g_sensitivity);
    let (na, ng) = (imu.accel.noise_std_counts, imu.gyro.noise_std_counts);
    let mut out = Readings {
        accel: Vec::with_capacity(n),
        gyro: Vec::with_capacity(n),
        ranges: Vec::new(),
    };
    for (seg, &(first, end)) in segs.iter().zip(&ranges) {
        for i in first..end {
            let s = seg.state(i as f64 / fs);
            out.accel.push(read(&da, &ba, s.accel, na, rng));
            out.gyro
                .push(read(&dg, &bg, s.omega + g * s.accel, ng, rng));
        }
    }
    out.ranges = ranges;
    out
}
