//! GGIR's still 10-s epochs of raw recordings (`wiical_analysis::input::raw::epochs`): on a simulated
//! raw recording with known truth (holds on the sphere between movements, a miscalibrated
//! sensor with a temperature drift), and on GGIRread's minutes-long test files, which are too
//! short for the autocalibration and must say so.

mod common;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_analysis::input::front_door::{load_input, Input};
use wiical_analysis::input::raw::epochs::{still_epochs, EpochOptions};
use wiical_analysis::input::raw::load::{raw_epoch_table, raw_file_format, Blocks};
use wiical_analysis::input::table::WindowTable;
use wiical_analysis::input::window_means::WindowInputOptions;
use wiical_analysis::input::InputError;
use wiical_analysis::{Error, Recording};

/// Truth of the simulated sensor: `x = (a − k·(T − T̄))/s − o` for gravity `a` (GGIR's model
/// `a = s·(x + o) + k·(T − T̄)` solved for the reading `x`).
const OFFSET: [f64; 3] = [0.02, -0.015, 0.01];
const SCALE: [f64; 3] = [0.98, 1.02, 1.01];
const TEMP_COEF: [f64; 3] = [0.0015, 0.0, -0.001];
const RATE: f64 = 25.0;
const HOLD_S: f64 = 60.0;
const MOVE_S: f64 = 30.0;
const HOLDS: usize = 40;

/// 40 holds of 60 s at directions spread over the sphere (golden-angle spiral), each
/// followed by 30 s of movement (SD 0.3 g); reading noise 4 mg; temperature swinging 20–30 °C with a
/// 1000-s period (not in step with the directions, so scale and drift are separable). Holds start on multiples of 90 s, so each gives exactly six
/// complete 10-s epochs and each movement none.
fn simulate() -> Recording {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let noise = Normal::new(0.0, 0.004).unwrap();
    let shake = Normal::new(0.0, 0.3).unwrap();
    let n_per = ((HOLD_S + MOVE_S) * RATE) as usize;
    let total = n_per * HOLDS;
    let temp_mean = 25.0;
    let mut rec = Recording::default();
    let (mut t, mut temp) = (Vec::new(), Vec::new());
    for i in 0..total {
        let ti = i as f64 / RATE;
        let h = i / n_per;
        // Still 0.2 s beyond the hold, so a sample timed a few µs early by a file's
        // quantised block times does not carry movement into the hold's last epoch.
        let in_hold = (i % n_per) as f64 / RATE < HOLD_S + 0.2;
        let z = 1.0 - 2.0 * (h as f64 + 0.5) / HOLDS as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = h as f64 * 2.399_963;
        let g = [r * phi.cos(), r * phi.sin(), z];
        let tc = temp_mean + 5.0 * (2.0 * std::f64::consts::PI * ti / 1000.0).sin();
        let x: [f64; 3] = std::array::from_fn(|a| {
            let a_true = if in_hold {
                g[a]
            } else {
                g[a] + shake.sample(&mut rng)
            };
            (a_true - TEMP_COEF[a] * (tc - temp_mean)) / SCALE[a] - OFFSET[a]
                + noise.sample(&mut rng)
        });
        rec.xyz.push(x);
        t.push(1.7e9 + ti);
        temp.push(tc);
    }
    rec.t = Some(t);
    rec.temp = Some(temp);
    rec.axis_columns = ["ax", "ay", "az"].map(String::from);
    rec
}

/// The epoch finder keeps exactly the hold epochs: 6 per hold, none of the movements.
#[test]
fn still_epochs_of_a_simulated_recording_are_the_holds() {
    let rec = simulate();
    let t = rec.t.clone().unwrap();
    let found = still_epochs(
        &t,
        &rec.xyz,
        rec.temp.as_deref(),
        RATE,
        &EpochOptions::default(),
    );
    assert_eq!(found.still.len(), 6 * HOLDS);
    assert_eq!(found.examined, 9 * HOLDS);
    for e in &found.still {
        let k = ((e.t_centre - t[0]) / 90.0).floor();
        let into = e.t_centre - t[0] - 90.0 * k;
        assert!(into < HOLD_S, "epoch at {into} s into a cycle");
        assert_eq!(e.count, 250);
        assert!(e.sd.iter().all(|&s| s > 0.002 && s < 0.006), "{:?}", e.sd);
    }
}

