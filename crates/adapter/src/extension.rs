//! Which extension the adapter serves: a Nunchuk or a MotionPlus on its controller bus, and
//! the address its target side answers the Wii Remote at.
//!
//! While nothing is connected, each poll first looks for a MotionPlus at `0x53`
//! ([`MotionPlusPoller`]; a transaction at `0x53` does not disturb a Nunchuk), then for a
//! Nunchuk at `0x52` ([`NunchukPoller`]): the Nunchuk's init writes `0xF0` at `0x52`, which
//! would deactivate an active MotionPlus, so it never runs while a MotionPlus is connected.
//! Once one is connected, only that one is polled until it is unplugged.

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;

use crate::error::Error;
use crate::motionplus_poller::{MotionPlusEvent, MotionPlusPoller};
use crate::poller::{NunchukPoller, PollEvent};

/// The extension the adapter presents to the Wii Remote.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Extension {
    /// A Nunchuk, or nothing connected yet (the adapter's original role: the emulated
    /// Nunchuk at `0x52`).
    #[default]
    Nunchuk,
    /// A MotionPlus: the emulated MotionPlus, at `0x53` while inactive and `0x52` once the
    /// Wii Remote activated it.
    MotionPlus,
}

/// One poll's result, by the extension that was polled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtensionEvent<E> {
    /// The Nunchuk poller ran (also when neither extension is connected).
    Nunchuk(Result<PollEvent, Error<E>>),
    /// The MotionPlus poller ran and a MotionPlus is (or was until this poll) connected.
    MotionPlus(Result<MotionPlusEvent, Error<E>>),
}

/// Both pollers and the choice between them; see the module docs.
#[derive(Debug, Clone, Default)]
pub struct ExtensionPoller {
    /// The Nunchuk side.
    pub nunchuk: NunchukPoller,
    /// The MotionPlus side.
    pub motionplus: MotionPlusPoller,
    motionplus_was_connected: bool,
}

impl ExtensionPoller {
    /// One step of whichever extension is connected, or a search for one (MotionPlus first).
    /// The answer is [`ExtensionEvent::MotionPlus`] while a MotionPlus is connected and on the
    /// poll that found it unplugged.
    pub async fn poll<B: I2c, D: DelayNs>(
        &mut self,
        bus: &mut B,
        delay: &mut D,
        now_ms: u64,
    ) -> ExtensionEvent<B::Error> {
        if !self.nunchuk.is_connected() {
            let was = self.motionplus_was_connected;
            let r = self.motionplus.poll(bus, delay, now_ms).await;
            self.motionplus_was_connected = self.motionplus.is_connected();
            if was || self.motionplus.is_connected() {
                return ExtensionEvent::MotionPlus(r);
            }
        }
        ExtensionEvent::Nunchuk(self.nunchuk.poll(bus, delay, now_ms).await)
    }

    /// True while either extension is connected.
    pub fn is_connected(&self) -> bool {
        self.nunchuk.is_connected() || self.motionplus.is_connected()
    }
}
