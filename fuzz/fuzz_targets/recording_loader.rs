//! Arbitrary text to the recording loader (`wiical fit FILE`): it must never panic, and
//! whatever it accepts must be a usable recording — at least one sample, every value finite,
//! the time column (if any) one value per sample and never going back (repeats: coarse timestamps), the axis columns
//! three different non-time columns. The first byte picks the `--columns` option. The same
//! text read as a window-mean table (forced or not) must give one window per row with SDs
//! finite and ≥ 0 and counts ≥ 2.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_analysis::input::columns::Sensor;
use wiical_analysis::input::window_means::{parse_window_table, WindowInputOptions};
use wiical_analysis::{parse, LoadOptions};

const CHOICES: [Option<[&str; 3]>; 4] = [
    None,
    Some(["x", "y", "z"]),
    Some(["gx", "gy", "gz"]),
    Some(["t", "x", "y"]),
];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    // The first byte picks the explicit columns (if any) and which sensor's triplet to prefer.
    const SENSORS: [Option<Sensor>; 4] = [
        None,
        Some(Sensor::Accelerometer),
        Some(Sensor::Magnetometer),
        Some(Sensor::Gyroscope),
    ];
    let pick = usize::from(pick);
    let opts = LoadOptions {
        columns: CHOICES[pick % CHOICES.len()].map(|c| c.map(String::from)),
        sensor: SENSORS[(pick / CHOICES.len()) % SENSORS.len()],
        ..Default::default()
    };
    check_window_table(text, &opts, pick % 2 == 0);
    let Ok(rec) = parse(text, &opts) else {
        return;
    };
    assert!(!rec.xyz.is_empty());
    assert!(rec.xyz.iter().flatten().all(|v| v.is_finite()));
    if let Some(t) = &rec.t {
        assert_eq!(t.len(), rec.xyz.len());
        assert!(t.iter().all(|v| v.is_finite()));
        assert!(t.windows(2).all(|w| w[0] <= w[1]), "time goes back");
    }
    if let Some(temp) = &rec.temp {
        assert_eq!(temp.len(), rec.xyz.len());
    }
    let [a, b, c] = &rec.axis_columns;
    assert!(a != b && a != c && b != c, "{:?}", rec.axis_columns);
    assert!(!rec
        .axis_columns
        .iter()
        .any(|n| ["t", "time", "timestamp"].contains(&n.to_ascii_lowercase().as_str())));
});

fn check_window_table(text: &str, opts: &LoadOptions, force: bool) {
    let wopts = WindowInputOptions {
        load: opts.clone(),
        force,
    };
    let Ok(Some(table)) = parse_window_table(text, &wopts) else {
        return;
    };
    let n = table.recording.len();
    assert_eq!(table.info.rows, n);
    if let Some(sd) = &table.sd {
        assert_eq!(sd.len(), n);
        assert!(sd.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
    if let Some(count) = &table.count {
        assert_eq!(count.len(), n);
        assert!(count.iter().all(|c| *c >= 2));
    }
    assert_eq!(
        wiical_analysis::detect::windows::Windows::of_table(&table)
            .stats
            .len(),
        n
    );
}
