//! Test vectors shared by the host and the emulated Cortex-M33.
//!
//! Each case runs core code on deterministic inputs (the same inputs as the desktop tests
//! and benchmarks: the seed's six-position matrix, the benchmark's 30-pose set, …, and two
//! real recordings) and records its results as a flat list of `f32`. The build script runs
//! these very functions on the host and writes the results, bit for bit, to `expected.rs`;
//! the `qemu-tests` binary runs them on the target and compares. Synthetic inputs are built
//! with integer arithmetic and `libm` only, so that both sides start from identical bits;
//! the real recordings reach both sides through `crate::real_data` (the build script reads
//! them and hands the target the same `f32` bits, see `build.rs`).
//!
//! This file is compiled twice: as a module of the `qemu-tests` library (thumbv8m) and,
//! through `#[path]`, as a module of the build script (host). Each of the two crates
//! provides its own `real_data` module with the same functions. It must stay
//! `no_std`-clean.

use crate::real_data;
use wiical_adapter::{Corrector, EmulatedNunchuk, IdealScale, NunchukInfo};
use wiical_core::estimators::{ConstantKalman, ConstantKalman3, Welford, Welford3};
use wiical_core::kalman::{PvbConfig, PvbFilter};
use wiical_core::magfit::{AxisEllipsoidFit, EllipsoidFit, MagFit, SphereFit};
use wiical_core::multipos::{self, MultiPosConfig, MultiPosModel};
use wiical_core::static_detect::{adaptive, StaticDetector, StaticDetectorConfig};
use wiical_core::{six_position, Calibration, Conditions, Error, Mat3, Vec3};
use wiical_extbus::nunchuk::StickAxisCalibration;
use wiical_extbus::{
    CalibrationBlock, CalibrationCopy, Encryption, NunchukRegisters, NunchukReport,
};

#[path = "gyro_cases.rs"]
pub mod gyro_cases;

/// Capacity of one case's result list.
pub const MAX_OUT: usize = 320;

/// A case's results, in the order the case records them.
pub struct Out {
    vals: [f32; MAX_OUT],
    len: usize,
}

impl Default for Out {
    fn default() -> Self {
        Self::new()
    }
}

impl Out {
    /// An empty result list.
    pub const fn new() -> Self {
        Self {
            vals: [0.0; MAX_OUT],
            len: 0,
        }
    }

    /// Records one value. Overflowing the capacity is a bug in a case: reported as an error.
    pub fn push(&mut self, v: f32) -> Result<(), Error> {
        let slot = self.vals.get_mut(self.len).ok_or(Error::CapacityExceeded)?;
        *slot = v;
        self.len += 1;
        Ok(())
    }

    /// Records several values.
    pub fn extend(&mut self, vs: &[f32]) -> Result<(), Error> {
        vs.iter().try_for_each(|v| self.push(*v))
    }

    /// The values recorded so far.
    pub fn as_slice(&self) -> &[f32] {
        &self.vals[..self.len]
    }
}

/// One test vector: a name and the function producing its results.
pub struct Case {
    /// Stable name, the key in `expected.rs`.
    pub name: &'static str,
    /// Largest accepted distance from the host's value, in units in the last place. 0 where
    /// host and target execute the same IEEE-754 operations in the same order.
    pub max_ulps: u32,
    /// Runs the case.
    pub run: fn(&mut Out) -> Result<(), Error>,
}

/// All cases, in the order they run and print.
pub const CASES: &[Case] = &[
    Case {
        name: "six_position_seed",
        max_ulps: 0,
        run: six_position_seed,
    },
    Case {
        name: "correct_linear",
        max_ulps: 0,
        run: correct_linear,
    },
    Case {
        name: "correct_with_effects",
        max_ulps: 0,
        run: correct_with_effects,
    },
    Case {
        name: "correct_with_cross_terms",
        max_ulps: 0,
        run: correct_with_cross_terms,
    },
    Case {
        name: "multipos_30_poses",
        max_ulps: 4,
        run: multipos_30,
    },
    Case {
        name: "multipos_diagonal_12_poses",
        max_ulps: 4,
        run: multipos_diagonal_12,
    },
    Case {
        name: "magfit_sphere",
        max_ulps: 4,
        run: magfit_sphere,
    },
    Case {
        name: "magfit_axis",
        max_ulps: 4,
        run: magfit_axis,
    },
    Case {
        name: "magfit_ellipsoid",
        max_ulps: 4,
        run: magfit_ellipsoid,
    },
    Case {
        name: "kalman_pvb_200_steps",
        max_ulps: 0,
        run: kalman_pvb,
    },
    Case {
        name: "static_detector",
        max_ulps: 0,
        run: static_detector,
    },
    Case {
        name: "adaptive_detector_and_fit",
        max_ulps: 4,
        run: adaptive_detector_and_fit,
    },
    Case {
        name: "welford",
        max_ulps: 0,
        run: welford,
    },
    Case {
        name: "constant_kalman",
        max_ulps: 0,
        run: constant_kalman,
    },
    Case {
        name: "nunchuk_register_read_path",
        max_ulps: 0,
        run: register_read_path,
    },
    Case {
        name: "adapter_corrector_calibrated",
        max_ulps: 0,
        run: adapter_corrector_calibrated,
    },
    Case {
        name: "adapter_corrector_cross_terms",
        max_ulps: 0,
        run: adapter_corrector_cross_terms,
    },
    Case {
        name: "adapter_corrector_pass_through",
        max_ulps: 0,
        run: adapter_corrector_pass_through,
    },
    Case {
        name: "adapter_emulated_nunchuk_reads",
        max_ulps: 0,
        run: adapter_emulated_reads,
    },
    Case {
        name: "xsens_static_detector",
        max_ulps: 0,
        run: xsens_static_detector,
    },
    Case {
        name: "gyro_motion_integration",
        max_ulps: 4,
        run: gyro_motion_integration,
    },
    Case {
        name: "gyro_zero_rate_tracker",
        max_ulps: 0,
        run: gyro_zero_rate_tracker,
    },
    Case {
        name: "xsens_multipos_fit",
        max_ulps: 4,
        run: xsens_multipos_fit,
    },
    Case {
        name: "gyro_correct_g_sensitivity",
        max_ulps: 0,
        run: gyro_cases::gyro_correct_g_sensitivity,
    },
    Case {
        name: "mag_out_ellipsoid_fit",
        max_ulps: 4,
        run: mag_out_ellipsoid_fit,
    },
];

