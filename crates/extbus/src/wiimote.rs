//! Wii Remote core input reports `0x30`–`0x37` and the accelerometer calibration block of
//! its EEPROM.
//!
//! Sources: WiiBrew, "Wiimote" (sections "Data Reporting", "Core Buttons",
//! "Accelerometer", "EEPROM Memory"; the EEPROM block layout and the example block
//! `82 82 82 15 9C 9C 9E 38 40 3E` are from revision diff
//! <https://wiibrew.org/wiki/Special:MobileDiff/103741>), and the Dolphin emulator, which
//! implements the same bit positions (`Source/Core/Core/HW/WiimoteCommon/WiimoteReport.h`,
//! `ButtonData`: 2 accel bits at bits 5–6 of each button byte; `DataReport.cpp`,
//! `GetAccelData`: "X has 10 bits of precision", "Y and Z only have 9 bits").
//!
//! ## Accelerometer precision in core reports
//! The three accelerometer bytes carry bits 9..2 of X, Y, Z. The remaining low bits live in
//! otherwise unused bits of the two button bytes:
//!
//! | value bit | where |
//! |---|---|
//! | X bit 1, bit 0 | button byte 0, bits 6, 5 |
//! | Y bit 1 | button byte 1, bit 5 |
//! | Z bit 1 | button byte 1, bit 6 |
//!
//! All three axes are returned on the same 10-bit scale (0..=1023) as the EEPROM
//! calibration, so `raw − zero` needs no shifting; Y and Z simply always have bit 0 clear
//! (9 significant bits). (Dolphin instead fills Y/Z bit 0 with a copy of the top bit to
//! stretch 0..=1022 to 0..=1023; the difference is at most 1 count.)

use crate::error::{pick_copy, Checked, Error, FromCopies};
use crate::nunchuk::NunchukReport;
use crate::packing::{self, exact, pack_xxyyzz, unpack_xxyyzz, MAX_10BIT};

bitflags::bitflags! {
    /// The core buttons, as the two button bytes read big-endian
    /// (`(byte0 << 8) | byte1`, the convention of wiiuse and WiiBrew's table).
    ///
    /// The four accelerometer low bits ([`ACCEL_LSB_MASK`]) are never part of a `Buttons`
    /// value; the unknown bit `0x8000` is retained as received.
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    pub struct Buttons: u16 {
        /// Button "2".
        const TWO = 0x0001;
        /// Button "1".
        const ONE = 0x0002;
        /// Trigger "B".
        const B = 0x0004;
        /// Button "A".
        const A = 0x0008;
        /// Button "−".
        const MINUS = 0x0010;
        /// Button "HOME".
        const HOME = 0x0080;
        /// D-pad left.
        const LEFT = 0x0100;
        /// D-pad right.
        const RIGHT = 0x0200;
        /// D-pad down.
        const DOWN = 0x0400;
        /// D-pad up.
        const UP = 0x0800;
        /// Button "+".
        const PLUS = 0x1000;
    }
}

/// Bits of the big-endian button word that carry accelerometer low bits, not buttons:
/// `0x6000` = X bits 1..0, `0x0020` = Y bit 1, `0x0040` = Z bit 1.
pub const ACCEL_LSB_MASK: u16 = 0x6060;

impl Buttons {
    /// Buttons from the two button bytes of a report (accelerometer bits removed).
    pub const fn from_report_bytes(b: [u8; 2]) -> Self {
        Self::from_bits_retain(u16::from_be_bytes(b) & !ACCEL_LSB_MASK)
    }

    /// The two button bytes, with the accelerometer bit positions zero.
    pub const fn to_report_bytes(self) -> [u8; 2] {
        (self.bits() & !ACCEL_LSB_MASK).to_be_bytes()
    }
}

/// Decode the accelerometer from the two button bytes and the three accelerometer bytes.
/// Returns `[x, y, z]` on the 10-bit scale (see the module docs).
pub const fn decode_accel(buttons: [u8; 2], accel: [u8; 3]) -> [u16; 3] {
    let x_lsb = ((buttons[0] >> 5) & 0b11) as u16;
    let y_bit1 = ((buttons[1] >> 5) & 1) as u16;
    let z_bit1 = ((buttons[1] >> 6) & 1) as u16;
    [
        ((accel[0] as u16) << 2) | x_lsb,
        ((accel[1] as u16) << 2) | (y_bit1 << 1),
        ((accel[2] as u16) << 2) | (z_bit1 << 1),
    ]
}

