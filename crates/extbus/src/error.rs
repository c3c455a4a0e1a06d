//! The one error type of this crate.

use core::fmt;

/// Why bytes could not be decoded or a value could not be encoded.
///
/// Every decoder in this crate returns one of these instead of panicking, whatever the
/// input bytes are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The input has the wrong number of bytes for the structure being decoded.
    WrongLength {
        /// Number of bytes the structure needs.
        expected: usize,
        /// Number of bytes supplied.
        got: usize,
    },
    /// The output buffer is too small for the encoded structure.
    BufferTooSmall {
        /// Number of bytes needed.
        needed: usize,
        /// Number of bytes available.
        got: usize,
    },
    /// A Wii Remote input report ID this crate does not decode (only `0x30`–`0x37` are).
    UnknownReportId(u8),
    /// The fields of a report do not match the layout of its report ID (e.g. accelerometer
    /// data given for report `0x30`, or an extension slice of the wrong length).
    LayoutMismatch,
    /// A value does not fit the bit width of its encoded field (e.g. an accelerometer
    /// calibration value above 1023 for a 10-bit field).
    ValueOutOfRange,
    /// Neither stored copy of a calibration block has a valid checksum.
    BadChecksum,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::WrongLength { expected, got } => {
                write!(f, "wrong length: expected {expected} bytes, got {got}")
            }
            Error::BufferTooSmall { needed, got } => {
                write!(
                    f,
                    "output buffer too small: need {needed} bytes, have {got}"
                )
            }
            Error::UnknownReportId(id) => write!(f, "unsupported Wii Remote report id 0x{id:02X}"),
            Error::LayoutMismatch => {
                f.write_str("report fields do not match the report id's layout")
            }
            Error::ValueOutOfRange => f.write_str("value does not fit its encoded bit width"),
            Error::BadChecksum => {
                f.write_str("no copy of the calibration block has a valid checksum")
            }
        }
    }
}

impl core::error::Error for Error {}

/// A decoded calibration block together with the result of its checksum test.
///
/// Decoding never refuses a block because of a bad checksum: the values are returned
/// anyway (they are often still informative) and the caller decides; the fallback helpers
/// (`from_copies`) are the ones that act on `checksum_ok`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Checked<T> {
    /// The decoded values.
    pub value: T,
    /// True when the stored checksum byte(s) match the ones computed from the data bytes.
    pub checksum_ok: bool,
}

/// Which stored copy of a duplicated calibration block was used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibrationCopy {
    /// The first copy (Wii Remote EEPROM `0x16`, Nunchuk register `0x20`).
    First,
    /// The backup copy (Wii Remote EEPROM `0x20`, Nunchuk register `0x30`), used because
    /// the first copy's checksum failed.
    Second,
}

/// The result of reading a duplicated calibration block with fallback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FromCopies<T> {
    /// The decoded values of the copy that passed its checksum.
    pub value: T,
    /// Which copy that was.
    pub copy: CalibrationCopy,
}

/// Shared fallback rule (Nintendo's, per WiiBrew): use the first copy if its checksum is
/// correct, else the second, else fail.
pub(crate) fn pick_copy<T>(
    first: Result<Checked<T>, Error>,
    second: Result<Checked<T>, Error>,
) -> Result<FromCopies<T>, Error> {
    let first = first?;
    if first.checksum_ok {
        return Ok(FromCopies {
            value: first.value,
            copy: CalibrationCopy::First,
        });
    }
    let second = second?;
    if second.checksum_ok {
        return Ok(FromCopies {
            value: second.value,
            copy: CalibrationCopy::Second,
        });
    }
    Err(Error::BadChecksum)
}
