//! Arbitrary bytes through the readers that read a file in passes (`wiical fit big.csv`):
//! the streamed first pass keeps its rows (the spill) and later passes read them back; and as standard input too long to hold, copied to a temporary file
//! (`wiical fit - < big.csv`) and read from there. Never a panic; a stream's every pass gives
//! the rows the text read whole gives, and its check passes on a file nobody changed; the copy of standard input holds exactly the bytes given and is
//! deleted when dropped.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::io::Read;
use wiical_analysis::input::front_door::{load_input_in, open_input, Input, Opened};
use wiical_analysis::input::window_means::WindowInputOptions;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    // fuzz-smoke sets TMPDIR to a scratch directory of its own.
    let path = std::env::temp_dir().join(format!("streamed-{}.csv", std::process::id()));
    if std::fs::write(&path, rest).is_err() {
        return;
    }
    let opts = WindowInputOptions::default();
    let piece = [16, 64, 300, 4096][usize::from(pick) % 4];
    let streamed = load_input_in(&path, &opts, 0, piece);
    let held = load_input_in(&path, &opts, u64::MAX, piece);
    if let (Ok(Input::Stream(src)), Ok(Input::Samples(rec))) = (streamed, held) {
        let bits = |rows: &[[f64; 3]]| -> Vec<[u64; 3]> {
            rows.iter().map(|r| r.map(f64::to_bits)).collect()
        };
        let rows: Vec<[f64; 3]> = src.rows().map(|r| r.xyz).collect();
        assert!(src.check().is_ok(), "{:?}", src.check());
        assert_eq!(bits(&rows), bits(&rec.xyz));
    }
    // Standard input over 8 bytes is copied to a temporary file: the same bytes, deleted after.
    if let Ok(Opened::Spooled(copy)) = open_input(
        &mut &rest[..],
        8,
        wiical_analysis::input::front_door::MAX_SPOOL_BYTES,
    ) {
        let mut got = Vec::new();
        let read = std::fs::File::open(&*copy).and_then(|mut f| f.read_to_end(&mut got));
        assert!(read.is_ok());
        assert_eq!(got, rest);
        let kept = copy.to_path_buf();
        drop(copy);
        assert!(!kept.exists());
    }
    let _ = std::fs::remove_file(&path);
});
