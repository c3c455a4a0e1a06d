//! The adapter in front of a real MotionPlus (issue 50 item 1): the controller side finds a
//! MotionPlus at 0x53, reads its block, activates it and polls it at 0x52 (a simulated device:
//! `wiical-extbus`'s MotionPlus register state machine behind a mock bus); a Nunchuk is still
//! found and never disturbed by the MotionPlus search; the Wii Remote side answers at 0x53
//! while inactive and 0x52 once activated; and a gyro calibration committed over the wire is
//! the one the emulated MotionPlus corrects with, after a reboot too.
#![cfg(feature = "motionplus")]

mod common;

use common::{block_on, factory_block, BusError, CutFlash, MockBus, NoDelay};
use embedded_hal_async::i2c::{ErrorType, I2c, NoAcknowledgeSource, Operation};
use wiical_adapter::{
    CalibrationStore, DeviceInfo, Extension, ExtensionEvent, ExtensionPoller, IdealGyroScale,
    IdealScale, MotionPlusEvent, MotionPlusPoller, PollEvent, Protocol,
};
use wiical_extbus::motionplus::{PassthroughMode, PassthroughNunchuk};
use wiical_extbus::motionplus_registers::Target;
use wiical_extbus::{
    Frame, MotionPlusRegisters, MotionPlusReport, NunchukRegisters, NunchukReport,
};
use wiical_wire::{Hello, Request, Response, WireCalibration, WireGyroCalibration};

/// A real MotionPlus on the controller bus: the register state machine answers where it says
/// it answers; what it passes to the extension reaches `nunchuk` when one is in its port;
/// everything else is NAKed at the address.
struct MotionPlusBus {
    device: MotionPlusRegisters,
    plugged: bool,
    /// Every write's (address, bytes).
    writes: Vec<(u8, Vec<u8>)>,
    /// A Nunchuk in the MotionPlus's port and the report it holds now (the MotionPlus reads
    /// it itself and passes it through, once the Nunchuk was initialised, in mode 0x05).
    nunchuk: Option<(NunchukRegisters, NunchukReport)>,
}

impl MotionPlusBus {
    /// The transaction's target: the MotionPlus, its port's Nunchuk, or nobody (`None`).
    fn route(&mut self, address: u8) -> Option<bool> {
        match self.device.target(address) {
            Target::MotionPlus => Some(false),
            Target::Extension if self.nunchuk.is_some() => Some(true),
            _ => None,
        }
    }

    /// What the MotionPlus passes through next: the Nunchuk's report once it is initialised.
    fn sample_nunchuk(&mut self) {
        let frame = self.nunchuk.as_ref().and_then(|(regs, report)| {
            regs.initialised().then(|| {
                PassthroughNunchuk {
                    report: *report,
                    extension_connected: true,
                }
                .to_bytes()
            })
        });
        match frame {
            Some(f) => self.device.set_extension_bytes(Some(&f)),
            None => self.device.set_extension_connected(self.nunchuk.is_some()),
        }
    }
}

impl ErrorType for MotionPlusBus {
    type Error = BusError;
}

impl I2c for MotionPlusBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), BusError> {
        let nak = Err(BusError::Nak(NoAcknowledgeSource::Address));
        let Some(to_nunchuk) = self.plugged.then(|| self.route(address)).flatten() else {
            return nak;
        };
        for op in operations {
            match (op, to_nunchuk) {
                (Operation::Write(b), _) => {
                    self.writes.push((address, b.to_vec()));
                    let forward = to_nunchuk
                        || self.device.write(address, b) == Target::MotionPlusThenExtension;
                    if let (true, Some((n, _))) = (forward, self.nunchuk.as_mut()) {
                        n.write(b);
                    }
                }
                (Operation::Read(buf), true) => {
                    if let Some((n, _)) = self.nunchuk.as_mut() {
                        n.read(buf);
                    }
                }
                (Operation::Read(buf), false) => {
                    self.sample_nunchuk();
                    self.device.read(address, buf);
                }
            }
        }
        Ok(())
    }
}

/// The device's block: the ideal scale's own (CRC valid), sign pattern of Dolphin's block.
fn device_block() -> [u8; 32] {
    IdealGyroScale::default()
        .block([true, false, true], [0x12, 0x34])
        .to_bytes()
}

