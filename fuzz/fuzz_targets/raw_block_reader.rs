//! Arbitrary bytes as Axivity `.cwa` data blocks after a valid header, read from a file block
//! by block (`wiical fit big.cwa`, `correct`, `six-position`: `input::raw::load`, the reader
//! whose clock places each block and leaves out a block stamped far ahead or back) against the
//! same bytes held in memory (`Blocks::Bytes`: standard input's, a gzip file's, read by the
//! same block reader from memory). Never a panic; when both read the
//! file, they give the same samples and times bit for bit, and the same error otherwise
//! (neither path may keep a block the other leaves out).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "cwa_bytes.rs"]
mod cwa_bytes;
use cwa_bytes::cwa_file;
use wiical_analysis::input::raw::load::{load_raw, Blocks};
use wiical_analysis::input::raw::{cwa, RawFormat};

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    // A short input is repeated into 1–8 whole blocks, so that a smoke run of seconds reaches
    // the blocks' fields and the clock (the same bytes again: the same stamp, a step back).
    let file = if rest.len() >= cwa::BLOCK_BYTES || rest.is_empty() {
        cwa_file(pick, rest.iter().copied())
    } else {
        let blocks = 1 + usize::from(pick >> 5);
        cwa_file(
            pick,
            rest.iter().copied().cycle().take(blocks * cwa::BLOCK_BYTES),
        )
    };
    // fuzz-smoke sets TMPDIR to a scratch directory of its own.
    let path = std::env::temp_dir().join(format!("raw-blocks-{}.cwa", std::process::id()));
    if std::fs::write(&path, &file).is_err() {
        return;
    }
    let streamed = load_raw(Blocks::File(&path, RawFormat::Cwa), &Default::default());
    let whole = load_raw(Blocks::Bytes(&file, RawFormat::Cwa), &Default::default());
    let _ = std::fs::remove_file(&path);
    let bits =
        |v: &[[f64; 3]]| -> Vec<[u64; 3]> { v.iter().map(|r| r.map(f64::to_bits)).collect() };
    match (streamed, whole) {
        (Ok(s), Ok(w)) => {
            assert_eq!(bits(&s.xyz), bits(&w.xyz), "samples differ");
            let t = |r: &wiical_analysis::input::recording::Recording| -> Vec<u64> {
                r.t.iter().flatten().map(|x| x.to_bits()).collect()
            };
            assert_eq!(t(&s), t(&w), "times differ");
        }
        (Err(_), Err(_)) => {}
        (s, w) => panic!(
            "one path read the file, the other did not: streamed {:?}, whole {:?}",
            s.map(|r| r.len()),
            w.map(|r| r.len())
        ),
    }
});
