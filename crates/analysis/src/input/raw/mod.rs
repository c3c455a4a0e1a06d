//! Raw accelerometer files of population studies: Axivity `.cwa` (AX3, AX6) and GENEActiv
//! `.bin`, read from their published format descriptions (OpenMovement's `cwa.h` /
//! AX3 technical documentation; Activinsights' "Decoding .bin files").
//!
//! A raw file is a sequence of data blocks (pages) in file order, each either decoded
//! ([`GoodBlock`]: start time, temperature, samples in g and °/s) or skipped with the reason
//! counted (a failed checksum, an impossible field). [`load`] reads them a chunk at a time
//! ([`Reader`], from the file on disk or from its bytes held in memory: [`Blocks`]) into the
//! [`Recording`](crate::Recording) every command analyses, with the samples' times taken from
//! the blocks' own timestamps (no resampling), the block temperature per sample, and the
//! accelerometer or gyroscope triplet chosen by the load options, or into its still epochs'
//! table. [`ggir`] reproduces GGIRread's resampling onto a regular grid (the values GGIRread's
//! tests assert), [`epochs`] finds GGIR's still 10-s epochs for the free-living
//! autocalibration.
//!
//! Times are the device clock's date and time counted in seconds since 1970-01-01 **as if it
//! were UTC**: neither format stores the time zone of its clock, so none is applied.

use crate::error::input::InputError;
use crate::error::{Error, Result};
use crate::input::columns::LoadOptions;
use std::path::Path;

pub(crate) mod block;
pub(crate) mod blocks;
pub mod cwa;
pub mod epochs;
pub mod geneactiv;
pub mod ggir;
pub mod load;
pub mod samples;

pub use block::{Block, GoodBlock, RawFormat};
pub use blocks::{Blocks, Raw, Reader};

/// The raw format `bytes` are in, by their first bytes (Axivity: `MD` and the header length
/// 1020; GENEActiv: `Device Identity`); `Ok(None)` for anything else, unless the file's
/// extension (`.cwa`, `.bin`) promises a raw format its bytes do not have: then the error
/// says so instead of a text parser's confusion.
pub fn detect(bytes: &[u8], path: &Path) -> Result<Option<RawFormat>> {
    if bytes.len() >= 4 && &bytes[..2] == b"MD" && u16::from_le_bytes([bytes[2], bytes[3]]) == 1020
    {
        return Ok(Some(RawFormat::Cwa));
    }
    if bytes.starts_with(b"Device Identity") {
        return Ok(Some(RawFormat::GeneActiv));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("cwa") => Err(InputError::RawHeader {
            format: "Axivity .cwa",
            why: "it does not start with the 'MD' header block of 1024 bytes".into(),
        }
        .into()),
        Some("bin") => Err(InputError::RawHeader {
            format: "GENEActiv .bin",
            why: "it does not start with 'Device Identity' (other .bin formats are not read)"
                .into(),
        }
        .into()),
        _ => Ok(None),
    }
}

/// The file as a table's description names it ("an Axivity AX3 .cwa file"), from the
/// sentence the reader describes the file with ("read as …: …").
pub fn source_of(info: &str) -> String {
    info.strip_prefix("read as ")
        .and_then(|s| s.split(':').next())
        .unwrap_or("the raw file")
        .to_string()
}

/// Blocks listed by index in a note or an error before "…".
const LISTED_BLOCKS: usize = 8;

/// What a file's blocks were, counted as they are read (a file read block by block keeps
/// these counts, not its blocks): the notes and the no-data error come from it.
#[derive(Debug, Clone, Default)]
pub struct Tally {
    /// Data blocks (pages) in the file.
    pub blocks: usize,
    /// Blocks that failed their checksum.
    pub corrupt: usize,
    /// The first `LISTED_BLOCKS` of them.
    pub corrupt_first: Vec<usize>,
    /// Blocks skipped for an impossible field.
    pub invalid: usize,
    /// The first `LISTED_BLOCKS` of them.
    pub invalid_first: Vec<usize>,
    /// The first such block's reason.
    pub first_invalid_why: Option<String>,
    /// Decoded blocks holding no sample.
    pub empty: usize,
    /// The first `LISTED_BLOCKS` of them.
    pub empty_first: Vec<usize>,
    /// Decoded blocks left out for standing far ahead of the blocks around them
    /// ([`TimePlan`]: a clock that jumps ahead for one block and back).
    pub ahead: usize,
    /// The first `LISTED_BLOCKS` of them.
    pub ahead_first: Vec<Ahead>,
}

