//! What a capture writes: the CSV (`t,x,y,z` + `ext_x,ext_y,ext_z` with a Nunchuk; raw counts; `# key: value`
//! header comments with the factory calibrations) and the side file `FILE.cal.json`.

use super::guided::PoseRecord;
use super::session::{describe_extension, DeviceSetup};
use anyhow::Result;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use wiical_extbus::motionplus::MotionPlusReport;

/// Where the calibration side file of a recording written to `path` goes:
/// `path` + `.cal.json` (like `simulate`'s `FILE.truth.json`).
pub fn cal_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".cal.json");
    PathBuf::from(p)
}

pub use wiical_factory::{
    motionplus_calibration, nunchuk_calibration, wiimote_calibration, BlockCopy,
    FactoryCalibration, GyroRange, MotionPlusFactory,
};

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
        wiical_io::write::write_file(path, text.as_bytes()).map_err(anyhow::Error::new)
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
