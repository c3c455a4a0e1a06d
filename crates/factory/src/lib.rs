//! Factory calibration blocks of the Wii Remote, the Nunchuk and the MotionPlus, decoded for
//! people: `wiical decode-cal` (one block given as hex, [`decode_cal`],
//! [`motionplus_calibration`]) and the side file of `wiical capture` (both stored copies,
//! [`wiimote_calibration`], [`nunchuk_calibration`]). The byte formats and Nintendo's
//! copy-choosing rule (the first copy whose checksum is correct) are `wiical_extbus`'s; this
//! module only reports them, with one rule for every caller.
//!
//! * Wii Remote: the 10-byte EEPROM block (address `0x16`, copy at `0x20`), or both copies
//!   as 20 bytes (EEPROM `0x16`–`0x29`).
//! * Nunchuk: the 16-byte block of registers `0x20`–`0x2F`, or 32 bytes `0x20`–`0x3F`
//!   (both copies).
//! * MotionPlus: the 32-byte gyro block at `0xA60020`, CRC-32 checked.
//!
//! Values are raw counts on the 10-bit scale; `one_g − zero` is counts per g. For the
//! Nunchuk the order of the low bits is an assumption (see
//! [`wiical_extbus::nunchuk::CalibrationBlock`]), so the 8-bit values are the safe ones.

use serde::Serialize;
use wiical_extbus::motionplus::{MotionPlusCalibration, RangeCalibration};
use wiical_extbus::nunchuk::CalibrationBlock;
use wiical_extbus::wiimote::{EEPROM_CALIBRATION_ADDR, EEPROM_CALIBRATION_BACKUP_ADDR};
use wiical_extbus::{AccelCalibration, CalibrationCopy, Checked, FromCopies};

/// What can be wrong with a calibration block given to decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FactoryError {
    /// No byte in the text.
    #[error("no hex bytes given")]
    NoBytes,
    /// A `0x` with no digits.
    #[error("empty hex token {0:?}")]
    EmptyToken(String),
    /// A character that is not a hex digit.
    #[error("invalid hex digit {digit:?} in {token:?}")]
    BadDigit {
        /// The character.
        digit: char,
        /// The token it is in.
        token: String,
    },
    /// A token with an odd number of digits.
    #[error("odd number of hex digits in {0:?}: write each byte as two digits (e.g. 0F)")]
    OddDigits(String),
    /// A Wii Remote block of the wrong length.
    #[error("a Wii Remote calibration block has {n} bytes (or {} for both EEPROM copies 0x16 and 0x20), got {got}", 2 * n)]
    WiimoteLength {
        /// One copy's length.
        n: usize,
        /// Bytes given.
        got: usize,
    },
    /// A Nunchuk block of the wrong length.
    #[error("a Nunchuk calibration block has {n} bytes (registers 0x20-0x2F; or {} for 0x20-0x3F, both copies), got {got}", 2 * n)]
    NunchukLength {
        /// One copy's length.
        n: usize,
        /// Bytes given.
        got: usize,
    },
    /// A device name that is none of the three.
    #[error("unknown device {0:?}: expected \"wiimote\", \"nunchuk\" or \"motionplus\"")]
    UnknownDevice(String),
    /// The capture's side file needs both stored copies.
    #[error("{what}: {n} bytes expected")]
    SideFileLength {
        /// Which block.
        what: &'static str,
        /// Bytes needed.
        n: usize,
    },
    /// The extension-bus decoder refused an accelerometer block.
    #[error("{0}")]
    Block(wiical_extbus::Error),
    /// The extension-bus decoder refused a MotionPlus block.
    #[error("MotionPlus calibration: {0}")]
    MotionPlus(wiical_extbus::Error),
}

/// Which device a block belongs to (`--device`; case-insensitive, with the common
/// spellings).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Device {
    /// Wii Remote (EEPROM accelerometer block).
    Wiimote,
    /// Nunchuk (extension registers `0x20`–`0x3F`).
    Nunchuk,
    /// MotionPlus (gyro block at `0xA60020`).
    MotionPlus,
}

impl std::str::FromStr for Device {
    type Err = FactoryError;
    fn from_str(s: &str) -> Result<Self, FactoryError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "wiimote" | "wii-remote" | "wiiremote" => Ok(Device::Wiimote),
            "nunchuk" | "nunchuck" => Ok(Device::Nunchuk),
            "motionplus" | "motion-plus" | "wmp" => Ok(Device::MotionPlus),
            _ => Err(FactoryError::UnknownDevice(s.to_string())),
        }
    }
}

/// Bytes as uppercase hex separated by spaces (`82 82 82`).
pub fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `"first"` or `"second"`.
fn copy_name(c: CalibrationCopy) -> String {
    match c {
        CalibrationCopy::First => "first",
        CalibrationCopy::Second => "second",
    }
    .into()
}

