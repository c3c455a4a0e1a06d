//! GGIRread's view of an Axivity file: its block selection and its resampling onto a regular
//! time grid (`readAxivity(file, start, end)`, R package GGIRread, as its documentation and
//! source describe the steps; reimplemented here, not copied), so that the values GGIRread's
//! tests assert on its test files can be checked against this crate's decoder.
//!
//! The analysis itself does not use this: it works on the samples at their own times
//! ([`super::load::load_raw`]). GGIRread's steps, in our words:
//!
//! 1. **End**: when `end` is inside the file, the first good block from `end` on gives the
//!    end time (corrupt ones are skipped, moving `end` forward); when `end` is the end of the
//!    file, the last good block (searching backwards, moving `end` back) gives it, plus three
//!    block durations of padding.
//! 2. **Start**: corrupt blocks at `start` are skipped (logged, not imputed); a range with no
//!    good block is the error "all requested blocks are corrupt".
//! 3. **Grid**: `t₀ + k/f` from the first good block's start `t₀` up to the end time
//!    (exclusive), `f` the header's rate.
//! 4. **Blocks**: each good block's samples are spread evenly from its start to the next good
//!    block's start, then linearly interpolated onto the grid points up to its last sample
//!    (the interpolation starts from the previous block's last grid value). The file's last
//!    block has no next: its samples are spread from the start of the block before it to its
//!    own start plus one block duration (GGIRread's extrapolation, kept as it is).
//! 5. **Integrity**: when the next good block's sequence number is not the next one (corrupt
//!    blocks between) or the observed rate differs from the declared by more than 10 %, the
//!    block's grid points are **imputed**: the last output value's direction scaled to 1 g
//!    (if its norm is within 0.8–1.2 g, else (0, 0, 1)), logged. Corrupt blocks inside the
//!    range are skipped and logged; more than 20 in a row is an error.
//! 6. The grid is cut after the last value written.
//!
//! Rows carry the block's temperature, battery and light, as GGIRread's columns do.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use super::block::{Block, GoodBlock};
use super::blocks::Blocks;
use crate::error::input::InputError;

/// This module's errors are all the input stage's.
type Result<T, E = InputError> = std::result::Result<T, E>;

/// Most consecutive corrupt blocks accepted (GGIRread's `maxAllowedCorruptBlocks` default).
pub const MAX_CORRUPT: usize = 20;
/// Largest relative difference of the observed from the declared rate before a block is
/// imputed (GGIRread's `frequency_tol`).
pub const FREQUENCY_TOL: f64 = 0.1;

/// One entry of GGIRread's quality-control log.
#[derive(Debug, Clone, PartialEq)]
pub struct QcEntry {
    /// False: the block failed its checksum and was skipped.
    pub checksum_pass: bool,
    /// The block described (its position for a corrupt block, else its sequence number).
    pub block: u64,
    /// The next block (position + 1 for a corrupt one, else the next good block's sequence).
    pub next: u64,
    /// True when the block's grid points were imputed.
    pub imputed: bool,
}

/// Values on the regular grid.
#[derive(Debug, Clone, Default)]
pub struct Grid {
    /// Grid times, device-clock seconds.
    pub time: Vec<f64>,
    /// Values per row (3, or 6 with the gyroscope first).
    pub channels: usize,
    /// Row-major values.
    pub values: Vec<f64>,
    /// Temperature per row, °C.
    pub temp: Vec<f64>,
    /// Battery per row, V.
    pub battery: Vec<f64>,
    /// Light per row (raw).
    pub light: Vec<f64>,
    /// The quality-control log.
    pub log: Vec<QcEntry>,
    /// The warnings GGIRread gives, e.g. `Skipping corrupt block #0`.
    pub warnings: Vec<String>,
}

impl Grid {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.time.len()
    }

    /// Columns of GGIRread's data frame: time, the channels, temperature, battery, light.
    pub fn columns(&self) -> usize {
        1 + self.channels + 3
    }

    /// Value of row `r`, channel `c`.
    pub fn at(&self, r: usize, c: usize) -> f64 {
        self.values[r * self.channels + c]
    }
}

/// GGIRread's `seq(a, b, by)`: `a + k·by` for `k = 0..=⌊(b−a)/by + 1e-10⌋`, capped at `b`.
fn seq_by(a: f64, b: f64, by: f64) -> Vec<f64> {
    let n = ((b - a) / by + 1e-10).floor();
    if !(n >= 0.0) || n > 1e9 {
        return vec![a];
    }
    (0..=n as usize)
        .map(|k| (a + k as f64 * by).min(b))
        .collect()
}

