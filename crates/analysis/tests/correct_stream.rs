//! `wiical correct` on a recording too large to hold: corrected as it is read
//! (`correct::pass`), the output is the held path's file byte for byte, and every refusal
//! is the held path's sentence with nothing written. A few-MiB recording with time and
//! temperature columns (a warm-up, a 40 s gap, six poses) streamed by a zero threshold,
//! with a calibration whose host terms need each regressor (time, temperature, the lagged
//! temperature, the temperature rate over ±15 s).

use std::io::Write;
use std::path::{Path, PathBuf};
use wiical_analysis::correct::correct_recording;
use wiical_analysis::correct::csv::write_corrected;
use wiical_analysis::correct::pass::correct_streamed;
use wiical_analysis::input::front_door::{load_samples, Input};
use wiical_analysis::output::calfile::CalibrationFile;
use wiical_analysis::output::host_term_checks::{HostReference, HostTerm};
use wiical_analysis::{Calibration, LoadOptions};

/// Raw counts per g and the bias of the simulated sensor.
const PER_G: f64 = 1000.0;
const BIAS: [f64; 3] = [30.0, -20.0, 10.0];

/// Rows `t,x,y,z,temp` at 100 Hz: six poses of 10 s in turn, a warm-up from 20 °C (90 s
/// time constant) with a wiggle, and a 40 s gap at sample `n/2` (each side's rate comes
/// from its own samples). `lone`: one sample alone 40 s after the rest (its rate is undefined).
fn recording(n: usize, scale: impl Fn(usize) -> f64, lone: bool) -> String {
    let poses = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let mut s = String::from("t,x,y,z,temp\n");
    for i in 0..n {
        let mut t = 5.0 + i as f64 * 0.01;
        if i >= n / 2 {
            t += 40.0;
        }
        let p = poses[(t / 10.0) as usize % 6];
        let wobble = ((i * 7919) % 101) as f64 / 101.0 - 0.5;
        let temp = 20.0 + 12.0 * (1.0 - (-t / 90.0).exp()) + 0.02 * (t * 0.7).sin();
        let m: [f64; 3] = std::array::from_fn(|j| BIAS[j] + scale(i) * (p[j] + 0.004 * wobble));
        s += &format!("{t:.2},{:.3},{:.3},{:.3},{temp:.4}\n", m[0], m[1], m[2]);
    }
    if lone {
        let t = 5.0 + n as f64 * 0.01 + 80.0;
        s += &format!("{t:.2},{},{},{},33\n", BIAS[0] + PER_G, BIAS[1], BIAS[2]);
    }
    s
}

fn term(family: &str, axis: u8, value: f64, reference: HostReference) -> HostTerm {
    HostTerm {
        name: format!("{family} ({})", ["x", "y", "z"][axis as usize]),
        family: family.into(),
        axis,
        value,
        unit: String::new(),
        reference,
        time_constant_s: (family == "thermal-lag").then_some(60.0),
    }
}

/// The sensor's calibration (`K = I/PER_G`, its bias) with one host term of every regressor.
fn calibration() -> CalibrationFile {
    let k = (1.0 / PER_G) as f32;
    let temp = |c| HostReference {
        temperature_c: Some(c),
        ..Default::default()
    };
    CalibrationFile {
        calibration: Calibration {
            bias: BIAS.map(|b| b as f32),
            matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
            ..Default::default()
        },
        quality: None,
        host_terms: vec![
            term(
                "scale-drift",
                0,
                2e-5,
                HostReference {
                    time_s: Some(100.0),
                    ..Default::default()
                },
            ),
            term("temperature-squared", 2, 0.05, temp(25.0)),
            term("thermal-lag", 1, 2.0, temp(25.0)),
            term(
                "temperature-rate",
                2,
                40.0,
                HostReference {
                    rate_c_per_s: Some(0.0),
                    ..Default::default()
                },
            ),
        ],
    }
}

/// A scratch directory for this test.
fn scratch(tag: &str) -> (tempfile::TempDir, PathBuf) {
    let guard = tempfile::Builder::new()
        .prefix(&format!("wiical-correct-stream-{tag}-"))
        .tempdir()
        .unwrap();
    let dir = guard.path().to_path_buf();
    (guard, dir)
}

/// An error and its sources in one line, as the command line prints it.
fn sentence(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        s += &format!(": {inner}");
        source = inner.source();
    }
    s
}

/// The held path's output (bytes) or sentence, then the streamed path's, for `rec` written to
/// `out_held` / `out_stream`; asserts the recording was streamed.
fn both(
    file: &CalibrationFile,
    rec: &Path,
    opts: &LoadOptions,
    out_held: &Path,
    out_stream: &Path,
) -> [Result<Vec<u8>, String>; 2] {
    let held = wiical_analysis::load(rec, opts).unwrap();
    let held = correct_recording(file, &held, 100.0)
        .map_err(|e| sentence(&e.in_file(rec)))
        .map(|c| {
            write_corrected(out_held, &c).unwrap();
            std::fs::read(out_held).unwrap()
        });
    let mut streamed = opts.clone();
    streamed.read.stream_from_bytes = 0;
    let Input::Stream(src) = load_samples(rec, &streamed, None).unwrap() else {
        panic!("{} was not streamed", rec.display());
    };
    let streamed = correct_streamed(file, &src, 100.0, out_stream, rec)
        .map(|c| {
            assert_eq!(c.samples, src.len());
            std::fs::read(out_stream).unwrap()
        })
        .map_err(|e| sentence(&e));
    [held, streamed]
}

