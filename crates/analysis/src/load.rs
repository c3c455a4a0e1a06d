//! Loading recordings: CSV with a header naming the columns, or header-less
//! whitespace-separated numeric text (`t x y z`, as in IMU-TK's test data).
//!
//! Accepted shapes:
//! * CSV (comma or semicolon) with a header line. Column names map by meaning, case-insensitive:
//!   time `t|time|timestamp|time_s`, axes by pattern (`x`, `ax`, `acc_x_g`, `AccX`,
//!   `mag_x_gauss`, `gyro_x_dps`, … see [`crate::columns`]: the wanted sensor's triplet),
//!   temperature `temp|temperature|temp_c`, pose label `pose|label`. A different triplet can be
//!   chosen with [`LoadOptions::columns`]. Lines before the header of the form `key,value`
//!   (e.g. `Fs,100`) are metadata; `Fs` gives the sample rate.
//! * Whitespace-separated numbers without a header: 3 columns `x y z`, 4 columns `t x y z`,
//!   5 columns `t x y z temp`. Lines starting with `#` or `%` are comments.
//!
//! Every value must be finite; the first bad line is reported with its number.

use crate::columns::Sensor;
use crate::error::{Error, Result};
use crate::recording::Recording;
use std::path::Path;

/// Options for [`load`].
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Explicit header names for the x, y, z columns (e.g. `["gx","gy","gz"]`).
    pub columns: Option<[String; 3]>,
    /// Which sensor's triplet to take from a header naming several
    /// ([`crate::columns`]; `None`: the accelerometer).
    pub sensor: Option<Sensor>,
}

/// Loads a recording from a file; see the module docs for the accepted formats.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Recording> {
    let bytes = std::fs::read(path).map_err(|source| Error::Read {
        path: path.into(),
        source,
    })?;
    let text = String::from_utf8(bytes).map_err(|_| Error::NotUtf8 { path: path.into() })?;
    parse(&text, opts).map_err(|e| e.in_file(path))
}

fn is_comment_or_blank(line: &str) -> bool {
    let l = line.trim();
    l.is_empty() || l.starts_with('#') || l.starts_with('%')
}

/// Parses recording text (see [`load`]).
pub fn parse(text: &str, opts: &LoadOptions) -> Result<Recording> {
    let first = text
        .lines()
        .find(|l| !is_comment_or_blank(l))
        .ok_or(Error::Empty)?;
    if first.contains(',') || first.contains(';') {
        parse_csv(text, opts)
    } else {
        if opts.columns.is_some() {
            return Err(Error::ColumnsNeedHeader);
        }
        parse_whitespace(text)
    }
}

/// Parses one field. Callers hand over fields already free of surrounding blanks (split on
/// ASCII whitespace, or trimmed by the CSV reader).
fn parse_number(s: &str, line_no: usize, col: &str) -> Result<f64> {
    let v: f64 = s.parse().map_err(|_| Error::NotANumber {
        line: line_no,
        column: col.into(),
        text: s.into(),
    })?;
    if !v.is_finite() {
        return Err(Error::NotFinite {
            line: line_no,
            column: col.into(),
            text: s.into(),
        });
    }
    Ok(v)
}

fn parse_whitespace(text: &str) -> Result<Recording> {
    let mut rec = Recording::default();
    let mut ncols = None;
    let (mut t, mut temp) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if is_comment_or_blank(line) {
            continue;
        }
        // Up to 5 fields without allocating a Vec per line (this loop is most of the time
        // `fit` spends on a 50k-line file).
        let mut fields = [""; 6];
        let mut count = 0usize;
        for f in line.split_ascii_whitespace() {
            if let Some(slot) = fields.get_mut(count) {
                *slot = f;
            }
            count += 1;
        }
        let n = *ncols.get_or_insert(count);
        if count != n {
            return Err(Error::RaggedLine {
                line: line_no,
                expected: n,
                found: count,
            });
        }
        let names: &[&str] = match n {
            3 => &["x", "y", "z"],
            4 => &["t", "x", "y", "z"],
            5 => &["t", "x", "y", "z", "temp"],
            _ => {
                return Err(Error::HeaderlessColumns {
                    line: line_no,
                    found: n,
                })
            }
        };
        let mut vals = [0.0f64; 5];
        for (k, f) in fields.iter().take(n).enumerate() {
            vals[k] = parse_number(f, line_no, names[k])?;
        }
        let off = if n == 3 { 0 } else { 1 };
        if n >= 4 {
            t.push(vals[0]);
        }
        if n == 5 {
            temp.push(vals[4]);
        }
        rec.xyz.push([vals[off], vals[off + 1], vals[off + 2]]);
    }
    if rec.xyz.is_empty() {
        return Err(Error::NoDataRows);
    }
    if !t.is_empty() {
        rec.t = Some(t);
    }
    if !temp.is_empty() {
        rec.temp = Some(temp);
    }
    rec.axis_columns = ["x".into(), "y".into(), "z".into()];
    Ok(rec)
}

