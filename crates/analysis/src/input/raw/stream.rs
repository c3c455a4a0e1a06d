//! A raw `.cwa` file's still epochs read block by block, never whole: what `fit`, `analyze` and
//! `batch` need of a raw file is its still 10-s epochs ([`crate::input::raw::epochs`]), and a
//! week of wear is hundreds of MB of blocks and tens of millions of samples.
//!
//! Two passes over the file, one chunk of blocks in memory at a time
//! ([`cwa::BlockReader`]): the first decodes every block and keeps, per decoded block, only
//! its time span ([`BlockSpan`], 24 bytes for a block of up to 120 samples) and the counts of
//! skipped blocks ([`Tally`]); the times' statistics (median step, gaps: the rate and the
//! notes) are then computed from the spans by regenerating the times; the second pass decodes
//! the blocks again and feeds each sample to the epoch search ([`EpochScan`]). Every number is
//! computed as the whole-file path computes it (same functions, same order), so the table is
//! the one [`crate::input::raw::to_recording`] + [`epoch_table`](crate::input::raw::epochs::epoch_table)
//! give, bit for bit.

use super::cwa::{self, BlockReader};
use super::epochs::{table_of, EpochOptions, EpochScan};
use super::{
    choose_channels, describe, explain_too_few, no_data, skip_notes, Block, BlockSpan, RawFormat,
    Tally, TimePlan,
};
use crate::error::Result;
use crate::input::columns::LoadOptions;
use crate::input::recording::Recording;
use crate::input::table::WindowTable;
use crate::input::timecheck::{time_notes_given, TimeSteps};
use std::path::Path;

/// True when `path` is a regular file starting with a `.cwa` header block's magic (`MD`,
/// length 1020): such a file is read block by block. Standard input, gzip and anything else
/// are read whole by the other readers.
pub fn is_cwa_file(path: &Path) -> bool {
    use std::io::Read;
    if path.as_os_str() == "-" || !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return false;
    }
    let mut head = [0u8; 4];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| &head[..2] == b"MD" && u16::from_le_bytes([head[2], head[3]]) == 1020)
}

/// What the first pass learnt.
struct Scan {
    header: cwa::Header,
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
}

/// First pass: every block decoded and counted, the decoded blocks' spans kept.
fn scan(path: &Path) -> Result<Scan> {
    let mut reader = BlockReader::open(path)?;
    let mut tally = Tally::default();
    let mut plan = TimePlan::default();
    let mut spans = Vec::new();
    let mut chunk = Vec::new();
    loop {
        let more = reader.next_chunk(&mut chunk)?;
        // The channel count is the first good block's, as the whole-file reader's.
        let nch = reader.channels().len();
        for b in &chunk {
            tally.push(b, nch);
            if let Block::Good(g) = b {
                spans.extend(plan.push(g.index, g.start_s, g.rate_hz, g.len(nch)));
            }
        }
        if !more {
            break;
        }
    }
    spans.extend(plan.finish());
    Ok(Scan {
        header: reader.header,
        channels: reader.channels(),
        tally,
        notes: reader.notes(),
        spans,
    })
}

/// The still-epoch table of the `.cwa` file at `path` ([`is_cwa_file`]), read block by block;
/// errors as the whole-file path's (without the file's name: the caller adds it).
pub fn cwa_epoch_table(
    path: &Path,
    opts: &LoadOptions,
    epochs: &EpochOptions,
) -> Result<WindowTable> {
    let scan = scan(path)?;
    let cols = choose_channels(&scan.channels, opts)?;
    let left_out = scan.spans.iter().filter(|s| s.is_none()).count();
    let (Some(t0), Some(t_end)) = (scan.times().next(), scan.spans.iter().flatten().last()) else {
        return Err(no_data(&scan.tally, left_out).into());
    };
    let t_end = t_end.time(t_end.n - 1);
    let mut notes = skip_notes(RawFormat::Cwa, &scan.notes, &scan.tally, left_out);
    let steps = TimeSteps::of_times(|| scan.times());
    notes.extend(time_notes_given("time", steps, || scan.times()));
    let info = describe(
        RawFormat::Cwa,
        scan.header.device,
        scan.tally.blocks,
        scan.header.rate_hz,
        &scan.channels,
    );
    let measured = steps.map(|s| s.rate_hz());
    let rate = measured.unwrap_or(100.0);
    let found = feed(path, &scan, cols, EpochScan::new(t0, rate, epochs))?.finish(t_end, rate);
    let source = super::source_of(&info);
    let like = Recording {
        temp: Some(Vec::new()),
        axis_columns: cols.map(|c| scan.channels[c].clone()),
        notes,
        info: vec![info],
        ..Recording::default()
    };
    table_of(found, like, &source, epochs).map_err(|e| {
        let (tally, header_hz) = (&scan.tally, scan.header.rate_hz);
        explain_too_few(e, RawFormat::Cwa, tally, left_out, measured, header_hz)
    })
}

/// Second pass: every kept sample's chosen channels, time and block temperature into `epochs`.
fn feed(path: &Path, scan: &Scan, cols: [usize; 3], mut epochs: EpochScan) -> Result<EpochScan> {
    let mut reader = BlockReader::open(path)?;
    let nch = scan.channels.len();
    let mut spans = scan.spans.iter();
    let mut chunk = Vec::new();
    loop {
        let more = reader.next_chunk(&mut chunk)?;
        for b in &chunk {
            let Block::Good(g) = b else { continue };
            let Some(Some(span)) = spans.next() else {
                continue;
            };
            for (i, t) in span.times().enumerate() {
                let row = &g.data[i * nch..(i + 1) * nch];
                epochs.push(t, cols.map(|c| row[c]), g.temp_c);
            }
        }
        if !more {
            break;
        }
    }
    Ok(epochs)
}
