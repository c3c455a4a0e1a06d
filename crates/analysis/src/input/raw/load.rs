//! Every raw file (`.cwa` or `.bin`) is read by this one path, a chunk of blocks at a time:
//! what `fit`, `analyze` and `batch` need of a raw file is its still 10-s epochs
//! ([`crate::input::raw::epochs`]), what `read` needs is every sample once, and a week of wear
//! is hundreds of MB of blocks and tens of millions of samples. A file read whole (standard
//! input, a gzip file: [`RawFile`]) is the one-chunk case of the same code ([`Blocks::Held`]),
//! so a held file and one read from disk give the same recording and table by construction.
//!
//! Two passes over the blocks, one chunk in memory at a time ([`BlockReader`],
//! [`geneactiv::PageReader`]; each chunk decoded on all cores): the first decodes every block
//! and keeps, per decoded block, only its time span ([`BlockSpan`], 24 bytes for a block of up
//! to 300 samples) and the counts of skipped blocks ([`Tally`]); the times' statistics (median
//! step, gaps: the rate and the notes) are then computed from the spans by regenerating the
//! times; the second pass decodes the blocks again (a held file's are decoded already) and
//! feeds each sample to the epoch search ([`EpochScan`]) or into a recording allocated once at
//! its final length.

use super::cwa::BlockReader;
use super::epochs::{table_of, EpochOptions, EpochScan};
use super::geneactiv::{self, PageReader};
use super::{
    choose_channels, describe, explain_too_few, no_data, skip_notes, Block, BlockSpan, RawFile,
    RawFormat, Tally, TimePlan,
};
use crate::error::Result;
use crate::input::bounded::HoldLimit;
use crate::input::columns::LoadOptions;
use crate::input::recording::Recording;
use crate::input::table::WindowTable;
use crate::input::timecheck::{time_notes_given, TimeSteps};
use std::path::Path;

/// The raw format of the regular file at `path` by its first bytes (`.cwa`: `MD`, length
/// 1020; `.bin`: `Device Identity`): such a file is read block by block. Standard input, gzip
/// and anything else are `None`, read whole by the other readers.
pub fn raw_file_format(path: &Path) -> Option<RawFormat> {
    if path.as_os_str() == "-" || !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut head = [0u8; 15];
    let mut file = std::fs::File::open(path).ok()?;
    let got = crate::input::bounded::read_full(&mut file, &mut head).ok()?;
    let head = &head[..got];
    if head.len() >= 4 && &head[..2] == b"MD" && u16::from_le_bytes([head[2], head[3]]) == 1020 {
        Some(RawFormat::Cwa)
    } else if head == b"Device Identity" {
        Some(RawFormat::GeneActiv)
    } else {
        None
    }
}

/// Where a raw file's blocks come from.
#[derive(Debug, Clone, Copy)]
pub enum Blocks<'a> {
    /// The regular file at this path, in this format ([`raw_file_format`]): read a chunk of
    /// blocks at a time, never whole.
    File(&'a Path, RawFormat),
    /// A file read whole (standard input, a gzip file): its blocks are the one chunk.
    Held(&'a RawFile),
}

impl<'a> Blocks<'a> {
    /// A reader at the first block (each pass opens its own).
    fn open(self) -> Result<Reader<'a>> {
        match self {
            Self::File(path, format) => Reader::open(path, format),
            Self::Held(raw) => Ok(Reader::Held(raw)),
        }
    }

    fn format(self) -> RawFormat {
        match self {
            Self::File(_, format) => format,
            Self::Held(raw) => raw.format,
        }
    }
}

/// A raw file's blocks a chunk at a time, whatever its format (a held file: one chunk).
pub(super) enum Reader<'a> {
    Cwa(BlockReader),
    Bin(Box<PageReader<std::io::BufReader<std::fs::File>>>),
    Held(&'a RawFile),
}

