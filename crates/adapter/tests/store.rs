//! The calibration store: record format, and power loss at every possible point of a
//! sequence of commits on a simulated NOR flash.

mod common;

use common::{block_on, CutFlash};
use embedded_storage_async::nor_flash::NorFlash;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sequential_storage::cache::Cache;
use sequential_storage::map::{MapConfig, MapStorage};
use wiical_adapter::store::{decode_record, encode_record, RECORD_KEY, RECORD_LEN, RECORD_LEN_V1};
use wiical_adapter::{CalibrationStore, Loaded, RecordError};
use wiical_core::{Calibration, Effects};

/// A plausible, distinct, valid calibration for index `i` (Nunchuk-like: bias ≈ 512,
/// K ≈ 1/200 with small cross terms; effects non-zero to exercise every field).
fn cal(i: u32) -> Calibration {
    let f = i as f32;
    let k = 1.0 / (195.0 + f);
    Calibration {
        bias: [500.0 + f, 510.0 - f * 0.5, 520.25 + f * 0.125],
        matrix: [
            [k, 1e-5 * f, -2e-5],
            [-3e-5, k * 1.01, 4e-6 * f],
            [1e-6, 2e-6, k * 0.99],
        ],
        effects: Effects {
            quadratic: [1e-3 * f, 0.0, -1e-3],
            cubic: [0.0, 2e-4, 0.0],
            bias_drift: [0.0, 0.0, 1e-3 * f],
            temp_ref_c: 25.0 + f,
            bias_temp: [0.1, -0.1, 0.0],
            scale_temp: [0.0, 1e-4, 0.0],
            cross_quadratic: [
                [1e-4 * f, 0.0, 0.0, 2e-4, 0.0],
                [0.0; 5],
                [0.0, 0.0, 0.0, 0.0, -3e-4],
            ],
            cross_cubic: [
                [0.0; 9],
                [5e-5 * f, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-4],
                [0.0; 9],
            ],
        },
    }
}

fn same(a: &Calibration, b: &Calibration) -> bool {
    encode_record(a) == encode_record(b)
}

#[test]
fn record_round_trip_is_bit_exact() {
    let mut c = cal(3);
    c.bias[1] = -0.0;
    c.matrix[0][1] = f32::MIN_POSITIVE / 4.0; // subnormal
    c.effects.cubic[2] = -1.5e-30;
    let rec = encode_record(&c);
    assert_eq!(rec.len(), RECORD_LEN);
    assert_eq!(&rec[..4], b"WCAL");
    assert_eq!(u16::from_le_bytes([rec[4], rec[5]]), 2);
    assert_eq!(u16::from_le_bytes([rec[6], rec[7]]), 280);
    let back = decode_record(&rec).unwrap();
    assert!(same(&back, &c));
    assert_eq!(back.bias[1].to_bits(), (-0.0f32).to_bits());
    // Independent check of the payload order: bias then matrix rows, little-endian.
    assert_eq!(&rec[8..12], &c.bias[0].to_le_bytes());
    assert_eq!(&rec[20..24], &c.matrix[0][0].to_le_bytes());
    assert_eq!(
        &rec[8 + 4 * 21..8 + 4 * 22],
        &c.effects.temp_ref_c.to_le_bytes()
    );
    // The cross terms follow version 1's 28 floats, row by row.
    assert_eq!(
        &rec[8 + 4 * 28..8 + 4 * 29],
        &c.effects.cross_quadratic[0][0].to_le_bytes()
    );
    assert_eq!(
        &rec[8 + 4 * 31..8 + 4 * 32],
        &c.effects.cross_quadratic[0][3].to_le_bytes()
    );
    assert_eq!(
        &rec[8 + 4 * 43..8 + 4 * 44],
        &c.effects.cross_cubic[0][0].to_le_bytes()
    );
    assert_eq!(
        &rec[8 + 4 * 52..8 + 4 * 53],
        &c.effects.cross_cubic[1][0].to_le_bytes()
    );
    assert_eq!(
        &rec[8 + 4 * 60..8 + 4 * 61],
        &c.effects.cross_cubic[1][8].to_le_bytes()
    );
}

