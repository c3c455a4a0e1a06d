//! The MotionPlus register map against the Wii Remote's activation dance as WiiBrew and
//! Dolphin describe it (docs/gyro.md): every read the Wii Remote makes, at each step, compared
//! with the bytes the documentation gives; then the interleaving, deactivation, odd writes,
//! and property tests (no panic, one address answering, the alternation rule).

use proptest::prelude::*;
use wiical_extbus::motionplus::{MotionPlusCalibration, RangeCalibration, ID_INACTIVE};
use wiical_extbus::motionplus_registers::Target;
use wiical_extbus::MotionPlusRegisters;

const INACTIVE: u8 = 0x53;
const ACTIVE: u8 = 0x52;

fn block() -> [u8; 32] {
    let half = |d: u8| RangeCalibration {
        zero: [0x7F10, 0x8020, 0x7E30],
        scale: [0x3B00, 0xC500, 0x3A00],
        degrees_div_6: d,
    };
    MotionPlusCalibration {
        fast: half(200),
        slow: half(45),
        uid: [0x12, 0x34],
    }
    .to_bytes()
}

/// Point at `reg` and read `n` bytes from `address`, as the Wii Remote does.
fn read_at(mp: &mut MotionPlusRegisters, address: u8, reg: u8, n: usize) -> (Target, Vec<u8>) {
    let t = mp.write(address, &[reg]);
    let mut buf = vec![0xEE; n];
    let r = mp.read(address, &mut buf);
    assert_eq!(t, r);
    (r, buf)
}

/// Gyro frame and Nunchuk pass-through frame with flag bits deliberately wrong, so that the
/// test sees the register map set them.
const GYRO: [u8; 6] = [0x11, 0x22, 0x33, 0x44 | 0b10, 0x55, 0x66 | 0b01];
const NUNCHUK: [u8; 6] = [0x81, 0x7F, 0xA0, 0x60, 0x40, 0xF0 | 0b11];