impl Tally {
    /// Counts block `b`, the next in file order, of a file whose samples have `channels` values.
    pub fn push(&mut self, b: &Block, channels: usize) {
        match b {
            Block::Good(g) => self.push_good(g.len(channels)),
            Block::Corrupt => {
                let index = self.blocks;
                self.blocks += 1;
                self.corrupt += 1;
                list_first(&mut self.corrupt_first, index);
            }
            Block::Invalid(why) => self.push_invalid(why),
        }
    }

    /// Counts the next block, decoded with `samples` samples.
    pub fn push_good(&mut self, samples: usize) {
        let index = self.blocks;
        self.blocks += 1;
        if samples == 0 {
            self.empty += 1;
            list_first(&mut self.empty_first, index);
        }
    }

    /// Counts the next block, skipped for an impossible field (`why`).
    pub fn push_invalid(&mut self, why: &str) {
        let index = self.blocks;
        self.blocks += 1;
        self.invalid += 1;
        list_first(&mut self.invalid_first, index);
        self.first_invalid_why
            .get_or_insert_with(|| why.to_string());
    }

    /// Takes the blocks `plan` left out for standing ahead of their neighbours (once the plan
    /// has seen every block).
    pub fn note_ahead(&mut self, plan: &TimePlan) {
        self.ahead = plan.ahead;
        self.ahead_first = plan.ahead_first.clone();
    }

    /// Decoded blocks left out (`left_out`, as the time plan counts them) whose clock steps
    /// back: those neither empty nor stamped ahead.
    fn stepped_back(&self, left_out: usize) -> usize {
        left_out.saturating_sub(self.empty + self.ahead)
    }

    /// "#30 at 2027-06-01 10:00:00 (365 days ahead)", … for the blocks stamped ahead.
    fn ahead_list(&self) -> String {
        let shown = self.ahead_first.iter().map(|a| {
            let at = block::civil_text(a.start_s);
            format!("#{} at {at} ({} ahead)", a.index, span_text(a.by_s))
        });
        listed(shown, self.ahead)
    }
}

/// The first blocks of `count` listed, ", …" after them when there are more.
fn listed(shown: impl Iterator<Item = String>, count: usize) -> String {
    let more = if count > LISTED_BLOCKS { ", …" } else { "" };
    format!("{}{more}", shown.collect::<Vec<_>>().join(", "))
}

/// `block` listed in `first` while it holds fewer than `LISTED_BLOCKS`.
fn list_first<T>(first: &mut Vec<T>, block: T) {
    if first.len() < LISTED_BLOCKS {
        first.push(block);
    }
}

/// A time difference in the unit a reader takes in at once (s, min, h, days).
fn span_text(s: f64) -> String {
    match s {
        s if s >= 2.0 * 86_400.0 => format!("{:.0} days", s / 86_400.0),
        s if s >= 2.0 * 3600.0 => format!("{:.0} h", s / 3600.0),
        s if s >= 120.0 => format!("{:.0} min", s / 60.0),
        s => format!("{s:.1} s"),
    }
}