/// A version-1 record, built byte by byte as the firmware before the cross terms wrote it
/// (28 floats, CRC-32/ISO-HDLC over the rest).
fn record_v1(c: &Calibration) -> Vec<u8> {
    let e = &c.effects;
    let mut floats: Vec<f32> = c.bias.to_vec();
    c.matrix.iter().for_each(|r| floats.extend(r));
    for v in [e.quadratic, e.cubic, e.bias_drift] {
        floats.extend(v);
    }
    floats.push(e.temp_ref_c);
    floats.extend(e.bias_temp);
    floats.extend(e.scale_temp);
    let mut rec = b"WCAL".to_vec();
    rec.extend(1u16.to_le_bytes());
    rec.extend(112u16.to_le_bytes());
    floats.iter().for_each(|x| rec.extend(x.to_le_bytes()));
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&rec);
    rec.extend(crc.to_le_bytes());
    rec
}

/// A calibration committed by the old firmware (record version 1) still loads after the
/// update, with zero cross terms; damage to it is still refused.
#[test]
fn a_version_1_record_from_the_old_firmware_still_loads() {
    let mut old = cal(4);
    old.effects.cross_quadratic = [[0.0; 5]; 3];
    old.effects.cross_cubic = [[0.0; 9]; 3];
    let rec = record_v1(&old);
    assert_eq!(rec.len(), RECORD_LEN_V1);
    let back = decode_record(&rec).unwrap();
    assert!(same(&back, &old));
    assert!(!back.effects.has_cross_terms());
    let mut bad = rec.clone();
    bad[30] ^= 4;
    assert_eq!(decode_record(&bad), Err(RecordError::BadCrc));
    // A version-1 header on a version-2 length, and the reverse, are refused.
    let mut long = encode_record(&cal(4));
    long[4] = 1;
    assert_eq!(
        decode_record(&long),
        Err(RecordError::WrongLength(RECORD_LEN))
    );
    let mut short = rec.clone();
    short[4] = 2;
    assert_eq!(
        decode_record(&short),
        Err(RecordError::WrongLength(RECORD_LEN_V1))
    );
    // In flash, through the map, as the old firmware stored it.
    let mut flash = Flash::new(6);
    {
        let mut map = MapStorage::<u8, _, _>::new(
            &mut flash,
            MapConfig::new(0..Flash::SIZE),
            Cache::new_uncached(),
        );
        let mut buf = [0u8; 512];
        block_on(map.store_item(&mut buf, &RECORD_KEY, &&rec[..])).unwrap();
    }
    let mut s = store(&mut flash, Flash::SIZE);
    let Loaded::Calibration(c) = block_on(s.load()).unwrap() else {
        panic!("the version-1 record was not loaded")
    };
    assert!(same(&c, &old));
    // The next commit writes version 2 over it, and that one wins.
    block_on(s.save(&cal(9))).unwrap();
    let Loaded::Calibration(c) = block_on(s.load()).unwrap() else {
        panic!()
    };
    assert!(same(&c, &cal(9)));
}

#[test]
fn every_single_bit_flip_of_a_record_is_rejected() {
    let rec = encode_record(&cal(7));
    for byte in 0..rec.len() {
        for bit in 0..8 {
            let mut r = rec;
            r[byte] ^= 1 << bit;
            assert!(
                decode_record(&r).is_err(),
                "flip of byte {byte} bit {bit} accepted"
            );
        }
    }
    // Specific reasons.
    let mut r = rec;
    r[0] = b'X';
    assert_eq!(decode_record(&r), Err(RecordError::BadMagic));
    let mut r = rec;
    r[4] = 3;
    assert_eq!(decode_record(&r), Err(RecordError::UnsupportedVersion(3)));
    assert_eq!(decode_record(&rec[..50]), Err(RecordError::WrongLength(50)));
    assert_eq!(decode_record(&[]), Err(RecordError::WrongLength(0)));
    let mut r = rec;
    r[40] ^= 0x10;
    assert_eq!(decode_record(&r), Err(RecordError::BadCrc));
    // Intact bytes, unusable calibration: refused too.
    let mut singular = cal(1);
    singular.matrix[2] = singular.matrix[1];
    assert_eq!(
        decode_record(&encode_record(&singular)),
        Err(RecordError::Invalid(wiical_core::Error::Singular))
    );
    let mut nan = cal(1);
    nan.effects.scale_temp[0] = f32::NAN;
    assert_eq!(
        decode_record(&encode_record(&nan)),
        Err(RecordError::Invalid(wiical_core::Error::NonFinite))
    );
}

type Flash = CutFlash<4, 1024, 4>;

fn store<F: NorFlash>(flash: F, size: u32) -> CalibrationStore<F> {
    CalibrationStore::new(flash, 0..size).unwrap()
}

