//! End-to-end `analyze` on a 50k-sample recording (the target: under 2 s), and `fit`;
//! `analyze` on the real Xsens recording (`$WIICAL_DATA` or `../shared/data`) and on a
//! 1 M-row simulation (~1,200 windows: the PRESS identity replaces the per-window refits).

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use wiical_analysis::fit::base::{self as fit, FitOptions};
use wiical_analysis::{analyze, AnalyzeOptions};
use wiical_sim::{simulate, EffectSpec, SimConfig, SimEffect};

fn bench(c: &mut Criterion) {
    // A simulated Wiimote recording with a quadratic nonlinearity, ≥ 50,000 samples.
    let mut poses = 50;
    let rec = loop {
        let sim = simulate(&SimConfig {
            effects: vec![EffectSpec::new(SimEffect::Quadratic, None)],
            poses,
            seed: 11,
            ..Default::default()
        })
        .unwrap();
        if sim.recording.len() >= 50_000 {
            break sim.recording;
        }
        poses += 10;
    };
    let mut g = c.benchmark_group("host");
    g.sample_size(10);
    g.bench_function(
        format!("analyze ({} samples, {poses} poses, quadratic)", rec.len()),
        |b| b.iter(|| analyze(black_box(&rec), &AnalyzeOptions::default()).unwrap()),
    );
    g.bench_function(format!("fit ({} samples)", rec.len()), |b| {
        b.iter(|| fit::run(black_box(&rec), &FitOptions::default()).unwrap())
    });
    let data = std::env::var_os("WIICAL_DATA")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
        });
    let xsens = wiical_analysis::load(
        &data.join("imu_tk_xsens/xsens_acc.mat"),
        &Default::default(),
    )
    .expect("the Xsens recording (set WIICAL_DATA)");
    g.bench_function(format!("analyze Xsens ({} samples)", xsens.len()), |b| {
        b.iter(|| analyze(black_box(&xsens), &AnalyzeOptions::default()).unwrap())
    });
    let big = simulate(&SimConfig {
        effects: vec![EffectSpec::new(SimEffect::Quadratic, None)],
        poses: 1200,
        seed: 12,
        ..Default::default()
    })
    .unwrap()
    .recording;
    g.bench_function(
        format!("analyze ({} samples, 1200 poses, quadratic)", big.len()),
        |b| b.iter(|| analyze(black_box(&big), &AnalyzeOptions::default()).unwrap()),
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
