//! The whole adapter on the desktop: simulated Nunchuk → poller → protocol/corrector →
//! emulated register map read by a simulated Wii Remote, with the host's requests, power
//! cuts during commits, and arbitrary requests / bytes.

mod common;

use common::{block_on, factory_block, CutFlash, MockBus, NoDelay, Plug};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wiical_adapter::corrector::nominal_calibration;
use wiical_adapter::protocol::bits_equal;
use wiical_adapter::{
    BootLoad, CalibrationStore, CorrectionMode, DeviceInfo, IdealScale, NunchukPoller, Protocol,
};
use wiical_core::acceptance::Acceptance;
use wiical_core::Calibration;
use wiical_extbus::{CalibrationBlock, Encryption, NunchukRegisters, NunchukReport};
use wiical_wire::{
    encode_frame, BootRecord, CalibrationState, DefaultFrameDecoder, ErrorCode, Hello, Request,
    Response, Sample, SelfCalPhase, WireCalibration, MAX_FRAME_LEN, PROTOCOL_VERSION, SCHEMA_KEY,
};

type Flash = CutFlash<4, 512, 4>;

const BASE_MHZ: u32 = 200_000;

fn info() -> DeviceInfo {
    DeviceInfo::new("test-0.1.0", [1, 2, 3, 4, 5, 6, 7, 8], BASE_MHZ)
}

/// The simulated sensor's true forward model `m = D·a + b` (counts), with cross-axis terms.
fn truth() -> (Matrix3<f64>, Vector3<f64>) {
    (
        Matrix3::new(203.0, 2.5, -1.0, -3.0, 196.0, 1.5, 0.8, -2.2, 207.0),
        Vector3::new(505.3, 497.8, 518.6),
    )
}

/// The calibration that inverts the truth exactly (as a perfect fit would give).
fn true_calibration() -> Calibration {
    let (d, b) = truth();
    let k = d.try_inverse().unwrap();
    Calibration {
        bias: [b.x as f32, b.y as f32, b.z as f32],
        matrix: [
            [k[(0, 0)] as f32, k[(0, 1)] as f32, k[(0, 2)] as f32],
            [k[(1, 0)] as f32, k[(1, 1)] as f32, k[(1, 2)] as f32],
            [k[(2, 0)] as f32, k[(2, 1)] as f32, k[(2, 2)] as f32],
        ],
        effects: Default::default(),
    }
}

fn raw_for(a: Vector3<f64>) -> [u16; 3] {
    let (d, b) = truth();
    let m = d * a + b;
    [m.x, m.y, m.z].map(|v| v.round().clamp(0.0, 1023.0) as u16)
}

struct Rig<'f> {
    bus: MockBus,
    poller: NunchukPoller,
    proto: Protocol<&'f mut Flash>,
    t: u64,
}

impl<'f> Rig<'f> {
    fn boot(flash: &'f mut Flash) -> Self {
        let store = CalibrationStore::new(flash, 0..Flash::SIZE).unwrap();
        let proto = block_on(Protocol::boot(store, info(), IdealScale::default()));
        let mut n = NunchukRegisters::new();
        n.set_calibration(&factory_block()).unwrap();
        n.set_report(&report([512, 512, 712]));
        Self {
            bus: MockBus::new(n),
            poller: NunchukPoller::default(),
            proto,
            t: 0,
        }
    }

    fn step(&mut self) -> Option<Sample> {
        self.t += 5;
        let r = block_on(
            self.poller
                .poll(&mut self.bus, &mut NoDelay::default(), self.t),
        );
        self.proto.on_poll(&r, self.poller.is_connected())
    }

    /// Poll until connected and one report went through.
    fn settle(&mut self) {
        for _ in 0..200 {
            self.step();
            if self.proto.status().connected && self.poller.is_connected() {
                self.step();
                return;
            }
        }
        panic!("never connected");
    }

    fn req(&mut self, r: Request) -> Response {
        block_on(self.proto.handle(r))
    }

    fn hello(&mut self) {
        let Response::Hello(h) = self.req(Request::Hello(Hello::CURRENT)) else {
            panic!("no hello")
        };
        assert_eq!(h.schema_key, SCHEMA_KEY);
    }

    fn get(&mut self) -> CalibrationState {
        match self.req(Request::GetCalibration) {
            Response::Calibration(s) => s,
            other => panic!("expected calibration, got {other:?}"),
        }
    }

    fn commit(&mut self, cal: &Calibration) {
        assert_eq!(
            self.req(Request::PutCalibration((*cal).into())),
            Response::Ack
        );
        assert_eq!(self.req(Request::CommitCalibration), Response::Ack);
    }
}

fn report(accel: [u16; 3]) -> NunchukReport {
    NunchukReport {
        stick: [0x81, 0x7F],
        accel,
        c: true,
        z: false,
    }
}