/// Encode `[x, y, z]` (10-bit scale) into the accelerometer low bits to OR into the two
/// button bytes and the three accelerometer bytes. Values are clamped to 1023; bit 0 of Y
/// and Z is dropped (the report cannot carry it).
pub fn encode_accel(v: [u16; 3]) -> ([u8; 2], [u8; 3]) {
    let v = v.map(|a| a.min(MAX_10BIT));
    let lsb = [
        ((v[0] & 0b11) as u8) << 5,
        ((((v[1] >> 1) & 1) as u8) << 5) | ((((v[2] >> 1) & 1) as u8) << 6),
    ];
    let hi = [(v[0] >> 2) as u8, (v[1] >> 2) as u8, (v[2] >> 2) as u8];
    (lsb, hi)
}

/// The Wii Remote input report IDs whose layout this crate decodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ReportId {
    /// `0x30`: core buttons.
    Buttons = 0x30,
    /// `0x31`: core buttons and accelerometer.
    ButtonsAccel = 0x31,
    /// `0x32`: core buttons with 8 extension bytes.
    ButtonsExt8 = 0x32,
    /// `0x33`: core buttons and accelerometer with 12 IR bytes.
    ButtonsAccelIr12 = 0x33,
    /// `0x34`: core buttons with 19 extension bytes.
    ButtonsExt19 = 0x34,
    /// `0x35`: core buttons and accelerometer with 16 extension bytes.
    ButtonsAccelExt16 = 0x35,
    /// `0x36`: core buttons with 10 IR bytes and 9 extension bytes.
    ButtonsIr10Ext9 = 0x36,
    /// `0x37`: core buttons and accelerometer with 10 IR bytes and 6 extension bytes.
    ButtonsAccelIr10Ext6 = 0x37,
}

/// Field layout of a report (after the report ID byte: 2 button bytes, then optionally 3
/// accelerometer bytes, then IR bytes, then extension bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReportLayout {
    /// Whether the 3 accelerometer bytes are present.
    pub accel: bool,
    /// Number of IR camera bytes.
    pub ir_len: usize,
    /// Number of extension bytes.
    pub ext_len: usize,
}

impl ReportId {
    /// All supported IDs, in numeric order.
    pub const ALL: [ReportId; 8] = [
        ReportId::Buttons,
        ReportId::ButtonsAccel,
        ReportId::ButtonsExt8,
        ReportId::ButtonsAccelIr12,
        ReportId::ButtonsExt19,
        ReportId::ButtonsAccelExt16,
        ReportId::ButtonsIr10Ext9,
        ReportId::ButtonsAccelIr10Ext6,
    ];

    /// The layout of this report.
    pub const fn layout(self) -> ReportLayout {
        let (accel, ir_len, ext_len) = match self {
            ReportId::Buttons => (false, 0, 0),
            ReportId::ButtonsAccel => (true, 0, 0),
            ReportId::ButtonsExt8 => (false, 0, 8),
            ReportId::ButtonsAccelIr12 => (true, 12, 0),
            ReportId::ButtonsExt19 => (false, 0, 19),
            ReportId::ButtonsAccelExt16 => (true, 0, 16),
            ReportId::ButtonsIr10Ext9 => (false, 10, 9),
            ReportId::ButtonsAccelIr10Ext6 => (true, 10, 6),
        };
        ReportLayout {
            accel,
            ir_len,
            ext_len,
        }
    }

    /// Total length of the report including the report ID byte.
    pub const fn report_len(self) -> usize {
        let l = self.layout();
        1 + 2 + if l.accel { 3 } else { 0 } + l.ir_len + l.ext_len
    }
}

impl TryFrom<u8> for ReportId {
    type Error = Error;
    fn try_from(id: u8) -> Result<Self, Error> {
        match id {
            0x30..=0x37 => Ok(Self::ALL[usize::from(id - 0x30)]),
            _ => Err(Error::UnknownReportId(id)),
        }
    }
}

/// A decoded core input report. The IR and extension bytes are borrowed from the input
/// undecoded (extension bytes are whatever the extension sent, e.g. a [`NunchukReport`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CoreReport<'a> {
    /// Report ID (determines the layout).
    pub id: ReportId,
    /// Core buttons.
    pub buttons: Buttons,
    /// Accelerometer `[x, y, z]` on the 10-bit scale, for IDs that carry it.
    pub accel: Option<[u16; 3]>,
    /// IR camera bytes (empty if the layout has none).
    pub ir: &'a [u8],
    /// Extension bytes (empty if the layout has none).
    pub ext: &'a [u8],
}

impl<'a> CoreReport<'a> {
    /// Decode a report. `bytes` starts with the report ID (without the Bluetooth HID
    /// `0xA1` transaction header) and must have exactly the layout's length.
    pub fn decode(bytes: &'a [u8]) -> Result<Self, Error> {
        let Some(&id_byte) = bytes.first() else {
            return Err(Error::WrongLength {
                expected: 1,
                got: 0,
            });
        };
        let id = ReportId::try_from(id_byte)?;
        if bytes.len() != id.report_len() {
            return Err(Error::WrongLength {
                expected: id.report_len(),
                got: bytes.len(),
            });
        }
        let layout = id.layout();
        let btn = [bytes[1], bytes[2]];
        let mut rest = &bytes[3..];
        let accel = if layout.accel {
            let (a, r) = rest.split_at(3);
            rest = r;
            Some(decode_accel(btn, [a[0], a[1], a[2]]))
        } else {
            None
        };
        let (ir, ext) = rest.split_at(layout.ir_len);
        Ok(Self {
            id,
            buttons: Buttons::from_report_bytes(btn),
            accel,
            ir,
            ext,
        })
    }

