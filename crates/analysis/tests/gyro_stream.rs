//! `gyrofit` on text files streamed in passes (`gyro::open_text`, `ImuPair::motions`: the rows never held) gives the
//! report of the same files held in memory, bit for bit: the whole JSON compared, on every real
//! recording `gyrofit` reads as plain text (the MPU-9150 units, sunsided's MPU-6050 logs, and
//! IMU-TK's Xsens pair when its text is streamed), on a few-MiB file made of an MPU-9150 log
//! repeated with a continuing clock, and on the refusals (a still log, the pair given swapped).

mod common;

use std::path::{Path, PathBuf};
use wiical_analysis::gyro::{self, open_text as open, GyroOptions, TextImu};
use wiical_analysis::input::columns::LoadOptions;
use wiical_analysis::input::front_door::load_imu;

/// The options `gyrofit` takes for `--counts-per-dps 16.384`, or the nominal estimated.
fn options(counts_per_dps: Option<f64>) -> GyroOptions {
    match counts_per_dps {
        Some(c) => GyroOptions::new([1f64.to_radians() / c; 3]),
        None => GyroOptions::estimated(),
    }
}

/// The report (or the error's sentence) as JSON text.
fn outcome<E: std::fmt::Display>(r: Result<gyro::GyroReport, E>) -> String {
    match r {
        Ok(rep) => serde_json::to_string(&rep).unwrap(),
        Err(e) => format!("error: {e}"),
    }
}

/// The motion fit on the files `imu` read in passes ([`TextImu::motions`]): a file's failure
/// and the fit's own error as one.
fn run_text(imu: &TextImu, opts: &GyroOptions) -> wiical_analysis::Result<gyro::GyroReport> {
    Ok(imu.motions(opts)??)
}

/// Held and streamed outcomes of `acc` (and `gyro_file`), asserted streamed.
fn both(acc: &Path, gyro_file: Option<&Path>, opts: &GyroOptions) -> (String, String) {
    let load = LoadOptions::default();
    let held = match gyro_file {
        None => {
            let (a, g) = load_imu(acc, &load, None).unwrap();
            outcome(gyro::run(&a, &g, opts))
        }
        Some(g) => {
            let a = wiical_analysis::load(acc, &load).unwrap();
            let g = wiical_analysis::load(g, &load).unwrap();
            outcome(gyro::run(&a, &g, opts))
        }
    };
    let imu = open((acc, &load), gyro_file.map(|g| (g, &load)), None, 0)
        .unwrap()
        .unwrap_or_else(|| panic!("{acc:?} not streamed"));
    (held, outcome(run_text(&imu, opts)))
}

fn data(rel: &str) -> PathBuf {
    common::data_dir().join(rel)
}

#[test]
fn mpu9150_units_stream_to_the_held_report() {
    for i in 0..5 {
        let path = data(&format!("mpu9150_mikoff_5units/imu{i}.csv"));
        let (held, streamed) = both(&path, None, &options(Some(16.384)));
        assert!(held.starts_with('{'), "{held}");
        assert_eq!(held, streamed, "imu{i}");
    }
    let path = data("mpu9150_mikoff_5units/imu1.csv");
    let (held, streamed) = both(&path, None, &options(None));
    assert_eq!(held, streamed, "imu1, nominal estimated");
}

#[test]
fn sunsided_logs_stream_to_the_held_report_or_refusal() {
    let dir = data("mpu6050_hmc5883l_sunsided_set2");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with("_mpu6050.csv"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 5);
    let mut refused = 0;
    for path in &files {
        let (held, streamed) = both(path, None, &options(None));
        refused += usize::from(held.starts_with("error"));
        assert_eq!(held, streamed, "{path:?}");
    }
    // The three unmoved logs and the roll-and-tilt one are refused; the full sphere is fitted.
    assert_eq!(refused, 4);
}

/// IMU-TK's Xsens pair is header-less whitespace text, which the streamed text source
/// declines (it reads files with a header): `gyrofit` reads the pair whole, as before.
#[test]
fn the_headerless_xsens_pair_is_read_whole() {
    let acc = data("imu_tk_xsens/xsens_acc.mat");
    let gyro_file = data("imu_tk_xsens/xsens_gyro.mat");
    let load = LoadOptions::default();
    let opened = open((&acc, &load), Some((&gyro_file, &load)), None, 0).unwrap();
    assert!(opened.is_none());
}

/// An MPU-9150 log repeated `copies` times with a continuing clock (each copy's times shifted
/// by the log's span plus one step), as `scripts/make-big-imu imu` writes it.
fn repeated(src: &Path, out: &Path, copies: usize) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<(f64, &str)> = lines
        .map(|l| {
            let (t, rest) = l.split_once(',').unwrap();
            (t.parse().unwrap(), rest)
        })
        .collect();
    let step = (rows[rows.len() - 1].0 - rows[0].0) / (rows.len() - 1) as f64;
    let span = rows[rows.len() - 1].0 - rows[0].0 + step;
    let mut s = format!("{header}\n");
    for c in 0..copies {
        for (t, rest) in &rows {
            s.push_str(&format!("{:.2},{rest}\n", c as f64 * span + t));
        }
    }
    std::fs::write(out, s).unwrap();
}