/// What a Wii Remote reads from the emulated Nunchuk after its init (plain or legacy):
/// the calibration block (both copies, with fallback) and the current report.
fn wiimote_reads(
    proto: &mut Protocol<&mut Flash>,
    enc: Encryption,
) -> (CalibrationBlock, NunchukReport) {
    let em = proto.emulated();
    for w in enc.init_sequence() {
        em.on_write(&w.to_bytes());
    }
    em.on_write(&[0xFA]);
    let mut id = [0u8; 6];
    em.on_read(&mut id);
    enc.decode_in_place(&mut id);
    assert_eq!(id, wiical_extbus::nunchuk::ID);
    em.on_write(&[0x20]);
    let mut block = [0u8; 32];
    em.on_read(&mut block);
    enc.decode_in_place(&mut block);
    let cal = CalibrationBlock::from_registers(&block).expect("emulated block checksum");
    em.on_write(&[0x00]);
    let mut rep = [0u8; 6];
    em.on_read(&mut rep);
    (cal.value, NunchukReport::decode_with(&rep, enc).unwrap())
}

#[test]
fn hello_gates_every_other_request() {
    let mut flash = Flash::new(1);
    let mut rig = Rig::boot(&mut flash);
    let gated = [
        Request::GetCalibration,
        Request::PutCalibration(true_calibration().into()),
        Request::CommitCalibration,
        Request::StartStream { rate_divider: 1 },
        Request::StopStream,
    ];
    for r in &gated {
        assert_eq!(
            rig.req(r.clone()),
            Response::Error(ErrorCode::SchemaMismatch)
        );
    }
    // A Hello with another key is answered (so the host can say why) but opens nothing.
    let other = Hello {
        protocol_version: 99,
        schema_key: SCHEMA_KEY ^ 1,
    };
    let Response::Hello(h) = rig.req(Request::Hello(other)) else {
        panic!()
    };
    assert_eq!(h.protocol_version, PROTOCOL_VERSION);
    assert_eq!(h.schema_key, SCHEMA_KEY);
    assert_eq!(h.firmware_version.as_str(), "test-0.1.0");
    assert_eq!(h.device_id, [1, 2, 3, 4, 5, 6, 7, 8]);
    for r in &gated {
        assert_eq!(
            rig.req(r.clone()),
            Response::Error(ErrorCode::SchemaMismatch)
        );
    }
    rig.hello();
    assert!(matches!(
        rig.req(Request::GetCalibration),
        Response::Calibration(_)
    ));
    // A later bad Hello closes the session again; reset_session too.
    rig.req(Request::Hello(other));
    assert_eq!(
        rig.req(Request::GetCalibration),
        Response::Error(ErrorCode::SchemaMismatch)
    );
    rig.hello();
    rig.proto.reset_session();
    assert_eq!(
        rig.req(Request::GetCalibration),
        Response::Error(ErrorCode::SchemaMismatch)
    );
}

#[test]
fn a_simulator_key_override_is_what_hello_compares() {
    let mut flash = Flash::new(1);
    let store = CalibrationStore::new(&mut flash, 0..Flash::SIZE).unwrap();
    let mut p = block_on(Protocol::boot(store, info(), IdealScale::default())).with_schema_key(7);
    let Response::Hello(h) = block_on(p.handle(Request::Hello(Hello::CURRENT))) else {
        panic!()
    };
    assert_eq!(h.schema_key, 7);
    assert_eq!(h.check(), Err(ErrorCode::SchemaMismatch));
    assert_eq!(
        block_on(p.handle(Request::GetCalibration)),
        Response::Error(ErrorCode::SchemaMismatch)
    );
}

#[test]
fn put_stages_commit_makes_live_and_persistent() {
    let mut flash = Flash::new(2);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    assert_eq!(rig.proto.status().boot, BootLoad::Empty);

    // Uncalibrated: the live calibration is the Nunchuk's factory block.
    let s = rig.get();
    assert!(!s.stored);
    assert_eq!(s.staged, None);
    let f = factory_block();
    let live = Calibration::from(s.live);
    for i in 0..3 {
        assert_eq!(live.bias[i], f32::from(f.zero[i]));
        assert_eq!(live.matrix[i][i], 1.0 / (f.one_g[i] - f.zero[i]) as f32);
    }

    let cal = true_calibration();
    assert_eq!(rig.req(Request::PutCalibration(cal.into())), Response::Ack);
    let s = rig.get();
    assert_eq!(s.staged, Some(WireCalibration::from(cal)));
    assert!(!s.stored, "staged is not live");
    assert_eq!(rig.proto.corrector().mode(), CorrectionMode::PassThrough);

    // Invalid calibrations are refused and leave the staged one alone.
    let mut singular = cal;
    singular.matrix[1] = singular.matrix[0];
    let mut nan = cal;
    nan.bias[2] = f32::NAN;
    for bad in [singular, nan] {
        assert_eq!(
            rig.req(Request::PutCalibration(bad.into())),
            Response::Error(ErrorCode::InvalidCalibration)
        );
    }
    assert_eq!(rig.get().staged, Some(WireCalibration::from(cal)));

    assert_eq!(rig.req(Request::CommitCalibration), Response::Ack);
    let s = rig.get();
    assert!(s.stored);
    assert_eq!(s.staged, None);
    assert!(bits_equal(&Calibration::from(s.live), &cal));
    assert_eq!(rig.proto.corrector().mode(), CorrectionMode::Calibrated);
    assert_eq!(
        rig.req(Request::CommitCalibration),
        Response::Error(ErrorCode::NothingStaged)
    );

    // Reboot: the committed calibration is back.
    let mut rig = Rig::boot(&mut flash);
    assert_eq!(rig.proto.status().boot, BootLoad::Loaded);
    rig.hello();
    assert!(bits_equal(&Calibration::from(rig.get().live), &cal));
}

