//! Axivity `.cwa` files (AX3, AX6), from OpenMovement's published format (`cwa.h`, the AX3
//! technical documentation). All values little-endian.
//!
//! * Header block, 1024 bytes: `MD`, length 1020, hardware type at byte 4 (`0x64` = AX6,
//!   else AX3), sample-rate code at byte 36.
//! * Data blocks, 512 bytes each after the header: `AX`, length 508; byte 4 `u16`: with its
//!   top bit set, a 15-bit fraction of a second of the timestamp; 10 `u32` sequence number;
//!   14 `u32` packed timestamp `YYYYYYMM MMDDDDDh hhhhmmmm mmssssss` (year − 2000); 18 `u16`:
//!   light in the low 10 bits, the gyroscope range code in bits 10–12 (range `8000 / 2ⁿ` °/s)
//!   and the accelerometer scale code in bits 13–15 (`2^(8+n)` counts per g); 20 `u16`
//!   temperature in the low 10 bits (`v·75/256 − 50` °C); 23 battery; 24 rate code (rate
//!   `3200 / 2^(15 − (c & 15))` Hz); 25 channels (high nibble: 3, 6 = gyro+accel, 9 =
//!   +magnetometer) and packing (low nibble: 0 = three 10-bit values with a shared 2-bit
//!   exponent in a `u32`, 2 = one `i16` per channel); 26 `i16` the sample index the whole-second
//!   timestamp belongs to; 28 `u16` sample count; 30 the samples (480 bytes); 510 a checksum
//!   word making the 256 words of the block sum to 0 (mod 2¹⁶).
//! * Very old files have 0 at byte 24: no checksum, the rate at byte 26.
//!
//! A block whose checksum fails is skipped ([`Block::Corrupt`]); one whose checksum passes but
//! whose fields are impossible (not `AX`, a sample count that overruns the 480 data bytes, an
//! impossible date, a channel layout different from the first block's) is skipped with its
//! reason ([`Block::Invalid`]); a cut-off last block is a note. Nothing here panics on any
//! bytes: every offset is inside a 512-byte block and every count is checked against it.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use super::block::{civil_seconds, valid_civil, Block, GoodBlock};
use crate::error::input::InputError;
use crate::input::bounded::read_full;

/// This module's errors are all the input stage's.
type Result<T, E = InputError> = std::result::Result<T, E>;

/// Bytes of the header block.
pub const HEADER_BYTES: usize = 1024;
/// Bytes of a data block.
pub const BLOCK_BYTES: usize = 512;
/// Bytes of sample data in a block.
const DATA_BYTES: usize = 480;

