//! Every extbus decoder on arbitrary bytes, re-encoding whatever decodes, and the Nunchuk
//! register state machine driven by an arbitrary sequence of bus writes and reads.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_extbus::nunchuk::RegisterWrite;
use wiical_extbus::wiimote::CoreReport;
use wiical_extbus::{
    AccelCalibration, CalibrationBlock, Encryption, NunchukRegisters, NunchukReport,
};

fuzz_target!(|data: &[u8]| {
    // Stateless decoders on the whole input and on its halves.
    let half = data.len() / 2;
    let _ = RegisterWrite::from_bytes(data);
    if let Ok(r) = NunchukReport::decode(data) {
        assert_eq!(NunchukReport::from_bytes(&r.to_bytes()), r);
    }
    let _ = NunchukReport::decode_with(data, Encryption::Legacy);
    if let Ok(c) = CalibrationBlock::decode(data) {
        if let Ok(bytes) = c.value.encode() {
            assert_eq!(CalibrationBlock::from_bytes(&bytes).value, c.value);
        }
        let _ = c.value.accel_to_g([0, 512, 1023]);
    }
    let _ = CalibrationBlock::from_registers(data);
    let _ = CalibrationBlock::from_copies(&data[..half], &data[half..]);
    if let Ok(c) = AccelCalibration::decode(data) {
        let bytes = c.value.encode().expect("decoded values are 10-bit");
        assert_eq!(AccelCalibration::from_bytes(&bytes).value, c.value);
    }
    let _ = AccelCalibration::from_copies(&data[..half], &data[half..]);
    let _ = AccelCalibration::from_eeprom(data);
    if let Ok(r) = CoreReport::decode(data) {
        let mut out = [0u8; 32];
        let n = r.encode(&mut out).expect("decoded report re-encodes");
        assert_eq!(CoreReport::decode(&out[..n]).expect("re-decodes"), r);
        let _ = r.nunchuk();
    }

    // Register machine: the input is a script. Op byte: low bit 0 = write of the next
    // (op >> 1) % 40 bytes, 1 = read of (op >> 1) bytes.
    let mut regs = NunchukRegisters::new();
    let mut rest = data;
    while let Some((&op, tail)) = rest.split_first() {
        let n = usize::from(op >> 1);
        if op & 1 == 0 {
            let n = (n % 40).min(tail.len());
            let (w, t) = tail.split_at(n);
            regs.write(w);
            rest = t;
        } else {
            let mut buf = [0u8; 128];
            let start = regs.pointer();
            regs.read(&mut buf[..n]);
            for (i, b) in buf[..n].iter().enumerate() {
                let addr = start.wrapping_add(i as u8);
                assert_eq!(regs.encryption().decode_byte(*b), regs.register(addr));
            }
            rest = tail;
        }
        // ROM stays ROM.
        assert_eq!(regs.register(0xFC), 0xA4);
        assert_eq!(regs.register(0xFD), 0x20);
    }
});
