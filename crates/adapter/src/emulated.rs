//! The target side of the adapter (I²C1, towards the Wii Remote): a Nunchuk register map fed
//! with corrected reports.
//!
//! The Wii Remote initialises the "extension" (either init), reads its ID and calibration
//! block, then polls the 6-byte report. [`EmulatedNunchuk`] answers all of that through
//! [`wiical_extbus::NunchukRegisters`], whose read path is a byte copy with an optional
//! per-byte `(p − 0x17) ^ 0x17`: a 6-byte report read is a few dozen instructions, far under
//! the ≈ 5 000-instruction budget of the firmware's I²C-target interrupt/task on a
//! Cortex-M33, and nothing on it can fail or allocate.
//!
//! Atomicity: the firmware must call [`EmulatedNunchuk::on_read`] for a whole read
//! transaction (fill the TX buffer at once) and update the report between transactions
//! (e.g. both under one `critical_section`/blocking mutex), so that the Wii Remote never sees
//! half of an old report and half of a new one.

use wiical_extbus::{NunchukRegisters, NunchukReport};

/// The emulated Nunchuk register map; see the module docs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EmulatedNunchuk {
    regs: NunchukRegisters,
}

impl EmulatedNunchuk {
    /// A map with a neutral report and the given calibration block in both copies.
    pub fn new(calibration_bytes: &[u8; 16]) -> Self {
        let mut regs = NunchukRegisters::new();
        regs.set_calibration_bytes(calibration_bytes);
        Self { regs }
    }

    /// Store the (corrected) report the Wii Remote will read next.
    #[inline]
    pub fn set_report(&mut self, report: &NunchukReport) {
        self.regs.set_report(report);
    }

    /// Store the calibration block (both copies).
    pub fn set_calibration_bytes(&mut self, bytes: &[u8; 16]) {
        self.regs.set_calibration_bytes(bytes);
    }

    /// Write transaction from the Wii Remote (`bytes[0]` = register, then data).
    #[inline]
    pub fn on_write(&mut self, bytes: &[u8]) {
        self.regs.write(bytes);
    }

    /// Read transaction from the Wii Remote: fills `buf` from the register pointer on,
    /// encrypted if the Wii Remote used the legacy init.
    #[inline]
    pub fn on_read(&mut self, buf: &mut [u8]) {
        self.regs.read(buf);
    }

    /// The underlying register state machine (for inspection and tests).
    pub fn registers(&self) -> &NunchukRegisters {
        &self.regs
    }
}
