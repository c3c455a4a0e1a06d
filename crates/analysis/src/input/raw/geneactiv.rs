//! GENEActiv `.bin` files, from Activinsights' published description ("Decoding .bin files"
//! in the GENEActiv instructions): a text file of `Key:Value` lines (CR LF).
//!
//! * The file header (about 59 lines, starting `Device Identity`) gives, among others,
//!   `Device Model`, `Measurement Frequency` (`85.7 Hz`), the per-axis calibration
//!   `x gain`, `x offset`, … (g = (raw·100 − offset) / gain), `Volts` and `Lux` (lux =
//!   light·Lux/Volts) and `Number of Pages`.
//! * Each page: a `Recorded Data` line, `Key:Value` lines (`Sequence Number`,
//!   `Page Time:YYYY-MM-DD hh:mm:ss:mmm`, `Temperature` °C, `Battery voltage`,
//!   `Measurement Frequency`), then one line of hex digits, 12 per sample (300 samples): x, y, z
//!   as 12-bit two's complement (3 digits each), then 10 bits of light and a button bit and a
//!   reserved bit (3 digits).
//!
//! A page whose fields or hex digits are impossible is skipped with its reason
//! ([`Block::Invalid`]; the format has no checksum); a last page cut off by the end of the file
//! is a note (GENEActiv files copied in part end mid-page). Header lines may hold NUL padding:
//! everything is read as bytes.
//!
//! The file is read line by line ([`PageReader`]), a chunk of pages at a time decoded on all
//! cores, whether it comes from disk or from memory ([`PageReader::of_bytes`]): a week of wear (hundreds of
//! MB) is read in the memory of one chunk, and both paths decode every page the same way. Of
//! each line only its first 8 KiB are kept (with its length and whether it holds
//! a `:`): a data line is at most 3600 bytes, and a key's value beyond 8 KiB is not read.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use super::block::{civil_seconds, valid_civil, Block, GoodBlock};
use crate::error::input::InputError;
use rayon::prelude::*;
use std::io::BufRead;

/// This module's errors are all the input stage's.
type Result<T, E = InputError> = std::result::Result<T, E>;

/// Samples in a page.
pub const PAGE_SAMPLES: usize = 300;
/// Longest line accepted, bytes (a data line is 3600 hex digits); longer lines keep this
/// many of their first bytes.
const MAX_LINE: usize = 8192;
/// The channels of every sample (the accelerometer's, in g).
pub const CHANNELS: [&str; 3] = ["ax", "ay", "az"];
/// Pages decoded together (about 4 MB of text): the memory of a page-by-page read.
pub const CHUNK_PAGES: usize = 1024;

/// Gains a header may declare (counts·100 per g): GENEActiv's ±8 g over 12 bits is about
/// 25 600; a gain outside this range would put the 12-bit full scale below 0.5 g or above
/// 1000 g.
const GAIN_RANGE: std::ops::RangeInclusive<f64> = 204.8..=409_600.0;
/// Largest |offset| a header may declare (counts·100: the whole 12-bit range).
const MAX_OFFSET: f64 = 204_800.0;
/// Highest rate a header or page may declare, Hz (the devices stop at 100 Hz).
const MAX_RATE_HZ: f64 = 10_000.0;
/// Temperatures a page may report, °C (the sensor's operating range with margin).
const TEMP_RANGE: std::ops::RangeInclusive<f64> = -60.0..=100.0;

/// A header's number as an error quotes it: exponent notation when huge or tiny (1e300, not
/// 301 digits).
fn shown(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The header's calibration and declarations.
#[derive(Debug, Clone)]
struct Header {
    gain: [f64; 3],
    offset: [f64; 3],
    lux_per_volt: f64,
    rate_hz: f64,
    pages: Option<usize>,
    model: String,
}

/// One line as read: its first [`MAX_LINE`] bytes (a trailing CR removed), its whole length
/// and whether it holds a `:` anywhere.
#[derive(Debug, Default)]
struct Line {
    kept: Vec<u8>,
    len: usize,
    colon: bool,
    /// Ended by a line feed (false only for the file's last line).
    terminated: bool,
}

impl Line {
    /// `Key:Value` with the key trimmed and the value trimmed of white space and NUL padding.
    fn key_value(&self) -> Option<(&str, &str)> {
        let line = std::str::from_utf8(&self.kept).ok()?;
        let (k, v) = line.split_once(':')?;
        Some((
            k.trim(),
            v.trim_matches(|c: char| c.is_whitespace() || c == '\0'),
        ))
    }
}

/// The first value of each of a fixed set of keys among `Key:Value` lines (a key given twice
/// counts by its first line, as a reader looking it up from the top would take it).
#[derive(Debug, Clone)]
struct Fields {
    keys: &'static [&'static str],
    values: Vec<Option<String>>,
}

