//! The static detector, the noise survey's block measurement and `Welford3` per sample: the
//! current code against the implementation it replaced (`src/static_detect/reference.rs`,
//! kept as the tests' oracle), one workload per run, so that
//! `perf stat -e cycles:u,instructions:u` counts the process's own cycles and instructions
//! whatever else the machine runs (wall-clock benchmarks on a shared machine are not).
//!
//! `cargo run --release -p wiical-core --example detector_cycles -- WORKLOAD` with WORKLOAD
//! one of `detector-old`, `detector-push`, `detector-slice`, `detector-spans`, `block-old`, `block-new`, `block-four`,
//! `welford-old`, `welford-new`, `welford-four`, `none` (the stream alone, to subtract); each runs 200 passes
//! over 10,000 samples (2,000,000 samples), or as many passes as a second argument says.

use std::hint::black_box;
use wiical_core::static_detect::{NoiseSurvey, SpanDetector, StaticDetector};
#[allow(unused_imports)] // for the reference module's `super::` paths
use wiical_core::static_detect::{StaticDetectorConfig, StaticInterval};
#[allow(unused_imports)] // for the reference module's `crate::` paths
use wiical_core::{all_finite, Error, Vec3};

mod estimators {
    pub use wiical_core::estimators::*;
}

#[path = "../src/static_detect/reference.rs"]
mod reference;

#[path = "../benches/support/motion_static_mix.rs"]
mod workload;
use workload::motion_static_mix;

fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    let xs = motion_static_mix(10_000);
    let cfg = StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0);
    let reference = [1.0f32, 1.0, 1.0];
    let mut found = 0u64;
    let passes: usize = std::env::args()
        .nth(2)
        .and_then(|p| p.parse().ok())
        .unwrap_or(200);
    for _ in 0..passes {
        found += pass(&which, black_box(&xs[..]), cfg, reference);
    }
    println!("{which}: {found}");
}

/// One pass of the workload `which` over `xs`: what it found (counted so that nothing is
/// optimised away). Apart from `main` so that the workloads read as one table.
fn pass(which: &str, xs: &[[f32; 3]], cfg: StaticDetectorConfig, reference: [f32; 3]) -> u64 {
    let mut found = 0u64;
    match which {
        "detector-old" => {
            let mut d =
                reference::ReferenceDetector::<511>::with_reference(cfg, reference).unwrap();
            for m in xs {
                found += u64::from(d.push(*m).unwrap().is_some());
            }
            found += u64::from(d.finish().is_some());
        }
        "detector-push" => {
            let mut d = StaticDetector::<511>::with_reference(cfg, reference).unwrap();
            for m in xs {
                found += u64::from(d.push(*m).unwrap().is_some());
            }
            found += u64::from(d.finish().is_some());
        }
        "detector-slice" => {
            let mut d = StaticDetector::<511>::with_reference(cfg, reference).unwrap();
            d.push_slice(xs, |_| found += 1).unwrap();
            found += u64::from(d.finish().is_some());
        }
        "detector-spans" => {
            let mut d = SpanDetector::<511>::with_reference(cfg, reference).unwrap();
            d.push_slice(xs, |_| found += 1).unwrap();
            found += u64::from(d.finish().is_some());
        }
        "block-old" => {
            for b in xs.chunks_exact(25) {
                found += reference::reference_measure_block(b).unwrap().0.x as u64;
            }
        }
        "block-new" => {
            for b in xs.chunks_exact(25) {
                found += NoiseSurvey::measure_block(b).unwrap().0.x as u64;
            }
        }
        "block-four" => {
            for b in xs.chunks_exact(100) {
                let four = [&b[..25], &b[25..50], &b[50..75], &b[75..]];
                for m in NoiseSurvey::measure_four_blocks(four) {
                    found += m.unwrap().0.x as u64;
                }
            }
        }
        "welford-old" => {
            let mut w = reference::ReferenceWelford3::new();
            for m in xs {
                w.push(*m).unwrap();
            }
            found += w.variance().unwrap().x as u64;
        }
        "welford-new" => {
            let mut w = wiical_core::estimators::Welford3::new();
            for m in xs {
                w.push(*m).unwrap();
            }
            found += w.variance().unwrap().x as u64;
        }
        "welford-four" => {
            let q = xs.len() / 4;
            let four = [&xs[..q], &xs[q..2 * q], &xs[2 * q..3 * q], &xs[3 * q..]];
            for w in wiical_core::estimators::Welford3::of_four(four) {
                found += w.unwrap().variance().unwrap().x as u64;
            }
        }
        "none" => found += xs.len() as u64,
        _ => {
            eprintln!("unknown workload {which:?} (see the file's doc comment)");
            std::process::exit(2);
        }
    }
    found
}
