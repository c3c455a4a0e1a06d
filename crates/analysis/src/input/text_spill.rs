//! The rows a streamed text file's first pass parsed, kept for the later passes: in memory
//! when they fit [`MEMORY_SPILL_BYTES`], else in an anonymous temporary file
//! ([`tempfile::tempfile`]: in the system's temporary directory, `$TMPDIR`, with no name, gone
//! when it is closed). A later pass reads the values back (from memory, or from the page
//! cache at the speed of a copy) instead of parsing the text again. Memory is one block per
//! pass on disk; the file is not counted in a process's resident memory.
//!
//! The values are written exactly: each block (one piece's rows) stores each column — time,
//! x, y, z, temperature — as `f32` when every value of it in the block is one (counts and
//! values of few digits mostly are, bit for bit after the round trip), else as `f64`. A row of
//! `t,x,y,z,temp` thus costs 20 to 40 bytes (28 for counts with a decimal time and
//! temperature). When all three axes are `f32` they are stored row by row (x, y, z of a row
//! together), and a block in memory is kept in 4-byte words: its axes are then the
//! detector's `[f32; 3]` samples as they lie ([`Spill::axes_f32`]), read with no copy. A
//! spill that cannot be written (no temporary directory, a full disk) is an error the reader
//! names (`text_source`): the text is never parsed again.

use crate::input::bounded::{free_bytes, KEEP_FREE_BYTES};
use crate::input::text_rows::Columns;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Most bytes of rows a spill keeps in memory; past it (or when the file's size says it will
/// pass it) they go to the temporary file. Why this much: a 222 MB file of counts with a
/// decimal time and temperature spills ~180 MB, and kept in memory its passes save the
/// kernel's copy of every byte into the page cache and out again (about a fifth of the
/// streamed run); with the pieces and parse buffers beside it (~60 MiB) the peak stays
/// under 300 MiB, near what holding such a file whole costs, and a larger file's stays flat
/// (its rows on disk).
pub const MEMORY_SPILL_BYTES: u64 = 192 << 20;

/// How one column of a block is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Width {
    /// The file has no such column.
    Absent,
    /// Every value is an `f32` exactly.
    F32,
    /// Values as `f64`.
    F64,
}

impl Width {
    fn bytes(self) -> usize {
        match self {
            Width::Absent => 0,
            Width::F32 => 4,
            Width::F64 => 8,
        }
    }

    /// The narrowest width holding every value of `values` exactly (their bits after the
    /// round trip, NaN payloads and signed zeros included).
    fn of(mut values: impl Iterator<Item = f64>) -> Self {
        Self::f32_if(values.all(is_f32))
    }

    /// `F32` when every value is an `f32` exactly, else `F64`.
    fn f32_if(exact: bool) -> Self {
        if exact {
            Width::F32
        } else {
            Width::F64
        }
    }
}

/// Whether `v` is an `f32` exactly (its bits after the round trip, NaN payloads and signed
/// zeros included).
fn is_f32(v: f64) -> bool {
    f64::from(v as f32).to_bits() == v.to_bits()
}

/// Whether a block whose columns have `widths` (t, x, y, z, temperature) stores its axes row
/// by row: when all three are `f32`.
fn axes_row_by_row(widths: &[Width; 5]) -> bool {
    widths[1..4].iter().all(|&w| w == Width::F32)
}

/// One piece's rows in the file: columns one after another, each `rows × width` bytes.
#[derive(Debug, Clone)]
struct Block {
    first_row: usize,
    rows: usize,
    offset: u64,
    /// t, x, y, z, temperature.
    widths: [Width; 5],
}

impl Block {
    /// Byte offset of column `c`'s value of the block's row `r` (for an axis: of a block whose
    /// axes are in columns, not [`Block::interleaved`]).
    fn at(&self, c: usize, r: usize) -> u64 {
        let before: usize = self.widths[..c].iter().map(|w| w.bytes() * self.rows).sum();
        self.offset + (before + r * self.widths[c].bytes()) as u64
    }

    /// Whether the axes are stored row by row (`x y z` of a row together, 12 bytes): when all
    /// three are `f32`. They take the place of the three columns (the temperature column's
    /// offset is the same either way).
    fn interleaved(&self) -> bool {
        axes_row_by_row(&self.widths)
    }

