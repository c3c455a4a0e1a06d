//! Byte formats of the Wii Remote's Bluetooth HID reports that `capture` uses.
//!
//! Sources: WiiBrew, "Wiimote" and "Wiimote/Protocol" (sections "Reports", "Status
//! Reporting", "Data Reporting", "Reading and Writing", "EEPROM Memory", "Control
//! Registers"), and the Dolphin emulator's `Source/Core/Core/HW/WiimoteCommon/WiimoteConstants.h`
//! (address spaces and the error codes of the read-memory reply).
//!
//! Every report is given as hidapi sees it: report ID first, without the Bluetooth HID
//! transaction header (`0xA2` for output, `0xA1` for input) that the HID layer adds and strips.
//! The lowest bit of the first payload byte of every output report is the rumble motor;
//! `capture` always sends it clear.
//!
//! | direction | ID | payload | meaning |
//! |---|---|---|---|
//! | out | `0x11` | `LL` | player LEDs in bits 4–7 (LED 1 = `0x10`) |
//! | out | `0x12` | `TT MM` | data reporting mode `MM`; `TT` bit 2 = continuous (report even if nothing changed) |
//! | out | `0x15` | `00` | request a status report (`0x20`) |
//! | out | `0x16` | `MM AA AA AA SS D×16` | write `SS` (1–16) bytes at the 24-bit big-endian address; `MM` = `0x00` EEPROM, `0x04` control registers |
//! | out | `0x17` | `MM AA AA AA SS SS` | read `SS SS` (big-endian) bytes; answered by one `0x21` per 16 bytes |
//! | in | `0x20` | `BB BB LF 00 00 VV` | status: `LF` bit 1 = extension connected, bits 4–7 LEDs; `VV` battery |
//! | in | `0x21` | `BB BB SE AA AA D×16` | read reply: `S` = size − 1, `E` = error, `AA AA` = low 16 bits of the address of the first byte |
//! | in | `0x22` | `BB BB RR EE` | acknowledgement of output report `RR` with error `EE` |
//! | in | `0x30`–`0x37` | see [`wiical_extbus::wiimote`] | data reports (buttons, accelerometer, IR, extension bytes) |
//!
//! A status report that arrives unrequested (extension plugged or unplugged) resets the data
//! reporting: WiiBrew says the host must send `0x12` again or no more data reports come.

use std::fmt;
use wiical_extbus::{Buttons, CoreReport, ReportId};

/// Nintendo's Bluetooth vendor ID.
pub const VENDOR_ID: u16 = 0x057E;
/// Product IDs of the Wii Remote: `0x0306` (RVL-CNT-01) and `0x0330` (RVL-CNT-01-TR, the
/// "Wii Remote Plus" with built-in MotionPlus).
pub const PRODUCT_IDS: [u16; 2] = [0x0306, 0x0330];

/// Output report: player LEDs.
pub const OUT_LEDS: u8 = 0x11;
/// Output report: data reporting mode.
pub const OUT_REPORT_MODE: u8 = 0x12;
/// Output report: status request.
pub const OUT_STATUS_REQUEST: u8 = 0x15;
/// Output report: write memory or registers.
pub const OUT_WRITE_MEMORY: u8 = 0x16;
/// Output report: read memory or registers.
pub const OUT_READ_MEMORY: u8 = 0x17;
/// Input report: status.
pub const IN_STATUS: u8 = 0x20;
/// Input report: read-memory reply.
pub const IN_READ_REPLY: u8 = 0x21;
/// Input report: acknowledgement / result of an output report.
pub const IN_ACK: u8 = 0x22;

/// Length of a status report, ID included.
pub const STATUS_LEN: usize = 7;
/// Length of a read-memory reply, ID included.
pub const READ_REPLY_LEN: usize = 22;
/// Length of an acknowledgement report, ID included.
pub const ACK_LEN: usize = 5;
/// Length of a write-memory output report, ID included (the data field is always 16 bytes).
pub const WRITE_MEMORY_LEN: usize = 22;
/// Largest input report of the Wii Remote, ID included (buffers are sized with margin).
pub const MAX_INPUT_LEN: usize = 22;

