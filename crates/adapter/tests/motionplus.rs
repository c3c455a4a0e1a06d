//! The adapter as a MotionPlus: corrected rates re-encoded and read back through the
//! extension-bus decoders and the emulated calibration block (an independent decode path),
//! against the rates a simulated MotionPlus was given; the range rule at its boundary; the
//! zero-rate tracker under a drifting bias; the Nunchuk passed through, corrected, against the
//! documented bit layout; the whole activation dance with corrected frames; property tests.

use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_adapter::motionplus::{
    classic_passthrough_bytes, passthrough_nunchuk, EmulatedMotionPlus, GyroCorrector,
    IdealGyroScale, Tracking,
};
use wiical_adapter::{Corrector, IdealScale};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_core::Calibration;
use wiical_extbus::motionplus::{
    MotionPlusCalibration, PassthroughMode, PassthroughNunchuk, RangeCalibration,
};
use wiical_extbus::motionplus_registers::Target;
use wiical_extbus::{Frame, MotionPlusReport, NunchukReport};

const RAD: f64 = std::f64::consts::PI / 180.0;
/// The default ideal scale, written out from docs/gyro.md (hid-wiimote's 8192/440 and 8192/2000
/// counts per °/s), not taken from the code under test.
const SLOW_CPD: f64 = 8192.0 / 440.0;
const FAST_CPD: f64 = 8192.0 / 2000.0;

/// What the documentation says the range rule gives (f64): slow when the rounded slow count
/// lies in 0..=16383.
fn slow_by_the_rule(rate_dps: f64) -> bool {
    let x = rate_dps * SLOW_CPD;
    x > -8192.5 && x < 8191.5
}

/// A report through the bytes and back with the extension-bus decoder, then the rates a reader
/// of `block` computes (°/s, signed as the block states).
fn read_back(report: &MotionPlusReport, block: &[u8; 32]) -> [f64; 3] {
    let bytes = report.to_bytes().unwrap();
    let decoded = MotionPlusReport::decode(&bytes).unwrap();
    assert_eq!(&decoded, report);
    let cal = MotionPlusCalibration::decode(block).unwrap();
    assert!(cal.checksum_ok);
    cal.value.rate_dps(&decoded).unwrap().map(f64::from)
}

/// The nominal calibration in slow counts along the count axes (K = 1/c_slow, b = 8192), with
/// a bias of its own.
fn nominal(bias: [f32; 3]) -> GyroCorrection<f32> {
    let k = (RAD / SLOW_CPD) as f32;
    GyroCorrection {
        bias,
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
        effects: Default::default(),
    }
}

#[test]
fn corrected_rates_round_trip_within_half_a_count_in_both_ranges_and_at_the_boundary() {
    let mut gyro = GyroCorrector::new(IdealGyroScale::default(), None);
    gyro.set_calibration(Some(nominal([8192.0; 3]))).unwrap();
    let block = gyro.calibration_block_bytes();
    // Without a device block the sign pattern is Dolphin's: yaw and pitch negative.
    let sign = [-1.0, 1.0, -1.0];
    let edge = 8191.5 / SLOW_CPD;
    let rates = [
        0.0,
        1.0,
        -7.3,
        100.0,
        -250.0,
        439.0,
        -440.0,
        edge - 0.01,
        edge + 0.01,
        -edge - 0.06,
        -(8192.5 / SLOW_CPD) + 0.01,
        441.0,
        -600.0,
        1234.5,
        -1999.0,
    ];
    for r in rates {
        // A count of this rate: the raw reading on the nominal scale, in the slow range.
        let m = 8192.0 + r * SLOW_CPD;
        let slow_count = m.round();
        let report = if (0.0..=16383.0).contains(&slow_count) {
            MotionPlusReport {
                rate: [slow_count as u16; 3],
                slow: [true; 3],
                extension_connected: false,
            }
        } else {
            let fast = (8192.0 + r * FAST_CPD).round() as u16;
            MotionPlusReport {
                rate: [fast; 3],
                slow: [false; 3],
                extension_connected: false,
            }
        };
        let c = gyro.correct(&report, false);
        let w = c.rate.unwrap().map(|x| f64::from(x) / RAD);
        let back = read_back(&c.report, &block);
        for i in 0..3 {
            assert_eq!(
                c.report.slow[i],
                slow_by_the_rule(w[i]),
                "rate {r}, axis {i}"
            );
            let cpd = if c.report.slow[i] { SLOW_CPD } else { FAST_CPD };
            let err = (back[i] * sign[i] - w[i]).abs();
            // Half a count, plus the f32 rounding of a 14-bit count.
            assert!(
                err <= (0.5 + 2e-3) / cpd,
                "rate {r} axis {i}: {} vs {}",
                back[i],
                w[i]
            );
        }
    }
}

