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
use crate::input::bounded::{parse_number, parse_reading, MAX_READING};
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
    /// line `first_line` of the file, parsed in chunks on all cores (see the module docs), on
    /// a piece of a file that continues rows read before, whose last time was `prev_time`: the time check is joined to it as between two chunks. With
    /// the rows, the number of line ends in `text` (counted on all cores with the chunks: the
    /// next piece's first line number, with no other pass over the text).
    pub(crate) fn read_plain_after(
        &self,
        text: &str,
        first_line: usize,
        delim: u8,
        prev_time: Option<f64>,
    ) -> Result<(Columns, usize)> {
        let mut cols = Columns::default();
        let newlines =
            self.read_plain_into(&mut cols, text, first_line, delim, CHUNK_BYTES, prev_time)?;
        Ok((cols, newlines))
    }

    /// [`RowLayout::read_plain_after`] appending to `cols` (rows read before, whose last time
    /// is the one the time check is joined to), with no copy of the rows: the chunks are parsed
    /// into `cols`' own new rows. The number of line ends in `text`. On an error `cols` holds
    /// the rows before and some of `text`'s.
    pub(crate) fn read_plain_onto(
        &self,
        cols: &mut Columns,
        text: &str,
        first_line: usize,
        delim: u8,
    ) -> Result<usize> {
        let prev_time = cols.t.last().copied();
        self.read_plain_into(cols, text, first_line, delim, CHUNK_BYTES, prev_time)
    }

    /// [`RowLayout::read_plain_after`]'s rows in chunks of about `chunk_bytes` (tests: many
    /// chunks from a small text).
    #[cfg(test)]
    fn read_plain_in(
        &self,
        text: &str,
        first_line: usize,
        delim: u8,
        chunk_bytes: usize,
        prev_time: Option<f64>,
    ) -> Result<Columns> {
        let mut cols = Columns::default();
        self.read_plain_into(&mut cols, text, first_line, delim, chunk_bytes, prev_time)?;
        Ok(cols)
    }

    /// The rows of `text` appended to `cols`, in chunks of about `chunk_bytes` (see the module
    /// docs): each chunk's share of the new rows is as many rows as it has lines, so that
    /// without blank or skipped lines the rows are where they belong and nothing moves. The
    /// number of line ends in `text`.
    fn read_plain_into(
        &self,
        cols: &mut Columns,
        text: &str,
        first_line: usize,
        delim: u8,
        chunk_bytes: usize,
        prev_time: Option<f64>,
    ) -> Result<usize> {
        let bytes = text.as_bytes();
        let bounds = chunk_bounds(bytes, chunk_bytes);
        let newlines: Vec<usize> = bounds
            .par_iter()
            .map(|&(a, b)| memchr::memchr_iter(b'\n', &bytes[a..b]).count())
            .collect();
        let caps: Vec<usize> = (bounds.iter().zip(&newlines))
            .map(|(&(_, b), n)| n + usize::from(bytes[b - 1] != b'\n'))
            .collect();
        let base = cols.xyz.len();
        self.grow(cols, caps.iter().sum());
        let plan = self.plan();
        let mut jobs = Vec::with_capacity(bounds.len());
        {
            let (tb, tempb) = (base.min(cols.t.len()), base.min(cols.temp.len()));
            let (mut xyz, mut t, mut temp) = (
                &mut cols.xyz[base..],
                &mut cols.t[tb..],
                &mut cols.temp[tempb..],
            );
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
                let err = (self.read_chunk(chunk, line, delim, plan.as_ref(), &mut slot)).err();
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
        self.join(cols, base, &caps, outs, prev_time)?;
        Ok(newlines.iter().sum())
    }

    /// `cols` with room for `rows` more rows (zero pages from the allocator when `cols` is
    /// empty: what no row fills is never touched).
    fn grow(&self, cols: &mut Columns, rows: usize) {
        if cols.xyz.is_empty() {
            let Columns {
                labels, skipped, ..
            } = std::mem::take(cols);
            *cols = Columns {
                labels,
                skipped,
                ..self.columns(rows)
            };
            return;
        }
        let n = cols.xyz.len() + rows;
        cols.xyz.resize(n, [0.0; 3]);
        if self.time.is_some() {
            cols.t.resize(n, 0.0);
        }
        if self.temp.is_some() {
            cols.temp.resize(n, 0.0);
        }
    }

    /// The chunks' results in file order, into `cols` from row `base`: the time joined at each
    /// boundary, the first error returned, the rows moved together (each chunk filled only the
    /// front of its share).
    fn join(
        &self,
        cols: &mut Columns,
        base: usize,
        caps: &[usize],
        outs: Vec<ChunkOut>,
        mut prev_time: Option<f64>,
    ) -> Result<()> {
        let (mut at, mut offset) = (base, base);
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
        Ok(())
    }

    /// One chunk's lines, each read by the fast path ([`fast_row`]) when the [`Plan`] allows
    /// and its fields are plain decimals, else split at its delimiters (a carriage return
    /// before the line end dropped, an empty line skipped) and read by [`RowLayout::row`], which
    /// names what is wrong with it.
    fn read_chunk(
        &self,
        chunk: &str,
        first_line: usize,
        delim: u8,
        plan: Option<&Plan>,
        slot: &mut Slot<'_>,
    ) -> Result<()> {
        let bytes = chunk.as_bytes();
        let mut fields: Vec<&str> = Vec::with_capacity(self.names.len() + 1);
        let (mut at, mut line_no) = (0usize, first_line);
        let mut vals = [0.0f64; 5];
        while at < bytes.len() {
            if let Some(plan) = plan {
                if let Some(next) = fast_row(&plan.dest, bytes, at, delim, &mut vals) {
                    if slot.take(&vals, plan, line_no) {
                        at = next;
                        line_no += 1;
                        continue;
                    }
                }
            }
            let end = memchr::memchr(b'\n', &bytes[at..]).map_or(bytes.len(), |p| at + p);
            let line = &chunk[at..end];
            let line = line.strip_suffix('\r').unwrap_or(line);
            if !line.is_empty() {
                fields.clear();
                fields.extend(line.split(char::from(delim)));
                self.row(&fields[..], line_no, slot)?;
            }
            at = end + 1;
            line_no += 1;
        }
        Ok(())
    }

    /// The fast path's plan for this layout: `None` when a field feeds two columns (an axis
    /// that is also the time: refused later, read by [`RowLayout::row`] until then), for a
    /// label column (text) and for decimal commas.
    fn plan(&self) -> Option<Plan> {
        if self.label.is_some() || self.decimal_comma {
            return None;
        }
        let mut dest = vec![SKIP; self.names.len()];
        let wanted = self.xyz.iter().enumerate().map(|(k, &i)| (i, k as Dest));
        let wanted = wanted.chain(self.time.map(|i| (i, TIME)));
        for (i, d) in wanted.chain(self.temp.map(|i| (i, TEMP))) {
            if *dest.get(i)? != SKIP {
                return None;
            }
            dest[i] = d;
        }
        Some(Plan {
            dest,
            temp: self.temp.is_some(),
        })
    }
}

