//! Persistent storage of the committed calibration.
//!
//! Two layers of protection, so that the adapter boots with the old or the new calibration
//! after a power loss at any instant, never a damaged one:
//! * [`sequential_storage`]'s map writes a new item after the old one and only then lets it
//!   supersede the old one; each item carries a CRC, pages are erased only after their live
//!   items were copied, and interrupted writes/erases are detected and repaired at the next
//!   access.
//! * The value itself is a versioned record with its own CRC-32 ([`encode_record`]), checked
//!   again after reading together with [`Calibration::validate`], so that even a bug or an
//!   undetected flash error yields "no calibration" (pass-through), not a corrupt one.
//!
//! ## Record layout (version 2, little-endian, [`RECORD_LEN`] bytes)
//! | offset | content |
//! |---|---|
//! | 0 | magic `"WCAL"` |
//! | 4 | version `u16` = [`RECORD_VERSION`] |
//! | 6 | payload length `u16` = 280 |
//! | 8 | 70 × `f32` in the order of `Calibration::floats` (the core's table of effect terms): bias\[3\], matrix row-major\[9\], quadratic\[3\], cubic\[3\], bias_drift\[3\], temp_ref_c, bias_temp\[3\], scale_temp\[3\], cross_quadratic row-major\[3\]\[5\], cross_cubic row-major\[3\]\[9\] |
//! | 288 | CRC-32/ISO-HDLC of bytes 0..288 |
//!
//! Version 1 (written by firmware before the orientation-dependent cross terms) is the same
//! up to `scale_temp`: 28 floats, payload length 112, CRC at offset 120, [`RECORD_LEN_V1`]
//! bytes. It is still read, with every cross term zero, so that a calibration committed
//! before a firmware update stays live after it. This firmware writes version 2 only; an
//! older firmware finds a version-2 record unsupported and runs uncalibrated (pass-through),
//! as it does for any record it refuses.
//!
//! ## The gyro record (key [`GYRO_RECORD_KEY`], version 1, [`GYRO_RECORD_LEN`] bytes)
//! The MotionPlus's gyro calibration (`wiical_wire::WireGyroCalibration`: `K·(m − b)` in
//! slow-range counts → rad/s along the count axes) is a third item of the same map, beside
//! the accelerometer's and the settings, written and read with the same power-loss safety,
//! its own magic and CRC:
//!
//! | offset | content |
//! |---|---|
//! | 0 | magic `"WGYR"` |
//! | 4 | version `u16` = [`GYRO_RECORD_VERSION`] |
//! | 6 | payload length `u16` = 48 |
//! | 8 | 12 × `f32`: bias\[3\] (counts), `K` row-major\[9\] (rad/s per count) — the first 12 of `GyroCorrection::floats`; the host-only terms of `GYRO_TERMS` (g-sensitivity) are not stored |
//! | 56 | CRC-32/ISO-HDLC of bytes 0..56 |
//!
//! A gyro record is judged again at boot by `Acceptance::check_gyro` (MotionPlus limits) and
//! refused like a damaged one when it fails; the accelerometer's record and the gyro's are
//! independent (either may be absent, damaged or refused without touching the other).

use core::ops::Range;

use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;

use crate::error::{RecordError, StoreError};
use crate::record_crc::CRC32;
use crate::settings::{
    decode_settings, encode_settings, StoredSettings, SETTINGS_KEY, SETTINGS_LEN,
};

/// Map key of the calibration record.
pub const RECORD_KEY: u8 = 0x01;
/// Version written by this firmware: the newest record version a term of the core's table
/// of effect terms needs.
pub const RECORD_VERSION: u16 = wiical_core::terms::RECORD_VERSION;
/// The previous version, still read (no cross terms).
pub const RECORD_VERSION_V1: u16 = 1;
/// Magic bytes at the start of a record.
pub const RECORD_MAGIC: [u8; 4] = *b"WCAL";
/// Number of `f32` in a version-1 payload: bias, `K` and the terms version 1 had.
const PAYLOAD_FLOATS_V1: usize = 12 + wiical_core::terms::floats_through_record(RECORD_VERSION_V1);
/// Number of `f32` in a version-2 payload: the calibration's canonical floats
/// (`Calibration::floats`), version 1's then the 15 + 27 cross coefficients.
const PAYLOAD_FLOATS: usize = wiical_core::terms::CALIBRATION_FLOATS;
/// Length of a version-2 record, bytes.
pub const RECORD_LEN: usize = 8 + 4 * PAYLOAD_FLOATS + 4;
/// Length of a version-1 record, bytes.
pub const RECORD_LEN_V1: usize = 8 + 4 * PAYLOAD_FLOATS_V1 + 4;

