//! Reading input files with bounds: only regular files (or `-` for standard input), never
//! more than a cap, so that `/dev/zero`, a FIFO that never ends or a 40 GB file give a clear
//! error instead of filling the memory; and reading one numeric field, its errors naming the
//! line and column (shared by every file format's reader).

use crate::error::input::InputError;
use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Largest recording accepted, bytes (256 MiB: about 5 million `t,x,y,z` lines; the largest
/// real recording in the project's data is a few MB).
pub const MAX_RECORDING_BYTES: u64 = 256 << 20;

/// Largest calibration file accepted, bytes (a calibration is under 1 kB of JSON).
pub const MAX_CALIBRATION_BYTES: u64 = 1 << 20;

/// Longest line of a text recording, bytes (a header of a thousand long column names, or a row
/// of a hundred numbers, is a few kB; a 50 MB line is not a recording and must not be split
/// into millions of fields).
pub const MAX_LINE_BYTES: usize = 64 << 10;

/// Refuses a text with a line longer than [`MAX_LINE_BYTES`], naming the line: the readers
/// then need memory in proportion to the file, not to one line's fields.
pub fn check_line_lengths(text: &str) -> Result<()> {
    // A line is too long only where MAX_LINE_BYTES + 1 bytes hold no line end: the scan jumps
    // from the last line end of each such window to the next (`memrchr`, SIMD), a few calls per
    // 64 kB instead of one per line; the line is named only when one is too long.
    let bytes = text.as_bytes();
    let mut start = 0;
    while bytes.len() - start > MAX_LINE_BYTES {
        match memchr::memrchr(b'\n', &bytes[start..=start + MAX_LINE_BYTES]) {
            Some(i) => start += i + 1,
            None => {
                let len = memchr::memchr(b'\n', &bytes[start..]).unwrap_or(bytes.len() - start);
                return Err(InputError::LineTooLong {
                    line: 1 + memchr::memchr_iter(b'\n', &bytes[..start]).count(),
                    bytes: len,
                    max: MAX_LINE_BYTES,
                }
                .into());
            }
        }
    }
    Ok(())
}

/// Refuses the first bytes of a stream that is to be copied whole before it is read (standard
/// input too long to hold, spooled to a temporary file): as text it must be UTF-8 (a character
/// cut by the end of `head` aside), its lines at most [`MAX_LINE_BYTES`], and it must hold a
/// digit somewhere. A binary stream, one endless line, or `yes` is then refused at once, with
/// the sentence its file would get, instead of filling the temporary directory first.
pub fn check_text_head(path: &Path, head: &[u8]) -> Result<()> {
    let head = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    // UTF-8 but for a character cut by the end of `head`.
    let text = match std::str::from_utf8(head) {
        Ok(text) => text,
        Err(e) if e.error_len().is_none() => {
            std::str::from_utf8(&head[..e.valid_up_to()]).unwrap_or_default()
        }
        Err(e) => {
            return Err(InputError::NotUtf8 {
                path: path.into(),
                why: not_utf8_why(head, e.valid_up_to()),
            }
            .into())
        }
    };
    check_line_lengths(text)?;
    if !head.iter().any(u8::is_ascii_digit) {
        return Err(InputError::NoDigits {
            path: path.into(),
            bytes: head.len(),
        }
        .into());
    }
    Ok(())
}

/// Free space a temporary copy leaves on its disk, bytes (standard input spooled, a streamed
/// file's parsed rows): such a copy stops, or is not made, before the disk is full, for the
/// command's own output and for everything else on it.
pub const KEEP_FREE_BYTES: u64 = 1 << 30;

/// Bytes free to an unprivileged user on `file`'s file system (`None` where unknown).
pub(crate) fn free_bytes(file: &std::fs::File) -> Option<u64> {
    #[cfg(unix)]
    {
        let s = rustix::fs::fstatvfs(file).ok()?;
        Some(s.f_bavail.saturating_mul(s.f_frsize))
    }
    #[cfg(not(unix))]
    {
        let _ = file;
        None
    }
}

/// Longest piece of a field quoted back in an error message, characters.
pub const MAX_QUOTED_CHARS: usize = 40;

/// Reads `path` (a regular file, or `-` for standard input) whole, refusing more than
/// `limit` bytes. A gzip file (recognised by its first bytes, whatever its name) is
/// decompressed, its content held to the same limit.
pub fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let read_err = |source| InputError::Read {
        path: path.into(),
        source,
    };
    let mut bytes = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin()
            .lock()
            .take(limit + 1)
            .read_to_end(&mut bytes)
            .map_err(read_err)?;
    } else {
        let meta = std::fs::metadata(path).map_err(read_err)?;
        if !meta.is_file() {
            return Err(Error::NotRegularFile { path: path.into() });
        }
        if meta.len() > limit {
            return Err(too_large(path, limit).into());
        }
        // Room for the whole file up front (`take` hides its size from `read_to_end`, which
        // would otherwise grow the buffer step by step, copying what it has read).
        bytes.reserve_exact(meta.len() as usize + 1);
        std::fs::File::open(path)
            .map_err(read_err)?
            .take(limit + 1)
            .read_to_end(&mut bytes)
            .map_err(read_err)?;
    }
    if bytes.len() as u64 > limit {
        return Err(too_large(path, limit).into());
    }
    decompressed(path, bytes, limit)
}

