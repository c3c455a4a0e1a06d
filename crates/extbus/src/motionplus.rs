//! The Wii MotionPlus (gyroscope extension): activation, the 6-byte report, the Nunchuk and
//! Classic Controller pass-through interleaving, and the 32-byte calibration block.
//!
//! Sources (public documentation and published behaviour; no code copied): WiiBrew,
//! "Wiimote/Extension Controllers/Wii Motion Plus"; Dolphin's `WiimoteEmu/MotionPlus.{h,cpp}`
//! (register layout, checksum coverage, pass-through bit moves "verified on real hardware via a
//! test of every bit"); the Linux `hid-wiimote` driver (`wiimod_mp_in_mp`: report layout and
//! slow/fast scales). The full table with what each source says is in `docs/gyro.md`.
//!
//! ## Bus
//! * Inactive, the MotionPlus answers at I²C address `0x53` (Wii Remote address space
//!   `0xA6xxxx`) with ID `00 00 A6 20 00 05` at `0xFA`, and passes bus traffic at `0x52`
//!   through to the extension plugged into its own port.
//! * Writing `0x55` to `0xF0` (at `0x53`) initialises it; writing the mode byte to `0xFE`
//!   activates it ([`PassthroughMode`]: `0x04` alone, `0x05` Nunchuk, `0x07` Classic). It
//!   then answers at `0x52` (`0xA4xxxx`) with ID `00 00 A4 20 <mode> 05`.
//! * Writing to `0xF0` at `0x52` while active deactivates it (the write is also the
//!   extension's own unencrypted init).
//!
//! ## Report (6 bytes, plain)
//! | byte | bits 7–2 | bit 1 | bit 0 |
//! |---|---|---|---|
//! | 0 | yaw\[7:0\] (all 8 bits) | | |
//! | 1 | roll\[7:0\] | | |
//! | 2 | pitch\[7:0\] | | |
//! | 3 | yaw\[13:8\] | yaw slow | pitch slow |
//! | 4 | roll\[13:8\] | roll slow | extension connected |
//! | 5 | pitch\[13:8\] | 1 = MotionPlus data | 0 |
//!
//! Rates are unsigned 14-bit counts, zero rate near 8192. A slow bit of 1 means the axis is in
//! its high-resolution range (about ±440 °/s, ≈18.6 counts per °/s per hid-wiimote); 0 means
//! the fast range (about ±2000 °/s, 2000/440 ≈ 4.55 times coarser).
//!
//! In a pass-through mode the MotionPlus alternates its own report with one from the
//! extension, told apart by byte 5 bit 1 (0 = extension data), see [`Frame`].

use crate::error::{Checked, Error};
use crate::nunchuk::{NunchukReport, RegisterWrite};
use crate::packing::exact;

/// I²C address of an inactive MotionPlus (`0xA6xxxx` in the Wii Remote's address space).
pub const INACTIVE_I2C_ADDRESS: u8 = 0x53;
/// I²C address of an active MotionPlus (the usual extension address, `0xA4xxxx`).
pub const ACTIVE_I2C_ADDRESS: u8 = 0x52;
/// Register of the 6 identification bytes.
pub const ID_REGISTER: u8 = 0xFA;
/// Identification of an inactive MotionPlus at [`INACTIVE_I2C_ADDRESS`]. (Dolphin notes that
/// the first byte is `0x01` on a Wii Remote Plus with the MotionPlus built in.)
pub const ID_INACTIVE: [u8; 6] = [0x00, 0x00, 0xA6, 0x20, 0x00, 0x05];
/// Register written with the mode byte to activate the MotionPlus.
pub const MODE_REGISTER: u8 = 0xFE;
/// Register of the first calibration byte.
pub const CALIBRATION_REGISTER: u8 = 0x20;
/// Zero-rate value of a 14-bit rate at the centre of the range.
pub const NOMINAL_ZERO: u16 = 8192;
/// Largest 14-bit rate.
pub const MAX_14BIT: u16 = 0x3FFF;

