//! The Nunchuk as seen on the Wii extension bus (I²C target address `0x52`): init
//! sequences, the legacy "encryption", the 6-byte input report, the 16-byte calibration
//! block and the identification bytes.
//!
//! Register map (one byte per address, 0x00–0xFF; WiiBrew "Wiimote/Extension Controllers"
//! and "…/Nunchuck"):
//!
//! | address | content |
//! |---|---|
//! | `0x00`–`0x05` | current input report ([`NunchukReport`]) |
//! | `0x20`–`0x2F` | calibration block ([`CalibrationBlock`]) |
//! | `0x30`–`0x3F` | second copy of the calibration block |
//! | `0x40`–`0x4F` | encryption key (writing `0x00` to `0x40` = legacy encrypted init) |
//! | `0xF0`, `0xFB` | unencrypted init (`0x55` → `0xF0`, then `0x00` → `0xFB`) |
//! | `0xFA`–`0xFF` | identification [`ID`] = `00 00 A4 20 00 00` |

use crate::error::{pick_copy, Checked, Error, FromCopies};
use crate::packing::{self, exact, pack_xxyyzz, unpack_xxyyzz, MAX_10BIT};

/// 7-bit I²C address of every Wii extension controller.
pub const I2C_ADDRESS: u8 = 0x52;

/// Register of the first byte of the input report.
pub const DATA_REGISTER: u8 = 0x00;
/// Register of the first calibration block.
pub const CALIBRATION_REGISTER: u8 = 0x20;
/// Register of the backup copy of the calibration block.
pub const CALIBRATION_BACKUP_REGISTER: u8 = 0x30;
/// First register of the encryption key; a write here starts the legacy encrypted mode.
pub const KEY_REGISTER: u8 = 0x40;
/// First register of the 6 identification bytes.
pub const ID_REGISTER: u8 = 0xFA;
/// Identification bytes of a Nunchuk at [`ID_REGISTER`] (the `A4 20` is common to all
/// extensions; the trailing `00 00` says "Nunchuk").
pub const ID: [u8; 6] = [0x00, 0x00, 0xA4, 0x20, 0x00, 0x00];

/// One register write on the extension bus: the I²C write transaction is
/// `[register, value]` addressed to [`I2C_ADDRESS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RegisterWrite {
    /// Register address (first byte of the I²C write).
    pub register: u8,
    /// Value written (second byte).
    pub value: u8,
}

impl RegisterWrite {
    /// The bytes of the I²C write transaction.
    pub const fn to_bytes(self) -> [u8; 2] {
        [self.register, self.value]
    }

    /// Parse a 2-byte I²C write transaction.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, Error> {
        let [register, value] = exact::<2>(bytes)?;
        Ok(Self { register, value })
    }
}

/// The unencrypted init: write `0x55` to `0xF0`, then `0x00` to `0xFB`. Afterwards the
/// extension returns plain bytes.
pub const INIT_UNENCRYPTED: [RegisterWrite; 2] = [
    RegisterWrite {
        register: 0xF0,
        value: 0x55,
    },
    RegisterWrite {
        register: 0xFB,
        value: 0x00,
    },
];

/// The legacy (original Wii) init: write `0x00` to `0x40`, which leaves an all-zero key so
/// that every byte read back is "encrypted" as described in [`Encryption::Legacy`].
pub const INIT_ENCRYPTED: [RegisterWrite; 1] = [RegisterWrite {
    register: KEY_REGISTER,
    value: 0x00,
}];

/// How the bytes read from the extension are transformed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encryption {
    /// Plain bytes (after [`INIT_UNENCRYPTED`]).
    #[default]
    None,
    /// Legacy zero-key encryption (after [`INIT_ENCRYPTED`]): the reader recovers the plain
    /// byte as `(x ^ 0x17) + 0x17` (mod 256), so the extension sends `(p - 0x17) ^ 0x17`.
    Legacy,
}

impl Encryption {
    /// The register writes that put an extension in this mode.
    pub const fn init_sequence(self) -> &'static [RegisterWrite] {
        match self {
            Encryption::None => &INIT_UNENCRYPTED,
            Encryption::Legacy => &INIT_ENCRYPTED,
        }
    }

    /// Transform a plain byte into what travels on the bus (extension side).
    #[inline]
    pub const fn encode_byte(self, plain: u8) -> u8 {
        match self {
            Encryption::None => plain,
            Encryption::Legacy => plain.wrapping_sub(0x17) ^ 0x17,
        }
    }

    /// Recover the plain byte from a byte read off the bus (Wii Remote side).
    #[inline]
    pub const fn decode_byte(self, wire: u8) -> u8 {
        match self {
            Encryption::None => wire,
            Encryption::Legacy => (wire ^ 0x17).wrapping_add(0x17),
        }
    }

    /// [`Self::encode_byte`] over a buffer, in place.
    pub fn encode_in_place(self, buf: &mut [u8]) {
        for b in buf {
            *b = self.encode_byte(*b);
        }
    }

    /// [`Self::decode_byte`] over a buffer, in place.
    pub fn decode_in_place(self, buf: &mut [u8]) {
        for b in buf {
            *b = self.decode_byte(*b);
        }
    }
}

