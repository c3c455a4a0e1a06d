//! Fixtures shared by the capture tests (this crate's, and the `wiical capture` command-line
//! tests in host/tests, which include this file): the real calibration bytes read in place, a
//! scripted fake remote, a simulated sensor pair with known truth, a MotionPlus block.
#![allow(dead_code)] // each test file uses a different part

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;
use std::path::{Path, PathBuf};
use wiical_capture::replay::{report_0x35, ReplayWiimote};
use wiical_capture::{CaptureMode, CaptureOptions};
use wiical_extbus::NunchukReport;

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`. Fails loudly when
/// missing, so a test on real data can never pass by skipping its data. This file is compiled
/// into this crate's tests (`crates/capture`) and the host's (`host/`), whose manifests sit at
/// different depths: the workspace is the nearest ancestor holding `Cargo.lock`.
pub fn data_dir() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let workspace = manifest
        .ancestors()
        .find(|d| d.join("Cargo.lock").is_file())
        .unwrap_or(manifest);
    let dir = std::env::var_os("WIICAL_DATA")
        .map(Into::into)
        .unwrap_or_else(|| workspace.join("../shared/data"));
    assert!(
        dir.is_dir(),
        "shared data not found at {} (set WIICAL_DATA)",
        dir.display()
    );
    dir
}

// ---------------------------------------------------------------------------------------------
// Real calibration bytes (read in place) and what SOURCE.md says they decode to.

pub fn parse_hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).unwrap())
        .collect()
}

/// (Wii Remote EEPROM block, Nunchuk block) from `wii_calibration_bytes/calibration_blocks.csv`.
pub fn real_blocks() -> ([u8; 10], [u8; 16]) {
    let path = data_dir().join("wii_calibration_bytes/calibration_blocks.csv");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut wiimote = None;
    let mut nunchuk = None;
    for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        match (f[0], f[2]) {
            ("wiimote", _) => wiimote = Some(parse_hex(f[3]).try_into().unwrap()),
            ("nunchuk", "0x20") => nunchuk = Some(parse_hex(f[3]).try_into().unwrap()),
            _ => {}
        }
    }
    (wiimote.expect("wiimote row"), nunchuk.expect("nunchuk row"))
}

// SOURCE.md, section 1: zero (521, 521, 521), one-g (627, 626, 632), 106/105/111 counts per g.
pub const WIIMOTE_ZERO: [u64; 3] = [521, 521, 521];
pub const WIIMOTE_ONE_G: [u64; 3] = [627, 626, 632];
// SOURCE.md, section 2: 8-bit zero (124, 125, 123), one-g (175, 174, 173); the 10-bit decode
// with the assumed LSB order gives zero (496, 502, 493), one-g (701, 696, 695).
pub const NUNCHUK_ZERO_8: [u64; 3] = [124, 125, 123];
pub const NUNCHUK_ONE_G_8: [u64; 3] = [175, 174, 173];
pub const NUNCHUK_ZERO_10: [u64; 3] = [496, 502, 493];
pub const NUNCHUK_ONE_G_10: [u64; 3] = [701, 696, 695];

/// A fake remote with the real EEPROM block at 0x0016 and its copy at 0x0020 (WiiBrew: the
/// block is stored twice), and optionally a Nunchuk with the real register dump.
pub fn fake(with_nunchuk: bool) -> ReplayWiimote {
    let (w, n) = real_blocks();
    let f = ReplayWiimote::new()
        .with_eeprom(0x16, &w)
        .with_eeprom(0x20, &w);
    if with_nunchuk {
        f.with_nunchuk(&n)
    } else {
        f
    }
}

pub fn tmp(name: &str) -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("wiical-capture-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

pub fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

pub fn u64s(v: &Value) -> Vec<u64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

pub fn opts(out: PathBuf, mode: CaptureMode) -> CaptureOptions {
    CaptureOptions {
        out,
        mode,
        ..Default::default()
    }
}

// ---------------------------------------------------------------------------------------------
// A simulated sensor pair with known truth.

/// Raw reading model of one accelerometer: m = bias + sens ⊙ g + noise, rounded, clamped to
/// 10 bits.
#[derive(Clone, Copy)]
pub struct Sensor {
    pub bias: [f64; 3],
    pub sens: [f64; 3],
}

// Deliberately not the factory values: the fit must find these, not the EEPROM's.
pub const REMOTE: Sensor = Sensor {
    bias: [518.3, 523.7, 515.2],
    sens: [104.2, 106.8, 101.5],
};
pub const NUNCHUK: Sensor = Sensor {
    bias: [497.6, 505.1, 490.4],
    sens: [201.3, 197.2, 204.9],
};

impl Sensor {
    fn read(&self, g: [f64; 3], noise: &mut impl FnMut() -> f64) -> [u16; 3] {
        std::array::from_fn(|a| {
            (self.bias[a] + self.sens[a] * g[a] + noise())
                .round()
                .clamp(0.0, 1023.0) as u16
        })
    }
}

pub fn normalize(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

pub enum Seg {
    /// Still with gravity along `g` (unit, device frame) for `secs`.
    Still([f64; 3], f64),
    /// Turning from one orientation to another, shaking, for `secs`.
    Turn([f64; 3], [f64; 3], f64),
}

/// Appends 100 Hz `0x35` reports for the segments, starting at `t`; the Nunchuk (if any) is
/// held together with the remote (same gravity direction). Returns the end time.
pub fn script(fake: &mut ReplayWiimote, segs: &[Seg], nunchuk: bool, seed: u64, mut t: f64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, 1.2).unwrap();
    let mut noise = move || normal.sample(&mut rng);
    let mut emit = |t: f64, g: [f64; 3], noise: &mut dyn FnMut() -> f64| {
        let mut nz = || noise();
        let w = REMOTE.read(g, &mut nz);
        let n = nunchuk.then(|| NunchukReport {
            stick: [128, 128],
            accel: NUNCHUK.read(g, &mut nz),
            c: false,
            z: false,
        });
        fake.push_report(t, report_0x35(w, n.as_ref()));
    };
    for seg in segs {
        match *seg {
            Seg::Still(g, secs) => {
                let n = (secs * 100.0).round() as usize;
                for _ in 0..n {
                    emit(t, g, &mut noise);
                    t += 0.01;
                }
            }
            Seg::Turn(a, b, secs) => {
                let n = (secs * 100.0).round() as usize;
                for k in 0..n {
                    let s = k as f64 / n as f64;
                    let dir =
                        normalize(std::array::from_fn(|i| a[i] * (1.0 - s) + b[i] * s + 1e-3));
                    // Hand motion: up to 0.4 g of shaking on top of gravity.
                    let shake = 0.4 * (s * std::f64::consts::PI).sin() * (k as f64 * 0.7).sin();
                    let g = dir.map(|x| x * (1.0 + shake));
                    emit(t, g, &mut noise);
                    t += 0.01;
                }
            }
        }
    }
    t
}

/// Twelve well-spread orientations (gravity in the device frame).
pub fn twelve_poses() -> Vec<[f64; 3]> {
    let s = 1.0 / 2f64.sqrt();
    let c = 1.0 / 3f64.sqrt();
    vec![
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [s, s, 0.0],
        [0.0, s, -s],
        [-s, 0.0, s],
        [c, -c, c],
        [-c, c, c],
        [-c, -c, -c],
    ]
}

// ---------------------------------------------------------------------------------------------
// A MotionPlus calibration block laid out by hand.

/// Textbook bitwise CRC-32 (reflected 0xEDB88320, init/final XOR 0xFFFFFFFF).
pub fn crc32(chunks: &[&[u8]]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &byte in chunks.iter().flat_map(|c| c.iter()) {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A MotionPlus calibration block laid out by hand: fast half at 0x00, slow half at 0x10, each
/// zero yaw/roll/pitch, scale yaw/roll/pitch (big-endian), degrees/6, UID; CRC-32 of
/// 0x00–0x0D + 0x10–0x1D, high half at 0x0E, low half at 0x1E.
pub fn mp_block() -> [u8; 32] {
    let mut b = [0u8; 32];
    let halves = [
        (
            [0x7F10u16, 0x8020, 0x80F0],
            [0x3B00u16, 0xC500, 0x3C40],
            200u8,
            0x0Bu8,
        ),
        ([0x7F20, 0x8010, 0x80E0], [0x3C00, 0xC400, 0x3D00], 45, 0xE9),
    ];
    for (o, (zero, scale, deg6, uid)) in [0usize, 16].into_iter().zip(halves) {
        for (i, w) in zero.iter().chain(scale.iter()).enumerate() {
            b[o + 2 * i] = (w >> 8) as u8;
            b[o + 2 * i + 1] = *w as u8;
        }
        b[o + 12] = deg6;
        b[o + 13] = uid;
    }
    let crc = crc32(&[&b[0..14], &b[16..30]]);
    b[14..16].copy_from_slice(&((crc >> 16) as u16).to_be_bytes());
    b[30..32].copy_from_slice(&(crc as u16).to_be_bytes());
    b
}