#[test]
fn rates_beyond_the_fast_range_saturate_at_its_rails() {
    let scale = IdealGyroScale::default();
    assert_eq!(scale.encode(2500.0), (16383, false));
    assert_eq!(scale.encode(-2500.0), (0, false));
    assert_eq!(scale.encode(f32::INFINITY), (16383, false));
    assert_eq!(scale.encode(f32::NAN), (8192, true));
    // 2000 °/s is 8192 fast counts above the zero: one past the top rail.
    assert_eq!(scale.encode(1999.8), (16383, false));
}

/// The simulated device's block: 16-bit spans at 270 °/s, slow at the nominal scale
/// (18.618 counts per °/s × 270 × 4), fast at about 1/4.40, 1/4.55, 1/4.62 of it.
const SLOW_SPAN16: u16 = 20108;
const FAST_SPAN16: [u16; 3] = [4570, 4419, 4352];

/// A MotionPlus with a scale error, misalignment and a bias of its own, whose block describes
/// its two ranges' relation (zero and ratio per axis) but not its true scale.
struct Sim {
    /// Slow counts per °/s along the count axes, truth (3×3: scale × misalignment).
    a: [[f64; 3]; 3],
    bias: [f64; 3],
    zero_fast: [f64; 3],
    ratio: [f64; 3],
}

impl Sim {
    fn new() -> Self {
        Self {
            a: [
                [SLOW_CPD * 1.03, 0.02 * SLOW_CPD, -0.01 * SLOW_CPD],
                [0.015 * SLOW_CPD, SLOW_CPD * 0.96, 0.01 * SLOW_CPD],
                [-0.02 * SLOW_CPD, 0.005 * SLOW_CPD, SLOW_CPD * 1.02],
            ],
            bias: [8105.0, 8290.0, 8051.0],
            zero_fast: [8170.0, 8214.0, 8150.0],
            // The ratios the block's integer spans state (about 4.40, 4.55, 4.62).
            ratio: FAST_SPAN16.map(|f| f64::from(SLOW_SPAN16) / f64::from(f)),
        }
    }

    /// The device's block: zeros, and spans stating the ratio (yaw and pitch negative, as a
    /// real block's); the slow span at the nominal scale (the factory's idea, not the truth).
    fn block(&self) -> [u8; 32] {
        let sgn = [-1i32, 1, -1];
        let half = |zero: [f64; 3], span: [u16; 3]| RangeCalibration {
            zero: zero.map(|z| (z * 4.0) as u16),
            scale: std::array::from_fn(|i| {
                ((zero[i] * 4.0) as i32 + sgn[i] * i32::from(span[i])) as u16
            }),
            degrees_div_6: 45, // 270 °/s
        };
        MotionPlusCalibration {
            slow: half(self.bias, [SLOW_SPAN16; 3]),
            fast: half(self.zero_fast, FAST_SPAN16),
            uid: [0x0B, 0xE9],
        }
        .to_bytes()
    }

