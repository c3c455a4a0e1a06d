//! 10-bit values split into a high byte and 2 low bits packed elsewhere.

use crate::error::Error;

/// Largest 10-bit value.
pub(crate) const MAX_10BIT: u16 = 0x3FF;

/// Combine three high bytes with a `--XXYYZZ` low-bits byte into 10-bit values.
///
/// This is the Wii Remote EEPROM calibration layout (WiiBrew, "Wiimote" page, "EEPROM
/// Memory": "low 2 bits packed in the fourth byte as --XXYYZZ"). The top two bits of the
/// low-bits byte are ignored.
#[inline]
pub(crate) fn unpack_xxyyzz(hi: [u8; 3], lsb: u8) -> [u16; 3] {
    [
        (u16::from(hi[0]) << 2) | u16::from((lsb >> 4) & 0b11),
        (u16::from(hi[1]) << 2) | u16::from((lsb >> 2) & 0b11),
        (u16::from(hi[2]) << 2) | u16::from(lsb & 0b11),
    ]
}

/// Inverse of [`unpack_xxyyzz`]; refuses values above 1023.
#[inline]
pub(crate) fn pack_xxyyzz(v: [u16; 3]) -> Result<([u8; 3], u8), Error> {
    if v.iter().any(|&x| x > MAX_10BIT) {
        return Err(Error::ValueOutOfRange);
    }
    let hi = [(v[0] >> 2) as u8, (v[1] >> 2) as u8, (v[2] >> 2) as u8];
    let lsb = (((v[0] & 0b11) as u8) << 4) | (((v[1] & 0b11) as u8) << 2) | ((v[2] & 0b11) as u8);
    Ok((hi, lsb))
}

/// Copy a slice into a fixed array, checking its length exactly.
#[inline]
pub(crate) fn exact<const N: usize>(bytes: &[u8]) -> Result<[u8; N], Error> {
    bytes.try_into().map_err(|_| Error::WrongLength {
        expected: N,
        got: bytes.len(),
    })
}

/// Factory sensitivity `one_g − zero` per axis (10-bit counts per g), shared by the Wii Remote
/// EEPROM block and the Nunchuk calibration block, which store the same two points.
#[inline]
pub(crate) fn counts_per_g(zero: [u16; 3], one_g: [u16; 3]) -> [i32; 3] {
    core::array::from_fn(|i| i32::from(one_g[i]) - i32::from(zero[i]))
}

/// `(raw − zero) / (one_g − zero)` per axis; `None` if an axis has `one_g == zero`.
#[inline]
pub(crate) fn accel_to_g(zero: [u16; 3], one_g: [u16; 3], raw: [u16; 3]) -> Option<[f32; 3]> {
    let span = counts_per_g(zero, one_g);
    if span.contains(&0) {
        return None;
    }
    Some(core::array::from_fn(|i| {
        (f32::from(raw[i]) - f32::from(zero[i])) / span[i] as f32
    }))
}