fn u16_at(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// The rate (Hz) of a rate code: `3200 / 2^(15 − (code & 15))`.
pub fn rate_of_code(code: u8) -> f64 {
    3200.0 / f64::from(1u32 << (15 - u32::from(code & 15)))
}

/// What the header block says.
#[derive(Debug, Clone, Copy)]
pub struct Header {
    /// `AX3` or `AX6` (hardware type at byte 4).
    pub device: &'static str,
    /// The declared sample rate, Hz.
    pub rate_hz: f64,
}

impl Header {
    /// The header of a file starting with `bytes` (all of it when shorter than the header
    /// block).
    pub fn of(bytes: &[u8]) -> Result<Self> {
        let header_err = |why: String| InputError::RawHeader {
            format: "Axivity .cwa",
            why,
        };
        if bytes.len() < HEADER_BYTES {
            return Err(header_err(format!(
                "the header block is cut short ({} of {HEADER_BYTES} bytes)",
                bytes.len()
            )));
        }
        if &bytes[..2] != b"MD" || u16_at(bytes, 2) != 1020 {
            return Err(header_err("no 'MD' header block of 1024 bytes".into()));
        }
        Ok(Self {
            device: if bytes[4] == 0x64 { "AX6" } else { "AX3" },
            rate_hz: rate_of_code(bytes[36]),
        })
    }
}

/// The note on a file whose last block is cut off (`rest` bytes of it after `full` blocks).
fn cut_note(full: usize, rest: usize) -> Option<String> {
    (rest != 0).then(|| format!(
        "the file is cut short: its last data block (#{full}) has {rest} of {BLOCK_BYTES} bytes and is not read"
    ))
}

/// The most samples a block of `layout` (channels, packed) can hold: its 480 data bytes by
/// the bytes of a sample (a checked block's count never exceeds it).
pub(crate) fn max_samples(layout: (u8, bool)) -> usize {
    let per_sample = if layout.1 {
        4
    } else {
        2 * usize::from(layout.0.max(1))
    };
    DATA_BYTES / per_sample
}

/// The channel names of a layout (channels, packed) as the blocks store them.
pub(crate) fn channel_names(layout: Option<(u8, bool)>) -> Vec<String> {
    let names = match layout.map(|l| l.0) {
        Some(6) => &["gx", "gy", "gz", "ax", "ay", "az"][..],
        Some(9) => &["gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz"][..],
        _ => &["ax", "ay", "az"][..],
    };
    names.iter().map(|s| s.to_string()).collect()
}

/// Blocks read from the file per chunk (4 MiB): the memory of a block-by-block read.
pub const CHUNK_BLOCKS: usize = 8192;

/// A `.cwa` file read a chunk of blocks at a time ([`CHUNK_BLOCKS`]), from disk or from its
/// bytes in memory (a held file, or a mapping): memory is one chunk, whatever the file's length.
pub struct BlockReader<'a> {
    source: Source<'a>,
    path: std::path::PathBuf,
    /// The header block's fields.
    pub header: Header,
    layout: Option<(u8, bool)>,
    index: usize,
    rest: usize,
}

/// A file's bytes in memory (a mapping of it, made by the caller), for
/// [`BlockReader::of_bytes`].
pub trait Mapped: Send + Sync {
    /// The whole file.
    fn bytes(&self) -> &[u8];
    /// The bytes before `upto` are read and will not be read again: a mapping may let go of
    /// them (its resident pages then do not grow to the file's size).
    fn consumed(&self, upto: usize) {
        let _ = upto;
    }
}

impl Mapped for Vec<u8> {
    fn bytes(&self) -> &[u8] {
        self
    }
}

impl Mapped for &[u8] {
    fn bytes(&self) -> &[u8] {
        self
    }
}

/// A file's bytes in memory, owned by the reader.
pub type Bytes = Box<dyn Mapped>;

/// Where a [`BlockReader`]'s blocks come from.
enum Source<'a> {
    /// Read from the file a chunk at a time into `buf`.
    File { file: std::fs::File, buf: Vec<u8> },
    /// The whole file already in memory (held, or a mapping the caller made), given a chunk
    /// at a time without a copy; `at`: where the next chunk starts.
    Bytes {
        bytes: Box<dyn Mapped + 'a>,
        at: usize,
    },
}

impl<'a> BlockReader<'a> {
    /// Opens `path` and reads its header block.
    pub fn open(path: &std::path::Path) -> crate::error::Result<Self> {
        let read_err = |source| InputError::Read {
            path: path.into(),
            source,
        };
        let mut file = std::fs::File::open(path).map_err(read_err)?;
        let mut head = vec![0u8; HEADER_BYTES];
        let got = read_full(&mut file, &mut head).map_err(read_err)?;
        let header = Header::of(&head[..got])?;
        let buf = vec![0u8; CHUNK_BLOCKS * BLOCK_BYTES];
        Ok(Self::with(Source::File { file, buf }, path, header))
    }

    /// The reader of a file whose bytes are `bytes` (held, or the file at `path` mapped into
    /// memory by the caller: the chunks are then slices of it, not copies), the blocks and
    /// notes as [`BlockReader::open`] gives them from the file.
    pub fn of_bytes(
        path: &std::path::Path,
        bytes: Box<dyn Mapped + 'a>,
    ) -> crate::error::Result<Self> {
        let all = bytes.bytes();
        let header = Header::of(&all[..all.len().min(HEADER_BYTES)])?;
        let at = HEADER_BYTES;
        Ok(Self::with(Source::Bytes { bytes, at }, path, header))
    }