    /// The report the device sends for a true rate (°/s), in the range its counts fit.
    fn report(&self, w: [f64; 3]) -> MotionPlusReport {
        let mut r = MotionPlusReport::default();
        for i in 0..3 {
            let m = self.bias[i] + (0..3).map(|j| self.a[i][j] * w[j]).sum::<f64>();
            if (0.0..=16383.0).contains(&m.round()) {
                (r.rate[i], r.slow[i]) = (m.round() as u16, true);
            } else {
                let f = self.zero_fast[i] + (m - self.bias[i]) / self.ratio[i];
                (r.rate[i], r.slow[i]) = (f.round().clamp(0.0, 16383.0) as u16, false);
            }
        }
        r
    }

    /// The calibration the truth implies: K = A⁻¹ in rad/s per slow count, b the bias.
    fn calibration(&self) -> GyroCorrection<f32> {
        let a = nalgebra::Matrix3::from_fn(|r, c| self.a[r][c]);
        let k = a.try_inverse().unwrap() * RAD;
        GyroCorrection {
            bias: self.bias.map(|b| b as f32),
            matrix: std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)] as f32)),
            effects: Default::default(),
        }
    }

    /// Largest error the input quantisation allows per axis (°/s): half a count in the range
    /// each axis came in, through K.
    fn input_bound(&self, r: &MotionPlusReport) -> [f64; 3] {
        let a = nalgebra::Matrix3::from_fn(|r, c| self.a[r][c]);
        let k = a.try_inverse().unwrap();
        let q: [f64; 3] = std::array::from_fn(|j| {
            if r.slow[j] {
                0.5
            } else {
                0.5 * self.ratio[j] + 0.01
            }
        });
        std::array::from_fn(|i| (0..3).map(|j| k[(i, j)].abs() * q[j]).sum())
    }
}

#[test]
fn a_miscalibrated_motionplus_reads_the_true_rate_after_correction() {
    let sim = Sim::new();
    let mut gyro = GyroCorrector::new(IdealGyroScale::default(), None);
    gyro.set_device_block(&sim.block());
    // Uncalibrated: the real report and the device's own block pass through.
    let r0 = sim.report([0.0; 3]);
    assert_eq!(gyro.correct(&r0, true).report, r0);
    assert_eq!(gyro.calibration_block_bytes(), sim.block());
    gyro.set_calibration(Some(sim.calibration())).unwrap();
    let block = gyro.calibration_block_bytes();
    assert_ne!(block, sim.block());
    let decoded = MotionPlusCalibration::decode(&block).unwrap().value;
    assert_eq!(decoded.uid, [0x0B, 0xE9], "the device's UID is kept");
    let sign = [-1.0, 1.0, -1.0];
    let (mut worst_before, mut worst_after, mut fast_axes) = (0.0f64, 0.0f64, 0);
    for w in [
        [0.0, 0.0, 0.0],
        [120.0, -45.0, 300.0],
        [-420.0, 10.0, 5.0],
        [800.0, -1500.0, 50.0],
        [-30.0, 436.0, -1200.0],
        [1800.0, 1.0, -430.0],
    ] {
        let raw = sim.report(w);
        fast_axes += raw.slow.iter().filter(|s| !**s).count();
        let out = gyro.correct(&raw, false).report;
        let back = read_back(&out, &block);
        // The raw report read with the nominal scale: what the Wii Remote would see without
        // the adapter's correction.
        let before = read_back(
            &raw,
            &IdealGyroScale::default()
                .block([true, false, true], [0; 2])
                .to_bytes(),
        );
        let bound = sim.input_bound(&raw);
        for i in 0..3 {
            let cpd = if out.slow[i] { SLOW_CPD } else { FAST_CPD };
            let err = (back[i] * sign[i] - w[i]).abs();
            assert!(
                err <= bound[i] + 0.5 / cpd + 1e-3,
                "{w:?} axis {i}: {} ({err} > {})",
                back[i] * sign[i],
                bound[i] + 0.5 / cpd
            );
            worst_after = worst_after.max(err);
            worst_before = worst_before.max((before[i] * sign[i] - w[i]).abs());
        }
    }
    eprintln!(
        "worst error: {worst_after:.4} °/s corrected, {worst_before:.2} °/s uncorrected; {fast_axes} axes fast"
    );
    assert!(
        fast_axes >= 4,
        "the fast range was exercised ({fast_axes} axes)"
    );
    // The test can fail: uncorrected, the scale, misalignment and bias errors are far larger.
    assert!(
        worst_before > 20.0 * worst_after,
        "{worst_before} vs {worst_after}"
    );
}