/// Flag in the status byte `LF`: an extension is connected.
pub const STATUS_EXTENSION: u8 = 0x02;

/// Where a memory read or write goes (the `MM` byte of `0x16`/`0x17`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AddressSpace {
    /// The remote's EEPROM (`MM = 0x00`): calibration at `0x0016` and `0x0020`, Mii data, …
    Eeprom,
    /// Control registers of the peripherals on the I²C bus (`MM = 0x04`): speaker `0xA2…`,
    /// extension `0xA4…`, IR camera `0xB0…`.
    Registers,
}

impl AddressSpace {
    /// The `MM` byte (rumble bit clear).
    pub const fn byte(self) -> u8 {
        match self {
            AddressSpace::Eeprom => 0x00,
            AddressSpace::Registers => 0x04,
        }
    }

    /// Short name for messages.
    pub const fn name(self) -> &'static str {
        match self {
            AddressSpace::Eeprom => "EEPROM",
            AddressSpace::Registers => "registers",
        }
    }
}

/// Register of the extension: first byte of the unencrypted-init sequence (write `0x55`).
pub const EXT_INIT1: u32 = 0xA4_00F0;
/// Register of the extension: second byte of the unencrypted-init sequence (write `0x00`).
pub const EXT_INIT2: u32 = 0xA4_00FB;
/// Register of the 6 extension identification bytes.
pub const EXT_ID: u32 = 0xA4_00FA;
/// Register of the extension's calibration block (16 bytes; the copy follows at `0xA40030`).
pub const EXT_CALIBRATION: u32 = 0xA4_0020;

/// An inactive MotionPlus's identification bytes (`00 00 A6 20 00 05`; a read fails with
/// error 7 when there is no MotionPlus or it is already active).
pub const MP_ID: u32 = 0xA6_00FA;
/// An inactive MotionPlus's 32-byte calibration block.
pub const MP_CALIBRATION: u32 = 0xA6_0020;
/// MotionPlus init register (write `0x55`).
pub const MP_INIT: u32 = 0xA6_00F0;
/// MotionPlus mode register: writing `0x04`/`0x05`/`0x07` activates it (alone, Nunchuk or
/// Classic pass-through).
pub const MP_MODE: u32 = 0xA6_00FE;

/// Largest address the 24-bit address field can carry.
pub const MAX_ADDRESS: u32 = 0xFF_FFFF;

/// `0x11`: light the LEDs in `mask` (bit 0 = LED 1 … bit 3 = LED 4). Lighting one stops the
/// blinking of a freshly connected remote, so the user sees which one is recording.
pub const fn set_leds(mask: u8) -> [u8; 2] {
    [OUT_LEDS, (mask & 0x0F) << 4]
}

/// `0x12`: select the data report `mode`, continuous (a report every ~10 ms even when nothing
/// changes, which a recording of a still remote needs) or on change only.
pub const fn set_report_mode(mode: ReportId, continuous: bool) -> [u8; 3] {
    [
        OUT_REPORT_MODE,
        if continuous { 0x04 } else { 0x00 },
        mode as u8,
    ]
}

/// `0x15`: ask for a status report.
pub const fn request_status() -> [u8; 2] {
    [OUT_STATUS_REQUEST, 0x00]
}

/// Why an output report could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RequestError {
    /// The address does not fit 24 bits.
    AddressTooLarge(u32),
    /// A write carries 1 to 16 bytes.
    BadWriteLength(usize),
    /// A read asks for at least 1 byte (and the request ends inside the 24-bit space).
    BadReadLength(usize),
}