/// Where a field of a data row goes on the fast path: an axis (0–2), the time ([`TIME`]), the
/// temperature ([`TEMP`]), or nowhere ([`SKIP`]: a column the recording does not keep).
type Dest = u8;
/// The time column's [`Dest`].
const TIME: Dest = 3;
/// The temperature column's [`Dest`].
const TEMP: Dest = 4;
/// A column not read.
const SKIP: Dest = u8::MAX;

/// How the fast path reads a row of this layout: every field's destination.
struct Plan {
    /// [`Dest`] of each field, in order.
    dest: Vec<Dest>,
    /// The layout has a temperature column (its reading is range-checked).
    temp: bool,
}

impl Slot<'_> {
    /// A row read by the fast path (values by [`Dest`]) kept when it passes the checks
    /// [`RowLayout::row`] makes (readings within range, time not going back); `false` leaves
    /// the slot as it was, for [`RowLayout::row`] to read the line again and name the problem.
    fn take(&mut self, v: &[f64; 5], plan: &Plan, line_no: usize) -> bool {
        let out = |x: f64| x.abs() > MAX_READING;
        if out(v[0]) || out(v[1]) || out(v[2]) || (plan.temp && out(v[4])) {
            return false;
        }
        let k = self.rows;
        if let Some(clock) = self.clock.as_mut() {
            if clock.push(v[3], line_no).is_err() {
                return false;
            }
            self.first_time.get_or_insert((v[3], line_no));
            self.t[k] = v[3];
        }
        if plan.temp {
            self.temp[k] = v[4];
        }
        self.xyz[k] = [v[0], v[1], v[2]];
        self.rows += 1;
        true
    }
}

