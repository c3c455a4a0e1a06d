//! The open basis: a term outside the seven candidates is found by the
//! open-basis stage after the greedy search, named by its family and target, stored in the
//! calibration, and nothing is named on a clean recording.
//!
//! The recordings are window-mean tables built here from a known calibration (independent of
//! the analysis's model code): raw means `m = b + D·u` with `u` solved from
//! `a(u) = g` for 40 directions `g` spread over the sphere, `a = u + c·u_x·u_y·e_z`, and
//! Gaussian noise of the stated per-window standard deviation.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use wiical_analysis::input::window_means::{parse_window_table, WindowInputOptions};
use wiical_analysis::pipeline;
use wiical_analysis::AnalyzeOptions;

/// Raw units per g (a 16-bit MEMS at ±2 g style scale) and the per-sample noise, counts.
const SD_COUNTS: f64 = 3.0;
/// Samples per window (the per-window mean noise is SD/√N = 0.3 counts ≈ 0.3 mg).
const N: usize = 100;

/// The cross term of the truth: `c·u_x·u_y` on z, or `c·u_x·u_y·u_z` on z.
#[derive(Clone, Copy)]
enum Cross {
    ZXy,
    ZXyz,
}

/// What the cross term adds to `a` at `u`.
fn delta(kind: Cross, c: f64, u: [f64; 3]) -> [f64; 3] {
    match kind {
        Cross::ZXy => [0.0, 0.0, c * u[0] * u[1]],
        Cross::ZXyz => [0.0, 0.0, c * u[0] * u[1] * u[2]],
    }
}

/// The window table: 40 directions (a Fibonacci sphere), the cross term `c` (1/g) of
/// `u_x·u_y` on z.
fn table(c: f64, seed: u64) -> String {
    table_of(Cross::ZXy, c, seed)
}

/// The window table with cross term `kind` of coefficient `c`.
fn table_of(kind: Cross, c: f64, seed: u64) -> String {
    table_with(kind, c, 0.0, seed)
}

/// Mean window time of the tables, s (40 windows 10 s apart).
const T_MEAN: f64 = 195.0;

/// The window table with cross term `kind` of coefficient `c` and a scale on x changing by
/// `drift` per second about [`T_MEAN`] (`u_x·(1 + drift·(t − T_MEAN)) = g_x`).
fn table_with(kind: Cross, c: f64, drift: f64, seed: u64) -> String {
    let b = [512.0, -300.0, 250.0];
    let d = [[1000.0, 5.0, -3.0], [0.0, 990.0, 4.0], [0.0, 0.0, 1010.0]];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, SD_COUNTS / (N as f64).sqrt()).unwrap();
    let mut text = String::from("t,x,y,z,sdx,sdy,sdz,n\n");
    let poses = 40;
    for i in 0..poses {
        // Row i (time 10·i s) visits direction k of the spiral: a shuffled order (13 is prime
        // to 40), so that time is not a function of the direction (in the spiral's own order
        // it would be −g_z, and a bias drift could not be told from the bias).
        let k = (13 * i) % poses;
        let zc = 1.0 - 2.0 * (k as f64 + 0.5) / poses as f64;
        let r = (1.0 - zc * zc).sqrt();
        let phi = k as f64 * 2.399_963_229_728_653;
        let g = [r * phi.cos(), r * phi.sin(), zc];
        // Solve u + Δ(u) = g by fixed-point iteration (|c| ≪ 1).
        let mut u = g;
        for _ in 0..50 {
            let dl = delta(kind, c, u);
            u = [0, 1, 2].map(|a| g[a] - dl[a]);
        }
        let t = 10.0 * i as f64;
        u[0] /= 1.0 + drift * (t - T_MEAN);
        let mut row = vec![format!("{t}")];
        for a in 0..3 {
            let m = b[a] + (0..3).map(|k| d[a][k] * u[k]).sum::<f64>() + noise.sample(&mut rng);
            row.push(format!("{m:.4}"));
        }
        for _ in 0..3 {
            row.push(format!("{SD_COUNTS}"));
        }
        row.push(N.to_string());
        text.push_str(&row.join(","));
        text.push('\n');
    }
    text
}

fn analyze(text: &str) -> wiical_analysis::AnalyzeReport {
    let t = parse_window_table(text, &WindowInputOptions::default())
        .unwrap()
        .expect("a window table");
    let input = wiical_analysis::input::front_door::Input::Table(t);
    pipeline::analyze_judged(&input, &AnalyzeOptions::default())
        .unwrap()
        .report
}