    /// Byte offset of row `r`'s axes in an [`Block::interleaved`] block.
    fn axes_at(&self, r: usize) -> u64 {
        self.offset + (self.widths[0].bytes() * self.rows + r * 12) as u64
    }
}

/// Which columns a read wants (the axes always).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Want {
    /// The time column.
    pub t: bool,
    /// The temperature column.
    pub temp: bool,
}

impl Want {
    /// Every column.
    pub(crate) const ALL: Want = Want {
        t: true,
        temp: true,
    };

    /// The axes alone.
    pub(crate) const AXES: Want = Want {
        t: false,
        temp: false,
    };
}

/// Where a spill's bytes are.
#[derive(Debug)]
enum Store {
    /// In memory, a buffer per block (no buffer grown by copying, none larger than a block),
    /// in 4-byte words so that `f32` values lie aligned ([`Spill::axes_f32`]).
    Memory(Vec<Vec<u32>>),
    /// In the temporary file.
    File(File),
}

/// The rows written, read back by row.
#[derive(Debug)]
pub(crate) struct Spill {
    store: Store,
    blocks: Vec<Block>,
    rows: usize,
}

/// A spill being written, block by block.
#[derive(Debug)]
pub(crate) struct SpillWriter {
    store: Store,
    blocks: Vec<Block>,
    at: u64,
    rows: usize,
    /// The block being written (every column's bytes are a whole number of words).
    buf: Vec<u32>,
    /// Most bytes written (a full disk, for tests: a write past it fails).
    limit: u64,
    /// Most bytes kept in memory (past them the rows go to a file in `dir`).
    memory: u64,
    /// The temporary directory (`None`: the system's).
    dir: Option<PathBuf>,
}

/// A temporary file in `dir` (`None`: the system's) and the bytes it may take: `limit`, and
/// what leaves [`KEEP_FREE_BYTES`] free on its disk (never down to a full disk: past it a
/// write fails as on a full disk).
fn temp_file(dir: Option<&Path>, limit: u64) -> std::io::Result<(File, u64)> {
    let file = match dir {
        Some(d) => tempfile::tempfile_in(d),
        None => tempfile::tempfile(),
    }?;
    let free = free_bytes(&file).map_or(u64::MAX, |f| f.saturating_sub(KEEP_FREE_BYTES));
    Ok((file, limit.min(free)))
}

impl SpillWriter {
    /// A spill of at most `limit` bytes, its first `memory` bytes kept in memory, the rest of
    /// it in a file in the temporary directory `dir` (`None`: the system's; of what leaves
    /// [`KEEP_FREE_BYTES`] free on its disk); an error when it is to be on disk and no file
    /// can be made there.
    pub(crate) fn create(dir: Option<&Path>, limit: u64, memory: u64) -> std::io::Result<Self> {
        let (store, limit) = if memory > 0 {
            (Store::Memory(Vec::new()), limit)
        } else {
            let (file, limit) = temp_file(dir, limit)?;
            (Store::File(file), limit)
        };
        Ok(Self {
            store,
            blocks: Vec::new(),
            at: 0,
            rows: 0,
            buf: Vec::new(),
            limit,
            memory,
            dir: dir.map(Path::to_path_buf),
        })
    }

    /// Whether the rows written so far are in memory.
    pub(crate) fn in_memory(&self) -> bool {
        matches!(self.store, Store::Memory(_))
    }

    /// Most bytes kept in memory.
    pub(crate) fn memory(&self) -> u64 {
        self.memory
    }

    /// Bytes written.
    pub(crate) fn bytes(&self) -> u64 {
        self.at
    }

    /// The rows written so far moved to a temporary file (the rows after them go there too);
    /// an error when no file can be made or written.
    pub(crate) fn move_to_disk(&mut self) -> std::io::Result<()> {
        let Store::Memory(blocks) = &mut self.store else {
            return Ok(());
        };
        let (mut file, limit) = temp_file(self.dir.as_deref(), self.limit)?;
        if self.at > limit {
            return Err(std::io::ErrorKind::StorageFull.into());
        }
        for b in blocks.iter() {
            file.write_all(bytemuck::cast_slice(b))?;
        }
        self.store = Store::File(file);
        self.limit = limit;
        Ok(())
    }

