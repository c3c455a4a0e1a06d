//! Test support shared by the core's integration tests: where the real recordings are.

use std::path::PathBuf;

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`. Fails loudly when
/// missing, so a test on real data can never pass by skipping its data.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("WIICAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    assert!(
        dir.is_dir(),
        "data directory {} is missing: set WIICAL_DATA to the shared/data folder",
        dir.display()
    );
    dir
}

/// A recording's accelerometer samples and sample rate, read in place (test support only: the
/// host has the real parser). Formats: IMU-TK's whitespace `.mat` text (`t x y z`), and CSV
/// with optional `key,value` metadata lines (`Fs,100`) before a header; the accelerometer
/// columns are the first of `ax`/`acc_x…`/`x` (and y, z), the time column `t` or `t_s`.
#[allow(dead_code)] // not every test binary uses it
pub fn load_accelerometer(path: &std::path::Path) -> (Vec<[f64; 3]>, Option<f64>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    if path.extension().is_some_and(|e| e == "mat") {
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
            .collect();
        let rate = (rows.len() - 1) as f64 / (rows[rows.len() - 1][0] - rows[0][0]);
        return (
            rows.iter().map(|v| [v[1], v[2], v[3]]).collect(),
            Some(rate),
        );
    }
    let mut lines = text.lines();
    let mut rate = None;
    let header: Vec<String> = loop {
        let l = lines.next().expect("a header line");
        let cells: Vec<String> = l.split(',').map(|c| c.trim().to_lowercase()).collect();
        if cells.len() == 2 && cells[0] == "fs" {
            rate = cells[1].parse().ok();
        }
        if cells.len() >= 3 {
            break cells;
        }
    };
    let find = |axis: &str| {
        let pats = [format!("a{axis}"), format!("acc_{axis}"), axis.to_string()];
        pats.iter()
            .find_map(|p| {
                header
                    .iter()
                    .position(|h| h == p || h.starts_with(&format!("{p}_")))
            })
            .unwrap_or_else(|| panic!("no {axis} column in {header:?}"))
    };
    let cols = [find("x"), find("y"), find("z")];
    let tcol = header.iter().position(|h| h == "t" || h == "t_s");
    let mut xyz = Vec::new();
    let mut times = Vec::new();
    for l in lines.filter(|l| !l.trim().is_empty()) {
        let v: Vec<f64> = l
            .split(',')
            .map(|c| c.trim().parse().unwrap_or(f64::NAN))
            .collect();
        xyz.push(cols.map(|c| v[c]));
        if let Some(t) = tcol {
            times.push(v[t]);
        }
    }
    if times.len() > 1 {
        rate = Some((times.len() - 1) as f64 / (times[times.len() - 1] - times[0]));
    }
    (xyz, rate)
}