impl fmt::Display for RequestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RequestError::AddressTooLarge(a) => write!(f, "address 0x{a:X} does not fit 24 bits"),
            RequestError::BadWriteLength(n) => {
                write!(f, "a memory write carries 1 to 16 bytes, not {n}")
            }
            RequestError::BadReadLength(n) => write!(f, "invalid memory read length {n}"),
        }
    }
}

impl std::error::Error for RequestError {}

fn address_bytes(address: u32) -> Result<[u8; 3], RequestError> {
    if address > MAX_ADDRESS {
        return Err(RequestError::AddressTooLarge(address));
    }
    let [_, a, b, c] = address.to_be_bytes();
    Ok([a, b, c])
}

/// `0x17`: read `len` bytes at `address`. The remote answers with `ceil(len / 16)` `0x21`
/// reports, or one `0x21` carrying an error code.
pub fn read_memory(space: AddressSpace, address: u32, len: u16) -> Result<[u8; 7], RequestError> {
    let [a2, a1, a0] = address_bytes(address)?;
    if len == 0 || address + u32::from(len) - 1 > MAX_ADDRESS {
        return Err(RequestError::BadReadLength(usize::from(len)));
    }
    let [s1, s0] = len.to_be_bytes();
    Ok([OUT_READ_MEMORY, space.byte(), a2, a1, a0, s1, s0])
}

/// `0x16`: write `data` (1–16 bytes) at `address`; the remote answers with a `0x22`
/// acknowledgement of report `0x16`.
pub fn write_memory(
    space: AddressSpace,
    address: u32,
    data: &[u8],
) -> Result<[u8; WRITE_MEMORY_LEN], RequestError> {
    let [a2, a1, a0] = address_bytes(address)?;
    if data.is_empty() || data.len() > 16 {
        return Err(RequestError::BadWriteLength(data.len()));
    }
    let mut out = [0u8; WRITE_MEMORY_LEN];
    out[..6].copy_from_slice(&[OUT_WRITE_MEMORY, space.byte(), a2, a1, a0, data.len() as u8]);
    out[6..6 + data.len()].copy_from_slice(data);
    Ok(out)
}

/// What the error nibble of a `0x21` reply (or the error byte of a `0x22`) means.
/// Codes from WiiBrew ("Reading and Writing": 7 = write-only register or unconnected
/// extension, 8 = nonexistent memory) and Dolphin (`ErrorCode`: 4 busy, 6 invalid address
/// space, 7 no acknowledge on the I²C bus, 8 invalid address).
pub const fn error_meaning(code: u8) -> &'static str {
    match code {
        0 => "success",
        4 => "busy (another memory read is still in progress)",
        6 => "invalid address space",
        7 => "no answer on the extension bus (extension not connected, or a write-only register)",
        8 => "invalid address (outside the readable memory)",
        _ => "undocumented error code",
    }
}

/// A decoded status report (`0x20`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// Core buttons.
    pub buttons: Buttons,
    /// Flags byte: bit 0 battery low, bit 1 extension connected, bit 2 speaker, bit 3 IR,
    /// bits 4–7 LEDs.
    pub flags: u8,
    /// Battery level (raw byte; ~0xC0 when fresh).
    pub battery: u8,
}

impl Status {
    /// True when an extension (e.g. a Nunchuk) is plugged in.
    pub const fn extension_connected(&self) -> bool {
        self.flags & STATUS_EXTENSION != 0
    }
}

/// A decoded read-memory reply (`0x21`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadReply<'a> {
    /// Number of data bytes (1–16), from the size nibble.
    pub size: usize,
    /// Error code (0 = success), see [`error_meaning`].
    pub error: u8,
    /// Low 16 bits of the address of the first data byte.
    pub address_lo: u16,
    /// The `size` data bytes.
    pub data: &'a [u8],
}

/// A decoded acknowledgement (`0x22`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ack {
    /// The output report acknowledged.
    pub report: u8,
    /// Its result (0 = success), see [`error_meaning`].
    pub error: u8,
}

