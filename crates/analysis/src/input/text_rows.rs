//! The data rows of a delimited text recording (after its header), parsed in chunks on all
//! cores: the text is cut at line ends into chunks of [`CHUNK_BYTES`], each chunk is scanned for
//! delimiters and line ends by `memchr` (SIMD) and its numbers parsed by `fast-float2`
//! (correctly rounded, so bit-identical to `str::parse`), into its own share of columns
//! allocated once for the most rows the text can hold. The time check runs inside each chunk
//! and is joined across chunk boundaries (the first time of a chunk against the last of the
//! chunk before), and of several errors the first in file order is reported, so a file reads
//! with the same values, skips and error sentences (line and column) as row by row.

use crate::error::input::InputError;
use crate::error::{Error, Result};
use crate::input::bounded::{parse_number, parse_reading};
use crate::input::timecheck::TimeCheck;
use rayon::prelude::*;

/// Bytes of text per chunk: large enough that a chunk's bookkeeping is nothing next to its
/// parse, small enough that the chunks of a few megabytes keep both cores busy.
pub(crate) const CHUNK_BYTES: usize = 1 << 20;

/// One CSV record's fields, from the `csv` reader or from the fast line splitter.
pub(crate) trait Fields {
    /// Number of fields.
    fn count(&self) -> usize;
    /// Field `i` (untrimmed).
    fn get(&self, i: usize) -> &str;
}

impl Fields for csv::StringRecord {
    fn count(&self) -> usize {
        self.len()
    }
    fn get(&self, i: usize) -> &str {
        &self[i]
    }
}

impl Fields for [&str] {
    fn count(&self) -> usize {
        self.len()
    }
    fn get(&self, i: usize) -> &str {
        self[i]
    }
}

/// What the header says about every data row: which fields hold what, how numbers are written.
#[derive(Debug, Clone)]
pub(crate) struct RowLayout {
    /// The header's names, lower-cased (for messages).
    pub names: Vec<String>,
    /// Index of the time column.
    pub time: Option<usize>,
    /// Indices of the x, y, z columns.
    pub xyz: [usize; 3],
    /// Index of the temperature column.
    pub temp: Option<usize>,
    /// Index of the pose-label column.
    pub label: Option<usize>,
    /// `;`-separated text: one `,` in a number is its decimal separator.
    pub decimal_comma: bool,
}

/// The data columns read from the rows, as the [`crate::input::recording::Recording`] holds them.
#[derive(Debug, Default)]
pub(crate) struct Columns {
    /// x, y, z of every row.
    pub xyz: Vec<[f64; 3]>,
    /// Times (empty without a time column).
    pub t: Vec<f64>,
    /// Temperatures (empty without a temperature column).
    pub temp: Vec<f64>,
    /// Pose labels (empty without a label column).
    pub labels: Vec<String>,
    /// Rows skipped because all three axis fields were empty.
    pub skipped: usize,
}

/// One chunk's share of the columns, filled from its front.
pub(crate) struct Slot<'a> {
    xyz: &'a mut [[f64; 3]],
    t: &'a mut [f64],
    temp: &'a mut [f64],
    labels: Vec<String>,
    rows: usize,
    skipped: usize,
    clock: Option<TimeCheck>,
    /// The first time read in this chunk and its line (joined to the chunk before).
    first_time: Option<(f64, usize)>,
}

/// What a chunk read, once its borrow of the columns has ended.
struct ChunkOut {
    rows: usize,
    skipped: usize,
    labels: Vec<String>,
    first_time: Option<(f64, usize)>,
    last_time: Option<f64>,
    err: Option<Error>,
}

impl RowLayout {
    /// One data record (line `line_no`) into `slot`: blank records are skipped, records whose
    /// three axis fields are empty counted and skipped, anything else read in full or refused
    /// in one sentence naming the line and column (fields in the order the row-by-row reader
    /// read them, so a row with two bad fields names the same one).
    pub(crate) fn row<F: Fields + ?Sized>(
        &self,
        record: &F,
        line_no: usize,
        slot: &mut Slot<'_>,
    ) -> Result<()> {
        let n = record.count();
        if (0..n).all(|i| record.get(i).trim_ascii().is_empty()) {
            return Ok(());
        }
        if n != self.names.len() {
            return Err(InputError::RaggedRow {
                line: line_no,
                expected: self.names.len(),
                found: n,
            }
            .into());
        }
        let field = |i: usize| record.get(i).trim_ascii();
        if self.xyz.iter().all(|&i| field(i).is_empty()) {
            slot.skipped += 1;
            return Ok(());
        }
        let dc = self.decimal_comma;
        let get = |i: usize| parse_reading(field(i), line_no, &self.names[i], dc);
        let k = slot.rows;
        slot.xyz[k] = [get(self.xyz[0])?, get(self.xyz[1])?, get(self.xyz[2])?];
        if let (Some(i), Some(clock)) = (self.time, slot.clock.as_mut()) {
            let time = parse_number(field(i), line_no, &self.names[i], dc)?;
            clock.push(time, line_no)?;
            slot.first_time.get_or_insert((time, line_no));
            slot.t[k] = time;
        }
        if let Some(i) = self.temp {
            slot.temp[k] = get(i)?;
        }
        if let Some(i) = self.label {
            slot.labels.push(field(i).to_string());
        }
        slot.rows += 1;
        Ok(())
    }

