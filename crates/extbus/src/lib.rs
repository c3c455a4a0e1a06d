//! # wiical-extbus
//!
//! `no_std`, allocation-free encoders and decoders for the byte formats of the Wii Remote
//! and its extension bus, as needed to read factory calibrations, decode raw accelerometer
//! samples and emulate a Nunchuk from an adapter:
//!
//! | module | what |
//! |---|---|
//! | [`nunchuk`] | I²C address, init sequences, legacy encryption, 6-byte report, 16-byte calibration block, ID |
//! | [`registers`] | [`NunchukRegisters`]: the Nunchuk register map as a pure I²C-target state machine |
//! | [`motionplus`] | MotionPlus gyro: activation (`0xA600FE`), 6-byte report (14-bit yaw/roll/pitch, slow bits), Nunchuk/Classic pass-through, 32-byte calibration block with CRC-32 |
//! | [`motionplus_registers`] | [`MotionPlusRegisters`]: the MotionPlus register map (`0x53` inactive, `0x52` active) as a pure I²C-target state machine, with the pass-through interleaving |
//! | [`wiimote`] | core input reports `0x30`–`0x37` (buttons + 10/9/9-bit accelerometer) and the EEPROM accelerometer calibration |
//!
//! ## Conventions
//! * Accelerometer values are raw ADC counts on a **10-bit scale** (0..=1023) for both
//!   devices and for calibration blocks, so `raw − zero` and `one_g − zero` are directly
//!   comparable. `one_g − zero` is the sensitivity in counts per g (≈105 for the Wii
//!   Remote's ADXL330, ≈200 for the Nunchuk). Axis directions are the devices' own.
//! * Buttons are `true`/set when pressed, whatever the polarity on the wire.
//! * Every decoder accepts any byte sequence without panicking: wrong lengths and unknown
//!   IDs give an [`Error`]; bad checksums are reported (`Checked::checksum_ok`), not
//!   hidden, and `from_copies` falls back to the second stored copy.
//! * Encoders are exact inverses of the decoders on the representable domain (10-bit
//!   values; Y/Z of a Wii Remote core report have 9 significant bits).
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod motionplus;
pub mod motionplus_registers;
pub mod nunchuk;
mod packing;
pub mod registers;
pub mod wiimote;

pub use error::{CalibrationCopy, Checked, Error, FromCopies};
pub use motionplus::{Frame, MotionPlusCalibration, MotionPlusReport, PassthroughMode};
pub use motionplus_registers::MotionPlusRegisters;
pub use nunchuk::{CalibrationBlock, Encryption, NunchukReport};
pub use registers::NunchukRegisters;
pub use wiimote::{AccelCalibration, Buttons, CoreReport, ReportId};