impl Fields {
    fn new(keys: &'static [&'static str]) -> Self {
        Self {
            keys,
            values: vec![None; keys.len()],
        }
    }

    fn feed(&mut self, line: &Line) {
        if let Some((k, v)) = line.key_value() {
            if let Some(i) = self.keys.iter().position(|key| *key == k) {
                self.values[i].get_or_insert_with(|| v.to_string());
            }
        }
    }

    fn get(&self, key: &str) -> Option<&str> {
        let i = self.keys.iter().position(|k| *k == key)?;
        self.values[i].as_deref()
    }
}

/// The header keys read.
const HEADER_KEYS: &[&str] = &[
    "x gain",
    "x offset",
    "y gain",
    "y offset",
    "z gain",
    "z offset",
    "Volts",
    "Measurement Frequency",
    "Lux",
    "Number of Pages",
    "Device Model",
];

/// A page's keys read.
const PAGE_KEYS: &[&str] = &[
    "Page Time",
    "Temperature",
    "Measurement Frequency",
    "Sequence Number",
    "Battery voltage",
];

/// A page's text as read: its fields and its first data line (a non-empty line without `:`),
/// or that line's length when it is longer than [`MAX_LINE`].
#[derive(Debug, Clone)]
struct PageText {
    fields: Fields,
    hex: Option<std::result::Result<Vec<u8>, usize>>,
}

impl PageText {
    fn new() -> Self {
        Self {
            fields: Fields::new(PAGE_KEYS),
            hex: None,
        }
    }

    fn feed(&mut self, line: &Line) {
        if line.colon {
            self.fields.feed(line);
        } else if self.hex.is_none() && line.len > 0 {
            self.hex = Some(if line.len > MAX_LINE {
                Err(line.len)
            } else {
                Ok(line.kept.clone())
            });
        }
    }
}

/// Lines of a byte stream, split at LF, each kept up to [`MAX_LINE`] bytes: memory is one
/// line whatever the stream holds.
struct Lines<R> {
    inner: R,
    line: Line,
    /// The last line returned ended with a line feed (the stream's last byte, once it ends).
    last_terminated: bool,
}

impl<R: BufRead> Lines<R> {
    /// The next line; `Ok(false)` at the end of the stream.
    fn next(&mut self) -> std::io::Result<bool> {
        let l = &mut self.line;
        l.kept.clear();
        (l.len, l.colon, l.terminated) = (0, false, false);
        let mut last = 0u8;
        loop {
            let buf = match self.inner.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if buf.is_empty() {
                break;
            }
            let (piece, used, end) = match memchr::memchr(b'\n', buf) {
                Some(i) => (&buf[..i], i + 1, true),
                None => (buf, buf.len(), false),
            };
            if let Some(&b) = piece.last() {
                last = b;
            }
            l.colon |= memchr::memchr(b':', piece).is_some();
            let room = MAX_LINE.saturating_sub(l.kept.len());
            l.kept.extend_from_slice(&piece[..piece.len().min(room)]);
            l.len += piece.len();
            self.inner.consume(used);
            if end {
                l.terminated = true;
                break;
            }
        }
        if l.len == 0 && !l.terminated {
            return Ok(false);
        }
        self.last_terminated = l.terminated;
        if last == b'\r' && l.len > 0 {
            if l.kept.len() == l.len {
                l.kept.pop();
            }
            l.len -= 1;
        }
        Ok(true)
    }
}

fn number_of(v: Option<&str>) -> Option<f64> {
    number(v?)
}

/// First number in `v` (`85.7 Hz` → 85.7).
fn number(v: &str) -> Option<f64> {
    v.split_whitespace()
        .next()?
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
}