fn motionplus_bus() -> MotionPlusBus {
    let mut device = MotionPlusRegisters::new();
    device.set_calibration_bytes(&device_block());
    MotionPlusBus {
        device,
        plugged: true,
        writes: Vec::new(),
        nunchuk: None,
    }
}

fn report_bytes(rate: [u16; 3]) -> [u8; 6] {
    MotionPlusReport {
        rate,
        slow: [true; 3],
        extension_connected: false,
    }
    .to_bytes()
    .unwrap()
}

#[test]
fn a_motionplus_is_found_at_0x53_activated_alone_and_polled_at_0x52() {
    let mut bus = motionplus_bus();
    bus.device.set_gyro_bytes(&report_bytes([9000, 8000, 8192]));
    let mut p = MotionPlusPoller::default();
    let mut d = NoDelay::default();
    match block_on(p.poll(&mut bus, &mut d, 0)) {
        Ok(MotionPlusEvent::Connected(info)) => {
            assert_eq!(info.calibration_bytes, device_block());
        }
        other => panic!("expected a connection, got {other:?}"),
    }
    assert!(p.is_connected());
    // Activated alone: 0x55 → 0xF0 then 0x04 → 0xFE, both at 0x53.
    assert!(bus.writes.contains(&(0x53, vec![0xF0, 0x55])));
    assert!(bus.writes.contains(&(0x53, vec![0xFE, 0x04])));
    assert!(bus.device.active().is_some());
    // It waited for the MotionPlus to switch before addressing it at 0x52.
    assert!(d.total_ns >= 20_000_000);
    match block_on(p.poll(&mut bus, &mut d, 5)) {
        Ok(MotionPlusEvent::Frame(wiical_extbus::Frame::MotionPlus(r))) => {
            assert_eq!(r.rate, [9000, 8000, 8192]);
            assert_eq!(r.slow, [true; 3]);
        }
        other => panic!("expected a gyro frame, got {other:?}"),
    }
    // Unplugged: three failures, then disconnected; replugged (a fresh, inactive device):
    // found again after the back-off.
    bus.plugged = false;
    for t in [10, 15, 20] {
        assert!(block_on(p.poll(&mut bus, &mut d, t)).is_err());
    }
    assert!(!p.is_connected());
    bus = motionplus_bus();
    assert_eq!(
        block_on(p.poll(&mut bus, &mut d, 25)),
        Ok(MotionPlusEvent::Idle)
    );
    assert!(matches!(
        block_on(p.poll(&mut bus, &mut d, 40)),
        Ok(MotionPlusEvent::Connected(_))
    ));
}

#[test]
fn a_nunchuk_is_found_and_the_motionplus_search_never_writes_to_it() {
    let mut bus = MockBus::new({
        let mut n = NunchukRegisters::new();
        n.set_calibration(&factory_block()).unwrap();
        n
    });
    let mut p = ExtensionPoller::default();
    let mut d = NoDelay::default();
    let first = block_on(p.poll(&mut bus, &mut d, 0));
    assert!(matches!(
        first,
        ExtensionEvent::Nunchuk(Ok(PollEvent::Connected(_)))
    ));
    // The MockBus NAKs every address but 0x52 and records the writes it ACKed: only the
    // Nunchuk's own init and reads.
    assert!(bus.writes.iter().all(|w| w[0] != 0xFE));
    assert!(matches!(
        block_on(p.poll(&mut bus, &mut d, 5)),
        ExtensionEvent::Nunchuk(Ok(PollEvent::Report(_)))
    ));
}

