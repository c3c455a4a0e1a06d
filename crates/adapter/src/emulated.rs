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

/// Depth of the RP2040's I²C RX FIFO (datasheet section 4.3, `IC_COMP_PARAM_1`): the most
/// received bytes [`EmulatedNunchuk::on_received`] takes at once.
pub const RX_FIFO_DEPTH: usize = 16;

/// RX FIFO entries `(data, first data byte of a transaction)` split into the write
/// transactions they were, each handed to `write` in order; at most [`RX_FIFO_DEPTH`] entries
/// are taken (see [`EmulatedNunchuk::on_received`]).
pub fn split_writes(entries: impl IntoIterator<Item = (u8, bool)>, mut write: impl FnMut(&[u8])) {
    let mut buf = [0u8; RX_FIFO_DEPTH];
    let mut len = 0;
    for (byte, first) in entries.into_iter().take(RX_FIFO_DEPTH) {
        if first && len > 0 {
            write(&buf[..len]);
            len = 0;
        }
        buf[len] = byte;
        len += 1;
    }
    if len > 0 {
        write(&buf[..len]);
    }
}

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

    /// Bytes the I²C target block received but no write transaction was reported for: its RX
    /// FIFO entries as `(data, first data byte of a transaction)`, possibly several writes
    /// back to back. Each is applied as the write it was ([`Self::on_write`]).
    ///
    /// The firmware needs this when a read of the Wii Remote was overtaken: the Wii Remote
    /// ended it, wrote the register pointer and addressed the next read before the firmware
    /// saw the end, so the pointer write is still in the FIFO while the next read waits (see
    /// firmware/src/wiimote.rs). At most [`RX_FIFO_DEPTH`] entries are taken; bytes of one
    /// write beyond that many are dropped (the FIFO cannot hold more).
    pub fn on_received(&mut self, entries: impl IntoIterator<Item = (u8, bool)>) {
        split_writes(entries, |w| self.on_write(w));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A calibration block with distinct bytes, so that a read shows where it started.
    const BLOCK: [u8; 16] = [
        0x80, 0x81, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8a, 0x8b, 0x8c, 0x8d, 0x8e,
        0x8f,
    ];

    fn read6(em: &mut EmulatedNunchuk) -> [u8; 6] {
        let mut buf = [0u8; 6];
        em.on_read(&mut buf);
        buf
    }

    #[test]
    fn a_pending_pointer_write_moves_the_pointer_like_a_write() {
        let mut em = EmulatedNunchuk::new(&BLOCK);
        em.on_write(&[0xf0, 0x55]);
        em.on_write(&[0xfb, 0x00]);
        // The 16-byte block read served in three 6-byte pieces leaves the pointer at 0x32.
        em.on_write(&[0x20]);
        for _ in 0..3 {
            read6(&mut em);
        }
        assert_eq!(em.registers().pointer(), 0x32);
        em.on_received([(0x00, true)]);
        assert_eq!(em.registers().pointer(), 0x00);
    }

    #[test]
    fn back_to_back_writes_are_split_at_their_first_bytes() {
        let mut em = EmulatedNunchuk::new(&BLOCK);
        // Init (0xF0 ← 0x55), then the pointer to the calibration block.
        em.on_received([(0xf0, true), (0x55, false), (0x20, true)]);
        assert_eq!(em.registers().pointer(), 0x20);
        assert_eq!(read6(&mut em), [0x80, 0x81, 0x82, 0x83, 0x84, 0x85]);
        let mut joined = EmulatedNunchuk::new(&BLOCK);
        // Taken as one write instead, 0x20 would be data for register 0xF1.
        joined.on_write(&[0xf0, 0x55, 0x20]);
        assert_ne!(joined.registers().pointer(), 0x20);
    }

    #[test]
    fn nothing_received_changes_nothing() {
        let mut em = EmulatedNunchuk::new(&BLOCK);
        em.on_write(&[0x24]);
        em.on_received([]);
        assert_eq!(em.registers().pointer(), 0x24);
    }

    #[test]
    fn more_than_a_fifo_of_bytes_is_bounded() {
        let mut em = EmulatedNunchuk::new(&BLOCK);
        let many = core::iter::once((0x20, true)).chain(core::iter::repeat((0xaa, false)));
        em.on_received(many.take(1000));
        let mut reference = EmulatedNunchuk::new(&BLOCK);
        let mut write = [0xaa; RX_FIFO_DEPTH];
        write[0] = 0x20;
        reference.on_write(&write);
        assert_eq!(em, reference);
    }
}
