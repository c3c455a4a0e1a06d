//! [`ReplayWiimote`]: a fake Wii Remote for tests and demonstrations. It answers memory reads
//! from a canned EEPROM / register map the way the real remote does (chunks of 16 bytes in
//! `0x21` replies, error codes for unmapped addresses), acknowledges writes with `0x22`,
//! answers status requests, records every output report, and plays back a script of timed
//! input reports (data reports, status reports for extension plug/unplug, or any bytes).
//!
//! Its clock is simulated: reading with a timeout when the next scripted report is later
//! advances the clock by the timeout and returns 0, so timeouts are deterministic and tests
//! never sleep.

use super::hid::{
    AddressSpace, IN_ACK, IN_READ_REPLY, IN_STATUS, OUT_READ_MEMORY, OUT_REPORT_MODE,
    OUT_STATUS_REQUEST, OUT_WRITE_MEMORY, STATUS_EXTENSION,
};
use super::io::WiimoteIo;
use anyhow::{bail, Result};
use std::collections::{BTreeMap, VecDeque};
use wiical_extbus::{Buttons, CoreReport, NunchukReport, ReportId};

/// A memory read request as the fake received it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadRequest {
    /// Address space.
    pub space: AddressSpace,
    /// Start address.
    pub address: u32,
    /// Number of bytes.
    pub len: u16,
}

/// Replaces the fake's answer to a read request: return `Some(reports)` to send those input
/// reports instead (e.g. an error nibble, a short report, nothing at all), `None` to answer
/// normally.
pub type ReadHook = Box<dyn FnMut(&ReadRequest) -> Option<Vec<Vec<u8>>>>;

/// What a read does after the last scripted report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EndOfScript {
    /// The link is lost (read returns an error), like a remote switched off.
    Disconnect,
    /// Nothing more arrives (reads time out).
    Silence,
}

/// The fake remote.
pub struct ReplayWiimote {
    eeprom: BTreeMap<u32, u8>,
    registers: BTreeMap<u32, u8>,
    extension_connected: bool,
    replies: VecDeque<Vec<u8>>,
    script: VecDeque<(f64, Vec<u8>)>,
    clock: f64,
    end: EndOfScript,
    /// Every output report received, in order.
    pub written: Vec<Vec<u8>>,
    /// Optional override of read replies.
    pub read_hook: Option<ReadHook>,
    /// If set, memory writes are acknowledged with this error code.
    pub write_error: Option<u8>,
}

impl ReplayWiimote {
    /// A remote with nothing in memory, no extension and an empty script.
    pub fn new() -> Self {
        Self {
            eeprom: BTreeMap::new(),
            registers: BTreeMap::new(),
            extension_connected: false,
            replies: VecDeque::new(),
            script: VecDeque::new(),
            clock: 0.0,
            end: EndOfScript::Disconnect,
            written: Vec::new(),
            read_hook: None,
            write_error: None,
        }
    }

    /// Stores `bytes` in the EEPROM at `address`.
    pub fn with_eeprom(mut self, address: u32, bytes: &[u8]) -> Self {
        for (i, &b) in bytes.iter().enumerate() {
            self.eeprom.insert(address + i as u32, b);
        }
        self
    }

    /// Stores `bytes` in the register space at `address` (e.g. `0xA40020`).
    pub fn with_registers(mut self, address: u32, bytes: &[u8]) -> Self {
        for (i, &b) in bytes.iter().enumerate() {
            self.registers.insert(address + i as u32, b);
        }
        self
    }

    /// Plugs a Nunchuk in: ID `00 00 A4 20 00 00` at `0xA400FA` and the 16-byte calibration
    /// block at `0xA40020` and again at `0xA40030`.
    pub fn with_nunchuk(self, calibration: &[u8; 16]) -> Self {
        let mut s = self
            .with_registers(0xA4_00FA, &wiical_extbus::nunchuk::ID)
            .with_registers(0xA4_0020, calibration)
            .with_registers(0xA4_0030, calibration);
        s.extension_connected = true;
        s
    }

