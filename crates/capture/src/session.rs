//! Request/reply exchanges with a remote: status, memory reads and writes, and the start-up
//! sequence of a capture (calibration blocks, extension init and identification).

use super::hid::{
    self, error_meaning, hex, parse_input, AddressSpace, InputReport, ReportError, Status,
    EXT_CALIBRATION, EXT_ID, EXT_INIT1, EXT_INIT2, MAX_INPUT_LEN, MP_CALIBRATION, MP_ID, MP_INIT,
    MP_MODE, OUT_WRITE_MEMORY,
};
use super::io::WiimoteIo;
use anyhow::{anyhow, bail, Context, Result};
use wiical_extbus::motionplus::PassthroughMode;
use wiical_extbus::wiimote::EEPROM_CALIBRATION_ADDR;
use wiical_extbus::ReportId;

/// The data report mode a capture uses: `0x35`, core buttons + accelerometer + 16 extension
/// bytes (the first 6 are the Nunchuk report).
pub const CAPTURE_MODE: ReportId = ReportId::ButtonsAccelExt16;

/// What the start-up sequence learnt about the remote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceSetup {
    /// The transport's description of the device.
    pub description: String,
    /// The 20 EEPROM bytes `0x0016`–`0x0029`: the accelerometer calibration block and its copy.
    pub eeprom_calibration: Vec<u8>,
    /// The extension, if one was connected.
    pub extension: Option<ExtensionSetup>,
    /// Battery byte of the first status report.
    pub battery: u8,
    /// The MotionPlus, if one answered at `0xA600FA` (it is active once the setup is done).
    pub motionplus: Option<MotionPlusSetup>,
}

/// A MotionPlus found and activated during the start-up sequence.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MotionPlusSetup {
    /// Its identification bytes as read while inactive (`?? 00 A6 20 00 05`).
    pub id: [u8; 6],
    /// The 32 calibration bytes `0xA60020`–`0xA6003F`.
    pub calibration: Vec<u8>,
    /// The mode it was activated in: Nunchuk pass-through when a Nunchuk is plugged into it,
    /// else gyro only.
    pub mode: PassthroughMode,
}

/// Whether 6 ID bytes are an inactive MotionPlus's: `?? 00 A6 20 ?? 05` (WiiBrew; Dolphin
/// notes the first byte is 1 on a Wii Remote Plus with the MotionPlus built in).
pub fn is_motionplus_id(id: &[u8]) -> bool {
    matches!(id, [_, 0x00, 0xA6, 0x20, _, 0x05])
}

/// A connected extension.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExtensionSetup {
    /// The 6 identification bytes at `0xA400FA`.
    pub id: [u8; 6],
    /// The 32 bytes `0xA40020`–`0xA4003F` (calibration block and its copy) if it is a Nunchuk.
    pub nunchuk_calibration: Option<Vec<u8>>,
}

impl ExtensionSetup {
    /// Whether the ID says "Nunchuk": `?? 00 A4 20 00 00`. WiiBrew ("Extension Controllers",
    /// identification table) lists `0000 A420 0000` for the Nunchuk; the first byte is `FF`
    /// on some third-party ones, and the last two bytes name the type.
    pub fn is_nunchuk(&self) -> bool {
        is_nunchuk_id(&self.id)
    }
}

/// See [`ExtensionSetup::is_nunchuk`].
pub fn is_nunchuk_id(id: &[u8; 6]) -> bool {
    id[1..] == [0x00, 0xA4, 0x20, 0x00, 0x00]
}

/// Request/reply helper over a transport.
///
/// Replies are matched by report ID (and, for memory reads, by address); data reports that
/// arrive meanwhile are dropped, unrelated acknowledgements and unknown report IDs are
/// skipped. Status reports update [`Self::extension_connected`].
pub struct Session<'a, D: WiimoteIo + ?Sized> {
    io: &'a mut D,
    /// Longest wait for one reply, milliseconds.
    pub reply_timeout_ms: u32,
    /// Extension state from the latest status report, if one was seen.
    pub extension_connected: Option<bool>,
    /// Reports skipped because their ID is not one the session knows.
    pub unknown_reports: u64,
}

impl<'a, D: WiimoteIo + ?Sized> Session<'a, D> {
    /// A session with a 1 s reply timeout.
    pub fn new(io: &'a mut D) -> Self {
        Self {
            io,
            reply_timeout_ms: 1000,
            extension_connected: None,
            unknown_reports: 0,
        }
    }

    /// The transport.
    pub fn io(&mut self) -> &mut D {
        self.io
    }