impl Reader<'_> {
    pub(super) fn open(path: &Path, format: RawFormat) -> Result<Self> {
        Ok(match format {
            RawFormat::Cwa => Self::Cwa(BlockReader::open(path)?),
            RawFormat::GeneActiv => Self::Bin(Box::new(PageReader::open(path)?)),
        })
    }

    /// The channel names (a `.cwa` file's are known once its first block is decoded).
    pub(super) fn channels(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.channels(),
            Self::Bin(_) => geneactiv::CHANNELS.iter().map(|s| s.to_string()).collect(),
            Self::Held(raw) => raw.channels.clone(),
        }
    }

    pub(super) fn notes(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.notes(),
            Self::Bin(r) => r.notes(),
            Self::Held(raw) => raw.notes.clone(),
        }
    }

    pub(super) fn device(&self) -> String {
        match self {
            Self::Cwa(r) => r.header.device.to_string(),
            Self::Bin(r) => r.device(),
            Self::Held(raw) => raw.device.clone(),
        }
    }

    pub(super) fn header_rate_hz(&self) -> f64 {
        match self {
            Self::Cwa(r) => r.header.rate_hz,
            Self::Bin(r) => r.header_rate_hz(),
            Self::Held(raw) => raw.header_rate_hz,
        }
    }

    /// Every chunk of blocks in file order through `each`.
    pub(super) fn for_each_chunk(&mut self, mut each: impl FnMut(&Self, &[Block])) -> Result<()> {
        if let Self::Held(raw) = *self {
            each(self, &raw.blocks);
            return Ok(());
        }
        let mut chunk = Vec::new();
        loop {
            let more = match self {
                Self::Cwa(r) => r.next_chunk(&mut chunk)?,
                Self::Bin(r) => r.next_chunk(&mut chunk)?,
                Self::Held(_) => false,
            };
            each(self, &chunk);
            if !more {
                return Ok(());
            }
        }
    }
}

/// What the first pass learnt.
struct Scan {
    format: RawFormat,
    device: String,
    header_rate_hz: f64,
    channels: Vec<String>,
    tally: Tally,
    notes: Vec<String>,
    /// One entry per decoded block, in file order (`None`: left out).
    spans: Vec<Option<BlockSpan>>,
}

impl Scan {
    /// Every sample's time in file order, regenerated from the spans.
    fn times(&self) -> impl Iterator<Item = f64> + '_ {
        self.spans.iter().flatten().flat_map(|s| s.times())
    }

    /// Decoded blocks left out (no sample, a clock step back, or stamped ahead).
    fn left_out(&self) -> usize {
        self.spans.iter().filter(|s| s.is_none()).count()
    }

    /// The reader's sentence on the file ([`describe`]).
    fn describe(&self) -> String {
        describe(
            self.format,
            &self.device,
            self.tally.blocks,
            self.header_rate_hz,
            &self.channels,
        )
    }
}

/// First pass: every block decoded and counted, the decoded blocks' spans kept.
fn scan(blocks: Blocks<'_>) -> Result<Scan> {
    let format = blocks.format();
    let mut reader = blocks.open()?;
    let mut tally = Tally::default();
    let mut plan = TimePlan::default();
    let mut spans = Vec::new();
    reader.for_each_chunk(|reader, chunk| {
        // The channel count is the first good block's, as the whole-file reader's.
        let nch = reader.channels().len();
        for b in chunk {
            tally.push(b, nch);
            if let Block::Good(g) = b {
                spans.extend(plan.push(g.index, g.start_s, g.rate_hz, g.len(nch)));
            }
        }
    })?;
    spans.extend(plan.finish());
    tally.note_ahead(&plan);
    Ok(Scan {
        format,
        device: reader.device(),
        header_rate_hz: reader.header_rate_hz(),
        channels: reader.channels(),
        tally,
        notes: reader.notes(),
        spans,
    })
}

