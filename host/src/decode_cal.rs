//! `wiical decode-cal`: decode a factory accelerometer calibration block given as hex.
//!
//! * Wii Remote: the 10-byte EEPROM block (address `0x16`, copy at `0x20`), or both copies
//!   as 20 bytes (EEPROM `0x16`–`0x29`), in which case the second is used when the first's
//!   checksum fails (Nintendo's rule).
//! * Nunchuk: the 16-byte block of registers `0x20`–`0x2F`, or 32 bytes `0x20`–`0x3F`
//!   (both copies, same fallback).
//!
//! Values are raw counts on the 10-bit scale; `one_g − zero` is counts per g. For the
//! Nunchuk the order of the low bits is an assumption (see
//! [`wiical_extbus::nunchuk::CalibrationBlock`]), so the 8-bit values are the safe ones.

use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use wiical_extbus::{AccelCalibration, CalibrationBlock, CalibrationCopy, Checked};

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

/// Parse hex bytes written as `82 82 82`, `0x82,0x82`, `828282`, or any mix: tokens are
/// separated by whitespace, commas, semicolons or colons; each token may carry a `0x`
/// prefix and holds an even number of hex digits.
pub fn parse_hex(text: &str) -> Result<Vec<u8>> {
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
            bail!("empty hex token {tok:?}");
        }
        if let Some(bad) = digits.chars().find(|c| !c.is_ascii_hexdigit()) {
            bail!("invalid hex digit {bad:?} in {tok:?}");
        }
        if digits.len() % 2 != 0 {
            bail!("odd number of hex digits in {tok:?}: write each byte as two digits (e.g. 0F)");
        }
        for pair in digits.as_bytes().chunks(2) {
            let s = std::str::from_utf8(pair)?;
            out.push(u8::from_str_radix(s, 16)?);
        }
    }
    if out.is_empty() {
        bail!("no hex bytes given");
    }
    Ok(out)
}

fn hex_string(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Pick the copy to report: the first if its checksum passes, else the second if it passes,
/// else the first (reported with `checksum_ok: false`).
fn choose<T: Copy>(first: Checked<T>, second: Option<Checked<T>>) -> (Checked<T>, CalibrationCopy) {
    match second {
        Some(s) if !first.checksum_ok && s.checksum_ok => (s, CalibrationCopy::Second),
        _ => (first, CalibrationCopy::First),
    }
}

/// Splits `bytes` into one or two stored copies of an `n`-byte block, decodes them and picks
/// the copy to use ([`choose`]). Returns the decoded copy, which one it is, and its bytes.
fn decode_copies<T: Copy>(
    bytes: &[u8],
    n: usize,
    decode: impl Fn(&[u8]) -> Result<Checked<T>, wiical_extbus::Error>,
    length_error: impl Fn(usize, usize) -> String,
) -> Result<(Checked<T>, CalibrationCopy, &[u8])> {
    if bytes.len() != n && bytes.len() != 2 * n {
        bail!("{}", length_error(n, bytes.len()));
    }
    let (first_bytes, rest) = bytes.split_at(n);
    let first = decode(first_bytes).map_err(|e| anyhow!(e))?;
    let second = if rest.is_empty() {
        None
    } else {
        Some(decode(rest).map_err(|e| anyhow!(e))?)
    };
    let (c, copy) = choose(first, second);
    let used = match copy {
        CalibrationCopy::First => first_bytes,
        CalibrationCopy::Second => rest,
    };
    Ok((c, copy, used))
}

/// Decode a calibration block of `device` (`"wiimote"` or `"nunchuk"`) from hex text.
pub fn decode_cal(device: &str, hex: &str) -> Result<DecodeCalReport> {
    let bytes = parse_hex(hex)?;
    let dev = device.trim().to_ascii_lowercase();
    match dev.as_str() {
        "wiimote" | "wii-remote" | "wiiremote" => {
            let (c, copy, used) = decode_copies(
                &bytes,
                AccelCalibration::LEN,
                AccelCalibration::decode,
                |n, got| {
                    format!(
                        "a Wii Remote calibration block has {n} bytes (or {} for both EEPROM \
                         copies 0x16 and 0x20), got {got}",
                        2 * n
                    )
                },
            )?;
            let n = AccelCalibration::LEN;
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
                bytes_hex: hex_string(used),
            })
        }
        "nunchuk" | "nunchuck" => {
            let (c, copy, used) = decode_copies(
                &bytes,
                CalibrationBlock::LEN,
                CalibrationBlock::decode,
                |n, got| {
                    format!(
                        "a Nunchuk calibration block has {n} bytes (registers 0x20-0x2F; or {} \
                         for 0x20-0x3F, both copies), got {got}",
                        2 * n
                    )
                },
            )?;
            let n = CalibrationBlock::LEN;
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
                bytes_hex: hex_string(used),
            })
        }
        _ => {
            bail!("unknown device {device:?}: expected \"wiimote\", \"nunchuk\" or \"motionplus\"")
        }
    }
}

fn copy_name(c: CalibrationCopy) -> String {
    match c {
        CalibrationCopy::First => "first",
        CalibrationCopy::Second => "second",
    }
    .into()
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