#[test]
fn the_tracker_keeps_a_still_motionplus_at_zero_through_a_bias_drift() {
    let mut rng = ChaCha8Rng::seed_from_u64(50);
    let noise = Normal::new(0.0, 1.5).unwrap();
    let mut on = GyroCorrector::new(IdealGyroScale::default(), Some(Tracking::default()));
    let mut off = GyroCorrector::new(IdealGyroScale::default(), None);
    for g in [&mut on, &mut off] {
        g.set_calibration(Some(nominal([8192.0; 3]))).unwrap();
    }
    // Still, the bias creeping from 8192 to 8232 (≈ 2.1 °/s) over 6 s at 200 Hz (a temperature
    // change), then 2 s at the new bias.
    let (mut sum_on, mut sum_off, mut n) = ([0.0f64; 3], [0.0f64; 3], 0.0);
    for k in 0..1600 {
        let b = 8192.0 + 40.0 * (f64::from(k) / 1200.0).min(1.0);
        let rate = std::array::from_fn(|_| (b + noise.sample(&mut rng)).round() as u16);
        let r = MotionPlusReport {
            rate,
            slow: [true; 3],
            extension_connected: false,
        };
        let a = on.correct(&r, true).report;
        let b_ = off.correct(&r, true).report;
        if k >= 1400 {
            for i in 0..3 {
                sum_on[i] += (f64::from(a.rate[i]) - 8192.0) / SLOW_CPD;
                sum_off[i] += (f64::from(b_.rate[i]) - 8192.0) / SLOW_CPD;
            }
            n += 1.0;
        }
    }
    for i in 0..3 {
        let (m_on, m_off) = (sum_on[i] / n, sum_off[i] / n);
        eprintln!("axis {i}: last second {m_on:.4} °/s with the tracker, {m_off:.4} without");
        // Noise over 200 samples: 1.5/√200 counts ≈ 0.006 °/s; the blend lags the end of the
        // ramp by at most a fraction of a count.
        assert!(m_on.abs() < 0.1, "axis {i}: {m_on} °/s with the tracker");
        assert!(
            (m_off - 40.0 / SLOW_CPD).abs() < 0.1,
            "axis {i}: {m_off} °/s without"
        );
    }
    assert!(on.bias_updates() >= 10);
}

#[test]
fn a_steady_turn_above_the_rest_limit_or_a_shaking_hand_does_not_move_the_bias() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let shake = Normal::new(0.0, 40.0).unwrap();
    let mut gyro = GyroCorrector::new(IdealGyroScale::default(), Some(Tracking::default()));
    gyro.set_calibration(Some(nominal([8192.0; 3]))).unwrap();
    // 30 °/s about yaw, noiseless (the gyro alone would call it still).
    let turn = (8192.0 + 30.0 * SLOW_CPD).round() as u16;
    for _ in 0..600 {
        let r = MotionPlusReport {
            rate: [turn, 8192, 8192],
            slow: [true; 3],
            extension_connected: false,
        };
        let out = gyro.correct(&r, true).report;
        assert_eq!(out.rate[0], turn);
    }
    // A hand near rest: rates within the limit, spread far above the tracker's.
    for _ in 0..600 {
        let rate = std::array::from_fn(|_| (8192.0f64 + shake.sample(&mut rng)).round() as u16);
        gyro.correct(
            &MotionPlusReport {
                rate,
                slow: [true; 3],
                extension_connected: false,
            },
            true,
        );
    }
    assert_eq!(gyro.bias_updates(), 0);
    assert_eq!(gyro.calibration().unwrap().bias, [8192.0; 3]);
}

