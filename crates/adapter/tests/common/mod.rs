//! Test doubles: a Nunchuk on a mock I²C bus (the real register state machine of
//! `wiical-extbus` behind it, with unplug / NAK / timeout / floating-bus injection), a
//! no-op delay, and a NOR flash that can lose power in the middle of a word program or a
//! page erase.
#![allow(dead_code)]

use std::collections::VecDeque;

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use embedded_storage_async::nor_flash::{
    ErrorType as FlashErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wiical_extbus::nunchuk::StickAxisCalibration;
use wiical_extbus::nunchuk::I2C_ADDRESS;
use wiical_extbus::{CalibrationBlock, NunchukRegisters};

/// Run a future whose awaits all complete immediately (mock bus and flash).
pub fn block_on<F: core::future::Future>(f: F) -> F::Output {
    embassy_futures::block_on(f)
}

// ---------------------------------------------------------------------------------------
// I²C

/// Errors of the mock bus, mapped to embedded-hal kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusError {
    /// NAK (address: nobody there; data: byte refused).
    Nak(NoAcknowledgeSource),
    /// The transfer timed out (clock stretched forever, bus stuck).
    Timeout,
}

impl embedded_hal_async::i2c::Error for BusError {
    fn kind(&self) -> ErrorKind {
        match self {
            BusError::Nak(s) => ErrorKind::NoAcknowledge(*s),
            BusError::Timeout => ErrorKind::Other,
        }
    }
}

/// Physical state of the extension port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plug {
    /// A Nunchuk answers.
    Present,
    /// Nothing plugged: every transaction is NAKed at the address.
    Unplugged,
    /// Lines floating high with something half-connected: writes are ACKed, reads give 0xFF.
    Floating,
    /// The bus hangs: every transaction times out.
    Stuck,
}

/// A Nunchuk behind a mock I²C controller.
pub struct MockBus {
    /// The simulated Nunchuk (the real register state machine).
    pub nunchuk: NunchukRegisters,
    /// Port state.
    pub plug: Plug,
    /// An original Nunchuk that refuses the plain init (NAKs a write to 0xF0).
    pub nak_plain_init: bool,
    /// Reads return 0xFF until a complete init (a freshly powered clone).
    pub ff_until_initialised: bool,
    /// Errors to return on the next transactions, in order (transient glitches).
    pub inject: VecDeque<BusError>,
    /// Plain bytes returned instead of the register contents by a read that starts at the
    /// given register (e.g. another extension's ID, a damaged calibration copy); encrypted
    /// like every read when the Nunchuk is in legacy mode.
    pub overrides: Vec<(u8, Vec<u8>)>,
    /// Number of transactions seen.
    pub transactions: usize,
    /// Every write transaction's bytes, in order.
    pub writes: Vec<Vec<u8>>,
}

impl MockBus {
    pub fn new(nunchuk: NunchukRegisters) -> Self {
        Self {
            nunchuk,
            plug: Plug::Present,
            nak_plain_init: false,
            ff_until_initialised: false,
            inject: VecDeque::new(),
            overrides: Vec::new(),
            transactions: 0,
            writes: Vec::new(),
        }
    }

    /// Replug: a freshly powered Nunchuk with the same report and calibration (not
    /// initialised, plain mode).
    pub fn replug(&mut self) {
        let mut fresh = NunchukRegisters::new();
        let mut cal = [0u8; 16];
        for (i, b) in cal.iter_mut().enumerate() {
            *b = self.nunchuk.register(0x20 + i as u8);
        }
        fresh.set_calibration_bytes(&cal);
        let mut report = [0u8; 6];
        for (i, b) in report.iter_mut().enumerate() {
            *b = self.nunchuk.register(i as u8);
        }
        fresh.set_report(&wiical_extbus::NunchukReport::from_bytes(&report));
        self.nunchuk = fresh;
        self.plug = Plug::Present;
    }
}

impl ErrorType for MockBus {
    type Error = BusError;
}

impl I2c for MockBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), BusError> {
        self.transactions += 1;
        if let Some(e) = self.inject.pop_front() {
            return Err(e);
        }
        match self.plug {
            Plug::Unplugged => return Err(BusError::Nak(NoAcknowledgeSource::Address)),
            Plug::Stuck => return Err(BusError::Timeout),
            Plug::Floating | Plug::Present => {}
        }
        if address != I2C_ADDRESS {
            return Err(BusError::Nak(NoAcknowledgeSource::Address));
        }
        for op in operations {
            match op {
                Operation::Write(bytes) => {
                    self.writes.push(bytes.to_vec());
                    if self.plug == Plug::Floating {
                        continue;
                    }
                    if self.nak_plain_init && bytes.first() == Some(&0xF0) {
                        return Err(BusError::Nak(NoAcknowledgeSource::Data));
                    }
                    self.nunchuk.write(bytes);
                }
                Operation::Read(buf) => {
                    if self.plug == Plug::Floating
                        || (self.ff_until_initialised && !self.nunchuk.initialised())
                    {
                        buf.fill(0xFF);
                    } else if let Some((_, bytes)) = self
                        .overrides
                        .iter()
                        .find(|(r, _)| *r == self.nunchuk.pointer())
                    {
                        let enc = self.nunchuk.encryption();
                        for (o, b) in buf.iter_mut().zip(bytes.iter().cycle()) {
                            *o = enc.encode_byte(*b);
                        }
                        // Advance the pointer as a real read would.
                        let mut sink = vec![0u8; buf.len()];
                        self.nunchuk.read(&mut sink);
                    } else {
                        self.nunchuk.read(buf);
                    }
                }
            }
        }
        Ok(())
    }
}