/// One input report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputReport<'a> {
    /// `0x20`.
    Status(Status),
    /// `0x21`.
    ReadReply(ReadReply<'a>),
    /// `0x22`.
    Ack(Ack),
    /// `0x30`–`0x37`.
    Data(CoreReport<'a>),
}

/// Why an input report could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReportError {
    /// Zero bytes.
    Empty,
    /// Fewer bytes than the report ID needs.
    Short {
        /// Report ID.
        id: u8,
        /// Bytes needed, ID included.
        expected: usize,
        /// Bytes received.
        got: usize,
    },
    /// A report ID `capture` does not use (`0x3D`–`0x3F`, or not a Wii Remote input report).
    Unknown(u8),
}

impl fmt::Display for ReportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReportError::Empty => f.write_str("empty input report"),
            ReportError::Short { id, expected, got } => write!(
                f,
                "short input report 0x{id:02X}: {got} bytes, expected {expected}"
            ),
            ReportError::Unknown(id) => write!(f, "unknown input report 0x{id:02X}"),
        }
    }
}

impl std::error::Error for ReportError {}

fn need(bytes: &[u8], expected: usize) -> Result<&[u8], ReportError> {
    bytes.get(..expected).ok_or(ReportError::Short {
        id: bytes.first().copied().unwrap_or(0),
        expected,
        got: bytes.len(),
    })
}

/// Decodes an input report (report ID first). Longer input than the report's length is
/// accepted (trailing bytes ignored, as some HID stacks pad); shorter input is an error.
/// Never panics, whatever the bytes.
pub fn parse_input(bytes: &[u8]) -> Result<InputReport<'_>, ReportError> {
    let Some(&id) = bytes.first() else {
        return Err(ReportError::Empty);
    };
    match id {
        IN_STATUS => {
            let b = need(bytes, STATUS_LEN)?;
            Ok(InputReport::Status(Status {
                buttons: Buttons::from_report_bytes([b[1], b[2]]),
                flags: b[3],
                battery: b[6],
            }))
        }
        IN_READ_REPLY => {
            let b = need(bytes, READ_REPLY_LEN)?;
            let size = usize::from(b[3] >> 4) + 1;
            Ok(InputReport::ReadReply(ReadReply {
                size,
                error: b[3] & 0x0F,
                address_lo: u16::from_be_bytes([b[4], b[5]]),
                data: &b[6..6 + size],
            }))
        }
        IN_ACK => {
            let b = need(bytes, ACK_LEN)?;
            Ok(InputReport::Ack(Ack {
                report: b[3],
                error: b[4],
            }))
        }
        0x30..=0x37 => {
            let rid = ReportId::try_from(id).map_err(|_| ReportError::Unknown(id))?;
            let b = need(bytes, rid.report_len())?;
            CoreReport::decode(b)
                .map(InputReport::Data)
                .map_err(|_| ReportError::Unknown(id))
        }
        _ => Err(ReportError::Unknown(id)),
    }
}

