//! The Nunchuk poller against a simulated Nunchuk (`wiical_extbus::NunchukRegisters`) on a
//! mock bus: init in both modes, identification, calibration copies, unplug/replug,
//! NAK/timeouts, garbage, and no panic on arbitrary bus data.

mod common;

use common::{block_on, factory_block, BusError, MockBus, NoDelay, Plug};
use embedded_hal_async::i2c::{ErrorType, I2c, NoAcknowledgeSource, Operation};
use proptest::prelude::*;
use wiical_adapter::{Error, NunchukPoller, PollEvent, PollerConfig};
use wiical_extbus::{CalibrationCopy, Encryption, NunchukRegisters, NunchukReport};

fn report(accel: [u16; 3]) -> NunchukReport {
    NunchukReport {
        stick: [0x80, 0x7D],
        accel,
        c: false,
        z: true,
    }
}

fn nunchuk() -> NunchukRegisters {
    let mut n = NunchukRegisters::new();
    n.set_calibration(&factory_block()).unwrap();
    n.set_report(&report([510, 498, 703]));
    n
}

type R = Result<PollEvent, Error<BusError>>;

fn poll(p: &mut NunchukPoller, bus: &mut MockBus, now: u64) -> R {
    block_on(p.poll(bus, &mut NoDelay::default(), now))
}

fn nak() -> Error<BusError> {
    Error::Bus(BusError::Nak(NoAcknowledgeSource::Address))
}

#[test]
fn plain_init_reads_id_and_calibration_then_reports() {
    let mut bus = MockBus::new(nunchuk());
    let mut p = NunchukPoller::default();
    let ev = poll(&mut p, &mut bus, 0);
    let Ok(PollEvent::Connected(info)) = ev else {
        panic!("expected Connected, got {ev:?}");
    };
    assert_eq!(info.encryption, Encryption::None);
    assert_eq!(
        info.calibration,
        Some((factory_block(), CalibrationCopy::First))
    );
    assert_eq!(info.calibration_bytes, factory_block().encode().unwrap());
    // The documented transactions: plain init, then pointer writes for ID, both copies.
    let expected: Vec<Vec<u8>> = vec![
        vec![0xF0, 0x55],
        vec![0xFB, 0x00],
        vec![0xFA],
        vec![0x20],
        vec![0x30],
    ];
    assert_eq!(bus.writes, expected);
    assert!(bus.nunchuk.initialised());
    assert!(p.is_connected());

    assert_eq!(
        poll(&mut p, &mut bus, 5),
        Ok(PollEvent::Report(report([510, 498, 703])))
    );
    assert_eq!(bus.writes.last(), Some(&vec![0x00]));
    bus.nunchuk.set_report(&report([0, 1023, 512]));
    assert_eq!(
        poll(&mut p, &mut bus, 10),
        Ok(PollEvent::Report(report([0, 1023, 512])))
    );
}

#[test]
fn legacy_encrypted_init_when_plain_init_is_nacked() {
    let mut bus = MockBus::new(nunchuk());
    bus.nak_plain_init = true;
    let mut p = NunchukPoller::default();
    let Ok(PollEvent::Connected(info)) = poll(&mut p, &mut bus, 0) else {
        panic!("no connection");
    };
    assert_eq!(info.encryption, Encryption::Legacy);
    assert_eq!(bus.nunchuk.encryption(), Encryption::Legacy);
    assert_eq!(bus.writes[..2], [vec![0xF0, 0x55], vec![0x40, 0x00]]);
    // The block was read encrypted and decrypted correctly.
    assert_eq!(
        info.calibration,
        Some((factory_block(), CalibrationCopy::First))
    );
    // Reports too: values whose encrypted bytes differ from the plain ones.
    for accel in [[510, 498, 703], [3, 1020, 77], [1023, 0, 600]] {
        let r = report(accel);
        bus.nunchuk.set_report(&r);
        assert_ne!(r.encode_with(Encryption::Legacy), r.to_bytes());
        assert_eq!(poll(&mut p, &mut bus, 5), Ok(PollEvent::Report(r)));
    }
    assert_eq!(p.encryption(), Some(Encryption::Legacy));
}