/// A delay that only adds up the time asked for.
#[derive(Debug, Default)]
pub struct NoDelay {
    pub total_ns: u64,
}

impl DelayNs for NoDelay {
    async fn delay_ns(&mut self, ns: u32) {
        self.total_ns += u64::from(ns);
    }
}

// ---------------------------------------------------------------------------------------
// NOR flash with power cuts

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    PowerLost,
    NotAligned,
    OutOfBounds,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::PowerLost => NorFlashErrorKind::Other,
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
        }
    }
}

/// A NOR flash of `PAGES` pages of `PAGE` bytes, programmed in words of `WORD` bytes.
///
/// Physics modelled: erase sets a page to 0xFF word by word; programming can only clear
/// bits (`new = old & data`). A power cut can be scheduled after `n` word operations
/// (word programs and word erases counted together): the word being worked on is left
/// half done (a random subset of the bits that should change did), the operation fails,
/// and every later operation fails until [`CutFlash::reboot`].
pub struct CutFlash<const WORD: usize, const PAGE: usize, const PAGES: usize> {
    pub data: Vec<u8>,
    /// Word operations done so far.
    pub ops: u64,
    /// Cut the power when this many more word operations have been done.
    pub cut_after: Option<u64>,
    dead: bool,
    /// Programs that would have needed a 0→1 transition (illegal on NOR).
    pub illegal_programs: u64,
    rng: ChaCha8Rng,
}

impl<const WORD: usize, const PAGE: usize, const PAGES: usize> CutFlash<WORD, PAGE, PAGES> {
    pub const SIZE: u32 = (PAGE * PAGES) as u32;

    pub fn new(seed: u64) -> Self {
        Self {
            data: vec![0xFF; PAGE * PAGES],
            ops: 0,
            cut_after: None,
            dead: false,
            illegal_programs: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// Power back on.
    pub fn reboot(&mut self) {
        self.dead = false;
        self.cut_after = None;
    }

    pub fn is_dead(&self) -> bool {
        self.dead
    }

    /// Count one word operation; `true` if the power goes now.
    fn tick(&mut self) -> bool {
        if let Some(n) = self.cut_after.as_mut() {
            if *n == 0 {
                self.dead = true;
                self.cut_after = None;
                return true;
            }
            *n -= 1;
        }
        self.ops += 1;
        false
    }

    fn check(&self, offset: u32, len: usize, align: usize) -> Result<usize, FlashError> {
        if self.dead {
            return Err(FlashError::PowerLost);
        }
        let off = offset as usize;
        if !off.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(FlashError::NotAligned);
        }
        if off + len > self.data.len() {
            return Err(FlashError::OutOfBounds);
        }
        Ok(off)
    }
}

impl<const WORD: usize, const PAGE: usize, const PAGES: usize> FlashErrorType
    for CutFlash<WORD, PAGE, PAGES>
{
    type Error = FlashError;
}

impl<const WORD: usize, const PAGE: usize, const PAGES: usize> ReadNorFlash
    for CutFlash<WORD, PAGE, PAGES>
{
    const READ_SIZE: usize = WORD;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let off = self.check(offset, bytes.len(), WORD)?;
        bytes.copy_from_slice(&self.data[off..off + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.data.len()
    }
}

impl<const WORD: usize, const PAGE: usize, const PAGES: usize> NorFlash
    for CutFlash<WORD, PAGE, PAGES>
{
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if to < from {
            return Err(FlashError::OutOfBounds);
        }
        let off = self.check(from, (to - from) as usize, PAGE)?;
        for w in (off..to as usize).step_by(WORD) {
            if self.tick() {
                // Partially erased word: some bits already back to 1.
                for b in &mut self.data[w..w + WORD] {
                    *b |= self.rng.random::<u8>();
                }
                return Err(FlashError::PowerLost);
            }
            self.data[w..w + WORD].fill(0xFF);
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let off = self.check(offset, bytes.len(), WORD)?;
        for (i, chunk) in bytes.chunks_exact(WORD).enumerate() {
            let w = off + i * WORD;
            if self.tick() {
                // Partially programmed word: only some of the bits that should clear did.
                for (b, d) in self.data[w..w + WORD].iter_mut().zip(chunk) {
                    *b &= d | self.rng.random::<u8>();
                }
                return Err(FlashError::PowerLost);
            }
            for (b, d) in self.data[w..w + WORD].iter_mut().zip(chunk) {
                if *b & d != *d {
                    self.illegal_programs += 1;
                }
                *b &= d;
            }
        }
        Ok(())
    }
}

/// The factory calibration block the simulated Nunchuk carries in these tests.
pub fn factory_block() -> CalibrationBlock {
    CalibrationBlock {
        zero: [496, 502, 493],
        one_g: [701, 696, 695],
        stick_x: StickAxisCalibration {
            max: 0xE3,
            min: 0x1C,
            centre: 0x7E,
        },
        stick_y: StickAxisCalibration {
            max: 0xE0,
            min: 0x1E,
            centre: 0x82,
        },
    }
}