    /// Plugs a MotionPlus in (inactive, at `0xA6xxxx`): ID `00 00 A6 20 00 05` at `0xA600FA`
    /// and its 32-byte calibration block at `0xA60020`. It answers like any register map:
    /// activation writes are acknowledged (what the remote sends afterwards is up to the
    /// script, e.g. [`report_0x35_ext`] with MotionPlus frames).
    pub fn with_motionplus(self, calibration: &[u8; 32]) -> Self {
        self.with_registers(0xA6_00FA, &wiical_extbus::motionplus::ID_INACTIVE)
            .with_registers(0xA6_0020, calibration)
    }

    /// Appends a timed input report to the script (times must not decrease; the first
    /// report's time is when the capture's clock starts counting, usually 0).
    pub fn push_report(&mut self, t: f64, report: Vec<u8>) {
        self.script.push_back((t, report));
    }

    /// Sets what happens after the script.
    pub fn with_end(mut self, end: EndOfScript) -> Self {
        self.end = end;
        self
    }

    /// Number of scripted reports not yet read.
    pub fn remaining(&self) -> usize {
        self.script.len()
    }

    fn answer_read(&mut self, req: ReadRequest) {
        if let Some(hook) = self.read_hook.as_mut() {
            if let Some(reports) = hook(&req) {
                self.replies.extend(reports);
                return;
            }
        }
        let (map, missing_error) = match req.space {
            AddressSpace::Eeprom => (&self.eeprom, 8u8),
            AddressSpace::Registers => (&self.registers, 7u8),
        };
        let no_extension = req.space == AddressSpace::Registers
            && (req.address >> 16) == 0xA4
            && !self.extension_connected;
        let mut done = 0u32;
        while done < u32::from(req.len) {
            let addr = req.address + done;
            let size = (u32::from(req.len) - done).min(16);
            let mut r = vec![0u8; 22];
            r[0] = IN_READ_REPLY;
            r[4..6].copy_from_slice(&(addr as u16).to_be_bytes());
            let bytes: Option<Vec<u8>> = (0..size).map(|i| map.get(&(addr + i)).copied()).collect();
            match bytes {
                Some(b) if !no_extension => {
                    r[3] = ((size as u8 - 1) << 4) & 0xF0;
                    r[6..6 + b.len()].copy_from_slice(&b);
                    self.replies.push_back(r);
                }
                _ => {
                    // One error reply ends the read (size nibble F, as Dolphin sends).
                    r[3] = 0xF0 | missing_error;
                    self.replies.push_back(r);
                    return;
                }
            }
            done += size;
        }
    }

    fn answer_write(&mut self, report: &[u8]) {
        let error = match report {
            [_, mm, a2, a1, a0, size, data @ ..] if usize::from(*size) <= data.len() => {
                let address = u32::from_be_bytes([0, *a2, *a1, *a0]);
                if *mm == AddressSpace::Registers.byte() {
                    if (address >> 16) == 0xA4 && !self.extension_connected {
                        7
                    } else {
                        for (i, &b) in data[..usize::from(*size)].iter().enumerate() {
                            // The ID and calibration are read-only on a real Nunchuk.
                            let a = address + i as u32;
                            if !matches!(a & 0xFF, 0x20..=0x3F | 0xFA..=0xFF) {
                                self.registers.insert(a, b);
                            }
                        }
                        0
                    }
                } else {
                    0
                }
            }
            _ => 8,
        };
        let error = self.write_error.unwrap_or(error);
        self.replies
            .push_back(vec![IN_ACK, 0x00, 0x00, OUT_WRITE_MEMORY, error]);
    }
}

impl Default for ReplayWiimote {
    fn default() -> Self {
        Self::new()
    }
}

