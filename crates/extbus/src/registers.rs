//! A pure state machine of the Nunchuk's register map as a Wii Remote sees it (I²C target
//! side), so that an adapter can emulate a Nunchuk.
//!
//! Bus semantics modelled (WiiBrew "Wiimote/Extension Controllers"):
//! * An I²C write transaction `[reg, d0, d1, …]` sets the register pointer to `reg` and
//!   stores `d0, d1, …` at `reg, reg+1, …` (auto-increment, wrapping after `0xFF`).
//!   A 1-byte write only sets the pointer, which is how the Wii Remote starts a read.
//! * An I²C read transaction returns bytes from the pointer onwards, auto-incrementing.
//! * Registers `0x00`–`0x05` (input report), `0x20`–`0x3F` (calibration) and `0xFA`–`0xFF`
//!   (ID) are read-only from the bus: writes there are acknowledged and ignored, like a
//!   real device's ROM. They are set through [`NunchukRegisters::set_report`] and
//!   [`NunchukRegisters::set_calibration`].
//! * Writing `0x55` to `0xF0` selects plain reads; a later `0x00` to `0xFB` completes the
//!   unencrypted init. Writing anything to `0x40` (the legacy init writes `0x00`) selects
//!   [`Encryption::Legacy`]: from then on every byte read is encrypted.
//!
//! Limitation: only the zero-key legacy cipher is modelled. A host that writes a non-zero
//! 16-byte key to `0x40`–`0x4F` (the real Wii does so with table-based encryption) still
//! gets zero-key-encrypted bytes. Hosts that use either documented init (as homebrew
//! libraries and this project's adapter do) are served correctly.

use crate::error::Error;
use crate::nunchuk::{
    CalibrationBlock, Encryption, NunchukReport, CALIBRATION_BACKUP_REGISTER, CALIBRATION_REGISTER,
    ID, ID_REGISTER, KEY_REGISTER,
};

/// Register space of a Nunchuk with a pointer and init/encryption state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NunchukRegisters {
    regs: [u8; 256],
    pointer: u8,
    encryption: Encryption,
    f0_unlocked: bool,
    initialised: bool,
}

impl Default for NunchukRegisters {
    fn default() -> Self {
        Self::new()
    }
}

/// True for addresses a bus master cannot overwrite.
const fn read_only(addr: u8) -> bool {
    matches!(addr, 0x00..=0x05 | 0x20..=0x3F | 0xFA..=0xFF)
}

impl NunchukRegisters {
    /// A freshly powered Nunchuk: report at rest (all zero, buttons released), calibration
    /// bytes zero, ID set, pointer 0, plain reads, not yet initialised.
    pub fn new() -> Self {
        let mut regs = [0u8; 256];
        regs[usize::from(ID_REGISTER)..].copy_from_slice(&ID);
        let mut s = Self {
            regs,
            pointer: 0,
            encryption: Encryption::None,
            f0_unlocked: false,
            initialised: false,
        };
        s.set_report(&NunchukReport::default());
        s
    }

    /// Store the current input report in registers `0x00`–`0x05`.
    pub fn set_report(&mut self, report: &NunchukReport) {
        self.regs[..NunchukReport::LEN].copy_from_slice(&report.to_bytes());
    }

    /// Store a calibration block in both copies (`0x20` and `0x30`), checksums computed.
    /// Fails (leaving the registers unchanged) if a value does not fit 10 bits.
    pub fn set_calibration(&mut self, cal: &CalibrationBlock) -> Result<(), Error> {
        let bytes = cal.encode()?;
        self.set_calibration_bytes(&bytes);
        Ok(())
    }

    /// Store raw calibration bytes in both copies, e.g. replayed from a real device.
    pub fn set_calibration_bytes(&mut self, bytes: &[u8; 16]) {
        for base in [CALIBRATION_REGISTER, CALIBRATION_BACKUP_REGISTER] {
            let b = usize::from(base);
            self.regs[b..b + 16].copy_from_slice(bytes);
        }
    }

    /// Handle an I²C write transaction: `bytes[0]` is the register address, the rest is
    /// data. An empty write (an address probe) changes nothing.
    pub fn write(&mut self, bytes: &[u8]) {
        let Some((&reg, data)) = bytes.split_first() else {
            return;
        };
        self.pointer = reg;
        for &value in data {
            let addr = self.pointer;
            match (addr, value) {
                (0xF0, 0x55) => {
                    self.encryption = Encryption::None;
                    self.f0_unlocked = true;
                }
                (0xFB, 0x00) if self.f0_unlocked => self.initialised = true,
                (KEY_REGISTER, _) => {
                    self.encryption = Encryption::Legacy;
                    self.initialised = true;
                }
                _ => {}
            }
            if !read_only(addr) {
                self.regs[usize::from(addr)] = value;
            }
            self.pointer = addr.wrapping_add(1);
        }
    }

    /// Handle an I²C read transaction: fill `buf` from the pointer onwards (auto-increment,
    /// wrapping after `0xFF`), encrypted if the legacy init was used.
    pub fn read(&mut self, buf: &mut [u8]) {
        for out in buf {
            *out = self
                .encryption
                .encode_byte(self.regs[usize::from(self.pointer)]);
            self.pointer = self.pointer.wrapping_add(1);
        }
    }

    /// Current register pointer.
    pub fn pointer(&self) -> u8 {
        self.pointer
    }

    /// Current read encryption mode.
    pub fn encryption(&self) -> Encryption {
        self.encryption
    }

    /// True once a complete init sequence (either mode) has been written.
    pub fn initialised(&self) -> bool {
        self.initialised
    }

    /// Plain (unencrypted) content of one register, for inspection and tests.
    pub fn register(&self, addr: u8) -> u8 {
        self.regs[usize::from(addr)]
    }
}
