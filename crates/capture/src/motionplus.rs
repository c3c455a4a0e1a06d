//! A `wiical capture` of a MotionPlus read back for `wiical gyrofit`: the gyro columns as the
//! adapter sees them.
//!
//! A capture of a MotionPlus ([`crate::output`]) writes per axis the raw 14-bit count
//! and its range bit (`gx,gy,gz`, `gx_slow,gy_slow,gz_slow`; `gx,gy,gz` = pitch, roll, yaw),
//! the 32-byte calibration block in the `# motionplus_cal:` header line, and empty gyro cells
//! in the rows that carry a Nunchuk passed through. A count in the fast range is about 4.5
//! times coarser than a slow one, so fitting the raw counts with one scale would be wrong
//! whenever a turn went past ≈ 440 °/s.
//!
//! Here every gyro row becomes **slow-range counts** with the adapter's own map
//! (`wiical_adapter::motionplus::RangeMap`: the block's when its CRC holds and its ranges are
//! plausible, else the nominal one, as the adapter does), so the calibration `gyrofit` writes
//! is in exactly the units the adapter's `GyroCorrector` applies it to. Rows without gyro data
//! are left out (their accelerometer sample with them: the fit needs both in every sample).
//! The result is an ordinary `t,x,y,z,gx,gy,gz` text the loader reads as any other file.

use anyhow::{anyhow, bail, Context, Result};
use std::fmt::Write as _;
use std::path::Path;
use wiical_adapter::motionplus::{IdealGyroScale, RangeMap};
use wiical_extbus::{MotionPlusCalibration, MotionPlusReport};

/// The header comment that carries the block ([`crate::output::CsvOut::start`]).
const CAL_LINE: &str = "# motionplus_cal: ";
/// How much of a file's start is searched for the header, bytes (a capture's comments and
/// column header take about 1 KiB).
const HEAD_BYTES: u64 = 64 * 1024;
/// The columns a MotionPlus capture has (besides `t`).
const GYRO: [&str; 6] = ["gx", "gy", "gz", "gx_slow", "gy_slow", "gz_slow"];

/// A MotionPlus capture rewritten in slow-range counts.
#[derive(Debug)]
pub struct SlowCounts {
    /// `t,x,y,z,gx,gy,gz` CSV text (gyro in slow-range counts).
    pub text: String,
    /// Gyro rows with at least one axis in the fast range.
    pub fast_rows: usize,
    /// Rows without gyro data (a Nunchuk's, passed through), left out.
    pub without_gyro: usize,
    /// Whether the capture's block was used (`false`: CRC failed or implausible, nominal map).
    pub block_used: bool,
}

/// `Some(block)` when `path` is a `wiical capture` of a MotionPlus (its header has the block
/// line and the `*_slow` columns); `None` for any other file (standard input included: it is
/// read once, by the ordinary loader).
pub fn detect(path: &Path) -> Result<Option<[u8; 32]>> {
    if path.as_os_str() == "-" || !path.is_file() {
        return Ok(None);
    }
    let mut head = Vec::new();
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    std::io::Read::read_to_end(&mut std::io::Read::take(file, HEAD_BYTES), &mut head)?;
    let head = String::from_utf8_lossy(&head);
    let mut block = None;
    for line in head.lines() {
        if let Some(rest) = line.strip_prefix(CAL_LINE) {
            block = Some(parse_block(rest)?);
        } else if !line.starts_with('#') {
            let names: Vec<&str> = line.split(',').map(str::trim).collect();
            let has_gyro = GYRO.iter().all(|c| names.contains(c));
            return Ok(block.filter(|_| has_gyro));
        }
    }
    Ok(None)
}

/// The 32 bytes of `HEX (CRC-32 ok), mode 0x05`.
fn parse_block(rest: &str) -> Result<[u8; 32]> {
    let hex = rest.split('(').next().unwrap_or_default();
    let bytes =
        wiical_factory::parse_hex(hex).map_err(|e| anyhow!("the motionplus_cal line: {e}"))?;
    bytes
        .try_into()
        .map_err(|b: Vec<u8>| anyhow!("the motionplus_cal line has {} bytes, not 32", b.len()))
}

/// The map from a report's counts to slow-range counts: the block's, or the nominal one.
fn range_map(block: &[u8; 32]) -> (RangeMap, bool) {
    match RangeMap::from_block(&MotionPlusCalibration::from_bytes(block)) {
        Some(map) => (map, true),
        None => (RangeMap::nominal(&IdealGyroScale::default()), false),
    }
}

