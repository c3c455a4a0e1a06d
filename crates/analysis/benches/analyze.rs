//! End-to-end `analyze` on a 50k-sample recording (issue: must finish under 2 s), and `fit`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use wiical_analysis::fit::{self, FitOptions};
use wiical_analysis::simulate::{simulate, EffectSpec, SimConfig, SimEffect};
use wiical_analysis::{analyze, AnalyzeOptions};

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
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
