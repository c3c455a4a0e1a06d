//! The background recalibration inside the adapter's report loop: reports go through
//! [`Protocol::on_report`], adoptions are committed by [`Protocol::service`] through the
//! power-loss-safe store, the settings travel over the wire and survive a reboot, a host
//! upload stays protected until the user allows replacing it, and a power cut at any flash
//! operation of an adoption boots with the old or the new calibration, never another.

mod common;
#[allow(dead_code)]
mod play;

use std::cell::RefCell;
use std::rc::Rc;

use common::{block_on, CutFlash, FlashError};
use embedded_storage_async::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use nalgebra::Vector3;
use play::{truth_error, Truth};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_adapter::background::LiveOrigin;
use wiical_adapter::settings::{Intervals, StoredSettings};
use wiical_adapter::{BootLoad, CalibrationStore, DeviceInfo, IdealScale, NunchukInfo, Protocol};
use wiical_core::Calibration;
use wiical_extbus::Encryption;
use wiical_extbus::NunchukReport;
use wiical_wire::{BackgroundSettings, CalibrationOrigin, Hello, RefusalReport, Request, Response};

type Raw = CutFlash<4, 1024, 4>;

/// One flash shared by the protocol under test and the test (to cut its power).
#[derive(Clone)]
struct Shared(Rc<RefCell<Raw>>);

impl ErrorType for Shared {
    type Error = FlashError;
}

impl ReadNorFlash for Shared {
    const READ_SIZE: usize = 4;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        // The mock's operations complete at once: run each inside its borrow.
        block_on(self.0.borrow_mut().read(offset, bytes))
    }
    fn capacity(&self) -> usize {
        Raw::SIZE as usize
    }
}

impl NorFlash for Shared {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 1024;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        block_on(self.0.borrow_mut().erase(from, to))
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        block_on(self.0.borrow_mut().write(offset, bytes))
    }
}

const RATE_HZ: f64 = 200.0;

fn boot(flash: &Shared) -> Protocol<Shared> {
    let store = CalibrationStore::new(flash.clone(), 0..Raw::SIZE).expect("store");
    let info = DeviceInfo::new("test", [0; 8], (RATE_HZ * 1000.0) as u32);
    let mut p = block_on(Protocol::boot(store, info, IdealScale::default()));
    let hello = block_on(p.handle(Request::Hello(Hello::CURRENT)));
    assert!(matches!(hello, Response::Hello(_)));
    p
}

/// A sensor without drift (the play simulator's truth) and a start calibration that is off by
/// a few counts of bias and 1 % of scale: 20–30 mg, worth replacing.
fn sensor(seed: u64) -> (Truth, Calibration) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = Truth::random(&mut rng, false);
    let mut start = truth.calibration_at(0.0);
    for (i, db) in [4.0, -3.0, 5.0].into_iter().enumerate() {
        start.bias[i] += db;
        start.matrix[i][i] *= 1.01;
    }
    (truth, start)
}

/// Play reduced to what the recalibration needs: `n` rests of 2 s in well-spread
/// orientations (a Fibonacci sphere, shuffled), each reached by a 0.5 s turn with a 0.5 g
/// shake on it (never still), with 0.6 counts of noise.
fn rests(truth: &Truth, n: usize, seed: u64) -> Vec<[u16; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut dirs: Vec<Vector3<f64>> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            Vector3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    dirs.shuffle(&mut rng);
    let noise = Normal::new(0.0, 0.6).expect("normal");
    let mut out = Vec::new();
    let mut from = Vector3::z();
    for to in dirs {
        let (turn, rest) = ((0.5 * RATE_HZ) as usize, (2.0 * RATE_HZ) as usize);
        for k in 0..turn + rest {
            let f = (k as f64 / turn as f64).min(1.0);
            let mut a = (from * (1.0 - f) + to * f).normalize();
            if k < turn {
                a += Vector3::new(0.5, -0.3, 0.4) * (k as f64 * 0.4).sin();
            }
            let m = truth.raw_exact(&a, 0.0);
            out.push(std::array::from_fn(|i| {
                (m[i] + noise.sample(&mut rng)).round().clamp(0.0, 1023.0) as u16
            }));
        }
        from = to;
    }
    out
}