/// `seq(a, b, length.out = n)`.
fn seq_len(a: f64, b: f64, n: usize) -> impl Iterator<Item = f64> {
    let by = if n > 1 { (b - a) / (n - 1) as f64 } else { 0.0 };
    (0..n).map(move |k| if k + 1 == n { b } else { a + k as f64 * by })
}

/// Linear interpolation of `raw` (rows of `nch` at times `raw_t[..stop]`, rising) at the times
/// `grid`, for the grid points up to `raw_t[stop − 1]`; rows returned.
fn resample(raw: &[f64], nch: usize, raw_t: &[f64], grid: &[f64], stop: usize) -> Vec<f64> {
    let u_max = raw_t[stop - 1];
    let last = grid.iter().take_while(|&&t| t <= u_max).count();
    let mut out = vec![0.0; last * nch];
    let mut pos = 1;
    for p in 0..last {
        while raw_t[pos] < grid[p] {
            pos += 1;
        }
        let u = (grid[p] - raw_t[pos - 1]) / (raw_t[pos] - raw_t[pos - 1]);
        for j in 0..nch {
            let (a, b) = (raw[(pos - 1) * nch + j], raw[pos * nch + j]);
            out[p * nch + j] = u * (b - a) + a;
        }
    }
    out
}

/// A file's blocks gathered whole from the one reader: GGIRread's reader looks at them by
/// index, forwards and back.
struct Gathered {
    blocks: Vec<Block>,
    /// Values per sample.
    channels: usize,
    header_rate_hz: f64,
}

fn good(raw: &Gathered, i: usize) -> Option<&GoodBlock> {
    match raw.blocks.get(i) {
        Some(Block::Good(g)) => Some(g),
        _ => None,
    }
}

/// Step 1: the end time and the (moved) end block.
fn end_time(raw: &Gathered, start: usize, mut end: usize, grid: &mut Grid) -> Result<(f64, usize)> {
    let nb = raw.blocks.len();
    let step = 1.0 / raw.header_rate_hz;
    let mut end_ts = None;
    if end < nb {
        let first_end = end; // the range is fixed before `end` moves, as in GGIRread
        for ii in first_end..=(nb - 1).min(first_end + MAX_CORRUPT) {
            if let Some(b) = good(raw, ii) {
                end_ts = Some(b.start_s);
                break;
            }
            grid.warnings
                .push(format!("Skipping corrupt end block #{ii}"));
            end += 1;
        }
    }
    if end == nb {
        let lo = start.max(end.saturating_sub(MAX_CORRUPT + 1));
        let first_len = (0..nb)
            .find_map(|i| good(raw, i))
            .map_or(0, |g| g.len(raw.channels));
        let mut found = None;
        let last_end = end;
        for ii in (lo..last_end).rev() {
            if let Some(b) = good(raw, ii) {
                found = Some(b);
                break;
            }
            grid.warnings
                .push(format!("Skipping corrupt end block #{ii}"));
            end -= 1;
        }
        let Some(b) = found else {
            return Err(InputError::AllBlocksCorrupt { start, end: nb });
        };
        end_ts = Some(b.start_s + 3.0 * first_len as f64 * step);
    }
    end_ts
        .map(|t| (t, end))
        .ok_or(InputError::TooManyCorruptBlocks {
            block: end,
            max: MAX_CORRUPT,
        })
}

/// GGIRread's `readAxivity(file, start, end)` of the file whose blocks are `blocks`: blocks
/// `start..end` (0 = the first data block; `end` capped at the number of blocks) on the
/// regular grid. See the module docs for the steps.
pub fn grid(blocks: Blocks<'_>, start: usize, end: usize) -> crate::error::Result<Grid> {
    let mut reader = blocks.open()?;
    let blocks = reader.all_blocks()?;
    let raw = Gathered {
        blocks,
        channels: reader.channels().len(),
        header_rate_hz: reader.header_rate_hz(),
    };
    Ok(grid_of(&raw, start, end)?)
}