    /// Encode into `out` (report ID first); returns the number of bytes written.
    ///
    /// Fails with [`Error::LayoutMismatch`] if `accel` presence or the IR / extension
    /// lengths do not match the ID's layout, and with [`Error::BufferTooSmall`] if `out` is
    /// short. Accelerometer values are clamped/truncated as in [`encode_accel`].
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, Error> {
        let layout = self.id.layout();
        if layout.accel != self.accel.is_some()
            || self.ir.len() != layout.ir_len
            || self.ext.len() != layout.ext_len
        {
            return Err(Error::LayoutMismatch);
        }
        let len = self.id.report_len();
        let Some(out) = out.get_mut(..len) else {
            return Err(Error::BufferTooSmall {
                needed: len,
                got: out.len(),
            });
        };
        let mut btn = self.buttons.to_report_bytes();
        out[0] = self.id as u8;
        let mut pos = 3;
        if let Some(a) = self.accel {
            let (lsb, hi) = encode_accel(a);
            btn[0] |= lsb[0];
            btn[1] |= lsb[1];
            out[3..6].copy_from_slice(&hi);
            pos = 6;
        }
        out[1] = btn[0];
        out[2] = btn[1];
        out[pos..pos + self.ir.len()].copy_from_slice(self.ir);
        pos += self.ir.len();
        out[pos..pos + self.ext.len()].copy_from_slice(self.ext);
        Ok(len)
    }

    /// The first 6 extension bytes read as a plain (already decrypted) Nunchuk report, if
    /// the report has at least 6 extension bytes.
    pub fn nunchuk(&self) -> Option<NunchukReport> {
        let b: &[u8; 6] = self.ext.get(..6)?.try_into().ok()?;
        Some(NunchukReport::from_bytes(b))
    }
}

/// EEPROM address of the accelerometer calibration block.
pub const EEPROM_CALIBRATION_ADDR: u16 = 0x0016;
/// EEPROM address of its backup copy.
pub const EEPROM_CALIBRATION_BACKUP_ADDR: u16 = 0x0020;

/// The Wii Remote's factory accelerometer calibration (10 bytes at EEPROM `0x16`, copy at
/// `0x20`; WiiBrew "EEPROM Memory").
///
/// | byte | content |
/// |---|---|
/// | 0–2 | zero-g X, Y, Z bits 9..2 |
/// | 3 | zero-g low bits `--XXYYZZ` |
/// | 4–6 | 1-g ("force of gravity") X, Y, Z bits 9..2 |
/// | 7 | 1-g low bits `--XXYYZZ` |
/// | 8 | not accelerometer data (`0x40` on all remotes WiiBrew checked) |
/// | 9 | checksum = (sum of bytes 0..=8 + 0x55) & 0xFF |
///
/// The real block `82 82 82 15 9C 9C 9E 38 40 3E` decodes to zero (521, 521, 521) and
/// one-g (627, 626, 632), i.e. ≈106 counts per g on the 10-bit scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AccelCalibration {
    /// Reading at 0 g per axis, 10-bit counts.
    pub zero: [u16; 3],
    /// Reading at +1 g per axis, 10-bit counts.
    pub one_g: [u16; 3],
    /// Byte 8, kept verbatim so that re-encoding reproduces the stored block.
    pub byte8: u8,
}

/// Checksum byte of a Wii Remote calibration block from its first 9 bytes.
pub fn calibration_checksum(data: &[u8; 9]) -> u8 {
    data.iter().fold(0x55u8, |acc, &b| acc.wrapping_add(b))
}

impl AccelCalibration {
    /// Length of the block in bytes.
    pub const LEN: usize = 10;

    /// Decode a 10-byte block. The values are returned even when the checksum fails.
    pub fn from_bytes(b: &[u8; 10]) -> Checked<Self> {
        let mut data = [0u8; 9];
        data.copy_from_slice(&b[..9]);
        Checked {
            value: Self {
                zero: unpack_xxyyzz([b[0], b[1], b[2]], b[3]),
                one_g: unpack_xxyyzz([b[4], b[5], b[6]], b[7]),
                byte8: b[8],
            },
            checksum_ok: calibration_checksum(&data) == b[9],
        }
    }