/// Bytes as uppercase hex separated by spaces (the factory-block module's helper).
pub use wiical_factory::hex;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_reports_are_the_documented_bytes() {
        // WiiBrew: "12 04 35" = continuous reporting in mode 0x35.
        assert_eq!(
            set_report_mode(ReportId::ButtonsAccelExt16, true),
            [0x12, 0x04, 0x35]
        );
        assert_eq!(set_leds(0b0001), [0x11, 0x10]);
        assert_eq!(request_status(), [0x15, 0x00]);
        // Read 16 bytes of the extension calibration: 17 04 A4 00 20 00 10.
        assert_eq!(
            read_memory(AddressSpace::Registers, 0xA40020, 16).unwrap(),
            [0x17, 0x04, 0xA4, 0x00, 0x20, 0x00, 0x10]
        );
        // Read the EEPROM calibration (both copies): 17 00 00 00 16 00 14.
        assert_eq!(
            read_memory(AddressSpace::Eeprom, 0x16, 20).unwrap(),
            [0x17, 0x00, 0x00, 0x00, 0x16, 0x00, 0x14]
        );
        // Unencrypted extension init, first write: 16 04 A4 00 F0 01 55 00…
        let w = write_memory(AddressSpace::Registers, 0xA400F0, &[0x55]).unwrap();
        assert_eq!(w[..7], [0x16, 0x04, 0xA4, 0x00, 0xF0, 0x01, 0x55]);
        assert!(w[7..].iter().all(|&b| b == 0));
        assert_eq!(w.len(), 22);
    }

    #[test]
    fn requests_refuse_what_the_format_cannot_carry() {
        assert_eq!(
            read_memory(AddressSpace::Eeprom, 0x100_0000, 1),
            Err(RequestError::AddressTooLarge(0x100_0000))
        );
        assert_eq!(
            read_memory(AddressSpace::Eeprom, 0, 0),
            Err(RequestError::BadReadLength(0))
        );
        assert_eq!(
            read_memory(AddressSpace::Eeprom, 0xFF_FFFF, 2),
            Err(RequestError::BadReadLength(2))
        );
        assert_eq!(
            write_memory(AddressSpace::Registers, 0xA400F0, &[0; 17]),
            Err(RequestError::BadWriteLength(17))
        );
        assert_eq!(
            write_memory(AddressSpace::Registers, 0xA400F0, &[]),
            Err(RequestError::BadWriteLength(0))
        );
    }

    #[test]
    fn input_reports_decode_field_by_field() {
        // Status: extension connected, LED 1, battery 0xC8.
        let s = parse_input(&[0x20, 0x00, 0x08, 0x12, 0, 0, 0xC8]).unwrap();
        let InputReport::Status(s) = s else {
            panic!("{s:?}")
        };
        assert!(s.extension_connected());
        assert_eq!(s.buttons, Buttons::A);
        assert_eq!(s.battery, 0xC8);
        // Read reply: size nibble 0x9 -> 10 bytes, error 0, address 0x0016.
        let mut r = [0u8; 22];
        r[..6].copy_from_slice(&[0x21, 0, 0, 0x90, 0x00, 0x16]);
        r[6..16].copy_from_slice(&[0x82, 0x82, 0x82, 0x15, 0x9C, 0x9C, 0x9E, 0x38, 0x40, 0x3E]);
        let InputReport::ReadReply(rr) = parse_input(&r).unwrap() else {
            panic!()
        };
        assert_eq!((rr.size, rr.error, rr.address_lo), (10, 0, 0x0016));
        assert_eq!(rr.data[9], 0x3E);
        // Error nibble 8 with size nibble F.
        r[3] = 0xF8;
        let InputReport::ReadReply(rr) = parse_input(&r).unwrap() else {
            panic!()
        };
        assert_eq!((rr.size, rr.error), (16, 8));
        assert_eq!(
            parse_input(&[0x22, 0, 0, 0x16, 0x07]).unwrap(),
            InputReport::Ack(Ack {
                report: 0x16,
                error: 7
            })
        );
    }

    #[test]
    fn bad_input_reports_are_errors() {
        assert_eq!(parse_input(&[]), Err(ReportError::Empty));
        assert_eq!(
            parse_input(&[0x21, 0, 0, 0]),
            Err(ReportError::Short {
                id: 0x21,
                expected: 22,
                got: 4
            })
        );
        assert_eq!(
            parse_input(&[0x35; 10]),
            Err(ReportError::Short {
                id: 0x35,
                expected: 22,
                got: 10
            })
        );
        assert_eq!(parse_input(&[0x3D; 22]), Err(ReportError::Unknown(0x3D)));
        assert_eq!(parse_input(&[0x01]), Err(ReportError::Unknown(0x01)));
        // Padding after a complete report is accepted.
        assert!(matches!(
            parse_input(&[0x31, 0, 0, 1, 2, 3, 0, 0]),
            Ok(InputReport::Data(_))
        ));
    }
}