    fn with(source: Source<'a>, path: &std::path::Path, header: Header) -> Self {
        Self {
            source,
            path: path.into(),
            header,
            layout: None,
            index: 0,
            rest: 0,
        }
    }

    /// The next chunk's bytes ([`CHUNK_BLOCKS`] blocks, fewer at the end of the file) and
    /// whether it was a whole chunk (more may follow).
    fn next_raw(&mut self) -> crate::error::Result<(&[u8], bool)> {
        let want = CHUNK_BLOCKS * BLOCK_BYTES;
        match &mut self.source {
            Source::File { file, buf } => {
                let got = read_full(file, buf).map_err(|source| InputError::Read {
                    path: self.path.clone(),
                    source,
                })?;
                Ok((&buf[..got], got == want))
            }
            Source::Bytes { bytes, at } => {
                bytes.consumed(*at);
                let all = bytes.bytes();
                let start = (*at).min(all.len());
                let end = start.saturating_add(want).min(all.len());
                *at = end;
                Ok((&all[start..end], end - start == want))
            }
        }
    }

    /// The next chunk's blocks in `out` (cleared first); `false` once the file is read.
    pub fn next_chunk(&mut self, out: &mut Vec<Block>) -> crate::error::Result<bool> {
        out.clear();
        let (_, more) = self.next_bytes(|first, bytes, layout| {
            decode_blocks(bytes, first, layout, out);
        })?;
        Ok(more)
    }

    /// The next chunk's whole blocks as read, given to `each` with the index of the first and
    /// the channel layout (fixed by the first good block); the index of the chunk's first
    /// block and whether more follow.
    pub(crate) fn next_bytes(
        &mut self,
        each: impl FnOnce(usize, &[u8], &mut Option<(u8, bool)>),
    ) -> crate::error::Result<(usize, bool)> {
        let first = self.index;
        let mut layout = self.layout;
        let (bytes, more) = self.next_raw()?;
        let got = bytes.len();
        each(first, &bytes[..got - got % BLOCK_BYTES], &mut layout);
        self.layout = layout;
        self.index += got / BLOCK_BYTES;
        self.rest = got % BLOCK_BYTES;
        Ok((first, more))
    }

    /// Whole data blocks the file holds now (its length after the header, by 512 bytes):
    /// what a one-pass reader sizes its output by.
    pub(crate) fn data_blocks(&self) -> crate::error::Result<usize> {
        let len = match &self.source {
            Source::File { file, .. } => file
                .metadata()
                .map_err(|source| InputError::Read {
                    path: self.path.clone(),
                    source,
                })?
                .len(),
            Source::Bytes { bytes, .. } => bytes.bytes().len() as u64,
        };
        Ok(
            usize::try_from(len.saturating_sub(HEADER_BYTES as u64)).unwrap_or(usize::MAX)
                / BLOCK_BYTES,
        )
    }

    /// The channel names (known once the first block is decoded).
    pub fn channels(&self) -> Vec<String> {
        channel_names(self.layout)
    }

    /// The reader's notes once the file is read (a cut-off last block).
    pub fn notes(&self) -> Vec<String> {
        cut_note(self.index, self.rest).into_iter().collect()
    }
}

/// Decodes the whole blocks of `bytes` (the first at position `first` in the file) onto `out`
/// as [`decode_block`] one after the other would, on all cores (see [`each_block`]).
fn decode_blocks(
    bytes: &[u8],
    first: usize,
    layout: &mut Option<(u8, bool)>,
    out: &mut Vec<Block>,
) {
    each_block(bytes, first, layout, out, decode_block);
}