    /// Decode a block from a slice, which must be exactly 10 bytes long.
    pub fn decode(bytes: &[u8]) -> Result<Checked<Self>, Error> {
        Ok(Self::from_bytes(&exact::<10>(bytes)?))
    }

    /// Encode to 10 bytes with the checksum computed. Fails with
    /// [`Error::ValueOutOfRange`] if a value exceeds 1023.
    pub fn encode(&self) -> Result<[u8; 10], Error> {
        let (zh, zl) = pack_xxyyzz(self.zero)?;
        let (gh, gl) = pack_xxyyzz(self.one_g)?;
        let data = [zh[0], zh[1], zh[2], zl, gh[0], gh[1], gh[2], gl, self.byte8];
        let mut out = [0u8; 10];
        out[..9].copy_from_slice(&data);
        out[9] = calibration_checksum(&data);
        Ok(out)
    }

    /// Read the two stored copies (EEPROM `0x16` and `0x20`): the first if its checksum is
    /// valid, else the second, else [`Error::BadChecksum`] (Nintendo's rule per WiiBrew).
    pub fn from_copies(first: &[u8], second: &[u8]) -> Result<FromCopies<Self>, Error> {
        pick_copy(Self::decode(first), Self::decode(second))
    }

    /// [`Self::from_copies`] on an EEPROM dump that starts at address 0 and reaches at
    /// least `0x2A` (the end of the backup copy).
    pub fn from_eeprom(dump: &[u8]) -> Result<FromCopies<Self>, Error> {
        let a = usize::from(EEPROM_CALIBRATION_ADDR);
        let b = usize::from(EEPROM_CALIBRATION_BACKUP_ADDR);
        let (Some(first), Some(second)) = (dump.get(a..a + 10), dump.get(b..b + 10)) else {
            return Err(Error::WrongLength {
                expected: b + 10,
                got: dump.len(),
            });
        };
        Self::from_copies(first, second)
    }

    /// Sensitivity `one_g − zero` per axis, 10-bit counts per g.
    pub fn counts_per_g(&self) -> [i32; 3] {
        packing::counts_per_g(self.zero, self.one_g)
    }

    /// Convert a raw 10-bit-scale reading to g with this factory calibration,
    /// `(raw − zero) / (one_g − zero)` per axis. `None` if an axis has `one_g == zero`.
    pub fn accel_to_g(&self, raw: [u16; 3]) -> Option<[f32; 3]> {
        packing::accel_to_g(self.zero, self.one_g, raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_ids_and_lengths_follow_the_wiibrew_table() {
        // (id, payload length after the id byte) from WiiBrew's "Data Reporting" table.
        let table = [
            (0x30, 2),
            (0x31, 5),
            (0x32, 10),
            (0x33, 17),
            (0x34, 21),
            (0x35, 21),
            (0x36, 21),
            (0x37, 21),
        ];
        for (id, payload) in table {
            let rid = ReportId::try_from(id).unwrap();
            assert_eq!(rid as u8, id);
            assert_eq!(rid.report_len(), 1 + payload, "id {id:#x}");
        }
        assert_eq!(ReportId::try_from(0x3D), Err(Error::UnknownReportId(0x3D)));
        assert_eq!(ReportId::try_from(0x2F), Err(Error::UnknownReportId(0x2F)));
    }

    #[test]
    fn button_bits() {
        assert_eq!(Buttons::from_report_bytes([0x08, 0x00]), Buttons::UP);
        assert_eq!(Buttons::from_report_bytes([0x10, 0x00]), Buttons::PLUS);
        assert_eq!(Buttons::from_report_bytes([0x00, 0x80]), Buttons::HOME);
        assert_eq!(Buttons::from_report_bytes([0x00, 0x08]), Buttons::A);
        assert_eq!(Buttons::from_report_bytes([0x00, 0x04]), Buttons::B);
        // Accelerometer bits are not buttons.
        assert_eq!(Buttons::from_report_bytes([0x60, 0x60]), Buttons::empty());
    }

    #[test]
    fn accel_low_bits_positions() {
        // X low bits 0b11 -> byte0 bits 6,5; Y bit1 -> byte1 bit5; Z bit1 -> byte1 bit6.
        assert_eq!(decode_accel([0x60, 0x00], [0, 0, 0]), [3, 0, 0]);
        assert_eq!(decode_accel([0x20, 0x00], [0, 0, 0]), [1, 0, 0]);
        assert_eq!(decode_accel([0x00, 0x20], [0, 0, 0]), [0, 2, 0]);
        assert_eq!(decode_accel([0x00, 0x40], [0, 0, 0]), [0, 0, 2]);
        assert_eq!(decode_accel([0, 0], [1, 2, 3]), [4, 8, 12]);
        assert_eq!(encode_accel([3, 3, 2]), ([0x60, 0x60], [0, 0, 0]));
    }
}