/// `bytes` read from `path`, decompressed when they are gzip (by their first bytes), the
/// content held to `limit` bytes as [`read_bounded`] holds it.
pub fn decompressed(path: &Path, bytes: Vec<u8>, limit: u64) -> Result<Vec<u8>> {
    if bytes.starts_with(&GZIP_MAGIC) {
        return gunzip(path, &bytes, limit);
    }
    Ok(bytes)
}

/// The first two bytes of a gzip member (RFC 1952).
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Decompresses gzip bytes held in memory (standard input's name in errors), bounded as
/// [`read_bounded`] bounds a file (the fuzz target's entry).
pub fn gunzip_bounded(compressed: &[u8], limit: u64) -> Result<Vec<u8>> {
    gunzip(Path::new("-"), compressed, limit)
}

/// A gzip file's content (every member, as `gzip -d` gives it), refused once it passes
/// `limit` bytes: a small file that inflates without end (a gzip bomb) stops at the limit,
/// like a large plain file.
fn gunzip(path: &Path, compressed: &[u8], limit: u64) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(compressed)
        .take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|cause| InputError::Gzip {
            path: path.into(),
            cause,
        })?;
    if out.len() as u64 > limit {
        return Err(InputError::GzipTooLarge {
            path: path.into(),
            limit_mib: limit.div_ceil(1 << 20),
        }
        .into());
    }
    Ok(out)
}

fn too_large(path: &Path, limit: u64) -> InputError {
    InputError::TooLarge {
        path: path.into(),
        limit_mib: limit.div_ceil(1 << 20),
    }
}

/// Reads `path` as UTF-8 text (a leading byte-order mark removed), bounded as
/// [`read_bounded`].
pub fn read_text(path: &Path, limit: u64) -> Result<String> {
    text_of(path, read_bounded(path, limit)?)
}

/// `bytes` read from `path` as UTF-8 text (a leading byte-order mark removed).
pub fn text_of(path: &Path, mut bytes: Vec<u8>) -> Result<String> {
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        bytes.drain(..3);
    }
    String::from_utf8(bytes).map_err(|e| {
        let why = not_utf8_why(e.as_bytes(), e.utf8_error().valid_up_to());
        InputError::NotUtf8 {
            path: path.into(),
            why,
        }
        .into()
    })
}

/// Why `bytes` is not UTF-8, in words a user can act on: UTF-16 (recognised by its
/// byte-order mark, as spreadsheet programs write "Unicode text") is named with the
/// conversion to make; otherwise the line and column (1-based, bytes) of the first byte that
/// is not UTF-8 are given, since a binary file given a text name fails there too.
pub(crate) fn not_utf8_why(bytes: &[u8], valid_up_to: usize) -> String {
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return "it is UTF-16 text (it starts with a UTF-16 byte-order mark): save it as UTF-8, \
                e.g. `iconv -f UTF-16 -t UTF-8 FILE > FILE.csv`"
            .into();
    }
    not_utf8_after(bytes, valid_up_to, 0)
}

/// [`not_utf8_why`] for `bytes` that follow `lines_before` whole lines of the file (a piece
/// of it: the line is counted in the file).
pub(crate) fn not_utf8_after(bytes: &[u8], valid_up_to: usize, lines_before: usize) -> String {
    let before = &bytes[..valid_up_to.min(bytes.len())];
    let line = 1 + lines_before + memchr::memchr_iter(b'\n', before).count();
    let column = 1 + before.len() - memchr::memrchr(b'\n', before).map_or(0, |i| i + 1);
    format!(
        "line {line}, column {column} holds a byte that is not UTF-8 (a binary file, or text in \
         another encoding): save it as UTF-8 text, or give a raw .cwa/.bin recording its own \
         extension"
    )
}