/// Distance between two `f32` in units in the last place (`u32::MAX` when exactly one is
/// NaN; NaNs compare equal to NaNs, +0 equals −0).
pub fn ulp_distance(a: f32, b: f32) -> u32 {
    if a.is_nan() || b.is_nan() {
        return if a.is_nan() && b.is_nan() {
            0
        } else {
            u32::MAX
        };
    }
    // Map the sign-magnitude bit patterns onto a monotonic integer line.
    let key = |x: f32| -> i64 {
        let bits = x.to_bits();
        if bits & 0x8000_0000 != 0 {
            -i64::from(bits & 0x7FFF_FFFF)
        } else {
            i64::from(bits)
        }
    };
    let d = (key(a) - key(b)).unsigned_abs();
    u32::try_from(d).unwrap_or(u32::MAX)
}

// ---------------------------------------------------------------------------------------
// Deterministic inputs (integer arithmetic and libm only).

/// Golden-angle spiral of `n` unit vectors, direction `k` (as in `crates/core/benches`).
pub fn direction(k: usize, n: usize) -> [f32; 3] {
    let z = -1.0 + 2.0 * (k as f32 + 0.5) / n as f32;
    let r = libm::sqrtf(1.0 - z * z);
    let th = k as f32 * 2.399_963;
    [r * libm::cosf(th), r * libm::sinf(th), z]
}

/// A Wii-Remote-like forward model `m = D·a + b` (10-bit counts), as in the benchmarks.
pub fn wiimote_model() -> (Mat3, Vec3) {
    let d = Mat3::new(106.0, -0.8, 1.1, 0.4, 104.5, -0.6, -0.3, 0.5, 110.2);
    let b = Vec3::new(521.3, 519.8, 524.6);
    (d, b)
}

/// The benchmark's pose `i` of `n`: the model applied to a spiral direction plus a small
/// deterministic error, so that the fit has a non-zero residual.
pub fn pose(i: usize, n: usize) -> [f32; 3] {
    let (d, b) = wiimote_model();
    let a = direction(i, n);
    let m = d * Vec3::new(a[0], a[1], a[2]) + b;
    let e = ((i * 7919) % 13) as f32 * 0.01 - 0.06;
    [m.x + e, m.y - e, m.z + 0.5 * e]
}

/// The 30-pose set of the benchmarks and `qemu-bench`.
pub fn poses30() -> [[f32; 3]; 30] {
    core::array::from_fn(|i| pose(i, 30))
}

/// Point `k` of `n` on a rotated, offset ellipsoid in raw counts (QMC5883L-like
/// magnitudes, as in the benchmarks).
pub fn mag_point(k: usize, n: usize) -> [f32; 3] {
    let u = direction(k, n);
    [
        6150.0 + 750.0 * u[0] + 30.0 * u[1],
        250.0 + 1030.0 * u[1] - 20.0 * u[2],
        3440.0 + 1620.0 * u[2] + 10.0 * u[0],
    ]
}

/// A small xorshift32 generator for reproducible "noise" (bits identical everywhere).
pub struct XorShift(u32);

impl XorShift {
    /// Seeded generator (seed ≠ 0).
    pub const fn new(seed: u32) -> Self {
        Self(if seed == 0 { 0x9E37_79B9 } else { seed })
    }

    /// Next value uniform in `[-1, 1)`, quantised to 2⁻²³.
    pub fn next_f32(&mut self) -> f32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        ((x >> 8) as f32) * (1.0 / 8_388_608.0) - 1.0
    }
}

/// The seed's measurement matrix M (Kalman-filtered pose means, 8-bit counts), by pose
/// `x+ x− y+ y− z+ z−` (`crates/core/src/six_position.rs`).
pub const SEED_M: [[f32; 3]; 6] = [
    [153.329, 127.181, 129.991],
    [102.978, 127.989, 129.991],
    [128.072, 153.248, 129.586],
    [127.989, 101.200, 128.992],
    [127.989, 127.989, 154.179],
    [127.989, 127.183, 105.012],
];