#[test]
fn stream_divider_seq_and_corrected_values() {
    let mut flash = Flash::new(3);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    let cal = true_calibration();
    rig.commit(&cal);
    assert!(rig.step().is_none(), "no stream yet");
    assert_eq!(
        rig.req(Request::StartStream { rate_divider: 0 }),
        Response::Error(ErrorCode::InvalidParameter)
    );
    assert_eq!(
        rig.req(Request::StartStream { rate_divider: 3 }),
        Response::StreamStarted {
            sample_rate_mhz: BASE_MHZ / 3
        }
    );
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut samples = Vec::new();
    for i in 0..30 {
        let r = NunchukReport {
            stick: [rng.random(), rng.random()],
            accel: [
                rng.random_range(1..1023),
                rng.random_range(1..1023),
                rng.random_range(1..1023),
            ],
            c: rng.random(),
            z: rng.random(),
        };
        rig.bus.nunchuk.set_report(&r);
        if let Some(s) = rig.step() {
            samples.push((i, r, s));
        }
    }
    assert_eq!(samples.len(), 10);
    for (n, (i, r, s)) in samples.iter().enumerate() {
        assert_eq!(*i % 3, 0, "every third report");
        assert_eq!(s.seq, n as u32);
        assert_eq!(s.raw, r.accel);
        assert_eq!(s.corrected, cal.correct_linear(r.accel.map(f32::from)));
        assert_eq!(s.stick, r.stick);
        assert_eq!(s.buttons & Sample::BUTTON_C != 0, r.c);
        assert_eq!(s.buttons & Sample::BUTTON_Z != 0, r.z);
    }
    // Restart: seq from 0 again; Stop ends it. A second client's Hello does not (the
    // stream is the port's, see the protocol docs); closing the port does.
    rig.req(Request::StartStream { rate_divider: 1 });
    assert_eq!(rig.step().map(|s| s.seq), Some(0));
    assert_eq!(rig.step().map(|s| s.seq), Some(1));
    assert_eq!(rig.req(Request::StopStream), Response::Ack);
    assert!(rig.step().is_none());
    rig.req(Request::StartStream { rate_divider: 1 });
    assert_eq!(rig.step().map(|s| s.seq), Some(0));
    rig.hello();
    assert_eq!(rig.step().map(|s| s.seq), Some(1));
    rig.proto.reset_session();
    assert!(rig.step().is_none());
    rig.hello();
    // No samples while the Nunchuk is unplugged; they resume after the replug.
    rig.req(Request::StartStream { rate_divider: 1 });
    rig.bus.plug = Plug::Unplugged;
    for _ in 0..50 {
        assert!(rig.step().is_none());
    }
    assert!(!rig.proto.status().connected);
    rig.bus.replug();
    let mut resumed = None;
    for _ in 0..100 {
        if let Some(s) = rig.step() {
            resumed = Some(s);
            break;
        }
    }
    assert!(rig.proto.status().connected);
    assert_eq!(resumed.map(|s| s.seq), Some(0));
}

#[test]
fn wiimote_sees_corrected_acceleration_on_the_ideal_scale() {
    let mut flash = Flash::new(4);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    let cal = true_calibration();
    let gen_before = rig.proto.block_generation();
    rig.commit(&cal);
    assert!(
        rig.proto.block_generation() != gen_before,
        "block change not signalled"
    );

    let (d, b) = truth();
    let k = d.try_inverse().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for trial in 0..200 {
        // Random direction, magnitude 0.2–2 g (dynamic motion, not only gravity).
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0f64),
        );
        if v.norm() < 1e-3 {
            continue;
        }
        let a = v.normalize() * rng.random_range(0.2..2.0);
        let raw = raw_for(a);
        rig.bus.nunchuk.set_report(&report(raw));
        rig.step();
        for enc in [Encryption::None, Encryption::Legacy] {
            let (block, rep) = wiimote_reads(&mut rig.proto, enc);
            assert_eq!(block.zero, [512; 3]);
            assert_eq!(block.one_g, [712; 3]);
            assert_eq!(
                block.stick_x,
                factory_block().stick_x,
                "stick calibration kept"
            );
            assert_eq!(
                (rep.stick, rep.c, rep.z),
                ((report(raw)).stick, true, false)
            );
            let seen = block.accel_to_g(rep.accel).unwrap();
            // f64 reference of the correction of the raw counts the adapter got.
            let m = Vector3::new(raw[0] as f64, raw[1] as f64, raw[2] as f64);
            let reference = k * (m - b);
            for i in 0..3 {
                let expect = reference[i].clamp(-512.0 / 200.0, 511.0 / 200.0);
                assert!(
                    (seen[i] as f64 - expect).abs() <= 0.5 / 200.0 + 1e-4,
                    "trial {trial} axis {i}: Wiimote sees {} g, reference {expect} g",
                    seen[i]
                );
                // And against the truth, within raw + re-encoding quantisation.
                if a[i].abs() < 2.4 {
                    assert!(
                        (seen[i] as f64 - a[i]).abs() < 0.006,
                        "trial {trial} axis {i}"
                    );
                }
            }
        }
    }
}