/// Map key of the gyro calibration record (see the module docs).
pub const GYRO_RECORD_KEY: u8 = 0x03;
/// Magic bytes at the start of a gyro record.
pub const GYRO_RECORD_MAGIC: [u8; 4] = *b"WGYR";
/// Version of the gyro record written and read by this firmware.
pub const GYRO_RECORD_VERSION: u16 = 1;
/// Number of `f32` in a gyro record: bias and `K` (what the wire's `WireGyroCalibration`
/// carries).
const GYRO_FLOATS: usize = 12;
/// Length of a gyro record, bytes.
pub const GYRO_RECORD_LEN: usize = 8 + 4 * GYRO_FLOATS + 4;

/// Size of the work buffer handed to `sequential-storage`: key + record, rounded up to the
/// largest flash word it supports (32 bytes).
const WORK_BUFFER_LEN: usize = (1 + RECORD_LEN).div_ceil(32) * 32;

/// Work buffer aligned for flash drivers that DMA from RAM.
#[repr(C, align(32))]
struct WorkBuffer([u8; WORK_BUFFER_LEN]);

/// Serialize a calibration as a version-2 record (see the module docs). Bit-exact: every
/// `f32` is stored as its IEEE bits.
pub fn encode_record(cal: &Calibration) -> [u8; RECORD_LEN] {
    let mut out = [0u8; RECORD_LEN];
    let (head, rest) = out.split_at_mut(8);
    head[..4].copy_from_slice(&RECORD_MAGIC);
    head[4..6].copy_from_slice(&RECORD_VERSION.to_le_bytes());
    head[6..8].copy_from_slice(&((4 * PAYLOAD_FLOATS) as u16).to_le_bytes());
    for (chunk, x) in rest.chunks_exact_mut(4).zip(cal.floats()) {
        chunk.copy_from_slice(&x.to_le_bytes());
    }
    let crc = CRC32.checksum(&out[..RECORD_LEN - 4]);
    out[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
    out
}

/// Parse and check a record: length, magic, version, CRC, then
/// [`Calibration::validate`]. Any failure is an error: the caller must then run without a
/// calibration.
pub fn decode_record(bytes: &[u8]) -> Result<Calibration, RecordError> {
    if bytes.len() < 8 {
        return Err(RecordError::WrongLength(bytes.len()));
    }
    if bytes[..4] != RECORD_MAGIC {
        return Err(RecordError::BadMagic);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    // Every version up to this firmware's is read: its payload is the canonical floats of the
    // terms it had (the table's `since_record`), the newer ones zero.
    let floats = match version {
        RECORD_VERSION_V1..=RECORD_VERSION => {
            12 + wiical_core::terms::floats_through_record(version)
        }
        _ => return Err(RecordError::UnsupportedVersion(version)),
    };
    let len = 8 + 4 * floats + 4;
    let payload_len = usize::from(u16::from_le_bytes([bytes[6], bytes[7]]));
    if bytes.len() != len || payload_len != 4 * floats {
        return Err(RecordError::WrongLength(bytes.len()));
    }
    let (body, crc) = bytes.split_at(len - 4);
    if CRC32.checksum(body).to_le_bytes() != [crc[0], crc[1], crc[2], crc[3]] {
        return Err(RecordError::BadCrc);
    }
    let mut f = [0f32; PAYLOAD_FLOATS];
    for (x, chunk) in f.iter_mut().zip(body[8..].chunks_exact(4)) {
        *x = f32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
    }
    let cal = Calibration::from_floats(&f[..floats]);
    cal.validate().map_err(RecordError::Invalid)?;
    Ok(cal)
}

/// Serialize a gyro calibration's linear part (bias, `K`) as a gyro record (see the module
/// docs); bit-exact. Its effect terms (host-only) are not stored.
pub fn encode_gyro_record(cal: &GyroCorrection<f32>) -> [u8; GYRO_RECORD_LEN] {
    let mut out = [0u8; GYRO_RECORD_LEN];
    out[..4].copy_from_slice(&GYRO_RECORD_MAGIC);
    out[4..6].copy_from_slice(&GYRO_RECORD_VERSION.to_le_bytes());
    out[6..8].copy_from_slice(&((4 * GYRO_FLOATS) as u16).to_le_bytes());
    let floats = cal.floats();
    for (chunk, x) in out[8..8 + 4 * GYRO_FLOATS]
        .chunks_exact_mut(4)
        .zip(&floats[..GYRO_FLOATS])
    {
        chunk.copy_from_slice(&x.to_le_bytes());
    }
    let crc = CRC32.checksum(&out[..GYRO_RECORD_LEN - 4]);
    out[GYRO_RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
    out
}

/// Parse and check a gyro record: length, magic, version, payload length, CRC, then usable
/// (finite, `K` invertible: what `GyroCorrection::validate` checks of a calibration without
/// terms). Any failure is an error (the caller then runs without a gyro
/// calibration: the MotionPlus's rates pass through). Never panics, whatever the bytes.
pub fn decode_gyro_record(bytes: &[u8]) -> Result<GyroCorrection<f32>, RecordError> {
    if bytes.len() < 8 {
        return Err(RecordError::WrongLength(bytes.len()));
    }
    if bytes[..4] != GYRO_RECORD_MAGIC {
        return Err(RecordError::BadMagic);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    if version != GYRO_RECORD_VERSION {
        return Err(RecordError::UnsupportedVersion(version));
    }
    let payload_len = usize::from(u16::from_le_bytes([bytes[6], bytes[7]]));
    if bytes.len() != GYRO_RECORD_LEN || payload_len != 4 * GYRO_FLOATS {
        return Err(RecordError::WrongLength(bytes.len()));
    }
    let (body, crc) = bytes.split_at(GYRO_RECORD_LEN - 4);
    if CRC32.checksum(body).to_le_bytes() != [crc[0], crc[1], crc[2], crc[3]] {
        return Err(RecordError::BadCrc);
    }
    let mut f = [0f32; GYRO_FLOATS];
    for (x, chunk) in f.iter_mut().zip(body[8..].chunks_exact(4)) {
        *x = f32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
    }
    let cal = GyroCorrection::from_floats(&f);
    // Usable: finite, `K` invertible (checked as the accelerometer's `K` is, with the code the
    // firmware links for it; the record holds no g-sensitivity to bound).
    Calibration {
        bias: cal.bias,
        matrix: cal.matrix,
        effects: Calibration::identity().effects,
    }
    .validate()
    .map_err(RecordError::Invalid)?;
    Ok(cal)
}

/// What [`CalibrationStore::load_gyro`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoadedGyro {
    /// No gyro record stored.
    Empty,
    /// A valid gyro calibration.
    Calibration(GyroCorrection<f32>),
    /// A record was found but refused; run without a gyro calibration.
    Rejected(RecordError),
}

/// What [`CalibrationStore::load`] found.
// no_std without an allocator: the calibration cannot be boxed; a `Loaded` is short-lived.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loaded {
    /// Nothing stored yet (or the storage was erased).
    Empty,
    /// A valid calibration.
    Calibration(Calibration),
    /// A record was found but refused; run uncalibrated.
    Rejected(RecordError),
}

type MapCache = Cache<Uncached, Uncached, Uncached, u8>;

/// The committed calibration in flash; see the module docs.
pub struct CalibrationStore<F: NorFlash> {
    map: MapStorage<u8, F, MapCache>,
    buf: WorkBuffer,
    range: Range<u32>,
}

impl<F: NorFlash> CalibrationStore<F> {
    /// Use `range` of `flash` for the calibration: page aligned, and either ≥ 3 erase pages
    /// each holding a record (≥ 512-byte pages since record version 2), or 2 pages each
    /// holding two records (≥ 1 KiB pages). A 4 KiB-sector QSPI flash needs 2 sectors.
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, StoreError<F::Error>> {
        let pages = (range.end.saturating_sub(range.start)) / (F::ERASE_SIZE.max(1) as u32);
        let config = MapConfig::<F>::try_new(range.clone()).map_err(StoreError::Config)?;
        // Room in a page: everything but the two page-state words.
        let usable = (F::ERASE_SIZE as u32).saturating_sub(2 * F::WRITE_SIZE as u32);
        let item = MapStorage::<u8, F, MapCache>::item_overhead_size()
            + (1 + RECORD_LEN as u32).next_multiple_of(F::WRITE_SIZE.max(1) as u32);
        // Each page must also have room for the small settings record beside a calibration.
        let settings_item = MapStorage::<u8, F, MapCache>::item_overhead_size()
            + (1 + SETTINGS_LEN as u32).next_multiple_of(F::WRITE_SIZE.max(1) as u32);
        // And for the gyro record (issue 50), the third item of the map.
        let gyro_item = MapStorage::<u8, F, MapCache>::item_overhead_size()
            + (1 + GYRO_RECORD_LEN as u32).next_multiple_of(F::WRITE_SIZE.max(1) as u32);
        let per_page = usable.saturating_sub(settings_item + gyro_item) / item.max(1);
        // The map keeps one page erased for migration, so with only two pages each must
        // hold two records, or a second commit would find the storage full.
        if per_page == 0 || (pages < 3 && per_page < 2) {
            return Err(StoreError::Config(
                sequential_storage::map::MapConfigError::PagesTooSmall,
            ));
        }
        Ok(Self {
            map: MapStorage::new(flash, config, MapCache::new_uncached()),
            buf: WorkBuffer([0; WORK_BUFFER_LEN]),
            range,
        })
    }

    /// Read the committed calibration. A damaged or unknown record gives
    /// [`Loaded::Rejected`], never a calibration; `Err` only when the flash cannot be read
    /// or the storage is beyond repair.
    pub async fn load(&mut self) -> Result<Loaded, StoreError<F::Error>> {
        let item: Option<&[u8]> = self
            .map
            .fetch_item(&mut self.buf.0, &RECORD_KEY)
            .await
            .map_err(StoreError::Flash)?;
        Ok(match item {
            None => Loaded::Empty,
            Some(bytes) => match decode_record(bytes) {
                Ok(cal) => Loaded::Calibration(cal),
                Err(e) => Loaded::Rejected(e),
            },
        })
    }

    /// Records in the range that start with the record magic and fail their own checks (a
    /// CRC mismatch, a length cut short): damaged or interrupted writes. `sequential-storage`
    /// skips an item whose bytes are damaged and returns the previous one without a word, so
    /// [`Self::load`] alone cannot tell "the newest record was damaged, this is the one
    /// before" from "this is the newest"; this scan of the raw flash can. Intact superseded
    /// records are not counted. Reads the range once, 256 bytes at a time; `Err` is the flash
    /// driver's read error.
    pub async fn damaged_records(&mut self) -> Result<u16, F::Error> {
        const CHUNK: usize = 256;
        let align = F::READ_SIZE.max(1);
        if !CHUNK.is_multiple_of(align) || align > WORK_BUFFER_LEN - RECORD_LEN {
            return Ok(0);
        }
        let Range { start, end } = self.range.clone();
        let mut chunk = [0u8; CHUNK];
        let mut damaged = 0u16;
        let mut carry = [0u8; 3];
        let mut addr = start;
        while addr < end {
            let n = CHUNK.min((end - addr) as usize);
            let flash = self.map.flash();
            flash.read(addr, &mut chunk[..n]).await?;
            for i in 0..n {
                // The magic may straddle two chunks: the last three bytes are carried over.
                let at = |k: usize| if k < 3 { carry[k] } else { chunk[k - 3] };
                let word = [at(i), at(i + 1), at(i + 2), at(i + 3)];
                let pos = addr as usize + i;
                if word == RECORD_MAGIC && pos >= start as usize + 3 {
                    let rec = (pos - 3) as u32;
                    if self.record_at_is_damaged(rec, end).await? {
                        damaged = damaged.saturating_add(1);
                    }
                }
            }
            if n >= 3 {
                carry.copy_from_slice(&chunk[n - 3..n]);
            }
            addr += n as u32;
        }
        Ok(damaged)
    }

    /// True when the bytes at `rec` (which start with the magic) do not decode for a reason
    /// other than an unknown version: a CRC mismatch or a record cut short by the range end.
    async fn record_at_is_damaged(&mut self, rec: u32, end: u32) -> Result<bool, F::Error> {
        let align = F::READ_SIZE.max(1) as u32;
        let from = rec - rec % align;
        let skip = (rec - from) as usize;
        let want = (skip + RECORD_LEN).next_multiple_of(align as usize);
        let avail = (end - from) as usize;
        let len = want.min(avail - avail % align as usize);
        let buf = &mut self.buf.0[..len];
        self.map.flash().read(from, buf).await?;
        let bytes = &buf[skip..];
        if bytes.len() < 8 {
            return Ok(true);
        }
        let version = u16::from_le_bytes([bytes[4], bytes[5]]);
        let rec_len = match version {
            RECORD_VERSION => RECORD_LEN,
            RECORD_VERSION_V1 => RECORD_LEN_V1,
            _ => return Ok(false),
        };
        Ok(match bytes.get(..rec_len) {
            None => true,
            Some(r) => matches!(
                decode_record(r),
                Err(RecordError::BadCrc | RecordError::WrongLength(_))
            ),
        })
    }

    /// Store `cal`, power-loss safe: after this returns, or after an interruption at any
    /// point, `load` gives either the previous calibration or `cal`. The caller validates
    /// `cal` first (as [`crate::Protocol`] does); an invalid one would be stored but then
    /// rejected by `load`.
    pub async fn save(&mut self, cal: &Calibration) -> Result<(), StoreError<F::Error>> {
        let record = encode_record(cal);
        self.map
            .store_item(&mut self.buf.0, &RECORD_KEY, &&record[..])
            .await
            .map_err(StoreError::Flash)
    }

    /// Read the committed gyro calibration ([`decode_gyro_record`]): a damaged or unknown
    /// record gives [`LoadedGyro::Rejected`], never a calibration; `Err` only when the flash
    /// cannot be read.
    pub async fn load_gyro(&mut self) -> Result<LoadedGyro, StoreError<F::Error>> {
        let item: Option<&[u8]> = self
            .map
            .fetch_item(&mut self.buf.0, &GYRO_RECORD_KEY)
            .await
            .map_err(StoreError::Flash)?;
        Ok(match item {
            None => LoadedGyro::Empty,
            Some(bytes) => match decode_gyro_record(bytes) {
                Ok(cal) => LoadedGyro::Calibration(cal),
                Err(e) => LoadedGyro::Rejected(e),
            },
        })
    }

    /// Store the gyro calibration, power-loss safe as [`Self::save`]: afterwards, or after an
    /// interruption at any point, [`Self::load_gyro`] gives the previous one or `cal`; the
    /// accelerometer's record and the settings are untouched either way.
    pub async fn save_gyro(
        &mut self,
        cal: &GyroCorrection<f32>,
    ) -> Result<(), StoreError<F::Error>> {
        let record = encode_gyro_record(cal);
        self.map
            .store_item(&mut self.buf.0, &GYRO_RECORD_KEY, &&record[..])
            .await
            .map_err(StoreError::Flash)
    }

    /// Read the settings record ([`crate::settings`]); `Ok(None)` when none is stored or the
    /// one stored is damaged or of an unknown version (the caller uses the defaults); `Err`
    /// only when the flash cannot be read.
    pub async fn load_settings(&mut self) -> Result<Option<StoredSettings>, StoreError<F::Error>> {
        let item: Option<&[u8]> = self
            .map
            .fetch_item(&mut self.buf.0, &SETTINGS_KEY)
            .await
            .map_err(StoreError::Flash)?;
        Ok(item.and_then(decode_settings))
    }

    /// Store the settings record, power-loss safe as [`Self::save`]: afterwards, or after an
    /// interruption, [`Self::load_settings`] gives the previous settings or these.
    pub async fn save_settings(&mut self, s: &StoredSettings) -> Result<(), StoreError<F::Error>> {
        let record = encode_settings(s);
        self.map
            .store_item(&mut self.buf.0, &SETTINGS_KEY, &&record[..])
            .await
            .map_err(StoreError::Flash)
    }

    /// Erase the whole range (recovery when [`Self::load`] keeps failing with a flash error
    /// the map cannot repair): afterwards `load` gives [`Loaded::Empty`].
    pub async fn erase_all(&mut self) -> Result<(), StoreError<F::Error>> {
        self.map.erase_all().await.map_err(StoreError::Flash)
    }

    /// Access the flash (e.g. to share it with other users between calls).
    pub fn flash(&mut self) -> &mut F {
        self.map.flash()
    }
}
