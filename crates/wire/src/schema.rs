//! Protocol version, schema description and its key.
//!
//! [`SCHEMA`] is a plain-text description of every message type, in field order, with
//! enum variant indices. [`SCHEMA_KEY`] is its 32-bit FNV-1a hash, computed at compile
//! time. The `Request:` and `Response:` lines are rendered from the protocol's declaration
//! ([`crate::protocol`]) and the `WireEffects:` line from the core's table of effect terms;
//! **whenever any other message type changes, update its line here**, and bump
//! [`PROTOCOL_VERSION`] either way; the key then changes, and a host and a firmware built from
//! different schemas refuse each other in the Hello exchange instead of misreading bytes.
//! The test `golden_encodings` in this crate pins the byte encoding of one instance of each
//! message, so a layout change that forgets to update [`SCHEMA`] fails CI.

use crate::declare::{PayloadSchema, VariantSchema};
use crate::messages::{ErrorCode, Hello, HelloResponse};
use crate::protocol::{Request, Response};

/// Human-facing protocol version, shown by the host. Compatibility is decided by
/// [`SCHEMA_KEY`], not by this number.
pub const PROTOCOL_VERSION: u16 = 8;

/// The schema text before the `Request` line.
const SCHEMA_PRELUDE: &str = "\
wiical-wire schema v8
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
";

/// The schema text between the `Request` and the `Response` lines.
const SCHEMA_HELLO: &str = "\
Hello: protocol_version:u16, schema_key:u32
";

/// The schema text between the `Response` line and the `WireEffects` line.
const SCHEMA_HEAD: &str = "\
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool, boot:BootRecord, damaged_records:u16
BootRecord: 0 Empty | 1 Loaded | 2 Rejected(RecordProblem) | 3 StorageError
RecordProblem: 0 WrongLength | 1 BadMagic | 2 UnsupportedVersion(u16) | 3 BadCrc | 4 Invalid
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
";

/// The schema text after the `WireEffects` line.
const SCHEMA_TAIL: &str = "\
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
BackgroundSettings: adopt:bool, replace_uploaded:bool, commit_interval_s:u32, commits_per_day:u8, fit_interval_ms:u32
BackgroundReport: phase:BackgroundPhase, settings:BackgroundSettings, origin:CalibrationOrigin, play_s:u32, moments:u32, bins_filled:u8, fresh_bins:u64, bin_moments:Vec<u8,54>, temperature_c:Option<f32>, coverage_gap:Option<CoverageGapReport>, candidate:Option<CandidateReport>, last_adoption:Option<AdoptionReport>, last_refusal:Option<RefusalReport>
BackgroundPhase: 0 Collecting | 1 Fitting | 2 Committing | 3 Invalid
CalibrationOrigin: 0 Factory | 1 SelfCal | 2 Background | 3 Host
CoverageGapReport: 0 TooFewBins{needed:u8, got:u8} | 1 MissingDirection{axis:u8, positive:bool} | 2 Flat | 3 BadDirection
CandidateReport: candidate_mg:f32, live_mg:f32, fit_rms_mg:f32, full_model:bool, temperature:bool, training_bins:u8, heldout_bins:u8
AdoptionReport: at_s:u32, before_mg:f32, after_mg:f32
RefusalReport: 0 Coverage(CoverageGapReport) | 1 TooFewHeldOut{needed:u8, got:u8} | 2 Fit | 3 Implausible | 4 NotBetter{candidate_mg:f32, live_mg:f32} | 5 MonitorOnly{candidate_mg:f32, live_mg:f32} | 6 HostCalibration | 7 Budget{wait_s:u32} | 8 UnsupportedLive | 9 Interrupted | 10 Storage
";

/// Appends `s` to `buf` at `at` (when `buf` is long enough: with an empty `buf` this only
/// counts), returning the new length.
const fn put(buf: &mut [u8], at: usize, s: &[u8]) -> usize {
    let mut i = 0;
    while i < s.len() {
        if at + i < buf.len() {
            buf[at + i] = s[i];
        }
        i += 1;
    }
    at + s.len()
}

/// Appends the decimal digits of `n` (< 100).
const fn put_count(buf: &mut [u8], at: usize, n: usize) -> usize {
    let at = if n >= 10 {
        put(buf, at, &[b'0' + (n / 10) as u8])
    } else {
        at
    };
    put(buf, at, &[b'0' + (n % 10) as u8])
}

