//! The CSV side of reading text shared by the held read ([`crate::input::text`]) and the
//! piece loop ([`crate::input::text_file`]): comment lines, the delimiter, metadata lines
//! and the header record by record (`CsvState`), the `csv` reader for quoted text, and the
//! check that a recording's axis columns are a sensor's. Its own module so that the two
//! readers import it one way, not each other.

use crate::error::input::InputError;
use crate::error::Result;
use crate::input::bounded::{parse_number, quote, quote_header, MAX_RATE_HZ, MIN_RATE_HZ};
use crate::input::columns::{LoadOptions, Sensor};
use crate::input::recording::Recording;
use crate::input::text_rows::{Columns, Fields, RowLayout};
use crate::input::timecheck::time_notes;

pub(crate) fn is_comment_or_blank(line: &str) -> bool {
    let l = line.trim();
    l.is_empty() || l.starts_with('#') || l.starts_with('%')
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