/// The still-epoch table of a raw file (errors without the file's name: the caller adds it).
pub fn raw_epoch_table(
    blocks: Blocks<'_>,
    opts: &LoadOptions,
    epochs: &EpochOptions,
) -> Result<WindowTable> {
    let scan = scan(blocks)?;
    let format = scan.format;
    let cols = choose_channels(&scan.channels, opts)?;
    let left_out = scan.left_out();
    let (Some(t0), Some(t_end)) = (scan.times().next(), scan.spans.iter().flatten().last()) else {
        return Err(no_data(&scan.tally, left_out).into());
    };
    let t_end = t_end.time(t_end.n - 1);
    let mut notes = skip_notes(format, &scan.notes, &scan.tally, left_out);
    let steps = TimeSteps::of_times(|| scan.times());
    notes.extend(time_notes_given("time", steps, || scan.times()));
    let info = scan.describe();
    let measured = steps.map(|s| s.rate_hz());
    let rate = measured.unwrap_or(100.0);
    let mut found = EpochScan::new(t0, rate, epochs);
    feed(blocks, &scan, |t, row, temp| {
        found.push(t, cols.map(|c| row[c]), temp)
    })?;
    let found = found.finish(t_end, rate);
    let source = super::source_of(&info);
    let like = Recording {
        temp: Some(Vec::new()),
        axis_columns: cols.map(|c| scan.channels[c].clone()),
        notes,
        info: vec![info],
        ..Recording::default()
    };
    table_of(found, like, &source, epochs).map_err(|e| {
        let (tally, header_hz) = (&scan.tally, scan.header_rate_hz);
        explain_too_few(e, format, tally, left_out, measured, header_hz)
    })
}

/// Every sample of a raw file, with the samples' times taken from the blocks' own timestamps
/// (no resampling, [`TimePlan`]), the block temperature per sample, and the triplet chosen by
/// `opts`: its vectors allocated once at their final length (no size cap: memory is the
/// recording itself and one chunk of blocks).
pub fn load_raw(blocks: Blocks<'_>, opts: &LoadOptions) -> Result<Recording> {
    load_raw_within(blocks, opts, None)
}

/// [`load_raw`] refused when the first pass counts more samples than `limit` (before the
/// arrays are allocated: the memory is never taken).
pub fn load_raw_within(
    blocks: Blocks<'_>,
    opts: &LoadOptions,
    limit: Option<HoldLimit>,
) -> Result<Recording> {
    let scan = scan(blocks)?;
    let cols = choose_channels(&scan.channels, opts)?;
    let left_out = scan.left_out();
    let n: usize = scan.spans.iter().flatten().map(|s| s.n as usize).sum();
    if n == 0 {
        return Err(no_data(&scan.tally, left_out).into());
    }
    if let Some(l) = limit {
        l.check(n)?;
    }
    let mut rec = Recording {
        xyz: Vec::with_capacity(n),
        ..Recording::default()
    };
    let (mut t, mut temp) = (Vec::with_capacity(n), Vec::with_capacity(n));
    feed(blocks, &scan, |ti, row, tc| {
        rec.xyz.push(cols.map(|c| row[c]));
        t.push(ti);
        temp.push(tc);
    })?;
    rec.axis_columns = cols.map(|c| scan.channels[c].clone());
    rec.notes = skip_notes(scan.format, &scan.notes, &scan.tally, left_out);
    rec.notes
        .extend(crate::input::timecheck::time_notes("time", &t));
    rec.info.push(scan.describe());
    rec.t = Some(t);
    rec.temp = Some(temp);
    Ok(rec)
}

/// Second pass: every kept sample's time, values (all channels) and block temperature into
/// `each`, in file order.
fn feed(blocks: Blocks<'_>, scan: &Scan, mut each: impl FnMut(f64, &[f64], f64)) -> Result<()> {
    let mut reader = blocks.open()?;
    let nch = scan.channels.len();
    let mut spans = scan.spans.iter();
    reader.for_each_chunk(|_, chunk| {
        for b in chunk {
            let Block::Good(g) = b else { continue };
            let Some(Some(span)) = spans.next() else {
                continue;
            };
            for (i, t) in span.times().enumerate() {
                each(t, &g.data[i * nch..(i + 1) * nch], g.temp_c);
            }
        }
    })
}