/// What the MotionPlus interleaves with its own data once active (the byte written to `0xFE`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassthroughMode {
    /// MotionPlus data only (`0x04`).
    None = 0x04,
    /// Nunchuk pass-through (`0x05`).
    Nunchuk = 0x05,
    /// Classic Controller (and instrument) pass-through (`0x07`).
    Classic = 0x07,
}

impl PassthroughMode {
    /// The mode byte of a known mode.
    pub fn from_byte(b: u8) -> Option<Self> {
        match b {
            0x04 => Some(Self::None),
            0x05 => Some(Self::Nunchuk),
            0x07 => Some(Self::Classic),
            _ => None,
        }
    }

    /// The writes (all addressed to [`INACTIVE_I2C_ADDRESS`]) that initialise and activate
    /// the MotionPlus in this mode: `0x55` → `0xF0`, then the mode byte → `0xFE`.
    pub const fn activation(self) -> [RegisterWrite; 2] {
        [
            RegisterWrite {
                register: 0xF0,
                value: 0x55,
            },
            RegisterWrite {
                register: MODE_REGISTER,
                value: self as u8,
            },
        ]
    }

    /// The identification read at `0x52`/`0xFA` once active in this mode.
    pub const fn active_id(self) -> [u8; 6] {
        [0x00, 0x00, 0xA4, 0x20, self as u8, 0x05]
    }
}

/// One MotionPlus gyro report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotionPlusReport {
    /// Raw 14-bit rates `[yaw, roll, pitch]` (0..=16383, zero rate ≈ 8192).
    pub rate: [u16; 3],
    /// Per axis `[yaw, roll, pitch]`: `true` in the slow (high-resolution) range.
    pub slow: [bool; 3],
    /// An extension is plugged into the MotionPlus's own port.
    pub extension_connected: bool,
}

impl MotionPlusReport {
    /// Decode a MotionPlus report. Fails with [`Error::LayoutMismatch`] when byte 5 bit 1 says
    /// the bytes are pass-through extension data (use [`Frame::decode`] for an interleaved
    /// stream).
    pub fn decode(bytes: &[u8]) -> Result<Self, Error> {
        let b = exact::<6>(bytes)?;
        if b[5] & 0b10 == 0 {
            return Err(Error::LayoutMismatch);
        }
        Ok(Self::from_bytes(&b))
    }

    /// Decode without looking at the data-type bit.
    pub fn from_bytes(b: &[u8; 6]) -> Self {
        let join = |lo: u8, hi: u8| (lo as u16) | (((hi >> 2) as u16) << 8);
        Self {
            rate: [join(b[0], b[3]), join(b[1], b[4]), join(b[2], b[5])],
            slow: [b[3] & 0b10 != 0, b[4] & 0b10 != 0, b[3] & 0b01 != 0],
            extension_connected: b[4] & 0b01 != 0,
        }
    }

    /// Encode (data-type bit set, bit 0 of byte 5 clear). Fails with
    /// [`Error::ValueOutOfRange`] for a rate above 16383; otherwise
    /// `from_bytes(&r.to_bytes()?) == r`.
    pub fn to_bytes(&self) -> Result<[u8; 6], Error> {
        if self.rate.iter().any(|r| *r > MAX_14BIT) {
            return Err(Error::ValueOutOfRange);
        }
        let [y, r, p] = self.rate;
        let hi = |v: u16| ((v >> 8) as u8) << 2;
        Ok([
            y as u8,
            r as u8,
            p as u8,
            hi(y) | (u8::from(self.slow[0]) << 1) | u8::from(self.slow[2]),
            hi(r) | (u8::from(self.slow[1]) << 1) | u8::from(self.extension_connected),
            hi(p) | 0b10,
        ])
    }
}

