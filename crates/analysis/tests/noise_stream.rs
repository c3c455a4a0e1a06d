//! `wiical noise` on a large plain text file streamed in passes (its samples never held)
//! against the same file held in memory, on simulated still noise with known truth: white
//! rate noise N and rate random walk K on a gyroscope, a still accelerometer beside it. Every
//! Allan point up to `FULL_OVERLAP_M` samples is the held one bit for bit; the points beyond
//! (cluster starts stepped) stay within a fraction of their uncertainty; N and K come back
//! from both; the refusals (a moving, constant or counter axis) are the held path's sentences.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::fmt::Write as _;
use std::path::Path;
use wiical_analysis::input::read_options::ReadOptions;
use wiical_analysis::noise::pass::FULL_OVERLAP_M;
use wiical_analysis::noise::report::{noise_of, open_sensors, NoiseReport, Sensors};

/// [`open_sensors`] streaming plain text files of at least `stream_from` bytes.
fn open_sensors_from(path: &Path, stream_from: u64) -> wiical_analysis::Result<Sensors> {
    let read = ReadOptions {
        stream_from_bytes: stream_from,
        ..Default::default()
    };
    open_sensors(path, None, &read)
}

const RATE: f64 = 100.0;
const N_GYRO: f64 = 0.01; // °/s/√Hz
const K_GYRO: f64 = 1e-3; // °/s/√s

/// `rows` rows of `t,ax,ay,az,gx,gy,gz`: the accelerometer still at 1 g on z with white noise
/// (integer-free values), the gyroscope white + random walk; `edit` changes a row's values.
fn write_still(path: &Path, rows: usize, edit: impl Fn(usize, &mut [f64; 6])) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut g = move || -> f64 { StandardNormal.sample(&mut rng) };
    let mut walk = [0.0f64; 3];
    let mut text = String::from("t,ax,ay,az,gx,gy,gz\n");
    for i in 0..rows {
        let mut v = [0.0; 6];
        for a in 0..3 {
            v[a] = 0.002 * g() + if a == 2 { 1.0 } else { 0.0 };
            walk[a] += K_GYRO / RATE.sqrt() * g();
            v[3 + a] = N_GYRO * RATE.sqrt() * g() + walk[a];
        }
        edit(i, &mut v);
        let _ = write!(text, "{:.2}", i as f64 / RATE);
        for x in v {
            let _ = write!(text, ",{x:.6}");
        }
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// The file's report by both paths: (streamed, held).
fn both(path: &Path) -> (NoiseReport, NoiseReport) {
    let streamed = open_sensors_from(path, 0).unwrap();
    let held = open_sensors_from(path, u64::MAX).unwrap();
    assert!(matches!(streamed, Sensors::Streamed(_)));
    assert!(matches!(held, Sensors::Held(_)));
    (
        noise_of(&streamed, RATE).unwrap(),
        noise_of(&held, RATE).unwrap(),
    )
}

#[test]
fn streamed_noise_is_the_held_one_and_gives_the_truth_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("still.csv");
    // 2¹⁸ samples: the curve reaches m = 2¹⁴ > FULL_OVERLAP_M, so one point is stepped.
    write_still(&path, 1 << 18, |_, _| {});
    let (s, h) = both(&path);
    assert!(h.streamed.is_none() && s.streamed.is_some());
    assert_eq!(
        (s.samples, s.sample_rate_hz, s.duration_s),
        (h.samples, h.sample_rate_hz, h.duration_s)
    );
    assert_eq!(s.axes.len(), 6);
    let mut stepped = 0;
    for (sa, ha) in s.axes.iter().zip(&h.axes) {
        assert_eq!(
            (&sa.column, sa.sensor, &sa.unit),
            (&ha.column, ha.sensor, &ha.unit)
        );
        assert_eq!(sa.curve.tau_s, ha.curve.tau_s);
        assert_eq!(sa.curve.adev_rel_err, ha.curve.adev_rel_err);
        for i in 0..ha.curve.tau_s.len() {
            let m = (ha.curve.tau_s[i] * RATE).round() as usize;
            let (a, b) = (sa.curve.adev[i], ha.curve.adev[i]);
            if m <= FULL_OVERLAP_M {
                assert_eq!(a.to_bits(), b.to_bits(), "{} τ = {}", sa.column, m);
            } else {
                stepped += 1;
                let rel = (a / b - 1.0).abs();
                assert!(
                    rel < 0.25 * ha.curve.adev_rel_err[i],
                    "{} m = {m}: {a} vs {b} ({rel:.4} against σ {:.4})",
                    sa.column,
                    ha.curve.adev_rel_err[i]
                );
            }
        }
    }
    assert!(stepped >= 6, "no stepped point tested");
    // The truth, read off the streamed curve: N at 1 s on the −½ line, K on the +½ line.
    for ax in s.axes.iter().filter(|a| a.sensor == "gyroscope") {
        let n = ax.terms.n.expect("N seen");
        assert!((n / N_GYRO - 1.0).abs() < 0.10, "{}: N {n}", ax.column);
        let k = ax.terms.k.expect("K seen");
        assert!((k / K_GYRO - 1.0).abs() < 0.35, "{}: K {k}", ax.column);
    }
}

