//! Arbitrary text as GENEActiv `.bin` pages (`wiical fit rec.bin`): after a minimal valid header
//! when the first byte is odd (so pages are reached), else the bytes as they are. The reader
//! must never panic; decoded pages must hold finite values, three per sample, and a loaded
//! recording strictly increasing times.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_analysis::input::raw::load::load_raw;
use wiical_analysis::input::raw::{Block, Blocks, RawFormat};

const HEADER: &[u8] = b"Device Identity\r\nDevice Model:1.1\r\nMeasurement Frequency:85.7 Hz\r\nx gain:25875\r\nx offset:439\r\ny gain:25734\r\ny offset:-662\r\nz gain:25538\r\nz offset:-3056\r\nVolts:300\r\nLux:800\r\nNumber of Pages:3\r\n";

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let mut file = Vec::new();
    if pick & 1 == 1 {
        file.extend_from_slice(HEADER);
    }
    file.extend_from_slice(rest);
    let blocks = Blocks::Bytes(&file, RawFormat::GeneActiv);
    let Ok(all) = blocks.open().and_then(|mut r| r.all_blocks()) else {
        return;
    };
    for b in all.iter().filter_map(|b| match b {
        Block::Good(g) => Some(g),
        _ => None,
    }) {
        assert_eq!(b.data.len() % 3, 0);
        assert!(b.data.iter().all(|v| v.is_finite()));
    }
    if let Ok(rec) = load_raw(blocks, &Default::default()) {
        let t = rec.t.as_ref().unwrap();
        assert!(t.windows(2).all(|w| w[0] < w[1]), "time not increasing");
    }
});