fn read_header(fields: &Fields) -> Result<Header> {
    let err = |why: String| InputError::RawHeader {
        format: "GENEActiv .bin",
        why,
    };
    let num = |key: &str| {
        number_of(fields.get(key))
            .ok_or_else(|| err(format!("no number in its header line '{key}'")))
    };
    let mut gain = [0.0; 3];
    let mut offset = [0.0; 3];
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        gain[k] = num(&format!("{a} gain"))?;
        offset[k] = num(&format!("{a} offset"))?;
        if !(GAIN_RANGE.contains(&gain[k]) && offset[k].abs() <= MAX_OFFSET) {
            return Err(err(format!(
                "{a} gain {} or offset {} is impossible (a gain of {}…{} and an offset within ±{MAX_OFFSET} are)",
                shown(gain[k]),
                shown(offset[k]),
                GAIN_RANGE.start(),
                GAIN_RANGE.end()
            )));
        }
    }
    let volts = num("Volts")?;
    let rate_hz = num("Measurement Frequency")?;
    if !(rate_hz > 0.0 && rate_hz <= MAX_RATE_HZ && volts > 0.0) {
        return Err(err(format!(
            "the measurement frequency ({} Hz) must be in (0, {MAX_RATE_HZ}] Hz and Volts ({}) positive",
            shown(rate_hz),
            shown(volts)
        )));
    }
    Ok(Header {
        gain,
        offset,
        lux_per_volt: num("Lux")? / volts,
        rate_hz,
        pages: number_of(fields.get("Number of Pages")).map(|p| p.max(0.0) as usize),
        model: fields.get("Device Model").unwrap_or("").to_string(),
    })
}

/// A `.bin` file read a chunk of pages at a time ([`CHUNK_PAGES`]), from disk or from its bytes
/// in memory: memory is one chunk, whatever the file's length.
pub struct PageReader<R> {
    lines: Lines<R>,
    path: std::path::PathBuf,
    header: Header,
    /// The page being read (its `Recorded Data` line seen); `None` before the first.
    page: Option<PageText>,
    /// Pages passed on (decoded or skipped).
    index: usize,
    notes: Vec<String>,
    done: bool,
}

impl<'a> PageReader<Box<dyn BufRead + 'a>> {
    /// Opens `path` and reads its header.
    pub fn open(path: &std::path::Path) -> crate::error::Result<Self> {
        let file = std::fs::File::open(path).map_err(|source| InputError::Read {
            path: path.into(),
            source,
        })?;
        let inner = std::io::BufReader::with_capacity(1 << 16, file);
        Ok(Self::new(Box::new(inner), path)?)
    }

    /// The reader of a file held in memory (`bytes`), its pages and notes as
    /// [`PageReader::open`] gives them from the file.
    pub fn of_bytes(bytes: &'a [u8]) -> crate::error::Result<Self> {
        Ok(Self::new(Box::new(bytes), std::path::Path::new(""))?)
    }
}

impl<R: BufRead> PageReader<R> {
    /// Reads the header from `inner` (up to the first `Recorded Data` line); `path` names the
    /// source in read errors.
    fn new(inner: R, path: &std::path::Path) -> Result<Self> {
        let mut lines = Lines {
            inner,
            line: Line::default(),
            last_terminated: false,
        };
        let read_err = |source| InputError::Read {
            path: path.into(),
            source,
        };
        let mut fields = Fields::new(HEADER_KEYS);
        let mut page = None;
        while lines.next().map_err(read_err)? {
            if lines.line.kept == b"Recorded Data" && lines.line.len == 13 {
                page = Some(PageText::new());
                break;
            }
            fields.feed(&lines.line);
        }
        Ok(Self {
            header: read_header(&fields)?,
            lines,
            path: path.into(),
            page,
            index: 0,
            notes: Vec::new(),
            done: false,
        })
    }

    /// The device as the header names it (`GENEActiv 1.1`).
    pub fn device(&self) -> String {
        format!("GENEActiv {}", self.header.model)
            .trim()
            .to_string()
    }

    /// The rate the header declares, Hz.
    pub fn header_rate_hz(&self) -> f64 {
        self.header.rate_hz
    }