fn report(raw: [u16; 3]) -> NunchukReport {
    NunchukReport {
        stick: [128, 128],
        accel: raw,
        c: false,
        z: false,
    }
}

/// Feeds `reports` through the report loop, servicing after each; stops early (returning the
/// index) when `stop` says so.
fn play(
    p: &mut Protocol<Shared>,
    reports: &[[u16; 3]],
    mut stop: impl FnMut(&Protocol<Shared>) -> bool,
) -> Option<usize> {
    for (i, raw) in reports.iter().enumerate() {
        let _ = p.on_report(&report(*raw));
        if stop(p) {
            return Some(i);
        }
        block_on(p.service());
    }
    None
}

/// The wire settings a fresh adapter reports: adoption on, host uploads kept, one commit per
/// 30 min of play and 8 per day, a fit attempt per minute.
fn defaults() -> BackgroundSettings {
    BackgroundSettings {
        adopt: true,
        replace_uploaded: false,
        commit_interval_s: 1800,
        commits_per_day: 8,
        fit_interval_ms: 60_000,
    }
}

fn live(p: &Protocol<Shared>) -> Calibration {
    *p.corrector()
        .user_calibration()
        .expect("a user calibration")
}

/// A flash holding `cal` made by `origin` (its origin record written too).
fn flash_with(cal: &Calibration, origin: LiveOrigin) -> Shared {
    flash_after(cal, origin, 1)
}

/// As [`flash_with`], after `commits` commits of `cal` (to move the map's pages on).
fn flash_after(cal: &Calibration, origin: LiveOrigin, commits: usize) -> Shared {
    let flash = Shared(Rc::new(RefCell::new(Raw::new(1))));
    let mut store = CalibrationStore::new(flash.clone(), 0..Raw::SIZE).expect("store");
    for _ in 0..commits {
        block_on(store.save(cal)).expect("save");
    }
    let s = StoredSettings {
        origin,
        ..StoredSettings::default()
    };
    block_on(store.save_settings(&s)).expect("settings");
    flash
}

#[test]
fn the_report_loop_adopts_through_the_store_and_the_next_boot_keeps_it() {
    let (truth, start) = sensor(3);
    let reports = rests(&truth, 40, 3);
    let flash = flash_with(&start, LiveOrigin::SelfCal);
    let mut p = boot(&flash);
    assert_eq!(p.status().boot, BootLoad::Loaded);
    play(&mut p, &reports, |_| false);
    let report = p.background_report();
    let adoption = report
        .last_adoption
        .expect("the report loop adopted a calibration");
    let adopted = live(&p);
    let before = truth_error(&truth, &start.prepare(), 0.0);
    let after = truth_error(&truth, &adopted.prepare(), 0.0);
    println!(
        "adopted at {} s: held-out {:.2} → {:.2} mg; truth {:.2} → {:.2} mg",
        adoption.at_s,
        adoption.before_mg,
        adoption.after_mg,
        before * 1e3,
        after * 1e3
    );
    assert!(
        before > 0.015,
        "the start should be off by > 15 mg: {before}"
    );
    assert!(after < 0.3 * before, "truth error {before} → {after}");
    assert_eq!(report.origin, CalibrationOrigin::Background);
    // The next boot loads exactly what was adopted, and knows who made it.
    drop(p);
    let p = boot(&flash);
    assert!(live(&p).bits_equal(&adopted));
    assert_eq!(p.background_report().origin, CalibrationOrigin::Background);
}