/// [`grid`] of the gathered blocks.
fn grid_of(raw: &Gathered, start: usize, end: usize) -> Result<Grid> {
    let nb = raw.blocks.len();
    let nch = raw.channels;
    let mut g = Grid {
        channels: nch,
        ..Grid::default()
    };
    let (req_start, req_end) = (start, end.min(nb));
    if req_end <= req_start {
        return Ok(g);
    }
    let all_corrupt = || InputError::AllBlocksCorrupt {
        start: req_start,
        end: req_end,
    };
    // GGIRread's header step reads the file's first good block, warning about the corrupt
    // ones before it.
    for ii in 0..nb.min(MAX_CORRUPT + 1) {
        if good(raw, ii).is_some() {
            break;
        }
        g.warnings.push(format!("Skipping corrupt block #{ii}"));
    }
    let (end_ts, end) = end_time(raw, req_start, req_end, &mut g)?;
    let mut start = req_start;
    let mut first = None;
    for _ in 0..(end.saturating_sub(start)).min(MAX_CORRUPT + 1) {
        if let Some(b) = good(raw, start) {
            first = Some(b);
            break;
        }
        g.log.push(QcEntry {
            checksum_pass: false,
            block: start as u64,
            next: start as u64 + 1,
            imputed: false,
        });
        g.warnings
            .push(format!("Skipping corrupt start block #{start}"));
        start += 1;
    }
    let Some(first) = first else {
        return Err(all_corrupt());
    };
    let step = 1.0 / raw.header_rate_hz;
    // GGIRread stops at gaps of 5 days; here the grid may not exceed twice the samples the
    // blocks can hold (plus a minute), so garbage timestamps cannot ask for gigabytes.
    let rows = ((end_ts - first.start_s) / step).floor();
    let cap = 2.0 * ((end - start + 1) * 480) as f64 + 60.0 * raw.header_rate_hz;
    if !(rows <= cap) {
        return Err(InputError::GridTooLong {
            start: req_start,
            end: req_end,
            rows,
        });
    }
    let mut time = seq_by(first.start_s, end_ts, step);
    time.pop();
    let written = fill(raw, &mut g, &time, first, start, end)?;
    time.truncate(written);
    g.values.truncate(written * nch);
    g.temp.truncate(written);
    g.battery.truncate(written);
    g.light.truncate(written);
    g.time = time;
    Ok(g)
}

/// Steps 4–5 over blocks `start+1..=end`; returns the rows written.
fn fill(
    raw: &Gathered,
    g: &mut Grid,
    time: &[f64],
    first: &GoodBlock,
    start: usize,
    end: usize,
) -> Result<usize> {
    let (nb, nch, nr) = (raw.blocks.len(), raw.channels, time.len());
    g.values = vec![0.0; nr * nch];
    (g.temp, g.battery, g.light) = (vec![0.0; nr], vec![0.0; nr], vec![0.0; nr]);
    // R's 1-based rawTime / rawAccel: index 0 unused.
    let (mut raw_t, mut raw_a) = (vec![0.0f64; 2], vec![0.0f64; 2 * nch]);
    let (mut prev, mut cur) = (first, first);
    let (mut prev_start, mut prev_len) = (f64::NAN, 0usize);
    let (mut pos, mut last, mut consecutive, mut started) = (1usize, 0usize, 0usize, false);
    for ii in start + 1..=end {
        let raw_last;
        if ii == nb {
            if prev_start.is_nan() {
                break;
            }
            let new_t =
                (prev.start_s - prev_start) / prev_len as f64 * prev.len(nch) as f64 + prev.start_s;
            prev_len = prev.len(nch);
            raw_last = prev_len + 1;
            set_times(&mut raw_t, prev_start, new_t, raw_last);
        } else {
            let Some(b) = good(raw, ii) else {
                skip_corrupt(g, ii, &mut consecutive)?;
                continue;
            };
            consecutive = 0;
            (prev_start, prev_len, cur) = (prev.start_s, prev.len(nch), b);
            raw_last = prev_len + 1;
            set_times(&mut raw_t, prev_start, cur.start_s, raw_last);
            if !started {
                raw_a[nch..2 * nch].copy_from_slice(&prev.data[..nch]);
                raw_t[1] = prev_start - 0.00001;
                started = true;
            }
        }
        let observed = raw_last as f64 / (raw_t[raw_last] - raw_t[1]);
        let bias = (observed - prev.rate_hz).abs() / prev.rate_hz;
        let impute = (ii < nb
            && cur.sequence != 0
            && i64::from(cur.sequence) - i64::from(prev.sequence) != 1)
            || bias > FREQUENCY_TOL;
        if impute || bias > 0.05 {
            g.log.push(QcEntry {
                checksum_pass: true,
                block: u64::from(prev.sequence),
                next: u64::from(cur.sequence),
                imputed: impute,
            });
        }
        if !impute {
            raw_a.resize((raw_last + 1) * nch, 0.0);
            raw_a[2 * nch..(raw_last + 1) * nch].copy_from_slice(&prev.data);
        }
        let Some(hi) = reach(pos, time, raw_t[raw_last], prev.rate_hz) else {
            break;
        };
        let slice = &time[pos - 1..hi];
        let rows = if impute {
            imputed_rows(&raw_a[nch..nch + 3], nch, slice, raw_t[raw_last])
        } else {
            resample(&raw_a[nch..], nch, &raw_t[1..], slice, raw_last)
        };
        last = write_rows(g, &rows, pos, nch, prev);
        if last >= 1 {
            raw_t[1] = time[last - 1];
            let row: Vec<f64> = g.values[(last - 1) * nch..last * nch].to_vec();
            raw_a[nch..2 * nch].copy_from_slice(&row);
        }
        prev = cur;
        pos = last + 1;
    }
    Ok(last)
}

