//! A regular delimited text file (of any size) read in line-aligned pieces of [`PIECE_BYTES`], never
//! held whole: memory is the rows read (and one piece), not the text beside them, and the
//! size cap for files read whole ([`crate::input::bounded::MAX_RECORDING_BYTES`]) does not
//! apply; the limits are per piece and per line ([`crate::input::bounded::MAX_LINE_BYTES`]).
//!
//! A text held whole is the one piece of the same loop (`Pieces::held`, no copy): plain
//! text of every size is read by one head (`read_head`), one loop over the pieces
//! (`parse_pieces`) and one row parser (`text_rows`: in parallel chunks, the time check joined
//! to the piece before), so a file reads the same values and sentences whatever its size.
//! A streamed file's pass (`text_source`) is that loop too: only where the rows go differs
//! (here one set of columns, there a summary and the rows kept for the later passes).
//!
//! Only text the fast splitter reads is read this way: a file with a quote, a lone carriage return,
//! a `#` or `%` comment, a byte that is not UTF-8, a line over the limit, no header in its
//! first piece (or a GRT or header-less whitespace file) is handed back
//! and read whole as before, so every such file keeps its sentence. A bad row is reported
//! once the rest of the file has been checked for those (which the whole-text path would
//! report first).

use crate::error::{Error, Result};
use crate::input::bounded::HoldLimit;
use crate::input::bounded::{check_line_lengths, MAX_LINE_BYTES};
use crate::input::columns::LoadOptions;
use crate::input::recording::Recording;
use crate::input::text_csv::{
    blank_comments, check_axis_columns, csv_reader, is_comment_or_blank, CsvState, Delimiter,
};
use crate::input::text_rows::{Columns, RowLayout};
use std::io::Read;
use std::path::Path;

/// Bytes read per piece (plus the unfinished line carried over from the piece before): the
/// parse splits a piece again into chunks for every core.
pub const PIECE_BYTES: usize = 16 << 20;

/// The file's pieces, each ending at a line end (the last at the end of the file). A gzip
/// file (by its magic) gives its content's pieces, decompressed as they are read (every
/// member, as `gzip -d` gives it).
///
/// A thread of its own reads the next piece, decompresses it, and checks it for the fast
/// splitter ([`plain_piece`]) while the one handed out last is parsed: those steps run one
/// piece at a time, and on the thread that parses they left the other cores idle for about a
/// sixth of a read. Two pieces are held at once (the one handed out, the next), their buffers
/// used again from piece to piece.
pub(crate) struct Pieces<'a> {
    cuts: std::sync::mpsc::Receiver<Cut>,
    spent: std::sync::mpsc::Sender<Vec<u8>>,
    /// The piece handed out last.
    current: Text<'a>,
    /// A held text's one piece, until it is handed out ([`Pieces::held`]).
    held: Option<&'a str>,
    /// How the pieces ended, once they have (every later call says it again).
    ended: Option<std::result::Result<(), ()>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

/// A piece as the reading thread hands it over: its `#`/`%` comment lines blanked (as
/// [`crate::input::text::parse`] blanks them), checked for the fast splitter, as text when it
/// passed ([`plain_piece`], which for text holds the UTF-8 check too), as UTF-8 text that did
/// not (its first piece may still be read when the quotes are in its head:
/// [`Pieces::data_after_bom`]), else as bytes.
/// A held text's one piece ([`Pieces::held`]) is plain text borrowed, never copied.
enum Text<'a> {
    Plain(std::borrow::Cow<'a, str>),
    Utf8(String),
    Bytes(Vec<u8>),
}

impl Text<'_> {
    fn bytes(&self) -> &[u8] {
        match self {
            Text::Plain(s) => s.as_bytes(),
            Text::Utf8(s) => s.as_bytes(),
            Text::Bytes(b) => b,
        }
    }

    /// The piece's buffer, to be used again (`None` for a held text's, which is borrowed).
    fn into_buffer(self) -> Option<Vec<u8>> {
        match self {
            Text::Plain(std::borrow::Cow::Owned(s)) | Text::Utf8(s) => Some(s.into_bytes()),
            Text::Plain(std::borrow::Cow::Borrowed(_)) => None,
            Text::Bytes(b) => Some(b),
        }
    }
}

/// What the reading thread sends: the next piece, the end, or a line too long to carry.
type Cut = std::result::Result<Option<Text<'static>>, ()>;

