//! End-to-end `gyrofit` on IMU-TK's Xsens recording (51,175 accelerometer + gyro samples, 38
//! windows, 37 motions): detection, accelerometer fit, six candidate gyro models, each with its
//! leave-one-motion-out refits. Loading is outside the timing.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::PathBuf;
use wiical_analysis::gyro::{run, GyroOptions};
use wiical_analysis::{load, LoadOptions};

fn data_dir() -> PathBuf {
    std::env::var_os("WIICAL_DATA")
        .map(Into::into)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

fn bench(c: &mut Criterion) {
    let dir = data_dir().join("imu_tk_xsens");
    let acc = load(&dir.join("xsens_acc.mat"), &LoadOptions::default()).expect("xsens_acc.mat");
    let gyro = load(&dir.join("xsens_gyro.mat"), &LoadOptions::default()).expect("xsens_gyro.mat");
    let opts = GyroOptions::new([1.0 / 6258.0; 3]);
    let mut g = c.benchmark_group("host");
    g.sample_size(10);
    g.bench_function(
        "gyrofit on Xsens (6 models with leave-one-motion-out)",
        |b| b.iter(|| run(black_box(&acc), black_box(&gyro), &opts).unwrap()),
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
