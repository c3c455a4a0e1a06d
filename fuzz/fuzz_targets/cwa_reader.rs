//! Arbitrary bytes as Axivity `.cwa` data blocks after a valid header (`wiical fit rec.cwa`):
//! the reader must never panic; with the first byte odd, every block's checksum is made to
//! pass so the field decoding is reached. Whatever decodes must be usable: finite values, a
//! whole number of samples per block, a recording with strictly increasing times, and
//! GGIRread's grid (`raw::ggir`) must return (rows or an error) without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "cwa_bytes.rs"]
mod cwa_bytes;
use cwa_bytes::cwa_file;
use wiical_analysis::input::raw::load::load_raw;
use wiical_analysis::input::raw::{ggir, Block, Blocks, RawFormat};

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let file = cwa_file(pick, rest.iter().copied());
    let blocks = Blocks::Bytes(&file, RawFormat::Cwa);
    let Ok(mut reader) = blocks.open() else {
        return;
    };
    let Ok(all) = reader.all_blocks() else {
        return;
    };
    let nch = reader.channels().len();
    for b in all.iter().filter_map(|b| match b {
        Block::Good(g) => Some(g),
        _ => None,
    }) {
        assert_eq!(b.data.len() % nch, 0);
        assert!(b.data.iter().all(|v| v.is_finite()));
        assert!(b.start_s.is_finite() && b.rate_hz > 0.0);
    }
    if let Ok(rec) = load_raw(blocks, &Default::default()) {
        let t = rec.t.as_ref().unwrap();
        assert_eq!(t.len(), rec.len());
        assert!(t.windows(2).all(|w| w[0] < w[1]), "time not increasing");
    }
    let n = all.len();
    let _ = ggir::grid(blocks, usize::from(pick) % (n + 1), n);
});