/// Parse hex bytes written as `82 82 82`, `0x82,0x82`, `828282`, or any mix: tokens are
/// separated by whitespace, commas, semicolons or colons; each token may carry a `0x`
/// prefix and holds an even number of hex digits.
pub fn parse_hex(text: &str) -> Result<Vec<u8>, FactoryError> {
    let mut out = Vec::new();
    let tokens = text
        .split(|c: char| c.is_whitespace() || matches!(c, ',' | ';' | ':'))
        .filter(|t| !t.is_empty());
    for tok in tokens {
        let digits = tok
            .strip_prefix("0x")
            .or_else(|| tok.strip_prefix("0X"))
            .unwrap_or(tok);
        if digits.is_empty() {
            return Err(FactoryError::EmptyToken(tok.into()));
        }
        if let Some(bad) = digits.chars().find(|c| !c.is_ascii_hexdigit()) {
            return Err(FactoryError::BadDigit {
                digit: bad,
                token: tok.into(),
            });
        }
        if digits.len() % 2 != 0 {
            return Err(FactoryError::OddDigits(tok.into()));
        }
        // All ASCII hex digits: every pair is a byte.
        for pair in digits.as_bytes().chunks(2) {
            let v = |c: u8| (c as char).to_digit(16).unwrap_or(0) as u8;
            out.push(v(pair[0]) << 4 | v(pair[1]));
        }
    }
    if out.is_empty() {
        return Err(FactoryError::NoBytes);
    }
    Ok(out)
}

/// Joystick calibration of one axis (Nunchuk only), raw 8-bit stick values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct StickAxisReport {
    /// Full deflection right/up.
    pub max: u8,
    /// Full deflection left/down.
    pub min: u8,
    /// At rest.
    pub centre: u8,
}

/// Decoded calibration block (the JSON of `wiical decode-cal --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecodeCalReport {
    /// `"wiimote"` or `"nunchuk"`.
    pub device: String,
    /// Zero-g reading per axis (X, Y, Z), 10-bit counts.
    pub zero: [u16; 3],
    /// +1 g reading per axis, 10-bit counts.
    pub one_g: [u16; 3],
    /// Whether the checksum of the block used is correct.
    pub checksum_ok: bool,
    /// Zero-g high bytes, 8-bit counts (exactly as stored).
    pub zero_8bit: [u8; 3],
    /// +1 g high bytes, 8-bit counts (exactly as stored).
    pub one_g_8bit: [u8; 3],
    /// Sensitivity `one_g − zero` per axis, 10-bit counts per g.
    pub counts_per_g: [i32; 3],
    /// Number of stored copies given (1 or 2).
    pub copies_given: usize,
    /// Which copy the values come from: `"first"` or `"second"` (the second only when the
    /// first's checksum fails and the second's passes).
    pub copy_used: String,
    /// Whether the bit order of the packed low bits is documented for this device
    /// (Wii Remote: yes, `--XXYYZZ`; Nunchuk: assumed the same, not confirmed).
    pub lsb_order_confirmed: bool,
    /// Joystick X calibration (Nunchuk only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stick_x: Option<StickAxisReport>,
    /// Joystick Y calibration (Nunchuk only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stick_y: Option<StickAxisReport>,
    /// The bytes decoded, as uppercase hex separated by spaces.
    pub bytes_hex: String,
}

/// One or two stored copies of an `n`-byte block, decoded, and the copy Nintendo's rule
/// picks (`wiical_extbus`'s `from_copies`): the first if its checksum passes, else the
/// second if it passes; when none passes, the first, reported with `checksum_ok: false`.
/// Returns the copy, which one it is, and its bytes.
fn decode_copies<T: Copy>(
    bytes: &[u8],
    n: usize,
    decode: impl Fn(&[u8]) -> Result<Checked<T>, wiical_extbus::Error>,
    from_copies: impl Fn(&[u8], &[u8]) -> Result<FromCopies<T>, wiical_extbus::Error>,
) -> Result<(Checked<T>, CalibrationCopy, &[u8]), FactoryError> {
    let (first, rest) = bytes.split_at(n.min(bytes.len()));
    let first_copy = decode(first).map_err(FactoryError::Block)?;
    if rest.is_empty() {
        return Ok((first_copy, CalibrationCopy::First, first));
    }
    decode(rest).map_err(FactoryError::Block)?;
    Ok(match from_copies(first, rest) {
        Ok(FromCopies {
            value,
            copy: CalibrationCopy::Second,
        }) => (
            Checked {
                value,
                checksum_ok: true,
            },
            CalibrationCopy::Second,
            rest,
        ),
        _ => (first_copy, CalibrationCopy::First, first),
    })
}