/// A sample calibration (the Wii-Remote-like model inverted).
pub fn wiimote_calibration() -> Result<Calibration, Error> {
    let (d, b) = wiimote_model();
    Calibration::from_forward(&d, &b)
}

/// Raw samples for the correction cases.
pub const SAMPLES: [[f32; 3]; 8] = [
    [600.0, 480.0, 530.0],
    [521.3, 519.8, 524.6],
    [627.0, 519.0, 524.0],
    [415.0, 521.0, 525.0],
    [521.0, 624.0, 526.0],
    [522.0, 415.0, 523.0],
    [520.0, 520.0, 635.0],
    [1023.0, 0.0, 512.0],
];

// ---------------------------------------------------------------------------------------
// Cases.

fn six_position_seed(o: &mut Out) -> Result<(), Error> {
    let fit = six_position::solve(&SEED_M)?;
    for row in &fit.t_hat {
        o.extend(row)?;
    }
    for row in &fit.d_inv {
        o.extend(row)?;
    }
    for row in &fit.residual {
        o.extend(row)?;
    }
    Ok(())
}

fn correct_linear(o: &mut Out) -> Result<(), Error> {
    let cal = wiimote_calibration()?;
    for row in &cal.matrix {
        o.extend(row)?;
    }
    for s in SAMPLES {
        o.extend(&cal.correct_linear(s))?;
    }
    Ok(())
}

fn correct_with_effects(o: &mut Out) -> Result<(), Error> {
    let mut cal = wiimote_calibration()?;
    cal.effects.quadratic = [0.01, -0.02, 0.005];
    cal.effects.cubic = [-0.003, 0.002, 0.001];
    cal.effects.bias_drift = [0.01, -0.02, 0.0];
    cal.effects.temp_ref_c = 25.0;
    cal.effects.bias_temp = [0.1, 0.0, -0.05];
    cal.effects.scale_temp = [1e-4, -2e-4, 0.0];
    correct_both_paths(o, &cal)
}

/// [`Calibration::correct`] and [`wiical_core::PreparedCalibration::correct`] of every sample,
/// with time and temperature conditions: both on the target, compared with the host's.
fn correct_both_paths(o: &mut Out, cal: &Calibration) -> Result<(), Error> {
    let prepared = cal.prepare();
    for (i, s) in SAMPLES.iter().enumerate() {
        let cond = Conditions {
            time_s: 3.5 * i as f32,
            temperature_c: Some(20.0 + 2.0 * i as f32),
        };
        o.extend(&cal.correct(*s, &cond))?;
        o.extend(&prepared.correct(*s, &cond))?;
    }
    Ok(())
}

/// Orientation-dependent cross terms: every coefficient distinct and non-zero,
/// of the sizes a real sensor could have (≤ 2 %/g²).
pub const CROSS_QUADRATIC: [[f32; 5]; 3] = [
    [0.004, -0.003, 0.002, -0.0015, 0.001],
    [-0.0025, 0.0035, -0.001, 0.0005, -0.002],
    [0.003, 0.0012, -0.004, 0.0022, -0.0008],
];

/// See [`CROSS_QUADRATIC`].
pub const CROSS_CUBIC: [[f32; 9]; 3] = [
    [
        0.002, -0.001, 0.0015, -0.0005, 0.0007, -0.0012, 0.0009, -0.0003, 0.0011,
    ],
    [
        -0.0014, 0.0006, -0.0009, 0.0013, -0.0002, 0.0008, -0.0016, 0.0004, -0.0007,
    ],
    [
        0.0005, -0.0018, 0.0012, -0.0006, 0.001, -0.0004, 0.0017, -0.0011, 0.0003,
    ],
];

fn correct_with_cross_terms(o: &mut Out) -> Result<(), Error> {
    let mut cal = wiimote_calibration()?;
    cal.effects.quadratic = [0.01, -0.02, 0.005];
    cal.effects.cubic = [-0.003, 0.002, 0.001];
    cal.effects.cross_quadratic = CROSS_QUADRATIC;
    cal.effects.cross_cubic = CROSS_CUBIC;
    // Acceleration-only (as the adapter corrects), then with time and temperature terms.
    let prepared = cal.prepare();
    for s in SAMPLES {
        o.extend(&cal.correct(s, &Conditions::default()))?;
        o.extend(&prepared.correct(s, &Conditions::default()))?;
    }
    cal.effects.bias_drift = [0.01, -0.02, 0.0];
    cal.effects.temp_ref_c = 25.0;
    cal.effects.bias_temp = [0.1, 0.0, -0.05];
    cal.effects.scale_temp = [1e-4, -2e-4, 0.0];
    correct_both_paths(o, &cal)
}

fn push_multipos(o: &mut Out, fit: &multipos::MultiPosFit) -> Result<(), Error> {
    o.extend(&fit.calibration.bias)?;
    for row in &fit.calibration.matrix {
        o.extend(row)?;
    }
    o.extend(&[
        fit.rms,
        fit.max_abs_residual,
        fit.iterations as f32,
        fit.identifiability,
    ])
}

