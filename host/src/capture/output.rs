//! What a capture writes: the CSV (`t,x,y,z` + `ext_x,ext_y,ext_z` with a Nunchuk; raw counts; `# key: value`
//! header comments with the factory calibrations) and the side file `FILE.cal.json`.

use super::guided::PoseRecord;
use super::protocol::hex;
use super::session::{describe_extension, DeviceSetup};
use anyhow::{Context, Result};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use wiical_extbus::motionplus::{MotionPlusCalibration, MotionPlusReport, RangeCalibration};
use wiical_extbus::nunchuk::CalibrationBlock;
use wiical_extbus::wiimote::{EEPROM_CALIBRATION_ADDR, EEPROM_CALIBRATION_BACKUP_ADDR};
use wiical_extbus::{AccelCalibration, CalibrationCopy};

/// Where the calibration side file of a recording written to `path` goes:
/// `path` + `.cal.json` (like `simulate`'s `FILE.truth.json`).
pub fn cal_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".cal.json");
    PathBuf::from(p)
}

/// One stored copy of a calibration block, decoded.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BlockCopy {
    /// Address of the copy (`0x0016`/`0x0020` in the EEPROM, `0xA40020`/`0xA40030` in the
    /// extension registers).
    pub address: String,
    /// The bytes, uppercase hex.
    pub hex: String,
    /// Whether its checksum is correct.
    pub checksum_ok: bool,
    /// Zero-g reading per axis, 10-bit counts.
    pub zero: [u16; 3],
    /// +1 g reading per axis, 10-bit counts.
    pub one_g: [u16; 3],
    /// `one_g − zero`, counts per g.
    pub counts_per_g: [i32; 3],
}

/// A device's factory calibration: both copies, and the one Nintendo's rule picks (the
/// first whose checksum is correct; none if both fail).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FactoryCalibration {
    /// `"wiimote"` or `"nunchuk"`.
    pub device: String,
    /// The two stored copies.
    pub copies: Vec<BlockCopy>,
    /// `"first"`, `"second"`, or null when no checksum passes.
    pub copy_used: Option<String>,
    /// Zero-g of the copy used (null if none passes).
    pub zero: Option<[u16; 3]>,
    /// +1 g of the copy used.
    pub one_g: Option<[u16; 3]>,
    /// Counts per g of the copy used.
    pub counts_per_g: Option<[i32; 3]>,
    /// Nunchuk only: the 8-bit values (the stored high bytes; exact), of the copy used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_8bit: Option<[u8; 3]>,
    /// Nunchuk only: 1-g high bytes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub one_g_8bit: Option<[u8; 3]>,
    /// Nunchuk only: joystick calibration `[max, min, centre]` for X then Y.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stick: Option<[[u8; 3]; 2]>,
    /// Whether the order of the packed low bits is documented (Wii Remote yes; Nunchuk no,
    /// assumed the same, so its 10-bit values may have the low 2 bits permuted between axes).
    pub lsb_order_confirmed: bool,
}

fn copy_name(c: CalibrationCopy) -> String {
    match c {
        CalibrationCopy::First => "first".into(),
        CalibrationCopy::Second => "second".into(),
    }
}

/// Decodes the 20 EEPROM bytes `0x0016`–`0x0029`.
pub fn wiimote_calibration(bytes: &[u8]) -> Result<FactoryCalibration> {
    let addrs = [EEPROM_CALIBRATION_ADDR, EEPROM_CALIBRATION_BACKUP_ADDR];
    let mut copies = Vec::new();
    for (k, a) in addrs.iter().enumerate() {
        let b = bytes
            .get(k * 10..k * 10 + 10)
            .context("EEPROM calibration: 20 bytes expected")?;
        let c = AccelCalibration::decode(b).map_err(|e| anyhow::anyhow!("{e}"))?;
        copies.push(BlockCopy {
            address: format!("0x{a:04X}"),
            hex: hex(b),
            checksum_ok: c.checksum_ok,
            zero: c.value.zero,
            one_g: c.value.one_g,
            counts_per_g: c.value.counts_per_g(),
        });
    }
    let used = AccelCalibration::from_copies(&bytes[..10], &bytes[10..20]).ok();
    Ok(FactoryCalibration {
        device: "wiimote".into(),
        copies,
        copy_used: used.map(|u| copy_name(u.copy)),
        zero: used.map(|u| u.value.zero),
        one_g: used.map(|u| u.value.one_g),
        counts_per_g: used.map(|u| u.value.counts_per_g()),
        zero_8bit: None,
        one_g_8bit: None,
        stick: None,
        lsb_order_confirmed: true,
    })
}

