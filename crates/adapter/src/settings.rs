//! The adapter's stored settings: whether the background recalibration may adopt, whether it
//! may replace a calibration the host uploaded, and who made the stored calibration (so that
//! a host upload stays protected across power cycles).
//!
//! Kept as a second small item beside the calibration in the store's power-loss-safe map
//! ([`crate::CalibrationStore::save_settings`]), with its own magic, version and CRC: a damaged
//! or unknown settings record reads as "none stored" and the defaults apply.
//!
//! ## Record layout (version 3, little-endian, [`SETTINGS_LEN`] bytes)
//! | offset | content |
//! |---|---|
//! | 0 | magic `"WSET"` |
//! | 4 | version `u16` = [`SETTINGS_VERSION`] |
//! | 6 | flags `u8`: bit 0 background adoption on, bit 1 replacing a host upload allowed |
//! | 7 | origin `u8` of the stored calibration: 0 factory, 1 self-calibration, 2 background, 3 host |
//! | 8 | the play clock when written, `u32` seconds ([`BudgetRecord::clock_s`]) |
//! | 12 | commits listed `u8` (≤ [`MAX_DAILY`]), then 3 zero bytes |
//! | 16 | [`MAX_DAILY`] commit times `u32` (play seconds, oldest first; unused ones zero) |
//! | 80 | the budget's commit interval `u32`, s of play ([`Intervals::commit_interval_s`]) |
//! | 84 | the fit interval `u32`, ms of play ([`Intervals::fit_interval_ms`]) |
//! | 88 | commits per day `u8` ([`Intervals::commits_per_day`]), then 3 zero bytes |
//! | 92 | CRC-32/ISO-HDLC of bytes 0..92 |
//!
//! Version 2 (84 bytes: bytes 0..80 as above, then the CRC of bytes 0..80, written before
//! the intervals were settable) is still read, with the default intervals; version 1 (12
//! bytes: bytes 0..8 as above, then the CRC of bytes 0..8, written before the budget was
//! stored) with an empty budget and the default intervals. A version-3 record whose
//! intervals are outside the wire protocol's bounds (`wiical_wire::BackgroundSettings`) is
//! refused like a damaged one.
//!
//! The flash-write budget of the background recalibration lives here so that a power cycle
//! does not reset it (see [`crate::background::adopt`]).
//!
//! ## Order of the two writes
//! The calibration and its origin are two items, so a power cut can fall between them. The
//! store is written so that the cut can only make a calibration *more* protected, never less:
//! a host upload writes the origin "host" first and the calibration second; every other
//! commit writes the calibration first and its origin second. Either way the worst outcome of
//! a cut is a calibration that the background recalibration treats as a host upload.

use crate::background::adopt::MAX_DAILY;
use crate::background::{BudgetRecord, LiveOrigin};
use crate::record_crc::CRC32;

/// Map key of the settings record (the calibration's is [`crate::store::RECORD_KEY`]).
pub const SETTINGS_KEY: u8 = 0x02;
/// Magic bytes at the start of a settings record.
pub const SETTINGS_MAGIC: [u8; 4] = *b"WSET";
/// Version written by this firmware.
pub const SETTINGS_VERSION: u16 = 3;
/// Length of a settings record, bytes.
pub const SETTINGS_LEN: usize = SETTINGS_LEN_V2 + 12;
/// Version 2 (a budget, the default intervals), still read.
const SETTINGS_VERSION_V2: u16 = 2;
/// Length of a version-2 record.
const SETTINGS_LEN_V2: usize = 16 + 4 * MAX_DAILY + 4;
/// Version 1 (no budget), still read.
const SETTINGS_VERSION_V1: u16 = 1;
/// Length of a version-1 record.
const SETTINGS_LEN_V1: usize = 12;

/// What the settings record holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoredSettings {
    /// The background recalibration adopts better candidates (false: monitor only).
    pub background_adopt: bool,
    /// The background recalibration may replace a calibration the host uploaded.
    pub replace_uploaded: bool,
    /// Who made the stored calibration.
    pub origin: LiveOrigin,
    /// The background recalibration's flash-write budget and play clock.
    pub budget: BudgetRecord,
    /// The budget's limits and the fit interval, set over the wire.
    pub intervals: Intervals,
}

/// The background recalibration's intervals as the host sets them: the flash-write budget
/// (at most one commit per `commit_interval_s` of play and `commits_per_day` per 24 h of
/// play) and how often a fit is attempted. Bounded by the wire protocol's limits
/// (`wiical_wire::BackgroundSettings::COMMIT_INTERVAL_S` and its siblings).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Intervals {
    /// Fewest seconds of play between two commits.
    pub commit_interval_s: u32,
    /// Most commits per 24 h of play (≤ [`MAX_DAILY`]).
    pub commits_per_day: u8,
    /// Milliseconds of play between fit attempts.
    pub fit_interval_ms: u32,
}