fn multipos_30(o: &mut Out) -> Result<(), Error> {
    let fit = multipos::fit(&poses30(), &MultiPosConfig::default())?;
    push_multipos(o, &fit)
}

fn multipos_diagonal_12(o: &mut Out) -> Result<(), Error> {
    let poses: [[f32; 3]; 12] = core::array::from_fn(|i| pose(i, 12));
    let cfg = MultiPosConfig {
        model: MultiPosModel::Diagonal,
        ..MultiPosConfig::default()
    };
    let fit = multipos::fit(&poses, &cfg)?;
    push_multipos(o, &fit)
}

const MAG_POINTS: usize = 300;

fn push_mag(o: &mut Out, fit: &MagFit) -> Result<(), Error> {
    o.extend(&fit.center)?;
    for row in &fit.matrix {
        o.extend(row)?;
    }
    o.push(fit.radius)?;
    let q = fit.quality((0..MAG_POINTS).map(|k| mag_point(k, MAG_POINTS)))?;
    o.extend(&[q.fit_error_pct, q.rms_radius_error])
}

fn magfit_sphere(o: &mut Out) -> Result<(), Error> {
    let mut f = SphereFit::new();
    for k in 0..MAG_POINTS {
        f.push(mag_point(k, MAG_POINTS))?;
    }
    push_mag(o, &f.solve()?)
}

fn magfit_axis(o: &mut Out) -> Result<(), Error> {
    let mut f = AxisEllipsoidFit::new();
    for k in 0..MAG_POINTS {
        f.push(mag_point(k, MAG_POINTS))?;
    }
    push_mag(o, &f.solve()?)
}

fn magfit_ellipsoid(o: &mut Out) -> Result<(), Error> {
    let mut f = EllipsoidFit::new();
    for k in 0..MAG_POINTS {
        f.push(mag_point(k, MAG_POINTS))?;
    }
    let fit = f.solve()?;
    push_mag(o, &fit)?;
    o.extend(&fit.semi_axes()?)
}

/// The Kalman demo's configuration (`host/src/kalman_demo.rs`): 100 Hz, σ_a = 0.05 m/s².
pub const PVB_CONFIG: PvbConfig = PvbConfig {
    dt: 0.01,
    accel_noise: 0.05,
    bias_walk: 0.0,
    pos_noise: 0.005,
    initial_state: [0.0; 3],
    initial_std: [0.005, 0.02, 0.5],
};

fn kalman_pvb(o: &mut Out) -> Result<(), Error> {
    // A body at rest measured by an accelerometer with a 0.25 m/s² bias and noise, and a
    // noisy position sensor; the filter should find the bias.
    let mut f = PvbFilter::new(&PVB_CONFIG)?;
    let mut rng = XorShift::new(2008);
    for k in 0..200 {
        f.predict(0.25 + 0.05 * rng.next_f32())?;
        let inn = f.update(0.005 * rng.next_f32())?;
        if k % 40 == 0 {
            o.extend(&[inn.residual, inn.variance])?;
        }
    }
    o.extend(f.state().as_slice())?;
    o.extend(f.covariance().as_slice())
}

/// A 3 s motion (300 samples of a MotionPlus-like 14-bit gyro turning about a slowly moving
/// axis, plus noise) integrated by RK4 with all 12 parameter sensitivities; out: the gravity
/// residual, its 3×12 Jacobian, the angle and the orientation.
fn gyro_motion_integration(o: &mut Out) -> Result<(), Error> {
    use wiical_core::gyro::{Adjustment, GyroCalibration, MotionIntegrator, NPARAM};
    let nominal =
        GyroCalibration::<f32>::nominal([8190.0, 8200.0, 8185.0], [1.2e-3, -1.2e-3, 1.2e-3]);
    let adj = Adjustment {
        p: wiical_core::Mat3::new(1.01, 0.01, -0.02, 0.015, 0.98, 0.01, -0.01, 0.02, 1.02),
        delta: wiical_core::Vec3::new(0.002, -0.001, 0.003),
    };
    let mut m = MotionIntegrator::new(nominal, adj, 0.01, [true; NPARAM])?;
    let mut rng = XorShift::new(13);
    for i in 0..300 {
        let t = i as f32 * 0.01;
        let bump = 1.0 - libm::cosf(core::f32::consts::TAU * t / 3.0);
        m.push(&[
            8190.0 + 600.0 * bump + 2.0 * rng.next_f32(),
            8200.0 - 300.0 * bump * libm::sinf(t) + 2.0 * rng.next_f32(),
            8185.0 + 200.0 * bump + 2.0 * rng.next_f32(),
        ])?;
    }
    let out = m.finish(
        &wiical_core::Vec3::new(0.1, 0.2, 0.97),
        &wiical_core::Vec3::new(0.5, -0.3, 0.8),
    )?;
    o.extend(out.residual.as_slice())?;
    o.extend(out.jacobian.as_slice())?;
    o.push(out.angle)?;
    o.extend(out.rotation.as_slice())
}