/// Decodes the 32 Nunchuk register bytes `0xA40020`–`0xA4003F`.
pub fn nunchuk_calibration(bytes: &[u8]) -> Result<FactoryCalibration> {
    let mut copies = Vec::new();
    for (k, a) in [0xA4_0020u32, 0xA4_0030].iter().enumerate() {
        let b = bytes
            .get(k * 16..k * 16 + 16)
            .context("Nunchuk calibration: 32 bytes expected")?;
        let c = CalibrationBlock::decode(b).map_err(|e| anyhow::anyhow!("{e}"))?;
        copies.push(BlockCopy {
            address: format!("0x{a:06X}"),
            hex: hex(b),
            checksum_ok: c.checksum_ok,
            zero: c.value.zero,
            one_g: c.value.one_g,
            counts_per_g: c.value.counts_per_g(),
        });
    }
    let used = CalibrationBlock::from_registers(&bytes[..32]).ok();
    Ok(FactoryCalibration {
        device: "nunchuk".into(),
        copies,
        copy_used: used.map(|u| copy_name(u.copy)),
        zero: used.map(|u| u.value.zero),
        one_g: used.map(|u| u.value.one_g),
        counts_per_g: used.map(|u| u.value.counts_per_g()),
        zero_8bit: used.map(|u| u.value.zero_8bit()),
        one_g_8bit: used.map(|u| u.value.one_g_8bit()),
        stick: used.map(|u| {
            let (x, y) = (u.value.stick_x, u.value.stick_y);
            [[x.max, x.min, x.centre], [y.max, y.min, y.centre]]
        }),
        lsb_order_confirmed: false,
    })
}

/// One range (fast or slow) of a MotionPlus calibration block.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GyroRange {
    /// Zero-rate readings `[yaw, roll, pitch]` as stored (16-bit = 14-bit × 4).
    pub zero: [u16; 3],
    /// Readings at the reference rate, as stored.
    pub scale: [u16; 3],
    /// The reference rate, °/s (`degrees_div_6 · 6`).
    pub degrees: u16,
    /// `(scale − zero)/4/degrees`: 14-bit counts per °/s `[yaw, roll, pitch]`, signed as stored
    /// (null when the reference rate is 0).
    pub counts_per_dps: Option<[f32; 3]>,
}

impl GyroRange {
    fn of(r: &RangeCalibration) -> Self {
        Self {
            zero: r.zero,
            scale: r.scale,
            degrees: u16::from(r.degrees_div_6) * 6,
            counts_per_dps: r.counts_per_dps(),
        }
    }
}

/// The MotionPlus's factory calibration (`wiical decode-cal --device motionplus` prints the
/// same fields).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MotionPlusFactory {
    /// The 32 bytes at `0xA60020`, uppercase hex.
    pub hex: String,
    /// Whether the stored CRC-32 matches.
    pub checksum_ok: bool,
    /// Fast (±2000 °/s class) range.
    pub fast: GyroRange,
    /// Slow (±440 °/s class) range.
    pub slow: GyroRange,
    /// The two UID bytes.
    pub uid: [u8; 2],
    /// Capture only: the activation mode byte written to `0xA600FE` (`0x04` gyro only,
    /// `0x05` Nunchuk pass-through).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mode: Option<u8>,
}

/// Decodes a MotionPlus calibration block (32 bytes); `mode` is the activation byte of a
/// capture (none for a block decoded on its own).
pub fn motionplus_calibration(bytes: &[u8], mode: Option<u8>) -> Result<MotionPlusFactory> {
    let c = MotionPlusCalibration::decode(bytes)
        .map_err(|e| anyhow::anyhow!("MotionPlus calibration: {e}"))?;
    Ok(MotionPlusFactory {
        hex: hex(bytes),
        checksum_ok: c.checksum_ok,
        fast: GyroRange::of(&c.value.fast),
        slow: GyroRange::of(&c.value.slow),
        uid: c.value.uid,
        mode,
    })
}

