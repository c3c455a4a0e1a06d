//! Text recordings: CSV with a header naming the columns, or header-less
//! whitespace-separated numeric text (`t x y z`, as in IMU-TK's test data); files reach it
//! through [`crate::input::front_door`].
//!
//! Accepted shapes:
//! * CSV (comma or semicolon) with a header line. Column names map by meaning, case-insensitive:
//!   time `t|time|timestamp|time_s`, axes by pattern (`x`, `ax`, `acc_x_g`, `AccX`,
//!   `mag_x_gauss`, `gyro_x_dps`, … see [`crate::input::columns`]: the wanted sensor's triplet),
//!   temperature `temp|temperature|temp_c`, pose label `pose|label`. A different triplet can be
//!   chosen with [`LoadOptions::columns`]. Lines before the header of the form `key,value`
//!   (e.g. `Fs,100`) are metadata; `Fs` gives the sample rate.
//! * Whitespace-separated numbers without a header: 3 columns `x y z`, 4 columns `t x y z`,
//!   5 columns `t x y z temp`. Lines starting with `#` or `%` are comments.
//!
//! Every value must be finite; the first bad line is reported with its number.

use crate::error::input::InputError;
use crate::error::Result;
use crate::input::bounded::{check_reading_scale, parse_number, parse_reading};
use crate::input::recording::Recording;
use crate::input::text_csv::{
    blank_comments, check_axis_columns, csv_reader, is_comment_or_blank, plain_csv, CsvState,
    Delimiter,
};
use crate::input::text_file::{hold, Pieces};
use crate::input::timecheck::{time_notes, TimeCheck};

pub use crate::input::columns::LoadOptions;

/// Parses recording text (see the module docs). A leading byte-order mark is ignored.
pub fn parse(text: &str, opts: &LoadOptions) -> Result<Recording> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    crate::input::bounded::check_line_lengths(text)?;
    let first = text
        .lines()
        .find(|l| !is_comment_or_blank(l))
        .ok_or(InputError::Empty)?;
    if crate::input::grt::is_grt(first) {
        return crate::input::grt::parse(text);
    }
    let rec = match Delimiter::of_first_line(first) {
        Some(delim) => {
            let text = blank_comments(text);
            // Plain text (most files) is the one piece of the loop a file read in pieces goes
            // through: the same head, rows and checks. Text with quotes (or another byte-order
            // mark) is read by the `csv` reader.
            if plain_csv(&text) && !text.starts_with('\u{feff}') {
                let mut pieces = Pieces::held(&text);
                if let Some(rec) = hold(&mut pieces, opts, |_| true, None)? {
                    return Ok(rec);
                }
            }
            parse_csv(&text, opts, delim)?
        }
        None => {
            if opts.columns.is_some() {
                return Err(InputError::ColumnsNeedHeader.into());
            }
            parse_whitespace(text)?
        }
    };
    check_axis_columns(&rec)?;
    check_reading_scale(&rec.xyz)?;
    Ok(rec)
}

fn parse_whitespace(text: &str) -> Result<Recording> {
    let mut rec = Recording::default();
    let mut ncols = None;
    let (mut t, mut temp) = (Vec::new(), Vec::new());
    let mut clock = TimeCheck::new("t");
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
            return Err(InputError::RaggedLine {
                line: line_no,
                expected: n,
                found: count,
            }
            .into());
        }
        let names: &[&str] = match n {
            3 => &["x", "y", "z"],
            4 => &["t", "x", "y", "z"],
            5 => &["t", "x", "y", "z", "temp"],
            _ => {
                return Err(InputError::HeaderlessColumns {
                    line: line_no,
                    found: n,
                }
                .into())
            }
        };
        let mut vals = [0.0f64; 5];
        for (k, f) in fields.iter().take(n).enumerate() {
            vals[k] = if names[k] == "t" {
                parse_number(f, line_no, names[k], false)?
            } else {
                parse_reading(f, line_no, names[k], false)?
            };
        }
        let off = if n == 3 { 0 } else { 1 };
        if n >= 4 {
            clock.push(vals[0], line_no)?;
            t.push(vals[0]);
        }
        if n == 5 {
            temp.push(vals[4]);
        }
        rec.xyz.push([vals[off], vals[off + 1], vals[off + 2]]);
    }
    if rec.xyz.is_empty() {
        return Err(InputError::NoDataRows.into());
    }
    if !t.is_empty() {
        rec.notes = time_notes("t", &t);
        rec.t = Some(t);
    }
    if !temp.is_empty() {
        rec.temp = Some(temp);
    }
    rec.axis_columns = ["x".into(), "y".into(), "z".into()];
    Ok(rec)
}