/// The zero-rate tracker on 2000 samples: rest, turning, rest with a drifted bias; out: the
/// bias after every update and the number of updates.
fn gyro_zero_rate_tracker(o: &mut Out) -> Result<(), Error> {
    use wiical_core::gyro_zero::{ZeroRateConfig, ZeroRateTracker};
    let cfg = ZeroRateConfig {
        block: 50,
        max_spread: 12.0f32,
        blend: 0.5,
    };
    let mut z = ZeroRateTracker::new(cfg, [8192.0, 8190.0, 8195.0])?;
    let mut rng = XorShift::new(17);
    for i in 0..2000u32 {
        let (moving, drift) = (i % 500 < 150, (i / 500) as f32 * 7.0);
        let turn = if moving {
            400.0 * libm::sinf(i as f32 * 0.05)
        } else {
            0.0
        };
        let m = [
            8192.0 + drift + turn + 1.5 * rng.next_f32(),
            8190.0 - drift + 1.5 * rng.next_f32(),
            8195.0 + 0.5 * drift - turn + 1.5 * rng.next_f32(),
        ];
        if let Some(b) = z.push(m, !moving)? {
            o.extend(&b)?;
        }
    }
    o.push(z.updates() as f32)
}

fn static_detector(o: &mut Out) -> Result<(), Error> {
    // 100 Hz: 2 s rest, then alternating 1 s motion and 2.5 s rest, raw counts with noise.
    let cfg = StaticDetectorConfig::for_rate(100.0, 0.21, 2.0, 1.0);
    let mut det: StaticDetector<21> = StaticDetector::new(cfg)?;
    let mut rng = XorShift::new(7);
    let mut intervals = 0u32;
    let mut record = |o: &mut Out, iv: wiical_core::static_detect::StaticInterval| {
        intervals += 1;
        o.extend(&[iv.start as f32, iv.end as f32])?;
        o.extend(&iv.mean)?;
        o.extend(&iv.variance)
    };
    let levels = [
        [33000.0, 33300.0, 36400.0],
        [36300.0, 33250.0, 33100.0],
        [33050.0, 29900.0, 33200.0],
    ];
    let mut idx = 0u32;
    for (seg, level) in levels.iter().enumerate() {
        let rest = if seg == 0 { 200 } else { 250 };
        for _ in 0..rest {
            let m = [
                level[0] + 3.0 * rng.next_f32(),
                level[1] + 3.0 * rng.next_f32(),
                level[2] + 3.0 * rng.next_f32(),
            ];
            if let Some(iv) = det.push(m)? {
                record(o, iv)?;
            }
            idx += 1;
        }
        for j in 0..100 {
            let ph = j as f32 * 0.0628;
            let m = [
                level[0] + 2000.0 * libm::sinf(ph),
                level[1] - 1500.0 * libm::sinf(2.0 * ph),
                level[2] + 1000.0 * libm::cosf(ph),
            ];
            if let Some(iv) = det.push(m)? {
                record(o, iv)?;
            }
            idx += 1;
        }
    }
    if let Some(iv) = det.finish() {
        record(o, iv)?;
    }
    o.extend(&[intervals as f32, idx as f32])
}

/// Sample `i` of a 100-Hz stream in raw counts that starts with 3 s of motion (no rest period)
/// and then holds 12 orientations for 1 s each, with 0.5-s turns between them: what the
/// adaptive detector is for. A pure function of `i` (noise from a per-sample xorshift), so that
/// the stream can be replayed for the detector's passes.
fn short_hold_sample(i: u32) -> [f32; 3] {
    const DIRS: [[f32; 3]; 12] = [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.6, 0.0, 0.8],
        [0.0, 0.6, -0.8],
        [-0.8, 0.6, 0.0],
        [0.48, -0.6, 0.64],
        [-0.6, -0.48, -0.64],
        [0.8, 0.36, -0.48],
    ];
    let mut rng = XorShift::new(i.wrapping_mul(2_654_435_761).wrapping_add(1));
    let mut noise = || 4.0 * rng.next_f32();
    let raw = |a: [f32; 3]| {
        [
            33000.0 + 4100.0 * a[0],
            33300.0 + 4050.0 * a[1],
            32400.0 + 4000.0 * a[2],
        ]
    };
    if i < 300 {
        let ph = i as f32 * 0.05;
        let m = raw([libm::sinf(ph), libm::cosf(ph), 0.3 * libm::sinf(2.0 * ph)]);
        return [m[0] + noise(), m[1] + noise(), m[2] + noise()];
    }
    let k = (i - 300) / 150;
    let within = (i - 300) % 150;
    let d = DIRS[k as usize % DIRS.len()];
    let a = if within < 100 {
        d
    } else {
        let q = DIRS[(k as usize + 1) % DIRS.len()];
        let t = (within - 100) as f32 / 50.0;
        [0, 1, 2].map(|j| d[j] + (q[j] - d[j]) * t)
    };
    let m = raw(a);
    [m[0] + noise(), m[1] + noise(), m[2] + noise()]
}