    /// A fresh slot over the given shares of the columns.
    fn slot<'a>(&self, xyz: &'a mut [[f64; 3]], t: &'a mut [f64], temp: &'a mut [f64]) -> Slot<'a> {
        Slot {
            xyz,
            t,
            temp,
            labels: Vec::new(),
            rows: 0,
            skipped: 0,
            clock: self.time.map(|i| TimeCheck::new(&self.names[i])),
            first_time: None,
        }
    }

    /// Columns for at most `rows` rows (zero pages from the allocator: what no row fills is
    /// never touched).
    fn columns(&self, rows: usize) -> Columns {
        let col = |present: bool| if present { vec![0.0; rows] } else { Vec::new() };
        Columns {
            xyz: vec![[0.0; 3]; rows],
            t: col(self.time.is_some()),
            temp: col(self.temp.is_some()),
            labels: Vec::new(),
            skipped: 0,
        }
    }

    /// Every record the `csv` reader gives after the header, in one thread (quoted fields and
    /// lone carriage returns, which the plain splitter does not read); `max_rows` bounds the
    /// records (line ends in the text, plus one).
    pub(crate) fn read_records(
        &self,
        reader: &mut csv::Reader<&[u8]>,
        max_rows: usize,
    ) -> Result<Columns> {
        let mut cols = self.columns(max_rows);
        let mut slot = self.slot(&mut cols.xyz, &mut cols.t, &mut cols.temp);
        let mut record = csv::StringRecord::new();
        while reader
            .read_record(&mut record)
            .map_err(InputError::MalformedCsv)?
        {
            let line_no = record.position().map(|p| p.line() as usize).unwrap_or(0);
            self.row(&record, line_no, &mut slot)?;
        }
        let (rows, skipped, labels) = (slot.rows, slot.skipped, std::mem::take(&mut slot.labels));
        cols.truncate(rows);
        cols.skipped = skipped;
        cols.labels = labels;
        Ok(cols)
    }

    /// The rows of `text` (plain delimited text: no quotes, no lone CR), whose first line is
    /// line `first_line` of the file, parsed in chunks on all cores (see the module docs).
    pub(crate) fn read_plain(&self, text: &str, first_line: usize, delim: u8) -> Result<Columns> {
        self.read_plain_in(text, first_line, delim, CHUNK_BYTES, None)
    }

    /// [`RowLayout::read_plain`] on a piece of a file that continues rows read before, whose
    /// last time was `prev_time`: the time check is joined to it as between two chunks.
    pub(crate) fn read_plain_after(
        &self,
        text: &str,
        first_line: usize,
        delim: u8,
        prev_time: Option<f64>,
    ) -> Result<Columns> {
        self.read_plain_in(text, first_line, delim, CHUNK_BYTES, prev_time)
    }

    /// [`RowLayout::read_plain_after`] in chunks of about `chunk_bytes`.
    fn read_plain_in(
        &self,
        text: &str,
        first_line: usize,
        delim: u8,
        chunk_bytes: usize,
        prev_time: Option<f64>,
    ) -> Result<Columns> {
        let bounds = chunk_bounds(text.as_bytes(), chunk_bytes);
        let newlines: Vec<usize> = bounds
            .par_iter()
            .map(|&(a, b)| memchr::memchr_iter(b'\n', &text.as_bytes()[a..b]).count())
            .collect();
        let caps: Vec<usize> = newlines.iter().map(|n| n + 1).collect();
        let mut cols = self.columns(caps.iter().sum());
        let mut jobs = Vec::with_capacity(bounds.len());
        {
            let (mut xyz, mut t, mut temp) =
                (&mut cols.xyz[..], &mut cols.t[..], &mut cols.temp[..]);
            let mut line = first_line;
            for (k, &(a, b)) in bounds.iter().enumerate() {
                let n = |s: &[f64]| if s.is_empty() { 0 } else { caps[k] };
                let (nt, ntemp) = (n(t), n(temp));
                let (x_head, x_tail) = std::mem::take(&mut xyz).split_at_mut(caps[k]);
                xyz = x_tail;
                let slot = self.slot(x_head, share(&mut t, nt), share(&mut temp, ntemp));
                jobs.push((slot, &text[a..b], line));
                line += newlines[k];
            }
        }
        let outs: Vec<ChunkOut> = jobs
            .into_par_iter()
            .map(|(mut slot, chunk, line)| {
                let err = self.read_chunk(chunk, line, delim, &mut slot).err();
                let last_time =
                    (slot.rows > 0 && !slot.t.is_empty()).then(|| slot.t[slot.rows - 1]);
                ChunkOut {
                    rows: slot.rows,
                    skipped: slot.skipped,
                    labels: slot.labels,
                    first_time: slot.first_time,
                    last_time,
                    err,
                }
            })
            .collect();
        self.join(cols, &caps, outs, prev_time)
    }

    /// The chunks' results in file order: the time joined at each boundary, the first error
    /// returned, the rows moved together (each chunk filled only the front of its share).
    fn join(
        &self,
        mut cols: Columns,
        caps: &[usize],
        outs: Vec<ChunkOut>,
        mut prev_time: Option<f64>,
    ) -> Result<Columns> {
        let (mut at, mut offset) = (0usize, 0usize);
        for (out, cap) in outs.into_iter().zip(caps) {
            if let (Some(prev), Some((t0, line)), Some(i)) = (prev_time, out.first_time, self.time)
            {
                TimeCheck::after(&self.names[i], prev).push(t0, line)?;
            }
            if let Some(e) = out.err {
                return Err(e);
            }
            if at != offset {
                cols.xyz.copy_within(offset..offset + out.rows, at);
                if !cols.t.is_empty() {
                    cols.t.copy_within(offset..offset + out.rows, at);
                }
                if !cols.temp.is_empty() {
                    cols.temp.copy_within(offset..offset + out.rows, at);
                }
            }
            at += out.rows;
            offset += cap;
            prev_time = out.last_time.or(prev_time);
            cols.skipped += out.skipped;
            cols.labels.extend(out.labels);
        }
        cols.truncate(at);
        Ok(cols)
    }

    /// One chunk's lines: fields cut at every delimiter and line end that `memchr2` finds, a
    /// carriage return before a line end dropped, empty lines skipped.
    fn read_chunk(
        &self,
        chunk: &str,
        first_line: usize,
        delim: u8,
        slot: &mut Slot<'_>,
    ) -> Result<()> {
        let bytes = chunk.as_bytes();
        let mut fields: Vec<&str> = Vec::with_capacity(self.names.len() + 1);
        let (mut line_start, mut field_start, mut line_no) = (0usize, 0usize, first_line);
        for pos in memchr::memchr2_iter(delim, b'\n', bytes) {
            if bytes[pos] == delim {
                fields.push(&chunk[field_start..pos]);
            } else {
                let line = &chunk[line_start..pos];
                self.end_line(line, field_start - line_start, line_no, &mut fields, slot)?;
                line_start = pos + 1;
                line_no += 1;
            }
            field_start = pos + 1;
        }
        if line_start < bytes.len() {
            let line = &chunk[line_start..];
            self.end_line(line, field_start - line_start, line_no, &mut fields, slot)?;
        }
        Ok(())
    }

    /// The end of `line` (its last field starting at byte `last`; the fields before it in
    /// `fields`): a CR before the line end dropped, an empty line skipped, else the row read.
    fn end_line<'c>(
        &self,
        line: &'c str,
        last: usize,
        line_no: usize,
        fields: &mut Vec<&'c str>,
        slot: &mut Slot<'_>,
    ) -> Result<()> {
        let line = line.strip_suffix('\r').unwrap_or(line);
        let result = if line.is_empty() {
            Ok(())
        } else {
            fields.push(&line[last.min(line.len())..]);
            self.row(&fields[..], line_no, slot)
        };
        fields.clear();
        result
    }
}