#[test]
fn adoption_off_is_stored_and_keeps_the_calibration() {
    let (truth, start) = sensor(5);
    let reports = rests(&truth, 40, 5);
    let flash = flash_with(&start, LiveOrigin::SelfCal);
    let mut p = boot(&flash);
    let off = BackgroundSettings {
        adopt: false,
        ..defaults()
    };
    assert_eq!(
        block_on(p.handle(Request::SetBackground(off))),
        Response::Ack
    );
    drop(p);
    // Kept across a reboot.
    let mut p = boot(&flash);
    let Response::Background(r) = block_on(p.handle(Request::GetBackgroundStatus)) else {
        panic!("GetBackgroundStatus answered with something else")
    };
    assert_eq!(r.settings, off);
    play(&mut p, &reports, |_| false);
    let r = p.background_report();
    assert!(
        live(&p).bits_equal(&start),
        "adoption off changed the calibration"
    );
    assert!(r.last_adoption.is_none());
    assert!(
        matches!(r.last_refusal, Some(RefusalReport::MonitorOnly { candidate_mg, live_mg }) if candidate_mg < live_mg),
        "{:?}",
        r.last_refusal
    );
    assert!(r.bins_filled >= 16, "{} bins", r.bins_filled);
    assert_eq!(r.fresh_bins.count_ones(), u32::from(r.bins_filled));
    let moments: u32 = r.bin_moments.iter().map(|m| u32::from(*m)).sum();
    assert_eq!(moments, r.moments);
}

#[test]
fn a_host_upload_is_replaced_only_when_allowed() {
    let (truth, start) = sensor(9);
    let flash = flash_with(&truth.calibration_at(0.0), LiveOrigin::SelfCal);
    let mut p = boot(&flash);
    assert_eq!(
        block_on(p.handle(Request::PutCalibration(start.into()))),
        Response::Ack
    );
    assert_eq!(
        block_on(p.handle(Request::CommitCalibration)),
        Response::Ack
    );
    assert_eq!(p.background_report().origin, CalibrationOrigin::Host);
    play(&mut p, &rests(&truth, 40, 9), |_| false);
    let r = p.background_report();
    assert!(live(&p).bits_equal(&start), "the host upload was replaced");
    assert_eq!(r.last_refusal, Some(RefusalReport::HostCalibration));
    drop(p);
    // Still the host's after a reboot; then the user allows replacing it.
    let mut p = boot(&flash);
    assert_eq!(p.background_report().origin, CalibrationOrigin::Host);
    let allow = BackgroundSettings {
        replace_uploaded: true,
        ..defaults()
    };
    assert_eq!(
        block_on(p.handle(Request::SetBackground(allow))),
        Response::Ack
    );
    play(&mut p, &rests(&truth, 40, 10), |_| false);
    assert!(p.background_report().last_adoption.is_some());
    assert!(!live(&p).bits_equal(&start));
}