/// Every regressor, plain and gzip'd, with and without a time column: the same file.
#[test]
fn the_streamed_output_is_the_held_one_byte_for_byte() {
    let (_g, dir) = scratch("same");
    let text = recording(60_000, |_| PER_G, false);
    assert!(text.len() > 2 << 20, "{}", text.len());
    let rec = dir.join("rec.csv");
    std::fs::write(&rec, &text).unwrap();
    let gz = dir.join("rec.csv.gz");
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(text.as_bytes()).unwrap();
    std::fs::write(&gz, z.finish().unwrap()).unwrap();
    // Without time: `i / Fs` from the metadata; only the time-free terms then.
    let no_time = dir.join("notime.csv");
    let mut rows = String::from("Fs,50\nx,y,z,temp\n");
    for line in text.lines().skip(1) {
        rows += line.split_once(',').unwrap().1;
        rows += "\n";
    }
    std::fs::write(&no_time, rows).unwrap();
    let opts = LoadOptions::default();
    let (a, b) = (dir.join("held.csv"), dir.join("streamed.csv"));
    let file = calibration();
    for path in [&rec, &gz, &no_time] {
        let [held, streamed] = both(&file, path, &opts, &a, &b);
        let held = held.unwrap();
        assert_eq!(held.len(), streamed.as_ref().map_or(0, Vec::len));
        assert!(held == streamed.unwrap(), "{} differs", path.display());
        let lines = held.iter().filter(|&&c| c == b'\n').count();
        assert_eq!(lines, 60_001);
    }
    // Each host term changes the output (none is a no-op by accident).
    let with_all = both(&file, &rec, &opts, &a, &b)[0].clone().unwrap();
    for k in 0..file.host_terms.len() {
        let mut fewer = calibration();
        fewer.host_terms.remove(k);
        let [held, streamed] = both(&fewer, &rec, &opts, &a, &b);
        assert!(held == streamed, "without term {k}");
        assert!(held.unwrap() != with_all, "term {k} changed nothing");
    }
}

/// Each refusal: the held path's sentence, nothing written, an existing output kept.
#[test]
fn every_refusal_is_the_held_paths_sentence() {
    let (_g, dir) = scratch("refuse");
    let opts = LoadOptions::default();
    let (a, b) = (dir.join("held.csv"), dir.join("streamed.csv"));
    let good = dir.join("good.csv");
    std::fs::write(&good, recording(20_000, |_| PER_G, false)).unwrap();
    let cases: Vec<(&str, CalibrationFile, PathBuf)> = {
        // A calibration in g applied to counts: the median magnitude is ~1000 g.
        let mut g = calibration();
        g.calibration.matrix = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        // An implausible core term: a cubic of 1e20.
        let mut cubic = calibration();
        cubic.calibration.effects.cubic = [0.0, 0.0, 1e20];
        // A scale drift of 1000/s: beyond ±16 g within a second.
        let mut drift = calibration();
        drift.host_terms[0].value = 1000.0;
        // A temperature term of 1e38: the bias overflows to ∞.
        let mut inf = calibration();
        inf.host_terms[1].value = 1e38;
        let lone = dir.join("lone.csv");
        std::fs::write(&lone, recording(20_000, |_| PER_G, true)).unwrap();
        let notemp = dir.join("notemp.csv");
        let text = recording(20_000, |_| PER_G, false);
        let rows: String = text
            .lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
            .collect();
        std::fs::write(&notemp, rows).unwrap();
        vec![
            ("in different units", g, good.clone()),
            ("implausible calibration", cubic, good.clone()),
            ("beyond ±16 g", drift, good.clone()),
            ("not a finite number", inf, good.clone()),
            ("no neighbours within 15 s", calibration(), lone),
            ("no temperature column", calibration(), notemp),
        ]
    };
    for (what, file, rec) in &cases {
        std::fs::write(&a, b"old").unwrap();
        std::fs::write(&b, b"old").unwrap();
        let [held, streamed] = both(file, rec, &opts, &a, &b);
        let held = held.unwrap_err();
        assert!(held.contains(what), "{what}: {held}");
        assert_eq!(Err(held), streamed);
        assert_eq!(
            std::fs::read(&b).unwrap(),
            b"old",
            "{what}: output replaced"
        );
    }
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(names.is_empty(), "temporary files left: {names:?}");
}

/// A recording whose linear magnitudes lie half at 0.3 g and half at 1.5 g: the counts cannot
/// settle the units check, the exact median (0.9 g) passes it; half at 0.3 g and half at
/// 0.6 g less one sample fails it at 0.3 g. Both paths agree on either.
#[test]
fn an_exact_median_decides_when_the_counts_cannot() {
    let (_g, dir) = scratch("median");
    let opts = LoadOptions::default();
    let (a, b) = (dir.join("held.csv"), dir.join("streamed.csv"));
    let mut file = calibration();
    file.host_terms.clear();
    let n = 10_000;
    for (split, hi_g, pass) in [(n / 2, 1.5, true), (n / 2 + 1, 0.6, false)] {
        let rec = dir.join("halves.csv");
        let scale = move |i: usize| if i < split { 0.3 * PER_G } else { hi_g * PER_G };
        std::fs::write(&rec, recording(n, scale, false)).unwrap();
        let [held, streamed] = both(&file, &rec, &opts, &a, &b);
        assert_eq!(held.is_ok(), pass, "{held:?}");
        if !pass {
            let e = held.as_ref().unwrap_err();
            assert!(e.contains("median magnitude is 0.3"), "{e}");
        }
        assert!(held == streamed, "{split}");
    }
}