/// The reading half of [`Pieces`]: the file cut into pieces at line ends.
struct Cutter {
    file: Box<dyn Read + Send>,
    /// The start of the next piece (the unfinished line of the one before).
    carry: Vec<u8>,
    eof: bool,
    piece_bytes: usize,
}

impl Cutter {
    /// The next piece, in `buf` (a spent piece's buffer, or a new one).
    fn next(&mut self, mut buf: Vec<u8>) -> std::result::Result<Option<Vec<u8>>, ()> {
        buf.clear();
        buf.append(&mut self.carry);
        // A piece is at least `piece_bytes` and holds a whole line: a line of up to
        // MAX_LINE_BYTES longer than the piece is carried whole.
        let most = self.piece_bytes + MAX_LINE_BYTES + 1;
        while !self.eof
            && (buf.len() < self.piece_bytes
                || (buf.len() <= most && memchr::memrchr(b'\n', &buf).is_none()))
        {
            // Read into the buffer's spare room (no zeroing of it first).
            let room = self.piece_bytes.min(most);
            buf.reserve(room);
            let mut next = (&mut self.file).take(room as u64);
            let n = next.read_to_end(&mut buf).map_err(|_| ())?;
            self.eof = n < room;
        }
        if buf.is_empty() {
            return Ok(None);
        }
        let end = if self.eof {
            buf.len()
        } else {
            memchr::memrchr(b'\n', &buf).ok_or(())? + 1
        };
        self.carry.extend_from_slice(&buf[end..]);
        buf.truncate(end);
        Ok(Some(buf))
    }

    /// Cuts pieces and sends them to `cuts`, each checked, until the end, an error, or no one
    /// takes them; a buffer from `spent` when there is one.
    fn run(
        mut self,
        cuts: std::sync::mpsc::SyncSender<Cut>,
        spent: std::sync::mpsc::Receiver<Vec<u8>>,
    ) {
        loop {
            let buf = spent.try_recv().unwrap_or_default();
            let cut = self.next(buf).map(|piece| piece.map(checked));
            let last = !matches!(cut, Ok(Some(_)));
            if cuts.send(cut).is_err() || last {
                return;
            }
        }
    }
}

/// A piece as [`Text`]: its comment lines blanked (a piece holds whole lines, so they are
/// the whole text's comment lines), then plain text when [`plain_piece`] passes it (its UTF-8
/// check made once, by the conversion to a `String`).
fn checked(piece: Vec<u8>) -> Text<'static> {
    match String::from_utf8(piece) {
        Ok(text) => {
            let text = match blank_comments(&text) {
                std::borrow::Cow::Borrowed(_) => text,
                std::borrow::Cow::Owned(blanked) => blanked,
            };
            if is_plain(&text) {
                Text::Plain(text.into())
            } else {
                Text::Utf8(text)
            }
        }
        Err(e) => Text::Bytes(e.into_bytes()),
    }
}

impl Pieces<'static> {
    pub(crate) fn open(path: &Path, piece_bytes: usize) -> Result<Self> {
        use std::io::BufRead;
        let read_err = |source| {
            Error::from(crate::error::input::InputError::Read {
                path: path.into(),
                source,
            })
        };
        // Reads of a whole piece bypass the buffer: it only lets the magic be seen.
        let mut file = std::io::BufReader::new(std::fs::File::open(path).map_err(read_err)?);
        let gzip = file
            .fill_buf()
            .map_err(read_err)?
            .starts_with(&[0x1f, 0x8b]);
        let file: Box<dyn Read + Send> = if gzip {
            Box::new(flate2::read::MultiGzDecoder::new(file))
        } else {
            Box::new(file)
        };
        Self::reading(file, piece_bytes).map_err(read_err)
    }

    /// The pieces of what `file` gives, cut on a thread of its own (an error when the system
    /// cannot start it).
    pub(crate) fn reading(file: Box<dyn Read + Send>, piece_bytes: usize) -> std::io::Result<Self> {
        let cutter = Cutter {
            file,
            carry: Vec::new(),
            eof: false,
            piece_bytes,
        };
        // Rendezvous: the next piece is cut while the last is parsed, no further ahead.
        let (to_pieces, cuts) = std::sync::mpsc::sync_channel(0);
        let (spent, spent_rx) = std::sync::mpsc::channel();
        let reader = std::thread::Builder::new()
            .name("wiical-pieces".into())
            .spawn(move || cutter.run(to_pieces, spent_rx))?;
        Ok(Self {
            cuts,
            spent,
            current: Text::Bytes(Vec::new()),
            held: None,
            ended: None,
            reader: Some(reader),
        })
    }
}