/// One line of plain decimals from `b[at]`: each field to its destination in `vals`
/// ([`Dest`]; skipped fields may hold anything but a delimiter or a line end), then the line
/// end (`\n`, `\r\n` or the end of the text). The index after the line, or `None` when the
/// line is anything else (blanks around a number, an exponent, an empty field, too many or
/// too few fields, more than 19 digits): [`RowLayout::row`] reads it then.
#[inline]
fn fast_row(dest: &[Dest], b: &[u8], at: usize, delim: u8, vals: &mut [f64; 5]) -> Option<usize> {
    let mut i = at;
    for (k, &d) in dest.iter().enumerate() {
        if k > 0 {
            if b.get(i) != Some(&delim) {
                return None;
            }
            i += 1;
        }
        if d == SKIP {
            while b.get(i).is_some_and(|&c| c != delim && c != b'\n') {
                i += 1;
            }
        } else {
            let (v, next) = plain_decimal(b, i)?;
            vals[usize::from(d)] = v;
            i = next;
        }
    }
    match b.get(i) {
        None => Some(i),
        Some(b'\n') => Some(i + 1),
        Some(b'\r') if b.get(i + 1) == Some(&b'\n') => Some(i + 2),
        _ => None,
    }
}

/// Powers of ten that are exact doubles (10²² is the largest).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A plain decimal `[-]digits[.digits]` at `b[i]` (at least one digit, at most 19, the digits
/// as an integer at most 2⁵³): its value and the index after it, else `None`. Such an integer
/// and the power of ten that scales it are exact doubles, so their quotient is the correctly
/// rounded value (Clinger's fast path): the bits `str::parse` and `fast-float2` give. Written
/// by hand because it is the one shape nearly every recording's numbers have, read here in
/// the same pass that finds the field's end (a general parser is called per field, after a
/// delimiter search).
#[inline]
fn plain_decimal(b: &[u8], mut i: usize) -> Option<(f64, usize)> {
    let neg = b.get(i) == Some(&b'-');
    i += usize::from(neg);
    let start = i;
    let mut m = 0u64;
    let mut frac = 0usize;
    let mut point = None;
    loop {
        match b.get(i) {
            Some(c @ b'0'..=b'9') => m = m.wrapping_mul(10).wrapping_add(u64::from(c - b'0')),
            Some(b'.') if point.is_none() => point = Some(i),
            _ => break,
        }
        i += 1;
    }
    if let Some(p) = point {
        frac = i - p - 1;
    }
    let digits = i - start - usize::from(point.is_some());
    if digits == 0 || digits > 19 || m > 1 << 53 {
        return None;
    }
    let v = m as f64 / POW10[frac];
    Some((if neg { -v } else { v }, i))
}

/// The first `n` values of `s`, leaving `s` the rest.
fn share<'a>(s: &mut &'a mut [f64], n: usize) -> &'a mut [f64] {
    let (head, tail) = std::mem::take(s).split_at_mut(n);
    *s = tail;
    head
}

impl Columns {
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