/// A Nunchuk report as passed through by the MotionPlus (mode `0x05`): the accelerometer
/// loses its least significant bit (the values here have bit 0 clear) and byte 4 bit 0 carries
/// the MotionPlus's extension-connected flag.
///
/// | byte | content |
/// |---|---|
/// | 0, 1 | stick X, Y |
/// | 2, 3 | accel X\[9:2\], Y\[9:2\] |
/// | 4 | accel Z\[9:3\] (7–1), extension connected (0) |
/// | 5 | Z\[2\] (7), Z\[1\] (6), Y\[1\] (5), X\[1\] (4), C (3), Z button (2), 0 = extension data (1), 0 (0) |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PassthroughNunchuk {
    /// The Nunchuk report on the usual 10-bit scale, bit 0 of each axis zero.
    pub report: NunchukReport,
    /// The extension-connected flag.
    pub extension_connected: bool,
}

impl PassthroughNunchuk {
    /// Decode pass-through Nunchuk bytes (the data-type bit is not checked here).
    pub fn from_bytes(b: &[u8; 6]) -> Self {
        let bit = |byte: u8, n: u8| ((byte >> n) & 1) as u16;
        let x = ((b[2] as u16) << 2) | (bit(b[5], 4) << 1);
        let y = ((b[3] as u16) << 2) | (bit(b[5], 5) << 1);
        let z = (((b[4] >> 1) as u16) << 3) | (bit(b[5], 7) << 2) | (bit(b[5], 6) << 1);
        Self {
            report: NunchukReport {
                stick: [b[0], b[1]],
                accel: [x, y, z],
                c: b[5] & (1 << 3) == 0,
                z: b[5] & (1 << 2) == 0,
            },
            extension_connected: b[4] & 1 != 0,
        }
    }

    /// Encode as the MotionPlus would send it. Accelerometer bit 0 is dropped and values above
    /// 1023 are clamped; `from_bytes(&p.to_bytes())` equals `p` when bit 0 was already clear.
    pub fn to_bytes(&self) -> [u8; 6] {
        let [x, y, z] = self.report.accel.map(|v| v.min(0x3FF));
        let bit = |v: u16, n: u16| ((v >> n) & 1) as u8;
        [
            self.report.stick[0],
            self.report.stick[1],
            (x >> 2) as u8,
            (y >> 2) as u8,
            (((z >> 3) as u8) << 1) | u8::from(self.extension_connected),
            (bit(z, 2) << 7)
                | (bit(z, 1) << 6)
                | (bit(y, 1) << 5)
                | (bit(x, 1) << 4)
                | (u8::from(!self.report.c) << 3)
                | (u8::from(!self.report.z) << 2),
        ]
    }
}

/// One 6-byte frame of an active MotionPlus's data stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame {
    /// Gyro data.
    MotionPlus(MotionPlusReport),
    /// Pass-through Nunchuk data (mode `0x05`).
    Nunchuk(PassthroughNunchuk),
    /// Pass-through Classic Controller data (mode `0x07`) with the MotionPlus's bit moves
    /// undone: the original 6 bytes except that bit 0 of bytes 0 and 1 (the left stick's
    /// least significant bits) is lost (set equal to bit 1) and bit 0 of byte 4 (an unused
    /// button bit) reads 1 (released).
    Classic([u8; 6]),
}