impl<'a> Pieces<'a> {
    /// Text held whole as the one piece of itself (no thread, no copy): a held text is read
    /// by the same head and piece loop as a file in pieces. `text` must be plain text with
    /// its comment lines blanked ([`crate::input::text_csv::plain_csv`]).
    pub(crate) fn held(text: &'a str) -> Self {
        // The end of the pieces is said once the one piece has been handed out.
        let (to_pieces, cuts) = std::sync::mpsc::sync_channel(1);
        let _ = to_pieces.send(Ok(None));
        Self {
            cuts,
            spent: std::sync::mpsc::channel().0,
            current: Text::Bytes(Vec::new()),
            held: Some(text),
            ended: None,
            reader: None,
        }
    }

    /// The piece handed out last (empty before the first).
    pub(crate) fn current(&self) -> &[u8] {
        self.current.bytes()
    }

    /// The piece handed out last as text the fast splitter reads ([`plain_piece`] of it,
    /// checked when it was read), else `None`.
    pub(crate) fn plain(&self) -> Option<&str> {
        match &self.current {
            Text::Plain(text) => Some(&**text),
            Text::Utf8(_) | Text::Bytes(_) => None,
        }
    }

    /// The piece handed out last as UTF-8 text after a byte-order mark (its comment lines
    /// blanked), plain or not; `None` when it is not UTF-8.
    pub(crate) fn text_after_bom(&self) -> Option<&str> {
        match &self.current {
            Text::Utf8(text) => Some(text.strip_prefix('\u{feff}').unwrap_or(text)),
            Text::Plain(_) | Text::Bytes(_) => self.plain_after_bom(),
        }
    }

    /// The first piece's data rows, from `offset` in [`Pieces::text_after_bom`], when they are
    /// plain text ([`plain_piece`]): a piece whose quotes (or other marks) are all in its head
    /// — a quoted header, `"t","x","y","z"` — still has its rows read by the fast splitter,
    /// which reads them as the `csv` reader does.
    pub(crate) fn data_after_bom(&self, offset: usize) -> Option<&str> {
        match &self.current {
            Text::Plain(_) => self.plain_after_bom()?.get(offset..),
            Text::Utf8(_) => self.text_after_bom()?.get(offset..).filter(|d| is_plain(d)),
            Text::Bytes(_) => self.plain_after_bom()?.get(offset..),
        }
    }

    /// [`Pieces::plain`] of the piece handed out last after a UTF-8 byte-order mark (the first
    /// piece's text): the reader's check stands for it when the piece passed it (without its
    /// first three bytes it still does), else the piece after the mark is checked here.
    pub(crate) fn plain_after_bom(&self) -> Option<&str> {
        match self.plain() {
            Some(text) => Some(text.strip_prefix('\u{feff}').unwrap_or(text)),
            None => {
                let piece = self.current();
                plain_piece(piece.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(piece))
            }
        }
    }

    /// Whether every piece left is plain text ([`Pieces::plain`]), read to the end.
    pub(crate) fn rest_is_plain(&mut self) -> bool {
        loop {
            match self.next_piece().map(|p| p.is_some()) {
                Ok(true) if self.plain().is_some() => {}
                Ok(false) => return true,
                _ => return false,
            }
        }
    }

    /// The next piece (`None` at the end), or `Err(())` when a line is longer than the limit
    /// allows a piece to carry (the whole-text path names it). I/O errors end the pieces too:
    /// the whole-text path reads the file again and names the error.
    pub(crate) fn next_piece(&mut self) -> std::result::Result<Option<&[u8]>, ()> {
        if let Some(end) = self.ended {
            return end.map(|()| None);
        }
        let spent = std::mem::replace(&mut self.current, Text::Bytes(Vec::new()));
        if let Some(text) = self.held.take() {
            self.current = Text::Plain(text.into());
            return Ok(Some(self.current.bytes()));
        }
        // The reader may have ended: the buffer is then dropped here.
        if let Some(buffer) = spent.into_buffer() {
            let _ = self.spent.send(buffer);
        }
        match self.cuts.recv() {
            Ok(Ok(Some(text))) => {
                self.current = text;
                Ok(Some(self.current.bytes()))
            }
            // A line too long or an error reading: never taken for the end of the file (the
            // caller reads it whole).
            Ok(Err(())) => {
                self.ended = Some(Err(()));
                Err(())
            }
            // A reader that stopped without saying: it panicked, a bug raised here as the
            // caller's own panic (not a reason to read the file another way, which would
            // hide it).
            Err(_) => {
                self.ended = Some(Err(()));
                self.raise_reader_panic();
                Err(())
            }
            Ok(Ok(None)) => {
                self.ended = Some(Ok(()));
                Ok(None)
            }
        }
    }
}

