//! The controller side of the adapter's Nunchuk bus (I²C0): init, identification,
//! factory-calibration read-out and report polling, with unplug / replug handling.
//!
//! ## Why async over `embedded-hal-async`
//! The firmware is embassy-based: its I²C driver implements
//! [`embedded_hal_async::i2c::I2c`] and its timer [`embedded_hal_async::delay::DelayNs`], so
//! the poller takes them as they are, without a wrapper, and never blocks the executor while
//! a transfer runs. Being async costs the desktop tests nothing: the mock bus' futures are
//! always ready, so a trivial `block_on` (embassy-futures) drives them.
//!
//! ## Time
//! The poller keeps no clock: every [`NunchukPoller::poll`] receives `now_ms`, a monotonic
//! millisecond count (e.g. `embassy_time::Instant::now().as_millis()`). The caller calls
//! `poll` at the report rate (≥ [`DEFAULT_POLL_HZ`]); while disconnected, `poll` returns
//! [`PollEvent::Idle`] without touching the bus until the back-off delay has passed.
//!
//! ## One bus phase per call
//! A call does either the whole init (≈ 8 short transactions, only on (re)connection) or one
//! report read (write `0x00`, wait, read 6 bytes), so that its duration is bounded.

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::{Error as _, ErrorKind, I2c};
use wiical_extbus::nunchuk::{
    CALIBRATION_BACKUP_REGISTER, CALIBRATION_REGISTER, DATA_REGISTER, I2C_ADDRESS, ID, ID_REGISTER,
    INIT_UNENCRYPTED,
};
use wiical_extbus::{CalibrationBlock, CalibrationCopy, Encryption, NunchukReport};

use crate::error::Error;

/// Recommended report poll rate, Hz (the Wii Remote itself reads extensions at up to 200 Hz).
pub const DEFAULT_POLL_HZ: u32 = 200;

/// Tunables of the poller. [`Default`] gives values that work with genuine and clone
/// Nunchuks at 100–400 kHz.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PollerConfig {
    /// Pause after each init write, µs (clones need time to switch mode).
    pub init_delay_us: u32,
    /// Pause between setting the register pointer and reading, µs (the Nunchuk does not
    /// support a repeated start; it needs a stop and a short gap).
    pub read_delay_us: u32,
    /// Consecutive failed or garbage polls tolerated before declaring the Nunchuk gone
    /// (≥ 1; at 200 Hz, 3 means 15 ms).
    pub max_failures: u8,
    /// First re-init attempt after a disconnection, ms.
    pub backoff_min_ms: u32,
    /// Back-off cap, ms; the delay doubles after each failed init up to this.
    pub backoff_max_ms: u32,
}

impl Default for PollerConfig {
    fn default() -> Self {
        Self {
            init_delay_us: 1_000,
            read_delay_us: 200,
            max_failures: 3,
            backoff_min_ms: 20,
            backoff_max_ms: 1_000,
        }
    }
}

/// What the poller learnt about a Nunchuk when it (re)connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NunchukInfo {
    /// The mode the init put the Nunchuk in (legacy only if the plain init was NAKed).
    pub encryption: Encryption,
    /// Decrypted calibration bytes as stored by the Nunchuk: the copy that passed its
    /// checksum, or the first copy if neither did. The emulated register map replays these
    /// in pass-through mode.
    pub calibration_bytes: [u8; 16],
    /// The decoded factory calibration and which copy it came from; `None` when neither
    /// copy has a valid checksum.
    pub calibration: Option<(CalibrationBlock, CalibrationCopy)>,
}

/// Result of a successful [`NunchukPoller::poll`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PollEvent {
    /// The Nunchuk was just initialised (first time, or after a replug).
    Connected(NunchukInfo),
    /// A fresh, plausible report.
    Report(NunchukReport),
    /// Disconnected and waiting for the back-off delay: no bus traffic this call.
    Idle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Disconnected { retry_at_ms: u64 },
    Connected { encryption: Encryption },
}

/// State machine for the controller side of the Nunchuk bus; see the module docs.
#[derive(Debug, Clone)]
pub struct NunchukPoller {
    config: PollerConfig,
    state: State,
    failures: u8,
    backoff_ms: u32,
    connections: u32,
}

impl Default for NunchukPoller {
    fn default() -> Self {
        Self::new(PollerConfig::default())
    }
}

/// True when the 6 bytes carry no information: every byte `0x00` or every byte `0xFF`.
/// A real report cannot look like this (all-zero would mean both buttons pressed with the
/// stick and all three axes at the low rail; all-`0xFF` all three axes at the high rail).
pub fn is_garbage(bytes: &[u8; 6]) -> bool {
    bytes.iter().all(|&b| b == 0x00) || bytes.iter().all(|&b| b == 0xFF)
}

impl NunchukPoller {
    /// A poller that will try to initialise the Nunchuk at its first `poll`.
    pub fn new(config: PollerConfig) -> Self {
        let max_failures = config.max_failures.max(1);
        let backoff_min_ms = config.backoff_min_ms.max(1);
        Self {
            config: PollerConfig {
                max_failures,
                backoff_min_ms,
                backoff_max_ms: config.backoff_max_ms.max(backoff_min_ms),
                ..config
            },
            state: State::Disconnected { retry_at_ms: 0 },
            failures: 0,
            backoff_ms: backoff_min_ms,
            connections: 0,
        }
    }

    /// True between a successful init and the detection of an unplug.
    pub fn is_connected(&self) -> bool {
        matches!(self.state, State::Connected { .. })
    }

    /// Mode of the connected Nunchuk.
    pub fn encryption(&self) -> Option<Encryption> {
        match self.state {
            State::Connected { encryption } => Some(encryption),
            State::Disconnected { .. } => None,
        }
    }