    /// The pages the header declares (`Number of Pages`), when it does.
    pub fn declared_pages(&self) -> Option<usize> {
        self.header.pages
    }

    /// The reader's notes once the file is read (a cut-off last page).
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// Up to [`CHUNK_PAGES`] complete pages' texts; the flag is true when the last of them is
    /// the file's last page and the file does not end with a line feed.
    fn next_texts(&mut self) -> Result<(Vec<PageText>, bool)> {
        let mut texts = Vec::new();
        while texts.len() < CHUNK_PAGES && !self.done {
            let more = self.lines.next().map_err(|source| InputError::Read {
                path: self.path.clone(),
                source,
            })?;
            if !more {
                self.done = true;
                texts.extend(self.page.take());
                let cut = !self.lines.last_terminated;
                return Ok((texts, cut));
            }
            let line = &self.lines.line;
            if line.kept == b"Recorded Data" && line.len == 13 {
                texts.extend(self.page.replace(PageText::new()));
            } else if let Some(p) = &mut self.page {
                p.feed(line);
            }
        }
        Ok((texts, false))
    }

    /// The next chunk's pages in `out` (cleared first); `false` once the file is read.
    pub fn next_chunk(&mut self, out: &mut Vec<Block>) -> crate::error::Result<bool> {
        out.clear();
        let (texts, last_cut) = self.next_texts()?;
        let first = self.index;
        let header = &self.header;
        let decoded: Vec<_> = texts
            .par_iter()
            .enumerate()
            .map(|(k, p)| decode_page(p, first + k, header))
            .collect();
        let n = decoded.len();
        for (k, page) in decoded.into_iter().enumerate() {
            let index = self.index;
            let cut = last_cut && self.done && k + 1 == n;
            match page {
                Ok(p) if p.len(3) == PAGE_SAMPLES || !cut => out.push(Block::Good(p)),
                Ok(p) => self.notes.push(cut_note(index, p.len(3))),
                Err(_) if cut => self.notes.push(cut_note(index, 0)),
                Err(why) => out.push(Block::Invalid(why)),
            }
            self.index += usize::from(!cut);
        }
        Ok(!self.done)
    }
}

fn cut_note(index: usize, samples: usize) -> String {
    format!(
        "the file is cut short in page #{index} ({samples} of {PAGE_SAMPLES} samples complete): that page is not read"
    )
}

fn page_time(v: &str) -> Option<f64> {
    let (date, time) = v.trim().split_once(' ')?;
    let d: Vec<u32> = date
        .split('-')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<u32> = time
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let (&[y, mo, d], &[h, mi, s, ms]) = (d.as_slice(), t.as_slice()) else {
        return None;
    };
    (valid_civil(y.into(), mo, d, h, mi, s) && ms < 1000).then(|| {
        civil_seconds(
            y.into(),
            mo,
            d,
            h,
            mi,
            f64::from(s) + f64::from(ms) / 1000.0,
        )
    })
}

/// 12-bit two's complement of three hex digits.
fn hex3(d: &[u8]) -> Option<i32> {
    let s = std::str::from_utf8(d).ok()?;
    u16::from_str_radix(s, 16).ok().map(i32::from)
}

/// A page's `Temperature` field, °C, or why not in the field's own terms: a page that says
/// `Temperature:nan` has the field, and "no 'Temperature'" would send the reader looking for
/// a missing line instead of a sensor that reported no value.
fn page_temperature(field: Option<&str>) -> std::result::Result<f64, String> {
    let Some(v) = field else {
        return Err("no 'Temperature'".into());
    };
    let word = v.split_whitespace().next().unwrap_or("");
    match word.parse::<f64>() {
        Ok(t) if t.is_finite() => Ok(t),
        Ok(t) if t.is_nan() => Err("its temperature is NaN (the device reported no value)".into()),
        Ok(_) => Err(format!("its temperature is {word}, not a finite number")),
        Err(_) if word.is_empty() => Err("its 'Temperature' line holds no value".into()),
        Err(_) => Err(format!("its temperature '{word}' is not a number")),
    }
}