impl Pieces<'_> {
    /// Waits for the reading thread and raises its panic, if it panicked, on this thread.
    fn raise_reader_panic(&mut self) {
        if let Some(Err(panic)) = self.reader.take().map(std::thread::JoinHandle::join) {
            std::panic::resume_unwind(panic);
        }
    }
}

impl Drop for Pieces<'_> {
    /// Stops the reading thread (it ends when its piece finds no taker) and waits for it, so
    /// that no file is left open behind a finished read. A panic of the thread not seen yet is
    /// raised here (unless this thread is already unwinding): a bug never passes unseen.
    fn drop(&mut self) {
        let (_, dead) = std::sync::mpsc::sync_channel(0);
        drop(std::mem::replace(&mut self.cuts, dead));
        if std::thread::panicking() {
            if let Some(reader) = self.reader.take() {
                // Already unwinding: a second panic would abort; the first one is reported.
                let _ = reader.join();
            }
        } else {
            self.raise_reader_panic();
        }
    }
}

/// The piece as text the fast splitter reads as the `csv` reader does, with no comment line
/// and no line over the limit; `None` for anything else.
fn plain_piece(piece: &[u8]) -> Option<&str> {
    std::str::from_utf8(piece)
        .ok()
        .filter(|text| is_plain(text))
}

/// Whether `text` is what the fast splitter reads as the `csv` reader does: no quote, no `#`
/// or `%` comment mark, no lone carriage return, no line over the limit ([`plain_piece`]
/// without its UTF-8 check).
fn is_plain(text: &str) -> bool {
    let piece = text.as_bytes();
    let marked = memchr::memchr3(b'"', b'#', b'%', piece).is_some();
    let lone_cr = memchr::memchr_iter(b'\r', piece).any(|i| piece.get(i + 1) != Some(&b'\n'));
    !marked && !lone_cr && check_line_lengths(text).is_ok()
}

/// Reads the regular text file `path` in pieces of [`PIECE_BYTES`] as
/// [`crate::input::text::parse`] reads its whole text; `head_ok` is asked about the first
/// piece's text (cut at a line end) before any row is read (a window-mean table is read
/// whole). `Ok(None)`: the file is to be read whole (see the module docs). Errors carry no
/// file name (the caller adds it). Refused as soon as the rows read pass `limit` (checked after each piece, so at most one
/// piece's rows beyond it are ever held).
pub fn load_pieces_within(
    path: &Path,
    opts: &LoadOptions,
    head_ok: impl Fn(&str) -> bool,
    limit: Option<HoldLimit>,
) -> Result<Option<Recording>> {
    read_pieces(path, opts, PIECE_BYTES, head_ok, limit)
}

/// [`load_pieces_within`] with pieces of `piece_bytes`: `Ok(None)` to read the file whole. The
/// pieces' rows are parsed onto one set of columns (no copy), `limit` checked after each.
pub(crate) fn read_pieces(
    path: &Path,
    opts: &LoadOptions,
    piece_bytes: usize,
    head_ok: impl Fn(&str) -> bool,
    limit: Option<HoldLimit>,
) -> Result<Option<Recording>> {
    let Ok(mut pieces) = Pieces::open(path, piece_bytes) else {
        return Ok(None);
    };
    hold(&mut pieces, opts, head_ok, limit)
}