/// Decode an accelerometer calibration block of `device` (`"wiimote"` or `"nunchuk"`) from
/// hex text (`wiical decode-cal`). A block whose checksum fails in every copy is decoded
/// anyway, with `checksum_ok: false`.
pub fn decode_cal(device: &str, hex_text: &str) -> Result<DecodeCalReport, FactoryError> {
    let bytes = parse_hex(hex_text)?;
    match device.parse::<Device>()? {
        Device::Wiimote => decode_wiimote(&bytes),
        Device::Nunchuk => decode_nunchuk(&bytes),
        Device::MotionPlus => Err(FactoryError::UnknownDevice(device.to_string())),
    }
}

fn decode_wiimote(bytes: &[u8]) -> Result<DecodeCalReport, FactoryError> {
    let n = AccelCalibration::LEN;
    if bytes.len() != n && bytes.len() != 2 * n {
        return Err(FactoryError::WiimoteLength {
            n,
            got: bytes.len(),
        });
    }
    let (c, copy, used) = decode_copies(
        bytes,
        n,
        AccelCalibration::decode,
        AccelCalibration::from_copies,
    )?;
    let v = c.value;
    Ok(DecodeCalReport {
        device: "wiimote".into(),
        zero: v.zero,
        one_g: v.one_g,
        checksum_ok: c.checksum_ok,
        zero_8bit: v.zero.map(|z| (z >> 2) as u8),
        one_g_8bit: v.one_g.map(|z| (z >> 2) as u8),
        counts_per_g: v.counts_per_g(),
        copies_given: bytes.len() / n,
        copy_used: copy_name(copy),
        lsb_order_confirmed: true,
        stick_x: None,
        stick_y: None,
        bytes_hex: hex(used),
    })
}