#[test]
fn the_g_sensitivity_is_named_as_not_applied() {
    let mut gyro = GyroCorrector::default();
    let mut cal = nominal([8192.0; 3]);
    gyro.set_calibration(Some(cal)).unwrap();
    assert!(!gyro.ignores_g_sensitivity());
    cal.effects.g_sensitivity[0][2] = 0.001;
    gyro.set_calibration(Some(cal)).unwrap();
    assert!(gyro.ignores_g_sensitivity());
    // An implausible calibration is refused and the previous one kept.
    cal.matrix[1] = [0.0; 3];
    assert!(gyro.set_calibration(Some(cal)).is_err());
    assert_eq!(
        gyro.calibration().unwrap().matrix[1][1],
        nominal([0.0; 3]).matrix[1][1]
    );
}

/// The pass-through layout written from docs/gyro.md's table, independently of extbus.
fn documented_passthrough(stick: [u8; 2], a: [u16; 3], c: bool, z: bool, ext: bool) -> [u8; 6] {
    let bit = |v: u16, n: u16| ((v >> n) & 1) as u8;
    [
        stick[0],
        stick[1],
        (a[0] >> 2) as u8,
        (a[1] >> 2) as u8,
        (((a[2] >> 3) as u8) << 1) | u8::from(ext),
        (bit(a[2], 2) << 7)
            | (bit(a[2], 1) << 6)
            | (bit(a[1], 1) << 5)
            | (bit(a[0], 1) << 4)
            | (u8::from(!c) << 3)
            | (u8::from(!z) << 2),
    ]
}

fn nunchuk_corrector() -> Corrector {
    let mut c = Corrector::new(IdealScale::default());
    c.set_user_calibration(Some(Calibration {
        bias: [500.25, 510.6, 489.9],
        matrix: [
            [1.0 / 201.0, 0.0, 0.0],
            [0.0, 1.0 / 197.0, 0.0],
            [0.0, 0.0, 1.0 / 203.0],
        ],
        effects: Default::default(),
    }))
    .unwrap();
    c
}

/// The even count nearest `512 + 200·g` (f64, from the calibration above).
fn expected_even(raw: [u16; 3]) -> [u16; 3] {
    let b = [500.25, 510.6, 489.9];
    let k = [201.0, 197.0, 203.0];
    std::array::from_fn(|i| {
        let ideal = 512.0 + 200.0 * (f64::from(raw[i]) - b[i]) / k[i];
        ((ideal / 2.0).round() * 2.0).clamp(0.0, 1022.0) as u16
    })
}

#[test]
fn the_nunchuk_passes_through_corrected_on_even_counts() {
    let c = nunchuk_corrector();
    for (raw, stick, cb, zb) in [
        ([700u16, 320, 512], [0x80u8, 0x7F], true, false),
        ([2, 1020, 900], [0x10, 0xF0], false, true),
        ([512, 512, 712], [0x00, 0xFF], false, false),
    ] {
        let p = PassthroughNunchuk {
            report: NunchukReport {
                stick,
                accel: raw,
                c: cb,
                z: zb,
            },
            extension_connected: true,
        };
        let q = passthrough_nunchuk(&c, &p);
        let want = expected_even(raw);
        assert_eq!(q.report.accel, want, "raw {raw:?}");
        assert_eq!(
            q.to_bytes(),
            documented_passthrough(stick, want, cb, zb, true)
        );
        // Within one count of the corrected value (what the Wii Remote's ideal block reads).
        let g = c.correct(raw).g;
        for i in 0..3 {
            let exact = 512.0 + 200.0 * g[i];
            if (1.0..1021.0).contains(&exact) {
                assert!((f32::from(want[i]) - exact).abs() <= 1.0);
            }
        }
    }
    // Uncalibrated: unchanged.
    let p = PassthroughNunchuk::from_bytes(&[1, 2, 3, 4, 5, 0xF0]);
    assert_eq!(passthrough_nunchuk(&Corrector::default(), &p), p);
}

