//! A plain text file streamed in passes (`Input::Stream`: its samples never held) gives
//! `fit --json` and `analyze --json` identical to the same file read into memory, on
//! simulated recordings with known truth: 16-bit counts with a temperature column and a
//! temperature effect (the thermal terms folded in a pass), the same in g (the quantiser
//! lattice mapped back from the first pass's distinct values), without a time column, and
//! with the fixed IMU-TK detector; and a file that changes after its first pass is read as
//! it was. The later passes read back the rows the first kept, in memory or in a temporary
//! file: the same windows and reports either way.

use std::path::Path;
use wiical_analysis::input::front_door::{load_input, Input};
use wiical_analysis::input::window_means::WindowInputOptions;
use wiical_analysis::pipeline::{analyze_judged, fit_judged};
use wiical_analysis::{AnalyzeOptions, FitOptions};
use wiical_sim::{Device, EffectSpec, SimConfig, SimEffect};

/// `path` read with plain text files of at least `stream_from` bytes streamed.
fn load_input_from(path: &Path, opts: &WindowInputOptions, stream_from: u64) -> Input {
    let mut opts = opts.clone();
    opts.load.read.stream_from_bytes = stream_from;
    load_input(path, &opts).unwrap()
}

/// The file read both ways: (streamed, held).
fn both(path: &Path) -> (Input, Input) {
    let opts = WindowInputOptions::default();
    let streamed = load_input_from(path, &opts, 0);
    let held = load_input_from(path, &opts, u64::MAX);
    assert!(
        matches!(streamed, Input::Stream(_)),
        "{path:?} not streamed"
    );
    assert!(matches!(held, Input::Samples(_)), "{path:?} not held");
    assert_eq!(streamed.len(), held.len());
    assert_eq!(streamed.recording().notes, held.recording().notes);
    (streamed, held)
}

/// `fit` and `analyze` JSON of both readings, asserted equal; the analysis returned.
fn same_reports(path: &Path, fit: &FitOptions, analyze: &AnalyzeOptions) -> serde_json::Value {
    let (streamed, held) = both(path);
    let f_s = json(&fit_judged(&streamed, fit).unwrap());
    let f_h = json(&fit_judged(&held, fit).unwrap());
    assert_eq!(f_s, f_h, "fit of {path:?}");
    let a_s = json(&analyze_judged(&streamed, analyze).unwrap());
    let a_h = json(&analyze_judged(&held, analyze).unwrap());
    assert_eq!(a_s, a_h, "analyze of {path:?}");
    serde_json::from_str(&a_s).unwrap()
}

/// A report as its JSON text.
fn json<T: serde::Serialize>(v: &T) -> String {
    serde_json::to_string(v).unwrap()
}

fn sim_csv(
    dir: &Path,
    name: &str,
    temp_effect: bool,
) -> (std::path::PathBuf, wiical_sim::SimOutput) {
    let out = wiical_sim::simulate(&SimConfig {
        effects: if temp_effect {
            vec![EffectSpec::new(SimEffect::Temperature, Some(20.0))]
        } else {
            Vec::new()
        },
        seed: 7,
        device: Device::Mems16,
        poses: 24,
        temp_column: true,
        ..Default::default()
    })
    .unwrap();
    let path = dir.join(name);
    std::fs::write(&path, wiical_sim::to_csv(&out.recording)).unwrap();
    (path, out)
}

/// A 16-bit MEMS in m/s² (counts on a lattice) with a temperature column and a 20 mg
/// temperature effect: the same reports both ways, and the effect put in is the one found.
#[test]
fn streamed_values_with_temperature_give_the_held_reports() {
    let dir = tempfile::tempdir().unwrap();
    let (path, out) = sim_csv(dir.path(), "ms2.csv", true);
    assert!(!out.recording.is_integer());
    let rep = same_reports(&path, &FitOptions::default(), &AnalyzeOptions::default());
    let effects: Vec<&str> = rep["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert!(
        effects.iter().any(|e| e.contains("temperature")),
        "{effects:?}"
    );
    assert_eq!(rep["samples"].as_u64(), Some(out.recording.len() as u64));
}

/// The same recording in g (a lattice of non-integer values), in integer counts without a
/// time column (an `Fs` line gives the rate; the ADC range is inferred from the counts), and
/// with the fixed detector: the same reports both ways.
#[test]
fn streamed_g_values_without_times_and_the_fixed_detector_give_the_held_reports() {
    let dir = tempfile::tempdir().unwrap();
    let (_, out) = sim_csv(dir.path(), "ms2.csv", false);
    let g = String::from("t,x,y,z,temp\n") + &g_rows(&out.recording, 0.0);
    let mut no_t = String::from("Fs,100\nx,y,z,temp\n");
    for (i, counts) in counts_of(&out.recording).into_iter().enumerate() {
        let temp = out.recording.temp.as_ref().unwrap()[i];
        let [x, y, z] = counts;
        no_t += &format!("{x},{y},{z},{temp:.2}\n");
    }
    let g_path = dir.path().join("g.csv");
    std::fs::write(&g_path, g).unwrap();
    let no_t_path = dir.path().join("counts_no_t.csv");
    std::fs::write(&no_t_path, no_t).unwrap();
    same_reports(&g_path, &FitOptions::default(), &AnalyzeOptions::default());
    same_reports(
        &no_t_path,
        &FitOptions::default(),
        &AnalyzeOptions::default(),
    );
    let mut fixed = AnalyzeOptions::default();
    fixed.fit.detect.adaptive = false;
    same_reports(&g_path, &fixed.fit, &fixed);
}