/// GGIRread's test files last minutes: the raw path says how many still epochs it found and
/// how many it needs, in one sentence, instead of analysing nothing.
#[test]
fn short_raw_files_say_too_few_epochs() {
    for name in [
        "ax3_testfile.cwa",
        "ax6_testfile.cwa",
        "GENEActiv_testfile.bin",
    ] {
        let path = common::data_dir().join("ggirread_testfiles").join(name);
        let err = load_input(&path, &WindowInputOptions::default()).unwrap_err();
        let Error::InFile { source, .. } = &err else {
            panic!("{err}")
        };
        match **source {
            Error::Input(InputError::TooFewStillEpochs {
                found,
                needed,
                examined,
                ..
            }) => {
                assert!(found < needed && needed == 10, "{name}: {found}/{needed}");
                assert!(examined >= 5, "{name}: {examined} epochs examined");
            }
            ref other => panic!("{name}: {other}"),
        }
        let msg = err.full_message();
        assert!(msg.contains("needs at least 10"), "{msg}");
        assert!(!msg.contains('\n'), "{msg}");
    }
}

/// A too-short simulated raw recording (written as a `.cwa` file) is refused the same way,
/// with the numbers.
#[test]
fn too_few_epochs_in_a_simulation_are_counted() {
    let mut rec = simulate();
    let keep = (HOLD_S * RATE) as usize; // the first hold only: 6 epochs
    rec.xyz.truncate(keep);
    rec.t.as_mut().unwrap().truncate(keep);
    rec.temp.as_mut().unwrap().truncate(keep);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.cwa");
    write_cwa(&rec, &path);
    let blocks = Blocks::File(&path, raw_file_format(&path).unwrap());
    let err = raw_epoch_table(blocks, &Default::default(), &EpochOptions::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::Input(InputError::TooFewStillEpochs {
                found: 6,
                needed: 10,
                ..
            })
        ),
        "{err}"
    );
    let _ = Input::Samples(rec);
}

/// Writes `rec` (g, 25 Hz, with temperature) as an unpacked 3-axis Axivity `.cwa` file, from
/// the published layout (a test-only writer: 80 samples of `i16` at 1/256 g per block, the
/// start time as whole seconds plus a 15-bit fraction, the sample index cancelling the
/// firmware's shift, checksum word last).
fn write_cwa(rec: &Recording, path: &std::path::Path) {
    let mut f = vec![0u8; 1024];
    f[..2].copy_from_slice(b"MD");
    f[2..4].copy_from_slice(&1020u16.to_le_bytes());
    f[36] = 8; // 3200 / 2^7 = 25 Hz
    let t = rec.t.as_ref().unwrap();
    let temp = rec.temp.as_ref().unwrap();
    for (k, chunk) in rec.xyz.chunks(80).enumerate() {
        let i0 = k * 80;
        let mut b = vec![0u8; 512];
        b[..2].copy_from_slice(b"AX");
        b[2..4].copy_from_slice(&508u16.to_le_bytes());
        let whole = t[i0].floor();
        let frac15 = (((t[i0] - whole) * 32768.0).round() as u32).min(0x7fff);
        b[4..6].copy_from_slice(&(0x8000u16 | frac15 as u16).to_le_bytes());
        b[10..14].copy_from_slice(&(k as u32).to_le_bytes());
        // Civil time of `whole` (seconds since 1970, no zone) packed as the device does.
        let days = (whole / 86400.0).floor() as i64;
        let sod = (whole - days as f64 * 86400.0) as u32;
        let (y, mo, d) = civil_from_days(days);
        let ts = (((y - 2000) as u32) << 26)
            | (mo << 22)
            | (d << 17)
            | ((sod / 3600) << 12)
            | ((sod / 60 % 60) << 6)
            | (sod % 60);
        b[14..18].copy_from_slice(&ts.to_le_bytes());
        let tv = ((temp[i0] + 50.0) * 256.0 / 75.0).round() as u16;
        b[20..22].copy_from_slice(&tv.to_le_bytes());
        b[24] = 8;
        b[25] = 0x32;
        let shift = ((frac15 << 1) * 25) >> 16;
        b[26..28].copy_from_slice(&(-(shift as i16)).to_le_bytes());
        b[28..30].copy_from_slice(&(chunk.len() as u16).to_le_bytes());
        for (i, s) in chunk.iter().enumerate() {
            for (a, &sa) in s.iter().enumerate() {
                let v = (sa * 256.0).round() as i16;
                let at = 30 + 6 * i + 2 * a;
                b[at..at + 2].copy_from_slice(&v.to_le_bytes());
            }
        }
        let sum = b.chunks_exact(2).fold(0u16, |s, w| {
            s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
        });
        b[510..512].copy_from_slice(&0u16.wrapping_sub(sum).to_le_bytes());
        f.extend(b);
    }
    std::fs::write(path, f).unwrap();
}