impl WiimoteIo for ReplayWiimote {
    fn write(&mut self, report: &[u8]) -> Result<()> {
        self.written.push(report.to_vec());
        match report {
            [OUT_STATUS_REQUEST, ..] => {
                self.replies
                    .push_back(status_report(self.extension_connected));
            }
            [OUT_READ_MEMORY, mm, a2, a1, a0, s1, s0, ..] => {
                let space = if mm & 0x04 != 0 {
                    AddressSpace::Registers
                } else {
                    AddressSpace::Eeprom
                };
                self.answer_read(ReadRequest {
                    space,
                    address: u32::from_be_bytes([0, *a2, *a1, *a0]),
                    len: u16::from_be_bytes([*s1, *s0]),
                });
            }
            [OUT_WRITE_MEMORY, ..] => self.answer_write(report),
            [OUT_REPORT_MODE, ..] | [_, ..] => {}
            [] => bail!("empty output report"),
        }
        Ok(())
    }

    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize> {
        let report = if let Some(r) = self.replies.pop_front() {
            r
        } else {
            let wait = f64::from(ms.max(0)) / 1000.0;
            match self.script.front() {
                Some((t, _)) if *t <= self.clock + wait => {
                    let (t, r) = self.script.pop_front().unwrap_or_default();
                    self.clock = self.clock.max(t);
                    // A scripted status report is an extension plug/unplug event.
                    if let [IN_STATUS, _, _, flags, ..] = r.as_slice() {
                        self.extension_connected = flags & STATUS_EXTENSION != 0;
                    }
                    r
                }
                Some(_) => {
                    self.clock += wait;
                    return Ok(0);
                }
                None => match self.end {
                    EndOfScript::Disconnect => {
                        bail!("lost the Wii Remote: end of the replay script")
                    }
                    EndOfScript::Silence => {
                        self.clock += wait;
                        return Ok(0);
                    }
                },
            }
        };
        let n = report.len().min(buf.len());
        buf[..n].copy_from_slice(&report[..n]);
        Ok(n)
    }

    fn now_s(&self) -> f64 {
        self.clock
    }

    fn describe(&self) -> String {
        "replayed Wii Remote (test script)".to_string()
    }
}

/// A `0x35` data report (core buttons + accelerometer + 16 extension bytes) carrying the
/// remote's accelerometer `wiimote` (10-bit scale; Y and Z lose bit 0 as on the wire) and,
/// if given, a plain Nunchuk report in the first 6 extension bytes (the other 10 are `0x00`).
pub fn report_0x35(wiimote: [u16; 3], nunchuk: Option<&NunchukReport>) -> Vec<u8> {
    let mut ext = [0u8; 16];
    if let Some(n) = nunchuk {
        ext[..6].copy_from_slice(&n.to_bytes());
    } else {
        ext = [0xFF; 16];
    }
    let report = CoreReport {
        id: ReportId::ButtonsAccelExt16,
        buttons: Buttons::empty(),
        accel: Some(wiimote),
        ir: &[],
        ext: &ext,
    };
    let mut out = vec![0u8; ReportId::ButtonsAccelExt16.report_len()];
    // The layout matches by construction; a failure would be a bug in this helper.
    let n = report.encode(&mut out).unwrap_or(0);
    out.truncate(n);
    out
}

/// A `0x35` data report with the accelerometer `wiimote` and these 6 extension bytes (e.g. a
/// MotionPlus frame); the other 10 extension bytes are `0x00`.
pub fn report_0x35_ext(wiimote: [u16; 3], ext6: [u8; 6]) -> Vec<u8> {
    let mut ext = [0u8; 16];
    ext[..6].copy_from_slice(&ext6);
    let report = CoreReport {
        id: ReportId::ButtonsAccelExt16,
        buttons: Buttons::empty(),
        accel: Some(wiimote),
        ir: &[],
        ext: &ext,
    };
    let mut out = vec![0u8; ReportId::ButtonsAccelExt16.report_len()];
    // The layout matches by construction; a failure would be a bug in this helper.
    let n = report.encode(&mut out).unwrap_or(0);
    out.truncate(n);
    out
}

/// A status report (`0x20`) announcing that an extension was plugged in or out.
pub fn status_report(extension_connected: bool) -> Vec<u8> {
    let flags = 0x10
        | if extension_connected {
            STATUS_EXTENSION
        } else {
            0
        };
    vec![IN_STATUS, 0x00, 0x00, flags, 0x00, 0x00, 0xC0]
}
