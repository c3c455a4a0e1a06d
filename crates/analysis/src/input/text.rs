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
use crate::input::bounded::{
    check_reading_scale, parse_number, parse_reading, quote, quote_header, MAX_RATE_HZ, MIN_RATE_HZ,
};
use crate::input::columns::Sensor;
use crate::input::recording::Recording;
use crate::input::text_file::{hold, Pieces};
use crate::input::text_rows::{Columns, Fields, RowLayout};
use crate::input::timecheck::{time_notes, TimeCheck};

pub use crate::input::columns::LoadOptions;

pub(crate) fn is_comment_or_blank(line: &str) -> bool {
    let l = line.trim();
    l.is_empty() || l.starts_with('#') || l.starts_with('%')
}

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

/// How a file with a header separates its fields, decided by the first non-comment line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Delimiter {
    /// `,` (decimal point `.`).
    Comma,
    /// `;`, as spreadsheets write in locales with a decimal comma: `1,5` is 1.5.
    Semicolon,
    /// A tab, with a header (tab-separated numbers without a header are whitespace text).
    Tab,
}

impl Delimiter {
    pub(crate) fn of_first_line(line: &str) -> Option<Self> {
        if line.contains(';') {
            Some(Self::Semicolon)
        } else if line.contains(',') {
            Some(Self::Comma)
        } else if line.contains('\t') && line.split('\t').any(|f| f.trim().parse::<f64>().is_err())
        {
            Some(Self::Tab)
        } else {
            None
        }
    }

    pub(crate) fn byte(self) -> u8 {
        match self {
            Self::Comma => b',',
            Self::Semicolon => b';',
            Self::Tab => b'\t',
        }
    }
}

/// The text with `#` and `%` comment lines blanked (line numbers kept), since the CSV reader
/// knows only one comment character and would split `% recorded 2024, 100 Hz` into fields.
pub(crate) fn blank_comments(text: &str) -> std::borrow::Cow<'_, str> {
    let is_comment = |l: &str| {
        let l = l.trim_start();
        l.starts_with('#') || l.starts_with('%')
    };
    // One memchr pass per marker instead of a walk over every line (most files have none).
    let bytes = text.as_bytes();
    if !bytes.contains(&b'#') && !bytes.contains(&b'%') || !text.lines().any(is_comment) {
        return text.into();
    }
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        if is_comment(line) {
            // A blank record (skipped by the reader's caller), not an empty line: the CSV
            // reader does not count every empty line in its line numbers.
            out.push_str(" \n");
        } else {
            out.push_str(line);
        }
    }
    out.into()
}

/// The axes must be three different columns, none of them the time, temperature or label
/// column (`--columns t,x,y` would calibrate time as an axis).
pub(crate) fn check_axis_columns(rec: &Recording) -> Result<()> {
    for name in &rec.axis_columns {
        let lower = name.to_ascii_lowercase();
        if TIME_NAMES.contains(&lower.as_str())
            || TEMP_NAMES.contains(&lower.as_str())
            || LABEL_NAMES.contains(&lower.as_str())
        {
            return Err(InputError::AxisIsNotAnAxis { name: name.clone() }.into());
        }
    }
    let [a, b, c] = &rec.axis_columns;
    if a == b || a == c || b == c {
        return Err(InputError::AxisTwice {
            columns: rec.axis_columns.join(","),
        }
        .into());
    }
    Ok(())
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

const TIME_NAMES: &[&str] = &["t", "time", "timestamp", "time_s", "t_s", "seconds"];
const TEMP_NAMES: &[&str] = &["temp", "temperature", "temp_c", "temperature_c"];
const LABEL_NAMES: &[&str] = &["pose", "label"];

/// True when plain splitting at line ends and delimiters reads `text` exactly as the `csv`
/// reader does: no quote character anywhere (quoting is the only thing the reader adds) and no
/// carriage return other than in a CR LF pair (the reader ends a line at a lone CR too).
pub(crate) fn plain_csv(text: &str) -> bool {
    let b = text.as_bytes();
    if memchr::memchr(b'"', b).is_some() {
        return false;
    }
    memchr::memchr_iter(b'\r', b).all(|i| b.get(i + 1) == Some(&b'\n'))
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

/// The `csv` reader of `text` (no header of its own: the loader reads it; records may differ
/// in length: a ragged row is named by the loader).
pub(crate) fn csv_reader(text: &str, delim: Delimiter) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        // Fields are trimmed where read: the reader's own trimming copies each record.
        .delimiter(delim.byte())
        .from_reader(text.as_bytes())
}

/// What [`parse_csv`] has read before the data rows: metadata, then the header.
pub(crate) struct CsvState<'o> {
    opts: &'o LoadOptions,
    decimal_comma: bool,
    rec: Recording,
    /// The header's layout, once the header is read.
    pub(crate) layout: Option<RowLayout>,
}

impl<'o> CsvState<'o> {
    pub(crate) fn new(opts: &'o LoadOptions, delim: Delimiter) -> Self {
        Self {
            opts,
            decimal_comma: delim == Delimiter::Semicolon,
            rec: Recording::default(),
            layout: None,
        }
    }

    /// Plain text's lines up to and including the header (metadata before it): the byte
    /// offset and line number (1-based) where the header ended, or the text's end and its
    /// line count when it holds no header. The delimiter and line ends are ASCII, so every
    /// cut is a character boundary.
    pub(crate) fn read_head(&mut self, text: &str, delim: Delimiter) -> Result<(usize, usize)> {
        let (mut offset, mut line_no) = (0usize, 0usize);
        let mut fields: Vec<&str> = Vec::new();
        while self.layout.is_none() && offset < text.len() {
            let end = memchr::memchr(b'\n', &text.as_bytes()[offset..])
                .map_or(text.len(), |p| offset + p);
            let line = &text[offset..end];
            line_no += 1;
            offset = (end + 1).min(text.len());
            let line = line.strip_suffix('\r').unwrap_or(line);
            if line.is_empty() {
                continue; // the csv reader skips empty lines too
            }
            fields.clear();
            fields.extend(line.split(char::from(delim.byte())));
            self.before_header(&fields[..], line_no)?;
        }
        Ok((offset, line_no))
    }