/// The 6-byte Nunchuk input report (registers `0x00`–`0x05`), decrypted.
///
/// | byte | bits |
/// |---|---|
/// | 0 | stick X |
/// | 1 | stick Y |
/// | 2 | accel X bits 9..2 |
/// | 3 | accel Y bits 9..2 |
/// | 4 | accel Z bits 9..2 |
/// | 5 | Z\[1:0\] (7–6), Y\[1:0\] (5–4), X\[1:0\] (3–2), C (1), Z button (0) |
///
/// Buttons are active-low on the bus (bit clear = pressed); here `true` means pressed.
/// Accelerometer values are raw 10-bit counts (0..=1023); about 200 counts per g on a
/// real Nunchuk (≈50 per g in the 8-bit high byte), zero-g near 512.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NunchukReport {
    /// Joystick `[x, y]`, raw 8-bit (centre ≈ 128, see [`CalibrationBlock::stick_x`]).
    pub stick: [u8; 2],
    /// Accelerometer `[x, y, z]`, raw 10-bit counts.
    pub accel: [u16; 3],
    /// C button pressed.
    pub c: bool,
    /// Z button pressed.
    pub z: bool,
}

impl NunchukReport {
    /// Length of the report in bytes.
    pub const LEN: usize = 6;

    /// Decode a plain (decrypted) report. Every 6-byte input is a valid report.
    pub const fn from_bytes(b: &[u8; 6]) -> Self {
        let lsb = b[5];
        Self {
            stick: [b[0], b[1]],
            accel: [
                ((b[2] as u16) << 2) | ((lsb >> 2) & 0b11) as u16,
                ((b[3] as u16) << 2) | ((lsb >> 4) & 0b11) as u16,
                ((b[4] as u16) << 2) | ((lsb >> 6) & 0b11) as u16,
            ],
            c: lsb & 0b10 == 0,
            z: lsb & 0b01 == 0,
        }
    }

    /// Decode a plain report from a slice, which must be exactly 6 bytes long.
    pub fn decode(bytes: &[u8]) -> Result<Self, Error> {
        Ok(Self::from_bytes(&exact::<6>(bytes)?))
    }

    /// Decode a report read from the bus in the given [`Encryption`] mode.
    pub fn decode_with(bytes: &[u8], enc: Encryption) -> Result<Self, Error> {
        let mut b = exact::<6>(bytes)?;
        enc.decode_in_place(&mut b);
        Ok(Self::from_bytes(&b))
    }

    /// Encode to the plain 6 bytes. Accelerometer values above 1023 are clamped to 1023
    /// (the sensor's rail), so encoding never fails; for values in range,
    /// `from_bytes(&r.to_bytes()) == r` exactly.
    pub fn to_bytes(&self) -> [u8; 6] {
        let a = self.accel.map(|v| v.min(MAX_10BIT));
        let lsb = (((a[2] & 0b11) as u8) << 6)
            | (((a[1] & 0b11) as u8) << 4)
            | (((a[0] & 0b11) as u8) << 2)
            | (u8::from(!self.c) << 1)
            | u8::from(!self.z);
        [
            self.stick[0],
            self.stick[1],
            (a[0] >> 2) as u8,
            (a[1] >> 2) as u8,
            (a[2] >> 2) as u8,
            lsb,
        ]
    }

    /// Encode as the extension sends it in the given [`Encryption`] mode.
    pub fn encode_with(&self, enc: Encryption) -> [u8; 6] {
        let mut b = self.to_bytes();
        enc.encode_in_place(&mut b);
        b
    }

    /// High 8 bits of each accelerometer axis (the value 8-bit-only readers use).
    pub fn accel_8bit(&self) -> [u8; 3] {
        self.accel.map(|v| (v.min(MAX_10BIT) >> 2) as u8)
    }
}

/// Joystick calibration of one axis: raw 8-bit stick values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StickAxisCalibration {
    /// Value at full deflection right/up.
    pub max: u8,
    /// Value at full deflection left/down.
    pub min: u8,
    /// Value at rest.
    pub centre: u8,
}