/// The first `n` values of `s`, leaving `s` the rest.
fn share<'a>(s: &mut &'a mut [f64], n: usize) -> &'a mut [f64] {
    let (head, tail) = std::mem::take(s).split_at_mut(n);
    *s = tail;
    head
}

impl Columns {
    /// `more` (the rows after these) appended.
    pub(crate) fn append(&mut self, more: Columns) {
        self.xyz.extend_from_slice(&more.xyz);
        self.t.extend_from_slice(&more.t);
        self.temp.extend_from_slice(&more.temp);
        self.labels.extend(more.labels);
        self.skipped += more.skipped;
    }

    fn truncate(&mut self, rows: usize) {
        self.xyz.truncate(rows);
        self.t.truncate(rows);
        self.temp.truncate(rows);
    }
}

/// `(start, end)` byte ranges of about `size` bytes covering `bytes`, each ending just after a
/// line end (the last at the end of the text).
pub(crate) fn chunk_bounds(bytes: &[u8], size: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(bytes.len() / size.max(1) + 1);
    let mut start = 0;
    while start < bytes.len() {
        let mut end = (start + size.max(1)).min(bytes.len());
        if end < bytes.len() {
            end = memchr::memchr(b'\n', &bytes[end..]).map_or(bytes.len(), |p| end + p + 1);
        }
        out.push((start, end));
        start = end;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> RowLayout {
        RowLayout {
            names: ["t", "x", "y", "z", "temp", "pose"]
                .map(String::from)
                .to_vec(),
            time: Some(0),
            xyz: [1, 2, 3],
            temp: Some(4),
            label: Some(5),
            decimal_comma: false,
        }
    }

    /// What a read gave, comparable: the columns' bits, or the error sentence.
    fn outcome(r: Result<Columns>) -> std::result::Result<String, String> {
        r.map(|c| {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let xyz: Vec<f64> = c.xyz.iter().flatten().copied().collect();
            format!(
                "{:?} {:?} {:?} {:?} {}",
                bits(&xyz),
                bits(&c.t),
                bits(&c.temp),
                c.labels,
                c.skipped
            )
        })
        .map_err(|e| e.to_string())
    }

    /// `n` rows with decimals of every length; `bad` replaces the row at its index.
    fn rows(n: usize, bad: Option<(usize, &str)>) -> String {
        let mut out = String::new();
        for i in 0..n {
            match bad {
                Some((at, line)) if at == i => out.push_str(line),
                _ => out.push_str(&format!(
                    "{},{},-{}.{},{}e-{},2{}.5,p{}",
                    i as f64 * 0.01,
                    i % 977,
                    i % 13,
                    i * 7919 % 100_003,
                    i % 5 + 1,
                    i % 3,
                    i % 4,
                    i % 7
                )),
            }
            out.push_str(if i % 3 == 0 { "\r\n" } else { "\n" });
        }
        out
    }

    /// Cut into chunks of any size, the rows read exactly as in one piece and as the `csv`
    /// reader reads them: values bit for bit, skips, labels, and the same first error
    /// (line and column), including a time that goes back right at a chunk boundary.
    #[test]
    fn chunks_read_as_one_piece_and_as_the_csv_reader() {
        let l = layout();
        let texts = [
            rows(300, None),
            rows(300, Some((150, ",,,,25,p"))),
            rows(300, Some((151, "1.495,1,2,3,25,p"))),
            rows(300, Some((7, "0.07,1,zz,3,25,p"))),
            rows(300, Some((250, "2.5,1,2,3"))),
            rows(300, Some((260, "2.6,1,2,3,1e300,p"))),
            rows(300, Some((299, "0.5,1,2,3,25,p"))),
            rows(300, None) + "9,1,2,3,25,p",
        ];
        for text in &texts {
            let whole = outcome(l.read_plain_in(text, 2, b',', usize::MAX, None));
            let mut reader = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .from_reader(text.as_bytes());
            // The csv reader counts lines its own way (from its own start, CR LF pairs): the
            // sentence after the line number is compared; the line numbers are checked below.
            let by_csv = outcome(l.read_records(&mut reader, text.len() + 1));
            match (&whole, by_csv) {
                (Ok(a), Ok(b)) => assert_eq!(a, &b),
                (Err(a), Err(b)) => {
                    assert_eq!(a.split_once(':').unwrap().1, b.split_once(':').unwrap().1);
                }
                (a, b) => panic!("{a:?} vs {b:?}"),
            }
            for size in [1, 7, 64, 500, 4096] {
                let chunked = outcome(l.read_plain_in(text, 2, b',', size, None));
                assert_eq!(chunked, whole, "chunks of {size}");
            }
        }
        // Row i is line i + 2.
        let e = outcome(l.read_plain_in(&texts[3], 2, b',', 7, None)).unwrap_err();
        assert_eq!(e, "line 9: column 'y': 'zz' is not a number");
        let e = outcome(l.read_plain_in(&texts[2], 2, b',', 1, None)).unwrap_err();
        assert!(
            e.starts_with("line 153: column 't': time goes from 1.5 back"),
            "{e}"
        );
        let e = outcome(l.read_plain_in(&texts[5], 2, b',', 64, None)).unwrap_err();
        assert!(
            e.starts_with("line 262, column temp: the reading 1e300"),
            "{e}"
        );
    }

    #[test]
    fn chunk_bounds_end_at_line_ends() {
        let text = b"a,b\nc\n\nlong line here\nz";
        for size in 1..30 {
            let b = chunk_bounds(text, size);
            assert_eq!(b.first().unwrap().0, 0);
            assert_eq!(b.last().unwrap().1, text.len());
            for w in b.windows(2) {
                assert_eq!(w[0].1, w[1].0);
                assert_eq!(text[w[0].1 - 1], b'\n');
            }
        }
        assert!(chunk_bounds(b"", 4).is_empty());
    }
}