#[test]
fn pass_through_presents_raw_counts_and_the_factory_block() {
    let mut flash = Flash::new(5);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    assert_eq!(rig.proto.corrector().mode(), CorrectionMode::PassThrough);
    for raw in [[0u16, 1023, 512], [496, 502, 493], [701, 7, 1000]] {
        rig.bus.nunchuk.set_report(&report(raw));
        rig.step();
        let (block, rep) = wiimote_reads(&mut rig.proto, Encryption::None);
        assert_eq!(block, factory_block());
        assert_eq!(rep.accel, raw);
    }
}

#[test]
fn unusable_factory_block_falls_back_to_nominal() {
    let mut flash = Flash::new(6);
    let mut rig = Rig::boot(&mut flash);
    let mut bad = factory_block().encode().unwrap();
    bad[14] ^= 0xFF;
    rig.bus.nunchuk.set_calibration_bytes(&bad);
    rig.settle();
    rig.hello();
    let live = Calibration::from(rig.get().live);
    assert!(bits_equal(&live, &nominal_calibration()));
    // The Nunchuk's own (bad) bytes are still what the Wii Remote gets, as it would without
    // the adapter.
    let em = rig.proto.emulated();
    assert_eq!(em.registers().register(0x2E), bad[14]);
}

#[test]
fn power_cut_during_commit_keeps_old_or_new_never_corrupt() {
    let old = true_calibration();
    let mut new = old;
    new.bias = [490.0, 530.5, 501.25];
    new.matrix[0][1] = 3e-4;
    // Measure how many flash operations a commit of `new` takes after `old`.
    let mut flash = Flash::new(7);
    {
        let mut rig = Rig::boot(&mut flash);
        rig.hello();
        rig.commit(&old);
    }
    let base = flash.ops;
    {
        let mut rig = Rig::boot(&mut flash);
        rig.hello();
        rig.commit(&new);
    }
    let per_commit = flash.ops - base;
    assert!(per_commit > 30);

    for cut in 0..per_commit + 2 {
        let mut flash = Flash::new(100 + cut);
        {
            let mut rig = Rig::boot(&mut flash);
            rig.hello();
            rig.commit(&old);
        }
        flash.cut_after = Some(cut);
        let committed = {
            let mut rig = Rig::boot(&mut flash);
            rig.hello();
            assert_eq!(rig.req(Request::PutCalibration(new.into())), Response::Ack);
            let resp = rig.req(Request::CommitCalibration);
            let live = Calibration::from(rig.get().live);
            match resp {
                Response::Ack => {
                    assert!(bits_equal(&live, &new));
                    true
                }
                Response::Error(ErrorCode::StorageFailure) => {
                    // The live calibration did not change.
                    assert!(bits_equal(&live, &old), "cut {cut}");
                    false
                }
                other => panic!("cut {cut}: {other:?}"),
            }
        };
        flash.reboot();
        let mut rig = Rig::boot(&mut flash);
        rig.hello();
        let live = Calibration::from(rig.get().live);
        assert_eq!(rig.proto.status().boot, BootLoad::Loaded, "cut {cut}");
        if committed {
            assert!(bits_equal(&live, &new), "cut {cut}: acked commit lost");
        } else {
            assert!(
                bits_equal(&live, &old) || bits_equal(&live, &new),
                "cut {cut}: neither old nor new"
            );
        }
    }
}

#[test]
fn damaged_storage_boots_in_pass_through() {
    let mut flash = Flash::new(8);
    {
        let mut rig = Rig::boot(&mut flash);
        rig.hello();
        rig.commit(&true_calibration());
    }
    // Smash the record's payload (behind sequential-storage's back).
    let pos = flash.data.windows(4).position(|w| w == b"WCAL").unwrap();
    flash.data[pos + 20] ^= 0x40;
    let mut rig = Rig::boot(&mut flash);
    assert_ne!(rig.proto.status().boot, BootLoad::Loaded);
    assert_eq!(rig.proto.corrector().mode(), CorrectionMode::PassThrough);
    rig.settle();
    rig.hello();
    let state = rig.get();
    assert!(!state.stored);
    // The damage is told to the host, not passed off as "none committed".
    assert!(
        state.damaged_records >= 1 || matches!(state.boot, BootRecord::Rejected(_)),
        "{:?} / {}",
        state.boot,
        state.damaged_records
    );
}

