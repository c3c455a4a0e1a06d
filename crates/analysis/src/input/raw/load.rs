//! Every raw file (`.cwa` or `.bin`) is read by this one path, a chunk of blocks at a time:
//! what `fit`, `analyze` and `batch` need of a raw file is its still 10-s epochs
//! ([`crate::input::raw::epochs`]), what `read` needs is every sample once, and a week of wear
//! is hundreds of MB of blocks and tens of millions of samples. A file read whole (standard
//! input, a gzip file: [`RawFile`]) is the one-chunk case of the same code ([`Blocks::Held`]),
//! so a held file and one read from disk give the same recording and table by construction.
//!
//! Two passes over the blocks, one chunk in memory at a time ([`BlockReader`],
//! [`geneactiv::PageReader`]; each chunk decoded on all cores), both in [`samples`]: the first
//! ([`samples::plan`]) checks every block and keeps, per kept block, only its index and time
//! span (32 bytes for a block of up to 300 samples) and the counts of skipped blocks; the
//! second reads the blocks again (a held file's are decoded already) into a sink: the
//! recording's arrays, allocated once at their final length, or the epoch search
//! ([`EpochScan`]) sample by sample.

use super::cwa::BlockReader;
use super::epochs::{table_of, EpochOptions, EpochScan};
use super::geneactiv::{self, PageReader};
use super::{explain_too_few, samples, Block, RawFile, RawFormat};
use crate::error::Result;
use crate::input::bounded::HoldLimit;
use crate::input::columns::LoadOptions;
use crate::input::recording::Recording;
use crate::input::table::WindowTable;
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
    // No extension given: bytes of neither format are `None`, not an error.
    super::detect(&head[..got], Path::new("")).ok().flatten()
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
    pub(super) fn open(self) -> Result<Reader<'a>> {
        match self {
            Self::File(path, format) => Reader::open(path, format),
            Self::Held(raw) => Ok(Reader::Held(raw)),
        }
    }

    pub(super) fn format(self) -> RawFormat {
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

/// The still-epoch table of a raw file (errors without the file's name: the caller adds it):
/// the plan's kept samples fed one by one to the epoch search.
pub fn raw_epoch_table(
    blocks: Blocks<'_>,
    opts: &LoadOptions,
    epochs: &EpochOptions,
) -> Result<WindowTable> {
    let plan = samples::plan(blocks, opts)?;
    // The times' summary regenerated from the spans (no per-block steps held: memory is the
    // plan and one chunk of blocks).
    let meta = plan.meta(None, None);
    // The plan keeps a block at least (else it is the no-data error).
    let (first, last) = (plan.kept[0].span, plan.kept[plan.kept.len() - 1].span);
    let rate = meta.rate_hz.unwrap_or(100.0);
    let mut found = EpochScan::new(first.time(0), rate, epochs);
    let nch = plan.channels.len();
    plan.pass(|mine| {
        for (g, k) in mine {
            for (i, t) in k.span.times().enumerate() {
                let row = &g.data[i * nch..(i + 1) * nch];
                found.push(t, plan.cols.map(|c| row[c]), g.temp_c);
            }
        }
    })?;
    let found = found.finish(last.time(last.n - 1), rate);
    let source = super::source_of(&meta.info);
    let like = Recording {
        temp: Some(Vec::new()),
        axis_columns: meta.columns,
        notes: meta.notes,
        info: vec![meta.info],
        ..Recording::default()
    };
    table_of(found, like, &source, epochs).map_err(|e| {
        let (tally, header_hz) = (&plan.tally, plan.header_rate_hz);
        explain_too_few(
            e,
            blocks.format(),
            tally,
            plan.left_out,
            meta.rate_hz,
            header_hz,
        )
    })
}

/// Every sample of a raw file, with the samples' times taken from the blocks' own timestamps
/// (no resampling, [`TimePlan`](super::TimePlan)), the block temperature per sample, and the
/// triplet chosen by `opts`: the f64 case of the array sink ([`samples::RawPlan::fill`]), its
/// vectors allocated once at their final length (no size cap: memory is the recording itself
/// and one chunk of blocks).
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
    let plan = samples::plan(blocks, opts)?;
    let n = plan.rows();
    if let Some(l) = limit {
        l.check(n)?;
    }
    let (mut xyz, mut t, mut temp) = (vec![[0.0; 3]; n], vec![0.0; n], vec![0.0; n]);
    let meta = plan.fill(xyz.as_flattened_mut(), &mut temp, Some(&mut t))?;
    Ok(Recording {
        xyz,
        t: Some(t),
        temp: Some(temp),
        axis_columns: meta.columns,
        notes: meta.notes,
        info: vec![meta.info],
        ..Recording::default()
    })
}