/// Civil date of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// End to end: the simulation written as a `.cwa` file, read by `load_input` (what `fit` and
/// `analyze` call) → the still-epoch table → the autocalibration recovers the truth through
/// the file's 1/256-g and 0.29-°C quantisation.
#[test]
fn simulated_cwa_file_runs_the_autocalibration() {
    let rec = simulate();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.cwa");
    write_cwa(&rec, &path);
    let Input::Table(table) = load_input(&path, &WindowInputOptions::default()).unwrap() else {
        panic!("a raw file must give the still-epoch table");
    };
    assert_eq!(table.info.rows, 6 * HOLDS);
    assert!(
        table.info.description.starts_with("240 still 10-s epochs"),
        "{}",
        table.info.description
    );
    assert!(
        table.recording.notes.is_empty(),
        "{:?}",
        table.recording.notes
    );
    let rep = wiical_analysis::pipeline::analyze_judged(
        &Input::Table(table.clone()),
        &Default::default(),
    )
    .unwrap()
    .report;
    assert!(rep.autocalibration_converged.is_some());
    let fit = wiical_analysis::autocal::autocalibrate(
        &table.recording.xyz,
        table.recording.temp.as_deref(),
        &wiical_analysis::autocal::AutocalOptions::converged(),
    )
    .unwrap();
    for a in 0..3 {
        assert!((fit.offset[a] - OFFSET[a]).abs() < 2e-3, "{:?}", fit.offset);
        assert!((fit.scale[a] - SCALE[a]).abs() < 2e-3, "{:?}", fit.scale);
        assert!(
            (fit.temp_coef[a] - TEMP_COEF[a]).abs() < 4e-4,
            "{:?}",
            fit.temp_coef
        );
    }
}

/// The file's bytes held in memory, read by the same readers.
fn whole_file_table(path: &std::path::Path) -> wiical_analysis::Result<WindowTable> {
    let format = wiical_analysis::input::raw::load::raw_file_format(path).expect("a raw file");
    let bytes = std::fs::read(path).unwrap();
    raw_epoch_table(
        Blocks::Bytes(&bytes, format),
        &Default::default(),
        &EpochOptions::default(),
    )
}

fn assert_same_table(a: &WindowTable, b: &WindowTable) {
    let bits =
        |v: &[[f64; 3]]| -> Vec<[u64; 3]> { v.iter().map(|r| r.map(f64::to_bits)).collect() };
    let bits1 = |v: &[f64]| -> Vec<u64> { v.iter().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&a.recording.xyz), bits(&b.recording.xyz));
    assert_eq!(bits(a.sd.as_ref().unwrap()), bits(b.sd.as_ref().unwrap()));
    assert_eq!(a.count, b.count);
    assert_eq!(
        bits1(a.recording.t.as_ref().unwrap()),
        bits1(b.recording.t.as_ref().unwrap())
    );
    assert_eq!(
        bits1(a.recording.temp.as_ref().unwrap()),
        bits1(b.recording.temp.as_ref().unwrap())
    );
    assert_eq!(a.recording.notes, b.recording.notes);
    assert_eq!(a.recording.info, b.recording.info);
    assert_eq!(a.recording.axis_columns, b.recording.axis_columns);
    assert_eq!(a.info.description, b.info.description);
}