/// Appends the line `{name}: 0 A | 1 B(T) | 2 C{f:t, g:u}` of an enum declared in
/// [`crate::messages`] (its variants' declared indices, names and payloads).
const fn put_variants(buf: &mut [u8], at: usize, name: &str, variants: &[VariantSchema]) -> usize {
    let mut at = put(buf, at, name.as_bytes());
    at = put(buf, at, b": ");
    let mut i = 0;
    while i < variants.len() {
        let v = &variants[i];
        if i > 0 {
            at = put(buf, at, b" | ");
        }
        at = put_count(buf, at, v.index as usize);
        at = put(buf, at, b" ");
        at = put(buf, at, v.name.as_bytes());
        at = match v.payload {
            PayloadSchema::Unit => at,
            PayloadSchema::Newtype(t) => {
                let at = put(buf, at, b"(");
                let at = put(buf, at, t.as_bytes());
                put(buf, at, b")")
            }
            PayloadSchema::Fields(fields) => {
                let mut at = put(buf, at, b"{");
                let mut j = 0;
                while j < fields.len() {
                    if j > 0 {
                        at = put(buf, at, b", ");
                    }
                    at = put(buf, at, fields[j].0.as_bytes());
                    at = put(buf, at, b":");
                    at = put(buf, at, fields[j].1.as_bytes());
                    j += 1;
                }
                put(buf, at, b"}")
            }
        };
        i += 1;
    }
    put(buf, at, b"\n")
}

/// Writes the whole schema into `buf` (or, with an empty `buf`, only measures it): the
/// prelude, the `Request` and `Response` lines rendered from the protocol's declaration
/// ([`Request::VARIANTS`], [`Response::VARIANTS`]) with the `Hello` line between them, the
/// head, then the `WireEffects` line rendered from the core's table of effect terms (each term's
/// name and its `f32` shape: `f32` for the reference value, `[f32;3]` for one coefficient
/// per axis, `[[f32;N];3]` for `N` per output axis), then the tail.
const fn write_schema(buf: &mut [u8]) -> usize {
    use wiical_core::terms::{Shape, TERMS};
    let mut at = put(buf, 0, SCHEMA_PRELUDE.as_bytes());
    at = put_variants(buf, at, "Request", Request::VARIANTS);
    at = put(buf, at, SCHEMA_HELLO.as_bytes());
    at = put_variants(buf, at, "Response", Response::VARIANTS);
    at = put(buf, at, SCHEMA_HEAD.as_bytes());
    at = put(buf, at, b"WireEffects: ");
    let mut i = 0;
    while i < TERMS.len() {
        let t = &TERMS[i];
        if i > 0 {
            at = put(buf, at, b", ");
        }
        at = put(buf, at, t.name.as_bytes());
        at = put(buf, at, b":");
        at = match t.shape {
            Shape::Reference => put(buf, at, b"f32"),
            Shape::Cross(_) => {
                let at = put(buf, at, b"[[f32;");
                let at = put_count(buf, at, t.per_axis());
                put(buf, at, b"];3]")
            }
            _ => put(buf, at, b"[f32;3]"),
        };
        i += 1;
    }
    at = put(buf, at, b"\n");
    at = put(buf, at, SCHEMA_TAIL.as_bytes());
    put_gyro(buf, at)
}

/// Appends the gyro calibration's lines (protocol 7): `WireGyroCalibration` with the linear
/// part and each row of `wiical_core::terms::GYRO_TERMS` as the device takes it (`name:[...]`
/// for a term it applies, none today) or leaves to hosts (`host only: name`), then the state.
const fn put_gyro(buf: &mut [u8], at: usize) -> usize {
    use wiical_core::terms::GYRO_TERMS;
    let mut at = put(
        buf,
        at,
        b"WireGyroCalibration: bias:[f32;3], matrix:[[f32;3];3]",
    );
    let mut i = 0;
    while i < GYRO_TERMS.len() {
        let t = &GYRO_TERMS[i];
        at = put(buf, at, b", ");
        if !t.device_applies {
            at = put(buf, at, b"host only: ");
        }
        at = put(buf, at, t.name.as_bytes());
        i += 1;
    }
    at = put(buf, at, b"\n");
    put(buf, at, SCHEMA_GYRO_STATE.as_bytes())
}

