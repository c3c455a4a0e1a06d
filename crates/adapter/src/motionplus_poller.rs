//! The controller side of a real MotionPlus on the adapter's extension bus (I²C0): found
//! inactive at `0x53` by its ID, its calibration block read there, activated alone (mode
//! `0x04`), then polled at `0x52`; unplug and replug handled as [`crate::NunchukPoller`] does
//! (the same [`PollerConfig`]: failures tolerated, back-off between attempts).
//!
//! Sequence of one connection (WiiBrew's MotionPlus page, docs/gyro.md):
//! 1. read 6 bytes at `0x53`/`0xFA`: `xx 00 A6 20 xx 05` is an inactive MotionPlus (byte 0 is
//!    `0x01` on a Wii Remote Plus's built-in one; byte 4 the last mode written);
//! 2. read the 32-byte calibration block at `0x53`/`0x20` (its CRC is judged by the
//!    corrector, [`crate::GyroCorrector::set_device_block`]);
//! 3. in Nunchuk pass-through only: initialise the extension in the MotionPlus's own port, which
//!    an inactive MotionPlus passes through at `0x52` (`0x55` → `0xF0`, `0x00` → `0xFB`, the
//!    Nunchuk's plain init; a NAK, nothing plugged in, is not an error: the MotionPlus then
//!    sends its own frames only);
//! 4. write `0x55` → `0xF0`, then the mode byte → `0xFE` at `0x53` (activation in the mode
//!    wanted, [`MotionPlusPoller::set_mode`]: alone, `0x04`, until told otherwise);
//! 5. wait [`ACTIVATION_DELAY_US`] (a real MotionPlus does not answer for about 20 ms after an
//!    activation).
//!
//! Then every poll reads one 6-byte frame at `0x52`/`0x00`, decoded in the mode activated (in
//! Nunchuk pass-through the MotionPlus alternates its own frames with the Nunchuk's).
//!
//! A mode change while connected (the Wii Remote activated the adapter in another mode) is
//! made on the next poll: `0x55` → `0xF0` at `0x52` deactivates the MotionPlus, then, after
//! [`ACTIVATION_DELAY_US`], steps 3–5 activate it in the new mode
//! ([`MotionPlusEvent::Switched`]); its block is not read again.
//!
//! Not done: Classic Controller pass-through (`0x07`): its init is the Nunchuk's, but what the
//! adapter would correct in it is nothing, and no emulator model of one exists; a request for
//! it activates the MotionPlus alone.

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;
use wiical_extbus::motionplus::{
    PassthroughMode, ACTIVE_I2C_ADDRESS, CALIBRATION_REGISTER, ID_REGISTER, INACTIVE_I2C_ADDRESS,
};
use wiical_extbus::Frame;

use crate::error::Error;
use crate::poller::{is_garbage, PollerConfig};

/// Pause after the activation before the MotionPlus is addressed at `0x52`, µs.
pub const ACTIVATION_DELAY_US: u32 = 25_000;

/// True for the ID of a MotionPlus, inactive (`A6 20`) or active (`A4 20`): bytes 1, 2, 3 and
/// 5; byte 0 differs on the built-in one, byte 4 is the mode register.
pub fn is_motionplus_id(id: &[u8; 6], active: bool) -> bool {
    let family = if active { 0xA4 } else { 0xA6 };
    id[1] == 0x00 && id[2] == family && id[3] == 0x20 && id[5] == 0x05
}

/// What the poller learnt about a MotionPlus when it (re)connected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MotionPlusInfo {
    /// The 32 bytes of its calibration block as read (CRC not judged here).
    pub calibration_bytes: [u8; 32],
}

/// Result of a successful [`MotionPlusPoller::poll`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionPlusEvent {
    /// A MotionPlus was found and activated (first time, or after a replug).
    Connected(MotionPlusInfo),
    /// One frame of the active MotionPlus.
    Frame(Frame),
    /// The connected MotionPlus was deactivated and activated again in this mode (the mode
    /// wanted changed); no frame this call.
    Switched(PassthroughMode),
    /// Disconnected and waiting for the back-off delay: no bus traffic this call.
    Idle,
}

/// State machine for the controller side of a MotionPlus; see the module docs.
#[derive(Debug, Clone)]
pub struct MotionPlusPoller {
    config: PollerConfig,
    retry_at_ms: Option<u64>,
    failures: u8,
    backoff_ms: u32,
    /// The mode to activate the MotionPlus in.
    wanted: PassthroughMode,
    /// The mode it was last activated in (meaningful while connected).
    active: PassthroughMode,
}

impl Default for MotionPlusPoller {
    fn default() -> Self {
        Self::new(PollerConfig::default())
    }
}

impl MotionPlusPoller {
    /// A poller that will look for a MotionPlus at its first `poll`.
    pub fn new(config: PollerConfig) -> Self {
        let backoff_min_ms = config.backoff_min_ms.max(1);
        Self {
            config: PollerConfig {
                max_failures: config.max_failures.max(1),
                backoff_min_ms,
                backoff_max_ms: config.backoff_max_ms.max(backoff_min_ms),
                ..config
            },
            retry_at_ms: Some(0),
            failures: 0,
            backoff_ms: backoff_min_ms,
            wanted: PassthroughMode::None,
            active: PassthroughMode::None,
        }
    }

    /// The mode to activate the MotionPlus in from the next poll on: alone or Nunchuk
    /// pass-through (Classic pass-through is served as alone, see the module docs). While
    /// connected in another mode, the next poll switches it.
    pub fn set_mode(&mut self, mode: PassthroughMode) {
        self.wanted = match mode {
            PassthroughMode::Classic => PassthroughMode::None,
            m => m,
        };
    }

