//! The adapter's stored settings: whether the background recalibration may adopt, whether it
//! may replace a calibration the host uploaded, and who made the stored calibration (so that
//! a host upload stays protected across power cycles).
//!
//! Kept as a second small item beside the calibration in the store's power-loss-safe map
//! ([`crate::CalibrationStore::save_settings`]), with its own magic, version and CRC: a damaged
//! or unknown settings record reads as "none stored" and the defaults apply.
//!
//! ## Record layout (version 1, little-endian, [`SETTINGS_LEN`] bytes)
//! | offset | content |
//! |---|---|
//! | 0 | magic `"WSET"` |
//! | 4 | version `u16` = [`SETTINGS_VERSION`] |
//! | 6 | flags `u8`: bit 0 background adoption on, bit 1 replacing a host upload allowed |
//! | 7 | origin `u8` of the stored calibration: 0 factory, 1 self-calibration, 2 background, 3 host |
//! | 8 | CRC-32/ISO-HDLC of bytes 0..8 |
//!
//! ## Order of the two writes
//! The calibration and its origin are two items, so a power cut can fall between them. The
//! store is written so that the cut can only make a calibration *more* protected, never less:
//! a host upload writes the origin "host" first and the calibration second; every other
//! commit writes the calibration first and its origin second. Either way the worst outcome of
//! a cut is a calibration that the background recalibration treats as a host upload.

use crc::{Crc, CRC_32_ISO_HDLC};

use crate::background::LiveOrigin;

/// Map key of the settings record (the calibration's is [`crate::store::RECORD_KEY`]).
pub const SETTINGS_KEY: u8 = 0x02;
/// Magic bytes at the start of a settings record.
pub const SETTINGS_MAGIC: [u8; 4] = *b"WSET";
/// Version written by this firmware.
pub const SETTINGS_VERSION: u16 = 1;
/// Length of a settings record, bytes.
pub const SETTINGS_LEN: usize = 12;

static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// What the settings record holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoredSettings {
    /// The background recalibration adopts better candidates (false: monitor only).
    pub background_adopt: bool,
    /// The background recalibration may replace a calibration the host uploaded.
    pub replace_uploaded: bool,
    /// Who made the stored calibration.
    pub origin: LiveOrigin,
}

impl Default for StoredSettings {
    /// Adoption on, host uploads protected, and a stored calibration of unknown origin
    /// counted as the host's (the protected case).
    fn default() -> Self {
        Self {
            background_adopt: true,
            replace_uploaded: false,
            origin: LiveOrigin::Host,
        }
    }
}

const fn origin_code(o: LiveOrigin) -> u8 {
    match o {
        LiveOrigin::Factory => 0,
        LiveOrigin::SelfCal => 1,
        LiveOrigin::Background => 2,
        LiveOrigin::Host => 3,
    }
}

/// Serialize settings as a version-1 record (see the module docs).
pub fn encode_settings(s: &StoredSettings) -> [u8; SETTINGS_LEN] {
    let mut out = [0u8; SETTINGS_LEN];
    out[..4].copy_from_slice(&SETTINGS_MAGIC);
    out[4..6].copy_from_slice(&SETTINGS_VERSION.to_le_bytes());
    out[6] = u8::from(s.background_adopt) | (u8::from(s.replace_uploaded) << 1);
    out[7] = origin_code(s.origin);
    let crc = CRC32.checksum(&out[..8]);
    out[8..].copy_from_slice(&crc.to_le_bytes());
    out
}

/// Parse and check a settings record; `None` for anything but an intact version-1 record
/// with known flags and origin (the caller then uses the defaults).
pub fn decode_settings(bytes: &[u8]) -> Option<StoredSettings> {
    if bytes.len() != SETTINGS_LEN || bytes[..4] != SETTINGS_MAGIC {
        return None;
    }
    if u16::from_le_bytes([bytes[4], bytes[5]]) != SETTINGS_VERSION {
        return None;
    }
    if CRC32.checksum(&bytes[..8]).to_le_bytes() != bytes[8..12] {
        return None;
    }
    let flags = bytes[6];
    if flags & !0b11 != 0 {
        return None;
    }
    let origin = match bytes[7] {
        0 => LiveOrigin::Factory,
        1 => LiveOrigin::SelfCal,
        2 => LiveOrigin::Background,
        3 => LiveOrigin::Host,
        _ => return None,
    };
    Some(StoredSettings {
        background_adopt: flags & 1 != 0,
        replace_uploaded: flags & 2 != 0,
        origin,
    })
}
