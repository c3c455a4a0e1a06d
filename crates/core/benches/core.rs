//! Criterion benchmarks of the core's hot paths (host CPU). On-target instruction counts come
//! from the QEMU benchmark (`cargo xtask qemu-bench`); see BENCHMARKS.md.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use wiical_core::kalman::{PvbConfig, PvbFilter};
use wiical_core::magfit::{EllipsoidFit, SphereFit};
use wiical_core::multipos::{self, MultiPosConfig};
use wiical_core::six_position;
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig};
use wiical_core::{Calibration, Conditions, Mat3, Vec3};

/// Deterministic spread of unit vectors (golden-angle spiral).
fn directions(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|k| {
            let z = -1.0 + 2.0 * (k as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let th = k as f32 * 2.399_963;
            [r * th.cos(), r * th.sin(), z]
        })
        .collect()
}

fn wiimote_cal() -> (Mat3, Vec3, Calibration) {
    let d = Mat3::new(106.0, -0.8, 1.1, 0.4, 104.5, -0.6, -0.3, 0.5, 110.2);
    let b = Vec3::new(521.3, 519.8, 524.6);
    (d, b, Calibration::from_forward(&d, &b).unwrap())
}

fn poses(n: usize) -> Vec<[f32; 3]> {
    let (d, b, _) = wiimote_cal();
    directions(n)
        .into_iter()
        .enumerate()
        .map(|(i, a)| {
            let m = d * Vec3::new(a[0], a[1], a[2]) + b;
            // A little deterministic "noise" so the fit has a non-zero residual.
            let e = ((i * 7919) % 13) as f32 * 0.01 - 0.06;
            [m.x + e, m.y - e, m.z + 0.5 * e]
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let (_, _, cal) = wiimote_cal();
    c.bench_function("correct_linear (per sample)", |bn| {
        bn.iter(|| cal.correct_linear(black_box([600.0, 480.0, 530.0])))
    });
    let cond = Conditions {
        time_s: 12.0,
        temperature_c: Some(31.0),
    };
    c.bench_function("correct with effects (per sample)", |bn| {
        bn.iter(|| cal.correct(black_box([600.0, 480.0, 530.0]), black_box(&cond)))
    });

    let seed_m: [[f32; 3]; 6] = [
        [153.329, 127.181, 129.991],
        [102.978, 127.989, 129.991],
        [128.072, 153.248, 129.586],
        [127.989, 101.200, 128.992],
        [127.989, 127.989, 154.179],
        [127.989, 127.183, 105.012],
    ];
    c.bench_function("six_position::solve", |bn| {
        bn.iter(|| six_position::solve(black_box(&seed_m)).unwrap())
    });

    let p30 = poses(30);
    c.bench_function("multipos::fit (30 poses)", |bn| {
        bn.iter(|| multipos::fit(black_box(&p30), &MultiPosConfig::default()).unwrap())
    });

    let cfg = StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0);
    let stream: Vec<[f32; 3]> = (0..1000)
        .map(|i| [33000.0 + (i % 7) as f32, 33300.0 - (i % 5) as f32, 36400.0])
        .collect();
    c.bench_function(
        "static_detect::push (1000 samples, 101-sample window)",
        |bn| {
            bn.iter(|| {
                let mut det: StaticDetector<101> = StaticDetector::new(cfg).unwrap();
                for s in &stream {
                    black_box(det.push(*s).unwrap());
                }
            })
        },
    );
}

fn bench_mag_kalman(c: &mut Criterion) {
    // 1000 points on a rotated, offset ellipsoid in raw counts (QMC5883L-like magnitudes).
    let pts: Vec<[f32; 3]> = directions(1000)
        .into_iter()
        .map(|u| {
            [
                6150.0 + 750.0 * u[0] + 30.0 * u[1],
                250.0 + 1030.0 * u[1] - 20.0 * u[2],
                3440.0 + 1620.0 * u[2] + 10.0 * u[0],
            ]
        })
        .collect();
    c.bench_function("magfit::EllipsoidFit::push (per sample)", |bn| {
        let mut f = EllipsoidFit::new();
        let mut i = 0usize;
        bn.iter(|| {
            i = (i + 1) % pts.len();
            f.push(black_box(pts[i])).unwrap()
        })
    });
    let mut ell = EllipsoidFit::new();
    let mut sph = SphereFit::new();
    for p in &pts {
        ell.push(*p).unwrap();
        sph.push(*p).unwrap();
    }
    c.bench_function("magfit::EllipsoidFit::solve", |bn| {
        bn.iter(|| black_box(&ell).solve().unwrap())
    });
    c.bench_function("magfit::SphereFit::solve", |bn| {
        bn.iter(|| black_box(&sph).solve().unwrap())
    });

    let cfg = PvbConfig {
        dt: 0.01,
        accel_noise: 0.05,
        bias_walk: 0.0,
        pos_noise: 0.005,
        initial_state: [0.0; 3],
        initial_std: [0.005, 0.02, 0.5],
    };
    c.bench_function("kalman::PvbFilter predict + update (one step)", |bn| {
        let mut f = PvbFilter::new(&cfg).unwrap();
        bn.iter(|| {
            f.predict(black_box(0.25)).unwrap();
            f.update(black_box(0.001)).unwrap()
        })
    });
}

/// The gyro integration step (per sample, f32 and f64) and the zero-rate tracker. The whole
/// fit on a real recording is benchmarked end to end by the host (`gyrofit` on Xsens).
fn bench_gyro(c: &mut Criterion) {
    use wiical_core::gyro::{Adjustment, GyroCalibration, MotionIntegrator, NPARAM};
    use wiical_core::gyro_zero::{ZeroRateConfig, ZeroRateTracker};
    let stream: Vec<[f32; 3]> = (0..1000u32)
        .map(|i| {
            [
                8192.0 + (i % 97) as f32,
                8190.0 - (i % 89) as f32,
                8195.0 + (i % 53) as f32,
            ]
        })
        .collect();
    let cal = GyroCalibration::<f32>::nominal([8192.0, 8190.0, 8195.0], [1.2e-3, -1.2e-3, 1.2e-3]);
    let scale_mask: [bool; NPARAM] = core::array::from_fn(|k| k < 9);
    for (label, tracked) in [
        (
            "gyro::MotionIntegrator::push, 1000 samples (RK4)",
            [false; NPARAM],
        ),
        (
            "gyro::MotionIntegrator::push, 1000 samples (RK4 + 9 sensitivities)",
            scale_mask,
        ),
    ] {
        c.bench_function(label, |bn| {
            bn.iter(|| {
                let mut m =
                    MotionIntegrator::new(cal, Adjustment::identity(), 0.01, tracked).unwrap();
                for s in &stream {
                    m.push(black_box(s)).unwrap();
                }
                m.finish(&[0.0, 0.0, 1.0].into(), &[0.0, 1.0, 0.0].into())
                    .unwrap()
                    .angle
            })
        });
    }
    let zcfg = ZeroRateConfig {
        block: 50,
        max_spread: 200.0f32,
        blend: 0.5,
    };
    c.bench_function("gyro_zero::ZeroRateTracker::push, 1000 samples", |bn| {
        bn.iter(|| {
            let mut t = ZeroRateTracker::new(zcfg, [8192.0, 8190.0, 8195.0]).unwrap();
            for s in &stream {
                t.push(black_box(*s), true).unwrap();
            }
            t.bias()
        })
    });
}

criterion_group!(benches, bench, bench_mag_kalman, bench_gyro, bench_detector);
criterion_main!(benches);

#[path = "support/motion_static_mix.rs"]
mod workload;
use workload::motion_static_mix;

/// The adaptive detection's per-sample work as the host runs it: the noise survey, a detector
/// with a 1 s window at 100 Hz (`StaticDetector<511>`, the analysis crate's capacity) and
/// `Welford3::push`. Throughput is per sample: criterion prints samples per second.
fn bench_detector(c: &mut Criterion) {
    use wiical_core::estimators::Welford3;
    use wiical_core::static_detect::NoiseSurvey;
    let xs = motion_static_mix(10_000);
    let mut g = c.benchmark_group("detector (10,000 samples, motion/static mix)");
    g.throughput(Throughput::Elements(xs.len() as u64));
    let cfg = StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0);
    let reference = [1.0f32, 1.0, 1.0];
    g.bench_function("StaticDetector<511>::push, 1 s window", |bn| {
        bn.iter(|| {
            let mut det: StaticDetector<511> =
                StaticDetector::with_reference(cfg, reference).unwrap();
            let mut n = 0u32;
            for s in &xs {
                n += u32::from(det.push(black_box(*s)).unwrap().is_some());
            }
            n + u32::from(det.finish().is_some())
        })
    });
    g.bench_function("StaticDetector<511>::push_slice, 1 s window", |bn| {
        bn.iter(|| {
            let mut det: StaticDetector<511> =
                StaticDetector::with_reference(cfg, reference).unwrap();
            let mut n = 0u32;
            det.push_slice(black_box(&xs), |_| n += 1).unwrap();
            n + u32::from(det.finish().is_some())
        })
    });
    g.bench_function("NoiseSurvey::push, 25-sample blocks", |bn| {
        bn.iter(|| {
            let mut s = NoiseSurvey::for_rate(100.0).unwrap();
            for m in &xs {
                s.push(black_box(*m)).unwrap();
            }
            s.blocks()
        })
    });
    g.bench_function("NoiseSurvey::measure_block, 25-sample blocks", |bn| {
        bn.iter(|| {
            let mut acc = 0.0f32;
            for b in black_box(&xs).chunks_exact(25) {
                acc += NoiseSurvey::measure_block(b).unwrap().0.x;
            }
            acc
        })
    });
    g.bench_function("Welford3::push", |bn| {
        bn.iter(|| {
            let mut w = Welford3::new();
            for m in &xs {
                w.push(black_box(*m)).unwrap();
            }
            w.variance().unwrap()
        })
    });
    g.finish();
}