/// The newest record damaged behind the storage layer's back, an older intact one before it:
/// the adapter boots with the older one (the storage layer skips the damaged item) and says
/// that it found a damaged record, so the host does not show the old calibration as simply
/// "committed, stored".
#[test]
fn a_damaged_newest_record_is_reported_with_the_previous_one_live() {
    let mut flash = Flash::new(8);
    let old = true_calibration();
    let mut new = old;
    new.bias[0] += 3.0;
    {
        let mut rig = Rig::boot(&mut flash);
        rig.hello();
        rig.commit(&old);
        rig.commit(&new);
        assert_eq!(rig.get().damaged_records, 0);
    }
    let last = flash
        .data
        .windows(4)
        .rposition(|w| w == b"WCAL")
        .expect("a record");
    flash.data[last + 20] ^= 0x40;
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    let state = rig.get();
    assert!(state.stored, "{state:?}");
    assert!(bits_equal(&Calibration::from(state.live), &old));
    assert_eq!(state.boot, BootRecord::Loaded);
    assert_eq!(state.damaged_records, 1);
    // An intact store reports none.
    let mut clean = Flash::new(8);
    let mut rig = Rig::boot(&mut clean);
    rig.hello();
    rig.commit(&old);
    rig.commit(&new);
    drop(rig);
    let mut rig = Rig::boot(&mut clean);
    rig.hello();
    assert_eq!(rig.get().damaged_records, 0);
}

/// The session belongs to the host that said Hello: once it ends its session (before closing
/// the port, which another process may hold open), a bare Commit or Put without a Hello of
/// its own is refused and the upload is gone; a new Hello discards a previous host's upload.
#[test]
fn a_bare_commit_after_the_uploading_host_left_is_refused() {
    let mut flash = Flash::new(23);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    let cal = true_calibration();
    // `device put` without --commit: Hello, Put, EndSession (the port stays open).
    rig.hello();
    assert_eq!(rig.req(Request::PutCalibration(cal.into())), Response::Ack);
    assert_eq!(rig.req(Request::EndSession), Response::Ack);
    assert!(!rig.proto.status().session_open && rig.proto.staged().is_none());
    // The other process: one bare CommitCalibration frame, no Hello.
    assert_eq!(
        rig.req(Request::CommitCalibration),
        Response::Error(ErrorCode::SchemaMismatch)
    );
    // A bare Put + Commit after `device get` ended its session: refused too.
    rig.hello();
    let _ = rig.get();
    assert_eq!(rig.req(Request::EndSession), Response::Ack);
    for req in [
        Request::PutCalibration(cal.into()),
        Request::CommitCalibration,
        Request::GetCalibration,
        Request::EndSession,
    ] {
        assert_eq!(rig.req(req), Response::Error(ErrorCode::SchemaMismatch));
    }
    rig.hello();
    let state = rig.get();
    assert!(!state.stored && state.staged.is_none(), "{state:?}");
    assert_eq!(rig.proto.corrector().mode(), CorrectionMode::PassThrough);
    // A stream started in a session keeps running when that session ends (the port's).
    assert!(matches!(
        rig.req(Request::StartStream { rate_divider: 1 }),
        Response::StreamStarted { .. }
    ));
    assert_eq!(rig.req(Request::EndSession), Response::Ack);
    assert!(rig.step().is_some());
}

fn arb_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -2.0f32..2.0,
        2 => 400.0f32..600.0,
        1 => any::<f32>(),
        1 => Just(f32::NAN),
        1 => Just(0.0f32),
    ]
}

fn arb_cal() -> impl Strategy<Value = WireCalibration> {
    (
        proptest::array::uniform3(arb_f32()),
        proptest::array::uniform3(proptest::array::uniform3(arb_f32())),
        proptest::array::uniform3(arb_f32()),
    )
        .prop_map(|(bias, matrix, quad)| {
            let mut c = Calibration {
                bias,
                matrix,
                effects: Default::default(),
            };
            c.effects.quadratic = quad;
            c.into()
        })
}

/// Calibrations near a real Nunchuk's, most of them plausible, some just beyond a limit.
fn near_nunchuk_cal() -> impl Strategy<Value = WireCalibration> {
    (
        proptest::array::uniform3(380.0f32..640.0),
        proptest::array::uniform3(150.0f32..250.0),
        proptest::array::uniform3(-0.001f32..0.001),
        proptest::array::uniform3(-0.2f32..0.2),
    )
        .prop_map(|(bias, counts_per_g, cross, quad)| {
            let k = counts_per_g.map(|c| 1.0 / c);
            let mut c = Calibration {
                bias,
                matrix: [
                    [k[0], cross[0], cross[1]],
                    [0.0, k[1], cross[2]],
                    [0.0, 0.0, k[2]],
                ],
                effects: Default::default(),
            };
            c.effects.quadratic = quad;
            c.into()
        })
}