    /// Sends an output report.
    pub fn send(&mut self, report: &[u8]) -> Result<()> {
        self.io.write(report)
    }

    /// Reads until `pick` returns `Some` or the reply timeout passes (`what` names the awaited
    /// reply in the error).
    fn wait_for<T>(
        &mut self,
        what: &str,
        mut pick: impl FnMut(&InputReport<'_>) -> Option<Result<T>>,
    ) -> Result<T> {
        let deadline = self.io.now_s() + f64::from(self.reply_timeout_ms) / 1000.0;
        let mut buf = [0u8; MAX_INPUT_LEN + 10];
        loop {
            let left_ms = ((deadline - self.io.now_s()) * 1000.0).ceil();
            if left_ms <= 0.0 {
                bail!(
                    "the Wii Remote did not answer within {} ms (waiting for {what})",
                    self.reply_timeout_ms
                );
            }
            let n = self.io.read_timeout(&mut buf, left_ms.min(1000.0) as i32)?;
            if n == 0 {
                continue;
            }
            let bytes = buf.get(..n).unwrap_or(&buf);
            match parse_input(bytes) {
                Ok(report) => {
                    if let InputReport::Status(s) = report {
                        self.extension_connected = Some(s.extension_connected());
                    }
                    if let Some(r) = pick(&report) {
                        return r;
                    }
                }
                Err(ReportError::Unknown(_)) => self.unknown_reports += 1,
                Err(e @ (ReportError::Short { .. } | ReportError::Empty)) => {
                    return Err(anyhow!(e)).with_context(|| format!("while waiting for {what}"));
                }
            }
        }
    }

    /// Asks for a status report and returns it.
    pub fn request_status(&mut self) -> Result<Status> {
        self.send(&hid::request_status())?;
        self.wait_for("a status report (0x20)", |r| match r {
            InputReport::Status(s) => Some(Ok(*s)),
            _ => None,
        })
    }

    /// Reads `len` bytes at `address`, collecting the `0x21` replies (16 bytes each).
    pub fn read_memory(&mut self, space: AddressSpace, address: u32, len: u16) -> Result<Vec<u8>> {
        let req = hid::read_memory(space, address, len)?;
        self.send(&req)?;
        let len = usize::from(len);
        let mut out = Vec::with_capacity(len);
        let what = format!(
            "the {} read of {len} bytes at 0x{address:06X}",
            space.name()
        );
        while out.len() < len {
            let expected_lo = (address as usize + out.len()) as u16;
            let chunk = self.wait_for(&what, |r| {
                let InputReport::ReadReply(rr) = r else {
                    return None;
                };
                if rr.error != 0 {
                    return Some(Err(anyhow!(
                        "the Wii Remote refused the {} read at 0x{:06X}: error {} ({})",
                        space.name(),
                        address as usize + out.len(),
                        rr.error,
                        error_meaning(rr.error)
                    )));
                }
                if rr.address_lo != expected_lo {
                    return Some(Err(anyhow!(
                        "read reply for address 0x..{:04X}, expected 0x..{expected_lo:04X} (a reply to another request?)",
                        rr.address_lo
                    )));
                }
                if out.len() + rr.size > len {
                    return Some(Err(anyhow!(
                        "read reply carries {} bytes, only {} were still expected",
                        rr.size,
                        len - out.len()
                    )));
                }
                Some(Ok(rr.data.to_vec()))
            })?;
            out.extend_from_slice(&chunk);
        }
        Ok(out)
    }

    /// Writes 1–16 bytes at `address` and waits for the acknowledgement of report `0x16`.
    pub fn write_memory(&mut self, space: AddressSpace, address: u32, data: &[u8]) -> Result<()> {
        let req = hid::write_memory(space, address, data)?;
        self.send(&req)?;
        let what = format!("the acknowledgement of the write at 0x{address:06X}");
        self.wait_for(&what, |r| match r {
            InputReport::Ack(a) if a.report == OUT_WRITE_MEMORY => Some(if a.error == 0 {
                Ok(())
            } else {
                Err(anyhow!(
                    "the Wii Remote refused the {} write at 0x{address:06X}: error {} ({})",
                    space.name(),
                    a.error,
                    error_meaning(a.error)
                ))
            }),
            _ => None,
        })
    }

    /// Puts the remote in continuous reporting mode [`CAPTURE_MODE`]. No acknowledgement is
    /// requested (the remote sends none unless asked).
    pub fn start_reporting(&mut self) -> Result<()> {
        self.send(&hid::set_report_mode(CAPTURE_MODE, true))
    }

    /// Unencrypted extension init (`0x55` → `0xA400F0`, `0x00` → `0xA400FB`; WiiBrew,
    /// "Extension Controllers", "The New Way"), then its 6 ID bytes and, for a Nunchuk, its
    /// 32 calibration bytes (block at `0xA40020` and copy at `0xA40030`).
    pub fn init_extension(&mut self) -> Result<ExtensionSetup> {
        self.write_memory(AddressSpace::Registers, EXT_INIT1, &[0x55])
            .context("extension init")?;
        self.write_memory(AddressSpace::Registers, EXT_INIT2, &[0x00])
            .context("extension init")?;
        let id_bytes = self
            .read_memory(AddressSpace::Registers, EXT_ID, 6)
            .context("reading the extension ID")?;
        let mut id = [0u8; 6];
        id.copy_from_slice(
            id_bytes
                .get(..6)
                .ok_or_else(|| anyhow!("short extension ID"))?,
        );
        let nunchuk_calibration = if is_nunchuk_id(&id) {
            Some(
                self.read_memory(AddressSpace::Registers, EXT_CALIBRATION, 32)
                    .context("reading the Nunchuk calibration")?,
            )
        } else {
            None
        };
        Ok(ExtensionSetup {
            id,
            nunchuk_calibration,
        })
    }

    /// Looks for a MotionPlus: its ID at `0xA600FA` (a refused read means none, or one that is
    /// already active) and, if found, its 32 calibration bytes at `0xA60020`.
    pub fn probe_motionplus(&mut self) -> Result<Option<([u8; 6], Vec<u8>)>> {
        let Ok(id_bytes) = self.read_memory(AddressSpace::Registers, MP_ID, 6) else {
            return Ok(None);
        };
        if !is_motionplus_id(&id_bytes) {
            return Ok(None);
        }
        let mut id = [0u8; 6];
        id.copy_from_slice(&id_bytes);
        let calibration = self
            .read_memory(AddressSpace::Registers, MP_CALIBRATION, 32)
            .context("reading the MotionPlus calibration")?;
        Ok(Some((id, calibration)))
    }

    /// Initialises and activates the MotionPlus: `0x55` → `0xA600F0`, then the mode byte →
    /// `0xA600FE` (WiiBrew; the extension on its port is reached through it from then on).
    pub fn activate_motionplus(&mut self, mode: PassthroughMode) -> Result<()> {
        self.write_memory(AddressSpace::Registers, MP_INIT, &[0x55])
            .context("MotionPlus init")?;
        self.write_memory(AddressSpace::Registers, MP_MODE, &[mode as u8])
            .context("MotionPlus activation")
    }

    /// The start-up sequence: LED 1 on, status (is an extension connected?), EEPROM
    /// calibration (20 bytes at `0x0016`: block and copy), extension init + ID + calibration,
    /// and finally continuous reporting in mode `0x35`. Reporting is switched on last so that
    /// the replies are not interleaved with 100 data reports a second.
    pub fn init(&mut self) -> Result<DeviceSetup> {
        self.send(&hid::set_leds(0b0001))?;
        let status = self.request_status()?;
        let eeprom_calibration = self
            .read_memory(AddressSpace::Eeprom, u32::from(EEPROM_CALIBRATION_ADDR), 20)
            .context("reading the accelerometer calibration from the EEPROM")?;
        // While inactive, a MotionPlus passes 0xA4 traffic through to the extension on its
        // port, so the extension is set up the usual way first.
        let probed = self.probe_motionplus()?;
        let extension = if status.extension_connected() {
            Some(self.init_extension()?)
        } else {
            None
        };
        let motionplus = match probed {
            Some((id, calibration)) => {
                let nunchuk = extension.as_ref().is_some_and(ExtensionSetup::is_nunchuk);
                let mode = if nunchuk {
                    PassthroughMode::Nunchuk
                } else {
                    PassthroughMode::None
                };
                self.activate_motionplus(mode)?;
                Some(MotionPlusSetup {
                    id,
                    calibration,
                    mode,
                })
            }
            None => None,
        };
        self.start_reporting()?;
        Ok(DeviceSetup {
            description: self.io.describe(),
            eeprom_calibration,
            extension,
            battery: status.battery,
            motionplus,
        })
    }
}

/// The extension ID as hex with its meaning, for messages.
pub fn describe_extension(id: &[u8; 6]) -> String {
    let kind = if is_nunchuk_id(id) {
        "Nunchuk"
    } else {
        match id[4..] {
            [0x01, 0x01] => "Classic Controller",
            _ => "not a Nunchuk",
        }
    };
    format!("{} ({kind})", hex(id))
}