/// The recording of `pieces` (a file's, or a held text's one piece), the rows parsed onto one
/// set of columns (no copy), `limit` checked after each piece: `Ok(None)` when the text is to
/// be read whole (see the module docs).
pub(crate) fn hold(
    pieces: &mut Pieces<'_>,
    opts: &LoadOptions,
    head_ok: impl Fn(&str) -> bool,
    limit: Option<HoldLimit>,
) -> Result<Option<Recording>> {
    let head = match read_head(pieces, opts, head_ok) {
        Ok(Some(head)) => head,
        Ok(None) => return Ok(None),
        Err(e) => return row_error(pieces, e),
    };
    let mut cols = Columns::default();
    let mut over = None;
    let read = parse_pieces(pieces, &head, |text, line, _| {
        let newlines = (head.layout).read_plain_onto(&mut cols, text, line, head.delim.byte())?;
        match limit.map(|l| l.check(cols.xyz.len())) {
            Some(Err(e)) => over = Some(e),
            _ => return Ok(Some(newlines)),
        }
        Ok(None)
    });
    match read {
        Ok(true) => {}
        Ok(false) => return Ok(None),
        Err(e) => return row_error(pieces, e),
    }
    if let Some(e) = over {
        return Err(e.into());
    }
    let rec = head.st.finish(Some(cols)).and_then(|rec| {
        check_axis_columns(&rec)?;
        crate::input::bounded::check_reading_scale(&rec.xyz)?;
        Ok(rec)
    });
    rec.map(Some)
}

/// The head of a file read in pieces, from its first piece: the reader's state after the
/// header (its metadata, its choices), the rows' layout and delimiter, and where the data
/// rows start.
pub(crate) struct Head<'o> {
    pub st: CsvState<'o>,
    pub layout: RowLayout,
    pub delim: Delimiter,
    /// Byte offset of the first data row in the first piece (its byte-order mark removed).
    pub data_offset: usize,
    /// Line number of the first data row's line.
    pub data_line: usize,
}

/// The header read from the first piece ([`first_piece_head`], [`read_piece_head`]);
/// `Ok(None)` hands the file back to be read whole (no header in the first piece, marks the
/// fast splitter does not read past its head, …).
pub(crate) fn read_head<'o>(
    pieces: &mut Pieces<'_>,
    opts: &'o LoadOptions,
    head_ok: impl Fn(&str) -> bool,
) -> Result<Option<Head<'o>>> {
    let Some((head, delim, plain)) = first_piece_head(pieces, head_ok) else {
        return Ok(None);
    };
    let mut st = CsvState::new(opts, delim);
    let Some((offset, header_line)) = read_piece_head(&mut st, head, delim, plain)? else {
        return Ok(None);
    };
    let Some(layout) = st.layout.clone() else {
        return Ok(None); // no header in the first piece: the whole-text path says what is wrong
    };
    if pieces.data_after_bom(offset).is_none() {
        return Ok(None); // marks past the head: read whole
    }
    Ok(Some(Head {
        st,
        layout,
        delim,
        data_offset: offset,
        data_line: header_line + 1,
    }))
}

/// The one loop over a file's pieces, whatever keeps their rows (a held recording's columns,
/// a streamed file's summary and spill): `parse` is given each piece's data text in order
/// (the first piece's after its head) with its first line number and the bytes of the file
/// read up to its end, and returns the piece's line ends, or `None` to stop. `Ok(false)`
/// when a piece is not plain text (the file is to be read whole); a row's error is `parse`'s.
pub(crate) fn parse_pieces(
    pieces: &mut Pieces<'_>,
    head: &Head<'_>,
    mut parse: impl FnMut(&str, usize, u64) -> Result<Option<usize>>,
) -> Result<bool> {
    let mut line = head.data_line;
    let mut done = pieces.current().len() as u64;
    // The first piece again, from its data rows (its head was read by `read_head`).
    let mut text = pieces.data_after_bom(head.data_offset);
    loop {
        let Some(piece) = text else {
            return Ok(false);
        };
        match parse(piece, line, done)? {
            Some(newlines) => line += newlines,
            None => return Ok(true),
        }
        text = match pieces.next_piece() {
            Ok(Some(p)) => {
                done += p.len() as u64;
                pieces.plain()
            }
            Ok(None) => return Ok(true),
            Err(()) => None,
        };
    }
}

/// The first piece as text (after a UTF-8 byte-order mark, its comment lines blanked), its
/// delimiter, and whether it is plain text, when it is UTF-8 with a delimited, non-GRT first
/// line that `head_ok` accepts; `None`: the whole-text path reads the file and says what it
/// finds. (A piece that is not plain still has its rows read in pieces when the marks are all
/// in its head: [`read_piece_head`], [`Pieces::data_after_bom`].)
pub(crate) fn first_piece_head<'p>(
    pieces: &'p mut Pieces<'_>,
    head_ok: impl Fn(&str) -> bool,
) -> Option<(&'p str, Delimiter, bool)> {
    pieces.next_piece().ok()??;
    head_of_current(pieces, head_ok)
}