    /// The mode the MotionPlus was last activated in.
    pub fn mode(&self) -> PassthroughMode {
        self.active
    }

    /// True between a successful activation and the detection of an unplug.
    pub fn is_connected(&self) -> bool {
        self.retry_at_ms.is_none()
    }

    /// One step: look for, read and activate a MotionPlus if disconnected and the back-off
    /// has elapsed, else read one frame. After an `Err`, [`Self::is_connected`] tells whether
    /// the failure was tolerated or the MotionPlus is now considered unplugged.
    pub async fn poll<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        now_ms: u64,
    ) -> Result<MotionPlusEvent, Error<B::Error>> {
        match self.retry_at_ms {
            Some(at) if now_ms < at => Ok(MotionPlusEvent::Idle),
            Some(_) => match self.connect(bus, delay).await {
                Ok(info) => {
                    self.retry_at_ms = None;
                    self.failures = 0;
                    self.backoff_ms = self.config.backoff_min_ms;
                    Ok(MotionPlusEvent::Connected(info))
                }
                Err(e) => {
                    self.retry_at_ms = Some(now_ms.saturating_add(u64::from(self.backoff_ms)));
                    self.backoff_ms = self
                        .backoff_ms
                        .saturating_mul(2)
                        .min(self.config.backoff_max_ms);
                    Err(e)
                }
            },
            None => match self.step(bus, delay).await {
                Ok(event) => {
                    self.failures = 0;
                    Ok(event)
                }
                Err(e) => {
                    self.failures = self.failures.saturating_add(1);
                    if self.failures >= self.config.max_failures {
                        self.failures = 0;
                        self.backoff_ms = self.config.backoff_min_ms;
                        let retry = now_ms.saturating_add(u64::from(self.config.backoff_min_ms));
                        self.retry_at_ms = Some(retry);
                    }
                    Err(e)
                }
            },
        }
    }

    async fn connect<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
    ) -> Result<MotionPlusInfo, Error<B::Error>> {
        let mut id = [0u8; 6];
        self.read_at(bus, delay, INACTIVE_I2C_ADDRESS, ID_REGISTER, &mut id)
            .await?;
        if is_garbage(&id) {
            return Err(Error::Garbage);
        }
        if !is_motionplus_id(&id, false) {
            return Err(Error::NotAMotionPlus(id));
        }
        let mut calibration_bytes = [0u8; 32];
        self.read_at(
            bus,
            delay,
            INACTIVE_I2C_ADDRESS,
            CALIBRATION_REGISTER,
            &mut calibration_bytes,
        )
        .await?;
        self.activate(bus, delay).await?;
        Ok(MotionPlusInfo { calibration_bytes })
    }

    /// Steps 3–5 of the module docs: the extension's init in Nunchuk pass-through, the
    /// activation in the mode wanted, the pause.
    async fn activate<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
    ) -> Result<(), Error<B::Error>> {
        let mode = self.wanted;
        if mode == PassthroughMode::Nunchuk {
            for w in [[0xF0, 0x55], [0xFB, 0x00]] {
                // A NAK: nothing in the MotionPlus's port (its frames then say so).
                let _ = bus.write(ACTIVE_I2C_ADDRESS, &w).await;
                delay.delay_us(self.config.init_delay_us).await;
            }
        }
        for w in mode.activation() {
            bus.write(INACTIVE_I2C_ADDRESS, &w.to_bytes())
                .await
                .map_err(Error::Bus)?;
            delay.delay_us(self.config.init_delay_us).await;
        }
        // Not checked by reading the active ID: the first frame read at 0x52 fails when the
        // activation did not take (its failures then count towards an unplug), and one bus
        // phase less in this state machine is flash the RP2350's budget has not got.
        delay.delay_us(ACTIVATION_DELAY_US).await;
        self.active = mode;
        Ok(())
    }

    /// One step while connected: a switch to the mode wanted, or one frame.
    async fn step<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
    ) -> Result<MotionPlusEvent, Error<B::Error>> {
        if self.wanted == self.active {
            return Ok(MotionPlusEvent::Frame(self.read_frame(bus, delay).await?));
        }
        // Any write to 0xF0 at 0x52 deactivates an active MotionPlus.
        bus.write(ACTIVE_I2C_ADDRESS, &[0xF0, 0x55])
            .await
            .map_err(Error::Bus)?;
        delay.delay_us(ACTIVATION_DELAY_US).await;
        self.activate(bus, delay).await?;
        Ok(MotionPlusEvent::Switched(self.active))
    }

    async fn read_frame<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
    ) -> Result<Frame, Error<B::Error>> {
        let mut b = [0u8; 6];
        self.read_at(bus, delay, ACTIVE_I2C_ADDRESS, 0x00, &mut b)
            .await?;
        if is_garbage(&b) {
            return Err(Error::Garbage);
        }
        // Alone, every frame is the MotionPlus's own (byte 5 bit 1 set); in Nunchuk
        // pass-through, byte 5 bit 1 tells its own from the Nunchuk's.
        Frame::decode(&b, self.active).map_err(|_| Error::Garbage)
    }

    /// Set the register pointer (1-byte write, stop), wait, then read `buf.len()` bytes.
    async fn read_at<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        address: u8,
        register: u8,
        buf: &mut [u8],
    ) -> Result<(), Error<B::Error>> {
        bus.write(address, &[register]).await.map_err(Error::Bus)?;
        delay.delay_us(self.config.read_delay_us).await;
        bus.read(address, buf).await.map_err(Error::Bus)
    }
}