#[test]
fn the_wii_remotes_activation_dance() {
    let mut mp = MotionPlusRegisters::new();
    mp.set_calibration_bytes(&block());
    // Inactive: 0x52 is the extension in the MotionPlus's port, 0x53 the MotionPlus.
    assert_eq!(mp.target(ACTIVE), Target::Extension);
    assert_eq!(mp.write(ACTIVE, &[0xFA]), Target::Extension);
    // Detection: the two bytes at 0xA600FE (WiiBrew: "00 05"), then the whole ID.
    assert_eq!(read_at(&mut mp, INACTIVE, 0xFE, 2).1, [0x00, 0x05]);
    assert_eq!(read_at(&mut mp, INACTIVE, 0xFA, 6).1, ID_INACTIVE);
    assert_eq!(ID_INACTIVE, [0x00, 0x00, 0xA6, 0x20, 0x00, 0x05]);
    // The calibration block in two 16-byte reads, CRC intact.
    let (_, a) = read_at(&mut mp, INACTIVE, 0x20, 16);
    let (_, b) = read_at(&mut mp, INACTIVE, 0x30, 16);
    let whole: Vec<u8> = a.into_iter().chain(b).collect();
    assert_eq!(whole, block());
    assert!(MotionPlusCalibration::decode(&whole).unwrap().checksum_ok);
    // Bus writes cannot change the block.
    mp.write(INACTIVE, &[0x20, 0, 0, 0]);
    assert_eq!(read_at(&mut mp, INACTIVE, 0x20, 3).1, block()[..3]);
    // 0x55 → 0xF0 initialises; still inactive.
    assert_eq!(mp.write(INACTIVE, &[0xF0, 0x55]), Target::MotionPlus);
    assert_eq!(mp.active(), None);
    // The mode byte → 0xFE activates in Nunchuk pass-through.
    assert_eq!(mp.write(INACTIVE, &[0xFE, 0x05]), Target::MotionPlus);
    assert_eq!(mp.active().map(|m| m as u8), Some(0x05));
    // Active: 0x53 is silent (the Wii Remote's read fails), 0x52 is the MotionPlus.
    let (t, buf) = read_at(&mut mp, INACTIVE, 0xFA, 6);
    assert_eq!((t, buf), (Target::Nobody, vec![0xEE; 6]));
    assert_eq!(
        read_at(&mut mp, ACTIVE, 0xFA, 6).1,
        [0x00, 0x00, 0xA4, 0x20, 0x05, 0x05]
    );
    // The block is still readable at 0x52/0x20.
    assert_eq!(read_at(&mut mp, ACTIVE, 0x20, 16).1, block()[..16]);
    // Data: the MotionPlus's own frame first, then the Nunchuk's, alternating.
    mp.set_gyro_bytes(&GYRO);
    mp.set_extension_bytes(Some(&NUNCHUK));
    let gyro_served = [0x11, 0x22, 0x33, 0x44 | 0b10, 0x55 | 1, 0x66 | 0b10];
    let nunchuk_served = [0x81, 0x7F, 0xA0, 0x60, 0x40 | 1, 0xF0];
    for _ in 0..3 {
        assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1, gyro_served);
        // A read elsewhere (the ID) does not advance the alternation.
        read_at(&mut mp, ACTIVE, 0xFA, 6);
        assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1, nunchuk_served);
    }
    // The extension unplugged: its own frames only, "extension connected" clear.
    mp.set_extension_bytes(None);
    for _ in 0..2 {
        assert_eq!(
            read_at(&mut mp, ACTIVE, 0x00, 6).1,
            [0x11, 0x22, 0x33, 0x44 | 0b10, 0x54, 0x66 | 0b10]
        );
    }
    // A pointer write to 0xF0 alone (no data) changes nothing.
    mp.write(ACTIVE, &[0xF0]);
    assert!(mp.active().is_some());
    // Deactivation: any value to 0xF0 at 0x52, which is the extension's init as well.
    assert_eq!(
        mp.write(ACTIVE, &[0xF0, 0x55]),
        Target::MotionPlusThenExtension
    );
    assert_eq!(mp.active(), None);
    assert_eq!(mp.target(ACTIVE), Target::Extension);
    // The mode byte stays in the ID (WiiBrew: "now reads 00 00 A6 20 04 05" after mode 04).
    assert_eq!(
        read_at(&mut mp, INACTIVE, 0xFA, 6).1,
        [0x00, 0x00, 0xA6, 0x20, 0x05, 0x05]
    );
}

#[test]
fn alone_mode_never_passes_the_extension_through() {
    let mut mp = MotionPlusRegisters::new();
    mp.set_gyro_bytes(&GYRO);
    mp.set_extension_bytes(Some(&NUNCHUK));
    mp.write(INACTIVE, &[0xF0, 0x55]);
    mp.write(INACTIVE, &[0xFE, 0x04]);
    assert_eq!(
        read_at(&mut mp, ACTIVE, 0xFA, 6).1,
        [0x00, 0x00, 0xA4, 0x20, 0x04, 0x05]
    );
    for _ in 0..4 {
        let f = read_at(&mut mp, ACTIVE, 0x00, 6).1;
        assert_eq!(f[5] & 0b11, 0b10, "{f:02x?}");
        // Extension connected is still reported.
        assert_eq!(f[4] & 1, 1);
    }
    // The flag without any extension frame (as an adapter in mode 0x04 learns it from the real
    // MotionPlus's reports), and withdrawn.
    mp.set_extension_bytes(None);
    mp.set_extension_connected(true);
    assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1[4] & 1, 1);
    mp.set_extension_connected(false);
    assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1[4] & 1, 0);
}

#[test]
fn unknown_modes_do_not_activate_and_deactivate_an_active_motionplus() {
    let mut mp = MotionPlusRegisters::new();
    for bad in [0x00, 0x06, 0xFF] {
        mp.write(INACTIVE, &[0xFE, bad]);
        assert_eq!(mp.active(), None, "mode {bad:#x}");
        assert_eq!(read_at(&mut mp, INACTIVE, 0xFE, 1).1, [bad]);
    }
    mp.write(INACTIVE, &[0xFE, 0x07]);
    assert_eq!(mp.active().map(|m| m as u8), Some(0x07));
    // A valid mode written while active changes the mode and stays active.
    mp.write(ACTIVE, &[0xFE, 0x05]);
    assert_eq!(mp.active().map(|m| m as u8), Some(0x05));
    // Games "sometimes write zero here to deactivate" (Dolphin).
    assert_eq!(mp.write(ACTIVE, &[0xFE, 0x00]), Target::MotionPlus);
    assert_eq!(mp.active(), None);
    // Re-activation starts again with the MotionPlus's own frame.
    mp.set_extension_bytes(Some(&NUNCHUK));
    mp.write(INACTIVE, &[0xFE, 0x05]);
    assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1[5] & 0b10, 0b10);
    assert_eq!(read_at(&mut mp, ACTIVE, 0x00, 6).1[5] & 0b10, 0);
}

