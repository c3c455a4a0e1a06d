//! Every sample of a raw file written into caller-allocated arrays (`input::raw::samples`)
//! against the recording path (`load::load_raw` of the file's bytes held in memory): the
//! same samples, times, temperatures, notes and rate, on every raw file of the shared data
//! and on a `.cwa` written here that spans two read chunks with a corrupt, an unreadable and
//! a clock-step-back block and a cut-off tail. As f64 the values are bit for bit the
//! whole-file path's; as f32 they are its values rounded, and for a `.cwa` exactly them (the
//! counts times powers of two fit f32's 24 bits).

mod common;

use std::path::{Path, PathBuf};
use wiical_analysis::input::columns::LoadOptions;
use wiical_analysis::input::raw::samples::{self, RawMeta, Real};
use wiical_analysis::input::raw::{cwa, load, RawFormat};
use wiical_analysis::Recording;

/// The recording of `path`'s bytes held in memory.
fn whole(path: &Path, opts: &LoadOptions) -> Recording {
    let format = load::raw_file_format(path).expect("a raw file");
    let bytes = std::fs::read(path).unwrap();
    load::load_raw(load::Blocks::Bytes(&bytes, format), opts).unwrap()
}

/// `(xyz, temp, t, meta)` through the plan and the fill, times asked for or not.
fn filled<T: Real + Default>(
    path: &Path,
    opts: &LoadOptions,
    with_t: bool,
) -> (Vec<T>, Vec<T>, Vec<f64>, RawMeta) {
    let format = load::raw_file_format(path).expect("a raw file");
    let plan = samples::plan(load::Blocks::File(path, format), opts).unwrap();
    let n = plan.rows();
    let (mut xyz, mut temp) = (vec![T::default(); 3 * n], vec![T::default(); n]);
    let mut t = vec![0.0; if with_t { n } else { 0 }];
    let meta = plan
        .fill(&mut xyz, &mut temp, with_t.then_some(&mut t[..]))
        .unwrap();
    (xyz, temp, t, meta)
}

/// The f64 fill is the recording bit for bit, the f32 fill its values rounded (and for a
/// `.cwa` unchanged by the rounding), with or without the times.
fn assert_same(path: &Path, opts: &LoadOptions) {
    let rec = whole(path, opts);
    let name = path.display();
    let (xyz, temp, t, meta) = filled::<f64>(path, opts, true);
    let flat: Vec<f64> = rec.xyz.iter().flatten().copied().collect();
    assert!(xyz == flat, "{name}: values differ");
    assert!(
        Some(&temp) == rec.temp.as_ref(),
        "{name}: temperatures differ"
    );
    assert!(Some(&t) == rec.t.as_ref(), "{name}: times differ");
    assert_eq!(meta.columns, rec.axis_columns, "{name}");
    assert_eq!(meta.notes, rec.notes, "{name}");
    assert_eq!(Some(&meta.info), rec.info.first(), "{name}");
    assert_eq!(meta.rate_hz, rec.estimated_rate_hz(), "{name}");
    let (xyz32, temp32, no_t, meta32) = filled::<f32>(path, opts, false);
    assert!(no_t.is_empty());
    assert_eq!(
        meta32, meta,
        "{name}: the description needs no stored times"
    );
    let cast: Vec<f32> = flat.iter().map(|&v| v as f32).collect();
    assert!(xyz32 == cast, "{name}: f32 values differ");
    let temp_cast: Vec<f32> = temp.iter().map(|&v| v as f32).collect();
    assert!(temp32 == temp_cast, "{name}: f32 temperatures differ");
    assert_read(path, opts, &rec, &meta);
    if load::raw_file_format(path) == Some(RawFormat::Cwa) {
        let back: Vec<f64> = xyz32.iter().map(|&v| f64::from(v)).collect();
        assert!(back == flat, "{name}: a .cwa value is not exact in f32");
        assert!(temp32
            .iter()
            .map(|&v| f64::from(v))
            .eq(temp.iter().copied()));
    }
}