#[test]
fn unplug_mid_stream_backs_off_and_replug_reconnects() {
    let cfg = PollerConfig::default();
    let mut bus = MockBus::new(nunchuk());
    let mut p = NunchukPoller::new(cfg);
    let mut t = 0;
    assert!(matches!(
        poll(&mut p, &mut bus, t),
        Ok(PollEvent::Connected(_))
    ));
    for _ in 0..10 {
        t += 5;
        assert!(matches!(
            poll(&mut p, &mut bus, t),
            Ok(PollEvent::Report(_))
        ));
    }

    bus.plug = Plug::Unplugged;
    // Tolerated glitches, then disconnected at the max_failures-th failure.
    for i in 1..=cfg.max_failures {
        t += 5;
        assert_eq!(poll(&mut p, &mut bus, t), Err(nak()));
        assert_eq!(p.is_connected(), i < cfg.max_failures, "after failure {i}");
    }
    let lost_at = t;
    assert_eq!(
        p.next_attempt_ms(),
        Some(lost_at + u64::from(cfg.backoff_min_ms))
    );

    // Waiting out the back-off: no bus traffic at all.
    let before = bus.transactions;
    assert_eq!(poll(&mut p, &mut bus, lost_at + 5), Ok(PollEvent::Idle));
    assert_eq!(bus.transactions, before);

    // Failed inits double the back-off up to the cap.
    let mut expected_backoff = cfg.backoff_min_ms;
    let mut attempts = 0;
    while let Some(next) = p.next_attempt_ms() {
        if attempts == 12 {
            break;
        }
        t = next;
        assert_eq!(poll(&mut p, &mut bus, t), Err(nak()));
        assert_eq!(p.next_attempt_ms(), Some(t + u64::from(expected_backoff)));
        expected_backoff = (expected_backoff * 2).min(cfg.backoff_max_ms);
        assert_eq!(p.backoff_ms(), expected_backoff);
        attempts += 1;
    }
    assert_eq!(p.backoff_ms(), cfg.backoff_max_ms);

    // Replugged (fresh, uninitialised Nunchuk): re-init at the next attempt.
    bus.replug();
    bus.nunchuk.set_report(&report([100, 200, 300]));
    assert!(!bus.nunchuk.initialised());
    t = p.next_attempt_ms().unwrap();
    assert!(matches!(
        poll(&mut p, &mut bus, t),
        Ok(PollEvent::Connected(_))
    ));
    assert!(bus.nunchuk.initialised());
    assert_eq!(p.connections(), 2);
    assert_eq!(p.backoff_ms(), cfg.backoff_min_ms);
    assert_eq!(
        poll(&mut p, &mut bus, t + 5),
        Ok(PollEvent::Report(report([100, 200, 300])))
    );
}

#[test]
fn transient_nak_and_timeout_are_tolerated() {
    let mut bus = MockBus::new(nunchuk());
    let mut p = NunchukPoller::default();
    assert!(matches!(
        poll(&mut p, &mut bus, 0),
        Ok(PollEvent::Connected(_))
    ));
    // Alternating single failures never reach max_failures in a row.
    for i in 0..20u64 {
        let glitch = if i % 2 == 0 {
            BusError::Nak(NoAcknowledgeSource::Data)
        } else {
            BusError::Timeout
        };
        bus.inject.push_back(glitch);
        assert_eq!(poll(&mut p, &mut bus, 10 * i + 1), Err(Error::Bus(glitch)));
        assert!(p.is_connected());
        assert!(matches!(
            poll(&mut p, &mut bus, 10 * i + 6),
            Ok(PollEvent::Report(_))
        ));
    }
    assert_eq!(p.connections(), 1);
}

#[test]
fn stuck_bus_disconnects_and_init_timeouts_back_off() {
    let mut bus = MockBus::new(nunchuk());
    let mut p = NunchukPoller::default();
    assert!(matches!(
        poll(&mut p, &mut bus, 0),
        Ok(PollEvent::Connected(_))
    ));
    bus.plug = Plug::Stuck;
    let mut t = 0;
    while p.is_connected() {
        t += 5;
        assert_eq!(
            poll(&mut p, &mut bus, t),
            Err(Error::Bus(BusError::Timeout))
        );
    }
    // A timeout in the init is not a NAK: no fall-back to the legacy init.
    let n_writes = bus.writes.len();
    t = p.next_attempt_ms().unwrap();
    assert_eq!(
        poll(&mut p, &mut bus, t),
        Err(Error::Bus(BusError::Timeout))
    );
    assert_eq!(bus.writes.len(), n_writes);
    bus.plug = Plug::Present;
    t = p.next_attempt_ms().unwrap();
    assert!(matches!(
        poll(&mut p, &mut bus, t),
        Ok(PollEvent::Connected(_))
    ));
}

#[test]
fn garbage_reports_are_skipped_then_a_brown_out_reinitialises() {
    let mut bus = MockBus::new(nunchuk());
    bus.ff_until_initialised = true;
    let mut p = NunchukPoller::default();
    assert!(matches!(
        poll(&mut p, &mut bus, 0),
        Ok(PollEvent::Connected(_))
    ));

    // An all-zero report (stick and axes at 0, both buttons pressed) is not believable.
    let zero = NunchukReport {
        stick: [0, 0],
        accel: [0, 0, 0],
        c: true,
        z: true,
    };
    assert_eq!(zero.to_bytes(), [0; 6]);
    bus.nunchuk.set_report(&zero);
    assert_eq!(poll(&mut p, &mut bus, 5), Err(Error::Garbage));
    assert!(p.is_connected());
    bus.nunchuk.set_report(&report([1, 2, 3]));
    assert_eq!(
        poll(&mut p, &mut bus, 10),
        Ok(PollEvent::Report(report([1, 2, 3])))
    );

    // Brown-out: the Nunchuk forgets its init and answers 0xFF; the poller must re-init.
    bus.replug();
    let mut t = 10;
    while p.is_connected() {
        t += 5;
        assert_eq!(poll(&mut p, &mut bus, t), Err(Error::Garbage));
    }
    t = p.next_attempt_ms().unwrap();
    assert!(matches!(
        poll(&mut p, &mut bus, t),
        Ok(PollEvent::Connected(_))
    ));
    assert_eq!(
        poll(&mut p, &mut bus, t + 5),
        Ok(PollEvent::Report(report([1, 2, 3])))
    );

    // A floating bus (writes ACKed, reads 0xFF) never connects: the ID is garbage.
    bus.plug = Plug::Floating;
    let mut p = NunchukPoller::default();
    assert_eq!(poll(&mut p, &mut bus, 0), Err(Error::Garbage));
    assert!(!p.is_connected());
}

