//! Window-mean input: files whose rows are already still windows (per-axis means, optionally
//! their within-window standard deviations, sample counts, temperature and time), as written
//! by free-living autocalibration tools such as GGIR (`g.calibrate`'s sphere data: one row per
//! still 10-s epoch over days of wear).
//!
//! Such a file must not go through the static detector: every row is one window already, and a
//! sample-level detector would find "windows" among the epochs. It is recognised by its header
//! — per-axis standard-deviation columns (`sdx`, `sd_x`, `x_sd`, `std_x`, …) or a sample-count
//! column (`n`, `samples`, `count`) — or forced with [`WindowInputOptions::force`] (the CLI's
//! `--windows`). Its rows become the analysis's [`crate::detect::windows::Windows`] directly (mean; variance = SD²;
//! count when given; temperature; time), and from there `fit` and `analyze` run the same
//! pipeline as for detected windows.
//!
//! Without a count column the noise floor var/n is unknown: it is left unknown (NaN per
//! window, `noise_floor_mg: null`), not guessed. The selection rule does not use the floor
//! (F-tests on the residuals and cross-validation), so effects are still chosen.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x >= 0.0)` is deliberately true for NaN.
use crate::error::input::InputError;
use crate::error::Result;
use crate::input::bounded::{parse_number, quote, read_text, MAX_RECORDING_BYTES};
pub use crate::input::table::WindowTable;
use crate::input::text;
use crate::input::text_csv::{blank_comments, is_comment_or_blank, Delimiter};
pub use crate::report::contract::WindowInputInfo;
use std::path::Path;

/// Most rows a window-mean table may have: 200 000 windows is 23 days of 10-s epochs, far
/// beyond what the greedy analysis handles in reasonable time (≈ 11 000 windows take tens of
/// seconds).
pub const MAX_WINDOW_ROWS: usize = 200_000;

/// Names of a sample-count column (lower-case).
const COUNT_NAMES: &[&str] = &[
    "n",
    "samples",
    "count",
    "n_samples",
    "nsamples",
    "sample_count",
];

/// Prefixes and suffixes that mark a standard-deviation column (after removing `_ - . `).
const SD_WORDS: &[&str] = &["sd", "std", "stdev", "stddev", "sigma"];

/// Options for reading a window-mean table.
#[derive(Debug, Clone, Default)]
pub struct WindowInputOptions {
    /// The loader's options (axis columns, sensor).
    pub load: text::LoadOptions,
    /// Take the rows as windows even without SD or count columns (`--windows`).
    pub force: bool,
}

/// Loads `path` as a window-mean table when its header says so or `opts.force`; `Ok(None)`
/// for an ordinary recording (read it with [`crate::load()`]; [`crate::input::front_door::load_input`]
/// reads either).
pub fn load_window_table(path: &Path, opts: &WindowInputOptions) -> Result<Option<WindowTable>> {
    let text = read_text(path, MAX_RECORDING_BYTES)?;
    parse_window_table(&text, opts).map_err(|e| e.in_file(path))
}

/// [`load_window_table`] on text.
pub fn parse_window_table(text: &str, opts: &WindowInputOptions) -> Result<Option<WindowTable>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    crate::input::bounded::check_line_lengths(text)?;
    let extra = read_extra_columns(text, opts)?;
    if extra.is_none() && !opts.force {
        return Ok(None);
    }
    let mut recording = text::parse(text, &opts.load)?;
    // Jumps between window times are expected (still epochs are scattered over the days):
    // the sample loader's notes about its time column do not apply to windows.
    recording.notes.clear();
    if recording.len() > MAX_WINDOW_ROWS {
        return Err(InputError::TooManyWindowRows {
            rows: recording.len(),
            max: MAX_WINDOW_ROWS,
        }
        .into());
    }
    let extra = extra.unwrap_or_default();
    if extra.rows != recording.len() && (extra.sd.is_some() || extra.count.is_some()) {
        // Both passes skip the same rows; a difference would be a bug here, never silent.
        return Err(InputError::WindowRowsMismatch {
            rows: recording.len(),
            values: extra.rows,
        }
        .into());
    }
    let info = WindowInputInfo {
        rows: recording.len(),
        sd_columns: extra.sd_names.clone(),
        count_column: extra.count_name.clone(),
        forced: extra.sd.is_none() && extra.count.is_none(),
        description: String::new(),
    };
    let mut table = WindowTable {
        recording,
        sd: extra.sd,
        count: extra.count,
        info,
    };
    table.info.description = describe(&table.info);
    Ok(Some(table))
}

