//! The raw reader (`input::raw::load`) on a file read block by block from disk against the
//! same file's bytes held in memory (`Blocks::Bytes`: standard input's, a gzip file's), read
//! by the same readers: the recording `load_raw` gives and the still-epoch table `raw_epoch_table` gives
//! must be bit for bit the same, on every raw file of the shared data and on files written here with
//! enough still epochs to be fitted (GENEActiv `.bin` with a bad and a cut-off page, AX3 and
//! AX6 `.cwa` with a corrupt block). Values are compared through their `Debug` text, which
//! prints every `f64` exactly (shortest round-trip form).

mod common;

use std::path::{Path, PathBuf};
use wiical_analysis::input::columns::LoadOptions;
use wiical_analysis::input::raw::load::{self, Blocks};
use wiical_analysis::input::raw::{self, Block, RawFormat};

/// The recording and still-epoch table (or its error) of `blocks`.
fn read_as(blocks: Blocks<'_>, opts: &LoadOptions) -> (String, String) {
    let rec = load::load_raw(blocks, opts).map_err(|e| e.to_string());
    let table = load::raw_epoch_table(blocks, opts, &Default::default()).map_err(|e| e.to_string());
    (format!("{rec:?}"), format!("{table:?}"))
}

/// The file's bytes held in memory.
fn whole(path: &Path, opts: &LoadOptions) -> (String, String) {
    let format = load::raw_file_format(path).expect("a raw file");
    read_as(Blocks::Bytes(&std::fs::read(path).unwrap(), format), opts)
}

/// The file read from disk a chunk of blocks at a time.
fn streamed(path: &Path, opts: &LoadOptions) -> (String, String) {
    let format = load::raw_file_format(path).expect("a raw file");
    read_as(Blocks::File(path, format), opts)
}

fn assert_same(path: &Path, opts: &LoadOptions) {
    let (rec_w, table_w) = whole(path, opts);
    let (rec_s, table_s) = streamed(path, opts);
    assert!(rec_w == rec_s, "{}: recordings differ", path.display());
    assert!(
        table_w == table_s,
        "{}: tables differ:\n{table_w}\n{table_s}",
        path.display()
    );
}

fn gyro() -> LoadOptions {
    LoadOptions {
        columns: Some(["gx", "gy", "gz"].map(String::from)),
        ..Default::default()
    }
}

/// Every raw file of GGIRread's test set, accelerometer and (AX6) gyroscope.
#[test]
fn real_raw_files_stream_as_they_read_whole() {
    common::each_ggirread_raw_file(assert_same);
}

/// Still holds at 12 directions (30 s each) with ±1 count of jitter: enough still epochs
/// for the table.
fn holds(rate_hz: f64, counts_per_g: f64) -> Vec<[i32; 3]> {
    let mut out = Vec::new();
    let mut seed = 7u32;
    for k in 0..12 {
        let z = 1.0 - 2.0 * ((k as f64 * 0.618034) % 1.0);
        let (r, phi) = ((1.0 - z * z).sqrt(), k as f64 * 2.399963);
        let g = [r * phi.cos(), r * phi.sin(), z];
        for _ in 0..(30.0 * rate_hz) as usize {
            out.push(g.map(|v| {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (v * counts_per_g).round() as i32 + (seed >> 16) as i32 % 3 - 1
            }));
        }
    }
    out
}

fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    common::scratch("raw-stream", name, bytes)
}