/// Every flash word operation of an adoption (the calibration record, its read-back, the
/// origin record, and the page change they cause), cut in turn: the next boot has the old or
/// the adopted calibration, bit for bit, and an origin that protects at least as much.
#[test]
fn a_power_cut_at_any_flash_operation_of_an_adoption_leaves_old_or_new() {
    let (truth, start) = sensor(3);
    let reports = rests(&truth, 40, 3);
    // The uninterrupted run: where the adoption waits, what it is, how many operations; with
    // enough earlier commits that the adoption's writes need a page erased.
    let adoption = |commits: usize| {
        let flash = flash_after(&start, LiveOrigin::SelfCal, commits);
        let mut p = boot(&flash);
        let at = play(&mut p, &reports, |p| {
            p.background().pending_calibration().is_some()
        })
        .expect("an adoption");
        let new = p.background().pending_calibration().expect("pending");
        let ops0 = flash.0.borrow().ops;
        block_on(p.service());
        assert!(live(&p).bits_equal(&new));
        let ops = flash.0.borrow().ops - ops0;
        (at, new, ops)
    };
    let (commits, (at, new, total)) = (1..16)
        .map(|c| (c, adoption(c)))
        .find(|(_, (_, _, ops))| *ops > 256)
        .expect("some number of earlier commits makes the adoption erase a page");
    println!(
        "adoption after {at} reports, {commits} earlier commits: {total} flash word operations"
    );
    let (mut olds, mut news) = (0, 0);
    for cut in 0..total {
        let flash = flash_after(&start, LiveOrigin::SelfCal, commits);
        let mut p = boot(&flash);
        let again = play(&mut p, &reports, |p| {
            p.background().pending_calibration().is_some()
        });
        assert_eq!(again, Some(at), "cut {cut}: the same run");
        flash.0.borrow_mut().cut_after = Some(cut);
        block_on(p.service());
        drop(p);
        flash.0.borrow_mut().reboot();
        let p = boot(&flash);
        assert_eq!(p.status().boot, BootLoad::Loaded, "cut {cut}");
        let got = live(&p);
        let origin = p.background_report().origin;
        if got.bits_equal(&start) {
            olds += 1;
            assert_eq!(origin, CalibrationOrigin::SelfCal, "cut {cut}");
        } else {
            assert!(got.bits_equal(&new), "cut {cut}: neither old nor new");
            news += 1;
            // The budget was stored before the calibration: a new calibration is counted.
            assert_eq!(
                p.stored_settings().budget.count,
                1,
                "cut {cut}: commit not counted"
            );
            assert!(
                matches!(
                    origin,
                    CalibrationOrigin::SelfCal | CalibrationOrigin::Background
                ),
                "cut {cut}: {origin:?}"
            );
        }
    }
    println!("{total} cuts: {olds} booted the old calibration, {news} the new");
    assert!(olds > 0 && news > 0);
}

/// The corrector applies a bias temperature slope at the board's temperature (the slope the
/// background fit learns): `a = K·(m − b − s·(θ − θ₀))`, computed here in f64; without a
/// reading the slope is left out.
#[test]
fn the_corrector_applies_the_temperature_slope_at_the_boards_reading() {
    use wiical_adapter::Corrector;
    let (truth, _) = sensor(11);
    let mut cal = truth.calibration_at(0.0);
    cal.effects.temp_ref_c = 25.0;
    cal.effects.bias_temp = [0.4, -0.25, 0.3];
    let mut c = Corrector::new(IdealScale::default());
    c.set_user_calibration(Some(cal)).expect("valid");
    let raw = [610u16, 480, 700];
    let expect = |theta: Option<f64>| -> [f64; 3] {
        let m: [f64; 3] = std::array::from_fn(|i| {
            let shift = theta.map_or(0.0, |t| {
                f64::from(cal.effects.bias_temp[i]) * (t - f64::from(cal.effects.temp_ref_c))
            });
            f64::from(raw[i]) - f64::from(cal.bias[i]) - shift
        });
        std::array::from_fn(|i| (0..3).map(|j| f64::from(cal.matrix[i][j]) * m[j]).sum())
    };
    for theta in [None, Some(25.0), Some(37.5), Some(-5.0)] {
        c.set_temperature(theta.map(|t| t as f32));
        let got = c.correct(raw).g;
        let want = expect(theta);
        for i in 0..3 {
            assert!(
                (f64::from(got[i]) - want[i]).abs() < 2e-6,
                "θ {theta:?}, axis {i}: {} vs {}",
                got[i],
                want[i]
            );
        }
    }
    // At 37.5 °C the slope moves x by 5 counts: about 25 mg, so the test above can fail.
    c.set_temperature(Some(37.5));
    let hot = c.correct(raw).g;
    c.set_temperature(None);
    let cold = c.correct(raw).g;
    assert!((hot[0] - cold[0]).abs() > 0.02, "{hot:?} vs {cold:?}");
    // A non-finite reading is no reading.
    c.set_temperature(Some(f32::NAN));
    assert_eq!(c.temperature(), None);
}