#[test]
fn empty_then_latest_wins_over_many_page_rotations() {
    let mut flash = Flash::new(1);
    let mut s = store(&mut flash, Flash::SIZE);
    assert_eq!(block_on(s.load()).unwrap(), Loaded::Empty);
    for i in 0..60 {
        block_on(s.save(&cal(i))).unwrap();
        let Loaded::Calibration(c) = block_on(s.load()).unwrap() else {
            panic!("nothing loaded after save {i}");
        };
        assert!(same(&c, &cal(i)), "save {i}");
    }
    // A new store over the same flash (a reboot) sees the last one.
    let mut s = store(&mut flash, Flash::SIZE);
    let Loaded::Calibration(c) = block_on(s.load()).unwrap() else {
        panic!()
    };
    assert!(same(&c, &cal(59)));
    assert_eq!(flash.illegal_programs, 0, "programmed a word twice");
    // Erasing the range forgets it.
    let mut s = store(&mut flash, Flash::SIZE);
    block_on(s.erase_all()).unwrap();
    assert_eq!(block_on(s.load()).unwrap(), Loaded::Empty);
    assert!(flash.data.iter().all(|&b| b == 0xFF));
}

#[test]
fn bad_flash_ranges_are_refused() {
    let mut flash = Flash::new(1);
    // One page only, unaligned.
    assert!(CalibrationStore::new(&mut flash, 0..1024).is_err());
    assert!(CalibrationStore::new(&mut flash, 4..2052).is_err());
    // Pages too small for a record (256-byte pages held a version-1 record, not a
    // version-2 one).
    let mut tiny = CutFlash::<4, 64, 8>::new(1);
    assert!(CalibrationStore::new(&mut tiny, 0..512).is_err());
    let mut small = CutFlash::<1, 256, 4>::new(1);
    assert!(CalibrationStore::new(&mut small, 0..1024).is_err());
    // Two pages holding one record each: the map could never move on to a new record
    // (it keeps one page free for migration), so this is refused up front…
    let mut two = CutFlash::<1, 512, 2>::new(1);
    assert!(CalibrationStore::new(&mut two, 0..1024).is_err());
    // …while the same pages with a third one work.
    let mut three = CutFlash::<1, 512, 3>::new(1);
    assert!(CalibrationStore::new(&mut three, 0..1536).is_ok());
}

/// Saves `cal(0..n)` in order with the power cut after `cut` word operations (or never).
/// Returns the index whose save was interrupted (None if all completed).
fn run_until_cut<F: NorFlash>(s: &mut CalibrationStore<F>, n: u32) -> Option<u32> {
    (0..n).find(|&i| block_on(s.save(&cal(i))).is_err())
}

/// Exhaustive power-cut test: for every word operation of a sequence of `N` commits (which
/// fills and rotates the pages several times), cut the power there, reboot, and require the
/// last completed calibration or the interrupted one; never anything else. Then require
/// that the storage still works (a new commit is read back after another reboot).
fn power_cut_everywhere<const W: usize, const P: usize, const NP: usize>(n: u32) -> u64 {
    let size = (P * NP) as u32;
    // Count the operations of an uninterrupted run.
    let mut flash = CutFlash::<W, P, NP>::new(0);
    let mut s = store(&mut flash, size);
    assert_eq!(run_until_cut(&mut s, n), None);
    let total = flash.ops;
    assert_eq!(flash.illegal_programs, 0);

    for cut in 0..=total {
        let mut flash = CutFlash::<W, P, NP>::new(cut);
        flash.cut_after = Some(cut);
        let mut s = store(&mut flash, size);
        let interrupted = run_until_cut(&mut s, n);
        flash.reboot();

        let mut s = store(&mut flash, size);
        let loaded = block_on(s.load()).unwrap_or_else(|e| panic!("cut {cut}: load failed: {e:?}"));
        match (interrupted, loaded) {
            (None, Loaded::Calibration(c)) => assert!(same(&c, &cal(n - 1)), "cut {cut}"),
            (Some(0), Loaded::Empty) => {}
            (Some(i), Loaded::Calibration(c)) => assert!(
                same(&c, &cal(i)) || (i > 0 && same(&c, &cal(i - 1))),
                "cut {cut} during save {i}: got a calibration that is neither old nor new"
            ),
            (i, other) => panic!("cut {cut} (interrupted save {i:?}): loaded {other:?}"),
        }
        // Life goes on after the reboot.
        let next = cal(1000 + cut as u32);
        block_on(s.save(&next)).unwrap_or_else(|e| panic!("cut {cut}: save after reboot: {e:?}"));
        let mut s = store(&mut flash, size);
        let Loaded::Calibration(c) = block_on(s.load()).unwrap() else {
            panic!("cut {cut}: nothing after the post-reboot save")
        };
        assert!(same(&c, &next), "cut {cut}");
    }
    total
}