/// `each` of every whole block of `bytes` (the first at position `first` in the file) onto
/// `out` in file order, as calling it on one block after the other would give, on all cores:
/// the blocks up to the one that fixes `layout` (the first good block) one by one, the rest
/// in parallel (each then only compares its layout with the fixed one).
pub(crate) fn each_block<R: Send>(
    bytes: &[u8],
    first: usize,
    layout: &mut Option<(u8, bool)>,
    out: &mut Vec<R>,
    each: impl Fn(&[u8], usize, &mut Option<(u8, bool)>) -> R + Sync,
) {
    use rayon::prelude::*;
    let n = bytes.len() / BLOCK_BYTES;
    let mut k = 0;
    while layout.is_none() && k < n {
        let block = &bytes[k * BLOCK_BYTES..(k + 1) * BLOCK_BYTES];
        out.push(each(block, first + k, layout));
        k += 1;
    }
    let fixed = *layout;
    out.par_extend(
        bytes[k * BLOCK_BYTES..n * BLOCK_BYTES]
            .par_chunks_exact(BLOCK_BYTES)
            .enumerate()
            .map(|(j, block)| each(block, first + k + j, &mut { fixed })),
    );
}

/// True when the 256 little-endian words of a block sum to 0 modulo 2¹⁶.
pub fn checksum_ok(block: &[u8]) -> bool {
    block.chunks_exact(2).fold(0u16, |s, w| {
        s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
    }) == 0
}

/// Decodes one 512-byte block. `layout` is the first good block's channel count and packing;
/// a later block with another layout is invalid (its samples would not line up).
fn decode_block(b: &[u8], index: usize, layout: &mut Option<(u8, bool)>) -> Block {
    match head_block(b, layout) {
        Checked::Good(h) => Block::Good(h.decode(b, index)),
        Checked::Corrupt => Block::Corrupt,
        Checked::Invalid(why) => Block::Invalid(why),
    }
}

/// A block checked as [`decode_block`] checks it, its samples not yet decoded.
#[derive(Debug, Clone)]
pub(crate) enum Checked {
    /// Readable: its fields.
    Good(Head),
    /// Its checksum fails.
    Corrupt,
    /// A field is impossible: the reason.
    Invalid(String),
}

/// Checks one 512-byte block (checksum, then fields) as [`decode_block`] does.
pub(crate) fn head_block(b: &[u8], layout: &mut Option<(u8, bool)>) -> Checked {
    let rate_code = b[24];
    if rate_code != 0 && !checksum_ok(b) {
        return Checked::Corrupt;
    }
    match Head::of(b, layout) {
        Ok(h) => Checked::Good(h),
        Err(why) => Checked::Invalid(why),
    }
}

/// The block's start time: the packed whole-second timestamp, plus the fraction of a second
/// when stored, minus the time of the samples before the one the timestamp belongs to.
fn start_time(b: &[u8], rate_hz: f64) -> std::result::Result<f64, String> {
    let ts = u32_at(b, 14);
    let (y, mo, d) = (
        2000 + (ts >> 26) as i64,
        (ts >> 22) & 0xf,
        (ts >> 17) & 0x1f,
    );
    let (h, mi, s) = ((ts >> 12) & 0x1f, (ts >> 6) & 0x3f, ts & 0x3f);
    if !valid_civil(y, mo, d, h, mi, s) {
        return Err(format!("impossible timestamp 0x{ts:08x}"));
    }
    let whole = civil_seconds(y, mo, d, h, mi, f64::from(s));
    let frac_word = u16_at(b, 4);
    let mut shift = f64::from(i16::from_le_bytes([b[26], b[27]]));
    let mut fraction = 0.0;
    if b[24] == 0 {
        shift = 0.0; // old files: byte 26 holds the rate
    } else if frac_word & 0x8000 != 0 {
        // 15-bit fraction stored as a 16-bit one; the firmware moved the timestamp's sample
        // index by the whole samples this fraction spans (with the rate truncated to an
        // integer), which is undone here.
        let frac16 = u32::from(frac_word & 0x7fff) << 1;
        fraction = f64::from(frac16) / 65536.0;
        shift += f64::from((frac16 * rate_hz as u32) >> 16);
    }
    Ok(whole + fraction - shift / rate_hz)
}