/// [`first_piece_head`] of the piece handed out last.
fn head_of_current<'p>(
    pieces: &'p Pieces<'_>,
    head_ok: impl Fn(&str) -> bool,
) -> Option<(&'p str, Delimiter, bool)> {
    let plain = pieces.plain().is_some();
    let head = (pieces.text_after_bom()).filter(|h| !h.starts_with('\u{feff}'))?;
    let first_line = head.lines().find(|l| !is_comment_or_blank(l))?;
    match Delimiter::of_first_line(first_line) {
        Some(d) if !crate::input::grt::is_grt(first_line) && head_ok(head) => {
            Some((head, d, plain))
        }
        _ => None,
    }
}

/// The first piece's head (metadata lines, then the header) read into `st`: the byte offset
/// of the first data row and the header's line number. A `plain` piece is read by plain
/// splitting, as before; any other by the `csv` reader, as the whole-text path reads a text
/// with quotes (a quoted header `"t","x","y","z"` is read as `t,x,y,z`), its line counted in
/// the text's lines. `Ok(None)` when that reader finds no header or an error (the whole-text
/// path then reads the file and says what it finds).
pub(crate) fn read_piece_head(
    st: &mut CsvState<'_>,
    head: &str,
    delim: Delimiter,
    plain: bool,
) -> Result<Option<(usize, usize)>> {
    if plain {
        return st.read_head(head, delim).map(Some);
    }
    let mut reader = csv_reader(head, delim);
    if st.read_records_head(&mut reader).is_err() || st.layout.is_none() {
        return Ok(None);
    }
    let offset = usize::try_from(reader.position().byte()).unwrap_or(usize::MAX);
    let Some(read) = head.as_bytes().get(..offset) else {
        return Ok(None);
    };
    // The header's own line: the line ends up to the first data row's start.
    Ok(Some((offset, memchr::memchr_iter(b'\n', read).count())))
}

/// Why the text file `path` (larger than the size read whole, `limit_mib`) could not be read
/// in pieces, as an error naming the place: the first byte that is not UTF-8 by its line and
/// column (the sentence a smaller file gets), else the first line with a quote, a lone
/// carriage return or a comment mark inside a row, or a line over the limit for one. `None`
/// when every piece is plain (the pieces declined for another reason: no header in the first
/// piece, a pose column…), or a line is too long for a piece to carry, or the file cannot be
/// read (the caller's error stands).
///
/// One more read of the file, on the way to an error only.
pub(crate) fn why_not_in_pieces(path: &Path, limit_mib: u64) -> Option<Error> {
    why_not_in(path, limit_mib, PIECE_BYTES)
}

/// [`why_not_in_pieces`] with pieces of `piece_bytes`.
fn why_not_in(path: &Path, limit_mib: u64, piece_bytes: usize) -> Option<Error> {
    use crate::error::input::InputError;
    let mut pieces = Pieces::open(path, piece_bytes).ok()?;
    let mut lines_before = 0usize;
    let mut first = true;
    let why = loop {
        match pieces.next_piece() {
            Ok(Some(_)) => {}
            // The end; or a line too long to carry, or a read error: the size sentence
            // stands (the pieces cannot tell which).
            Ok(None) | Err(()) => return None,
        }
        let piece = pieces.current();
        if let Err(e) = std::str::from_utf8(piece) {
            let why = if lines_before == 0 {
                crate::input::bounded::not_utf8_why(piece, e.valid_up_to())
            } else {
                crate::input::bounded::not_utf8_after(piece, e.valid_up_to(), lines_before)
            };
            return Some(
                InputError::NotUtf8 {
                    path: path.into(),
                    why,
                }
                .into(),
            );
        }
        // The first piece's head may hold quotes (a quoted header): its rows are what count.
        let from = if std::mem::take(&mut first) {
            first_data_offset(&pieces)
        } else {
            0
        };
        let piece = pieces.text_after_bom().unwrap_or_default();
        if let Some(why) = piece.get(from..).and_then(|rows| first_mark(rows)) {
            let line = lines_before
                + 1
                + memchr::memchr_iter(b'\n', &piece.as_bytes()[..from + why.0]).count();
            break format!("line {line} {}", why.1);
        }
        lines_before += memchr::memchr_iter(b'\n', pieces.current()).count();
    };
    Some(
        InputError::NotPlainInPieces {
            path: path.into(),
            limit_mib,
            why,
        }
        .into(),
    )
}