const TIME_NAMES: &[&str] = &["t", "time", "timestamp", "time_s", "t_s", "seconds"];
const TEMP_NAMES: &[&str] = &["temp", "temperature", "temp_c", "temperature_c"];
const LABEL_NAMES: &[&str] = &["pose", "label"];

fn parse_csv(text: &str, opts: &LoadOptions) -> Result<Recording> {
    let delim = if text.lines().any(|l| l.contains(';')) && !text.lines().any(|l| l.contains(',')) {
        b';'
    } else {
        b','
    };
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .delimiter(delim)
        .from_reader(text.as_bytes());

    let mut rec = Recording::default();
    let mut header: Option<Vec<String>> = None;
    let mut idx = (usize::MAX, [0usize; 3], usize::MAX, usize::MAX); // t, xyz, temp, label
    let (mut t, mut temp, mut labels) = (Vec::new(), Vec::new(), Vec::new());

    for result in reader.records() {
        let record = result.map_err(Error::MalformedCsv)?;
        let line_no = record.position().map(|p| p.line() as usize).unwrap_or(0);
        if record.iter().all(|f| f.is_empty()) {
            continue;
        }
        let Some(cols) = &header else {
            // Before the header: metadata `key,value` lines, or the header itself.
            let fields: Vec<String> = record.iter().map(|f| f.to_ascii_lowercase()).collect();
            let numeric = fields.iter().filter(|f| f.parse::<f64>().is_ok()).count();
            if numeric == fields.len() {
                return Err(Error::DataBeforeHeader { line: line_no });
            }
            if fields.len() == 2 && numeric == 1 && fields[1].parse::<f64>().is_ok() {
                if fields[0] == "fs" || fields[0] == "sample_rate" || fields[0] == "rate_hz" {
                    let fs: f64 = fields[1].parse().unwrap_or(f64::NAN);
                    if !(fs.is_finite() && fs > 0.0) {
                        return Err(Error::BadSampleRate {
                            line: line_no,
                            value: fs,
                        });
                    }
                    rec.sample_rate_hz = Some(fs);
                }
                continue;
            }
            idx = map_header(&fields, opts)?;
            rec.axis_columns = idx.1.map(|i| fields[i].clone());
            header = Some(fields);
            continue;
        };
        if record.len() != cols.len() {
            return Err(Error::RaggedRow {
                line: line_no,
                expected: cols.len(),
                found: record.len(),
            });
        }
        if idx.1.iter().all(|&i| record[i].is_empty()) {
            rec.skipped_empty_rows += 1;
            continue;
        }
        let get = |i: usize| parse_number(&record[i], line_no, &cols[i]);
        rec.xyz
            .push([get(idx.1[0])?, get(idx.1[1])?, get(idx.1[2])?]);
        if idx.0 != usize::MAX {
            t.push(get(idx.0)?);
        }
        if idx.2 != usize::MAX {
            temp.push(get(idx.2)?);
        }
        if idx.3 != usize::MAX {
            labels.push(record[idx.3].to_string());
        }
    }
    if header.is_none() {
        return Err(Error::NoHeader);
    }
    if rec.xyz.is_empty() {
        return Err(Error::HeaderOnly);
    }
    if idx.0 != usize::MAX {
        rec.t = Some(t);
    }
    if idx.2 != usize::MAX {
        rec.temp = Some(temp);
    }
    if idx.3 != usize::MAX {
        rec.labels = Some(labels);
    }
    Ok(rec)
}