#[test]
fn power_cut_at_every_word_operation_4_byte_words() {
    // 3 records per page, 4 pages: 24 commits rotate through every page twice, with erases.
    let total = power_cut_everywhere::<4, 1024, 4>(24);
    // 24 records of 76 words plus at least two page erases of 256 words.
    assert!(total > 24 * 76 + 2 * 256, "sequence too short: {total} ops");
}

#[test]
fn power_cut_at_every_word_operation_1_byte_words_small_pages() {
    // Byte-programmable flash with one record per page and 3 pages, the tightest
    // configuration the store accepts (every commit moves to the next page and erases one).
    power_cut_everywhere::<1, 512, 3>(7);
}

#[test]
fn power_cut_at_every_word_operation_two_pages() {
    // The other tight case: only 2 pages, each holding 3 records.
    power_cut_everywhere::<4, 1024, 2>(10);
}

#[test]
fn power_cut_at_every_word_operation_16_byte_words() {
    power_cut_everywhere::<16, 2048, 3>(10);
}

#[test]
fn damaged_record_in_flash_loads_as_nothing_never_as_garbage() {
    // Flip each bit of the stored record's value in flash in turn (behind the store's back).
    let mut flash = Flash::new(3);
    let mut s = store(&mut flash, Flash::SIZE);
    block_on(s.save(&cal(5))).unwrap();
    let pos = flash
        .data
        .windows(4)
        .position(|w| w == b"WCAL")
        .expect("record not found in flash");
    for byte in pos..pos + RECORD_LEN {
        for bit in [0u8, 3, 7] {
            let mut f = Flash::new(3);
            f.data = flash.data.clone();
            f.data[byte] ^= 1 << bit;
            let mut s = store(&mut f, Flash::SIZE);
            match block_on(s.load()) {
                Ok(Loaded::Calibration(c)) => {
                    panic!("byte {byte} bit {bit}: damaged record loaded as {c:?}")
                }
                Ok(Loaded::Empty) | Ok(Loaded::Rejected(_)) | Err(_) => {}
            }
        }
    }
}

#[test]
fn record_of_unknown_version_is_rejected() {
    // Written by a hypothetical newer firmware with the same key.
    let mut flash = Flash::new(4);
    let mut rec = encode_record(&cal(2));
    rec[4] = 9;
    {
        let mut map = MapStorage::<u8, _, _>::new(
            &mut flash,
            MapConfig::new(0..Flash::SIZE),
            Cache::new_uncached(),
        );
        let mut buf = [0u8; 512];
        block_on(map.store_item(&mut buf, &RECORD_KEY, &&rec[..])).unwrap();
    }
    let mut s = store(&mut flash, Flash::SIZE);
    assert_eq!(
        block_on(s.load()).unwrap(),
        Loaded::Rejected(RecordError::UnsupportedVersion(9))
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random calibrations (any bit patterns that validate), random cut point and random
    /// half-programmed bits: after the reboot, old or new, bit for bit.
    #[test]
    fn random_power_cuts_old_or_new(seed in any::<u64>(), cut in 0u64..1200, n in 1u32..15) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cals: Vec<Calibration> = (0..n)
            .map(|_| {
                let mut c = cal(rng.random_range(0..100));
                c.bias = [rng.random(), rng.random(), rng.random::<f32>() * 1e3];
                c.matrix[0][0] = rng.random_range(1e-3..1.0);
                c
            })
            .collect();
        let mut flash = Flash::new(seed);
        flash.cut_after = Some(cut);
        let mut s = store(&mut flash, Flash::SIZE);
        let mut interrupted = None;
        for (i, c) in cals.iter().enumerate() {
            if block_on(s.save(c)).is_err() {
                interrupted = Some(i);
                break;
            }
        }
        flash.reboot();
        let mut s = store(&mut flash, Flash::SIZE);
        let loaded = block_on(s.load()).unwrap();
        let ok = match (interrupted, loaded) {
            (None, Loaded::Calibration(c)) => same(&c, &cals[cals.len() - 1]),
            (Some(0), Loaded::Empty) => true,
            (Some(i), Loaded::Calibration(c)) => same(&c, &cals[i]) || (i > 0 && same(&c, &cals[i - 1])),
            _ => false,
        };
        prop_assert!(ok, "interrupted {:?}", interrupted);
    }
}