#[test]
fn other_extension_is_refused() {
    let mut bus = MockBus::new(nunchuk());
    // A Classic Controller's ID.
    let classic = [0x00, 0x00, 0xA4, 0x20, 0x01, 0x01];
    bus.overrides.push((0xFA, classic.to_vec()));
    let mut p = NunchukPoller::default();
    assert_eq!(poll(&mut p, &mut bus, 0), Err(Error::NotANunchuk(classic)));
    assert!(!p.is_connected());
    // Same in legacy mode: the ID is decrypted before comparing.
    bus.nak_plain_init = true;
    bus.nunchuk = nunchuk();
    let t = p.next_attempt_ms().unwrap();
    assert_eq!(poll(&mut p, &mut bus, t), Err(Error::NotANunchuk(classic)));
}

#[test]
fn calibration_copy_fallback() {
    let good = factory_block().encode().unwrap();
    let mut bad = good;
    bad[3] ^= 0x01;

    // First copy damaged: the second is used and replayed.
    let mut bus = MockBus::new(nunchuk());
    bus.overrides.push((0x20, bad.to_vec()));
    let mut p = NunchukPoller::default();
    let Ok(PollEvent::Connected(info)) = poll(&mut p, &mut bus, 0) else {
        panic!()
    };
    assert_eq!(
        info.calibration,
        Some((factory_block(), CalibrationCopy::Second))
    );
    assert_eq!(info.calibration_bytes, good);

    // Both damaged: no factory calibration, the first copy's bytes kept as they are.
    let mut bus = MockBus::new(nunchuk());
    bus.overrides.push((0x20, bad.to_vec()));
    bus.overrides.push((0x30, bad.to_vec()));
    let mut p = NunchukPoller::default();
    let Ok(PollEvent::Connected(info)) = poll(&mut p, &mut bus, 0) else {
        panic!()
    };
    assert_eq!(info.calibration, None);
    assert_eq!(info.calibration_bytes, bad);
}

/// A bus answering with arbitrary bytes and arbitrary failures.
struct ChaosBus {
    data: Vec<u8>,
    faults: Vec<u8>,
    i: usize,
    f: usize,
}

impl ErrorType for ChaosBus {
    type Error = BusError;
}

impl I2c for ChaosBus {
    async fn transaction(
        &mut self,
        _address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), BusError> {
        let fault = self.faults.get(self.f % self.faults.len().max(1)).copied();
        self.f += 1;
        match fault.map(|x| x % 6) {
            Some(0) => return Err(BusError::Nak(NoAcknowledgeSource::Address)),
            Some(1) => return Err(BusError::Nak(NoAcknowledgeSource::Data)),
            Some(2) => return Err(BusError::Timeout),
            _ => {}
        }
        for op in operations {
            if let Operation::Read(buf) = op {
                for b in buf.iter_mut() {
                    *b = self
                        .data
                        .get(self.i % self.data.len().max(1))
                        .copied()
                        .unwrap_or(0);
                    self.i += 1;
                }
            }
        }
        Ok(())
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Whatever the bus returns, the poller neither panics nor hands out a report made of
    /// garbage, and its connected flag agrees with the events it returns.
    #[test]
    fn arbitrary_bus_data_never_panics(
        data in proptest::collection::vec(any::<u8>(), 1..200),
        faults in proptest::collection::vec(any::<u8>(), 0..50),
        max_failures in 0u8..5,
    ) {
        let mut bus = ChaosBus { data, faults, i: 0, f: 0 };
        let mut p = NunchukPoller::new(PollerConfig { max_failures, ..Default::default() });
        let mut t = 0u64;
        for _ in 0..300 {
            t += 5;
            match block_on(p.poll(&mut bus, &mut NoDelay::default(), t)) {
                Ok(PollEvent::Connected(_)) => prop_assert!(p.is_connected()),
                Ok(PollEvent::Report(r)) => {
                    prop_assert!(p.is_connected());
                    let enc = p.encryption().unwrap();
                    let wire = r.encode_with(enc);
                    prop_assert!(!wiical_adapter::poller::is_garbage(&wire));
                    prop_assert!(!wiical_adapter::poller::is_garbage(&r.to_bytes()));
                }
                Ok(PollEvent::Idle) => prop_assert!(!p.is_connected()),
                Err(_) => {}
            }
        }
    }
}
