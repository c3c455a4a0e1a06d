//! "Every hold a window": on brisk simulated recordings (hand-placed holds of
//! 2–4 s, moves of 1–2 s with hand bumps) the default detector finds at least 95 % of the holds
//! with ≥ 1.5 s of still samples, for a Nunchuk (10-bit, ~200 counts/g, 100 Hz), a Wii Remote
//! (~105 counts/g, 200 Hz) and a 16-bit MEMS written in m/s² at 400 Hz. The truth is the
//! simulator's (`wiical_sim::score_holds` defines found / present); no window lies outside a hold.

use wiical_analysis::detect::windows::detect_windows;
use wiical_analysis::DetectOptions;
use wiical_sim::{score_holds, Device, Profile, SimConfig};

const SEEDS: std::ops::RangeInclusive<u64> = 1..=6;

/// (found, present, stray windows, windows) over `seeds` for one device at one rate.
fn score(
    device: Device,
    rate_hz: f64,
    profile: Profile,
    seeds: std::ops::RangeInclusive<u64>,
) -> (usize, usize, usize, usize) {
    let mut total = (0, 0, 0, 0);
    for seed in seeds {
        let sim = wiical_sim::simulate(&SimConfig {
            device,
            rate_hz,
            profile,
            seed,
            poses: 30,
            ..Default::default()
        })
        .unwrap();
        let ws = detect_windows(&sim.recording, &DetectOptions::default()).unwrap();
        let spans: Vec<(f64, f64)> = ws.stats.iter().map(|w| (w.t_first, w.t_last)).collect();
        let s = score_holds(&sim.truth.poses, &spans);
        eprintln!(
            "{} {rate_hz} Hz {profile:?} seed {seed}: {}/{} holds, {} stray, missed {:?}",
            device.name(),
            s.found,
            s.present,
            s.stray,
            s.missed
        );
        total.0 += s.found;
        total.1 += s.present;
        total.2 += s.stray;
        total.3 += spans.len();
    }
    total
}

fn assert_every_hold(device: Device, rate_hz: f64) {
    let (found, present, stray, windows) = score(device, rate_hz, Profile::Brisk, SEEDS);
    eprintln!(
        "| {} | {rate_hz} | {found} / {present} | {:.1} % | {stray} of {windows} |",
        device.name(),
        100.0 * found as f64 / present as f64
    );
    // 6 seeds × 31 holds (the rest and 30 poses), all 2 s or longer.
    assert_eq!(present, 6 * 31);
    assert!(
        found as f64 >= 0.95 * present as f64,
        "{}: {found} of {present} holds",
        device.name()
    );
    assert_eq!(stray, 0, "{}: windows outside every hold", device.name());
}

#[test]
fn brisk_nunchuk_at_100_hz_every_hold_a_window() {
    assert_every_hold(Device::Nunchuk, 100.0);
}

#[test]
fn brisk_wiimote_at_200_hz_every_hold_a_window() {
    assert_every_hold(Device::Wiimote, 200.0);
}

#[test]
fn brisk_16_bit_mems_in_m_s2_at_400_hz_every_hold_a_window() {
    assert_every_hold(Device::Mems16, 400.0);
}

/// The calm profile (holds of 4–8 s, what the sweeps of `several_effects.rs` and `analyze.rs`
/// draw) was found whole before; it still is, one window per hold and no stray window, so the
/// fill adds nothing there (40 seeds per device).
#[test]
fn calm_recordings_keep_one_window_per_hold() {
    for device in [Device::Wiimote, Device::Nunchuk] {
        let (found, present, stray, windows) = score(device, 100.0, Profile::Calm, 1..=40);
        assert_eq!((found, stray, windows), (present, 0, present), "{device:?}");
    }
}

/// The scoring itself, on hand-made spans: a window inside a hold (within the edge
/// tolerance) and long enough finds it; a short one or one reaching into a move does not.
#[test]
fn score_holds_counts_inside_and_long_enough() {
    let pose = |a: f64, b: f64| wiical_sim::TruePose {
        t_start: a,
        t_end: b,
        direction: [0.0, 0.0, 1.0],
    };
    let poses = [pose(0.0, 5.0), pose(7.0, 9.0), pose(11.0, 12.2)];
    let s = score_holds(&poses, &[(0.2, 4.8), (7.05, 7.9), (10.9, 12.3)]);
    // The third hold is shorter than 1.5 s: not present; its window lies inside it.
    assert_eq!((s.present, s.found, s.stray), (2, 1, 0));
    assert_eq!(s.missed, vec![1]);
    let s = score_holds(&poses, &[(6.5, 8.9)]);
    assert_eq!((s.found, s.stray), (0, 1));
}

/// Coarse time, end to end: the brisk Wii Remote log at 200 Hz with its times printed to
/// 10 ms (each time twice, as many loggers write them) is read through the CSV loader, the rate
/// comes from the span (one note naming the repeats), and every hold still gets a window.
#[test]
fn coarse_timestamps_at_200_hz_are_read_and_every_hold_found() {
    let sim = wiical_sim::simulate(&SimConfig {
        device: Device::Wiimote,
        rate_hz: 200.0,
        profile: Profile::Brisk,
        seed: 7,
        poses: 30,
        temp_column: false,
        ..Default::default()
    })
    .unwrap();
    let mut text = String::from("t,x,y,z\n");
    for (i, m) in sim.recording.xyz.iter().enumerate() {
        let t = (i as f64 / 200.0 * 100.0).floor() / 100.0;
        text.push_str(&format!("{t:.2},{},{},{}\n", m[0], m[1], m[2]));
    }
    let rec = wiical_analysis::parse(&text, &Default::default()).unwrap();
    let rate = rec.estimated_rate_hz().unwrap();
    assert!((rate - 200.0).abs() < 0.5, "{rate}");
    let repeats: Vec<&String> = rec.notes.iter().filter(|n| n.contains("repeat")).collect();
    assert_eq!(repeats.len(), 1, "{:?}", rec.notes);
    assert!(
        repeats[0].contains(&format!("{} of {} rows", rec.len() / 2, rec.len())),
        "{:?}",
        rec.notes
    );
    let ws = detect_windows(&rec, &DetectOptions::default()).unwrap();
    // Times to 10 ms: compare on the true clock (sample index / rate).
    let spans: Vec<(f64, f64)> = ws
        .stats
        .iter()
        .map(|w| (w.start as f64 / 200.0, (w.end - 1) as f64 / 200.0))
        .collect();
    let s = score_holds(&sim.truth.poses, &spans);
    assert!(s.found as f64 >= 0.95 * s.present as f64, "{s:?}");
    assert_eq!(s.stray, 0, "{s:?}");
}