/// The one-call read (a `.cwa` in one pass) gives the recording's values, temperatures and
/// times bit for bit as f64, its values rounded as f32, and the same description, with the
/// times in full, left out, or as block spans that expand to the same times.
fn assert_read(path: &Path, opts: &LoadOptions, rec: &Recording, meta: &RawMeta) {
    let name = path.display();
    let format = load::raw_file_format(path).expect("a raw file");
    let full = samples::read::<f64>(path, format, opts, samples::Times::Full).unwrap();
    let flat: Vec<f64> = rec.xyz.iter().flatten().copied().collect();
    assert!(full.xyz == flat, "{name}: read's values differ");
    assert!(
        Some(&full.temp) == rec.temp.as_ref(),
        "{name}: read's temperatures differ"
    );
    assert!(
        full.t.as_ref() == rec.t.as_ref(),
        "{name}: read's times differ"
    );
    assert!(full.spans.is_none());
    assert_eq!(&full.meta, meta, "{name}: read's description");
    if format == RawFormat::Cwa {
        let bytes = Box::new(std::fs::read(path).unwrap());
        let mapped = samples::read_cwa_bytes::<f64>(path, bytes, opts, samples::Times::Full);
        assert_same_samples(&mapped.unwrap(), &full, &name.to_string());
    }
    let spans = samples::read::<f32>(path, format, opts, samples::Times::Spans).unwrap();
    let cast: Vec<f32> = flat.iter().map(|&v| v as f32).collect();
    assert!(spans.xyz == cast, "{name}: read's f32 values differ");
    assert!(spans.t.is_none());
    assert_eq!(
        &spans.meta, meta,
        "{name}: the description needs no stored times"
    );
    let s = spans.spans.expect("spans asked for");
    assert_eq!(s.rows.first(), Some(&0));
    assert_eq!(s.rows.last().copied(), Some(rec.len() as u64));
    let mut t = vec![f64::NAN; rec.len()];
    s.times_into(&mut t).expect("consistent spans");
    assert!(
        Some(&t) == rec.t.as_ref(),
        "{name}: the spans' times differ"
    );
    let none = samples::read::<f32>(path, format, opts, samples::Times::Omit).unwrap();
    assert!(none.t.is_none() && none.spans.is_none() && none.xyz == spans.xyz);
    assert_eq!(&none.meta, meta, "{name}");
}

/// `got` holds the same samples, times, spans and description as `want`, bit for bit.
fn assert_same_samples<T: Real + PartialEq>(
    got: &samples::Samples<T>,
    want: &samples::Samples<T>,
    name: &str,
) {
    assert!(got.xyz == want.xyz, "{name}: values differ");
    assert!(got.temp == want.temp, "{name}: temperatures differ");
    assert!(got.t == want.t, "{name}: times differ");
    assert_eq!(got.spans, want.spans, "{name}: spans differ");
    assert_eq!(got.meta, want.meta, "{name}: descriptions differ");
}

/// Every raw file of GGIRread's test set (packed AX3, one with six corrupt blocks, AX6 with
/// its gyroscope, GENEActiv), accelerometer and (AX6) gyroscope.
#[test]
fn real_raw_files_fill_as_they_read_whole() {
    common::each_ggirread_raw_file(assert_same);
}

fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    common::scratch("raw-samples", name, bytes)
}

/// A block with its checksum word set so that the 256 words sum to 0.
fn seal(mut b: Vec<u8>) -> Vec<u8> {
    b[510..512].fill(0);
    let s = b.chunks_exact(2).fold(0u16, |s, w| {
        s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
    });
    b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
    b
}

/// An unpacked AX3 block `i` (80 samples at 100 Hz, 256 counts/g) starting `secs` after
/// 2024-01-02 00:00:00, its values a function of `i` and the sample.
fn block(i: usize, secs: f64) -> Vec<u8> {
    let mut b = vec![0u8; 512];
    b[..2].copy_from_slice(b"AX");
    b[2..4].copy_from_slice(&508u16.to_le_bytes());
    b[10..14].copy_from_slice(&(i as u32).to_le_bytes());
    let whole = secs.floor() as u32;
    let ts: u32 = (24 << 26)
        | (1 << 22)
        | (2 << 17)
        | ((whole / 3600) << 12)
        | ((whole / 60 % 60) << 6)
        | (whole % 60);
    b[14..18].copy_from_slice(&ts.to_le_bytes());
    b[20..22].copy_from_slice(&(200 + (i % 300) as u16).to_le_bytes());
    b[24] = 0x4a;
    b[25] = 0x32;
    // The timestamp belongs to the sample that starts its second.
    let before = ((secs - secs.floor()) * 100.0).round() as i16;
    b[26..28].copy_from_slice(&(-before).to_le_bytes());
    b[28..30].copy_from_slice(&80u16.to_le_bytes());
    for s in 0..80 {
        for k in 0..3 {
            let v = ((i * 7 + s * 13 + k * 101) % 1024) as i16 - 512;
            let at = 30 + 6 * s + 2 * k;
            b[at..at + 2].copy_from_slice(&v.to_le_bytes());
        }
    }
    seal(b)
}

/// A `.cwa` of more than one read chunk: block 8195 corrupt, 8200 of an unknown channel
/// layout, 8300 stamped 10 s before its predecessor (left out), a cut-off tail.
fn long_cwa() -> Vec<u8> {
    let mut f = vec![0u8; 1024];
    f[..2].copy_from_slice(b"MD");
    f[2..4].copy_from_slice(&1020u16.to_le_bytes());
    f[36] = 0x4a;
    let blocks = cwa::CHUNK_BLOCKS + 500;
    for i in 0..blocks {
        let secs = i as f64 * 0.8 - if i == 8300 { 10.0 } else { 0.0 };
        let mut b = block(i, secs);
        if i == 8195 {
            b[100] ^= 1;
        }
        if i == 8200 {
            b[25] = 0x52;
            b = seal(b);
        }
        f.extend(b);
    }
    f.extend([0u8; 100]);
    f
}