/// 15 mg of `u_x·u_y` on z: named `cross-quadratic (z: x·y)`, the coefficient within 3
/// standard errors of the truth, the held-out RMS brought to the floor (within 1.5× the
/// noise floor), and the calibration file's cross term carries it.
#[test]
fn a_cross_quadratic_is_named_and_stored() {
    let truth = 0.015;
    for seed in 1..=3u64 {
        let r = analyze(&table(truth, seed));
        let names: Vec<&str> = r.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(
            names,
            ["cross-quadratic (z: x·y)"],
            "seed {seed}: {}",
            r.verdict
        );
        let e = &r.effects[0];
        let (v, se) = (e.values.unwrap()[2], e.std_errors.unwrap()[2]);
        assert!(se > 0.0 && (v - truth).abs() < 3.0 * se, "{v} ± {se}");
        let floor = r.noise_floor_mg.unwrap();
        let cv = r.final_model.cv_rms_mg.unwrap();
        assert!(cv < 1.5 * floor, "CV {cv} mg vs floor {floor} mg");
        assert!(r.base.cv_rms_mg.unwrap() > 3.0 * floor);
        // z: x·y is DEGREE2[3], the third cross coefficient of output axis z (CROSS2[2]).
        let stored = r.calibration.effects.cross_quadratic[2][2] as f64;
        assert!((stored - v).abs() < 1e-6, "{stored} vs {v}");
        assert!(e.evidence.contains("x: y·z, y: x·z"), "{}", e.evidence);
    }
}

/// The same recordings without the term: nothing is named.
#[test]
fn a_clean_recording_names_nothing() {
    for seed in 1..=5u64 {
        let r = analyze(&table(0.0, seed));
        assert!(r.effects.is_empty(), "seed {seed}: {}", r.verdict);
        assert_eq!(r.calibration.effects.cross_quadratic, [[0.0; 5]; 3]);
    }
}

/// 20 mg of `u_x·u_y·u_z` on z (degree 3): named `cross-cubic (z: x·y·z)`, within 3 standard
/// errors, stored in `cross_cubic[2][8]` (DEGREE3[9] = xyz, the ninth of CROSS3[2]). (A term
/// like `u_x²·u_y` on y is not an open-basis test: its pattern `g_x²·g_y²` lies in the span of
/// the matrix and the cubic block on the sphere, and the cubic candidate takes it.)
#[test]
fn a_cross_cubic_is_named_and_stored() {
    let truth = 0.020;
    for seed in 1..=2u64 {
        let r = analyze(&table_of(Cross::ZXyz, truth, seed));
        let names: Vec<&str> = r.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(
            names,
            ["cross-cubic (z: x·y·z)"],
            "seed {seed}: {}",
            r.verdict
        );
        let e = &r.effects[0];
        assert_eq!(e.unit.as_deref(), Some("1/g²"));
        let (v, se) = (e.values.unwrap()[2], e.std_errors.unwrap()[2]);
        assert!(se > 0.0 && (v - truth).abs() < 3.0 * se, "{v} ± {se}");
        let stored = r.calibration.effects.cross_cubic[2][8] as f64;
        assert!((stored - v).abs() < 1e-6, "{stored} vs {v}");
    }
}

/// A sensitivity on x that changes by 1 % over the recording (5·10⁻⁵ per s, ±10 mg at the
/// ends): named `scale-drift (x)` (a host term), its value within 3 standard errors, in 1/s;
/// the calibration file keeps no trace of it (no cross terms).
#[test]
fn a_scale_drift_is_named_as_a_host_term() {
    let truth = 5e-5;
    for seed in 1..=2u64 {
        let r = analyze(&table_with(Cross::ZXy, 0.0, truth, seed));
        let names: Vec<&str> = r.effects.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["scale-drift (x)"], "seed {seed}: {}", r.verdict);
        let e = &r.effects[0];
        assert_eq!(e.unit.as_deref(), Some("1/s"));
        let (v, se) = (e.values.unwrap()[0], e.std_errors.unwrap()[0]);
        assert!(se > 0.0 && (v - truth).abs() < 3.0 * se, "{v} ± {se}");
        assert!(e.evidence.contains("host term"), "{}", e.evidence);
        assert_eq!(r.calibration.effects.cross_quadratic, [[0.0; 5]; 3]);
    }
}