/// `static_detect::adaptive::detect_fitted` on [`short_hold_sample`]: noise survey, hold
/// schedule, detector with the measured reference, and the multi-position fit of its windows.
fn adaptive_detector_and_fit(o: &mut Out) -> Result<(), Error> {
    let samples = (0..300 + 12 * 150).map(short_hold_sample);
    let mut scratch = [[0.0f32; 3]; 40];
    let mut intervals = 0u32;
    let mut rec: Result<(), Error> = Ok(());
    let (det, fit) = adaptive::detect_fitted::<101, _>(
        samples,
        100.0,
        12,
        &MultiPosConfig::default(),
        &mut scratch,
        |iv| {
            intervals += 1;
            if rec.is_ok() {
                rec = o
                    .extend(&[iv.start as f32, iv.end as f32])
                    .and_then(|_| o.extend(&iv.mean));
            }
        },
    )?;
    rec?;
    o.extend(&det.thresholds.reference_variance)?;
    o.extend(&[
        det.config.window as f32,
        det.config.min_static_samples as f32,
        intervals as f32,
    ])?;
    push_multipos(o, &fit?)
}

fn welford(o: &mut Out) -> Result<(), Error> {
    let mut w = Welford::new();
    let mut w3 = Welford3::new();
    let mut rng = XorShift::new(99);
    for k in 0..500 {
        let x = 33123.0 + 5.0 * rng.next_f32();
        w.push(x)?;
        w3.push([x, -x * 0.5 + k as f32 * 0.001, 0.1 * rng.next_f32()])?;
    }
    o.extend(&[w.mean()?, w.variance()?, w.std_dev()?])?;
    o.extend(w3.mean()?.as_slice())?;
    o.extend(w3.variance()?.as_slice())
}

fn constant_kalman(o: &mut Out) -> Result<(), Error> {
    let mut k = ConstantKalman::new(0.0, 1e30, 0.04)?;
    let mut k3 = ConstantKalman3::new([128.0; 3], [100.0; 3], [0.25, 0.3, 0.2])?;
    let mut rng = XorShift::new(5);
    for _ in 0..300 {
        k.update(153.3 + 0.2 * rng.next_f32())?;
        k3.update([
            127.2 + 0.5 * rng.next_f32(),
            153.2 + 0.5 * rng.next_f32(),
            105.0 + 0.5 * rng.next_f32(),
        ])?;
    }
    o.extend(&[k.estimate(), k.variance()])?;
    o.extend(k3.estimate().as_slice())?;
    o.extend(k3.covariance().as_slice())
}

/// The adapter's hot path with the extension-bus crate: a raw Nunchuk report is corrected,
/// re-encoded as calibrated 10-bit counts (zero 512, 200 counts/g), stored in the emulated
/// register map, and read back the way a Wii Remote does (pointer write `0x00`, 6-byte read).
pub fn register_read_path(o: &mut Out) -> Result<(), Error> {
    let cal = Calibration {
        bias: [510.0, 514.0, 508.0],
        matrix: [
            [1.0 / 204.0, 0.0001, 0.0],
            [-0.0002, 1.0 / 198.0, 0.0],
            [0.0, 0.0003, 1.0 / 201.0],
        ],
        effects: Default::default(),
    };
    let mut regs = NunchukRegisters::new();
    regs.write(&[0xF0, 0x55]);
    regs.write(&[0xFB, 0x00]);
    let raws: [[u16; 3]; 4] = [
        [512, 512, 712],
        [714, 514, 508],
        [0, 1023, 512],
        [300, 700, 900],
    ];
    for (i, raw) in raws.iter().enumerate() {
        let mut buf = [0u8; 6];
        read_path_step(&cal, &mut regs, *raw, i % 2 == 0, &mut buf);
        for b in buf {
            o.push(f32::from(b))?;
        }
    }
    Ok(())
}

/// One step of [`register_read_path`]: correct `raw`, store, read 6 bytes into `buf`.
#[inline]
pub fn read_path_step(
    cal: &Calibration,
    regs: &mut NunchukRegisters,
    raw: [u16; 3],
    z: bool,
    buf: &mut [u8; 6],
) {
    let a = cal.correct_linear(raw.map(f32::from));
    let counts = a.map(|g| {
        let c = libm::roundf(512.0 + 200.0 * g);
        // Clamp to the 10-bit range; the float-to-int cast saturates and maps NaN to 0.
        c.clamp(0.0, 1023.0) as u16
    });
    let report = NunchukReport {
        stick: [128, 128],
        accel: counts,
        c: false,
        z,
    };
    regs.set_report(&report);
    regs.write(&[0x00]);
    regs.read(buf);
}

// ---------------------------------------------------------------------------------------
// Adapter logic (wiical-adapter): corrector and the Wii Remote's view of the register map.

/// A Nunchuk-like user calibration (10-bit counts, ≈ 200 counts/g, small cross-axis terms).
pub const NUNCHUK_CAL: Calibration = Calibration {
    bias: [510.0, 514.0, 508.0],
    matrix: [
        [1.0 / 204.0, 0.0001, 0.0],
        [-0.0002, 1.0 / 198.0, 0.0],
        [0.0, 0.0003, 1.0 / 201.0],
    ],
    effects: wiical_core::Effects {
        quadratic: [0.0; 3],
        cubic: [0.0; 3],
        bias_drift: [0.0; 3],
        temp_ref_c: 0.0,
        bias_temp: [0.0; 3],
        scale_temp: [0.0; 3],
        cross_quadratic: [[0.0; 5]; 3],
        cross_cubic: [[0.0; 9]; 3],
    },
};