/// The simulated 16-bit recording's values as whole counts.
fn counts_of(rec: &wiical_analysis::Recording) -> Vec<[f64; 3]> {
    let per_count = Device::Mems16.unit_per_count();
    rec.xyz
        .iter()
        .map(|m| m.map(|v| (v / per_count).round()))
        .collect()
}

/// The recording's rows in g (its counts over counts-per-g: a lattice of non-integer values),
/// `t,x,y,z,temp`, its times (at 100 Hz) shifted by `t0`.
fn g_rows(rec: &wiical_analysis::Recording, t0: f64) -> String {
    let per_g = Device::Mems16.counts_per_g();
    let times = rec.times(100.0);
    let mut g = String::new();
    for (i, counts) in counts_of(rec).into_iter().enumerate() {
        let temp = rec.temp.as_ref().unwrap()[i];
        let [x, y, z] = counts.map(|c| c / per_g);
        g += &format!("{:.5},{x},{y},{z},{temp:.2}\n", times[i] + t0);
    }
    g
}

/// A file that grows after its first pass changes nothing: the later passes read the rows
/// the first kept, and give the report of the file as it was.
#[test]
fn a_file_changed_after_its_first_pass_is_read_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = sim_csv(dir.path(), "ms2.csv", false);
    let (streamed, held) = both(&path);
    std::thread::sleep(std::time::Duration::from_millis(20));
    let mut text = std::fs::read_to_string(&path).unwrap();
    text.push_str("1e9,1,2,3,20\n");
    std::fs::write(&path, text).unwrap();
    let fit = FitOptions::default();
    let want = json(&fit_judged(&held, &fit).unwrap());
    assert_eq!(json(&fit_judged(&streamed, &fit).unwrap()), want);
}

/// `text` gzip'd in `members` members (as `cat a.gz b.gz > c.gz` makes them).
fn gzip_members(text: &[u8], members: usize) -> Vec<u8> {
    use std::io::Write;
    let step = text.len().div_ceil(members);
    text.chunks(step)
        .flat_map(|part| {
            let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            z.write_all(part).unwrap();
            z.finish().unwrap()
        })
        .collect()
}

/// A gzip'd recording is streamed as the plain file is, decompressed afresh in every pass,
/// in small pieces (many pieces per pass): `fit` and `analyze` give the reports of the same
/// text uncompressed and read into memory; with the streaming size out of reach it is read
/// whole, alike again. The effect put into the simulation is the one found.
#[test]
fn a_gzip_file_is_streamed_and_gives_the_plain_file_reports() {
    use wiical_analysis::input::front_door::load_input_in;
    let dir = tempfile::tempdir().unwrap();
    let (path, out) = sim_csv(dir.path(), "ms2.csv", true);
    let gz = dir.path().join("ms2.csv.gz");
    std::fs::write(&gz, gzip_members(&std::fs::read(&path).unwrap(), 3)).unwrap();
    let opts = WindowInputOptions::default();
    let held = load_input_from(&path, &opts, u64::MAX);
    let streamed = load_input_in(&gz, &opts, 0, 64 << 10).unwrap();
    let gz_held = load_input_from(&gz, &opts, u64::MAX);
    assert!(matches!(held, Input::Samples(_)));
    assert!(matches!(streamed, Input::Stream(_)), "gzip not streamed");
    assert!(matches!(gz_held, Input::Samples(_)));
    let (fit, analyze) = (FitOptions::default(), AnalyzeOptions::default());
    let want_fit = json(&fit_judged(&held, &fit).unwrap());
    let want_analyze = json(&analyze_judged(&held, &analyze).unwrap());
    for input in [&streamed, &gz_held] {
        assert_eq!(json(&fit_judged(input, &fit).unwrap()), want_fit);
        assert_eq!(
            json(&analyze_judged(input, &analyze).unwrap()),
            want_analyze
        );
    }
    let rep: serde_json::Value = serde_json::from_str(&want_analyze).unwrap();
    assert_eq!(rep["samples"].as_u64(), Some(out.recording.len() as u64));
    let effects = rep["effects"].to_string();
    assert!(effects.contains("temperature"), "{effects}");
}