fn arb_request() -> impl Strategy<Value = Request> {
    prop_oneof![
        2 => Just(Request::Hello(Hello::CURRENT)),
        1 => (any::<u16>(), any::<u32>()).prop_map(|(v, k)| Request::Hello(Hello {
            protocol_version: v,
            schema_key: k
        })),
        2 => Just(Request::GetCalibration),
        2 => arb_cal().prop_map(Request::PutCalibration),
        2 => near_nunchuk_cal().prop_map(Request::PutCalibration),
        2 => Just(Request::CommitCalibration),
        1 => Just(Request::GetStatus),
        2 => any::<u16>().prop_map(|d| Request::StartStream { rate_divider: d % 5 }),
        1 => Just(Request::StopStream),
        1 => Just(Request::EndSession),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Any request sequence, interleaved with reports: no panic, each answer is one the
    /// request allows, the live calibration always validates, samples count up by one and
    /// carry exactly the linear correction of their raw counts.
    #[test]
    fn arbitrary_requests_keep_the_invariants(
        reqs in proptest::collection::vec((arb_request(), 0usize..4), 1..40),
        accel in proptest::collection::vec(proptest::array::uniform3(0u16..1024), 1..20),
    ) {
        let mut flash = Flash::new(11);
        let mut rig = Rig::boot(&mut flash);
        rig.settle();
        let mut last_seq: Option<u32> = None;
        let mut open = false;
        let mut ai = 0;
        for (req, polls) in reqs {
            let is_hello = matches!(req, Request::Hello(_));
            let good_hello = matches!(req, Request::Hello(h) if h.schema_key == SCHEMA_KEY);
            let is_start = matches!(req, Request::StartStream { rate_divider: 1.. });
            let resp = rig.req(req.clone());
            match (&req, &resp) {
                (Request::Hello(_), Response::Hello(_)) => open = good_hello,
                (_, Response::Error(ErrorCode::SchemaMismatch)) => prop_assert!(!open),
                (Request::GetCalibration, Response::Calibration(s)) => {
                    prop_assert!(Calibration::from(s.live).validate().is_ok());
                }
                (Request::PutCalibration(w), Response::Ack) => {
                    prop_assert!(Acceptance::nunchuk().check(&Calibration::from(*w), None).is_ok());
                }
                (Request::PutCalibration(w), Response::Error(ErrorCode::InvalidCalibration)) => {
                    prop_assert!(Calibration::from(*w).validate().is_err());
                }
                (Request::PutCalibration(w), Response::Error(ErrorCode::ImplausibleCalibration)) => {
                    let cal = Calibration::from(*w);
                    prop_assert!(cal.validate().is_ok());
                    prop_assert!(Acceptance::nunchuk().check(&cal, None).is_err());
                }
                (Request::GetStatus, Response::Status(st)) => {
                    prop_assert_eq!(st.phase, SelfCalPhase::Off);
                }
                (Request::CommitCalibration, Response::Ack)
                | (Request::CommitCalibration, Response::Error(ErrorCode::NothingStaged)) => {}
                (Request::StartStream { rate_divider: 0 }, Response::Error(ErrorCode::InvalidParameter)) => {}
                (Request::StartStream { rate_divider }, Response::StreamStarted { sample_rate_mhz }) => {
                    prop_assert_eq!(*sample_rate_mhz, BASE_MHZ / u32::from(*rate_divider));
                }
                (Request::StopStream, Response::Ack) => {}
                (Request::EndSession, Response::Ack) => {
                    prop_assert!(open);
                    open = false;
                    prop_assert!(rig.proto.staged().is_none());
                }
                _ => prop_assert!(false, "{:?} answered with {:?}", req, resp),
            }
            if is_start || matches!(req, Request::StopStream) {
                last_seq = None;
            }
            if is_hello {
                // A new session never inherits a staged calibration.
                prop_assert!(rig.proto.staged().is_none());
            }
            prop_assert!(rig.proto.corrector().live_calibration().validate().is_ok());
            for _ in 0..polls {
                rig.bus.nunchuk.set_report(&report(accel[ai % accel.len()]));
                ai += 1;
                if let Some(s) = rig.step() {
                    if let Some(prev) = last_seq {
                        prop_assert_eq!(s.seq, prev.wrapping_add(1));
                    }
                    last_seq = Some(s.seq);
                    let live = rig.proto.corrector().live_calibration();
                    if live.effects.is_none() {
                        let want = live.correct_linear(s.raw.map(f32::from));
                        prop_assert_eq!(s.corrected.map(f32::to_bits), want.map(f32::to_bits));
                    }
                }
            }
        }
    }

    /// Arbitrary bytes from the serial line: every complete frame gets one answer, corrupt
    /// frames a BadFrame error, and nothing panics.
    #[test]
    fn arbitrary_serial_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut flash = Flash::new(12);
        let store = CalibrationStore::new(&mut flash, 0..Flash::SIZE).unwrap();
        let mut p = block_on(Protocol::boot(store, info(), IdealScale::default()));
        let mut rx = DefaultFrameDecoder::new();
        let mut out = [0u8; MAX_FRAME_LEN];
        for item in rx.feed::<Request>(&bytes) {
            let resp = match item {
                Ok(req) => block_on(p.handle(req)),
                Err(e) => {
                    let r = p.bad_frame(e);
                    prop_assert_eq!(&r, &Response::Error(ErrorCode::BadFrame));
                    r
                }
            };
            prop_assert!(encode_frame(&resp, &mut out).is_ok());
        }
    }
}