fn decode_page(
    page: &PageText,
    index: usize,
    h: &Header,
) -> std::result::Result<GoodBlock, String> {
    let get = |key: &str| page.fields.get(key);
    let start_s = get("Page Time")
        .and_then(page_time)
        .ok_or("no valid 'Page Time'")?;
    let temp_c = page_temperature(get("Temperature"))?;
    if !TEMP_RANGE.contains(&temp_c) {
        return Err(format!(
            "temperature {} °C is impossible ({}…{} °C)",
            shown(temp_c),
            TEMP_RANGE.start(),
            TEMP_RANGE.end()
        ));
    }
    let rate_hz = get("Measurement Frequency")
        .and_then(number)
        .filter(|r| *r > 0.0)
        .unwrap_or(h.rate_hz);
    if rate_hz > MAX_RATE_HZ {
        return Err(format!(
            "measurement frequency {} Hz is impossible",
            shown(rate_hz)
        ));
    }
    let sequence = get("Sequence Number")
        .and_then(number)
        .map_or(0, |v| v.clamp(0.0, u32::MAX as f64) as u32);
    let hex = match &page.hex {
        None => return Err("no data line".into()),
        Some(Err(len)) => return Err(format!("a data line of {len} bytes")),
        Some(Ok(hex)) => hex,
    };
    let mut data = Vec::with_capacity(3 * PAGE_SAMPLES);
    let mut lux = Vec::with_capacity(PAGE_SAMPLES);
    for s in hex.chunks_exact(12) {
        for k in 0..3 {
            let raw = hex3(&s[3 * k..3 * k + 3]).ok_or("a sample that is not hex digits")?;
            let raw = if raw >= 2048 { raw - 4096 } else { raw };
            data.push((f64::from(raw) * 100.0 - h.offset[k]) / h.gain[k]);
        }
        let light = hex3(&s[9..12]).ok_or("a sample that is not hex digits")? >> 2;
        lux.push(f64::from(light) * h.lux_per_volt);
    }
    Ok(GoodBlock {
        index,
        sequence,
        start_s,
        rate_hz,
        temp_c,
        battery_v: get("Battery voltage").and_then(number).unwrap_or(f64::NAN),
        light: lux.first().copied().unwrap_or(f64::NAN),
        data,
        light_per_sample: Some(lux),
    })
}

#[cfg(test)]
mod tests {
    use super::tests_support::*;
    use super::*;

    fn page(time: &str, hex: &str) -> String {
        page_at(time, "21.5", hex)
    }

    #[test]
    fn a_page_decodes_calibration_time_and_light() {
        // x = 0x100 = 256 → 256·100/25600 = 1 g; y = 0xfff = −1 → (−100 + 256)/25600;
        // z = 0x800 = −2048 → −8 g; light 0x00c >> 2 = 3 → 3·800/300 lux.
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let text = format!("{HEADER}{}", page("2013-05-30 10:12:54:500", &hex));
        let (pages, reader) = read(text.as_bytes()).unwrap();
        let b = good(&pages).next().unwrap();
        assert_eq!(&b.data[..3], &[1.0, 156.0 / 25600.0, -8.0]);
        assert_eq!(b.light_per_sample.as_ref().unwrap()[0], 8.0);
        assert_eq!(b.start_s, civil_seconds(2013, 5, 30, 10, 12, 54.5));
        assert_eq!(reader.declared_pages(), Some(9));
        assert_eq!(reader.device(), "GENEActiv 1.1");
    }

    #[test]
    fn bad_and_cut_pages_are_skipped() {
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let mut text = format!(
            "{HEADER}{}{}",
            page("2013-05-30 10:12:54:500", &"zz".repeat(6)),
            page("2013-05-30 10:12:58:000", &hex)
        );
        text.push_str("Recorded Data\r\nPage Time:2013-05-30 10:13:02:000\r\n100f");
        let (pages, reader) = read(text.as_bytes()).unwrap();
        assert_eq!(invalid(&pages).len(), 1);
        assert_eq!(good(&pages).count(), 1);
        let notes = reader.notes();
        assert!(notes[0].contains("page #2"), "{notes:?}");
        let e = read(b"Device Identity\r\nx gain:0\r\nx offset:1\r\n")
            .map(drop)
            .unwrap_err();
        assert!(e.to_string().contains("x gain"), "{e}");
    }
}
#[cfg(test)]
mod plausibility {
    use super::tests_support::*;
    use super::*;