/// The schema text after the `WireGyroCalibration` line.
const SCHEMA_GYRO_STATE: &str = "\
GyroCalibrationState: live:Option<WireGyroCalibration>, staged:Option<WireGyroCalibration>, boot:BootRecord
GyroSample: seq:u32, raw:[u16;3], slow:u8, corrected:Option<[f32;3]>
";

/// Length of [`SCHEMA`], bytes.
const SCHEMA_LEN: usize = write_schema(&mut []);

/// The bytes of [`SCHEMA`], built at compile time.
const SCHEMA_BYTES: [u8; SCHEMA_LEN] = {
    let mut buf = [0u8; SCHEMA_LEN];
    write_schema(&mut buf);
    buf
};

/// Description of the wire format. Changing any message means changing this text; the
/// `WireEffects` line is rendered from `wiical_core::terms::TERMS` (the order and shape of
/// the effect coefficients on the wire), so a new effect term changes it, and the key, by
/// itself.
pub const SCHEMA: &str = match core::str::from_utf8(&SCHEMA_BYTES) {
    Ok(s) => s,
    Err(_) => panic!("the schema is ASCII"),
};

/// Schema keys of earlier protocol versions, newest first, so that either side can say
/// *which* older build it is talking to ("host speaks protocol 1, adapter 2: update the
/// host") instead of only "mismatch". Frozen: append when [`PROTOCOL_VERSION`] is bumped.
pub const PREVIOUS_SCHEMA_KEYS: [(u16, u32); 7] = [
    (7, 0x1178_DF7F),
    (6, 0xBAC3_B81A),
    (5, 0x1C56_6B18),
    (4, 0x2FCE_88CF),
    (3, 0x815C_88B5),
    (2, 0x4E19_BCC6),
    (1, 0x1A6C_EBDC),
];

/// The protocol version a schema key belongs to, if it is this build's or a known older one.
pub const fn protocol_of_key(key: u32) -> Option<u16> {
    if key == SCHEMA_KEY {
        return Some(PROTOCOL_VERSION);
    }
    let mut i = 0;
    while i < PREVIOUS_SCHEMA_KEYS.len() {
        if PREVIOUS_SCHEMA_KEYS[i].1 == key {
            return Some(PREVIOUS_SCHEMA_KEYS[i].0);
        }
        i += 1;
    }
    None
}

/// 32-bit FNV-1a hash of [`SCHEMA`]: the value host and firmware compare in Hello.
pub const SCHEMA_KEY: u32 = fnv1a_32(SCHEMA.as_bytes());

impl Hello {
    /// The Hello of this build.
    pub const CURRENT: Hello = Hello {
        protocol_version: PROTOCOL_VERSION,
        schema_key: SCHEMA_KEY,
    };

    /// Compare the peer's key with this build's: `Err(SchemaMismatch)` if they differ.
    pub fn check(&self) -> Result<(), ErrorCode> {
        check_schema_key(self.schema_key)
    }
}

/// `Ok` when `peer_key` equals this build's [`SCHEMA_KEY`], else
/// [`ErrorCode::SchemaMismatch`].
pub fn check_schema_key(peer_key: u32) -> Result<(), ErrorCode> {
    if peer_key == SCHEMA_KEY {
        Ok(())
    } else {
        Err(ErrorCode::SchemaMismatch)
    }
}

impl HelloResponse {
    /// Compare the adapter's key with this build's: `Err(SchemaMismatch)` if they differ.
    pub fn check(&self) -> Result<(), ErrorCode> {
        check_schema_key(self.schema_key)
    }
}