#[test]
fn corrector_encoding_saturates_and_is_nan_safe() {
    let s = IdealScale::default();
    assert_eq!(s.encode(0.0), 512);
    assert_eq!(s.encode(1.0), 712);
    assert_eq!(s.encode(-1.0), 312);
    assert_eq!(s.encode(0.0024), 512); // 0.48 count rounds down
    assert_eq!(s.encode(0.0026), 513);
    assert_eq!(s.encode(2.555), 1023);
    assert_eq!(s.encode(50.0), 1023);
    assert_eq!(s.encode(-50.0), 0);
    assert_eq!(s.encode(f32::INFINITY), 1023);
    assert_eq!(s.encode(f32::NEG_INFINITY), 0);
    assert_eq!(s.encode(f32::NAN), 512);
    // The ideal block: checksums valid, zero/one-g as documented, low bits clear.
    let block = s
        .block(factory_block().stick_x, factory_block().stick_y)
        .unwrap();
    let bytes = block.encode().unwrap();
    assert!(CalibrationBlock::from_bytes(&bytes).checksum_ok);
    assert_eq!(
        &bytes[..8],
        &[0x80, 0x80, 0x80, 0x00, 0xB2, 0xB2, 0xB2, 0x00]
    );
    // A scale that does not fit 10 bits is refused.
    assert!(IdealScale {
        zero: 900,
        counts_per_g: 200
    }
    .block(factory_block().stick_x, factory_block().stick_y)
    .is_none());
}

proptest! {
    /// Any calibration that validates and any raw sample: counts are 10-bit and follow the
    /// encoding of `g`; a calibration that does not validate is refused.
    #[test]
    fn corrector_never_panics(cal in arb_cal(), raw in proptest::array::uniform3(any::<u16>())) {
        let mut c = wiical_adapter::Corrector::default();
        let cal = Calibration::from(cal);
        match c.set_user_calibration(Some(cal)) {
            Ok(()) => {
                let out = c.correct(raw);
                for i in 0..3 {
                    prop_assert!(out.counts[i] <= 1023);
                    prop_assert_eq!(out.counts[i], c.scale().encode(out.g[i]));
                }
            }
            Err(_) => {
                prop_assert!(cal.validate().is_err());
                prop_assert_eq!(c.mode(), CorrectionMode::PassThrough);
                let out = c.correct(raw);
                prop_assert_eq!(out.counts, raw.map(|x| x.min(1023)));
            }
        }
    }
}

#[test]
fn encoded_state_round_trips_through_frames() {
    // The responses the adapter produces fit in a frame (the largest is the calibration
    // state with a staged calibration).
    let mut flash = Flash::new(13);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    rig.req(Request::PutCalibration(true_calibration().into()));
    let resp = rig.req(Request::GetCalibration);
    let mut buf = [0u8; MAX_FRAME_LEN];
    let frame = encode_frame(&resp, &mut buf).unwrap().to_vec();
    let mut rx = DefaultFrameDecoder::new();
    let back: Vec<_> = rx.feed::<Response>(&frame).collect();
    assert_eq!(back, vec![Ok(resp)]);
}

/// The absurd uploads that were once "verified bit for bit" are refused with a
/// typed error; neither the staged nor the live calibration changes.
#[test]
fn implausible_uploads_are_refused_and_the_old_calibration_kept() {
    let mut flash = Flash::new(21);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    let good = true_calibration();
    assert_eq!(Acceptance::nunchuk().check(&good, None), Ok(()));
    rig.commit(&good);
    assert_eq!(rig.req(Request::PutCalibration(good.into())), Response::Ack);
    let mut absurd = Vec::new();
    for (field, value) in [
        ("quadratic", 1e30f32),
        ("cubic", 3e38),
        ("bias", 1e30),
        ("temp_ref", 1e38),
        ("cross_quadratic", 1e30),
        ("cross_cubic", -3e38),
    ] {
        let mut c = good;
        match field {
            "quadratic" => c.effects.quadratic[0] = value,
            "cubic" => c.effects.cubic[1] = value,
            "cross_quadratic" => c.effects.cross_quadratic[2][3] = value,
            "cross_cubic" => c.effects.cross_cubic[0][8] = value,
            "bias" => c.bias[2] = value,
            _ => c.effects.temp_ref_c = value,
        }
        absurd.push(c);
    }
    let mut half_scale = good;
    half_scale.matrix[0][0] *= 2.0;
    absurd.push(half_scale);
    for c in absurd {
        assert!(c.validate().is_ok(), "finite and invertible: {c:?}");
        assert_eq!(
            rig.req(Request::PutCalibration(c.into())),
            Response::Error(ErrorCode::ImplausibleCalibration),
            "{c:?}"
        );
        let state = rig.get();
        assert_eq!(state.staged, Some(good.into()), "staged copy untouched");
        assert!(bits_equal(&Calibration::from(state.live), &good));
    }
    // Non-finite stays the older, more specific code.
    let mut nan = good;
    nan.bias[0] = f32::NAN;
    assert_eq!(
        rig.req(Request::PutCalibration(nan.into())),
        Response::Error(ErrorCode::InvalidCalibration)
    );
}