    /// Number of successful inits so far (a replug increments it).
    pub fn connections(&self) -> u32 {
        self.connections
    }

    /// Current back-off delay before the next init attempt, ms.
    pub fn backoff_ms(&self) -> u32 {
        self.backoff_ms
    }

    /// When disconnected, the time (ms) of the next init attempt.
    pub fn next_attempt_ms(&self) -> Option<u64> {
        match self.state {
            State::Disconnected { retry_at_ms } => Some(retry_at_ms),
            State::Connected { .. } => None,
        }
    }

    /// One step: init if disconnected and the back-off has elapsed, else read one report.
    ///
    /// `Err` means this step failed; afterwards [`Self::is_connected`] tells whether the
    /// failure was tolerated (report skipped) or the Nunchuk is now considered unplugged.
    pub async fn poll<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        now_ms: u64,
    ) -> Result<PollEvent, Error<B::Error>> {
        match self.state {
            State::Disconnected { retry_at_ms } => {
                if now_ms < retry_at_ms {
                    return Ok(PollEvent::Idle);
                }
                match self.init(bus, delay).await {
                    Ok(info) => {
                        self.state = State::Connected {
                            encryption: info.encryption,
                        };
                        self.failures = 0;
                        self.backoff_ms = self.config.backoff_min_ms;
                        self.connections = self.connections.wrapping_add(1);
                        Ok(PollEvent::Connected(info))
                    }
                    Err(e) => {
                        self.state = State::Disconnected {
                            retry_at_ms: now_ms.saturating_add(u64::from(self.backoff_ms)),
                        };
                        self.backoff_ms = self
                            .backoff_ms
                            .saturating_mul(2)
                            .min(self.config.backoff_max_ms);
                        Err(e)
                    }
                }
            }
            State::Connected { encryption } => {
                match self.read_report(bus, delay, encryption).await {
                    Ok(report) => {
                        self.failures = 0;
                        Ok(PollEvent::Report(report))
                    }
                    Err(e) => {
                        self.failures = self.failures.saturating_add(1);
                        if self.failures >= self.config.max_failures {
                            self.failures = 0;
                            self.backoff_ms = self.config.backoff_min_ms;
                            self.state = State::Disconnected {
                                retry_at_ms: now_ms
                                    .saturating_add(u64::from(self.config.backoff_min_ms)),
                            };
                        }
                        Err(e)
                    }
                }
            }
        }
    }

    async fn init<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
    ) -> Result<NunchukInfo, Error<B::Error>> {
        let [first, second] = INIT_UNENCRYPTED;
        let encryption = match bus.write(I2C_ADDRESS, &first.to_bytes()).await {
            Ok(()) => {
                delay.delay_us(self.config.init_delay_us).await;
                bus.write(I2C_ADDRESS, &second.to_bytes())
                    .await
                    .map_err(Error::Bus)?;
                Encryption::None
            }
            Err(e) if matches!(e.kind(), ErrorKind::NoAcknowledge(_)) => {
                // Refused: an original Nunchuk that only knows the legacy (zero-key) init.
                delay.delay_us(self.config.init_delay_us).await;
                for w in Encryption::Legacy.init_sequence() {
                    bus.write(I2C_ADDRESS, &w.to_bytes())
                        .await
                        .map_err(Error::Bus)?;
                }
                Encryption::Legacy
            }
            Err(e) => return Err(Error::Bus(e)),
        };
        delay.delay_us(self.config.init_delay_us).await;

        let mut id = [0u8; 6];
        self.read_registers(bus, delay, ID_REGISTER, &mut id)
            .await?;
        let wire_id = id;
        encryption.decode_in_place(&mut id);
        if is_garbage(&wire_id) || is_garbage(&id) {
            return Err(Error::Garbage);
        }
        if id != ID {
            return Err(Error::NotANunchuk(id));
        }

        let mut first_copy = [0u8; 16];
        let mut second_copy = [0u8; 16];
        self.read_registers(bus, delay, CALIBRATION_REGISTER, &mut first_copy)
            .await?;
        self.read_registers(bus, delay, CALIBRATION_BACKUP_REGISTER, &mut second_copy)
            .await?;
        encryption.decode_in_place(&mut first_copy);
        encryption.decode_in_place(&mut second_copy);
        let calibration = CalibrationBlock::from_copies(&first_copy, &second_copy)
            .ok()
            .map(|c| (c.value, c.copy));
        let calibration_bytes = match calibration {
            Some((_, CalibrationCopy::Second)) => second_copy,
            _ => first_copy,
        };
        Ok(NunchukInfo {
            encryption,
            calibration_bytes,
            calibration,
        })
    }

    async fn read_report<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        encryption: Encryption,
    ) -> Result<NunchukReport, Error<B::Error>> {
        let mut wire = [0u8; 6];
        self.read_registers(bus, delay, DATA_REGISTER, &mut wire)
            .await?;
        let mut plain = wire;
        encryption.decode_in_place(&mut plain);
        if is_garbage(&wire) || is_garbage(&plain) {
            return Err(Error::Garbage);
        }
        Ok(NunchukReport::from_bytes(&plain))
    }

    /// Set the register pointer (1-byte write, stop), wait, then read `buf.len()` bytes.
    async fn read_registers<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        register: u8,
        buf: &mut [u8],
    ) -> Result<(), Error<B::Error>> {
        bus.write(I2C_ADDRESS, &[register])
            .await
            .map_err(Error::Bus)?;
        delay.delay_us(self.config.read_delay_us).await;
        bus.read(I2C_ADDRESS, buf).await.map_err(Error::Bus)
    }
}