/// A GENEActiv file at 50 Hz: the holds in pages of 300 samples, page 3 with a non-hex
/// digit, the file cut inside its last page.
fn bin_file() -> Vec<u8> {
    let mut text = String::from(
        "Device Identity\r\nDevice Model:1.1\r\nMeasurement Frequency:50 Hz\r\nx gain:25600\r\nx offset:0\r\ny gain:25600\r\ny offset:-256\r\nz gain:25600\r\nz offset:0\r\nVolts:300\r\nLux:800\r\nNumber of Pages:99\r\n\r\n",
    );
    for (p, page) in holds(50.0, 256.0).chunks_exact(300).enumerate() {
        let ms = 1_000 + p * 6_000;
        let mut hex: String = page
            .iter()
            .map(|s| {
                format!(
                    "{:03X}{:03X}{:03X}00C",
                    s[0] & 0xfff,
                    s[1] & 0xfff,
                    s[2] & 0xfff
                )
            })
            .collect();
        if p == 3 {
            hex.replace_range(40..41, "G");
        }
        text.push_str(&format!(
            "Recorded Data\r\nSequence Number:{p}\r\nPage Time:2013-05-30 10:{:02}:{:02}:{:03}\r\nTemperature:{}\r\nMeasurement Frequency:50\r\n{hex}\r\n",
            ms / 60_000,
            ms / 1000 % 60,
            ms % 1000,
            20.0 + p as f64 / 10.0
        ));
    }
    text.push_str("Recorded Data\r\nPage Time:2013-05-30 11:00:00:000\r\n1000FF");
    text.into_bytes()
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

/// A `.cwa` file at 100 Hz (unpacked int16, 256 counts/g): AX3 (80 samples a block) or AX6
/// (40 samples of gyro and accelerometer; the gyro reads a constant turn); block 5 corrupt.
fn cwa_file(ax6: bool) -> Vec<u8> {
    let mut f = cwa_header(ax6);
    let per_block = if ax6 { 40 } else { 80 };
    for (i, samples) in holds(100.0, 256.0).chunks_exact(per_block).enumerate() {
        let mut b = cwa_block(i, samples, ax6);
        if i == 5 {
            b[100] ^= 1;
        }
        f.extend(b);
    }
    f
}

/// The `.cwa` header block of [`cwa_file`].
fn cwa_header(ax6: bool) -> Vec<u8> {
    let mut f = vec![0u8; 1024];
    f[..2].copy_from_slice(b"MD");
    f[2..4].copy_from_slice(&1020u16.to_le_bytes());
    f[4] = if ax6 { 0x64 } else { 0x17 };
    f[36] = 0x4a;
    f
}

/// Data block `i` of [`cwa_file`] holding `samples` (sealed), its time `i` blocks after
/// 2024-01-02 03:00:00.
fn cwa_block(i: usize, samples: &[[i32; 3]], ax6: bool) -> Vec<u8> {
    let per_block = samples.len();
    let mut b = vec![0u8; 512];
    b[..2].copy_from_slice(b"AX");
    b[2..4].copy_from_slice(&508u16.to_le_bytes());
    b[10..14].copy_from_slice(&(i as u32).to_le_bytes());
    let secs = (i * per_block / 100) as u32;
    let ts: u32 = (24 << 26)
        | (1 << 22)
        | (2 << 17)
        | ((3 + secs / 3600) << 12)
        | ((secs / 60 % 60) << 6)
        | (secs % 60);
    b[14..18].copy_from_slice(&ts.to_le_bytes());
    b[20..22].copy_from_slice(&(256 + i as u16 % 50).to_le_bytes());
    b[24] = 0x4a;
    b[25] = if ax6 { 0x62 } else { 0x32 };
    // The sample index of the whole-second timestamp: the samples before it this second.
    let before = (i * per_block % 100) as i16;
    b[26..28].copy_from_slice(&(-before).to_le_bytes());
    b[28..30].copy_from_slice(&(per_block as u16).to_le_bytes());
    let mut at = 30;
    for s in samples {
        let row: Vec<i16> = if ax6 {
            vec![100, -50, 25, s[0] as i16, s[1] as i16, s[2] as i16]
        } else {
            s.iter().map(|&v| v as i16).collect()
        };
        for v in row {
            b[at..at + 2].copy_from_slice(&v.to_le_bytes());
            at += 2;
        }
    }
    seal(b)
}

/// Data block `k` of the `.cwa` bytes `f` changed by `edit`, then sealed again.
fn edit_block(f: &mut [u8], k: usize, edit: impl FnOnce(&mut [u8])) {
    let at = 1024 + 512 * k;
    let mut b = f[at..at + 512].to_vec();
    edit(&mut b);
    f[at..at + 512].copy_from_slice(&seal(b));
}

/// A block's clock set one year ahead (the year field of its timestamp).
fn a_year_ahead(b: &mut [u8]) {
    let ts = u32::from_le_bytes(b[14..18].try_into().unwrap()) + (1 << 26);
    b[14..18].copy_from_slice(&ts.to_le_bytes());
}

/// `read`'s one-pass (`.cwa`) or two-pass (`.bin`) samples are `load_raw`'s: values, times,
/// notes.
fn assert_read_is_load_raw(path: &Path, format: RawFormat) -> wiical_analysis::Recording {
    let rec = load::load_raw(Blocks::File(path, format), &LoadOptions::default()).unwrap();
    let got = raw::samples::read::<f64>(
        path,
        format,
        &LoadOptions::default(),
        raw::samples::Times::Full,
    )
    .unwrap();
    let flat: Vec<f64> = rec.xyz.iter().flatten().copied().collect();
    assert!(got.xyz == flat, "{}: samples differ", path.display());
    assert!(
        got.t.as_ref() == rec.t.as_ref(),
        "{}: times differ",
        path.display()
    );
    assert_eq!(got.meta.notes, rec.notes);
    rec
}

/// One block (page) stamped a year ahead among good ones costs that block alone, named by
/// its index and time (it cost every block after it: "the clock steps back … the file is
/// damaged"), on every path: whole, block by block, and `read`'s one pass, also when the
/// block ends a chunk (its samples already placed); one `.cwa` block of 0 samples is told as
/// empty, not as a clock that steps back.
#[test]
fn one_block_stamped_ahead_costs_that_block_only() {
    let clean = load::load_raw(
        Blocks::File(&scratch("clean3.cwa", &cwa_file(false)), RawFormat::Cwa),
        &LoadOptions::default(),
    )
    .unwrap();
    let mut f = cwa_file(false);
    edit_block(&mut f, 30, a_year_ahead);
    edit_block(&mut f, 60, |b| b[28..30].fill(0));
    let path = scratch("ahead.cwa", &f);
    assert_same(&path, &LoadOptions::default());
    let rec = assert_read_is_load_raw(&path, RawFormat::Cwa);
    assert_eq!(rec.len(), clean.len() - 160);
    let notes = rec.notes.join("\n");
    for want in [
        "left out 1 data block(s) stamped far ahead of the data blocks around them (the clock jumped ahead and back; the data blocks after them are kept): #30 at 2025-01-02 03:00:24 (366 days ahead)",
        "left out 1 empty data block(s) (0 samples, a valid checksum): #60",
    ] {
        assert!(notes.contains(want), "{want}\n{notes}");
    }
    assert!(!notes.contains("steps back"), "{notes}");
    let (_, table) = streamed(&path, &LoadOptions::default());
    assert!(table.starts_with("Ok("), "{table}");
    // The last block of the first chunk stamped ahead: its rows, placed with that chunk,
    // are given back when the next chunk's first block shows it.
    let last = raw::cwa::CHUNK_BLOCKS - 1;
    let samples = holds(100.0, 256.0);
    let mut f = cwa_header(false);
    for i in 0..last + 50 {
        let k = i % (samples.len() / 80);
        let mut b = cwa_block(i, &samples[80 * k..80 * (k + 1)], false);
        if i == last {
            a_year_ahead(&mut b);
            b = seal(b);
        }
        f.extend(b);
    }
    let path = scratch("ahead-chunk.cwa", &f);
    let rec = assert_read_is_load_raw(&path, RawFormat::Cwa);
    assert_eq!(rec.len(), 80 * (last + 49));
    // A GENEActiv page a year ahead (page 7 of the written file).
    let text = String::from_utf8(bin_file()).unwrap().replacen(
        "Page Time:2013-05-30 10:00:43:000",
        "Page Time:2014-05-30 10:00:43:000",
        1,
    );
    let path = scratch("ahead.bin", text.as_bytes());
    assert_same(&path, &LoadOptions::default());
    let rec = assert_read_is_load_raw(&path, RawFormat::GeneActiv);
    let notes = rec.notes.join("\n");
    assert!(
        notes.contains("left out 1 page(s) stamped far ahead of the pages around them (the clock jumped ahead and back; the pages after them are kept): #7 at 2014-05-30 10:00:43 (365 days ahead)"),
        "{notes}"
    );
    assert!(!notes.contains("steps back"), "{notes}");
}

#[test]
fn written_bin_streams_as_it_reads_whole() {
    let path = scratch("holds.bin", &bin_file());
    let (_, table) = streamed(&path, &LoadOptions::default());
    assert!(table.starts_with("Ok("), "{table}");
    assert!(table.contains("skipped 1 unreadable page(s)"), "{table}");
    assert!(table.contains("cut short in page #"), "{table}");
    assert_same(&path, &LoadOptions::default());
}

#[test]
fn written_cwa_streams_as_it_reads_whole() {
    for ax6 in [false, true] {
        let path = scratch(
            if ax6 { "holds6.cwa" } else { "holds3.cwa" },
            &cwa_file(ax6),
        );
        let (_, table) = streamed(&path, &LoadOptions::default());
        assert!(table.starts_with("Ok("), "{table}");
        assert!(table.contains("skipped 1 corrupt data block(s)"), "{table}");
        assert_same(&path, &LoadOptions::default());
        if ax6 {
            assert_same(&path, &gyro());
        }
    }
}

/// The reader's own classification is the format the streaming path picks.
#[test]
fn raw_file_format_reads_the_first_bytes() {
    let bin = scratch("f.bin", &bin_file());
    let cwa = scratch("f.cwa", &cwa_file(false));
    let csv = scratch("f.csv", b"t,x,y,z\n0,0,0,1\n");
    assert_eq!(load::raw_file_format(&bin), Some(RawFormat::GeneActiv));
    assert_eq!(load::raw_file_format(&cwa), Some(RawFormat::Cwa));
    assert_eq!(load::raw_file_format(&csv), None);
    assert_eq!(load::raw_file_format(Path::new("-")), None);
}

/// Hostile `.bin` text: a data line of 20 000 digits skips its page by name (only its first
/// 8 KiB are held), a header without pages says so, both paths alike.
#[test]
fn overlong_lines_and_missing_pages_are_named() {
    let text = String::from_utf8(bin_file()).unwrap();
    let key = "Measurement Frequency:50\r\n";
    let long = text.replacen(key, &format!("{key}{}\r\n", "1".repeat(20_000)), 2);
    let path = scratch("long.bin", long.as_bytes());
    let (_, table) = streamed(&path, &LoadOptions::default());
    assert!(table.contains("a data line of 20"), "{table}");
    assert_same(&path, &LoadOptions::default());
    let header = &text[..text.find("Recorded Data").unwrap()];
    let path = scratch("nopages.bin", header.as_bytes());
    let format = load::raw_file_format(&path).unwrap();
    let e = load::load_raw(Blocks::File(&path, format), &LoadOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("ends before its first data block"),
        "{e}"
    );
}

/// A bad last page of a file that ends with its line feed is an unreadable page, not a
/// cut-off one (only a file ending inside its last line is cut short).
#[test]
fn a_bad_last_page_is_not_a_cut_one() {
    let text = String::from_utf8(bin_file()).unwrap();
    let whole = &text[..text.rfind("Recorded Data").unwrap()];
    let bad = format!(
        "{whole}Recorded Data\r\nPage Time:2013-05-30 11:00:00:000\r\nTemperature:1e300\r\n100\r\n"
    );
    let path = scratch("badlast.bin", bad.as_bytes());
    let mut reader = Blocks::File(&path, RawFormat::GeneActiv).open().unwrap();
    let pages = reader.all_blocks().unwrap();
    let invalid = pages.iter().filter(|b| matches!(b, Block::Invalid(_)));
    assert_eq!(invalid.count(), 2, "{:?}", reader.notes());
    assert!(reader.notes().is_empty(), "{:?}", reader.notes());
    assert_same(&path, &LoadOptions::default());
}
