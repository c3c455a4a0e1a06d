//! Reading input files with bounds: only regular files (or `-` for standard input), never
//! more than a cap, so that `/dev/zero`, a FIFO that never ends or a 40 GB file give a clear
//! error instead of filling the memory; gzip decompressed to the same cap; UTF-8 checked (the
//! line and column of the first byte that is not UTF-8 named); lines bounded in length.

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
pub fn free_bytes(file: &std::fs::File) -> Option<u64> {
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
pub fn not_utf8_why(bytes: &[u8], valid_up_to: usize) -> String {
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return "it is UTF-16 text (it starts with a UTF-16 byte-order mark): save it as UTF-8, \
                e.g. `iconv -f UTF-16 -t UTF-8 FILE > FILE.csv`"
            .into();
    }
    not_utf8_after(bytes, valid_up_to, 0)
}

/// [`not_utf8_why`] for `bytes` that follow `lines_before` whole lines of the file (a piece
/// of it: the line is counted in the file).
pub fn not_utf8_after(bytes: &[u8], valid_up_to: usize, lines_before: usize) -> String {
    let before = &bytes[..valid_up_to.min(bytes.len())];
    let line = 1 + lines_before + memchr::memchr_iter(b'\n', before).count();
    let column = 1 + before.len() - memchr::memrchr(b'\n', before).map_or(0, |i| i + 1);
    format!(
        "line {line}, column {column} holds a byte that is not UTF-8 (a binary file, or text in \
         another encoding): save it as UTF-8 text, or give a raw .cwa/.bin recording its own \
         extension"
    )
}

/// Fills `buf` from `r` until it is full or the input ends; the bytes read (fewer only at the
/// end). One `read` may give less than asked — a decompressor a few kB, a pipe what it holds —
/// so the block, piece or head readers loop here rather than take a short read for the end.
pub fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
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
