//! Arbitrary bytes as Axivity `.cwa` data blocks after a valid header (`wiical fit rec.cwa`):
//! the reader must never panic; with the first byte odd, every block's checksum is made to
//! pass so the field decoding is reached. Whatever decodes must be usable: finite values, a
//! whole number of samples per block, a recording with strictly increasing times, and
//! GGIRread's grid (`raw::ggir`) must return (rows or an error) without panicking.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_analysis::input::raw::{cwa, ggir, to_recording};

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let mut file = vec![0u8; cwa::HEADER_BYTES];
    file[..2].copy_from_slice(b"MD");
    file[2..4].copy_from_slice(&1020u16.to_le_bytes());
    file[4] = if pick & 2 != 0 { 0x64 } else { 0 };
    file[36] = pick >> 2;
    file.extend_from_slice(rest);
    if pick & 1 == 1 {
        for b in file[cwa::HEADER_BYTES..].chunks_exact_mut(cwa::BLOCK_BYTES) {
            b[510] = 0;
            b[511] = 0;
            let s = b.chunks_exact(2).fold(0u16, |s, w| {
                s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
            });
            b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
        }
    }
    let Ok(raw) = cwa::parse(&file) else {
        return;
    };
    let nch = raw.n_channels();
    for b in raw.good() {
        assert_eq!(b.data.len() % nch, 0);
        assert!(b.data.iter().all(|v| v.is_finite()));
        assert!(b.start_s.is_finite() && b.rate_hz > 0.0);
    }
    if let Ok(rec) = to_recording(&raw, &Default::default()) {
        let t = rec.t.as_ref().unwrap();
        assert_eq!(t.len(), rec.len());
        assert!(t.windows(2).all(|w| w[0] < w[1]), "time not increasing");
    }
    let n = raw.blocks.len();
    let _ = ggir::grid(&raw, usize::from(pick) % (n + 1), n);
});
