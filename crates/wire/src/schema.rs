//! Protocol version, schema description and its key.
//!
//! [`SCHEMA`] is a plain-text description of every message type, in field order, with
//! enum variant indices. [`SCHEMA_KEY`] is its 32-bit FNV-1a hash, computed at compile
//! time. **Whenever any message type changes, update [`SCHEMA`]** (and bump
//! [`PROTOCOL_VERSION`]); the key then changes, and a host and a firmware built from
//! different schemas refuse each other in the Hello exchange instead of misreading bytes.
//! The test `golden_encodings` in this crate pins the byte encoding of one instance of each
//! message, so a layout change that forgets to update [`SCHEMA`] fails CI.

/// Human-facing protocol version, shown by the host. Compatibility is decided by
/// [`SCHEMA_KEY`], not by this number.
pub const PROTOCOL_VERSION: u16 = 1;

/// Description of the wire format. Changing any message means changing this text.
pub const SCHEMA: &str = "\
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

/// 32-bit FNV-1a hash of [`SCHEMA`]: the value host and firmware compare in Hello.
pub const SCHEMA_KEY: u32 = fnv1a_32(SCHEMA.as_bytes());

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
    use super::*;

    #[test]
    fn fnv1a_reference_vectors() {
        // Published FNV-1a 32-bit test vectors.
        assert_eq!(fnv1a_32(b""), 0x811C_9DC5);
        assert_eq!(fnv1a_32(b"a"), 0xE40C_292C);
        assert_eq!(fnv1a_32(b"foobar"), 0xBF9C_F968);
    }

    #[test]
    fn schema_key_is_the_hash_of_the_schema() {
        assert_eq!(SCHEMA_KEY, fnv1a_32(SCHEMA.as_bytes()));
        // Any edit of the description changes the key.
        let mut edited = [0u8; 2048];
        let n = SCHEMA.len();
        edited[..n].copy_from_slice(SCHEMA.as_bytes());
        edited[n - 2] ^= 1;
        assert_ne!(fnv1a_32(&edited[..n]), SCHEMA_KEY);
    }
}