#[test]
fn with_a_motionplus_the_nunchuk_init_never_runs() {
    let mut bus = motionplus_bus();
    let mut p = ExtensionPoller::default();
    let mut d = NoDelay::default();
    assert!(matches!(
        block_on(p.poll(&mut bus, &mut d, 0)),
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Connected(_)))
    ));
    for t in 1..20 {
        let e = block_on(p.poll(&mut bus, &mut d, 5 * t));
        assert!(matches!(e, ExtensionEvent::MotionPlus(Ok(_))), "{e:?}");
    }
    // No write at 0x52 at all (the Nunchuk's init would write 0xF0 there and deactivate).
    assert!(bus.writes.iter().all(|(a, _)| *a == 0x53 || *a == 0x52));
    assert!(!bus.writes.iter().any(|(a, b)| *a == 0x52 && b.len() > 1));
    assert!(bus.device.active().is_some());
    // Unplugged: the poll that finds it gone is still the MotionPlus's.
    bus.plugged = false;
    let mut last = None;
    for t in 20..23 {
        last = Some(block_on(p.poll(&mut bus, &mut d, 5 * t)));
    }
    assert!(matches!(last, Some(ExtensionEvent::MotionPlus(Err(_)))));
    assert!(!p.is_connected());
}

type Flash = CutFlash<4, 512, 4>;

fn boot(flash: &mut Flash) -> Protocol<&mut Flash> {
    let store = CalibrationStore::new(flash, 0..Flash::SIZE).unwrap();
    let info = DeviceInfo::new("test", [0; 8], 200_000);
    let mut p = block_on(Protocol::boot(store, info, IdealScale::default()));
    assert!(matches!(
        block_on(p.handle(Request::Hello(Hello::CURRENT))),
        Response::Hello(_)
    ));
    p
}

/// A gyro calibration of a MotionPlus with `S` slow counts per °/s (not the nominal
/// 8192/440) and a bias off 8192, no misalignment: rad/s per count on the diagonal.
const S: f32 = 20.0;
const BIAS: [f32; 3] = [8292.0, 8142.0, 8222.0];
fn calibration() -> WireGyroCalibration {
    let k = core::f32::consts::PI / 180.0 / S;
    WireGyroCalibration {
        bias: BIAS,
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
    }
}

/// Connects a simulated MotionPlus through the protocol, does the Wii Remote's activation
/// dance on the target side, checking the address at each step, and returns the counts the
/// Wii Remote reads for a true rate of `dps` °/s on every axis.
fn wiimote_reads(p: &mut Protocol<&mut Flash>, dps: f32) -> [u16; 3] {
    let mut bus = motionplus_bus();
    let mut poller = ExtensionPoller::default();
    let mut d = NoDelay::default();
    let raw = BIAS.map(|b| (b + S * dps).round() as u16);
    bus.device.set_gyro_bytes(&report_bytes(raw));
    for t in 0..2 {
        let e = block_on(poller.poll(&mut bus, &mut d, 5 * t));
        p.on_extension_poll(&e, &poller);
    }
    assert_eq!(p.extension(), Extension::MotionPlus);
    assert_eq!(p.target_address(), 0x53);
    assert!(!p.extension_detect(), "inactive, nothing in its port");
    let mut id = [0u8; 6];
    p.target_write(&[0xFA]);
    p.target_read(&mut id);
    assert_eq!(id, [0x00, 0x00, 0xA6, 0x20, 0x00, 0x05]);
    p.target_write(&[0xF0, 0x55]);
    assert_eq!(p.target_address(), 0x53);
    p.target_write(&[0xFE, 0x04]);
    assert_eq!(p.target_address(), 0x52);
    assert!(p.extension_detect());
    p.target_write(&[0xFA]);
    p.target_read(&mut id);
    assert_eq!(id, [0x00, 0x00, 0xA4, 0x20, 0x04, 0x05]);
    let mut frame = [0u8; 6];
    p.target_write(&[0x00]);
    p.target_read(&mut frame);
    MotionPlusReport::decode(&frame).unwrap().rate
}

#[test]
fn the_committed_gyro_calibration_corrects_the_rates_the_wii_remote_reads_after_a_reboot_too() {
    let dps = 100.0_f32;
    // The ideal scale's counts for the true rate (8192/440 counts per °/s, slow range).
    let ideal = (8192.0 + f64::from(dps) * 8192.0 / 440.0).round() as u16;
    let mut flash = Flash::new(1);
    {
        let mut p = boot(&mut flash);
        // Uncalibrated: the rates pass through as they came.
        let raw = BIAS.map(|b| (b + S * dps).round() as u16);
        assert_eq!(wiimote_reads(&mut p, dps), raw);
        assert_eq!(
            block_on(p.handle(Request::PutGyroCalibration(calibration()))),
            Response::Ack
        );
        assert_eq!(
            block_on(p.handle(Request::CommitGyroCalibration)),
            Response::Ack
        );
        let got = wiimote_reads(&mut p, dps);
        assert!(
            got.iter().all(|&c| c.abs_diff(ideal) <= 1),
            "{got:?} vs {ideal}"
        );
    }
    flash.reboot();
    let mut p = boot(&mut flash);
    let got = wiimote_reads(&mut p, dps);
    assert!(
        got.iter().all(|&c| c.abs_diff(ideal) <= 1),
        "{got:?} vs {ideal}"
    );
    // Deactivation (any write to 0xF0 at 0x52) moves the target back to 0x53.
    p.target_write(&[0xF0, 0x55]);
    assert_eq!(p.target_address(), 0x53);
}