    /// The next rows (`cols`: one piece's, the time and temperature columns empty when the
    /// file has none) appended.
    pub(crate) fn push(&mut self, cols: &Columns) -> std::io::Result<()> {
        let rows = cols.xyz.len();
        if rows == 0 {
            return Ok(());
        }
        let opt = |v: &[f64]| (!v.is_empty()).then(|| Width::of(v.iter().copied()));
        let [x, y, z] = axis_widths(&cols.xyz);
        let widths = [
            opt(&cols.t).unwrap_or(Width::Absent),
            x,
            y,
            z,
            opt(&cols.temp).unwrap_or(Width::Absent),
        ];
        let bytes = rows * widths.iter().map(|w| w.bytes()).sum::<usize>();
        self.buf.clear();
        self.buf.reserve_exact(bytes / 4);
        put(&mut self.buf, widths[0], cols.t.iter().copied());
        if axes_row_by_row(&widths) {
            put(
                &mut self.buf,
                Width::F32,
                cols.xyz.iter().flatten().copied(),
            );
        } else {
            for (a, &w) in widths[1..4].iter().enumerate() {
                put(&mut self.buf, w, cols.xyz.iter().map(|r| r[a]));
            }
        }
        put(&mut self.buf, widths[4], cols.temp.iter().copied());
        let len = bytes as u64;
        if self.at.saturating_add(len) > self.limit {
            return Err(std::io::ErrorKind::StorageFull.into());
        }
        if self.in_memory() && self.at.saturating_add(len) > self.memory {
            self.move_to_disk()?;
        }
        match &mut self.store {
            Store::Memory(blocks) => blocks.push(std::mem::take(&mut self.buf)),
            Store::File(file) => file.write_all(bytemuck::cast_slice(&self.buf))?,
        }
        self.blocks.push(Block {
            first_row: self.rows,
            rows,
            offset: self.at,
            widths,
        });
        self.at += len;
        self.rows += rows;
        Ok(())
    }

    /// The spill, to be read back.
    pub(crate) fn finish(self) -> Spill {
        Spill {
            store: self.store,
            blocks: self.blocks,
            rows: self.rows,
        }
    }
}

/// The widths of the three axes of `xyz` ([`Width::of`] of each), in one pass over the rows
/// (the three tests of a row at once, none stopping early: a loop the compiler runs on
/// several values at a time).
fn axis_widths(xyz: &[[f64; 3]]) -> [Width; 3] {
    let all = xyz.iter().fold([true; 3], |all, r| {
        [
            all[0] & is_f32(r[0]),
            all[1] & is_f32(r[1]),
            all[2] & is_f32(r[2]),
        ]
    });
    all.map(Width::f32_if)
}

/// `values` appended to `buf` at width `w`, little-endian: each word's bytes are the value's
/// little-endian bytes, whatever the machine's order (an `f64` is two words).
fn put(buf: &mut Vec<u32>, w: Width, values: impl Iterator<Item = f64>) {
    match w {
        Width::Absent => {}
        Width::F32 => buf.extend(values.map(|v| le_word((v as f32).to_le_bytes()))),
        Width::F64 => values.for_each(|v| {
            let b = v.to_le_bytes();
            buf.extend([
                le_word([b[0], b[1], b[2], b[3]]),
                le_word([b[4], b[5], b[6], b[7]]),
            ]);
        }),
    }
}

/// The word whose bytes in memory are `b`.
#[inline]
fn le_word(b: [u8; 4]) -> u32 {
    u32::from_ne_bytes(b)
}

impl Spill {
    /// Rows written.
    pub(crate) fn len(&self) -> usize {
        self.rows
    }

    /// Whether the rows are in memory (else in the temporary file).
    pub(crate) fn in_memory(&self) -> bool {
        matches!(self.store, Store::Memory(_))
    }

    /// Rows `from..to` (`to` at most [`Spill::len`]) into `cols` (replacing what it held),
    /// with the columns `want` asks for that the file has; `scratch` holds the bytes read.
    pub(crate) fn read_rows(
        &self,
        from: usize,
        to: usize,
        want: Want,
        cols: &mut Columns,
        scratch: &mut Vec<u8>,
    ) -> std::io::Result<()> {
        cols.xyz.clear();
        cols.t.clear();
        cols.temp.clear();
        self.each_span(from, to, |b, rows| {
            let start = cols.xyz.len();
            cols.xyz.resize(start + rows.len(), [0.0; 3]);
            let to_f64 = (|v: f32| f64::from(v), |v: f64| v);
            self.axes_into(b, rows.clone(), scratch, &mut cols.xyz[start..], to_f64)?;
            for (c, on, out) in [(0, want.t, &mut cols.t), (4, want.temp, &mut cols.temp)] {
                if on && b.1.widths[c] != Width::Absent {
                    let bytes = self.column(b, c, rows.clone(), scratch)?;
                    match b.1.widths[c] {
                        Width::F32 => out.extend(bytes.chunks_exact(4).map(f32_of)),
                        _ => out.extend(bytes.chunks_exact(8).map(f64_of)),
                    }
                }
            }
            Ok(())
        })
    }