    /// The `csv` reader's records up to and including the header (metadata before it), one
    /// record reused for every line.
    pub(crate) fn read_records_head(&mut self, reader: &mut csv::Reader<&[u8]>) -> Result<()> {
        let mut record = csv::StringRecord::new();
        while self.layout.is_none()
            && reader
                .read_record(&mut record)
                .map_err(InputError::MalformedCsv)?
        {
            let line_no = record.position().map_or(0, |p| p.line() as usize);
            self.before_header(&record, line_no)?;
        }
        Ok(())
    }

    /// Before the header: metadata `key,value` lines, or the header itself (a blank record
    /// is skipped).
    pub(crate) fn before_header<F: Fields + ?Sized>(
        &mut self,
        record: &F,
        line_no: usize,
    ) -> Result<()> {
        if (0..record.count()).all(|i| record.get(i).trim_ascii().is_empty()) {
            return Ok(());
        }
        let decimal_comma = self.decimal_comma;
        let fields: Vec<String> = (0..record.count())
            .map(|i| record.get(i).trim_ascii().to_ascii_lowercase())
            .collect();
        let is_number = |f: &String| {
            f.parse::<f64>().is_ok()
                || (decimal_comma && f.replacen(',', ".", 1).parse::<f64>().is_ok())
        };
        let numeric = fields.iter().filter(|f| is_number(f)).count();
        if numeric == fields.len() {
            return Err(InputError::DataBeforeHeader { line: line_no }.into());
        }
        let rate_key = ["fs", "sample_rate", "rate_hz"].contains(&fields[0].as_str());
        if fields.len() == 2 && (rate_key || (numeric == 1 && is_number(&fields[1]))) {
            if rate_key {
                let fs = parse_number(&fields[1], line_no, &fields[0], decimal_comma)
                    .unwrap_or(f64::NAN);
                if !(fs.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&fs)) {
                    return Err(InputError::BadSampleRate {
                        line: line_no,
                        text: record.get(1).trim_ascii().chars().take(40).collect(),
                    }
                    .into());
                }
                self.rec.sample_rate_hz = Some(fs);
            }
            return Ok(());
        }
        let mut choice = None;
        let idx = map_header(&fields, self.opts, &mut choice)?;
        self.rec.info.extend(choice);
        self.rec.axis_columns = idx.1.map(|i| fields[i].clone());
        let some = |i: usize| (i != usize::MAX).then_some(i);
        self.layout = Some(RowLayout {
            names: fields,
            time: some(idx.0),
            xyz: idx.1,
            temp: some(idx.2),
            label: some(idx.3),
            decimal_comma,
        });
        Ok(())
    }

    /// The recording's metadata without its rows (rate, axis columns, the loader's choices),
    /// for a file whose rows are streamed ([`crate::input::text_source`]).
    pub(crate) fn into_meta(self) -> Recording {
        self.rec
    }

    /// The recording from the metadata, the header and the rows read after it.
    pub(crate) fn finish(self, cols: Option<Columns>) -> Result<Recording> {
        let mut rec = self.rec;
        let (Some(layout), Some(cols)) = (self.layout, cols) else {
            return Err(InputError::NoHeader.into());
        };
        if cols.xyz.is_empty() {
            return Err(InputError::HeaderOnly.into());
        }
        rec.xyz = cols.xyz;
        rec.skipped_empty_rows = cols.skipped;
        if let Some(i) = layout.time {
            rec.notes = time_notes(&layout.names[i], &cols.t);
            rec.t = Some(cols.t);
        }
        if layout.temp.is_some() {
            rec.temp = Some(cols.temp);
        }
        if layout.label.is_some() {
            rec.labels = Some(cols.labels);
        }
        Ok(rec)
    }
}

/// Column indices of time, x/y/z, temperature and label (`usize::MAX`: absent); `choice`
/// receives the sentence saying which triplet was taken when there was a choice.
fn map_header(
    fields: &[String],
    opts: &LoadOptions,
    choice: &mut Option<String>,
) -> Result<(usize, [usize; 3], usize, usize)> {
    let find = |names: &[&str]| fields.iter().position(|f| names.contains(&f.as_str()));
    let mut seen = std::collections::HashSet::new();
    for f in fields {
        if !seen.insert(f) {
            return Err(InputError::DuplicateColumn { name: quote(f) }.into());
        }
    }
    let xyz =
        if let Some(cols) = &opts.columns {
            let mut out = [0usize; 3];
            for (k, c) in cols.iter().enumerate() {
                let c = c.to_ascii_lowercase();
                out[k] = fields.iter().position(|f| *f == c).ok_or_else(|| {
                    InputError::ColumnNotFound {
                        name: quote(&c),
                        header: quote_header(&fields.join(", ")),
                    }
                })?;
            }
            out
        } else {
            let want = opts.sensor.unwrap_or(Sensor::Accelerometer);
            let t = crate::input::columns::find_triplet(fields, want).ok_or_else(|| {
                InputError::NoAxisColumns {
                    header: quote_header(&fields.join(", ")),
                }
            })?;
            *choice = crate::input::columns::choice_note(fields, &t, want);
            t.columns
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
}