/// 32-bit FNV-1a hash (offset basis `0x811C9DC5`, prime `0x01000193`), usable in `const`
/// context. Not cryptographic: it only has to make accidental collisions between two
/// schema revisions unlikely.
pub const fn fnv1a_32(bytes: &[u8]) -> u32 {
    let mut hash: u32 = 0x811C_9DC5;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u32;
        hash = hash.wrapping_mul(0x0100_0193);
        i += 1;
    }
    hash
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::String;

    #[test]
    fn fnv1a_reference_vectors() {
        // Published FNV-1a 32-bit test vectors.
        assert_eq!(fnv1a_32(b""), 0x811C_9DC5);
        assert_eq!(fnv1a_32(b"a"), 0xE40C_292C);
        assert_eq!(fnv1a_32(b"foobar"), 0xBF9C_F968);
    }

    /// The text of protocol 1's schema, verbatim from its release.
    const SCHEMA_V1: &str = "\
wiical-wire schema v1
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
";

    /// The text of protocol 2's schema, verbatim from its release (before the
    /// orientation-dependent cross terms).
    const SCHEMA_V2: &str = "\
wiical-wire schema v2
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
";

    /// The text of protocol 3's schema, verbatim from its release (before the host's
    /// `EndSession` and the boot record report).
    const SCHEMA_V3: &str = "\
wiical-wire schema v3
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3], cross_quadratic:[[f32;5];3], cross_cubic:[[f32;9];3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
";

    /// The text of protocol 4's schema, verbatim from its release (before the background
    /// recalibration's messages).
    const SCHEMA_V4: &str = "\
wiical-wire schema v4
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus | 7 EndSession
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool, boot:BootRecord, damaged_records:u16
BootRecord: 0 Empty | 1 Loaded | 2 Rejected(RecordProblem) | 3 StorageError
RecordProblem: 0 WrongLength | 1 BadMagic | 2 UnsupportedVersion(u16) | 3 BadCrc | 4 Invalid
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3], cross_quadratic:[[f32;5];3], cross_cubic:[[f32;9];3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
";

    /// The text of protocol 5's schema, verbatim from its release (before the background
    /// settings carried the flash-write budget and the fit interval).
    const SCHEMA_V5: &str = "\
wiical-wire schema v5
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus | 7 EndSession | 8 GetBackgroundStatus | 9 SetBackground(BackgroundSettings)
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus) | 7 Background(BackgroundReport)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool, boot:BootRecord, damaged_records:u16
BootRecord: 0 Empty | 1 Loaded | 2 Rejected(RecordProblem) | 3 StorageError
RecordProblem: 0 WrongLength | 1 BadMagic | 2 UnsupportedVersion(u16) | 3 BadCrc | 4 Invalid
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3], cross_quadratic:[[f32;5];3], cross_cubic:[[f32;9];3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
BackgroundSettings: adopt:bool, replace_uploaded:bool
BackgroundReport: phase:BackgroundPhase, settings:BackgroundSettings, origin:CalibrationOrigin, play_s:u32, moments:u32, bins_filled:u8, fresh_bins:u64, bin_moments:Vec<u8,54>, temperature_c:Option<f32>, coverage_gap:Option<CoverageGapReport>, candidate:Option<CandidateReport>, last_adoption:Option<AdoptionReport>, last_refusal:Option<RefusalReport>
BackgroundPhase: 0 Collecting | 1 Fitting | 2 Committing | 3 Invalid
CalibrationOrigin: 0 Factory | 1 SelfCal | 2 Background | 3 Host
CoverageGapReport: 0 TooFewBins{needed:u8, got:u8} | 1 MissingDirection{axis:u8, positive:bool} | 2 Flat | 3 BadDirection
CandidateReport: candidate_mg:f32, live_mg:f32, fit_rms_mg:f32, full_model:bool, temperature:bool, training_bins:u8, heldout_bins:u8
AdoptionReport: at_s:u32, before_mg:f32, after_mg:f32
RefusalReport: 0 Coverage(CoverageGapReport) | 1 TooFewHeldOut{needed:u8, got:u8} | 2 Fit | 3 Implausible | 4 NotBetter{candidate_mg:f32, live_mg:f32} | 5 MonitorOnly{candidate_mg:f32, live_mg:f32} | 6 HostCalibration | 7 Budget{wait_s:u32} | 8 UnsupportedLive | 9 Interrupted | 10 Storage
";

    #[test]
    fn protocol_5s_schema_is_protocol_4s_with_the_background_messages() {
        // Protocol 4's text, the background recalibration's request and response added to
        // its Request and Response lines, and its types appended.
        let mut v5 = String::from(SCHEMA_V4)
            .replace("schema v4", "schema v5")
            .replace(
                "7 EndSession\n",
                "7 EndSession | 8 GetBackgroundStatus | 9 SetBackground(BackgroundSettings)\n",
            )
            .replace(
                "6 Status(AdapterStatus)\n",
                "6 Status(AdapterStatus) | 7 Background(BackgroundReport)\n",
            );
        for line in [
            "BackgroundSettings: adopt:bool, replace_uploaded:bool",
            "BackgroundReport: phase:BackgroundPhase, settings:BackgroundSettings, origin:CalibrationOrigin, play_s:u32, moments:u32, bins_filled:u8, fresh_bins:u64, bin_moments:Vec<u8,54>, temperature_c:Option<f32>, coverage_gap:Option<CoverageGapReport>, candidate:Option<CandidateReport>, last_adoption:Option<AdoptionReport>, last_refusal:Option<RefusalReport>",
            "BackgroundPhase: 0 Collecting | 1 Fitting | 2 Committing | 3 Invalid",
            "CalibrationOrigin: 0 Factory | 1 SelfCal | 2 Background | 3 Host",
            "CoverageGapReport: 0 TooFewBins{needed:u8, got:u8} | 1 MissingDirection{axis:u8, positive:bool} | 2 Flat | 3 BadDirection",
            "CandidateReport: candidate_mg:f32, live_mg:f32, fit_rms_mg:f32, full_model:bool, temperature:bool, training_bins:u8, heldout_bins:u8",
            "AdoptionReport: at_s:u32, before_mg:f32, after_mg:f32",
            "RefusalReport: 0 Coverage(CoverageGapReport) | 1 TooFewHeldOut{needed:u8, got:u8} | 2 Fit | 3 Implausible | 4 NotBetter{candidate_mg:f32, live_mg:f32} | 5 MonitorOnly{candidate_mg:f32, live_mg:f32} | 6 HostCalibration | 7 Budget{wait_s:u32} | 8 UnsupportedLive | 9 Interrupted | 10 Storage",
        ] {
            v5.push_str(line);
            v5.push('\n');
        }
        assert_eq!(SCHEMA_V5, v5);
    }

    /// The text of protocol 6's schema, verbatim from its release (before the gyro
    /// calibration's messages).
    const SCHEMA_V6: &str = "\
wiical-wire schema v6
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus | 7 EndSession | 8 GetBackgroundStatus | 9 SetBackground(BackgroundSettings)
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus) | 7 Background(BackgroundReport)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool, boot:BootRecord, damaged_records:u16
BootRecord: 0 Empty | 1 Loaded | 2 Rejected(RecordProblem) | 3 StorageError
RecordProblem: 0 WrongLength | 1 BadMagic | 2 UnsupportedVersion(u16) | 3 BadCrc | 4 Invalid
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3], cross_quadratic:[[f32;5];3], cross_cubic:[[f32;9];3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
BackgroundSettings: adopt:bool, replace_uploaded:bool, commit_interval_s:u32, commits_per_day:u8, fit_interval_ms:u32
BackgroundReport: phase:BackgroundPhase, settings:BackgroundSettings, origin:CalibrationOrigin, play_s:u32, moments:u32, bins_filled:u8, fresh_bins:u64, bin_moments:Vec<u8,54>, temperature_c:Option<f32>, coverage_gap:Option<CoverageGapReport>, candidate:Option<CandidateReport>, last_adoption:Option<AdoptionReport>, last_refusal:Option<RefusalReport>
BackgroundPhase: 0 Collecting | 1 Fitting | 2 Committing | 3 Invalid
CalibrationOrigin: 0 Factory | 1 SelfCal | 2 Background | 3 Host
CoverageGapReport: 0 TooFewBins{needed:u8, got:u8} | 1 MissingDirection{axis:u8, positive:bool} | 2 Flat | 3 BadDirection
CandidateReport: candidate_mg:f32, live_mg:f32, fit_rms_mg:f32, full_model:bool, temperature:bool, training_bins:u8, heldout_bins:u8
AdoptionReport: at_s:u32, before_mg:f32, after_mg:f32
RefusalReport: 0 Coverage(CoverageGapReport) | 1 TooFewHeldOut{needed:u8, got:u8} | 2 Fit | 3 Implausible | 4 NotBetter{candidate_mg:f32, live_mg:f32} | 5 MonitorOnly{candidate_mg:f32, live_mg:f32} | 6 HostCalibration | 7 Budget{wait_s:u32} | 8 UnsupportedLive | 9 Interrupted | 10 Storage
";

    #[test]
    fn protocol_6s_schema_is_protocol_5s_with_the_budget_settings() {
        // Protocol 5's text, the background settings' budget and fit interval appended.
        let v6 = String::from(SCHEMA_V5)
            .replace("schema v5", "schema v6")
            .replace(
                "BackgroundSettings: adopt:bool, replace_uploaded:bool\n",
                "BackgroundSettings: adopt:bool, replace_uploaded:bool, commit_interval_s:u32, commits_per_day:u8, fit_interval_ms:u32\n",
            );
        assert_eq!(SCHEMA_V6, v6);
    }

    /// The text of protocol 7's schema, verbatim from its release (before the streamed gyro
    /// sample).
    const SCHEMA_V7: &str = "\
wiical-wire schema v7
frame: cobs(postcard(msg) ++ le16(crc16_ibm_3740(postcard(msg)))) ++ 0x00
Request: 0 Hello(Hello) | 1 GetCalibration | 2 PutCalibration(WireCalibration) | 3 CommitCalibration | 4 StartStream{rate_divider:u16} | 5 StopStream | 6 GetStatus | 7 EndSession | 8 GetBackgroundStatus | 9 SetBackground(BackgroundSettings) | 10 GetGyroCalibration | 11 PutGyroCalibration(WireGyroCalibration) | 12 CommitGyroCalibration
Hello: protocol_version:u16, schema_key:u32
Response: 0 Hello(HelloResponse) | 1 Error(ErrorCode) | 2 Ack | 3 Calibration(CalibrationState) | 4 StreamStarted{sample_rate_mhz:u32} | 5 Sample(Sample) | 6 Status(AdapterStatus) | 7 Background(BackgroundReport) | 8 GyroCalibration(GyroCalibrationState)
HelloResponse: protocol_version:u16, schema_key:u32, firmware_version:String<32>, device_id:[u8;8]
ErrorCode(u8): 1 SchemaMismatch | 2 BadFrame | 3 UnsupportedRequest | 4 InvalidCalibration | 5 NothingStaged | 6 StorageFailure | 7 Busy | 8 InvalidParameter | 9 NoSensor | 10 Internal | 11 ImplausibleCalibration
CalibrationState: live:WireCalibration, staged:Option<WireCalibration>, stored:bool, boot:BootRecord, damaged_records:u16
BootRecord: 0 Empty | 1 Loaded | 2 Rejected(RecordProblem) | 3 StorageError
RecordProblem: 0 WrongLength | 1 BadMagic | 2 UnsupportedVersion(u16) | 3 BadCrc | 4 Invalid
WireCalibration: bias:[f32;3], matrix:[[f32;3];3], effects:WireEffects
WireEffects: quadratic:[f32;3], cubic:[f32;3], bias_drift:[f32;3], temp_ref_c:f32, bias_temp:[f32;3], scale_temp:[f32;3], cross_quadratic:[[f32;5];3], cross_cubic:[[f32;9];3]
Sample: seq:u32, raw:[u16;3], corrected:[f32;3], buttons:u16, stick:[u8;2]
AdapterStatus: phase:SelfCalPhase, poses:u8, last_result:Option<SelfCalOutcome>, stale_moments:u32, stale_rms_mg:f32, recalibration_suggested:bool
SelfCalPhase: 0 Off | 1 Arming | 2 WaitingForStillness | 3 PoseTaken | 4 MoveToNewOrientation | 5 Committing | 6 Done | 7 Failed
SelfCalOutcome: 0 Done{rms_mg:f32, poses:u8} | 1 Failed{message:String<96>}
BackgroundSettings: adopt:bool, replace_uploaded:bool, commit_interval_s:u32, commits_per_day:u8, fit_interval_ms:u32
BackgroundReport: phase:BackgroundPhase, settings:BackgroundSettings, origin:CalibrationOrigin, play_s:u32, moments:u32, bins_filled:u8, fresh_bins:u64, bin_moments:Vec<u8,54>, temperature_c:Option<f32>, coverage_gap:Option<CoverageGapReport>, candidate:Option<CandidateReport>, last_adoption:Option<AdoptionReport>, last_refusal:Option<RefusalReport>
BackgroundPhase: 0 Collecting | 1 Fitting | 2 Committing | 3 Invalid
CalibrationOrigin: 0 Factory | 1 SelfCal | 2 Background | 3 Host
CoverageGapReport: 0 TooFewBins{needed:u8, got:u8} | 1 MissingDirection{axis:u8, positive:bool} | 2 Flat | 3 BadDirection
CandidateReport: candidate_mg:f32, live_mg:f32, fit_rms_mg:f32, full_model:bool, temperature:bool, training_bins:u8, heldout_bins:u8
AdoptionReport: at_s:u32, before_mg:f32, after_mg:f32
RefusalReport: 0 Coverage(CoverageGapReport) | 1 TooFewHeldOut{needed:u8, got:u8} | 2 Fit | 3 Implausible | 4 NotBetter{candidate_mg:f32, live_mg:f32} | 5 MonitorOnly{candidate_mg:f32, live_mg:f32} | 6 HostCalibration | 7 Budget{wait_s:u32} | 8 UnsupportedLive | 9 Interrupted | 10 Storage
WireGyroCalibration: bias:[f32;3], matrix:[[f32;3];3], host only: g_sensitivity
GyroCalibrationState: live:Option<WireGyroCalibration>, staged:Option<WireGyroCalibration>, boot:BootRecord
";

    #[test]
    fn protocol_7s_schema_is_protocol_6s_with_the_gyro_calibration() {
        // Protocol 6's text, the gyro calibration's requests and response added to the
        // Request and Response lines (at their ends: additive) and its two types appended.
        let mut v7 = String::from(SCHEMA_V6)
            .replace("schema v6", "schema v7")
            .replace(
                "9 SetBackground(BackgroundSettings)\n",
                "9 SetBackground(BackgroundSettings) | 10 GetGyroCalibration | 11 PutGyroCalibration(WireGyroCalibration) | 12 CommitGyroCalibration\n",
            )
            .replace(
                "7 Background(BackgroundReport)\n",
                "7 Background(BackgroundReport) | 8 GyroCalibration(GyroCalibrationState)\n",
            );
        v7.push_str(
            "WireGyroCalibration: bias:[f32;3], matrix:[[f32;3];3], host only: g_sensitivity\n",
        );
        v7.push_str("GyroCalibrationState: live:Option<WireGyroCalibration>, staged:Option<WireGyroCalibration>, boot:BootRecord\n");
        assert_eq!(SCHEMA_V7, v7);
    }

    #[test]
    fn the_built_schema_is_protocol_8s() {
        // Protocol 7's text, the streamed gyro sample added at the end of the Response line
        // (additive) and its type appended.
        let mut v8 = String::from(SCHEMA_V7)
            .replace("schema v7", "schema v8")
            .replace(
                "8 GyroCalibration(GyroCalibrationState)\n",
                "8 GyroCalibration(GyroCalibrationState) | 9 GyroSample(GyroSample)\n",
            );
        v8.push_str("GyroSample: seq:u32, raw:[u16;3], slow:u8, corrected:Option<[f32;3]>\n");
        assert_eq!(SCHEMA, v8);
        assert_eq!(SCHEMA_KEY, fnv1a_32(v8.as_bytes()));
    }

    #[test]
    fn previous_keys_are_the_hashes_of_the_previous_schemas() {
        assert_eq!(PREVIOUS_SCHEMA_KEYS[6], (1, fnv1a_32(SCHEMA_V1.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[5], (2, fnv1a_32(SCHEMA_V2.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[4], (3, fnv1a_32(SCHEMA_V3.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[3], (4, fnv1a_32(SCHEMA_V4.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[2], (5, fnv1a_32(SCHEMA_V5.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[1], (6, fnv1a_32(SCHEMA_V6.as_bytes())));
        assert_eq!(PREVIOUS_SCHEMA_KEYS[0], (7, fnv1a_32(SCHEMA_V7.as_bytes())));
        for (k, v) in [(6, 1), (5, 2), (4, 3), (3, 4), (2, 5), (1, 6), (0, 7)] {
            assert_eq!(protocol_of_key(PREVIOUS_SCHEMA_KEYS[k].1), Some(v));
        }
        assert_eq!(protocol_of_key(SCHEMA_KEY), Some(PROTOCOL_VERSION));
        assert_eq!(protocol_of_key(0xDEAD_BEEF), None);
        assert!(PREVIOUS_SCHEMA_KEYS.iter().all(|(_, k)| *k != SCHEMA_KEY));
    }

    #[test]
    fn schema_key_is_the_hash_of_the_schema() {
        assert_eq!(SCHEMA_KEY, fnv1a_32(SCHEMA.as_bytes()));
        // Any edit of the description changes the key.
        let mut edited = [0u8; 4096];
        let n = SCHEMA.len();
        edited[..n].copy_from_slice(SCHEMA.as_bytes());
        edited[n - 2] ^= 1;
        assert_ne!(fnv1a_32(&edited[..n]), SCHEMA_KEY);
    }
}