impl Frame {
    /// Decode one frame in the given mode: byte 5 bit 1 tells gyro data (1) from pass-through
    /// extension data (0). In [`PassthroughMode::None`] extension data cannot occur and gives
    /// [`Error::LayoutMismatch`].
    pub fn decode(bytes: &[u8], mode: PassthroughMode) -> Result<Self, Error> {
        let b = exact::<6>(bytes)?;
        if b[5] & 0b10 != 0 {
            return Ok(Frame::MotionPlus(MotionPlusReport::from_bytes(&b)));
        }
        match mode {
            PassthroughMode::None => Err(Error::LayoutMismatch),
            PassthroughMode::Nunchuk => Ok(Frame::Nunchuk(PassthroughNunchuk::from_bytes(&b))),
            PassthroughMode::Classic => {
                let mut c = b;
                // The MotionPlus moved byte 5 bits 0 and 1 into bit 0 of bytes 0 and 1.
                c[5] = (c[5] & !0b11) | (b[0] & 1) | ((b[1] & 1) << 1);
                c[0] = (b[0] & !1) | ((b[0] >> 1) & 1);
                c[1] = (b[1] & !1) | ((b[1] >> 1) & 1);
                c[4] |= 1;
                Ok(Frame::Classic(c))
            }
        }
    }
}

/// One half of the calibration block: the two-point calibration of one range.
///
/// Values are 16-bit (the 14-bit rates scaled by 4): `zero` is the reading at rest, `scale`
/// the reading at `degrees_div_6 · 6` °/s. The sign of `scale − zero` is the axis's sign as
/// stored; Dolphin observes that real blocks do not follow the right-hand rule and flips
/// pitch and yaw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RangeCalibration {
    /// Zero-rate readings `[yaw, roll, pitch]`, 16-bit.
    pub zero: [u16; 3],
    /// Readings at the reference rate `[yaw, roll, pitch]`, 16-bit.
    pub scale: [u16; 3],
    /// The reference rate divided by 6, °/s.
    pub degrees_div_6: u8,
}

impl RangeCalibration {
    /// Sensitivity in 14-bit counts per °/s per axis `[yaw, roll, pitch]` (signed as stored);
    /// `None` when the reference rate is 0.
    pub fn counts_per_dps(&self) -> Option<[f32; 3]> {
        if self.degrees_div_6 == 0 {
            return None;
        }
        let deg = f32::from(self.degrees_div_6) * 6.0;
        Some(core::array::from_fn(|i| {
            (f32::from(self.scale[i]) - f32::from(self.zero[i])) / 4.0 / deg
        }))
    }

    /// Zero-rate readings on the 14-bit scale.
    pub fn zero_14bit(&self) -> [f32; 3] {
        self.zero.map(|z| f32::from(z) / 4.0)
    }
}

/// The 32-byte calibration block at `0x20` (read while inactive, at `0x53`).
///
/// | offset | content |
/// |---|---|
/// | `0x00`–`0x0B` | fast range: yaw, roll, pitch zero; yaw, roll, pitch scale (big-endian u16) |
/// | `0x0C` | fast range degrees / 6 |
/// | `0x0D` | UID 1 |
/// | `0x0E`–`0x0F` | CRC-32 high half (big-endian) |
/// | `0x10`–`0x1D` | slow range, same layout, UID 2 at `0x1D` |
/// | `0x1E`–`0x1F` | CRC-32 low half (big-endian) |
///
/// The CRC is the common CRC-32 (zlib's, `CRC-32/ISO-HDLC`) of bytes `0x00`–`0x0D` followed
/// by `0x10`–`0x1D` (Dolphin).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotionPlusCalibration {
    /// Fast (±2000 °/s class) range.
    pub fast: RangeCalibration,
    /// Slow (±440 °/s class) range.
    pub slow: RangeCalibration,
    /// The two UID bytes (`0x0D`, `0x1D`).
    pub uid: [u8; 2],
}

/// Bitwise (no table): 28 bytes once per connection; a table would cost 1 KiB of flash (and
/// `Crc::new` called at run time builds it on the stack).
static CALIBRATION_CRC: crc::Crc<u32, crc::NoTable> =
    crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 of the calibration data bytes (`0x00`–`0x0D` then `0x10`–`0x1D`).
pub fn calibration_crc(block: &[u8; 32]) -> u32 {
    let mut digest = CALIBRATION_CRC.digest();
    digest.update(&block[0x00..0x0E]);
    digest.update(&block[0x10..0x1E]);
    digest.finalize()
}