/// Where the first piece's data rows start, when its head reads ([`read_piece_head`]); else 0.
fn first_data_offset(pieces: &Pieces<'_>) -> usize {
    let opts = LoadOptions::default();
    let Some((head, delim, plain)) = head_of_current(pieces, |_| true) else {
        return 0;
    };
    let mut st = CsvState::new(&opts, delim);
    match read_piece_head(&mut st, head, delim, plain) {
        Ok(Some((offset, _))) if st.layout.is_some() => offset,
        _ => 0,
    }
}

/// The byte offset in `rows` (whole lines, comments blanked) of the first thing the fast
/// splitter does not read, and what it is with what to do.
fn first_mark(rows: &str) -> Option<(usize, &'static str)> {
    let b = rows.as_bytes();
    let quote = memchr::memchr(b'"', b)
        .map(|i| (i, "holds a quote (\"): write the data rows without quotes"));
    let comment = memchr::memchr2(b'#', b'%', b).map(|i| {
        (
            i,
            "holds '#' or '%' inside a row: a comment must be a line of its own",
        )
    });
    let lone_cr = memchr::memchr_iter(b'\r', b)
        .find(|&i| b.get(i + 1) != Some(&b'\n'))
        .map(|i| {
            (
                i,
                "ends with a lone carriage return (old Mac line ends): convert them to \
                       line feeds, e.g. `tr '\\r' '\\n'`",
            )
        });
    let mut start = 0;
    let long = memchr::memchr_iter(b'\n', b)
        .chain(std::iter::once(b.len()))
        .find_map(|end| {
            let line = (end - start > MAX_LINE_BYTES).then_some(start);
            start = end + 1;
            line
        })
        .map(|i| {
            (
                i,
                "is longer than the limit for a line (a file without line breaks?)",
            )
        });
    [quote, comment, lone_cr, long]
        .into_iter()
        .flatten()
        .min_by_key(|m| m.0)
}