    /// The axes of rows `from..to` (`to` at most [`Spill::len`]) as `f32` (`v as f32` of each
    /// value read back) into `out` (replacing what it held): the detector's view of values
    /// on no lattice, with no `f64` rows between; `scratch` holds the bytes read.
    pub(crate) fn read_f32(
        &self,
        from: usize,
        to: usize,
        out: &mut Vec<[f32; 3]>,
        scratch: &mut Vec<u8>,
    ) -> std::io::Result<()> {
        out.clear();
        self.each_span(from, to, |b, rows| {
            let start = out.len();
            out.resize(start + rows.len(), [0.0; 3]);
            let to_f32 = (|v: f32| v, |v: f64| v as f32);
            self.axes_into(b, rows, scratch, &mut out[start..], to_f32)
        })
    }

    /// The axes of rows `rows` of block `b` (its index and itself) into `out` (one per row),
    /// each value converted by `of.0` when stored as `f32`, by `of.1` when as `f64`.
    fn axes_into<T: Copy>(
        &self,
        b: &(usize, &Block),
        rows: std::ops::Range<usize>,
        scratch: &mut Vec<u8>,
        out: &mut [[T; 3]],
        of: (impl Fn(f32) -> T, impl Fn(f64) -> T),
    ) -> std::io::Result<()> {
        if b.1.interleaved() {
            let at = b.1.axes_at(rows.start);
            let bytes = self.bytes(b, at, rows.len() * 12, scratch)?;
            for (x, c) in out.iter_mut().zip(bytes.chunks_exact(12)) {
                *x = std::array::from_fn(|a| of.0(f32_at(&c[4 * a..4 * a + 4])));
            }
            return Ok(());
        }
        for a in 0..3 {
            let bytes = self.column(b, a + 1, rows.clone(), scratch)?;
            let dst = out.iter_mut();
            match b.1.widths[a + 1] {
                Width::F32 => dst
                    .zip(bytes.chunks_exact(4))
                    .for_each(|(x, c)| x[a] = of.0(f32_at(c))),
                _ => dst
                    .zip(bytes.chunks_exact(8))
                    .for_each(|(x, c)| x[a] = of.1(f64_of(c))),
            }
        }
        Ok(())
    }

    /// The axes of block `k` as the `[f32; 3]` samples they are, in place, when they can be
    /// (the block in memory, its axes [`Block::interleaved`], a little-endian machine: the
    /// bytes were written little-endian); `None` otherwise, when [`Spill::read_f32`] reads
    /// them.
    pub(crate) fn axes_f32(&self, k: usize) -> Option<&[[f32; 3]]> {
        let (Store::Memory(words), Some(b)) = (&self.store, self.blocks.get(k)) else {
            return None;
        };
        if !(cfg!(target_endian = "little") && b.interleaved()) {
            return None;
        }
        let from = (b.axes_at(0) - b.offset) as usize / 4;
        let axes = words.get(k)?.get(from..from + 3 * b.rows)?;
        bytemuck::try_cast_slice(axes).ok()
    }

    /// Each block holding some of rows `from..to` (its index and itself), in order, with the
    /// range of its own rows among them: the walk [`Spill::read_rows`] and
    /// [`Spill::read_f32`] share. Rows past the blocks written are an unexpected end.
    fn each_span(
        &self,
        from: usize,
        to: usize,
        mut f: impl FnMut(&(usize, &Block), std::ops::Range<usize>) -> std::io::Result<()>,
    ) -> std::io::Result<()> {
        let mut k = self
            .blocks
            .partition_point(|b| b.first_row + b.rows <= from);
        let mut row = from;
        while row < to {
            let Some(b) = self.blocks.get(k) else {
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            };
            let (r0, r1) = (row - b.first_row, (to - b.first_row).min(b.rows));
            f(&(k, b), r0..r1)?;
            row += r1 - r0;
            k += 1;
        }
        Ok(())
    }