/// Raw Nunchuk readings (10-bit counts), including both rails.
pub const NUNCHUK_RAWS: [[u16; 3]; 6] = [
    [512, 512, 712],
    [714, 514, 508],
    [0, 1023, 512],
    [300, 700, 900],
    [1023, 1023, 1023],
    [496, 502, 693],
];

/// A factory block as a real Nunchuk stores it (zero ≈ 496–502, one-g ≈ 695–701).
pub fn factory_info() -> Result<NunchukInfo, Error> {
    let block = CalibrationBlock {
        zero: [496, 502, 493],
        one_g: [701, 696, 695],
        stick_x: StickAxisCalibration {
            max: 0xE3,
            min: 0x1D,
            centre: 0x7F,
        },
        stick_y: StickAxisCalibration {
            max: 0xDF,
            min: 0x22,
            centre: 0x81,
        },
    };
    let bytes = block.encode().map_err(|_| Error::InvalidParameter)?;
    Ok(NunchukInfo {
        encryption: Encryption::None,
        calibration_bytes: bytes,
        calibration: Some((block, CalibrationCopy::First)),
    })
}

fn adapter_corrector_calibrated(o: &mut Out) -> Result<(), Error> {
    let mut c = Corrector::new(IdealScale::default());
    c.set_factory(&factory_info()?);
    c.set_user_calibration(Some(NUNCHUK_CAL))?;
    for raw in NUNCHUK_RAWS {
        let r = c.correct(raw);
        o.extend(&r.g)?;
        o.extend(&r.counts.map(f32::from))?;
    }
    // With nonlinearity terms the corrector takes the full correction path.
    let mut fx = NUNCHUK_CAL;
    fx.effects.quadratic = [0.01, -0.02, 0.005];
    fx.effects.cubic = [-0.003, 0.002, 0.001];
    c.set_user_calibration(Some(fx))?;
    for raw in NUNCHUK_RAWS {
        let r = c.correct(raw);
        o.extend(&r.g)?;
        o.extend(&r.counts.map(f32::from))?;
    }
    for b in c.calibration_block_bytes() {
        o.push(f32::from(b))?;
    }
    Ok(())
}

/// The adapter with orientation-dependent cross terms: the corrected g and the
/// counts the Wii Remote reads, after the calibration went through a flash record (version 2)
/// and back, as a committed one does at boot.
fn adapter_corrector_cross_terms(o: &mut Out) -> Result<(), Error> {
    let mut fx = NUNCHUK_CAL;
    fx.effects.quadratic = [0.01, -0.02, 0.005];
    fx.effects.cross_quadratic = CROSS_QUADRATIC;
    fx.effects.cross_cubic = CROSS_CUBIC;
    fx.effects.bias_drift = [0.5, 0.0, 0.0]; // stored, not applied by the adapter
    let record = wiical_adapter::store::encode_record(&fx);
    let stored = wiical_adapter::store::decode_record(&record).map_err(|_| Error::NonFinite)?;
    let mut c = Corrector::new(IdealScale::default());
    c.set_factory(&factory_info()?);
    c.set_user_calibration(Some(stored))?;
    for raw in NUNCHUK_RAWS {
        let r = c.correct(raw);
        o.extend(&r.g)?;
        o.extend(&r.counts.map(f32::from))?;
    }
    o.push(record.len() as f32)
}

fn adapter_corrector_pass_through(o: &mut Out) -> Result<(), Error> {
    let mut c = Corrector::new(IdealScale::default());
    c.set_factory(&factory_info()?);
    for raw in NUNCHUK_RAWS {
        let r = c.correct(raw);
        o.extend(&r.g)?;
        o.extend(&r.counts.map(f32::from))?;
    }
    for b in c.calibration_block_bytes() {
        o.push(f32::from(b))?;
    }
    Ok(())
}

/// What a Wii Remote reads from the emulated Nunchuk: plain init, ID, calibration block and
/// reports; then the legacy (encrypted) init and the same reads.
fn adapter_emulated_reads(o: &mut Out) -> Result<(), Error> {
    let mut c = Corrector::new(IdealScale::default());
    c.set_factory(&factory_info()?);
    c.set_user_calibration(Some(NUNCHUK_CAL))?;
    let mut e = EmulatedNunchuk::new(&c.calibration_block_bytes());
    let record = |o: &mut Out, e: &mut EmulatedNunchuk, reg: u8, n: usize| {
        let mut buf = [0u8; 16];
        let n = n.min(buf.len());
        e.on_write(&[reg]);
        e.on_read(&mut buf[..n]);
        buf[..n].iter().try_for_each(|b| o.push(f32::from(*b)))
    };
    for init in [&[0xF0u8, 0x55][..], &[0xFB, 0x00][..]] {
        e.on_write(init);
    }
    record(o, &mut e, 0xFA, 6)?;
    record(o, &mut e, 0x20, 16)?;
    for (i, raw) in NUNCHUK_RAWS.iter().enumerate() {
        wiimote_read_path(&c, &mut e, *raw, i % 3 == 0, o)?;
    }
    e.on_write(&[0x40, 0x00]);
    record(o, &mut e, 0xFA, 6)?;
    for (i, raw) in NUNCHUK_RAWS.iter().enumerate() {
        wiimote_read_path(&c, &mut e, *raw, i % 2 == 0, o)?;
    }
    Ok(())
}