/// `text` as quoted in an error message: at most [`MAX_QUOTED_CHARS`] characters, control
/// characters escaped, with the full length said when it was cut (a 10 MB bad field must not
/// be echoed whole).
pub fn quote(text: &str) -> String {
    quote_at_most(text, MAX_QUOTED_CHARS)
}

/// A header line as quoted in an error message (longer than a field, still bounded).
pub fn quote_header(text: &str) -> String {
    quote_at_most(text, 5 * MAX_QUOTED_CHARS)
}

fn quote_at_most(text: &str, max: usize) -> String {
    let count = text.chars().count();
    let shown: String = text
        .chars()
        .take(max)
        .flat_map(char::escape_debug)
        .collect();
    if count > max {
        format!("{shown}… ({count} characters)")
    } else {
        shown
    }
}

/// A decimal number as Rust's `str::parse::<f64>` reads it (correctly rounded; `inf`, `nan`
/// accepted here and refused as not finite by the caller), by `fast-float2`. Whitespace or
/// anything after the number is refused.
pub(crate) fn parse_f64(s: &[u8]) -> Option<f64> {
    fast_float2::parse::<f64, _>(s).ok()
}

/// Parses one field. Callers hand over fields already free of surrounding blanks (split on
/// ASCII whitespace, or trimmed by the CSV reader). With `decimal_comma` one `,` is the
/// decimal separator. Quoted text in errors is cut to a readable length.
pub(crate) fn parse_number(s: &str, line_no: usize, col: &str, decimal_comma: bool) -> Result<f64> {
    let parsed = if decimal_comma && s.contains(',') {
        if s.matches(',').count() == 1 && !s.contains('.') {
            parse_f64(s.replacen(',', ".", 1).as_bytes()).ok_or(())
        } else {
            Err(())
        }
    } else {
        parse_f64(s.as_bytes()).ok_or(())
    };
    let v = parsed.map_err(|_| InputError::NotANumber {
        line: line_no,
        column: quote(col),
        text: quote(s),
    })?;
    if v.is_infinite() && written_as_digits(s) {
        return Err(InputError::BeyondDouble {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    if !v.is_finite() {
        return Err(InputError::NotFinite {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    Ok(v)
}

/// True when `s` spells a number with digits (as `1e309` does), not `inf`/`Infinity`/`NaN`:
/// such a field that reads as infinite overflowed a double.
fn written_as_digits(s: &str) -> bool {
    s.bytes().any(|b| b.is_ascii_digit())
        && !s
            .bytes()
            .any(|b| b.is_ascii_alphabetic() && !matches!(b, b'e' | b'E'))
}

/// Largest magnitude a sensor reading may have. No sensor in any unit reports 10¹² (a 32-bit
/// counter is 4·10⁹); values beyond are a corrupt cell, and squares of them (10²⁴, summed over
/// windows) would lose every digit of the noise the detector measures.
pub(crate) const MAX_READING: f64 = 1e12;

/// The largest reading of a recording must reach this (any unit: 1 nano-g, 1 count): below it
/// every reading is numerically zero next to rounding and no pose can be told from another.
pub(crate) const MIN_FULL_SCALE: f64 = 1e-9;

/// Highest sample rate a recording or `--rate-hz` may state (1 MHz; inertial sensors stop at
/// a few kHz).
pub const MAX_RATE_HZ: f64 = 1e6;

/// Lowest sample rate a recording or `--rate-hz` may state (one sample per 1000 s: below it
/// no inertial recording exists, and the averaging times and windows it implies are absurd).
pub const MIN_RATE_HZ: f64 = 1e-3;

/// A sensor reading (axis or temperature): a finite number of magnitude at most
/// [`MAX_READING`], else an error naming the line and column.
pub(crate) fn parse_reading(
    s: &str,
    line_no: usize,
    col: &str,
    decimal_comma: bool,
) -> Result<f64> {
    let v = parse_number(s, line_no, col, decimal_comma)?;
    if v.abs() > MAX_READING {
        return Err(InputError::ReadingOutOfRange {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    Ok(v)
}

/// Refuses a recording whose readings are all numerically zero (largest |value| below
/// [`MIN_FULL_SCALE`]): a unit error (e.g. a scale applied twice), not a sensor.
pub(crate) fn check_reading_scale(xyz: &[[f64; 3]]) -> Result<()> {
    // The first reading of full scale ends the scan (in a recording, the first row); the
    // largest is looked for only to be named.
    if xyz.is_empty() || xyz.iter().flatten().any(|v| v.abs() >= MIN_FULL_SCALE) {
        return Ok(());
    }
    let largest = xyz.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    check_largest_reading(true, largest)
}

/// Fills `buf` from `r` until it is full or the input ends; the bytes read (fewer only at the
/// end). One `read` may give less than asked — a decompressor a few kB, a pipe what it holds —
/// so the block, piece or head readers loop here rather than take a short read for the end.
pub(crate) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// [`check_reading_scale`] given its fold: `any` sample, the `largest` |value|.
pub(crate) fn check_largest_reading(any: bool, largest: f64) -> Result<()> {
    if any && largest < MIN_FULL_SCALE {
        return Err(InputError::ReadingsTooSmall { largest }.into());
    }
    Ok(())
}

/// The most samples a command that holds its whole recording (`magfit`, `tempcal`, `gyrofit`,
/// `six-position`, `correct` of a raw file) loads: 2²² (11.6 h at 100 Hz), about 170 MB as
/// held (40 B a sample: time, x, y, z, temperature) and at most twice that while read.
/// Why: a 2.5 MB `.gz` holding 1 GB of rows, or a 300 MB `.cwa`, took 1–3.8 GB in those
/// commands; the commands that read in passes (`fit`, `analyze`, `correct` of text, `noise`)
/// have no such bound.
pub const MAX_HELD_SAMPLES: usize = 1 << 22;

/// The bound `front_door::load_held` reads within, and the sentence's parts.
#[derive(Debug, Clone, Copy)]
pub struct HoldLimit {
    /// At most this many samples.
    pub samples: usize,
    /// The command holding them (`magfit`).
    pub command: &'static str,
    /// What reads such a file instead (the end of the sentence).
    pub instead: &'static str,
}

impl HoldLimit {
    /// [`MAX_HELD_SAMPLES`] for `command`.
    pub fn of(command: &'static str, instead: &'static str) -> Self {
        Self {
            samples: MAX_HELD_SAMPLES,
            command,
            instead,
        }
    }

    /// The refusal when `n` samples are more than the bound.
    pub(crate) fn check(&self, n: usize) -> std::result::Result<(), InputError> {
        if n > self.samples {
            Err(InputError::TooManyToHold {
                limit: self.samples,
                command: self.command,
                instead: self.instead,
            })
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gz(bytes: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn gzip_files_are_read_as_their_content_and_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let text = b"t,x,y,z\n0,1,2,3\n0.01,1,2,3\n";
        let p = dir.path().join("rec.csv.gz");
        std::fs::write(&p, gz(text)).unwrap();
        assert_eq!(read_bounded(&p, 1 << 20).unwrap(), text);
        // The same content under any name: recognised by its first bytes.
        let q = dir.path().join("rec.csv");
        std::fs::write(&q, gz(text)).unwrap();
        assert_eq!(read_text(&q, 1 << 20).unwrap().as_bytes(), text);
        // Two members (cat a.gz b.gz) are both read, as gzip -d does.
        let mut two = gz(b"a\n");
        two.extend(gz(b"b\n"));
        std::fs::write(&p, two).unwrap();
        assert_eq!(read_bounded(&p, 1 << 20).unwrap(), b"a\nb\n");
        // A bomb: 64 MiB of zeros in a few kB stops at the limit with its own sentence.
        let bomb = gz(&vec![0u8; 64 << 20]);
        assert!(bomb.len() < 1 << 20);
        std::fs::write(&p, &bomb).unwrap();
        let e = read_bounded(&p, 8 << 20).unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::GzipTooLarge { limit_mib: 8, .. })
            ),
            "{e:?}"
        );
        assert!(
            e.to_string().contains("decompresses to more than 8 MiB"),
            "{e}"
        );
        // Cut short: an error naming the file, not a panic.
        let cut = gz(text);
        std::fs::write(&p, &cut[..cut.len() - 6]).unwrap();
        let e = read_bounded(&p, 1 << 20).unwrap_err();
        assert!(e.to_string().starts_with("cannot decompress"), "{e}");
    }

    #[test]
    fn parse_f64_reads_as_str_parse_does() {
        let cases = [
            "0",
            "-0",
            "509",
            "24.68",
            "-0.80836403369903564",
            "0.1",
            "1.",
            ".5",
            "-.5",
            "+3.25",
            "123456789012345",
            "1234567890123456",
            "9007199254740993",
            "0.000000000000001",
            "99999.9999999999",
            "1e3",
            "inf",
            "NaN",
            "-",
            ".",
            "1.2.3",
            "",
            "1,5",
            " 1",
        ];
        for c in cases {
            let want = c.parse::<f64>().ok();
            let got = parse_f64(c.as_bytes());
            assert_eq!(
                got.map(f64::to_bits),
                want.map(f64::to_bits),
                "{c:?}: {got:?} vs {want:?}"
            );
        }
        // A sweep of short decimals, bit for bit.
        for i in (-200_000i64..200_000).step_by(7) {
            for d in 0..6 {
                let c = format!("{}.{:0d$}", i / 1000, (i % 1000).unsigned_abs(), d = d);
                let want = c.parse::<f64>().ok().map(f64::to_bits);
                assert_eq!(parse_f64(c.as_bytes()).map(f64::to_bits), want, "{c}");
            }
        }
    }

    /// The windowed scan names the line a line-by-line count names: the first line over the
    /// limit, its length, at every position and length around the limit.
    #[test]
    fn line_lengths_are_checked_as_line_by_line() {
        let by_lines = |text: &str| {
            let mut lines = text.split('\n').enumerate();
            lines
                .find(|(_, line)| line.len() > MAX_LINE_BYTES)
                .map(|(k, line)| (k + 1, line.len()))
        };
        let m = MAX_LINE_BYTES;
        for short in [0, 1, 35, m - 1, m] {
            for long in [m - 1, m, m + 1, m + 2, 3 * m] {
                for ending in ["", "\n", "\r\n"] {
                    let row = format!("{}\n", "1".repeat(short));
                    let text = format!("{}{}{ending}{}", row.repeat(3), "2".repeat(long), row);
                    let got = match check_line_lengths(&text) {
                        Ok(()) => None,
                        Err(Error::Input(InputError::LineTooLong { line, bytes, .. })) => {
                            Some((line, bytes))
                        }
                        Err(e) => panic!("{e}"),
                    };
                    assert_eq!(got, by_lines(&text), "{short} {long} {ending:?}");
                }
            }
        }
        assert!(check_line_lengths("").is_ok());
        assert!(check_line_lengths(&"3".repeat(m)).is_ok());
        assert!(check_line_lengths(&"3".repeat(m + 1)).is_err());
    }

    #[test]
    fn quote_cuts_long_fields_and_escapes_controls() {
        assert_eq!(quote("abc"), "abc");
        assert_eq!(quote("a\tb"), "a\\tb");
        let long = "9".repeat(10_000_000);
        let q = quote(&long);
        assert!(q.len() < 80, "{q}");
        assert!(q.ends_with("… (10000000 characters)"), "{q}");
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_directories_are_refused() {
        for p in ["/dev/zero", "/dev/null", "/"] {
            let e = read_bounded(Path::new(p), 1 << 20).unwrap_err();
            assert!(matches!(e, Error::NotRegularFile { .. }), "{p}: {e}");
        }
    }

    #[test]
    fn size_cap_and_bom() {
        let guard = tempfile::tempdir().unwrap();
        let dir = guard.path();
        let p = dir.join("big.txt");
        std::fs::write(&p, vec![b'1'; 2000]).unwrap();
        let e = read_bounded(&p, 1000).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{} is larger than 1 MiB, the limit for this kind of file",
                p.display()
            )
        );
        assert_eq!(read_bounded(&p, 2000).unwrap().len(), 2000);
        std::fs::write(&p, b"\xEF\xBB\xBF1 2 3\n").unwrap();
        assert_eq!(read_text(&p, 100).unwrap(), "1 2 3\n");
        std::fs::write(&p, b"t,x\n1 \xFF 3\n").unwrap();
        let e = read_text(&p, 100).unwrap_err();
        assert!(matches!(e, crate::Error::Input(InputError::NotUtf8 { .. })));
        assert!(
            e.to_string().contains("line 2, column 3 holds a byte"),
            "{e}"
        );
        std::fs::write(&p, b"\xFF\xFEt\0,\0x\0").unwrap();
        let e = read_text(&p, 100).unwrap_err().to_string();
        assert!(
            e.contains("it is UTF-16 text") && e.contains("save it as UTF-8"),
            "{e}"
        );
    }
}
