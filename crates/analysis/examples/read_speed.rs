//! Reading speed of the recording loader (docs/benchmarks-history.md, "Reading speed"): loads FILE
//! `RUNS` times (default 7) with `wiical_analysis::load` and prints the median wall time and
//! MB/s (10⁶ bytes). `cargo run --release -p wiical-analysis --example read_speed -- FILE [RUNS]`

use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: read_speed FILE [RUNS]");
        std::process::exit(2);
    };
    let runs: usize = args.next().and_then(|r| r.parse().ok()).unwrap_or(7).max(1);
    let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0) as f64;
    let mut times = Vec::with_capacity(runs);
    let mut rows = 0;
    for _ in 0..runs {
        let t0 = Instant::now();
        let rec = match wiical_analysis::load(path.as_ref(), &Default::default()) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {}", e.full_message());
                std::process::exit(1);
            }
        };
        times.push(t0.elapsed().as_secs_f64());
        rows = rec.len();
    }
    times.sort_by(f64::total_cmp);
    let median = times[runs / 2];
    println!(
        "{path}: {rows} rows, {:.1} MB, median {:.3} s of {runs} runs (min {:.3} s): {:.0} MB/s",
        bytes / 1e6,
        median,
        times[0],
        bytes / 1e6 / median
    );
}