/// Rewrites the capture `text` in slow-range counts (see the module docs).
pub fn to_slow_counts(text: &str, block: &[u8; 32]) -> Result<SlowCounts> {
    let (map, block_used) = range_map(block);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| anyhow!("no column header"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| {
        names
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| anyhow!("no {name} column"))
    };
    let keep = ["t", "x", "y", "z"].map(col);
    let keep: Vec<usize> = keep.into_iter().collect::<Result<_>>()?;
    let gyro: Vec<usize> = GYRO.map(col).into_iter().collect::<Result<_>>()?;
    let mut out = SlowCounts {
        text: String::with_capacity(text.len()),
        fast_rows: 0,
        without_gyro: 0,
        block_used,
    };
    out.text.push_str("t,x,y,z,gx,gy,gz\n");
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let field = |k: usize| f.get(k).copied().unwrap_or_default();
        if gyro[..3].iter().all(|&k| field(k).is_empty()) {
            out.without_gyro += 1;
            continue;
        }
        let report = report(&gyro.iter().map(|&k| field(k)).collect::<Vec<_>>())
            .with_context(|| format!("line {}", i + 1))?;
        out.fast_rows += usize::from(report.slow.iter().any(|s| !s));
        // `[yaw, roll, pitch]` = gz, gy, gx.
        let [yaw, roll, pitch] = map.slow_counts(&report);
        let kept: Vec<&str> = keep.iter().map(|&k| field(k)).collect();
        writeln!(out.text, "{},{pitch},{roll},{yaw}", kept.join(","))?;
    }
    Ok(out)
}

/// A report from the six cells `gx,gy,gz,gx_slow,gy_slow,gz_slow`.
fn report(cells: &[&str]) -> Result<MotionPlusReport> {
    let count = |s: &str| -> Result<u16> {
        match s.parse::<u16>() {
            Ok(v) if v <= wiical_extbus::motionplus::MAX_14BIT => Ok(v),
            _ => bail!("{s:?} is not a 14-bit MotionPlus count"),
        }
    };
    let bit = |s: &str| -> Result<bool> {
        match s {
            "1" => Ok(true),
            "0" => Ok(false),
            _ => bail!("{s:?} is not a range bit (0 or 1)"),
        }
    };
    let &[gx, gy, gz, sx, sy, sz] = cells else {
        bail!("six gyro cells expected");
    };
    Ok(MotionPlusReport {
        rate: [count(gz)?, count(gy)?, count(gx)?],
        slow: [bit(sz)?, bit(sy)?, bit(sx)?],
        extension_connected: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use wiical_extbus::motionplus::RangeCalibration;

    /// A block with slow zero 8200 and fast zero 8180 on every axis, 20 slow counts per °/s
    /// and 4 fast ones (ratio 5).
    fn block() -> [u8; 32] {
        let range = |zero: u16, cpd: u16, deg: u16| RangeCalibration {
            zero: [zero * 4; 3],
            scale: [(zero + cpd * deg) * 4; 3],
            degrees_div_6: (deg / 6) as u8,
        };
        MotionPlusCalibration {
            fast: range(8180, 4, 1200),
            slow: range(8200, 20, 270),
            uid: [1, 2],
        }
        .to_bytes()
    }

    #[test]
    fn fast_counts_go_onto_the_slow_scale_and_rows_without_gyro_are_left_out() {
        let text =
            "# motionplus_cal: x\nt,x,y,z,ext_x,ext_y,ext_z,gx,gy,gz,gx_slow,gy_slow,gz_slow\n\
                    0.0,500,510,620,,,,8200,8300,8180,1,1,0\n\
                    0.01,501,512,622,514,498,716,,,,,,\n\
                    0.02,502,514,624,,,,8190,8180,8181,0,0,1\n";
        let s = to_slow_counts(text, &block()).unwrap();
        assert!(s.block_used);
        assert_eq!(s.without_gyro, 1);
        assert_eq!(s.fast_rows, 2);
        // gz 8180 fast = the fast zero = the slow zero 8200; gx 8190 fast: 8200 + 10·5;
        // gy 8180 fast: 8200 + 0·5.
        assert_eq!(
            s.text,
            "t,x,y,z,gx,gy,gz\n0.0,500,510,620,8200,8300,8200\n0.02,502,514,624,8250,8200,8181\n"
        );
    }

    #[test]
    fn a_block_with_a_bad_crc_falls_back_to_the_nominal_map() {
        let mut b = block();
        b[3] ^= 1;
        let text = "t,x,y,z,gx,gy,gz,gx_slow,gy_slow,gz_slow\n0,1,2,3,8193,8192,8192,0,1,1\n";
        let s = to_slow_counts(text, &b).unwrap();
        assert!(!s.block_used);
        // Nominal: zero 8192 in both ranges, ratio (8192/440)/(8192/2000) = 4.545…
        let gx: f64 = s
            .text
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(4)
            .unwrap()
            .parse()
            .unwrap();
        assert!((gx - (8192.0 + 2000.0 / 440.0)).abs() < 1e-3, "{gx}");
    }

    #[test]
    fn bad_cells_are_refused_with_their_line() {
        let text = "t,x,y,z,gx,gy,gz,gx_slow,gy_slow,gz_slow\n0,1,2,3,8193,,8192,0,1,1\n";
        let e = to_slow_counts(text, &block()).unwrap_err();
        assert!(format!("{e:#}").contains("line 2"), "{e:#}");
        let text = "t,x,y,z,gx,gy,gz,gx_slow,gy_slow,gz_slow\n0,1,2,3,8193,1,8192,0,2,1\n";
        assert!(to_slow_counts(text, &block()).is_err());
    }
}