/// The accelerometer calibration of the Nunchuk behind the MotionPlus: bias in counts, K in g
/// per count (not the ideal 512 + 200·g, so that a correction shows).
const ACC_BIAS: [f32; 3] = [500.25, 510.5, 489.75];
const ACC_PER_G: [f32; 3] = [201.0, 197.0, 203.0];

/// The counts an ideal Nunchuk (512 + 200·g) reads for raw counts `raw`, the calibration
/// applied in f64.
fn ideal_counts(raw: [u16; 3]) -> [f64; 3] {
    std::array::from_fn(|i| {
        512.0 + 200.0 * (f64::from(raw[i]) - f64::from(ACC_BIAS[i])) / f64::from(ACC_PER_G[i])
    })
}

/// The Wii Remote's dance in Nunchuk pass-through (mode 0x05) on the adapter's target side.
fn activate_in_nunchuk_passthrough(p: &mut Protocol<&mut Flash>) {
    assert_eq!(p.target_address(), 0x53);
    p.target_write(&[0xF0, 0x55]);
    p.target_write(&[0xFE, 0x05]);
    assert_eq!(p.target_address(), 0x52);
    let mut id = [0u8; 6];
    p.target_write(&[0xFA]);
    p.target_read(&mut id);
    assert_eq!(id, PassthroughMode::Nunchuk.active_id());
}

#[test]
fn a_nunchuk_behind_the_motionplus_passes_through_with_both_corrected() {
    let mut flash = Flash::new(2);
    let mut p = boot(&mut flash);
    let k = ACC_PER_G.map(|s| 1.0 / s);
    let acc = WireCalibration {
        bias: ACC_BIAS,
        matrix: [[k[0], 0.0, 0.0], [0.0, k[1], 0.0], [0.0, 0.0, k[2]]],
        effects: Default::default(),
    };
    for r in [
        Request::PutCalibration(acc),
        Request::CommitCalibration,
        Request::PutGyroCalibration(calibration()),
        Request::CommitGyroCalibration,
    ] {
        assert_eq!(block_on(p.handle(r)), Response::Ack);
    }
    let mut bus = motionplus_bus();
    let dps = -150.0_f32;
    bus.device
        .set_gyro_bytes(&report_bytes(BIAS.map(|b| (b + S * dps).round() as u16)));
    // Odd raw counts: the MotionPlus drops bit 0 before the adapter sees them.
    let truth = NunchukReport {
        stick: [0x31, 0xC2],
        accel: [701, 323, 898],
        c: true,
        z: false,
    };
    bus.nunchuk = Some((NunchukRegisters::new(), truth));
    let mut poller = ExtensionPoller::default();
    let mut d = NoDelay::default();
    // As the firmware's extension task does: the mode the Wii Remote asked for handed to the
    // poller (here before each poll, there after each).
    let mut poll = |p: &mut Protocol<&mut Flash>, bus: &mut MotionPlusBus, t: u64| {
        if let Some(m) = p.motionplus_mode() {
            poller.motionplus.set_mode(m);
        }
        let e = block_on(poller.poll(bus, &mut d, t));
        p.on_extension_poll(&e, &poller);
        e
    };
    assert!(matches!(
        poll(&mut p, &mut bus, 0),
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Connected(_)))
    ));
    // Activated alone at first: the Nunchuk was not initialised, nothing is passed through.
    assert_eq!(bus.device.active(), Some(PassthroughMode::None));
    assert!(!bus.nunchuk.as_ref().unwrap().0.initialised());
    activate_in_nunchuk_passthrough(&mut p);
    let before = bus.writes.len();
    assert_eq!(
        poll(&mut p, &mut bus, 5),
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Switched(PassthroughMode::Nunchuk)))
    );
    // Deactivated at 0x52, the Nunchuk initialised through it there, activated in mode 0x05.
    assert_eq!(
        bus.writes[before..],
        [
            (0x52, vec![0xF0, 0x55]),
            (0x52, vec![0xF0, 0x55]),
            (0x52, vec![0xFB, 0x00]),
            (0x53, vec![0xF0, 0x55]),
            (0x53, vec![0xFE, 0x05]),
        ]
    );
    assert_eq!(bus.device.active(), Some(PassthroughMode::Nunchuk));
    let (mut gyro, mut nunchuk) = (0, 0);
    for t in 2..12 {
        assert!(matches!(
            poll(&mut p, &mut bus, 5 * t),
            ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Frame(_)))
        ));
        let mut b = [0u8; 6];
        p.target_write(&[0x00]);
        p.target_read(&mut b);
        if check_frame(&b, &truth, dps) {
            gyro += 1;
        } else {
            nunchuk += 1;
        }
    }
    assert!(
        gyro >= 4 && nunchuk >= 4,
        "{gyro} gyro, {nunchuk} Nunchuk frames"
    );
}