/// The Nunchuk's 16-byte calibration block (registers `0x20`–`0x2F`, copy at `0x30`).
///
/// | offset | content |
/// |---|---|
/// | 0–2 | zero-g X, Y, Z bits 9..2 |
/// | 3 | zero-g low bits, **assumed** `--XXYYZZ` |
/// | 4–6 | 1-g X, Y, Z bits 9..2 |
/// | 7 | 1-g low bits, **assumed** `--XXYYZZ` |
/// | 8–10 | stick X max, min, centre |
/// | 11–13 | stick Y max, min, centre |
/// | 14 | checksum 1 = (sum of bytes 0..=13) + 0x55 |
/// | 15 | checksum 2 = checksum 1 + 0x55 |
///
/// **LSB packing assumption.** The order of the low bits in bytes 3 and 7 is not
/// documented for the Nunchuk (the Wiimote Project wiki lists it as unknown); this crate
/// assumes the Wii Remote's `--XXYYZZ` (WiiBrew, "EEPROM Memory"). The high bytes are
/// certain, so [`Self::zero_8bit`]/[`Self::one_g_8bit`] are the safe values; the low two
/// bits of `zero`/`one_g` may be permuted between axes. For the real block in
/// `wii_calibration_bytes` this gives zero (496, 502, 493) and one-g (701, 696, 695),
/// versus 8-bit zero (124, 125, 123) and one-g (175, 174, 173).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CalibrationBlock {
    /// Accelerometer reading at 0 g per axis, 10-bit counts.
    pub zero: [u16; 3],
    /// Accelerometer reading at +1 g per axis, 10-bit counts.
    pub one_g: [u16; 3],
    /// Joystick X calibration.
    pub stick_x: StickAxisCalibration,
    /// Joystick Y calibration.
    pub stick_y: StickAxisCalibration,
}

/// The two checksum bytes of a Nunchuk calibration block from its first 14 bytes.
pub fn calibration_checksum(data: &[u8; 14]) -> [u8; 2] {
    let c1 = data.iter().fold(0x55u8, |acc, &b| acc.wrapping_add(b));
    [c1, c1.wrapping_add(0x55)]
}

impl CalibrationBlock {
    /// Length of the block in bytes.
    pub const LEN: usize = 16;

    /// Decode a 16-byte block. The values are returned even when the checksum fails.
    pub fn from_bytes(b: &[u8; 16]) -> Checked<Self> {
        let mut data = [0u8; 14];
        data.copy_from_slice(&b[..14]);
        let checksum_ok = calibration_checksum(&data) == [b[14], b[15]];
        Checked {
            value: Self {
                zero: unpack_xxyyzz([b[0], b[1], b[2]], b[3]),
                one_g: unpack_xxyyzz([b[4], b[5], b[6]], b[7]),
                stick_x: StickAxisCalibration {
                    max: b[8],
                    min: b[9],
                    centre: b[10],
                },
                stick_y: StickAxisCalibration {
                    max: b[11],
                    min: b[12],
                    centre: b[13],
                },
            },
            checksum_ok,
        }
    }

    /// Decode a block from a slice, which must be exactly 16 bytes long.
    pub fn decode(bytes: &[u8]) -> Result<Checked<Self>, Error> {
        Ok(Self::from_bytes(&exact::<16>(bytes)?))
    }

    /// Encode to 16 bytes with both checksum bytes computed. Fails with
    /// [`Error::ValueOutOfRange`] if an accelerometer value exceeds 1023.
    pub fn encode(&self) -> Result<[u8; 16], Error> {
        let (zh, zl) = pack_xxyyzz(self.zero)?;
        let (gh, gl) = pack_xxyyzz(self.one_g)?;
        let data = [
            zh[0],
            zh[1],
            zh[2],
            zl,
            gh[0],
            gh[1],
            gh[2],
            gl,
            self.stick_x.max,
            self.stick_x.min,
            self.stick_x.centre,
            self.stick_y.max,
            self.stick_y.min,
            self.stick_y.centre,
        ];
        let [c1, c2] = calibration_checksum(&data);
        let mut out = [0u8; 16];
        out[..14].copy_from_slice(&data);
        out[14] = c1;
        out[15] = c2;
        Ok(out)
    }

    /// Read the two stored copies (registers `0x20` and `0x30`): the first if its checksum
    /// is valid, else the second, else [`Error::BadChecksum`].
    pub fn from_copies(first: &[u8], second: &[u8]) -> Result<FromCopies<Self>, Error> {
        pick_copy(Self::decode(first), Self::decode(second))
    }