/// A staged calibration belongs to its session; a later client's commit gets
/// `NothingStaged` instead of committing someone else's upload.
#[test]
fn a_staged_calibration_does_not_survive_its_session() {
    let mut flash = Flash::new(22);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    rig.hello();
    let cal = true_calibration();
    assert_eq!(rig.req(Request::PutCalibration(cal.into())), Response::Ack);
    // Another client opens a session (second Hello) and commits.
    rig.hello();
    assert_eq!(rig.get().staged, None);
    assert_eq!(
        rig.req(Request::CommitCalibration),
        Response::Error(ErrorCode::NothingStaged)
    );
    assert!(!rig.get().stored);
    // Same after the port closes.
    assert_eq!(rig.req(Request::PutCalibration(cal.into())), Response::Ack);
    rig.proto.reset_session();
    rig.hello();
    assert_eq!(
        rig.req(Request::CommitCalibration),
        Response::Error(ErrorCode::NothingStaged)
    );
    // Within one session, upload then commit works.
    assert_eq!(rig.req(Request::PutCalibration(cal.into())), Response::Ack);
    assert_eq!(rig.req(Request::CommitCalibration), Response::Ack);
    assert!(rig.get().stored);
}

/// Orientation-dependent cross terms are applied on the device: the streamed
/// value is the linear correction plus the cross monomials, computed here in f64 from the
/// linear part; the committed record (version 2) brings them back after a reboot. The drift
/// term in the same calibration is not applied (the adapter has no clock origin): the output
/// of one raw reading does not change with time.
#[test]
fn orientation_terms_are_applied_on_the_device_and_survive_a_reboot() {
    let mut flash = Flash::new(24);
    let mut cal = true_calibration();
    // a_z += 0.02·xy (1/g), a_x += −0.01·xyz (1/g²), a_y += 0.005·z² (1/g).
    let e = &mut cal.effects;
    e.cross_quadratic[2][2] = 0.02; // CROSS2[2][2] = DEGREE2[3] = xy
    e.cross_cubic[0][8] = -0.01; // CROSS3[0][8] = DEGREE3[9] = xyz
    e.cross_quadratic[1][1] = 0.005; // CROSS2[1][1] = DEGREE2[2] = z²
    e.bias_drift = [0.5, 0.0, 0.0];
    assert_eq!(Acceptance::nunchuk().check(&cal, None), Ok(()));
    let raws = [[700u16, 300, 650], [512, 512, 712], [900, 850, 200]];
    let expect = |raw: [u16; 3]| -> [f64; 3] {
        let u = cal.correct_linear(raw.map(f32::from)).map(f64::from);
        [
            u[0] - 0.01 * u[0] * u[1] * u[2],
            u[1] + 0.005 * u[2] * u[2],
            u[2] + 0.02 * u[0] * u[1],
        ]
    };
    for boot in 0..2 {
        let mut rig = Rig::boot(&mut flash);
        rig.settle();
        rig.hello();
        if boot == 0 {
            rig.commit(&cal);
        }
        let live = Calibration::from(rig.get().live);
        assert!(bits_equal(&live, &cal), "boot {boot}: {live:?}");
        rig.req(Request::StartStream { rate_divider: 1 });
        for raw in raws.iter().chain(raws.iter()) {
            rig.bus.nunchuk.set_report(&report(*raw));
            let s = rig.step().expect("a streamed sample");
            let want = expect(*raw);
            for i in 0..3 {
                let err = (f64::from(s.corrected[i]) - want[i]).abs();
                assert!(
                    err < 2e-6,
                    "boot {boot} raw {raw:?} axis {i}: {:?} vs {want:?}",
                    s.corrected
                );
            }
            let core = cal.correct(raw.map(f32::from), &wiical_core::Conditions::default());
            assert_eq!(s.corrected.map(f32::to_bits), core.map(f32::to_bits));
        }
    }
}

/// Old hosts (protocols 1 and 2) get the frozen Hello answer, from which they can tell that
/// the adapter speaks a newer protocol, and every other request is refused with
/// `SchemaMismatch` rather than misread (a protocol-2 calibration is shorter than a
/// protocol-3 one).
#[test]
fn an_old_host_gets_a_clear_schema_mismatch() {
    for (old_version, old_key) in wiical_wire::PREVIOUS_SCHEMA_KEYS {
        an_old_host_of_protocol(old_version, old_key);
    }
}

fn an_old_host_of_protocol(old_version: u16, old_key: u32) {
    let mut flash = Flash::new(23);
    let mut rig = Rig::boot(&mut flash);
    rig.settle();
    let resp = rig.req(Request::Hello(Hello {
        protocol_version: old_version,
        schema_key: old_key,
    }));
    // The bytes an old host decodes: Response variant 0 and the frozen HelloResponse layout.
    let mut buf = [0u8; MAX_FRAME_LEN];
    let bytes = postcard::to_slice(&resp, &mut buf).unwrap();
    assert_eq!(bytes[0], 0, "Response::Hello is variant 0");
    assert_eq!(bytes[1], PROTOCOL_VERSION as u8);
    let Response::Hello(h) = resp else {
        panic!("{resp:?}")
    };
    assert_eq!(h.protocol_version, 8);
    assert_eq!(h.check(), Ok(()));
    assert_eq!(
        wiical_wire::check_schema_key(old_key),
        Err(ErrorCode::SchemaMismatch)
    );
    assert_eq!(wiical_wire::protocol_of_key(old_key), Some(old_version));
    for req in [
        Request::GetCalibration,
        Request::GetStatus,
        Request::CommitCalibration,
        Request::EndSession,
    ] {
        assert_eq!(rig.req(req), Response::Error(ErrorCode::SchemaMismatch));
    }
}