#[test]
fn a_few_mib_log_streams_to_the_held_report() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu-3mb.csv");
    repeated(&data("mpu9150_mikoff_5units/imu1.csv"), &path, 6);
    assert!(std::fs::metadata(&path).unwrap().len() > 2 << 20);
    let (held, streamed) = both(&path, None, &options(Some(16.384)));
    assert!(held.contains("\"motions\":"), "{held}");
    assert_eq!(held, streamed);
}

/// A file named with gyro columns that are not a gyroscope's is refused by the stream as by
/// the held reading; a file that changes after its first pass gives the report of the file
/// as it was (the later passes read the rows the first kept).
#[test]
fn unnamed_gyro_columns_and_a_changed_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("acc.csv");
    std::fs::write(
        &path,
        "t,x,y,z\n0,1,2,3\n0.01,1,2,3\n0.02,1,2,3\n0.03,1,2,4\n",
    )
    .unwrap();
    let e = open((&path, &LoadOptions::default()), None, None, 0).unwrap_err();
    assert!(e.to_string().contains("acc.csv"), "{e}");
    let held = load_imu(&path, &LoadOptions::default(), None).unwrap_err();
    assert_eq!(e.full_message(), held.full_message());
    let log = dir.path().join("imu.csv");
    repeated(&data("mpu9150_mikoff_5units/imu1.csv"), &log, 1);
    let imu = open((&log, &LoadOptions::default()), None, None, 0)
        .unwrap()
        .unwrap();
    let want = outcome(run_text(&imu, &options(Some(16.384))));
    let text = std::fs::read_to_string(&log).unwrap();
    std::fs::write(&log, text.replace("0.00,", "0.000,")).unwrap();
    let got = outcome(run_text(&imu, &options(Some(16.384))));
    assert!(want.starts_with('{'), "{want}");
    assert_eq!(got, want);
}

/// An MPU-9150 log split into an accelerometer file and a gyro file (both with a header): the
/// pair streams to the held report, and given in swapped order is refused alike.
#[test]
fn a_two_file_pair_streams_to_the_held_report_and_swapped_is_refused_alike() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("mpu9150_mikoff_5units/imu2.csv")).unwrap();
    let (mut acc, mut gyro) = (String::new(), String::new());
    for line in text.lines() {
        let f: Vec<&str> = line.split(',').collect();
        acc.push_str(&format!("{},{},{},{}\n", f[0], f[1], f[2], f[3]));
        gyro.push_str(&format!("{},{},{},{}\n", f[0], f[4], f[5], f[6]));
    }
    let (a, g) = (dir.path().join("acc.csv"), dir.path().join("gyro.csv"));
    std::fs::write(&a, acc).unwrap();
    std::fs::write(&g, gyro).unwrap();
    let opts = options(Some(16.384));
    let (held, streamed) = both(&a, Some(&g), &opts);
    assert!(held.starts_with('{'), "{held}");
    assert_eq!(held, streamed);
    let (held, streamed) = both(&g, Some(&a), &opts);
    assert!(held.contains("swapped"), "{held}");
    assert_eq!(held, streamed);
}

/// `gyrofit`'s library entry ([`wiical_analysis::gyrofit`], held) and [`gyrofit_of`] on the
/// same file streamed: the JSON of each, or its error.
fn entry_both(rel: &str, table_rates_dps: Option<Vec<f64>>) -> (String, String) {
    use wiical_analysis::gyro::request::{gyrofit_of, Gyrofit};
    let path = data(rel);
    let req = wiical_analysis::GyrofitRequest {
        table_rates_dps,
        ..wiical_analysis::GyrofitRequest::new(&path)
    };
    let text = |r: wiical_analysis::Result<Gyrofit>| match r {
        Ok(f) => serde_json::to_string(&f).unwrap(),
        Err(e) => format!("error: {e}"),
    };
    let load = LoadOptions::default();
    let imu = open((&path, &load), None, None, 0)
        .unwrap()
        .expect("streamed");
    let streamed = text(gyrofit_of(&req, &imu));
    (text(wiical_analysis::gyrofit(&req)), streamed)
}

/// The protocols' methods, which `gyrofit` falls back to when the motions between poses say
/// the recording is another protocol's (or runs for a gyro-only file, or given table rates),
/// read a large file in passes to the held report: imucal's Ferraris session (its turns and
/// g-sensitivity), the BMI160 rate table with and without its 25 °/s (`rate-table`, else the
/// rests' bias alone), and a still ADIS16405 log (the bias alone).
#[test]
fn the_protocol_fallback_streams_to_the_held_report() {
    for (rel, rates, method) in [
        (
            "imucal_nilspod_ferraris/ferraris_session.csv",
            None,
            "ferraris",
        ),
        (
            "apophis_bmi160_table/rate_table.csv",
            Some(vec![25.0]),
            "rate-table",
        ),
        ("apophis_bmi160_table/rate_table.csv", None, "rest-bias"),
        ("adis16405_static_smac/imu1.csv.gz", None, "rest-bias"),
    ] {
        let (held, streamed) = entry_both(rel, rates);
        assert!(
            held.contains(&format!("\"method\":\"{method}\"")),
            "{rel}: {held}"
        );
        assert_eq!(held, streamed, "{rel}");
    }
}