/// Checks one frame the Wii Remote read in Nunchuk pass-through against the truth; true for a
/// gyro frame, false for a Nunchuk frame.
fn check_frame(b: &[u8; 6], truth: &NunchukReport, dps: f32) -> bool {
    match Frame::decode(b, PassthroughMode::Nunchuk).unwrap() {
        Frame::MotionPlus(r) => {
            let ideal = (8192.0 + f64::from(dps) * 8192.0 / 440.0).round() as u16;
            assert!(r.rate.iter().all(|c| c.abs_diff(ideal) <= 1), "{r:?}");
            assert!(r.extension_connected);
            true
        }
        Frame::Nunchuk(n) => {
            assert_eq!(n.report.stick, truth.stick);
            assert_eq!((n.report.c, n.report.z), (truth.c, truth.z));
            // Within one count of the calibration applied to what the MotionPlus passed
            // (bit 0 dropped), and within 1 + 200/k counts (about 2) of it applied to
            // the Nunchuk's full-precision counts.
            let seen = ideal_counts(truth.accel.map(|a| a & !1));
            let full = ideal_counts(truth.accel);
            for i in 0..3 {
                let got = f64::from(n.report.accel[i]);
                assert!((got - seen[i]).abs() <= 1.0, "{i}: {got} vs {}", seen[i]);
                assert!((got - full[i]).abs() <= 2.0, "{i}: {got} vs {}", full[i]);
            }
            false
        }
        Frame::Classic(_) => panic!("a Classic frame in Nunchuk pass-through"),
    }
}

#[test]
fn without_a_nunchuk_in_its_port_the_passthrough_motionplus_sends_gyro_frames_only() {
    let mut flash = Flash::new(3);
    let mut p = boot(&mut flash);
    let mut bus = motionplus_bus();
    let mut poller = ExtensionPoller::default();
    let mut d = NoDelay::default();
    let e = block_on(poller.poll(&mut bus, &mut d, 0));
    p.on_extension_poll(&e, &poller);
    activate_in_nunchuk_passthrough(&mut p);
    poller.motionplus.set_mode(p.motionplus_mode().unwrap());
    // The Nunchuk's init NAKs (nothing plugged in) and is not an error.
    let e = block_on(poller.poll(&mut bus, &mut d, 5));
    assert_eq!(
        e,
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Switched(PassthroughMode::Nunchuk)))
    );
    for t in 2..8 {
        let e = block_on(poller.poll(&mut bus, &mut d, 5 * t));
        p.on_extension_poll(&e, &poller);
        let mut b = [0u8; 6];
        p.target_write(&[0x00]);
        p.target_read(&mut b);
        assert!(matches!(
            Frame::decode(&b, PassthroughMode::Nunchuk),
            Ok(Frame::MotionPlus(r)) if !r.extension_connected
        ));
    }
}
