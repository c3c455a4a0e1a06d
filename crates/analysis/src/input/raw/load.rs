//! Every raw file (`.cwa` or `.bin`) is read by this one path, a chunk of blocks at a time: what
//! `fit`, `analyze` and `batch` need of a raw file is its still 10-s epochs
//! ([`crate::input::raw::epochs`]), what `read` needs is every sample once, and a week of wear is
//! hundreds of MB of blocks and tens of millions of samples. A file held in memory (standard
//! input, a gzip file's content: [`Blocks::Bytes`]) is read by the same readers a chunk at a
//! time, so a held file and one read from disk give the same recording and table by
//! construction.
//!
//! Two passes over the blocks, one chunk in memory at a time
//! ([`BlockReader`](super::cwa::BlockReader), [`PageReader`](super::geneactiv::PageReader); each
//! chunk decoded on all cores), both in [`samples`]: the first ([`samples::plan`]) checks every
//! block and keeps, per kept block, only its index and time span (32 bytes for a block of up to 300
//! samples) and the counts of skipped blocks; the second reads the blocks again into a sink: the recording's arrays, allocated once at their final length, or
//! the epoch search ([`EpochScan`]) sample by sample.

pub use super::blocks::Blocks;
use super::epochs::{table_of, EpochOptions, EpochScan};
use super::{explain_too_few, samples, RawFormat};
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