    /// Every text the fast path reads, read as by the `csv` reader and [`RowLayout::row`]
    /// (which the fast path hands any other line to): plain decimals of every shape, and lines
    /// it must hand over — blanks, exponents, signs, more than 19 digits or over 2⁵³, readings
    /// out of range, times that go back, empty, missing or extra fields, a column not read.
    #[test]
    #[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
    fn fast_path_reads_as_the_csv_reader() {
        let l = RowLayout {
            names: ["t", "x", "note", "y", "z", "temp"]
                .map(String::from)
                .to_vec(),
            time: Some(0),
            xyz: [1, 3, 4],
            temp: Some(5),
            label: None,
            decimal_comma: false,
        };
        assert!(l.plan().is_some());
        let odd = [
            "-0",
            "0",
            "-0.0",
            ".5",
            "-.5",
            "1.",
            "007.250",
            "9007199254740992",
            "9007199254740993",
            "1234567890123456789",
            "12345678901234567890",
            "0.1234567890123456789",
            "999999999999",
            "1000000000000",
            "1000000000000.5",
            "-1000000000001",
            "+1",
            " 1",
            "1 ",
            "1e3",
            "-",
            ".",
            "1.2.3",
            "",
            "inf",
            "0x10",
            "1,5",
        ];
        let mut text = String::new();
        let mut t = 0.0f64;
        for (i, v) in odd.iter().cycle().take(400).enumerate() {
            t += [0.01, 0.0, 0.25][i % 3];
            let t_text = if i == 333 {
                format!("{}", t - 1.0)
            } else {
                format!("{t:.4}")
            };
            let row = match i % 4 {
                0 => format!(
                    "{t_text},{v},n{i},{},-{}.{},2{}",
                    i % 97,
                    i % 13,
                    i * 31 % 1000,
                    i % 9
                ),
                1 => format!("{t_text},{},,{v},{}.5,{v}", i % 7, i % 5),
                2 => format!("{t_text},{},x y,{},{v},2{}.25", i % 3, i % 11, i % 8),
                _ => format!(
                    "{t_text},1,n,2,3,{}{}",
                    20 + i % 5,
                    if i % 8 == 3 { ",9" } else { "" }
                ),
            };
            text += &row;
            text += if i % 5 == 0 { "\r\n" } else { "\n" };
            if i % 50 == 7 {
                text += "\n";
            }
        }
        // Errors end a read at their line: read each line's prefix so every bad line is met.
        let mut checked = 0;
        for cut in memchr::memchr_iter(b'\n', text.as_bytes()).step_by(3) {
            let part = &text[..=cut];
            let whole = outcome(l.read_plain_in(part, 2, b',', usize::MAX, None));
            let mut reader = csv::ReaderBuilder::new()
                .has_headers(false)
                .flexible(true)
                .from_reader(part.as_bytes());
            let by_csv = outcome(l.read_records(&mut reader, part.len() + 1));
            match (&whole, by_csv) {
                (Ok(a), Ok(b)) => assert_eq!(a, &b, "{part:?}"),
                (Err(a), Err(b)) => {
                    assert_eq!(a.split_once(':').unwrap().1, b.split_once(':').unwrap().1);
                    checked += 1;
                }
                (a, b) => panic!("{a:?} vs {b:?}"),
            }
            for size in [1, 64, 4096] {
                let chunked = outcome(l.read_plain_in(part, 2, b',', size, None));
                assert_eq!(chunked, whole, "chunks of {size}");
            }
        }
        assert!(checked > 10, "{checked} prefixes ended in an error");
    }

    /// The hand-written decimal reader gives `str::parse`'s bits, or hands the field over.
    #[test]
    fn plain_decimals_read_as_str_parse() {
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "1.",
            ".5",
            "-.5",
            "00012.3400",
            "4503599627370497",
        ]
        .map(String::from)
        .to_vec();
        for i in (-3_000_000i64..3_000_000).step_by(997) {
            for d in 0..8 {
                let (int, frac) = (i / 1000, (i % 1000).unsigned_abs());
                cases.push(format!("{int}.{frac:0d$}", d = d));
            }
        }
        for p in 0..20 {
            cases.push(format!("0.{}1", "0".repeat(p)));
            cases.push(format!("9007199254740{p:03}"));
        }
        for c in &cases {
            if let Some((v, end)) = plain_decimal(c.as_bytes(), 0) {
                assert_eq!(end, c.len(), "{c}");
                assert_eq!(v.to_bits(), c.parse::<f64>().unwrap().to_bits(), "{c}");
            }
        }
        assert_eq!(plain_decimal(b"1.25,", 0), Some((1.25, 4)));
        for hand_over in [
            "",
            "-",
            ".",
            "9007199254740993",
            "12345678901234567890",
            "+1",
        ] {
            assert_eq!(plain_decimal(hand_over.as_bytes(), 0), None, "{hand_over}");
        }
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