impl MotionPlusCalibration {
    /// Length in bytes.
    pub const LEN: usize = 32;

    /// Decode a 32-byte block; the values are returned even when the CRC fails.
    pub fn from_bytes(b: &[u8; 32]) -> Checked<Self> {
        let u16_at = |i: usize| u16::from_be_bytes([b[i], b[i + 1]]);
        let range = |o: usize| RangeCalibration {
            zero: [u16_at(o), u16_at(o + 2), u16_at(o + 4)],
            scale: [u16_at(o + 6), u16_at(o + 8), u16_at(o + 10)],
            degrees_div_6: b[o + 12],
        };
        let stored = (u32::from(u16_at(0x0E)) << 16) | u32::from(u16_at(0x1E));
        Checked {
            value: Self {
                fast: range(0x00),
                slow: range(0x10),
                uid: [b[0x0D], b[0x1D]],
            },
            checksum_ok: stored == calibration_crc(b),
        }
    }

    /// Decode from a slice that must be exactly 32 bytes long.
    pub fn decode(bytes: &[u8]) -> Result<Checked<Self>, Error> {
        Ok(Self::from_bytes(&exact::<32>(bytes)?))
    }

    /// Encode with the CRC computed; `from_bytes(&c.to_bytes())` is `c` with `checksum_ok`.
    pub fn to_bytes(&self) -> [u8; 32] {
        let mut b = [0u8; 32];
        for (o, r, uid) in [
            (0x00, &self.fast, self.uid[0]),
            (0x10, &self.slow, self.uid[1]),
        ] {
            for (i, v) in r.zero.iter().chain(r.scale.iter()).enumerate() {
                b[o + 2 * i..o + 2 * i + 2].copy_from_slice(&v.to_be_bytes());
            }
            b[o + 12] = r.degrees_div_6;
            b[o + 13] = uid;
        }
        let crc = calibration_crc(&b);
        b[0x0E..0x10].copy_from_slice(&((crc >> 16) as u16).to_be_bytes());
        b[0x1E..0x20].copy_from_slice(&(crc as u16).to_be_bytes());
        b
    }

    /// Rates in °/s `[yaw, roll, pitch]` of a report, each axis with the range its slow bit
    /// selects, signed as the block stores them; `None` when a range has a zero reference
    /// rate or `scale == zero`.
    pub fn rate_dps(&self, report: &MotionPlusReport) -> Option<[f32; 3]> {
        let mut out = [0.0f32; 3];
        for (i, o) in out.iter_mut().enumerate() {
            let r = if report.slow[i] {
                &self.slow
            } else {
                &self.fast
            };
            let span = f32::from(r.scale[i]) - f32::from(r.zero[i]);
            if span == 0.0 || r.degrees_div_6 == 0 {
                return None;
            }
            let raw16 = f32::from(report.rate[i]) * 4.0;
            *o = (raw16 - f32::from(r.zero[i])) / span * f32::from(r.degrees_div_6) * 6.0;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_bits_land_where_the_table_says() {
        // yaw = 0x2ABC, roll = 0x1234, pitch = 0x3FFF, yaw slow, pitch fast, roll slow, ext.
        let r = MotionPlusReport {
            rate: [0x2ABC, 0x1234, 0x3FFF],
            slow: [true, true, false],
            extension_connected: true,
        };
        let b = r.to_bytes().unwrap();
        assert_eq!(
            b,
            [
                0xBC,
                0x34,
                0xFF,
                (0x2A << 2) | 0b10,
                (0x12 << 2) | 0b11,
                0xFC | 0b10
            ]
        );
        assert_eq!(MotionPlusReport::decode(&b).unwrap(), r);
        assert!(MotionPlusReport {
            rate: [0x4000, 0, 0],
            ..r
        }
        .to_bytes()
        .is_err());
    }
}
