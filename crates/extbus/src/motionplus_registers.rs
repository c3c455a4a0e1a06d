//! A pure state machine of the MotionPlus's register map as a Wii Remote sees it (I²C target
//! side), so that an adapter can answer as a MotionPlus.
//!
//! Behaviour modelled, from the published descriptions in `docs/gyro.md` (WiiBrew's MotionPlus
//! page and Dolphin's emulated MotionPlus; no code copied):
//!
//! | state | `0x53` | `0x52` |
//! |---|---|---|
//! | inactive | the MotionPlus's map: ID `00 00 A6 20 <mode> 05` at `0xFA`, calibration at `0x20` | the extension in the MotionPlus's own port ([`Target::Extension`]) |
//! | active | no answer ([`Target::Nobody`]: a Wii Remote's read fails, "error 7") | the MotionPlus's map: ID `00 00 A4 20 <mode> 05`, the 6-byte report at `0x00` |
//!
//! * The ID's byte 4 **is** register `0xFE`, where the mode is written: writing `0x04` (alone),
//!   `0x05` (Nunchuk pass-through) or `0x07` (Classic pass-through) there activates; any
//!   other value leaves an inactive MotionPlus inactive and deactivates an active one. The
//!   byte stays after deactivation (WiiBrew: the ID at `0xA600FA` "now reads 00 00 A6 20 04 05").
//! * `0x55` to `0xF0` at `0x53` (the first step of the Wii Remote's dance) is stored and changes
//!   nothing else: activation is the mode write.
//! * While active, a write of any value to `0xF0` deactivates; the same write is the extension's
//!   own unencrypted init, so it is also for the extension ([`Target::MotionPlusThenExtension`]).
//! * While active, each read that starts at `0x00` prepares the frame it returns: the
//!   MotionPlus alternates its own report with the extension's (pass-through modes only), the
//!   first frame after activation being its own; with no extension frame available it sends
//!   its own instead. Bit 1 of byte 5 (1 = MotionPlus data), bit 0 of byte 5 (0) and bit 0 of
//!   byte 4 (extension connected) are set here for both kinds of frame, as the MotionPlus does.
//!
//! Not modelled: the 20 ms during which a real MotionPlus does not answer after an activation
//! or deactivation, the challenge registers (`0x50`–`0x8F`, `0xF1`, `0xF7`) beyond storing
//! what is written, and the "garbage" first report Dolphin mentions. Registers `0x00`–`0x05`,
//! `0x20`–`0x3F` and `0xFA`–`0xFD`, `0xFF` are read-only from the bus (set through
//! [`MotionPlusRegisters::set_calibration_bytes`] and the frame setters).

use crate::motionplus::{
    PassthroughMode, ACTIVE_I2C_ADDRESS, CALIBRATION_REGISTER, ID_INACTIVE, ID_REGISTER,
    INACTIVE_I2C_ADDRESS, MODE_REGISTER,
};

/// Register whose write deactivates an active MotionPlus (and initialises the extension).
pub const DEACTIVATE_REGISTER: u8 = 0xF0;

/// Who answers a transaction to an I²C address.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// The MotionPlus's own register map (handled here).
    MotionPlus,
    /// The extension plugged into the MotionPlus's port: the caller forwards the transaction.
    Extension,
    /// A write the MotionPlus handled (it deactivated) and that the caller also forwards to the
    /// extension, for which it is the unencrypted init.
    MotionPlusThenExtension,
    /// Nobody: the transaction is not acknowledged.
    Nobody,
}

/// Register space of a MotionPlus with its activation state and the frames it interleaves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MotionPlusRegisters {
    regs: [u8; 256],
    pointer: u8,
    active: Option<PassthroughMode>,
    gyro: [u8; 6],
    extension: Option<[u8; 6]>,
    connected: bool,
    last_was_gyro: bool,
}

impl Default for MotionPlusRegisters {
    fn default() -> Self {
        Self::new()
    }
}

/// True for addresses a bus master cannot overwrite (`0xFE`, the mode, is writable).
const fn read_only(addr: u8) -> bool {
    matches!(addr, 0x00..=0x05 | 0x20..=0x3F | 0xFA..=0xFD | 0xFF)
}

impl MotionPlusRegisters {
    /// A freshly powered MotionPlus: inactive, ID [`ID_INACTIVE`], calibration bytes zero,
    /// pointer 0, a gyro frame at rest (zero rate 8192, slow) and no extension frame.
    pub fn new() -> Self {
        let mut regs = [0u8; 256];
        regs[usize::from(ID_REGISTER)..].copy_from_slice(&ID_INACTIVE);
        Self {
            regs,
            pointer: 0,
            active: None,
            // 8192 on every axis, all slow, MotionPlus data.
            gyro: [0x00, 0x00, 0x00, 0x82, 0x82, 0x82],
            extension: None,
            connected: false,
            last_was_gyro: false,
        }
    }

    /// Store the 32-byte calibration block at `0x20` (its CRC is the caller's, e.g.
    /// `MotionPlusCalibration::to_bytes`).
    pub fn set_calibration_bytes(&mut self, bytes: &[u8; 32]) {
        let b = usize::from(CALIBRATION_REGISTER);
        self.regs[b..b + 32].copy_from_slice(bytes);
    }