/// "read as 10,958 window means (columns sdx,sdy,sdz): no static detection".
fn describe(info: &WindowInputInfo) -> String {
    let mut cols: Vec<String> = Vec::new();
    if let Some(sd) = &info.sd_columns {
        cols.push(sd.join(","));
    }
    if let Some(n) = &info.count_column {
        cols.push(n.clone());
    }
    let why = if cols.is_empty() {
        "as asked, no SD or count columns".to_string()
    } else {
        format!("columns {}", cols.join(", "))
    };
    format!(
        "read as {} window means ({why}): no static detection",
        thousands(info.rows)
    )
}

/// `10958` → `10,958`.
fn thousands(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// What the SD and count columns held.
#[derive(Default)]
struct Extra {
    rows: usize,
    sd_names: Option<[String; 3]>,
    count_name: Option<String>,
    sd: Option<Vec<[f64; 3]>>,
    count: Option<Vec<usize>>,
}

/// The header's SD and count columns and their values, bounded and checked (`None`: a header
/// without either, or no header at all).
fn read_extra_columns(text: &str, opts: &WindowInputOptions) -> Result<Option<Extra>> {
    let Some(first) = text.lines().find(|l| !is_comment_or_blank(l)) else {
        return Ok(None);
    };
    let Some(delim) = Delimiter::of_first_line(first) else {
        return Ok(None); // header-less numbers: no extra columns
    };
    let text = blank_comments(text);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .delimiter(delim.byte())
        .from_reader(text.as_bytes());
    let mut header: Option<(Vec<String>, Columns)> = None;
    let mut extra = Extra::default();
    let decimal_comma = delim == Delimiter::Semicolon;
    for result in reader.records() {
        let record = result.map_err(InputError::MalformedCsv)?;
        let line = record.position().map(|p| p.line() as usize).unwrap_or(0);
        if record.iter().all(|f| f.is_empty()) {
            continue;
        }
        let Some((names, cols)) = &header else {
            let fields: Vec<String> = record.iter().map(|f| f.to_ascii_lowercase()).collect();
            let numeric = fields.iter().filter(|f| f.parse::<f64>().is_ok()).count();
            if fields.len() == 2 && numeric == 1 {
                continue; // `key,value` metadata before the header
            }
            if numeric == fields.len() {
                return Ok(None); // the loader reports data before a header
            }
            let cols = find_columns(&fields, opts)?;
            if cols.sd.is_none() && cols.count.is_none() {
                return Ok(None);
            }
            extra.sd_names = cols.sd.map(|i| i.map(|k| fields[k].clone()));
            extra.count_name = cols.count.map(|k| fields[k].clone());
            extra.sd = cols.sd.map(|_| Vec::new());
            extra.count = cols.count.map(|_| Vec::new());
            header = Some((fields, cols));
            continue;
        };
        if record.len() != names.len() {
            continue; // the loader reports the ragged row
        }
        if cols.axes.iter().all(|&i| record[i].is_empty()) {
            continue; // skipped by the loader too
        }
        extra.rows += 1;
        if extra.rows > MAX_WINDOW_ROWS {
            return Err(InputError::TooManyWindowRows {
                rows: extra.rows,
                max: MAX_WINDOW_ROWS,
            }
            .into());
        }
        if let (Some(sd_cols), Some(sd)) = (cols.sd, extra.sd.as_mut()) {
            let mut row = [0.0; 3];
            for (a, &k) in sd_cols.iter().enumerate() {
                row[a] = read_sd(&record[k], line, &names[k], decimal_comma)?;
            }
            sd.push(row);
        }
        if let (Some(k), Some(count)) = (cols.count, extra.count.as_mut()) {
            count.push(read_count(&record[k], line, &names[k])?);
        }
    }
    Ok(header.map(|_| extra))
}

/// Column indices of the axes and the extra columns.
#[derive(Clone, Copy)]
struct Columns {
    axes: [usize; 3],
    sd: Option<[usize; 3]>,
    count: Option<usize>,
}

/// The axis triplet (as the loader picks it) and the SD / count columns by name.
fn find_columns(fields: &[String], opts: &WindowInputOptions) -> Result<Columns> {
    let axes = match &opts.load.columns {
        Some(c) => {
            let mut out = [usize::MAX; 3];
            for (a, name) in c.iter().enumerate() {
                let lower = name.to_ascii_lowercase();
                out[a] = fields
                    .iter()
                    .position(|f| *f == lower)
                    .unwrap_or(usize::MAX);
            }
            out
        }
        None => crate::input::columns::find_triplet(
            fields,
            opts.load
                .sensor
                .unwrap_or(crate::input::columns::Sensor::Accelerometer),
        )
        .map_or([usize::MAX; 3], |t| t.columns),
    };
    if axes.contains(&usize::MAX) {
        // The loader reports the missing axes; no extra columns without them.
        return Ok(Columns {
            axes: [0; 3],
            sd: None,
            count: None,
        });
    }
    let squash = |s: &str| s.replace(['_', '-', '.', ' '], "");
    let sd_of = |a: usize| {
        let letter = ["x", "y", "z"][a];
        let axis_name = squash(&fields[axes[a]]);
        fields.iter().position(|f| {
            let f = squash(f);
            SD_WORDS.iter().any(|w| {
                [letter, axis_name.as_str()]
                    .iter()
                    .any(|ax| f == format!("{w}{ax}") || f == format!("{ax}{w}"))
            })
        })
    };
    let found: [Option<usize>; 3] = std::array::from_fn(sd_of);
    let sd = match found {
        [Some(x), Some(y), Some(z)] => Some([x, y, z]),
        [None, None, None] => None,
        _ => {
            let names: Vec<&str> = found
                .iter()
                .flatten()
                .map(|&k| fields[k].as_str())
                .collect();
            let axis = ["x", "y", "z"][found.iter().position(Option::is_none).unwrap_or(0)];
            return Err(InputError::WindowSdColumnMissing {
                found: names.join(","),
                axis,
            }
            .into());
        }
    };
    let count = fields
        .iter()
        .position(|f| COUNT_NAMES.contains(&f.as_str()));
    Ok(Columns { axes, sd, count })
}

/// A standard deviation: finite and ≥ 0.
fn read_sd(
    text: &str,
    line: usize,
    column: &str,
    decimal_comma: bool,
) -> std::result::Result<f64, InputError> {
    let bad = || InputError::WindowSdInvalid {
        line,
        column: quote(column),
        text: quote(text),
    };
    let v = parse_number(text, line, column, decimal_comma).map_err(|_| bad())?;
    if !(v >= 0.0) {
        return Err(bad());
    }
    Ok(v)
}

/// A sample count: an integer ≥ 2 (at most 2⁴⁰, far beyond any recording).
fn read_count(text: &str, line: usize, column: &str) -> std::result::Result<usize, InputError> {
    let bad = || InputError::WindowCountInvalid {
        line,
        column: quote(column),
        text: quote(text),
    };
    let v: f64 = text.parse().map_err(|_| bad())?;
    if !(v.is_finite() && v.fract() == 0.0 && (2.0..=(1u64 << 40) as f64).contains(&v)) {
        return Err(bad());
    }
    Ok(v as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, force: bool) -> Result<Option<WindowTable>> {
        parse_window_table(
            text,
            &WindowInputOptions {
                force,
                ..Default::default()
            },
        )
    }

    #[test]
    fn sd_and_count_headers_are_recognised() {
        for header in [
            "t,x,y,z,temp,sdx,sdy,sdz,en",
            "t,x,y,z,sd_x,sd_y,sd_z",
            "t,x,y,z,x_sd,y_sd,z_sd",
            "t,ax,ay,az,std_ax,std_ay,std_az",
            "t,x,y,z,n",
        ] {
            let cols = header.split(',').count();
            let mut text = format!("{header}\n");
            for i in 0..3 {
                let mut row = vec![format!("{}", i * 10), "0.1".into(), "0.2".into()];
                row.push("0.97".into());
                while row.len() < cols {
                    row.push("5".into());
                }
                text += &(row.join(",") + "\n");
            }
            let t = read(&text, false)
                .unwrap()
                .unwrap_or_else(|| panic!("{header}"));
            assert_eq!(t.info.rows, 3, "{header}");
            assert!(!t.info.forced);
            assert_eq!(t.recording.len(), 3);
            assert_eq!(t.recording.t.as_ref().unwrap()[2], 20.0);
        }
        let t = read("t,x,y,z,sdx,sdy,sdz\n0,0.01,0,1,0.01,0.02,0.03\n", false)
            .unwrap()
            .unwrap();
        assert_eq!(
            t.info.description,
            "read as 1 window means (columns sdx,sdy,sdz): no static detection"
        );
        assert_eq!(t.sd.as_deref(), Some(&[[0.01, 0.02, 0.03]][..]));
        assert_eq!(t.count, None);
    }

    #[test]
    fn ordinary_recordings_are_not_tables_unless_forced() {
        let text = "t,x,y,z,temp\n0,0,0,1,20\n0.01,0,0,1,20\n";
        assert!(read(text, false).unwrap().is_none());
        let t = read(text, true).unwrap().unwrap();
        assert!(t.info.forced);
        assert!(
            t.info.description.contains("as asked"),
            "{}",
            t.info.description
        );
        assert!(t.sd.is_none());
        // Header-less numbers, forced: two rows without time.
        let t = read("0 0 1\n0 1 0\n", true).unwrap().unwrap();
        assert_eq!((t.recording.len(), t.recording.t.is_none()), (2, true));
    }

    #[test]
    fn bad_sd_count_and_columns_are_errors_naming_line_and_column() {
        let e = read(
            "t,x,y,z,sdx,sdy,sdz\n0,0,0,1,0.1,0.1,0.1\n10,0,0,1,0.1,-0.2,0.1\n",
            false,
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "line 3: column 'sdy': window standard deviation '-0.2' must be a finite number ≥ 0"
        );
        let e = read("t,x,y,z,sdx,sdy,sdz\n0,0,0,1,0.1,NaN,0.1\n", false)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("line 2: column 'sdy'"), "{e}");
        for bad in ["1", "2.5", "-3", "x", "inf"] {
            let e = read(&format!("x,y,z,n\n0,0,1,{bad}\n"), false)
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("line 2: column 'n': sample count"),
                "{bad}: {e}"
            );
        }
        let e = read("x,y,z,sdx,sdz\n0,0,1,0.1,0.1\n", false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("none for axis y"), "{e}");
        // Means are checked by the loader as for any file.
        let e = read("x,y,z,sdx,sdy,sdz\n0,zz,1,0.1,0.1,0.1\n", false)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "line 2: column 'y': 'zz' is not a number");
    }

    #[test]
    fn thousands_separator() {
        assert_eq!(thousands(7), "7");
        assert_eq!(thousands(10958), "10,958");
        assert_eq!(thousands(1234567), "1,234,567");
    }

    proptest::proptest! {
        /// Arbitrary SD / count fields never panic; what is accepted is finite, ≥ 0, ≥ 2.
        #[test]
        fn arbitrary_sd_and_count_fields(
            fields in proptest::collection::vec(("[-0-9.eEinfNa]{0,8}", "[-0-9.eE]{0,6}"), 1..20),
            force in proptest::bool::ANY,
        ) {
            let mut text = String::from("x,y,z,sdx,sdy,sdz,n\n");
            for (sd, n) in &fields {
                text += &format!("0.01,0.02,1,{sd},0.001,0.002,{n}\n");
            }
            if let Ok(Some(t)) = read(&text, force) {
                proptest::prop_assert_eq!(t.recording.len(), fields.len());
                let sd = t.sd.as_deref().unwrap_or_default();
                proptest::prop_assert_eq!(sd.len(), fields.len());
                proptest::prop_assert!(sd.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
                let count = t.count.as_deref().unwrap_or_default();
                proptest::prop_assert_eq!(count.len(), fields.len());
                proptest::prop_assert!(count.iter().all(|n| *n >= 2));
            }
        }
    }
}