/// The error for a file without one sample to analyse, naming every reason blocks were
/// skipped or left out (`left_out`: decoded blocks whose time steps back or that hold no
/// sample).
pub(crate) fn no_data(tally: &Tally, left_out: usize) -> InputError {
    let mut why = Vec::new();
    if tally.corrupt > 0 {
        why.push(format!("{} fail their checksum", tally.corrupt));
    }
    if let (Some(i), Some(reason)) = (tally.invalid_first.first(), &tally.first_invalid_why) {
        if tally.corrupt == 0 {
            why.push(format!("block #{i}: {reason}"));
        } else {
            why.push(format!(
                "{} have an impossible field (block #{i}: {reason})",
                tally.invalid
            ));
        }
    }
    if tally.empty > 0 {
        why.push(format!("{} hold 0 samples", tally.empty));
    }
    if tally.ahead > 0 {
        why.push(format!(
            "{} stamped far ahead of the blocks around them: {}",
            tally.ahead,
            tally.ahead_list()
        ));
    }
    let stepped_back = tally.stepped_back(left_out);
    if stepped_back > 0 {
        why.push(format!(
            "{stepped_back} start before the previous block's last sample (the clock steps back)"
        ));
    }
    if why.is_empty() {
        why.push("the file ends before its first data block".to_string());
    }
    InputError::RawNoData {
        blocks: tally.blocks,
        skipped: tally.corrupt + tally.invalid,
        why: why.join("; "),
    }
}

/// `e` with its cause said when it is too few still epochs and the file, not its length, is
/// why: half or more of its blocks skipped or left out, or timestamps that do not hold the
/// declared rate (more than 10 % off). `measured_hz` is the rate of the samples' times.
pub(crate) fn explain_too_few(
    e: Error,
    format: RawFormat,
    tally: &Tally,
    left_out: usize,
    measured_hz: Option<f64>,
    header_hz: f64,
) -> Error {
    let Error::Input(InputError::TooFewStillEpochs {
        found,
        examined,
        needed,
        span_s,
        cause,
    }) = e
    else {
        return e;
    };
    let unit = format.unit();
    let stepped_back = tally.stepped_back(left_out);
    let lost = tally.corrupt + tally.invalid + stepped_back + tally.ahead;
    let cause = if lost > 0 && 2 * lost >= tally.blocks {
        let mut parts = Vec::new();
        for (k, what) in [
            (tally.corrupt, "fail their checksum"),
            (tally.invalid, "have an impossible field"),
            (
                tally.ahead,
                "are stamped far ahead of the blocks around them",
            ),
            (
                stepped_back,
                "start before the previous one ends (the clock steps back)",
            ),
        ] {
            if k > 0 {
                parts.push(format!("{k} {what}"));
            }
        }
        format!(
            "{lost} of its {} {unit}s could not be used ({}): the file is damaged, not too short",
            tally.blocks,
            parts.join(", ")
        )
    } else if let Some(m) = measured_hz.filter(|m| (m / header_hz - 1.0).abs() > 0.1) {
        format!(
            "the samples' timestamps give {:.3} Hz where the header declares {header_hz} Hz: the device did not hold its declared rate",
            m
        )
    } else {
        cause
    };
    InputError::TooFewStillEpochs {
        found,
        examined,
        needed,
        span_s,
        cause,
    }
    .into()
}

/// Which three channels the options ask for among the channel names `channels`: `--columns`
/// names, else the wanted sensor's triplet (the accelerometer by default).
pub(crate) fn choose_channels(channels: &[String], opts: &LoadOptions) -> Result<[usize; 3]> {
    let have = channels.join(",");
    if let Some(cols) = &opts.columns {
        let mut out = [0usize; 3];
        for (k, c) in cols.iter().enumerate() {
            let c = c.to_ascii_lowercase();
            out[k] =
                channels
                    .iter()
                    .position(|n| *n == c)
                    .ok_or_else(|| InputError::RawNoChannel {
                        have: have.clone(),
                        wanted: format!("channel '{c}'"),
                    })?;
        }
        return Ok(out);
    }
    let want = opts
        .sensor
        .unwrap_or(crate::input::columns::Sensor::Accelerometer);
    crate::input::columns::find_triplet(channels, want)
        .filter(|t| t.sensor == want)
        .map(|t| t.columns)
        .ok_or_else(|| InputError::RawNoChannel {
            have,
            wanted: format!("the {}", want.name()),
        })
        .map_err(Error::from)
}

/// The sample times of one decoded block: `n` samples spread evenly over `dur` seconds from
/// `start_s` (see [`TimePlan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockSpan {
    /// Time of the first sample, s.
    pub start_s: f64,
    /// Time the block's samples cover, s.
    pub dur: f64,
    /// Samples.
    pub n: u32,
}