#[test]
fn a_long_written_cwa_fills_as_it_reads_whole() {
    let path = scratch("long.cwa", &long_cwa());
    let rec = whole(&path, &LoadOptions::default());
    let notes = rec.notes.join("\n");
    for said in [
        "skipped 1 corrupt data block(s)",
        "skipped 1 unreadable data block(s)",
        "left out 1 data block(s)",
        "is cut short",
    ] {
        assert!(notes.contains(said), "{said}: {notes}");
    }
    assert_same(&path, &LoadOptions::default());
}

/// A `.cwa` read from its bytes in memory (what the Python package maps) reads as the file
/// read a chunk at a time: cut inside the header block, after it, inside a data block of the
/// first chunk and of the second, and whole; the same samples, or the same error sentence.
#[test]
fn a_cut_cwa_reads_from_its_bytes_as_from_the_file() {
    let full = long_cwa();
    let opts = LoadOptions::default();
    let cuts = [0, 600, 1024, 1024 + 3 * 512 + 100, 1024 + 8192 * 512 + 37];
    for len in cuts.into_iter().chain([full.len()]) {
        let path = scratch(&format!("cut{len}.cwa"), &full[..len]);
        let name = format!("cut at {len} of {}", full.len());
        for times in [samples::Times::Full, samples::Times::Spans] {
            let read = samples::read::<f32>(&path, RawFormat::Cwa, &opts, times);
            let bytes = Box::new(full[..len].to_vec());
            let mapped = samples::read_cwa_bytes::<f32>(&path, bytes, &opts, times);
            match (mapped, read) {
                (Ok(got), Ok(want)) => assert_same_samples(&got, &want, &name),
                (Err(got), Err(want)) => assert_eq!(got.to_string(), want.to_string(), "{name}"),
                (got, want) => panic!("{name}: {:?} against {:?}", got.err(), want.err()),
            }
        }
    }
    assert!(samples::read::<f32>(
        &scratch("cut600.cwa", &full[..600]),
        RawFormat::Cwa,
        &opts,
        samples::Times::Full
    )
    .is_err_and(|e| e.to_string().contains("header block is cut short")));
}

/// A file that changed after the first pass (cut shorter) is an error naming the block, not
/// a panic or zeros.
#[test]
fn a_file_cut_between_the_passes_is_refused() {
    let bytes = long_cwa();
    let path = scratch("shrinks.cwa", &bytes);
    let plan = samples::plan(
        load::Blocks::File(&path, RawFormat::Cwa),
        &LoadOptions::default(),
    )
    .unwrap();
    std::fs::write(&path, &bytes[..1024 + 512 * 8500]).unwrap();
    let n = plan.rows();
    let (mut xyz, mut temp) = (vec![0f32; 3 * n], vec![0f32; n]);
    let e = plan
        .fill(&mut xyz, &mut temp, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("data block #8500 changed while the file was read"),
        "{e}"
    );
}

/// Blocks of fewer samples than a block can hold (40 of 80, and none), and a first read chunk
/// without one good block (the layout, the channels and the output's size are fixed in the
/// second): the one-pass read places every block's samples where the whole-file path does.
#[test]
fn short_blocks_and_a_late_first_good_block_read_as_whole() {
    let mut f = long_cwa();
    for i in 0..cwa::CHUNK_BLOCKS + 3 {
        let at = 1024 + 512 * i;
        f[at + 100] ^= 1; // checksum fails: corrupt
    }
    for (i, n) in [(8197usize, 40u16), (8198, 0), (8250, 1), (8400, 79)] {
        let at = 1024 + 512 * i;
        let mut b = f[at..at + 512].to_vec();
        b[28..30].copy_from_slice(&n.to_le_bytes());
        f[at..at + 512].copy_from_slice(&seal(b));
    }
    let path = scratch("short.cwa", &f);
    let rec = whole(&path, &LoadOptions::default());
    assert!(rec.notes.join("\n").contains("corrupt"), "{:?}", rec.notes);
    assert_same(&path, &LoadOptions::default());
}

/// Spans that do not describe the rows (rows not increasing, a length that differs, `t` of
/// another length) are refused, not a panic.
#[test]
fn inconsistent_spans_are_refused() {
    let ok = samples::Spans {
        start_s: vec![0.0, 1.0],
        dur_s: vec![1.0, 1.0],
        rows: vec![0, 2, 4],
    };
    let mut t = vec![0.0; 4];
    assert_eq!(ok.times_into(&mut t), Some(()));
    assert_eq!(t, [0.0, 0.5, 1.0, 1.5]);
    let back = samples::Spans {
        rows: vec![0, 3, 2],
        ..ok.clone()
    };
    assert_eq!(back.times_into(&mut [0.0; 2]), None);
    assert_eq!(ok.times_into(&mut [0.0; 5]), None);
    let short = samples::Spans {
        dur_s: vec![1.0],
        ..ok
    };
    assert_eq!(short.times_into(&mut t), None);
}