/// Text the fast splitter does not read (quotes, lone carriage returns) by the `csv` reader:
/// metadata and the header record by record, then the data rows by [`RowLayout`].
fn parse_csv(text: &str, opts: &LoadOptions, delim: Delimiter) -> Result<Recording> {
    let mut st = CsvState::new(opts, delim);
    let mut reader = csv_reader(text, delim);
    st.read_records_head(&mut reader)?;
    // A record ends at a line end or a lone CR: the records left are at most these plus one.
    let max_rows = memchr::memchr2_iter(b'\n', b'\r', text.as_bytes()).count() + 1;
    let cols = match &st.layout {
        Some(layout) => Some(layout.read_records(&mut reader, max_rows)?),
        None => None,
    };
    st.finish(cols)
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
    fn tab_separated_with_header() {
        let r = p("t\tx\ty\tz\n0\t1\t2\t3\n0.01\t4\t5\t6\n").unwrap();
        assert_eq!(r.xyz, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(r.t.unwrap(), vec![0.0, 0.01]);
        // Tab-separated numbers without a header stay whitespace text.
        let r = p("0\t1\t2\t3\n").unwrap();
        assert_eq!(r.xyz, vec![[1.0, 2.0, 3.0]]);
    }

    #[test]
    fn percent_and_hash_comments_in_csv_keep_line_numbers() {
        let text = "% logger v2, 100 Hz\nt,x,y,z\n# a, b\n0,1,2,3\n%, x\n0.01,1,zz,3\n";
        let e = p(text).unwrap_err().to_string();
        assert_eq!(e, "line 6: column 'y': 'zz' is not a number");
        let r = p("% header, comment\nx,y,z\n1,2,3\n").unwrap();
        assert_eq!(r.xyz, vec![[1.0, 2.0, 3.0]]);
    }

    /// The fast splitter reads every plain file exactly as the `csv` reader does: values,
    /// skipped rows, and the errors (line numbers too, except after empty lines, which the
    /// reader does not count).
    #[test]
    fn fast_splitter_matches_the_csv_reader() {
        let texts = [
            "t,x,y,z\n0,1,2,3\n0.01,4,5,6",
            "t,x,y,z\r\n0,1,2,3\r\n\r\n0.01,4,5,6\r\n",
            "Fs,50\n\nx,y,z\n \n1,2,3\n\n\n4,5,6\n",
            "t,x,y,z,ext_x,ext_y,ext_z\n0,1,2,3,,,\n0.01, 4 ,5,6,7,8,9\n",
            "x,y,z\n1,2,3\n1,2\n",
            "t,x,y,z\n0,1,2,3\n0,1,2,3\n",
            "x,y,z\n1,2,3\n1,abc,3\n",
            "pose,x,y,z\nx+,1,2,3\nx-,-1,2,3\n",
            "x;y;z\n1,5;2;3\n",
            "x,y,z\n1,2,3,\n",
            ",,\nx,y,z\n1,2,3\n",
        ];
        let opts = LoadOptions::default();
        let fast = |text| hold(&mut Pieces::held(text), &opts, |_| true, None).map(Option::unwrap);
        for text in texts {
            let delim = Delimiter::of_first_line(text.lines().next().unwrap()).unwrap();
            let slow = parse_csv(text, &opts, delim);
            let fast = fast(text);
            match (fast, slow) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a.xyz, b.xyz, "{text:?}");
                    assert_eq!(a.t, b.t, "{text:?}");
                    assert_eq!(a.labels, b.labels, "{text:?}");
                    assert_eq!(a.skipped_empty_rows, b.skipped_empty_rows, "{text:?}");
                    assert_eq!(a.sample_rate_hz, b.sample_rate_hz, "{text:?}");
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{text:?}"),
                (a, b) => panic!("{text:?}: {a:?} vs {b:?}"),
            }
        }
        // After an empty line the fast splitter names the true line (4); the csv reader does
        // not count empty lines and said line 3.
        let e = fast("t,x,y,z\n0,1,2,3\n\n-1,1,2,3\n").unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::TimeNotIncreasing { line: 4, .. })
            ),
            "{e}"
        );
        assert!(plain_csv("x,y\r\n1,2\n"));
        assert!(!plain_csv("x,y\r1,2\n"));
        assert!(!plain_csv("\"x\",y\n"));
    }

    #[test]
    fn byte_order_mark_is_ignored() {
        let r = p("\u{feff}0.0 1 2 3\n0.01 4 5 6\n").unwrap();
        assert_eq!(r.xyz[0], [1.0, 2.0, 3.0]);
        let r = p("\u{feff}x,y,z\n1,2,3\n").unwrap();
        assert_eq!(r.axis_columns[0], "x");
    }

    #[test]
    fn semicolon_csv_with_decimal_commas() {
        let r = p("Fs;50,5\nt;x;y;z\n0;1,5;-2,25;3\n0,02;4;5;6,125\n").unwrap();
        assert_eq!(r.sample_rate_hz, Some(50.5));
        assert_eq!(r.xyz, vec![[1.5, -2.25, 3.0], [4.0, 5.0, 6.125]]);
        assert_eq!(r.t.unwrap(), vec![0.0, 0.02]);
        // A semicolon file with decimal points still reads; a field with two commas does not.
        assert_eq!(p("x;y;z\n1.5;2;3\n").unwrap().xyz[0], [1.5, 2.0, 3.0]);
        let e = p("x;y;z\n1,5,5;2;3\n").unwrap_err().to_string();
        assert!(e.contains("'1,5,5' is not a number"), "{e}");
    }

    #[test]
    fn a_huge_bad_field_is_quoted_short() {
        // A long bad field inside a line of legal length is quoted short …
        let text = format!("x,y,z\n1,{},3\n", "7a".repeat(15_000));
        let e = p(&text).unwrap_err().to_string();
        assert!(e.len() < 200, "{} bytes", e.len());
        assert!(e.contains("(30000 characters)"), "{e}");
        // … and a line too long to be a recording's is refused by its length.
        let text = format!("x,y,z\n1,{},3\n", "7a".repeat(5_000_000));
        let e = p(&text).unwrap_err().to_string();
        assert!(e.contains("line 2 is 10000004 bytes long"), "{e}");
    }

    #[test]
    fn time_and_temperature_are_not_axes() {
        let cols = |c: [&str; 3]| LoadOptions {
            columns: Some(c.map(String::from)),
            sensor: None,
            ..Default::default()
        };
        let text = "t,x,y,z,temp\n0,1,2,3,20\n0.01,1,2,3,20\n";
        let e = parse(text, &cols(["t", "x", "y"])).unwrap_err();
        assert!(
            matches!(e, crate::Error::Input(InputError::AxisIsNotAnAxis { ref name }) if name == "t"),
            "{e}"
        );
        let e = parse(text, &cols(["x", "y", "temp"])).unwrap_err();
        assert!(
            matches!(e, crate::Error::Input(InputError::AxisIsNotAnAxis { .. })),
            "{e}"
        );
        let e = parse(text, &cols(["x", "x", "y"])).unwrap_err();
        assert!(
            matches!(e, crate::Error::Input(InputError::AxisTwice { .. })),
            "{e}"
        );
    }

    #[test]
    fn time_must_increase() {
        let e = p("t,x,y,z\n0,1,2,3\n0.02,1,2,3\n0.01,1,2,3\n").unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::TimeNotIncreasing { line: 4, .. })
            ),
            "{e}"
        );
        // A repeated time is read (coarse timestamps), a time that goes back is not.
        assert!(p("t,x,y,z\n0,1,2,3\n0,1,2,3\n0.01,1,2,3\n").is_ok());
        let e = p("t,x,y,z\n0,1,2,3\n0,1,2,3\n-0.01,1,2,3\n").unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::TimeNotIncreasing { line: 4, .. })
            ),
            "{e}"
        );
        let e = p("0 1 2 3\n0.01 1 2 3\n# c\n0.005 1 2 3\n").unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::TimeNotIncreasing { line: 4, .. })
            ),
            "{e}"
        );
        // A gap is a note, not an error.
        let mut text = String::from("t,x,y,z\n");
        for i in 0..20 {
            let t = if i < 10 {
                i as f64 * 0.01
            } else {
                5.0 + i as f64 * 0.01
            };
            text += &format!("{t},1,2,3\n");
        }
        let r = p(&text).unwrap();
        assert_eq!(r.notes.len(), 1, "{:?}", r.notes);
        assert!(r.notes[0].contains("time jumps 1 time(s)"), "{:?}", r.notes);
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
        assert!(e("x,y,z\n1,-1e309,3\n").contains("'-1e309' is beyond the range of a double"));
        assert!(e("x,x,y,z\n1,2,3,4\n").contains("twice"));
        assert!(e("x,y,z\n1,abc,3\n").contains("not a number"));
        assert!(e("1,2,3\n").contains("before any header"));
    }

    /// Every text, read in pieces of every size, gives what the whole-text parse gives: the
    /// values bit for bit or the same sentence — or is handed back to be read whole.
    #[test]
    fn pieces_read_as_the_whole_text() {
        let mut rows = String::from("Fs,100\nt,x,y,z,temp\n");
        for i in 0..400 {
            let t = i as f64 * 0.01;
            rows += &format!(
                "{t},{},{}.{},-{}e-{},2{}.5\n",
                i % 97,
                i % 13,
                i * 31 % 1000,
                i % 7,
                i % 3,
                i % 9
            );
        }
        let bad_time = rows.replace("\n2.5,", "\n1.5,");
        let bad_cell = rows.replace("\n3.01,", "\n3.01,x");
        let ragged = rows.clone() + "1,2\n";
        let semicolon = "t;x;y;z\n0;1,5;2;3\n0,01;4;5;6\n".to_string();
        let no_header = "1,2,3\n4,5,6\n".to_string();
        let texts = [
            rows.clone(),
            rows.trim_end().to_string(),
            rows.replace('\n', "\r\n"),
            bad_time,
            bad_cell,
            ragged,
            semicolon,
            no_header,
            "x,y,z\n".to_string(),
            format!("\u{feff}{rows}"),
            rows.clone() + "# a comment\n",
            rows.replace("2.5,", "\"2.5\","),
            rows.replace("t,x,y,z,temp", "\"t\",\"x\",\"y\",\"z\",\"temp\""),
            format!("# logger\n% 100 Hz, 16 bit\n{rows}").replace("\n2.5,", "\n% pause\n2.5,"),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let opts = LoadOptions::default();
        for text in &texts {
            std::fs::write(&path, text).unwrap();
            let whole = parse(text.trim_start_matches('\u{feff}'), &opts);
            let whole = whole.map(|r| format!("{:?} {:?} {:?} {:?}", r.xyz, r.t, r.temp, r.notes));
            let whole = whole.map_err(|e| e.to_string());
            for size in [1, 7, 64, 300, 4096, 1 << 20] {
                let got = match crate::input::text_file::read_pieces(
                    &path,
                    &opts,
                    size,
                    |_| true,
                    None,
                ) {
                    Ok(None) => continue, // read whole by the caller
                    Ok(Some(r)) => Ok(format!("{:?} {:?} {:?} {:?}", r.xyz, r.t, r.temp, r.notes)),
                    Err(e) => Err(e.to_string()),
                };
                assert_eq!(got, whole, "{text:?} in pieces of {size}");
            }
        }
        // The plain file is read in pieces, not handed back.
        std::fs::write(&path, &texts[0]).unwrap();
        assert!(matches!(
            crate::input::text_file::read_pieces(&path, &opts, 64, |_| true, None),
            Ok(Some(_))
        ));
        assert!(matches!(
            crate::input::text_file::read_pieces(&path, &opts, 64, |_| false, None),
            Ok(None)
        ));
        // Comment lines, a quoted header: read in pieces; a quote in a row: read whole.
        for (k, in_pieces) in [(10, true), (12, true), (13, true), (11, false)] {
            std::fs::write(&path, &texts[k]).unwrap();
            let got = crate::input::text_file::read_pieces(&path, &opts, 64, |_| true, None);
            assert_eq!(matches!(got, Ok(Some(_))), in_pieces, "{k}: {got:?}");
        }
    }
}