fn read_at(mp: &mut EmulatedMotionPlus, address: u8, reg: u8, n: usize) -> (Target, Vec<u8>) {
    mp.on_write(address, &[reg]);
    let mut buf = vec![0xEE; n];
    let t = mp.on_read(address, &mut buf);
    (t, buf)
}

/// The block at 0x53/0x20 in two 16-byte reads: CRC intact, the ideal scale's reference rates
/// and spans, the simulated device's sign pattern.
fn read_ideal_block(mp: &mut EmulatedMotionPlus) -> [u8; 32] {
    let (_, a) = read_at(mp, 0x53, 0x20, 16);
    let (_, b) = read_at(mp, 0x53, 0x30, 16);
    let block: [u8; 32] = a
        .into_iter()
        .chain(b)
        .collect::<Vec<_>>()
        .try_into()
        .unwrap();
    let cal = MotionPlusCalibration::decode(&block).unwrap();
    assert!(cal.checksum_ok);
    assert_eq!(
        (cal.value.slow.degrees_div_6, cal.value.fast.degrees_div_6),
        (55, 125)
    );
    assert_eq!(
        cal.value.slow.scale,
        [32768 - 24576, 32768 + 24576, 32768 - 24576]
    );
    block
}

#[test]
fn the_dance_then_corrected_gyro_and_nunchuk_frames_alternate() {
    let sim = Sim::new();
    let mut gyro = GyroCorrector::new(IdealGyroScale::default(), None);
    gyro.set_device_block(&sim.block());
    let mut mp = EmulatedMotionPlus::new(gyro);
    mp.set_calibration(Some(sim.calibration())).unwrap();
    let nunchuk = nunchuk_corrector();
    // Detection and the block at 0x53.
    assert_eq!(read_at(&mut mp, 0x53, 0xFE, 2).1, [0x00, 0x05]);
    let block = read_ideal_block(&mut mp);
    // Activation in Nunchuk pass-through.
    assert_eq!(mp.on_write(0x53, &[0xF0, 0x55]), Target::MotionPlus);
    assert_eq!(mp.on_write(0x53, &[0xFE, 0x05]), Target::MotionPlus);
    assert_eq!(
        read_at(&mut mp, 0x52, 0xFA, 6).1,
        PassthroughMode::Nunchuk.active_id()
    );
    // The real MotionPlus's interleaved stream, as the adapter polls it.
    let w = [200.0, -1000.0, 20.0];
    let mut real = sim.report(w);
    real.extension_connected = true;
    let raw_n = [700u16, 320, 512];
    let pn = PassthroughNunchuk {
        report: NunchukReport {
            stick: [0x80, 0x7F],
            accel: raw_n,
            c: true,
            z: false,
        },
        extension_connected: true,
    };
    for f in [real.to_bytes().unwrap(), pn.to_bytes()] {
        let frame = Frame::decode(&f, PassthroughMode::Nunchuk).unwrap();
        mp.on_frame(&frame, &nunchuk, false);
    }
    let sign = [-1.0, 1.0, -1.0];
    for _ in 0..2 {
        let g = read_at(&mut mp, 0x52, 0x00, 6).1;
        let Frame::MotionPlus(r) = Frame::decode(&g, PassthroughMode::Nunchuk).unwrap() else {
            panic!("gyro frame expected: {g:02x?}");
        };
        assert!(r.extension_connected);
        let back = read_back(&r, &block);
        let bound = sim.input_bound(&real);
        for i in 0..3 {
            let cpd = if r.slow[i] { SLOW_CPD } else { FAST_CPD };
            assert!((back[i] * sign[i] - w[i]).abs() <= bound[i] + 0.5 / cpd + 1e-3);
        }
        assert!(!r.slow[1], "-1000 °/s goes in the fast range");
        let n = read_at(&mut mp, 0x52, 0x00, 6).1;
        assert_eq!(
            n,
            documented_passthrough([0x80, 0x7F], expected_even(raw_n), true, false, true)
        );
    }
    // The Nunchuk unplugged from the real MotionPlus: gyro frames only.
    real.extension_connected = false;
    mp.on_frame(&Frame::MotionPlus(real), &nunchuk, false);
    for _ in 0..3 {
        let g = read_at(&mut mp, 0x52, 0x00, 6).1;
        assert_eq!((g[4] & 1, g[5] & 0b11), (0, 0b10));
    }
    // Deactivation, forwarded to the extension as its init.
    assert_eq!(
        mp.on_write(0x52, &[0xF0, 0x55]),
        Target::MotionPlusThenExtension
    );
    assert_eq!(
        read_at(&mut mp, 0x53, 0xFA, 6).1,
        [0x00, 0x00, 0xA6, 0x20, 0x05, 0x05]
    );
}