    /// Header gains, offsets, rates and page temperatures beyond any device are refused by
    /// name (a header of 1e300 must not turn into samples of 1e-296 g).
    #[test]
    fn impossible_header_and_page_values_are_refused() {
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let page = page_at("2013-05-30 10:12:54:500", "21.5", &hex);
        for (from, to, want) in [
            ("x gain:25600", "x gain:1e300", "x gain 1e300"),
            (
                "y offset:-256",
                "y offset:1e300",
                "y gain 25600 or offset 1e300",
            ),
            (
                "Frequency:50 Hz",
                "Frequency:1e300 Hz",
                "measurement frequency",
            ),
            ("Volts:300", "Volts:-3", "Volts (-3)"),
        ] {
            let text = format!("{}{page}", HEADER.replace(from, to));
            let e = read(text.as_bytes()).map(drop).unwrap_err().to_string();
            assert!(e.contains(want), "{to}: {e}");
        }
        let text = format!(
            "{HEADER}{}",
            page_at("2013-05-30 10:12:54:500", "1e300", &hex)
        );
        let (pages, _) = read(text.as_bytes()).unwrap();
        let why = invalid(&pages)[0];
        assert!(why.contains("temperature 1e300 °C is impossible"), "{why}");
        // A field that is there but not a number is told as what it holds, not as missing.
        for (temp, want) in [
            (
                "nan",
                "its temperature is NaN (the device reported no value)",
            ),
            (
                "NaN",
                "its temperature is NaN (the device reported no value)",
            ),
            ("inf", "its temperature is inf, not a finite number"),
            ("warm", "its temperature 'warm' is not a number"),
            ("", "its 'Temperature' line holds no value"),
        ] {
            let text = format!("{HEADER}{}", page_at("2013-05-30 10:12:54:500", temp, &hex));
            let (pages, _) = read(text.as_bytes()).unwrap();
            assert_eq!(invalid(&pages)[0], want, "{temp}");
        }
        // The real device's values pass.
        let text = format!("{HEADER}{page}");
        assert_eq!(good(&read(text.as_bytes()).unwrap().0).count(), 1);
    }
}

#[cfg(test)]
mod tests_support {
    use super::{Block, GoodBlock, PageReader};
    use std::io::BufRead;

    /// Pages read by the one reader from a file held in memory.
    type Read<'a> = (Vec<Block>, PageReader<Box<dyn BufRead + 'a>>);

    /// Every page of `bytes` in order, and the reader (its header's values and notes).
    pub(super) fn read(bytes: &[u8]) -> crate::error::Result<Read<'_>> {
        let mut reader = PageReader::of_bytes(bytes)?;
        let (mut pages, mut chunk) = (Vec::new(), Vec::new());
        loop {
            let more = reader.next_chunk(&mut chunk)?;
            pages.append(&mut chunk);
            if !more {
                return Ok((pages, reader));
            }
        }
    }

    /// The decoded pages.
    pub(super) fn good(pages: &[Block]) -> impl Iterator<Item = &GoodBlock> {
        pages.iter().filter_map(|b| match b {
            Block::Good(g) => Some(g),
            _ => None,
        })
    }

    /// The reasons of the pages skipped for an impossible field.
    pub(super) fn invalid(pages: &[Block]) -> Vec<&str> {
        pages
            .iter()
            .filter_map(|b| match b {
                Block::Invalid(why) => Some(why.as_str()),
                _ => None,
            })
            .collect()
    }

    pub(super) const HEADER: &str = "Device Identity\r\nDevice Model:1.1  \r\nMeasurement Frequency:50 Hz\r\nx gain:25600\r\nx offset:0\r\ny gain:25600\r\ny offset:-256\r\nz gain:25600\r\nz offset:0\r\nVolts:300\r\nLux:800\r\nNumber of Pages:9\r\n";

    pub(super) fn page_at(time: &str, temp: &str, hex: &str) -> String {
        format!("Recorded Data\r\nSequence Number:0\r\nPage Time:{time}\r\nTemperature:{temp}\r\nMeasurement Frequency:50\r\n{hex}\r\n")
    }
}