/// `e` (an error in the rows) once the rest of the file is known to be plain text, else
/// `Ok(None)`: the file is read whole, and the whole-text path reports what it finds first.
pub(crate) fn row_error<T>(pieces: &mut Pieces<'_>, e: Error) -> Result<Option<T>> {
    pieces.rest_is_plain().then_some(Err(e)).transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gives `text`, then fails: with an error (`panic: false`) or by panicking.
    struct Failing {
        text: std::io::Cursor<Vec<u8>>,
        panic: bool,
    }

    impl Read for Failing {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            match self.text.read(buf)? {
                0 if self.panic => panic!("a reader that panics"),
                0 => Err(std::io::Error::other("a failing disk")),
                n => Ok(n),
            }
        }
    }

    /// A source that fails after some pieces with an error ends the pieces with `Err(())` —
    /// the file then read whole, which names the error — never as the end of the file (which
    /// would cut the recording short); later calls say it again, and a dropped `Pieces` stops
    /// its thread mid-file.
    #[test]
    fn a_source_that_fails_is_never_the_end_of_the_file() {
        let text: Vec<u8> = (0..2000)
            .flat_map(|i| format!("{i},1,2\n").into_bytes())
            .collect();
        let file = Failing {
            text: std::io::Cursor::new(text.clone()),
            panic: false,
        };
        let mut pieces = Pieces::reading(Box::new(file), 1000).unwrap();
        let mut read = Vec::new();
        let end = loop {
            match pieces.next_piece() {
                Ok(Some(p)) => read.extend_from_slice(p),
                other => break other.map(|p| p.is_some()),
            }
        };
        assert_eq!(end, Err(()));
        assert_eq!(pieces.next_piece(), Err(()));
        assert!(text.starts_with(&read) && read.len() < text.len());
        let endless = std::io::repeat(b'\n');
        let mut pieces = Pieces::reading(Box::new(endless), 1000).unwrap();
        assert!(matches!(pieces.next_piece(), Ok(Some(_))));
        drop(pieces);
    }

    /// The message of a panic caught by `catch_unwind` (`panic!` with a format gives a
    /// `String`, with a literal a `&str`).
    fn message(payload: &(dyn std::any::Any + Send)) -> Option<&str> {
        payload
            .downcast_ref::<&str>()
            .copied()
            .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
    }

    /// A reading thread that panics after some pieces: its panic is raised by `next_piece` on
    /// the caller's thread — a bug, never a reason to read the file another way (which would
    /// hide it) nor the end of the file; later calls then end the pieces with `Err(())`.
    #[test]
    fn a_reader_that_panics_raises_its_panic_to_the_caller() {
        let text: Vec<u8> = (0..2000)
            .flat_map(|i| format!("{i},1,2\n").into_bytes())
            .collect();
        let file = Failing {
            text: std::io::Cursor::new(text.clone()),
            panic: true,
        };
        let mut pieces = Pieces::reading(Box::new(file), 1000).unwrap();
        let mut read = Vec::new();
        let raised = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| loop {
            match pieces.next_piece() {
                Ok(Some(p)) => read.extend_from_slice(p),
                other => break other.map(|p| p.is_some()),
            }
        }));
        let payload = raised.expect_err("the reader's panic is raised, not an end of the pieces");
        assert_eq!(message(payload.as_ref()), Some("a reader that panics"));
        assert!(text.starts_with(&read) && read.len() < text.len());
        assert_eq!(pieces.next_piece(), Err(()));
        // A reader that panics before its first piece was asked for: raised by the drop.
        let file = Failing {
            text: std::io::Cursor::new(Vec::new()),
            panic: true,
        };
        let pieces = Pieces::reading(Box::new(file), 1000).unwrap();
        let raised = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| drop(pieces)));
        let payload = raised.expect_err("the reader's panic is raised by the drop");
        assert_eq!(message(payload.as_ref()), Some("a reader that panics"));
    }

    /// What stopped a file's pieces is named by line: a byte that is not UTF-8 on the last
    /// line with its line and column (as a file read whole gets it), a quote in a row, a
    /// lone carriage return; a quoted header is no reason, and a plain file has none.
    #[test]
    fn what_stops_the_pieces_is_named_by_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.csv");
        // Line 1 the header, line k + 1 the row k: many pieces of 4096 bytes, the lines
        // counted across them.
        let mut rows = String::from("\"t\",\"x\",\"y\",\"z\"\n");
        let row = "0.000000001,123456,234567,345678\n";
        let n = 5000;
        for _ in 0..n {
            rows += row;
        }
        let why = |bytes: &[u8]| {
            std::fs::write(&path, bytes).unwrap();
            why_not_in(&path, 256, 4096).map(|e| e.full_message())
        };
        assert_eq!(why(rows.as_bytes()), None);
        // The last line (n + 2), column 6: a Latin-1 byte.
        let mut bad = rows.clone().into_bytes();
        bad.extend_from_slice(b"0.01,\xe91,2,3\n");
        let got = why(&bad).unwrap();
        let whole = crate::input::bounded::text_of(&path, bad.clone())
            .unwrap_err()
            .to_string();
        assert!(
            whole.contains(&format!("line {}, column 6", n + 2)),
            "{whole}"
        );
        assert_eq!(got, whole);
        let quoted = format!("{rows}\"1\",2,3,4\n");
        let got = why(quoted.as_bytes()).unwrap();
        assert!(
            got.contains(&format!("but line {} holds a quote", n + 2)),
            "{got}"
        );
        let cr = format!("{rows}1,2,3,4\r5,6,7,8\n");
        let got = why(cr.as_bytes()).unwrap();
        assert!(
            got.contains(&format!(
                "but line {} ends with a lone carriage return",
                n + 2
            )),
            "{got}"
        );
    }

    /// A bound on held rows: at the 400 rows the file has, read; one below, refused in the
    /// sentence that names the bound and the command, whatever the piece size.
    #[test]
    fn pieces_beyond_the_hold_limit_are_refused() {
        let mut rows = String::from("t,x,y,z\n");
        for i in 0..400 {
            rows += &format!("{},{},{},{}\n", i as f64 * 0.01, i % 7, i % 5, 1000 + i);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, &rows).unwrap();
        let opts = LoadOptions::default();
        let limit = |samples| HoldLimit {
            samples,
            command: "magfit",
            instead: "cut it shorter",
        };
        for size in [64, 300, 1 << 20] {
            let ok = read_pieces(&path, &opts, size, |_| true, Some(limit(400)));
            assert_eq!(ok.unwrap().unwrap().len(), 400, "pieces of {size}");
            let refused = read_pieces(&path, &opts, size, |_| true, Some(limit(399)));
            assert_eq!(
                refused.unwrap_err().to_string(),
                "it holds more than 399 samples, the most `wiical magfit` keeps in memory; cut it shorter",
                "pieces of {size}"
            );
        }
    }
}