/// The settings record round-trips, and any single flipped bit reads as "none stored" (the
/// defaults: adoption on, a host upload kept, the calibration counted as the host's), never as
/// other settings.
#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn settings_records_round_trip_and_a_flipped_bit_is_no_record() {
    use wiical_adapter::background::adopt::MAX_DAILY;
    use wiical_adapter::background::BudgetRecord;
    use wiical_adapter::settings::{decode_settings, encode_settings, SETTINGS_LEN};
    let origins = [
        LiveOrigin::Factory,
        LiveOrigin::SelfCal,
        LiveOrigin::Background,
        LiveOrigin::Host,
    ];
    for (k, origin) in origins.into_iter().enumerate() {
        let mut budget = BudgetRecord {
            clock_s: 90_000 * k as u32 + 7,
            ..BudgetRecord::default()
        };
        for i in 0..(5 * k).min(MAX_DAILY) {
            budget.commits[i] = 1_000 * i as u32 + k as u32;
            budget.count += 1;
        }
        let s = StoredSettings {
            background_adopt: k % 2 == 0,
            replace_uploaded: k / 2 == 1,
            origin,
            budget,
            intervals: Intervals {
                commit_interval_s: 10 + 600_000 * (k as u32 % 2),
                commits_per_day: 1 + 5 * k as u8,
                fit_interval_ms: 500 + 1_000_000 * k as u32,
            },
        };
        let bytes = encode_settings(&s);
        assert_eq!(bytes.len(), SETTINGS_LEN);
        assert_eq!(decode_settings(&bytes), Some(s));
        for bit in 0..8 * SETTINGS_LEN {
            let mut b = bytes;
            b[bit / 8] ^= 1 << (bit % 8);
            assert_eq!(decode_settings(&b), None, "bit {bit} of {s:?}");
        }
        assert_eq!(decode_settings(&bytes[..SETTINGS_LEN - 1]), None);
    }
    let d = StoredSettings::default();
    assert!(d.background_adopt && !d.replace_uploaded && d.origin == LiveOrigin::Host);
    assert_eq!(d.budget, BudgetRecord::default());
    let nominal = Intervals {
        commit_interval_s: 1800,
        commits_per_day: 8,
        fit_interval_ms: 60_000,
    };
    assert_eq!(d.intervals, nominal);
    // Intervals outside the wire protocol's bounds, with a valid CRC (a writer's bug), are
    // refused like a damaged record.
    for bad in [
        Intervals {
            commit_interval_s: 0,
            ..nominal
        },
        Intervals {
            commits_per_day: 17,
            ..nominal
        },
        Intervals {
            fit_interval_ms: 0,
            ..nominal
        },
    ] {
        let s = StoredSettings {
            intervals: bad,
            ..d
        };
        assert_eq!(decode_settings(&encode_settings(&s)), None, "{bad:?}");
    }
    // A version-2 record (written before the intervals were settable, bytes as that
    // firmware wrote them: adoption off, self-calibration origin, clock 5000 s, two commits
    // at 100 and 2000 s, CRC-32 of the first 80 bytes) still reads, with its budget and the
    // default intervals.
    let mut v2 = [0u8; 84];
    v2[..8].copy_from_slice(b"WSET\x02\x00\x00\x01");
    v2[8..12].copy_from_slice(&5000u32.to_le_bytes());
    v2[12] = 2;
    v2[16..20].copy_from_slice(&100u32.to_le_bytes());
    v2[20..24].copy_from_slice(&2000u32.to_le_bytes());
    let crc = crc32_iso_hdlc(&v2[..80]);
    v2[80..].copy_from_slice(&crc.to_le_bytes());
    let mut commits = [0; MAX_DAILY];
    commits[..2].copy_from_slice(&[100, 2000]);
    let want = StoredSettings {
        background_adopt: false,
        replace_uploaded: false,
        origin: LiveOrigin::SelfCal,
        budget: BudgetRecord {
            clock_s: 5000,
            commits,
            count: 2,
        },
        intervals: nominal,
    };
    assert_eq!(decode_settings(&v2), Some(want));
    // A version-1 record (written before the budget was stored, bytes as that firmware
    // wrote them: adoption on, background origin, CRC-32 of the first 8 bytes) still reads,
    // with an empty budget.
    let mut v1 = *b"WSET\x01\x00\x01\x02\0\0\0\0";
    let crc = crc32_iso_hdlc(&v1[..8]);
    v1[8..].copy_from_slice(&crc.to_le_bytes());
    let want = StoredSettings {
        background_adopt: true,
        replace_uploaded: false,
        origin: LiveOrigin::Background,
        budget: BudgetRecord::default(),
        intervals: nominal,
    };
    assert_eq!(decode_settings(&v1), Some(want));
}