    /// [`Self::from_copies`] on the 32 bytes read from registers `0x20`–`0x3F`.
    pub fn from_registers(region: &[u8]) -> Result<FromCopies<Self>, Error> {
        let r = exact::<32>(region)?;
        Self::from_copies(&r[..16], &r[16..])
    }

    /// High 8 bits of the zero-g values (exactly the stored bytes 0–2).
    pub fn zero_8bit(&self) -> [u8; 3] {
        self.zero.map(|v| (v.min(MAX_10BIT) >> 2) as u8)
    }

    /// High 8 bits of the 1-g values (exactly the stored bytes 4–6).
    pub fn one_g_8bit(&self) -> [u8; 3] {
        self.one_g.map(|v| (v.min(MAX_10BIT) >> 2) as u8)
    }

    /// Sensitivity `one_g − zero` per axis, 10-bit counts per g.
    pub fn counts_per_g(&self) -> [i32; 3] {
        packing::counts_per_g(self.zero, self.one_g)
    }

    /// Convert a raw 10-bit accelerometer reading to g with this factory calibration,
    /// `(raw − zero) / (one_g − zero)` per axis. `None` if an axis has `one_g == zero`.
    pub fn accel_to_g(&self, raw: [u16; 3]) -> Option<[f32; 3]> {
        packing::accel_to_g(self.zero, self.one_g, raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legacy_encryption_is_the_documented_formula_and_invertible() {
        for p in 0..=255u8 {
            let wire = Encryption::Legacy.encode_byte(p);
            // Reader side formula, written out independently: (x ^ 0x17) + 0x17 mod 256.
            let decoded = ((u16::from(wire ^ 0x17) + 0x17) & 0xFF) as u8;
            assert_eq!(decoded, p);
            assert_eq!(Encryption::Legacy.decode_byte(wire), p);
            assert_eq!(Encryption::None.encode_byte(p), p);
        }
        // A zero plain byte travels as (0 - 0x17) ^ 0x17 = 0xE9 ^ 0x17 = 0xFE.
        assert_eq!(Encryption::Legacy.encode_byte(0x00), 0xFE);
    }

    #[test]
    fn init_sequences_are_the_documented_writes() {
        let plain: [[u8; 2]; 2] = INIT_UNENCRYPTED.map(RegisterWrite::to_bytes);
        assert_eq!(plain, [[0xF0, 0x55], [0xFB, 0x00]]);
        assert_eq!(INIT_ENCRYPTED.map(RegisterWrite::to_bytes), [[0x40, 0x00]]);
        assert_eq!(Encryption::None.init_sequence(), &INIT_UNENCRYPTED[..]);
        assert_eq!(Encryption::Legacy.init_sequence(), &INIT_ENCRYPTED[..]);
        assert_eq!(
            RegisterWrite::from_bytes(&[0xF0, 0x55]),
            Ok(INIT_UNENCRYPTED[0])
        );
        assert_eq!(
            RegisterWrite::from_bytes(&[0xF0]),
            Err(Error::WrongLength {
                expected: 2,
                got: 1
            })
        );
    }

    #[test]
    fn report_bit_positions() {
        // X = 0b1010101011 (683), Y = 0b0000000001 (1), Z = 0b1111111110 (1022),
        // C pressed, Z released.
        let r = NunchukReport {
            stick: [1, 2],
            accel: [683, 1, 1022],
            c: true,
            z: false,
        };
        // byte5 = ZZ=10 YY=01 XX=11 !C=0 !Z=1 = 0b10_01_11_0_1
        assert_eq!(
            r.to_bytes(),
            [1, 2, 0b1010_1010, 0, 0b1111_1111, 0b1001_1101]
        );
        assert_eq!(NunchukReport::from_bytes(&r.to_bytes()), r);
        // Out of range values clamp to the rail.
        let big = NunchukReport {
            accel: [5000, 1023, 0],
            ..r
        };
        assert_eq!(
            NunchukReport::from_bytes(&big.to_bytes()).accel,
            [1023, 1023, 0]
        );
    }

    #[test]
    fn calibration_encode_refuses_values_above_10_bits() {
        let cal = CalibrationBlock {
            zero: [1024, 0, 0],
            ..Default::default()
        };
        assert_eq!(cal.encode(), Err(Error::ValueOutOfRange));
        assert_eq!(
            CalibrationBlock::decode(&[0; 15]),
            Err(Error::WrongLength {
                expected: 16,
                got: 15
            })
        );
    }
}
