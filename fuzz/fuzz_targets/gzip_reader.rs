//! Arbitrary bytes as a gzip recording (`wiical fit rec.csv.gz`): decompression must never
//! panic nor pass its bound (1 MiB here: the output is at most that, whatever the input
//! inflates to), and what it gives is read by the loader like any text.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_analysis::input::bounded::gunzip_bounded;
use wiical_analysis::{parse, LoadOptions};

const LIMIT: u64 = 1 << 20;

fuzz_target!(|data: &[u8]| {
    // Half the inputs get a gzip header so the decoder, not the magic check, sees them.
    let mut bytes = Vec::with_capacity(data.len() + 10);
    if data.first().is_some_and(|b| b & 1 == 1) {
        bytes.extend_from_slice(&[0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3]);
    }
    bytes.extend_from_slice(data);
    if let Ok(out) = gunzip_bounded(&bytes, LIMIT) {
        assert!(out.len() as u64 <= LIMIT);
        if let Ok(text) = std::str::from_utf8(&out) {
            if let Ok(rec) = parse(text, &LoadOptions::default()) {
                assert!(!rec.xyz.is_empty());
                assert!(rec.xyz.iter().flatten().all(|v| v.is_finite()));
            }
        }
    }
});