/// The fields of a readable data block: what decoding its samples needs, and its time.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Head {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Channels per sample (3, 6 or 9).
    pub channels: u8,
    /// Three 10-bit values and an exponent in a `u32` (else one `i16` per channel).
    pub packed: bool,
    /// Samples in the block.
    pub n: usize,
    /// g per count of the accelerometer (`2^-(8+n)`).
    pub accel_scale: f64,
    /// The gyroscope's full range, °/s (`8000 / 2ⁿ`).
    pub gyro_range: f64,
    /// Time of the first sample, device-clock seconds.
    pub start_s: f64,
    /// Word 18: light (low 10 bits) and the range codes.
    word18: u16,
}

impl Head {
    /// The fields of block `b`, checked in the order [`decode_block`] always has (the layout
    /// is fixed by the first block that gets that far, even if its timestamp is impossible).
    fn of(b: &[u8], layout: &mut Option<(u8, bool)>) -> std::result::Result<Self, String> {
        if &b[..2] != b"AX" || u16_at(b, 2) != 508 {
            return Err("not an 'AX' data block of 512 bytes".into());
        }
        let rate_hz = if b[24] == 0 {
            f64::from(u16_at(b, 26))
        } else {
            rate_of_code(b[24])
        };
        if !(rate_hz > 0.0) {
            return Err("sample rate 0".into());
        }
        let channels = b[25] >> 4;
        let packed = b[25] & 0x0f == 0;
        let per_sample = match (channels, packed) {
            (3, true) => 4,
            (3 | 6 | 9, false) if b[25] & 0x0f == 2 => 2 * channels as usize,
            _ => return Err(format!("unknown channel layout 0x{:02x}", b[25])),
        };
        if *layout.get_or_insert((channels, packed)) != (channels, packed) {
            return Err("channel layout differs from the first block's".into());
        }
        let n = usize::from(u16_at(b, 28));
        if n * per_sample > DATA_BYTES {
            return Err(format!(
                "{n} samples overrun the block's {DATA_BYTES} data bytes"
            ));
        }
        let word18 = u16_at(b, 18);
        Ok(Self {
            rate_hz,
            channels,
            packed,
            n,
            accel_scale: 1.0 / f64::from(1u32 << (8 + (word18 >> 13))),
            gyro_range: 8000.0 / f64::from(1u32 << ((word18 >> 10) & 7)),
            start_s: start_time(b, rate_hz)?,
            word18,
        })
    }

    /// Value `v` (as stored) of channel `c` in the unit of its sensor: g for the
    /// accelerometer, °/s for the gyroscope, counts for a magnetometer.
    fn scaled(&self, c: usize, v: f64) -> f64 {
        match (self.channels, c) {
            (3, _) | (_, 3..=5) => v * self.accel_scale,
            (_, 0..=2) => v / 32768.0 * self.gyro_range,
            _ => v, // magnetometer: raw counts
        }
    }