/// A change made to a row's values.
type Edit = fn(usize, &mut [f64; 6]);

#[test]
fn streamed_refusals_are_the_held_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    let cases: [(&str, Edit); 4] = [
        // Turned by 90° half-way: the accelerometer moved.
        ("moved", |i, v| {
            if i > 20_000 {
                v.swap(1, 2)
            }
        }),
        ("constant", |_, v| v[4] = 3.0),
        // An 8-bit sample counter where a still axis should be (it was accepted as a
        // perfect sensor: B = 1e-12).
        ("counter ax", |i, v| v[0] = (i % 256) as f64),
        // A 16-bit counter on every gyro axis.
        ("counter gx", |i, v| {
            v[3] = (i % 65_536) as f64;
            v[4] = v[3];
            v[5] = v[3];
        }),
    ];
    for (name, edit) in cases {
        write_still(&path, 40_000, edit);
        let err = |from: u64| {
            let sensors = open_sensors_from(&path, from).unwrap();
            noise_of(&sensors, RATE).unwrap_err().to_string()
        };
        let (s, h) = (err(0), err(u64::MAX));
        assert_eq!(s, h, "{name}");
        if let Some(column) = name.strip_prefix("counter ") {
            assert!(
                s.contains(&format!("column {column} counts rather than measures")),
                "{name}: {s}"
            );
        }
    }
}

/// A still log written at 400 Hz from sensors that update at 100 Hz (each reading four times
/// in a row): both paths find the polling and take the curves from the distinct samples at
/// the sensors' own rate, bit for bit alike (the large-file path did not look for polling
/// before the two were made one).
#[test]
fn a_polled_log_is_found_held_and_streamed_alike() {
    let dir = tempfile::tempdir().unwrap();
    let still = dir.path().join("still.csv");
    write_still(&still, 20_000, |_, _| {});
    let text = std::fs::read_to_string(&still).unwrap();
    let mut lines = text.lines();
    let mut polled = format!("{}\n", lines.next().unwrap());
    for (i, line) in lines.enumerate() {
        let values = line.split_once(',').unwrap().1;
        for k in 0..4 {
            let _ = writeln!(polled, "{:.4},{values}", (4 * i + k) as f64 / 400.0);
        }
    }
    let path = dir.path().join("polled.csv");
    std::fs::write(&path, polled).unwrap();
    let (s, h) = both(&path);
    assert_eq!(h.polled.len(), 2, "accelerometer and gyroscope polled");
    assert_eq!(s.polled.len(), 2);
    for (sp, hp) in s.polled.iter().zip(&h.polled) {
        assert_eq!((&sp.columns, &sp.polling), (&hp.columns, &hp.polling));
        assert_eq!(hp.polling.typical_run, 4);
        assert!(
            (hp.polling.sensor_hz / RATE - 1.0).abs() < 0.01,
            "{:?}",
            hp.polling
        );
    }
    for (sa, ha) in s.axes.iter().zip(&h.axes) {
        // 20 000 distinct samples: every point within FULL_OVERLAP_M, so bit for bit.
        assert_eq!(sa.curve, ha.curve, "{}", sa.column);
        assert!((sa.curve.tau_s[0] - 1.0 / RATE).abs() < 1e-3 / RATE);
    }
}