    /// The MotionPlus's own next report (6 bytes as `MotionPlusReport::to_bytes` gives them;
    /// byte 4 bit 0 and byte 5 bits 1–0 are set when the frame is served).
    pub fn set_gyro_bytes(&mut self, bytes: &[u8; 6]) {
        self.gyro = *bytes;
    }

    /// The extension's next frame in the pass-through layout (e.g.
    /// `PassthroughNunchuk::to_bytes`), or `None` when no extension is plugged in; sets the
    /// extension-connected flag accordingly.
    pub fn set_extension_bytes(&mut self, bytes: Option<&[u8; 6]>) {
        self.extension = bytes.copied();
        self.connected = bytes.is_some();
    }

    /// Whether an extension is plugged into the MotionPlus's port, for the flag (byte 4 bit 0)
    /// of every frame: in mode `0x04` no extension frame is ever passed through, yet the flag
    /// tells one is there. `false` also withdraws the extension's frame.
    pub fn set_extension_connected(&mut self, connected: bool) {
        self.connected = connected;
        if !connected {
            self.extension = None;
        }
    }

    /// The mode when active, `None` when inactive.
    pub fn active(&self) -> Option<PassthroughMode> {
        self.active
    }

    /// Who answers a transaction to `address` in the current state.
    pub fn target(&self, address: u8) -> Target {
        match (self.active, address) {
            (None, INACTIVE_I2C_ADDRESS) | (Some(_), ACTIVE_I2C_ADDRESS) => Target::MotionPlus,
            (None, ACTIVE_I2C_ADDRESS) => Target::Extension,
            _ => Target::Nobody,
        }
    }

    /// Handle an I²C write transaction to `address` (`bytes[0]` register, then data, stored
    /// with auto-increment). Changes nothing unless the MotionPlus answers at `address`; the
    /// answer says who handles it.
    pub fn write(&mut self, address: u8, bytes: &[u8]) -> Target {
        let target = self.target(address);
        if target != Target::MotionPlus {
            return target;
        }
        let Some((&reg, data)) = bytes.split_first() else {
            return target;
        };
        self.pointer = reg;
        let mut deactivated = false;
        for &value in data {
            let addr = self.pointer;
            if !read_only(addr) {
                self.regs[usize::from(addr)] = value;
            }
            match (self.active, addr) {
                (_, MODE_REGISTER) => match PassthroughMode::from_byte(value) {
                    Some(mode) => self.activate(mode),
                    None if self.active.is_some() => {
                        self.deactivate();
                        deactivated = true;
                    }
                    None => {}
                },
                (Some(_), DEACTIVATE_REGISTER) => {
                    self.deactivate();
                    deactivated = true;
                }
                _ => {}
            }
            self.pointer = addr.wrapping_add(1);
        }
        if deactivated && reg == DEACTIVATE_REGISTER {
            Target::MotionPlusThenExtension
        } else {
            target
        }
    }

    /// Handle an I²C read transaction from `address`: when the MotionPlus answers, fill `buf`
    /// from the pointer on (auto-increment), a read starting at `0x00` of an active MotionPlus
    /// first preparing the next frame; otherwise `buf` is left as it was.
    pub fn read(&mut self, address: u8, buf: &mut [u8]) -> Target {
        let target = self.target(address);
        if target != Target::MotionPlus {
            return target;
        }
        if self.pointer == 0x00 {
            if let Some(mode) = self.active {
                self.prepare_frame(mode);
            }
        }
        for out in buf {
            *out = self.regs[usize::from(self.pointer)];
            self.pointer = self.pointer.wrapping_add(1);
        }
        target
    }

    fn activate(&mut self, mode: PassthroughMode) {
        if self.active.is_none() {
            self.regs[..6].fill(0);
            self.last_was_gyro = false;
        }
        self.active = Some(mode);
        self.regs[usize::from(ID_REGISTER) + 2] = ACTIVE_I2C_ADDRESS << 1;
    }

    fn deactivate(&mut self) {
        self.active = None;
        self.regs[usize::from(ID_REGISTER) + 2] = INACTIVE_I2C_ADDRESS << 1;
    }

    /// The frame a read of `0x00` returns: its own after an extension frame (or first), else
    /// the extension's when the mode passes one through and one is available.
    fn prepare_frame(&mut self, mode: PassthroughMode) {
        let extension = match (mode, self.last_was_gyro, self.extension) {
            (PassthroughMode::Nunchuk | PassthroughMode::Classic, true, Some(e)) => Some(e),
            _ => None,
        };
        let (mut frame, gyro) = match extension {
            Some(e) => (e, false),
            None => (self.gyro, true),
        };
        frame[4] = (frame[4] & !1) | u8::from(self.connected);
        frame[5] = (frame[5] & !0b11) | (u8::from(gyro) << 1);
        self.regs[..6].copy_from_slice(&frame);
        self.last_was_gyro = gyro;
    }

    /// Current register pointer.
    pub fn pointer(&self) -> u8 {
        self.pointer
    }

    /// Content of one register, for inspection and tests.
    pub fn register(&self, addr: u8) -> u8 {
        self.regs[usize::from(addr)]
    }
}