/// A corrupt block: logged (checksum failed, not imputed) and warned about; too many in a row
/// stop the reading.
fn skip_corrupt(g: &mut Grid, ii: usize, consecutive: &mut usize) -> Result<()> {
    g.log.push(QcEntry {
        checksum_pass: false,
        block: ii as u64,
        next: ii as u64 + 1,
        imputed: false,
    });
    g.warnings.push(format!("Skipping corrupt block #{ii}"));
    *consecutive += 1;
    if *consecutive > MAX_CORRUPT {
        return Err(InputError::TooManyCorruptBlocks {
            block: ii,
            max: MAX_CORRUPT,
        });
    }
    Ok(())
}

/// The grid points (1-based end index) a block may reach from `pos`: 200 ahead, more after a
/// time jump; `None` past the grid's end.
fn reach(pos: usize, time: &[f64], raw_t_last: f64, rate_hz: f64) -> Option<usize> {
    let nr = time.len();
    let mut hi = (pos + 200).min(nr);
    if pos > nr || hi == 0 {
        return None;
    }
    if raw_t_last > time[hi - 1] {
        let jump = raw_t_last - time[hi - 1];
        hi = (hi + (jump * rate_hz).floor() as usize).min(nr);
    }
    Some(hi)
}

/// An imputed gap: the last good sample's direction `v` scaled to 1 g (or straight up when
/// its norm is not near 1 g), for every grid point before `until`.
fn imputed_rows(v: &[f64], nch: usize, slice: &[f64], until: f64) -> Vec<f64> {
    let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let unit = if norm > 0.8 && norm < 1.2 {
        [v[0] / norm, v[1] / norm, v[2] / norm]
    } else {
        [0.0, 0.0, 1.0]
    };
    let n = slice.iter().filter(|&&t| t < until).count();
    let mut r = vec![0.0; n * nch];
    for row in r.chunks_exact_mut(nch) {
        row[..3].copy_from_slice(&unit);
    }
    r
}

/// Writes `rows` at grid row `pos` (1-based) with the block's temperature, battery and
/// light; returns the last row written (1-based; `pos − 1` when none).
fn write_rows(g: &mut Grid, rows: &[f64], pos: usize, nch: usize, block: &GoodBlock) -> usize {
    let n = rows.len() / nch;
    let last = n + pos - 1;
    if n > 0 {
        g.values[(pos - 1) * nch..last * nch].copy_from_slice(rows);
        g.temp[pos - 1..last].fill(block.temp_c);
        g.battery[pos - 1..last].fill(block.battery_v);
        g.light[pos - 1..last].fill(block.light);
    }
    last
}

/// R's `rawTime[2:(n+1)] = seq(a, b, length.out = n)` (growing the vector as R does).
fn set_times(raw_t: &mut Vec<f64>, a: f64, b: f64, n: usize) {
    if raw_t.len() < n + 2 {
        raw_t.resize(n + 2, 0.0);
    }
    for (k, v) in seq_len(a, b, n).enumerate() {
        raw_t[2 + k] = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resample_interpolates_linearly_up_to_the_last_raw_time() {
        let raw = [0.0, 10.0, 20.0];
        let out = resample(&raw, 1, &[0.0, 1.0, 2.0], &[0.5, 1.5, 2.0, 2.5], 3);
        assert_eq!(out, vec![5.0, 15.0, 20.0]);
        assert_eq!(seq_by(0.0, 1.0, 0.25), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        assert_eq!(
            seq_len(0.0, 1.0, 3).collect::<Vec<_>>(),
            vec![0.0, 0.5, 1.0]
        );
    }
}