fn map_header(fields: &[String], opts: &LoadOptions) -> Result<(usize, [usize; 3], usize, usize)> {
    let find = |names: &[&str]| fields.iter().position(|f| names.contains(&f.as_str()));
    let mut seen = std::collections::HashSet::new();
    for f in fields {
        if !seen.insert(f) {
            return Err(Error::DuplicateColumn { name: f.clone() });
        }
    }
    let xyz = if let Some(cols) = &opts.columns {
        let mut out = [0usize; 3];
        for (k, c) in cols.iter().enumerate() {
            let c = c.to_ascii_lowercase();
            out[k] = fields
                .iter()
                .position(|f| *f == c)
                .ok_or_else(|| Error::ColumnNotFound {
                    name: c.clone(),
                    header: fields.join(", "),
                })?;
        }
        out
    } else {
        crate::columns::find_triplet(fields, opts.sensor.unwrap_or(Sensor::Accelerometer))
            .map(|t| t.columns)
            .ok_or_else(|| Error::NoAxisColumns {
                header: fields.join(", "),
            })?
    };
    Ok((
        find(TIME_NAMES).unwrap_or(usize::MAX),
        xyz,
        find(TEMP_NAMES).unwrap_or(usize::MAX),
        find(LABEL_NAMES).unwrap_or(usize::MAX),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> Result<Recording> {
        parse(s, &LoadOptions::default())
    }

    #[test]
    fn whitespace_t_x_y_z() {
        let r = p("  2.98e-02   3.3108e+04 3.3329e+04 3.6429e+04\n0.0398 1 2 3\n").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r.xyz[0], [33108.0, 33329.0, 36429.0]);
        assert_eq!(r.t.as_ref().unwrap()[1], 0.0398);
    }

    #[test]
    fn csv_with_metadata_and_named_columns() {
        let r = p("Fs,50.00\nInitialization time,60\nmx,my,mz\n6242,980,3872\n6267,945,3860\n")
            .unwrap();
        assert_eq!(r.sample_rate_hz, Some(50.0));
        assert_eq!(r.xyz[1], [6267.0, 945.0, 3860.0]);
        assert!(r.t.is_none());
        let r = p("ax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n").unwrap();
        assert_eq!(r.xyz[0], [1.0, 2.0, 3.0]);
        let gyro = parse(
            "ax,ay,az,gx,gy,gz\n1,2,3,4,5,6\n",
            &LoadOptions {
                columns: Some(["gx".into(), "gy".into(), "gz".into()]),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(gyro.xyz[0], [4.0, 5.0, 6.0]);
    }

    #[test]
    fn csv_with_time_temp_and_labels() {
        let r = p("time,x,y,z,temp\n0,1,2,3,25\n0.01,1,2,3,25.5\n").unwrap();
        assert_eq!(r.temp.unwrap(), vec![25.0, 25.5]);
        let r = p("pose,x,y,z\nx+,1,2,3\n").unwrap();
        assert_eq!(r.labels.unwrap(), vec!["x+".to_string()]);
    }

    #[test]
    fn rows_with_empty_selected_axes_are_skipped() {
        let text = "t,x,y,z,ext_x,ext_y,ext_z\n0,1,2,3,4,5,6\n0.01,1,2,3,,,\n0.02,1,2,3,7,8,9\n";
        let opts = LoadOptions {
            columns: Some(["ext_x".into(), "ext_y".into(), "ext_z".into()]),
            ..Default::default()
        };
        let r = parse(text, &opts).unwrap();
        assert_eq!(r.xyz, vec![[4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]);
        assert_eq!(r.t.unwrap(), vec![0.0, 0.02]);
        assert_eq!(r.skipped_empty_rows, 1);
        // A partly empty row is an error, not a skip.
        let e = parse("t,x,y,z\n0,1,,3\n", &LoadOptions::default()).unwrap_err();
        assert!(e.full_message().contains("not a number"));
    }

    #[test]
    fn bad_inputs_give_readable_errors() {
        let e = |s: &str| p(s).unwrap_err().full_message();
        assert!(e("").contains("empty"));
        assert!(e("a,b,c\n1,2,3\n").contains("no x/y/z columns"));
        assert!(e("x,y,z\n1,NaN,3\n").contains("not finite"));
        assert!(e("x,y,z\n1,2\n").contains("expected 3 fields"));
        assert!(e("x,y,z\n").contains("no data rows"));
        assert!(e("1 2 3\n1 2\n").contains("expected 3 columns"));
        assert!(e("1 2\n").contains("without a header"));
        assert!(e("1 inf 3\n").contains("not finite"));
        assert!(e("x,x,y,z\n1,2,3,4\n").contains("twice"));
        assert!(e("x,y,z\n1,abc,3\n").contains("not a number"));
        assert!(e("1,2,3\n").contains("before any header"));
    }
}