#[test]
fn other_addresses_are_never_answered() {
    let mut mp = MotionPlusRegisters::new();
    for a in [0x00, 0x51, 0x54, 0x7F] {
        assert_eq!(mp.write(a, &[0xFE, 0x04]), Target::Nobody);
    }
    assert_eq!(mp.active(), None);
}

#[derive(Debug, Clone)]
enum Op {
    Write(u8, Vec<u8>),
    Read(u8, usize),
    Gyro([u8; 6]),
    Ext(Option<[u8; 6]>),
    Connected(bool),
}

fn op() -> impl Strategy<Value = Op> {
    let addr = prop_oneof![Just(0x52u8), Just(0x53u8), any::<u8>()];
    // Registers the dance touches, so that random writes reach the state changes.
    let reg = prop_oneof![
        Just(0x00u8),
        Just(0xF0u8),
        Just(0xFEu8),
        Just(0xFAu8),
        any::<u8>()
    ];
    let val = prop_oneof![
        Just(0x04u8),
        Just(0x05),
        Just(0x07),
        Just(0x55),
        any::<u8>()
    ];
    prop_oneof![
        (addr.clone(), reg, prop::collection::vec(val, 0..4)).prop_map(|(a, r, mut d)| {
            d.insert(0, r);
            Op::Write(a, d)
        }),
        (addr, 0usize..40).prop_map(|(a, n)| Op::Read(a, n)),
        any::<[u8; 6]>().prop_map(Op::Gyro),
        any::<Option<[u8; 6]>>().prop_map(Op::Ext),
        any::<bool>().prop_map(Op::Connected),
    ]
}

proptest! {
    /// Any sequence of transactions: no panic; exactly one of 0x52/0x53 is the MotionPlus's and
    /// the ID's address byte says which; never two extension frames in a row, none in mode 0x04
    /// or without an extension frame.
    #[test]
    fn any_transactions_keep_the_invariants(ops in prop::collection::vec(op(), 0..60)) {
        let mut mp = MotionPlusRegisters::new();
        let mut last_ext = false;
        for o in ops {
            match o {
                Op::Write(a, d) => { mp.write(a, &d); }
                Op::Gyro(g) => mp.set_gyro_bytes(&g),
                Op::Ext(e) => mp.set_extension_bytes(e.as_ref()),
                Op::Connected(c) => mp.set_extension_connected(c),
                Op::Read(a, n) => {
                    let start = mp.pointer();
                    let mut buf = vec![0u8; n];
                    let t = mp.read(a, &mut buf);
                    let served = t == Target::MotionPlus && start == 0 && mp.active().is_some();
                    if served && n < 6 {
                        // A frame was served but not seen whole: no constraint on the next.
                        last_ext = false;
                    }
                    if served && n >= 6 {
                        let ext = buf[5] & 0b10 == 0;
                        prop_assert!(!(ext && last_ext));
                        prop_assert_eq!(buf[5] & 1, 0);
                        if ext {
                            prop_assert_ne!(mp.active().map(|m| m as u8), Some(0x04));
                        }
                        last_ext = ext;
                    }
                }
            }
            if mp.active().is_none() { last_ext = false; }
            let mine = [0x52u8, 0x53].map(|a| mp.target(a) == Target::MotionPlus);
            prop_assert!(mine[0] ^ mine[1]);
            prop_assert_eq!(mine[0], mp.active().is_some());
            prop_assert_eq!(mp.register(0xFC), if mine[0] { 0xA4 } else { 0xA6 });
        }
    }
}
