//! The CRC-32 that closes every record of the adapter's flash store (calibration, gyro and
//! settings records). Bitwise, without a table: the records are checked at boot and on a
//! commit only, and a 1 KiB table (one per user, as there were) costs the RP2040's flash.

use crc::{Crc, NoTable, CRC_32_ISO_HDLC};

/// CRC-32/ISO-HDLC (the zlib CRC).
pub(crate) static CRC32: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);