/// CRC-32/ISO-HDLC written out (reflected, polynomial 0xEDB88320, initial and final XOR
/// 0xFFFFFFFF): an expectation independent of the `crc` crate the adapter uses.
fn crc32_iso_hdlc(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// The Nunchuk's factory block as the poller hands it over (the bytes identify the device).
fn nunchuk_info(block: [u8; 16]) -> NunchukInfo {
    NunchukInfo {
        encryption: Encryption::None,
        calibration_bytes: block,
        calibration: None,
    }
}

/// The flash-write budget is stored with the settings: after an adoption and a power cycle, a
/// better candidate waits for the rest of the commit interval (the play before the power-off
/// not counted), where a board whose flash holds the same calibration without the budget
/// adopts it at once.
#[test]
fn a_power_cycle_does_not_reset_the_write_budget() {
    let (truth, start) = sensor(3);
    let flash = flash_with(&start, LiveOrigin::SelfCal);
    let mut p = boot(&flash);
    play(&mut p, &rests(&truth, 40, 3), |_| false);
    let first = p
        .background_report()
        .last_adoption
        .expect("a first adoption");
    let adopted = live(&p);
    let interval = p.background().settings().min_commit_interval_s;
    drop(p);
    // The sensor moves on (a few counts of bias): worth another adoption.
    let mut moved = truth.clone();
    moved.b0 += Vector3::new(3.0, -4.0, 3.0);
    let again = rests(&moved, 40, 4);
    let mut p = boot(&flash);
    assert!(live(&p).bits_equal(&adopted));
    play(&mut p, &again, |_| false);
    let r = p.background_report();
    let played = r.play_s;
    assert!(
        live(&p).bits_equal(&adopted),
        "adopted again after a power cycle"
    );
    assert!(r.last_adoption.is_none());
    match r.last_refusal {
        // The interval runs from the first commit's clock, and the refusal came after the
        // first fit interval (60 s) of this boot's play and before its end.
        Some(RefusalReport::Budget { wait_s }) => assert!(
            (interval - played..=interval - 60).contains(&wait_s),
            "{wait_s} s ({played} s played)"
        ),
        other => panic!("refused for {other:?}, not the budget (first adoption {first:?})"),
    }
    // The control: the same calibration and origin without a stored budget adopts.
    let mut p = boot(&flash_with(&adopted, LiveOrigin::Background));
    play(&mut p, &again, |_| false);
    assert!(
        p.background_report().last_adoption.is_some(),
        "the control did not adopt"
    );
}

/// A different Nunchuk (another factory block) clears the bins; the same one plugged back
/// keeps them.
#[test]
fn a_swapped_nunchuk_starts_with_empty_bins() {
    let (truth, start) = sensor(5);
    let flash = flash_with(&start, LiveOrigin::SelfCal);
    let mut p = boot(&flash);
    let (a, mut b) = ([0x80; 16], [0x80; 16]);
    b[3] = 0x7F;
    p.on_connected(&nunchuk_info(a));
    play(&mut p, &rests(&truth, 10, 5), |_| false);
    let filled = p.background_report().bins_filled;
    let moments = p.background_report().moments;
    assert!(
        filled >= 5 && moments >= 8,
        "{filled} bins, {moments} moments"
    );
    p.on_disconnected();
    p.on_connected(&nunchuk_info(a));
    assert_eq!(p.background_report().bins_filled, filled, "same Nunchuk");
    assert_eq!(p.background_report().moments, moments);
    p.on_disconnected();
    p.on_connected(&nunchuk_info(b));
    let r = p.background_report();
    assert_eq!(
        (r.bins_filled, r.moments, r.fresh_bins),
        (0, 0, 0),
        "another Nunchuk"
    );
    assert!(r.bin_moments.iter().all(|m| *m == 0));
}

/// The budget and the fit interval set over the wire: out-of-bounds values are refused and
/// store nothing; the values set are stored (a reboot reports them) and enforced. With a
/// commit every 45 s of play the sensor's second move is adopted 100 s after the first; with
/// one commit per day it is refused with `Budget` and the rest of the day as the wait; the
/// defaults (one per 30 min) refuse it too.
#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn the_budget_set_over_the_wire_is_stored_and_enforced() {
    let (truth, start) = sensor(3);
    let mut moved = truth.clone();
    moved.b0 += Vector3::new(3.0, -4.0, 3.0);
    let (first, again) = (rests(&truth, 40, 3), rests(&moved, 40, 4));
    // Adoptions (play seconds) after the two plays, and the last refusal.
    let run = |set: Option<BackgroundSettings>| {
        let flash = flash_with(&start, LiveOrigin::SelfCal);
        let mut p = boot(&flash);
        if let Some(set) = set {
            for bad in [
                BackgroundSettings {
                    commit_interval_s: 0,
                    ..set
                },
                BackgroundSettings {
                    commits_per_day: 0,
                    ..set
                },
                BackgroundSettings {
                    commits_per_day: 200,
                    ..set
                },
                BackgroundSettings {
                    fit_interval_ms: 0,
                    ..set
                },
            ] {
                let answer = block_on(p.handle(Request::SetBackground(bad)));
                assert_eq!(
                    answer,
                    Response::Error(wiical_wire::ErrorCode::InvalidParameter)
                );
                assert_eq!(p.background_report().settings, defaults());
            }
            let answer = block_on(p.handle(Request::SetBackground(set)));
            assert_eq!(answer, Response::Ack);
            drop(p);
            p = boot(&flash);
            assert_eq!(p.background_report().settings, set, "not stored");
        }
        let mut adoptions = Vec::new();
        for reports in [&first, &again] {
            for raw in reports.iter() {
                let _ = p.on_report(&report(*raw));
                block_on(p.service());
                let a = p.background_report().last_adoption.map(|a| a.at_s);
                if let Some(at) = a.filter(|&at| Some(at) != adoptions.last().copied()) {
                    adoptions.push(at);
                }
            }
        }
        (adoptions, p.background_report())
    };
    let fast = BackgroundSettings {
        commit_interval_s: 45,
        commits_per_day: 16,
        fit_interval_ms: 1500,
        ..defaults()
    };
    let (adoptions, r) = run(Some(fast));
    assert!(adoptions.len() >= 2, "{adoptions:?}: {:?}", r.last_refusal);
    assert!(
        adoptions.windows(2).all(|w| w[1] - w[0] >= 45),
        "{adoptions:?}"
    );
    // One commit per day: the first adoption only, then the day's wait.
    let daily = BackgroundSettings {
        commits_per_day: 1,
        ..fast
    };
    let (adoptions1, r) = run(Some(daily));
    assert_eq!(adoptions1.len(), 1, "{adoptions1:?}");
    let played = r.play_s;
    match r.last_refusal {
        Some(RefusalReport::Budget { wait_s }) => {
            assert!(
                (86_400 - played..86_400 - 45).contains(&wait_s),
                "{wait_s} s ({played} s played)"
            );
        }
        other => panic!("refused for {other:?}, not the budget"),
    }
    // The defaults: a commit per 30 min of play, a fit per minute.
    let (adoptions0, r) = run(None);
    assert_eq!(adoptions0.len(), 1, "{adoptions0:?}");
    assert!(
        matches!(
            r.last_refusal,
            Some(RefusalReport::Budget { .. }) | Some(RefusalReport::NotBetter { .. })
        ),
        "{:?}",
        r.last_refusal
    );
}