impl BlockSpan {
    /// Time of sample `i`, s.
    pub fn time(&self, i: u32) -> f64 {
        self.start_s + f64::from(i) * self.dur / f64::from(self.n)
    }

    /// Every sample's time in order.
    pub fn times(self) -> impl Iterator<Item = f64> {
        (0..self.n).map(move |i| self.time(i))
    }
}

/// What [`TimePlan`] needs of a decoded block.
#[derive(Debug, Clone, Copy)]
struct Pending {
    index: usize,
    start_s: f64,
    rate_hz: f64,
    n: usize,
}

/// A decoded block left out for standing ahead of the blocks around it ([`TimePlan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ahead {
    /// Its index among the file's data blocks.
    pub index: usize,
    /// Its start, device-clock seconds.
    pub start_s: f64,
    /// How far it starts after the block that follows it, s.
    pub by_s: f64,
}

/// The sample times of the decoded blocks, one block at a time: a block's span is known once
/// the next decoded block is (its start ends the block), so each push returns the previous
/// block's span. A block is left out (`None`) when it holds no sample, when its start is not
/// after the previous block's last sample (a clock step back), or when it starts a block's
/// length or more after the next block, which resumes after the blocks before it (one block
/// stamped ahead). A block's samples are spread evenly from its start to the next block's
/// start when the next block follows it in the file and starts within half to twice the
/// nominal block duration later (the devices' own clocks set the rate, as GGIRread and
/// OpenMovement's converters do); otherwise (last block, a gap of skipped blocks, a time jump)
/// at the block's nominal rate.
#[derive(Debug, Clone)]
pub struct TimePlan {
    pending: Option<Pending>,
    last_t: f64,
    /// Blocks left out for standing ahead of their neighbours.
    pub ahead: usize,
    /// The first `LISTED_BLOCKS` of them.
    pub ahead_first: Vec<Ahead>,
}

impl Default for TimePlan {
    fn default() -> Self {
        Self {
            pending: None,
            last_t: f64::NEG_INFINITY,
            ahead: 0,
            ahead_first: Vec::new(),
        }
    }
}

impl TimePlan {
    /// The next decoded block (its index in the file, start time, rate and sample count);
    /// `Some(span)` for the previous decoded block (`Some(None)`: it is left out).
    pub fn push(
        &mut self,
        index: usize,
        start_s: f64,
        rate_hz: f64,
        n: usize,
    ) -> Option<Option<BlockSpan>> {
        let next = Pending {
            index,
            start_s,
            rate_hz,
            n,
        };
        let prev = self.pending.replace(next)?;
        Some(self.close(prev, Some(next)))
    }

    /// Whether the block last pushed will be kept when its span is closed: it holds samples
    /// and starts after the last kept sample, which every block before it has already fixed
    /// (only its duration waits for the next block), unless the next block shows it stamped
    /// ahead ([`TimePlan::ahead`] then grows at the next push). Lets a one-pass reader place
    /// its samples before its span is known (and take them back in that one case).
    pub(crate) fn keeps_pending(&self) -> bool {
        self.pending
            .is_some_and(|p| p.n > 0 && p.start_s > self.last_t)
    }

    /// The last decoded block's span, once the file ends.
    pub fn finish(&mut self) -> Option<Option<BlockSpan>> {
        let prev = self.pending.take()?;
        Some(self.close(prev, None))
    }

    fn close(&mut self, b: Pending, next: Option<Pending>) -> Option<BlockSpan> {
        if b.n == 0 || b.start_s <= self.last_t {
            return None;
        }
        let nominal = b.n as f64 / b.rate_hz;
        // One block whose clock jumps ahead while the next one resumes after the blocks before
        // it: the one block is wrong, not the rest. Kept, it would put every later block
        // before its own last sample (left out as stepping back: a whole recording lost to
        // one bad stamp).
        if let Some(nx) = next
            .filter(|nx| nx.n > 0 && nx.start_s > self.last_t && b.start_s - nx.start_s >= nominal)
        {
            self.ahead += 1;
            let by_s = b.start_s - nx.start_s;
            let (index, start_s) = (b.index, b.start_s);
            list_first(
                &mut self.ahead_first,
                Ahead {
                    index,
                    start_s,
                    by_s,
                },
            );
            return None;
        }
        let dur = match next {
            Some(next) if next.index == b.index + 1 => {
                let d = next.start_s - b.start_s;
                if d > 0.5 * nominal && d < 2.0 * nominal {
                    d
                } else {
                    nominal
                }
            }
            _ => nominal,
        };
        let span = BlockSpan {
            start_s: b.start_s,
            dur,
            n: b.n as u32,
        };
        self.last_t = span.time(span.n - 1);
        Some(span)
    }
}