fn decode_nunchuk(bytes: &[u8]) -> Result<DecodeCalReport, FactoryError> {
    let n = CalibrationBlock::LEN;
    if bytes.len() != n && bytes.len() != 2 * n {
        return Err(FactoryError::NunchukLength {
            n,
            got: bytes.len(),
        });
    }
    let (c, copy, used) = decode_copies(
        bytes,
        n,
        CalibrationBlock::decode,
        CalibrationBlock::from_copies,
    )?;
    let v = c.value;
    let stick = |s: wiical_extbus::nunchuk::StickAxisCalibration| StickAxisReport {
        max: s.max,
        min: s.min,
        centre: s.centre,
    };
    Ok(DecodeCalReport {
        device: "nunchuk".into(),
        zero: v.zero,
        one_g: v.one_g,
        checksum_ok: c.checksum_ok,
        zero_8bit: v.zero_8bit(),
        one_g_8bit: v.one_g_8bit(),
        counts_per_g: v.counts_per_g(),
        copies_given: bytes.len() / n,
        copy_used: copy_name(copy),
        lsb_order_confirmed: false,
        stick_x: Some(stick(v.stick_x)),
        stick_y: Some(stick(v.stick_y)),
        bytes_hex: hex(used),
    })
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

/// Decodes the 20 EEPROM bytes `0x0016`–`0x0029`.
pub fn wiimote_calibration(bytes: &[u8]) -> Result<FactoryCalibration, FactoryError> {
    let addrs = [EEPROM_CALIBRATION_ADDR, EEPROM_CALIBRATION_BACKUP_ADDR];
    let mut copies = Vec::new();
    for (k, a) in addrs.iter().enumerate() {
        let b = bytes
            .get(k * 10..k * 10 + 10)
            .ok_or(FactoryError::SideFileLength {
                what: "EEPROM calibration",
                n: 20,
            })?;
        let c = AccelCalibration::decode(b).map_err(FactoryError::Block)?;
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
pub fn nunchuk_calibration(bytes: &[u8]) -> Result<FactoryCalibration, FactoryError> {
    let mut copies = Vec::new();
    for (k, a) in [0xA4_0020u32, 0xA4_0030].iter().enumerate() {
        let b = bytes
            .get(k * 16..k * 16 + 16)
            .ok_or(FactoryError::SideFileLength {
                what: "Nunchuk calibration",
                n: 32,
            })?;
        let c = CalibrationBlock::decode(b).map_err(FactoryError::Block)?;
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
pub fn motionplus_calibration(
    bytes: &[u8],
    mode: Option<u8>,
) -> Result<MotionPlusFactory, FactoryError> {
    let c = MotionPlusCalibration::decode(bytes).map_err(FactoryError::MotionPlus)?;
    Ok(MotionPlusFactory {
        hex: hex(bytes),
        checksum_ok: c.checksum_ok,
        fast: GyroRange::of(&c.value.fast),
        slow: GyroRange::of(&c.value.slow),
        uid: c.value.uid,
        mode,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const WIIBREW: &str = "82 82 82 15 9C 9C 9E 38 40 3E";
    const NUNCHUK: &str = "7C 7D 7B 09 AF AE AD 13 DF 18 81 E3 20 81 EB 40";

    #[test]
    fn wiibrew_block_decodes_to_the_documented_values() {
        let r = decode_cal("wiimote", WIIBREW).unwrap();
        assert_eq!(r.zero, [521, 521, 521]);
        assert_eq!(r.one_g, [627, 626, 632]);
        assert!(r.checksum_ok);
        assert_eq!(r.zero_8bit, [0x82; 3]);
        assert_eq!(r.one_g_8bit, [0x9C, 0x9C, 0x9E]);
        assert_eq!(r.counts_per_g, [106, 105, 111]);
        assert_eq!(r.copies_given, 1);
        assert_eq!(r.copy_used, "first");
        assert_eq!(r.bytes_hex, WIIBREW);
    }

    #[test]
    fn hex_forms_are_tolerated() {
        let forms = [
            "0x82,0x82,0x82,0x15,0x9c,0x9C,0x9E,0x38,0x40,0x3E",
            "82828215 9C9C9E38 403E",
            "  82:82:82:15:9C:9C:9E:38:40:3E\n",
            "0X82, 82; 82 15 9c 9c 9e 38 40 3e",
        ];
        for f in forms {
            let r = decode_cal("wiimote", f).unwrap();
            assert_eq!((r.zero, r.one_g), ([521; 3], [627, 626, 632]), "{f}");
        }
    }

    #[test]
    fn bad_hex_and_lengths_give_clear_errors() {
        let e = decode_cal("wiimote", "82 82 8G").unwrap_err().to_string();
        assert!(e.contains("'G'") && e.contains("8G"), "{e}");
        let e = decode_cal("wiimote", "82 82 828").unwrap_err().to_string();
        assert!(e.contains("odd number"), "{e}");
        let e = decode_cal("wiimote", "82 82 82").unwrap_err().to_string();
        assert!(e.contains("10 bytes") && e.contains("got 3"), "{e}");
        let e = decode_cal("nunchuk", WIIBREW).unwrap_err().to_string();
        assert!(e.contains("16 bytes") && e.contains("got 10"), "{e}");
        let e = decode_cal("classic", WIIBREW).unwrap_err().to_string();
        assert!(e.contains("unknown device"), "{e}");
        assert!(decode_cal("wiimote", " , ").is_err());
        assert!(decode_cal("wiimote", "0x").is_err());
    }

    #[test]
    fn bad_checksum_is_reported_and_the_backup_copy_used() {
        let corrupt = "82 82 82 15 9C 9C 9E 38 40 3F";
        let r = decode_cal("wiimote", corrupt).unwrap();
        assert!(!r.checksum_ok);
        let both = format!("{corrupt} {WIIBREW}");
        let r = decode_cal("wiimote", &both).unwrap();
        assert!(r.checksum_ok);
        assert_eq!(r.copy_used, "second");
        assert_eq!(r.copies_given, 2);
        assert_eq!(r.one_g, [627, 626, 632]);
        // Both bad: the first is reported, flagged.
        let r = decode_cal("wiimote", &format!("{corrupt} {corrupt}")).unwrap();
        assert_eq!((r.checksum_ok, r.copy_used.as_str()), (false, "first"));
    }

    #[test]
    fn nunchuk_block_and_json_keys() {
        let r = decode_cal("Nunchuk", &format!("{NUNCHUK} {NUNCHUK}")).unwrap();
        assert!(r.checksum_ok);
        assert_eq!(r.zero_8bit, [124, 125, 123]);
        assert_eq!(r.one_g_8bit, [175, 174, 173]);
        assert_eq!(r.zero, [496, 502, 493]);
        assert_eq!(r.one_g, [701, 696, 695]);
        assert!(!r.lsb_order_confirmed);
        assert_eq!(
            r.stick_x,
            Some(StickAxisReport {
                max: 223,
                min: 24,
                centre: 129
            })
        );
        let j = serde_json::to_value(&r).unwrap();
        assert_eq!(j["zero"], serde_json::json!([496, 502, 493]));
        assert_eq!(j["one_g"], serde_json::json!([701, 696, 695]));
        assert_eq!(j["checksum_ok"], serde_json::json!(true));
        assert_eq!(j["stick_y"]["max"], serde_json::json!(227));
        let w = serde_json::to_value(decode_cal("wiimote", WIIBREW).unwrap()).unwrap();
        assert!(w.get("stick_x").is_none());
    }
}