/// `load_input` reads a `.cwa` file block by block; its table is the whole-file path's bit for
/// bit, also with corrupt blocks, an unreadable block, a block whose clock steps back and a
/// cut-off end (the notes name each), and its errors are the same on the real test files.
#[test]
fn block_by_block_reading_equals_the_whole_file_path() {
    let rec = simulate();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.cwa");
    write_cwa(&rec, &path);
    let streamed = |p: &std::path::Path| match load_input(p, &WindowInputOptions::default()) {
        Ok(Input::Table(t)) => Ok(t),
        Ok(Input::Samples(_) | Input::Stream(_)) => {
            panic!("a raw file must give the still-epoch table")
        }
        Err(e) => Err(e),
    };
    assert_same_table(&streamed(&path).unwrap(), &whole_file_table(&path).unwrap());
    // Damage: block 5's checksum, block 9's magic (checksum kept right), block 20's clock set
    // back one minute, a cut-off end.
    let mut bytes = std::fs::read(&path).unwrap();
    let at = |k: usize| 1024 + 512 * k;
    bytes[at(5) + 40] ^= 1;
    let reseal = |b: &mut [u8]| {
        b[510] = 0;
        b[511] = 0;
        let s = b.chunks_exact(2).fold(0u16, |s, w| {
            s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
        });
        b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
    };
    bytes[at(9)] = b'Q';
    reseal(&mut bytes[at(9)..at(10)]);
    let ts = u32::from_le_bytes(bytes[at(20) + 14..at(20) + 18].try_into().unwrap());
    let minute = (ts >> 6) & 0x3f;
    let ts = (ts & !(0x3f << 6)) | ((minute.saturating_sub(1)) << 6);
    bytes[at(20) + 14..at(20) + 18].copy_from_slice(&ts.to_le_bytes());
    reseal(&mut bytes[at(20)..at(21)]);
    bytes.extend([0u8; 100]);
    std::fs::write(&path, &bytes).unwrap();
    let (a, b) = (streamed(&path).unwrap(), whole_file_table(&path).unwrap());
    assert_same_table(&a, &b);
    let notes = a.recording.notes.join("\n");
    for want in [
        "skipped 1 corrupt data block(s)",
        "skipped 1 unreadable",
        "cut short",
    ] {
        assert!(notes.contains(want), "{want}: {notes}");
    }
    // The real test files: the same refusal, word for word.
    for name in [
        "ax3_testfile.cwa",
        "ax6_testfile.cwa",
        "ax3_testfile_corrupt_blocks_0_13_14_142_143_144.cwa",
    ] {
        let path = common::data_dir().join("ggirread_testfiles").join(name);
        let a = streamed(&path).unwrap_err().full_message();
        let b = whole_file_table(&path)
            .unwrap_err()
            .in_file(&path)
            .full_message();
        assert_eq!(a, b, "{name}");
    }
}

/// Too few still epochs because the file is damaged is said so, not "a longer recording is
/// needed"; blocks holding no sample are named as such; both paths say it word for word.
#[test]
fn a_damaged_file_names_its_damage() {
    let rec = simulate();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.cwa");
    write_cwa(&rec, &path);
    let clean = std::fs::read(&path).unwrap();
    let blocks = (clean.len() - 1024) / 512;
    let mut bytes = clean.clone();
    for k in (0..blocks).filter(|k| k % 5 != 0) {
        bytes[1024 + 512 * k + 40] ^= 1; // 4 in 5 fail their checksum
    }
    std::fs::write(&path, &bytes).unwrap();
    let streamed = load_input(&path, &WindowInputOptions::default())
        .unwrap_err()
        .full_message();
    // The same bytes gzip-compressed are read whole (`load_input`'s other path).
    let gz = dir.path().join("sim.cwa.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &bytes).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    let whole = load_input(&gz, &WindowInputOptions::default())
        .unwrap_err()
        .full_message()
        .replace("sim.cwa.gz", "sim.cwa");
    let lost = blocks - blocks.div_ceil(5);
    let want = format!("{lost} of its {blocks} data blocks could not be used ({lost} fail their checksum): the file is damaged, not too short");
    assert!(streamed.contains(&want), "{streamed}");
    assert!(!streamed.contains("longer recording"), "{streamed}");
    assert_eq!(streamed, whole);
    // Every block with a sample count of 0 (checksum kept right).
    let mut bytes = clean;
    for k in 0..blocks {
        let b = &mut bytes[1024 + 512 * k..1024 + 512 * (k + 1)];
        b[28] = 0;
        b[29] = 0;
        b[510] = 0;
        b[511] = 0;
        let s = b.chunks_exact(2).fold(0u16, |s, w| {
            s.wrapping_add(u16::from_le_bytes([w[0], w[1]]))
        });
        b[510..512].copy_from_slice(&0u16.wrapping_sub(s).to_le_bytes());
    }
    std::fs::write(&path, &bytes).unwrap();
    let e = load_input(&path, &WindowInputOptions::default())
        .unwrap_err()
        .full_message();
    assert!(
        e.contains(&format!(
            "none of its {blocks} data blocks is readable (0 skipped: {blocks} hold 0 samples)"
        )),
        "{e}"
    );
    assert!(!e.contains("ends before"), "{e}");
}