    /// Channels `cols` of every sample of block `b` (whose head this is) into `out`, three
    /// values a sample (`out` holds `3·n`), each as [`Head::decode`] gives it, then cast.
    pub fn samples_into<T: Copy>(
        &self,
        b: &[u8],
        cols: [usize; 3],
        cast: impl Fn(f64) -> T,
        out: &mut [T],
    ) {
        let nch = usize::from(self.channels);
        if self.packed {
            for (w, row) in b[30..30 + 4 * self.n]
                .chunks_exact(4)
                .zip(out.chunks_exact_mut(3))
            {
                let v = u32_at(w, 0);
                let e = v >> 30;
                for (o, &c) in row.iter_mut().zip(&cols) {
                    let raw = (((v >> (10 * c)) & 0x3ff) as i32) << 22 >> 22;
                    *o = cast(f64::from(raw << e) * self.accel_scale);
                }
            }
        } else if self.channels == 3 && cols == [0, 1, 2] {
            // The AX3's own layout in its own order: one straight loop over the 16-bit
            // values (the same product and cast as below, which the compiler vectorises).
            let scale = self.accel_scale;
            for (w, o) in b[30..30 + 6 * self.n].chunks_exact(2).zip(out.iter_mut()) {
                *o = cast(f64::from(i16::from_le_bytes([w[0], w[1]])) * scale);
            }
        } else {
            let scale = cols.map(|c| self.scaled(c, 1.0));
            let direct = cols.map(|c| matches!((self.channels, c), (3, _) | (_, 3..=5)));
            for (s, row) in b[30..30 + 2 * nch * self.n]
                .chunks_exact(2 * nch)
                .zip(out.chunks_exact_mut(3))
            {
                for k in 0..3 {
                    let c = cols[k];
                    let v = f64::from(i16::from_le_bytes([s[2 * c], s[2 * c + 1]]));
                    row[k] = cast(if direct[k] {
                        v * scale[k]
                    } else {
                        self.scaled(c, v)
                    });
                }
            }
        }
    }

    /// Sensor temperature, °C (`v·75/256 − 50` of the low 10 bits of word 20).
    pub fn temp_c(b: &[u8]) -> f64 {
        f64::from(u16_at(b, 20) & 0x3ff) * 75.0 / 256.0 - 50.0
    }