#[test]
fn a_classic_frame_goes_back_to_the_layout_it_came_in() {
    // As a MotionPlus sends it: byte 5 bits 0–1 in bit 0 of bytes 0–1, bit 1 of byte 5 clear.
    let wire = [0x39, 0x8E, 0x55, 0xAA, 0x0F | 1, 0xF0];
    let Frame::Classic(c) = Frame::decode(&wire, PassthroughMode::Classic).unwrap() else {
        panic!()
    };
    let back = classic_passthrough_bytes(&c);
    assert_eq!(back[..4], wire[..4]);
    assert_eq!(back[5], wire[5]);
}

proptest! {
    /// Any polled bytes in any mode, any stillness: no panic, and a served frame decodes.
    #[test]
    fn any_polled_bytes_are_handled(
        frames in prop::collection::vec((any::<[u8; 6]>(), 0usize..3, any::<bool>()), 0..40),
        calibrated in any::<bool>(),
    ) {
        let mut mp = EmulatedMotionPlus::new(GyroCorrector::default());
        if calibrated {
            mp.set_calibration(Some(nominal([8100.0, 8200.0, 8300.0]))).unwrap();
        }
        mp.on_write(0x53, &[0xFE, 0x05]);
        let nunchuk = nunchuk_corrector();
        let modes = [PassthroughMode::None, PassthroughMode::Nunchuk, PassthroughMode::Classic];
        for (bytes, m, still) in frames {
            if let Ok(f) = Frame::decode(&bytes, modes[m]) {
                mp.on_frame(&f, &nunchuk, still);
            }
            let (t, buf) = read_at(&mut mp, 0x52, 0x00, 6);
            prop_assert_eq!(t, Target::MotionPlus);
            prop_assert!(Frame::decode(&buf, PassthroughMode::Nunchuk).is_ok());
        }
    }

    /// The range rule for any rate: the slow bit as the documentation's inequality says, and
    /// the count within half a count of the rate in its range unless the fast range saturates.
    #[test]
    fn the_range_rule_holds_for_any_rate(r in -3000.0f32..3000.0) {
        let scale = IdealGyroScale::default();
        let (count, slow) = scale.encode(r);
        let r = f64::from(r);
        // Away from the rounding edge by more than the f32 rounding of the product.
        let x = r * SLOW_CPD;
        if (x + 8192.5).abs() > 1e-2 && (x - 8191.5).abs() > 1e-2 {
            prop_assert_eq!(slow, slow_by_the_rule(r));
        }
        let cpd = if slow { SLOW_CPD } else { FAST_CPD };
        let ideal = 8192.0 + r * cpd;
        if (0.0..=16383.0).contains(&ideal) {
            prop_assert!((f64::from(count) - ideal).abs() <= 0.5 + 1e-3);
        } else {
            prop_assert_eq!(count, if ideal < 0.0 { 0 } else { 16383 });
        }
    }
}