/// Summary of a capture (also in the side file).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaptureStats {
    /// `"duration"` or `"guided"`.
    pub mode: String,
    /// Rows written.
    pub samples: u64,
    /// Time of the last row, s (the first row is at 0).
    pub duration_s: f64,
    /// Mean report rate `(samples − 1) / duration_s`, Hz (null for fewer than 2 samples).
    pub mean_rate_hz: Option<f64>,
    /// Reports that could not be decoded (too short) and were skipped.
    pub bad_reports: u64,
    /// Reports with an ID the capture does not use, skipped.
    pub unknown_reports: u64,
    /// Status reports received during the capture (extension plugged/unplugged).
    pub status_reports: u64,
    /// Guided mode: the poses done.
    pub poses: Vec<PoseRecord>,
    /// Whether the capture ran to its end (false: stopped by an error, the data is partial).
    pub complete: bool,
}

/// The side file `FILE.cal.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalFile {
    /// Format tag.
    pub format: String,
    /// The device, as the transport describes it.
    pub device: String,
    /// The Wii Remote's EEPROM calibration.
    pub wiimote: FactoryCalibration,
    /// The extension ID (hex and meaning), if one was connected.
    pub extension_id: Option<String>,
    /// The Nunchuk's calibration, if a Nunchuk was connected.
    pub nunchuk: Option<FactoryCalibration>,
    /// The MotionPlus's calibration, if one was found (absent from the JSON otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motionplus: Option<MotionPlusFactory>,
    /// What the CSV columns are.
    pub columns: String,
    /// Filled in at the end (null while the capture runs).
    pub capture: Option<CaptureStats>,
}

impl CalFile {
    /// The side file for a device setup.
    pub fn new(setup: &DeviceSetup) -> Result<Self> {
        let wiimote = wiimote_calibration(&setup.eeprom_calibration)?;
        let nunchuk = match setup
            .extension
            .as_ref()
            .and_then(|e| e.nunchuk_calibration.as_ref())
        {
            Some(b) => Some(nunchuk_calibration(b)?),
            None => None,
        };
        let ext = nunchuk.is_some();
        let motionplus = match &setup.motionplus {
            Some(mp) => Some(motionplus_calibration(
                &mp.calibration,
                Some(mp.mode as u8),
            )?),
            None => None,
        };
        let mut columns = columns_doc(ext).to_string();
        if motionplus.is_some() {
            columns.push_str(GYRO_COLUMNS_DOC);
        }
        Ok(Self {
            format: "wiical-capture-calibration/1".into(),
            device: setup.description.clone(),
            wiimote,
            extension_id: setup.extension.as_ref().map(|e| describe_extension(&e.id)),
            nunchuk,
            motionplus,
            columns,
            capture: None,
        })
    }

    /// Writes the file (pretty JSON), atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        wiical_analysis::write::write_file(path, text.as_bytes())
            .map_err(crate::cli_error::cli_error)
    }
}

/// The MotionPlus columns, appended to the column description.
const GYRO_COLUMNS_DOC: &str = "; gx,gy,gz = MotionPlus pitch, roll, yaw rates (Dolphin's x, y, z), raw 14-bit counts, zero near 8192; gx_slow,gy_slow,gz_slow = 1 in the slow (high-resolution) range, 0 in the fast one, whose counts are about 4.5 times coarser; the gyro columns are empty in rows that carry pass-through Nunchuk data, and the Nunchuk columns in rows that carry gyro data (the MotionPlus alternates them)";

fn columns_doc(ext: bool) -> &'static str {
    if ext {
        "t = host monotonic clock, s from the first sample; x,y,z = Wii Remote accelerometer, raw 10-bit counts (Y, Z have 9 significant bits: bit 0 always 0); ext_x,ext_y,ext_z = Nunchuk accelerometer, raw 10-bit counts (empty while it is unplugged)"
    } else {
        "t = host monotonic clock, s from the first sample; x,y,z = Wii Remote accelerometer, raw 10-bit counts (Y, Z have 9 significant bits: bit 0 always 0)"
    }
}

fn fmt3<T: std::fmt::Display>(v: &[T; 3]) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