impl Default for Intervals {
    /// One commit per 30 min of play, 8 per day, a fit attempt per minute
    /// ([`crate::background::BackgroundSettings::nunchuk`]'s).
    fn default() -> Self {
        Self {
            commit_interval_s: 1800,
            commits_per_day: 8,
            fit_interval_ms: 60_000,
        }
    }
}

impl Intervals {
    /// Within the wire protocol's bounds.
    pub fn in_bounds(&self) -> bool {
        use wiical_wire::BackgroundSettings as W;
        W::COMMIT_INTERVAL_S.contains(&self.commit_interval_s)
            && W::COMMITS_PER_DAY.contains(&self.commits_per_day)
            && W::FIT_INTERVAL_MS.contains(&self.fit_interval_ms)
            && usize::from(self.commits_per_day) <= MAX_DAILY
    }
}

impl Default for StoredSettings {
    /// Adoption on, host uploads protected, and a stored calibration of unknown origin
    /// counted as the host's (the protected case).
    fn default() -> Self {
        Self {
            background_adopt: true,
            replace_uploaded: false,
            origin: LiveOrigin::Host,
            budget: BudgetRecord::default(),
            intervals: Intervals::default(),
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

/// Serialize settings as a version-3 record (see the module docs).
pub fn encode_settings(s: &StoredSettings) -> [u8; SETTINGS_LEN] {
    let mut out = [0u8; SETTINGS_LEN];
    out[..4].copy_from_slice(&SETTINGS_MAGIC);
    out[4..6].copy_from_slice(&SETTINGS_VERSION.to_le_bytes());
    out[6] = u8::from(s.background_adopt) | (u8::from(s.replace_uploaded) << 1);
    out[7] = origin_code(s.origin);
    out[8..12].copy_from_slice(&s.budget.clock_s.to_le_bytes());
    let commits = s.budget.commits();
    out[12] = commits.len() as u8;
    for (chunk, t) in out[16..16 + 4 * MAX_DAILY].chunks_exact_mut(4).zip(commits) {
        chunk.copy_from_slice(&t.to_le_bytes());
    }
    let i = &s.intervals;
    out[80..84].copy_from_slice(&i.commit_interval_s.to_le_bytes());
    out[84..88].copy_from_slice(&i.fit_interval_ms.to_le_bytes());
    out[88] = i.commits_per_day;
    let end = SETTINGS_LEN - 4;
    let crc = CRC32.checksum(&out[..end]);
    out[end..].copy_from_slice(&crc.to_le_bytes());
    out
}

/// Parse and check a settings record; `None` for anything but an intact version-3 (or
/// version-2 or -1) record with known flags and origin, a budget of at most [`MAX_DAILY`]
/// commits and intervals within their bounds (the caller then uses the defaults).
pub fn decode_settings(bytes: &[u8]) -> Option<StoredSettings> {
    let len = match u16::from_le_bytes([*bytes.get(4)?, *bytes.get(5)?]) {
        SETTINGS_VERSION => SETTINGS_LEN,
        SETTINGS_VERSION_V2 => SETTINGS_LEN_V2,
        SETTINGS_VERSION_V1 => SETTINGS_LEN_V1,
        _ => return None,
    };
    if bytes.len() != len || bytes[..4] != SETTINGS_MAGIC {
        return None;
    }
    if CRC32.checksum(&bytes[..len - 4]).to_le_bytes() != bytes[len - 4..] {
        return None;
    }
    let budget = if len >= SETTINGS_LEN_V2 {
        decode_budget(bytes)?
    } else {
        BudgetRecord::default()
    };
    let intervals = if len == SETTINGS_LEN {
        decode_intervals(bytes)?
    } else {
        Intervals::default()
    };
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
        budget,
        intervals,
    })
}

/// The intervals of a version-3 record whose CRC matched; `None` for nonzero padding or a
/// value outside its bounds.
fn decode_intervals(bytes: &[u8]) -> Option<Intervals> {
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    if bytes[89..92] != [0, 0, 0] {
        return None;
    }
    let i = Intervals {
        commit_interval_s: word(80),
        fit_interval_ms: word(84),
        commits_per_day: bytes[88],
    };
    i.in_bounds().then_some(i)
}

/// The budget of a version-2 or -3 record whose CRC matched; `None` for a count beyond
/// [`MAX_DAILY`], nonzero padding or unused slots, or a commit after the record's clock.
fn decode_budget(bytes: &[u8]) -> Option<BudgetRecord> {
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let count = bytes[12];
    if usize::from(count) > MAX_DAILY || bytes[13..16] != [0, 0, 0] {
        return None;
    }
    let mut r = BudgetRecord {
        clock_s: word(8),
        count,
        ..BudgetRecord::default()
    };
    for (i, slot) in r.commits.iter_mut().enumerate() {
        *slot = word(16 + 4 * i);
        let valid = i < usize::from(count);
        if (!valid && *slot != 0) || (valid && *slot > r.clock_s) {
            return None;
        }
    }
    Some(r)
}
