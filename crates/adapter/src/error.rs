//! Error types. Each carries the error of the hardware behind it (`E`: the I²C bus error of
//! the HAL, or the flash error), so that the firmware can log what really happened.

use core::fmt;

/// Why one step of the [`crate::NunchukPoller`] failed.
///
/// After an error the poller may still be connected (a single glitch is tolerated, see
/// [`crate::PollerConfig::max_failures`]); [`crate::NunchukPoller::is_connected`] tells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error<E> {
    /// An I²C transaction failed: NAK (nothing plugged in, or the device refused the
    /// bytes), timeout, arbitration loss… The HAL's error is inside.
    Bus(E),
    /// The report (or the ID) read back was all `0x00` or all `0xFF`: the bus is floating
    /// (extension unplugged while the pull-ups hold the lines) or the extension lost its
    /// init (replugged, brown-out).
    Garbage,
    /// The device at `0x52` answered but is not a Nunchuk; these are its (decrypted) ID bytes.
    NotANunchuk([u8; 6]),
    /// The device at `0x53` answered but is not a MotionPlus; these are its ID bytes.
    NotAMotionPlus([u8; 6]),
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "I2C bus error: {e:?}"),
            Error::Garbage => f.write_str("extension returned all-0x00/0xFF bytes"),
            Error::NotANunchuk(id) => write!(f, "extension is not a Nunchuk (ID {id:02X?})"),
            Error::NotAMotionPlus(id) => write!(f, "device is not a MotionPlus (ID {id:02X?})"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}

/// Why the [`crate::CalibrationStore`] could not read or write the flash. `E` is the flash
/// driver's error.
#[derive(Debug)]
pub enum StoreError<E> {
    /// The flash range given to the store is unusable (not page aligned, fewer than 2 pages,
    /// pages too small for a record).
    Config(sequential_storage::map::MapConfigError),
    /// `sequential-storage` failed: a flash driver error, or storage it could not repair.
    Flash(sequential_storage::Error<E>),
}

impl<E: fmt::Debug> fmt::Display for StoreError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StoreError::Config(e) => write!(f, "bad flash range for the calibration store: {e:?}"),
            StoreError::Flash(e) => write!(f, "calibration storage failed: {e:?}"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for StoreError<E> {}

/// Why a stored calibration record was not used. Whatever the reason, the adapter then runs
/// without a user calibration (pass-through), never with a damaged one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordError {
    /// The record does not have the length of any known version.
    WrongLength(usize),
    /// The record does not start with the magic bytes (not a calibration record).
    BadMagic,
    /// A record version this firmware does not know (written by a newer firmware).
    UnsupportedVersion(u16),
    /// The record's own CRC-32 does not match its bytes.
    BadCrc,
    /// The bytes are intact but the calibration is unusable (non-finite or singular `K`).
    Invalid(wiical_core::Error),
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::WrongLength(n) => write!(f, "calibration record has wrong length {n}"),
            RecordError::BadMagic => f.write_str("not a calibration record (bad magic)"),
            RecordError::UnsupportedVersion(v) => {
                write!(f, "calibration record version {v} is not supported")
            }
            RecordError::BadCrc => f.write_str("calibration record CRC mismatch"),
            RecordError::Invalid(e) => write!(f, "stored calibration is unusable: {e}"),
        }
    }
}

impl core::error::Error for RecordError {}