    /// The bytes of rows `rows` of column `c` of block `b` (its index and itself): in memory,
    /// else read into `scratch` (grown, never shrunk: no bytes cleared per read).
    fn column<'s>(
        &'s self,
        (k, b): &(usize, &Block),
        c: usize,
        rows: std::ops::Range<usize>,
        scratch: &'s mut Vec<u8>,
    ) -> std::io::Result<&'s [u8]> {
        let n = rows.len() * b.widths[c].bytes();
        self.bytes(&(*k, b), b.at(c, rows.start), n, scratch)
    }

    /// The `n` bytes of block `b` (its index and itself) at the spill's byte `at`: in memory,
    /// else read into `scratch` (grown, never shrunk: no bytes cleared per read).
    fn bytes<'s>(
        &'s self,
        (k, b): &(usize, &Block),
        at: u64,
        n: usize,
        scratch: &'s mut Vec<u8>,
    ) -> std::io::Result<&'s [u8]> {
        match &self.store {
            Store::Memory(blocks) => {
                let from = (at - b.offset) as usize;
                let words: &[u8] = bytemuck::cast_slice(&blocks[*k]);
                let bytes = words.get(from..from + n);
                bytes.ok_or_else(|| std::io::ErrorKind::UnexpectedEof.into())
            }
            Store::File(file) => {
                if scratch.len() < n {
                    scratch.resize(n, 0);
                }
                let bytes = &mut scratch[..n];
                read_at(file, bytes, at)?;
                Ok(bytes)
            }
        }
    }

    /// The block holding row `row` and its first row (past the last row: the number of
    /// blocks and of rows).
    pub(crate) fn block_holding(&self, row: usize) -> (usize, usize) {
        let k = self.blocks.partition_point(|b| b.first_row + b.rows <= row);
        (k, self.blocks.get(k).map_or(self.rows, |b| b.first_row))
    }

    /// Empties the file (a spill that can no longer be read back).
    #[cfg(test)]
    pub(crate) fn truncate(&self) {
        match &self.store {
            Store::File(file) => file.set_len(0).unwrap(),
            Store::Memory(_) => panic!("a spill in memory cannot be emptied"),
        }
    }

    /// The row ranges of the blocks, in order (a pass reads a block at a time).
    pub(crate) fn block_rows(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.blocks
            .iter()
            .map(|b| (b.first_row, b.first_row + b.rows))
    }
}

/// The value of 4 little-endian bytes of an `f32` (`c` a chunk of exactly 4: one load).
fn f32_of(c: &[u8]) -> f64 {
    f64::from(f32_at(c))
}

/// The `f32` of 4 little-endian bytes (`c` a chunk of exactly 4).
fn f32_at(c: &[u8]) -> f32 {
    let mut b = [0u8; 4];
    b.copy_from_slice(c);
    f32::from_le_bytes(b)
}

/// The value of 8 little-endian bytes of an `f64` (`c` a chunk of exactly 8: one load).
fn f64_of(c: &[u8]) -> f64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(c);
    f64::from_le_bytes(b)
}

/// Fills `buf` from `file` at byte `offset` (positioned reads: several threads may read one
/// spill at once).
#[cfg(unix)]
fn read_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
}