fn comment_lines(prefix: &str, c: &FactoryCalibration) -> Vec<String> {
    let mut out = Vec::new();
    match (&c.zero, &c.one_g, &c.counts_per_g) {
        (Some(z), Some(g), Some(s)) => {
            out.push(format!("{prefix}_zero: {}", fmt3(z)));
            out.push(format!("{prefix}_one_g: {}", fmt3(g)));
            out.push(format!("{prefix}_counts_per_g: {}", fmt3(s)));
        }
        _ => out.push(format!(
            "{prefix}_cal: none (no copy has a valid checksum; see the hex below)"
        )),
    }
    if let (Some(z), Some(g)) = (&c.zero_8bit, &c.one_g_8bit) {
        out.push(format!("{prefix}_zero_8bit: {}", fmt3(z)));
        out.push(format!("{prefix}_one_g_8bit: {}", fmt3(g)));
    }
    out.push(format!(
        "{prefix}_copy_used: {}",
        c.copy_used.as_deref().unwrap_or("none")
    ));
    for copy in &c.copies {
        out.push(format!(
            "{prefix}_block_{}: {} (checksum {})",
            copy.address,
            copy.hex,
            if copy.checksum_ok { "ok" } else { "BAD" }
        ));
    }
    out
}

/// Writes CSV rows.
pub struct CsvOut<W: Write> {
    w: W,
    ext: bool,
    gyro: bool,
    /// Rows written.
    pub rows: u64,
}

impl<W: Write> CsvOut<W> {
    /// Writes the `# key: value` header comments and the column header.
    pub fn start(mut w: W, cal: &CalFile, cal_file_name: &str) -> Result<Self> {
        let ext = cal.nunchuk.is_some();
        let mut lines = vec![
            "wiical capture: Wii Remote accelerometer over Bluetooth HID (report 0x35, continuous)"
                .to_string(),
            format!("device: {}", cal.device),
        ];
        lines.extend(comment_lines("wiimote_cal", &cal.wiimote));
        if let Some(id) = &cal.extension_id {
            lines.push(format!("extension_id: {id}"));
        }
        if let Some(n) = &cal.nunchuk {
            lines.extend(comment_lines("nunchuk_cal", n));
        }
        let gyro = cal.motionplus.is_some();
        if let Some(mp) = &cal.motionplus {
            lines.push(format!(
                "motionplus_cal: {} (CRC-32 {}), mode 0x{:02X}",
                mp.hex,
                if mp.checksum_ok { "ok" } else { "BAD" },
                mp.mode.unwrap_or(0)
            ));
        }
        lines.push(format!("columns: {}", cal.columns));
        lines.push(format!("calibration_file: {cal_file_name}"));
        for l in lines {
            writeln!(w, "# {l}")?;
        }
        writeln!(
            w,
            "{}{}",
            if ext {
                "t,x,y,z,ext_x,ext_y,ext_z"
            } else {
                "t,x,y,z"
            },
            if gyro {
                ",gx,gy,gz,gx_slow,gy_slow,gz_slow"
            } else {
                ""
            }
        )?;
        Ok(Self {
            w,
            ext,
            gyro,
            rows: 0,
        })
    }

    /// Whether the file has Nunchuk columns.
    pub fn has_ext(&self) -> bool {
        self.ext
    }

    /// One row. `ext` is ignored without Nunchuk columns and `gyro` without MotionPlus
    /// columns; `None` leaves them empty. The MotionPlus's `[yaw, roll, pitch]` go to
    /// `gz, gy, gx`.
    pub fn row(
        &mut self,
        t: f64,
        xyz: [u16; 3],
        ext: Option<[u16; 3]>,
        gyro: Option<&MotionPlusReport>,
    ) -> Result<()> {
        write!(self.w, "{t:.6},{},{},{}", xyz[0], xyz[1], xyz[2])?;
        if self.ext {
            match ext {
                Some(e) => write!(self.w, ",{},{},{}", e[0], e[1], e[2])?,
                None => write!(self.w, ",,,")?,
            }
        }
        if self.gyro {
            match gyro {
                Some(g) => {
                    let [yaw, roll, pitch] = g.rate;
                    let [ys, rs, ps] = g.slow.map(u8::from);
                    write!(self.w, ",{pitch},{roll},{yaw},{ps},{rs},{ys}")?
                }
                None => write!(self.w, ",,,,,,")?,
            }
        }
        writeln!(self.w)?;
        self.rows += 1;
        Ok(())
    }

    /// A `# …` comment line between rows (events such as an unplugged extension).
    pub fn comment(&mut self, text: &str) -> Result<()> {
        writeln!(self.w, "# {text}")?;
        Ok(())
    }

    /// Flushes the writer.
    pub fn flush(&mut self) -> Result<()> {
        self.w.flush()?;
        Ok(())
    }
}