/// Warnings on skipped blocks: counted, the first few named. `out_of_order`: decoded blocks
/// left out, empty ones included (the tally tells them apart).
pub(crate) fn skip_notes(
    format: RawFormat,
    reader_notes: &[String],
    tally: &Tally,
    out_of_order: usize,
) -> Vec<String> {
    let mut notes = reader_notes.to_vec();
    let unit = format.unit();
    let list = |idx: &[usize], count: usize| listed(idx.iter().map(|i| format!("#{i}")), count);
    if tally.corrupt > 0 {
        notes.push(format!(
            "skipped {} corrupt {unit}(s) of {} (checksum failed): {}",
            tally.corrupt,
            tally.blocks,
            list(&tally.corrupt_first, tally.corrupt)
        ));
    }
    if let Some(why) = &tally.first_invalid_why {
        notes.push(format!(
            "skipped {} unreadable {unit}(s) of {}: {} (the first: {why})",
            tally.invalid,
            tally.blocks,
            list(&tally.invalid_first, tally.invalid)
        ));
    }
    // Blocks left out for holding no sample are said so: counted with the clock's steps back
    // they were told as a time that steps back, which sends the reader to the wrong fault.
    if tally.empty > 0 {
        notes.push(format!(
            "left out {} empty {unit}(s) (0 samples, a valid checksum): {}",
            tally.empty,
            list(&tally.empty_first, tally.empty)
        ));
    }
    if tally.ahead > 0 {
        notes.push(format!(
            "left out {} {unit}(s) stamped far ahead of the {unit}s around them (the clock jumped ahead and back; the {unit}s after them are kept): {}",
            tally.ahead,
            tally.ahead_list()
        ));
    }
    let stepped_back = tally.stepped_back(out_of_order);
    if stepped_back > 0 {
        notes.push(format!(
            "left out {stepped_back} {unit}(s) whose time steps back before the previous one's samples"
        ));
    }
    notes
}

/// "read as an Axivity AX6 .cwa file: 285 data blocks at 100 Hz, channels gx,gy,gz,ax,ay,az".
pub(crate) fn describe(
    format: RawFormat,
    device: &str,
    blocks: usize,
    header_rate_hz: f64,
    channels: &[String],
) -> String {
    let what = match format {
        RawFormat::Cwa => format!("an Axivity {device} .cwa file"),
        RawFormat::GeneActiv => format!("a {device} .bin file"),
    };
    let units = if channels.iter().any(|c| c.starts_with('g')) {
        "g and °/s"
    } else {
        "g"
    };
    format!(
        "read as {what}: {blocks} {}s at {header_rate_hz} Hz, channels {} ({units}), times from the device clock",
        format.unit(),
        channels.join(",")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detect_by_magic_and_extension() {
        let p = Path::new("a.csv");
        assert_eq!(detect(b"t,x,y,z\n", p).unwrap(), None);
        let mut md = b"MD".to_vec();
        md.extend(1020u16.to_le_bytes());
        assert_eq!(detect(&md, p).unwrap(), Some(RawFormat::Cwa));
        assert_eq!(
            detect(b"Device Identity\r\n", p).unwrap(),
            Some(RawFormat::GeneActiv)
        );
        let e = detect(b"x,y,z\n", Path::new("rec.CWA")).unwrap_err();
        assert!(e.to_string().contains("'MD'"), "{e}");
        assert!(detect(b"\0\0", Path::new("rec.bin")).is_err());
    }
}