/// Fills `buf` from `file` at byte `offset`.
#[cfg(windows)]
fn read_at(file: &File, mut buf: &mut [u8], mut offset: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buf.is_empty() {
        match file.seek_read(buf, offset)? {
            0 => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            n => {
                buf = &mut buf[n..];
                offset += n as u64;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of every kind read back bit for bit, from memory, from disk and from a spill
    /// moved to disk as it was written; a spill past its limit fails.
    #[test]
    fn rows_read_back_bit_for_bit() {
        let odd = [
            0.0,
            -0.0,
            1.5,
            0.1,
            f64::NAN,
            f64::from_bits(0x7ff8_0000_0000_0001),
            f64::INFINITY,
            1e300,
            -3.0,
            f64::from(f32::MAX),
            5e-324,
        ];
        let piece = |n: usize, k: usize| Columns {
            xyz: (0..n)
                .map(|i| [odd[(i + k) % odd.len()], (i * 3 + k) as f64, odd[i % 3]])
                .collect(),
            t: (0..n).map(|i| (i + k) as f64 * 0.01).collect(),
            temp: if k == 1 { vec![] } else { vec![25.0; n] },
            ..Default::default()
        };
        // Axes that are all `f32` (stored row by row) in the third piece.
        let mut third = piece(13, 2);
        third
            .xyz
            .iter_mut()
            .for_each(|r| r[0] = f64::from(r[0] as f32));
        let pieces = [piece(7, 0), piece(0, 5), third, piece(1, 3)];
        let all: Vec<(f64, [f64; 3], f64)> = pieces
            .iter()
            .flat_map(|p| (0..p.xyz.len()).map(|i| (p.t[i], p.xyz[i], p.temp[i])))
            .collect();
        // On disk, in memory, and moved to disk after the first block.
        for memory in [0, u64::MAX, 300] {
            let mut w = SpillWriter::create(None, u64::MAX, memory).unwrap();
            pieces.iter().for_each(|p| w.push(p).unwrap());
            let spill = w.finish();
            assert_eq!(spill.in_memory(), memory == u64::MAX);
            reads_back(&spill, &all);
        }
        let mut w = SpillWriter::create(None, u64::MAX, u64::MAX).unwrap();
        w.push(&pieces[0]).unwrap();
        w.move_to_disk().unwrap();
        w.push(&pieces[2]).unwrap();
        let spill = w.finish();
        assert!(!spill.in_memory());
        reads_back(&spill, &all[..20]);
        let mut small = SpillWriter::create(None, 200, u64::MAX).unwrap();
        assert!(small.push(&pieces[0]).is_ok());
        assert!(small.push(&pieces[2]).is_err());
        // Past the memory kept, a disk too small for the rows fails alike.
        let mut small = SpillWriter::create(None, 200, 100).unwrap();
        assert!(small.push(&pieces[0]).is_ok() && !small.in_memory());
        assert!(small.push(&pieces[2]).is_err());
    }

    /// `spill` reads back `all` bit for bit, by block and across block ends, with the columns
    /// asked for.
    fn reads_back(spill: &Spill, all: &[(f64, [f64; 3], f64)]) {
        assert_eq!(spill.len(), all.len());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let (mut cols, mut scratch) = (Columns::default(), Vec::new());
        for from in 0..all.len() {
            for to in from..=all.len() {
                spill
                    .read_rows(from, to, Want::ALL, &mut cols, &mut scratch)
                    .unwrap();
                let want = &all[from..to];
                assert_eq!(
                    bits(&cols.t),
                    bits(&want.iter().map(|r| r.0).collect::<Vec<_>>())
                );
                let xyz: Vec<f64> = cols.xyz.concat();
                let want_xyz: Vec<f64> = want.iter().flat_map(|r| r.1).collect();
                assert_eq!(bits(&xyz), bits(&want_xyz), "rows {from}..{to}");
                assert_eq!(
                    bits(&cols.temp),
                    bits(&want.iter().map(|r| r.2).collect::<Vec<_>>())
                );
            }
        }
        let f32_bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        let as_f32 = |rows: &[(f64, [f64; 3], f64)]| -> Vec<[f32; 3]> {
            rows.iter().map(|r| r.1.map(|v| v as f32)).collect()
        };
        let mut view = Vec::new();
        for from in 0..all.len() {
            for to in from..=all.len() {
                spill.read_f32(from, to, &mut view, &mut scratch).unwrap();
                assert_eq!(f32_bits(&view), f32_bits(&as_f32(&all[from..to])));
            }
        }
        let mut in_place = 0;
        for (k, (from, to)) in spill.block_rows().enumerate() {
            if let Some(axes) = spill.axes_f32(k) {
                assert_eq!(f32_bits(axes), f32_bits(&as_f32(&all[from..to])));
                in_place += 1;
            }
        }
        // Only the block of `f32` axes, and only in memory.
        assert_eq!(in_place, usize::from(spill.in_memory()), "{in_place}");
        let only_xyz = Want {
            t: false,
            temp: false,
        };
        spill
            .read_rows(2, 9, only_xyz, &mut cols, &mut scratch)
            .unwrap();
        assert!(cols.t.is_empty() && cols.temp.is_empty() && cols.xyz.len() == 7);
        assert!(spill
            .read_rows(0, all.len() + 1, Want::ALL, &mut cols, &mut scratch)
            .is_err());
    }
}