    /// The decoded block: every channel of every sample.
    fn decode(&self, b: &[u8], index: usize) -> GoodBlock {
        let nch = usize::from(self.channels);
        let per_sample = if self.packed { 4 } else { 2 * nch };
        let samples = &b[30..30 + self.n * per_sample];
        let mut data = Vec::with_capacity(self.n * nch);
        if self.packed {
            for w in samples.chunks_exact(4) {
                let v = u32_at(w, 0);
                let e = v >> 30;
                for k in 0..3 {
                    // 10-bit two's complement, then shifted left by the shared exponent.
                    let raw = (((v >> (10 * k)) & 0x3ff) as i32) << 22 >> 22;
                    data.push(f64::from(raw << e) * self.accel_scale);
                }
            }
        } else {
            for (i, w) in samples.chunks_exact(2).enumerate() {
                let v = f64::from(i16::from_le_bytes([w[0], w[1]]));
                data.push(self.scaled(i % nch, v));
            }
        }
        GoodBlock {
            index,
            sequence: u32_at(b, 10),
            start_s: self.start_s,
            rate_hz: self.rate_hz,
            temp_c: Self::temp_c(b),
            battery_v: 3.0 * (f64::from(b[23]) / 256.0 + 1.0),
            light: f64::from(self.word18 & 0x3ff),
            data,
            light_per_sample: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block with the checksum word set so that the words sum to 0.
    fn seal(mut b: Vec<u8>) -> Vec<u8> {
        b[510] = 0;
        b[511] = 0;
        let s = b.chunks_exact(2).fold(0u16, |s, w| {
            s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
        });
        b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
        b
    }

    fn block(samples: &[[i16; 3]]) -> Vec<u8> {
        let mut b = vec![0u8; 512];
        b[..2].copy_from_slice(b"AX");
        b[2..4].copy_from_slice(&508u16.to_le_bytes());
        // 2024-01-02 03:04:05
        let ts: u32 = (24 << 26) | (1 << 22) | (2 << 17) | (3 << 12) | (4 << 6) | 5;
        b[14..18].copy_from_slice(&ts.to_le_bytes());
        b[20..22].copy_from_slice(&256u16.to_le_bytes()); // 25 °C
        b[24] = 0x4a; // 100 Hz
        b[25] = 0x32; // 3 channels, unpacked
        b[28..30].copy_from_slice(&(samples.len() as u16).to_le_bytes());
        for (i, s) in samples.iter().enumerate() {
            for k in 0..3 {
                b[30 + 6 * i + 2 * k..32 + 6 * i + 2 * k].copy_from_slice(&s[k].to_le_bytes());
            }
        }
        seal(b)
    }

    fn file(blocks: &[Vec<u8>]) -> Vec<u8> {
        let mut f = vec![0u8; 1024];
        f[..2].copy_from_slice(b"MD");
        f[2..4].copy_from_slice(&1020u16.to_le_bytes());
        f[36] = 0x4a;
        for b in blocks {
            f.extend(b);
        }
        f
    }

    /// A file held in memory as the one reader gives it: its blocks, notes and header rate.
    fn read(bytes: &[u8]) -> crate::error::Result<(Vec<Block>, Vec<String>, f64)> {
        let mut reader = BlockReader::of_bytes(std::path::Path::new(""), Box::new(bytes))?;
        let (mut blocks, mut chunk) = (Vec::new(), Vec::new());
        while reader.next_chunk(&mut chunk)? {
            blocks.append(&mut chunk);
        }
        blocks.append(&mut chunk);
        Ok((blocks, reader.notes(), reader.header.rate_hz))
    }

    /// The first decoded block.
    fn first_good(blocks: &[Block]) -> &GoodBlock {
        blocks
            .iter()
            .find_map(|b| match b {
                Block::Good(g) => Some(g),
                _ => None,
            })
            .unwrap()
    }

    #[test]
    fn unpacked_block_decodes_scale_time_and_temperature() {
        let (blocks, _, header_rate_hz) = read(&file(&[block(&[[256, -128, 512]; 80])])).unwrap();
        let b = first_good(&blocks);
        assert_eq!(&b.data[..3], &[1.0, -0.5, 2.0]);
        assert_eq!(b.len(3), 80);
        assert_eq!(b.temp_c, 25.0);
        assert_eq!(b.start_s, civil_seconds(2024, 1, 2, 3, 4, 5.0));
        assert_eq!(header_rate_hz, 100.0);
    }

    #[test]
    fn packed_values_use_the_shared_exponent() {
        let mut b = block(&[]);
        b[25] = 0x30;
        b[28..30].copy_from_slice(&1u16.to_le_bytes());
        // x = −1 (0x3ff), y = 3, z = 0x200 (−512), exponent 2.
        let v: u32 = 0x3ff | (3 << 10) | (0x200 << 20) | (2 << 30);
        b[30..34].copy_from_slice(&v.to_le_bytes());
        let (blocks, _, _) = read(&file(&[seal(b)])).unwrap();
        let g = first_good(&blocks);
        assert_eq!(g.data, vec![-4.0 / 256.0, 12.0 / 256.0, -2048.0 / 256.0]);
    }

    #[test]
    fn bad_checksum_overrun_and_truncation_are_skipped_not_fatal() {
        let good = block(&[[256, 0, 0]; 80]);
        let mut corrupt = good.clone();
        corrupt[40] ^= 1;
        let mut overrun = block(&[]);
        overrun[28..30].copy_from_slice(&81u16.to_le_bytes()); // 81·6 > 480
        let mut bytes = file(&[good, corrupt, seal(overrun)]);
        bytes.extend([0u8; 100]);
        let (blocks, notes, _) = read(&bytes).unwrap();
        assert_eq!(blocks.len(), 3);
        assert!(matches!(blocks[0], Block::Good(_)), "{:?}", blocks[0]);
        assert!(matches!(blocks[1], Block::Corrupt), "{:?}", blocks[1]);
        assert!(matches!(blocks[2], Block::Invalid(_)), "{:?}", blocks[2]);
        assert!(notes[0].contains("(#3) has 100 of 512 bytes"), "{notes:?}");
        let e = read(&bytes[..500]).unwrap_err().to_string();
        assert!(e.contains("500 of 1024"), "{e}");
    }
}