/// A streamed input's windows as text (every value as its shortest exact decimal).
fn windows_text(input: &Input, opts: &wiical_analysis::detect::windows::DetectOptions) -> String {
    let Input::Stream(src) = input else {
        panic!("not streamed")
    };
    let w = wiical_analysis::detect::windows::detect_windows(&**src, opts).unwrap();
    src.check().unwrap();
    format!(
        "{:?} {:?} {} {:?}",
        w.stats, w.clock, w.units, w.reference_variance
    )
}

/// The rows read back from the temporary file (many blocks: small pieces) give the windows,
/// `fit` and `analyze` of the rows kept in memory, bit for bit, for the adaptive and the fixed
/// detector, with and without a time column.
#[test]
fn the_rows_read_back_from_disk_give_the_windows_of_the_rows_in_memory() {
    use wiical_analysis::input::front_door::load_input_in;
    use wiical_analysis::input::read_options::SpillMode;
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = sim_csv(dir.path(), "ms2.csv", true);
    let text = std::fs::read_to_string(&path).unwrap();
    let no_t: String = text
        .lines()
        .map(|l| l.split_once(',').unwrap().1.to_string() + "\n")
        .collect();
    let no_t_path = dir.path().join("no_t.csv");
    std::fs::write(&no_t_path, format!("Fs,100\n{no_t}")).unwrap();
    let opts = WindowInputOptions::default();
    let mut disk = WindowInputOptions::default();
    disk.load.read.spill = SpillMode::Disk;
    for path in [&path, &no_t_path] {
        let spilled = load_input_in(path, &disk, 0, 64 << 10).unwrap();
        let in_memory = load_input_in(path, &opts, 0, 64 << 10).unwrap();
        let (Input::Stream(s), Input::Stream(m)) = (&spilled, &in_memory) else {
            panic!("{path:?} not streamed")
        };
        assert!(
            !s.is_spill_in_memory() && m.is_spill_in_memory(),
            "{path:?}"
        );
        let in_memory_read = in_memory;
        let mut fixed = AnalyzeOptions::default();
        fixed.fit.detect.adaptive = false;
        for analyze in [AnalyzeOptions::default(), fixed] {
            let detect = &analyze.fit.detect;
            let want = windows_text(&in_memory_read, detect);
            assert_eq!(windows_text(&spilled, detect), want, "{path:?}");
            let fit = json(&fit_judged(&in_memory_read, &analyze.fit).unwrap());
            assert_eq!(json(&fit_judged(&spilled, &analyze.fit).unwrap()), fit);
            let rep = json(&analyze_judged(&in_memory_read, &analyze).unwrap());
            assert_eq!(json(&analyze_judged(&spilled, &analyze).unwrap()), rep);
        }
    }
}

/// A recording in g (values on a lattice of 1/counts-per-g) whose first rows all read whole
/// numbers (resting at exactly 0, 0, 1 g): the first pass keeps no distinct values while they
/// are all whole, so the lattice is found in a pass of its own, and the reports are the held
/// file's.
#[test]
fn a_lattice_after_whole_first_rows_is_found_and_gives_the_held_reports() {
    use wiical_analysis::input::front_door::load_input_in;
    use wiical_analysis::input::sample_summary::Distinct;
    let dir = tempfile::tempdir().unwrap();
    let (_, out) = sim_csv(dir.path(), "ms2.csv", false);
    let mut g = String::from("t,x,y,z,temp\n");
    for i in 0..3000 {
        g += &format!("{:.5},0,0,1,25.00\n", i as f64 * 0.01);
    }
    g += &g_rows(&out.recording, 30.0);
    let path = dir.path().join("g_whole_first.csv");
    std::fs::write(&path, g).unwrap();
    let opts = WindowInputOptions::default();
    let streamed = load_input_in(&path, &opts, 0, 16 << 10).unwrap();
    let Input::Stream(src) = &streamed else {
        panic!("not streamed")
    };
    assert!(!src.summary.integer);
    assert_eq!(src.summary.distinct, Distinct::NotKept);
    let held = load_input_from(&path, &opts, u64::MAX);
    let mut fixed = AnalyzeOptions::default();
    fixed.fit.detect.adaptive = false;
    for analyze in [AnalyzeOptions::default(), fixed] {
        // The same report, or the same refusal (the fixed detector's rest period is the
        // constant first rows: too few windows either way).
        let fit = |input| outcome(fit_judged(input, &analyze.fit));
        assert_eq!(fit(&streamed), fit(&held));
        let rep = |input| outcome(analyze_judged(input, &analyze));
        assert_eq!(rep(&streamed), rep(&held));
    }
    assert!(fit_judged(&streamed, &FitOptions::default()).is_ok());
}

/// A report as its JSON text, or the error's sentence.
fn outcome<T: serde::Serialize>(r: wiical_analysis::error::Result<T>) -> String {
    r.map_or_else(|e| e.to_string(), |v| json(&v))
}