fn wiimote_read_path(
    c: &Corrector,
    e: &mut EmulatedNunchuk,
    raw: [u16; 3],
    z: bool,
    o: &mut Out,
) -> Result<(), Error> {
    let mut buf = [0u8; 6];
    adapter_report_update(c, e, raw, z);
    adapter_wiimote_read(e, &mut buf);
    buf.iter().try_for_each(|b| o.push(f32::from(*b)))
}

/// Per Nunchuk report (the poll task): correct and store the report the Wii Remote will read.
#[inline]
pub fn adapter_report_update(c: &Corrector, e: &mut EmulatedNunchuk, raw: [u16; 3], z: bool) {
    let corrected = c.correct(raw);
    e.set_report(&NunchukReport {
        stick: [0x80, 0x7F],
        accel: corrected.counts,
        c: !z,
        z,
    });
}

/// Per Wii Remote poll (the I²C-target task): pointer write `0x00`, 6-byte read.
#[inline]
pub fn adapter_wiimote_read(e: &mut EmulatedNunchuk, buf: &mut [u8; 6]) {
    e.on_write(&[0x00]);
    e.on_read(buf);
}

// ---------------------------------------------------------------------------------------
// Real recordings (`crate::real_data`; see build.rs for how they are read).

/// Capacity of the static detector's window ring in `wiical fit` (`crates/analysis/src/detect/windows.rs`,
/// `MAX_WINDOW`): windows up to 5 s at 100 Hz.
pub const FIT_MAX_WINDOW: usize = 511;

/// The detector settings of `wiical fit` with its defaults on a 100 Hz recording: window 1 s
/// (101 samples after rounding to odd), initial rest 2 s, minimum static run 2 s, threshold
/// factor 6 (`for_rate`'s default, which the analysis sets again from `--threshold 6`).
pub fn fit_detector_config() -> StaticDetectorConfig {
    StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0)
}

/// Runs the static detector over the IMU-TK Xsens accelerometer recording (raw 16-bit counts
/// as `f32`, in file order) exactly as `wiical fit`'s fixed detector does (`wiical_analysis::detect::detector::fixed_intervals`:
/// every sample pushed, then `finish`), calling `found` for each static interval. Returns the detector
/// (for its reference variance) and the number of samples pushed.
pub fn xsens_detect(
    mut found: impl FnMut(wiical_core::static_detect::StaticInterval) -> Result<(), Error>,
) -> Result<(StaticDetector<FIT_MAX_WINDOW>, u32), Error> {
    let mut det: StaticDetector<FIT_MAX_WINDOW> = StaticDetector::new(fit_detector_config())?;
    let mut n = 0u32;
    // The recording is stored as little-endian f32 triplets (x, y, z); `chunks_exact(4)`
    // makes the byte indexing below infallible.
    let mut vals = real_data::xsens_acc_f32le()
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
    while let (Some(x), Some(y), Some(z)) = (vals.next(), vals.next(), vals.next()) {
        if let Some(iv) = det.push([x, y, z])? {
            found(iv)?;
        }
        n += 1;
    }
    if let Some(iv) = det.finish() {
        found(iv)?;
    }
    Ok((det, n))
}

/// The whole detection on the device: 51,175 samples in, every interval's bounds, mean and
/// variance out (the means are what `xsens_multipos_fit` fits, computed there by the host).
fn xsens_static_detector(o: &mut Out) -> Result<(), Error> {
    let mut intervals = 0u32;
    let (det, n) = xsens_detect(|iv| {
        intervals += 1;
        o.extend(&[iv.start as f32, iv.end as f32])?;
        o.extend(&iv.mean)?;
        o.extend(&iv.variance)
    })?;
    o.extend(&det.reference_variance().ok_or(Error::TooFewSamples {
        needed: fit_detector_config().init_samples,
        got: n,
    })?)?;
    o.extend(&[intervals as f32, n as f32])
}

/// `wiical fit`'s multi-position fit (full 9-parameter model, default settings) of the 38
/// static-window means the host's detector found in the Xsens recording.
fn xsens_multipos_fit(o: &mut Out) -> Result<(), Error> {
    let fit = multipos::fit(real_data::xsens_poses(), &MultiPosConfig::default())?;
    push_multipos(o, &fit)
}

/// `wiical magfit --model ellipsoid` on the 347 raw points of `mag_out.txt`: streaming
/// accumulation in file order, solve, then the quality pass over the same points.
fn mag_out_ellipsoid_fit(o: &mut Out) -> Result<(), Error> {
    let pts = real_data::mag_out_points();
    let mut f = EllipsoidFit::new();
    for p in pts {
        f.push(*p)?;
    }
    let fit = f.solve()?;
    o.extend(&fit.center)?;
    for row in &fit.matrix {
        o.extend(row)?;
    }
    o.push(fit.radius)?;
    let q = fit.quality(pts.iter().copied())?;
    o.extend(&[q.fit_error_pct, q.rms_radius_error])?;
    o.extend(&fit.semi_axes()?)
}
