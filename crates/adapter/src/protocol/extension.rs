//! The protocol's glue for the extension it serves: a poll result of either extension
//! ([`crate::extension::ExtensionPoller`]) into the emulated Nunchuk or the emulated
//! MotionPlus, and the Wii Remote's transactions to whichever of the two it presents, at the
//! address it answers at now.
//!
//! The stored gyro calibration reaches the MotionPlus's corrector at boot and after every
//! gyro commit (`Protocol::install_gyro`); until one is committed the MotionPlus's rates and
//! block pass through unchanged. (Only with the crate's `motionplus` feature, which brings
//! `gyro-calibration` with it.)

use embedded_storage_async::nor_flash::NorFlash;
use wiical_extbus::motionplus::{PassthroughMode, ACTIVE_I2C_ADDRESS, INACTIVE_I2C_ADDRESS};
use wiical_extbus::nunchuk::I2C_ADDRESS;
use wiical_extbus::{Frame, MotionPlusReport};
use wiical_wire::{GyroSample, Sample};

use super::Protocol;
use crate::error::Error;
use crate::extension::{Extension, ExtensionEvent, ExtensionPoller};
use crate::motionplus::{EmulatedMotionPlus, GyroCorrected};
use crate::motionplus_poller::MotionPlusEvent;

impl<F: NorFlash> Protocol<F> {
    /// Feed one poll of [`ExtensionPoller`] (`poller` as it is after the poll). Returns the
    /// sample to send when streaming (Nunchuk reports only: a `Sample` is an accelerometer's);
    /// a MotionPlus's stream sample is [`Protocol::take_gyro_sample`]'s.
    pub fn on_extension_poll<E>(
        &mut self,
        event: &ExtensionEvent<E>,
        poller: &ExtensionPoller,
    ) -> Option<Sample> {
        match event {
            ExtensionEvent::Nunchuk(r) => {
                if matches!(r, Ok(crate::PollEvent::Connected(_))) {
                    self.extension = Extension::Nunchuk;
                }
                self.on_poll(r, poller.nunchuk.is_connected())
            }
            ExtensionEvent::MotionPlus(r) => {
                self.on_motionplus_poll(r, poller.motionplus.is_connected());
                None
            }
        }
    }

    /// Feed one poll of the MotionPlus: a (re)connection takes its calibration block and
    /// starts the emulated MotionPlus inactive; a frame is corrected into the emulated map
    /// (returned, `None` for a pass-through extension frame).
    pub fn on_motionplus_poll<E>(
        &mut self,
        result: &Result<MotionPlusEvent, Error<E>>,
        still_connected: bool,
    ) -> Option<GyroCorrected> {
        match result {
            Ok(MotionPlusEvent::Connected(info)) => {
                self.extension = Extension::MotionPlus;
                self.connected = true;
                self.motionplus.restart(&info.calibration_bytes);
                self.block_generation = self.block_generation.wrapping_add(1);
                None
            }
            // No stillness evidence of its own (the accelerometer is in the Wii Remote): the
            // corrector's rest limit is the gate. A Nunchuk's pass-through frame is corrected
            // with the stored accelerometer calibration, as a Nunchuk's own report is. Only a
            // gyro frame gives the stream a sample (protocol 8 streams a pass-through Nunchuk's
            // frames to the Wii Remote only, not to the host).
            Ok(MotionPlusEvent::Frame(f)) => {
                let c = self.motionplus.on_frame(f, &self.corrector, true)?;
                if let Frame::MotionPlus(raw) = f {
                    self.gyro_sample = self.stream_seq().map(|seq| gyro_sample(seq, raw, &c));
                }
                Some(c)
            }
            Ok(MotionPlusEvent::Switched(_) | MotionPlusEvent::Idle) | Err(_) => {
                if !still_connected && self.connected {
                    self.connected = false;
                }
                None
            }
        }
    }

    /// (Protocol 8.) The stream's sample of the last MotionPlus gyro frame (every
    /// `rate_divider`-th while streaming, counted with the Nunchuk's samples), once: send it
    /// as [`wiical_wire::Response::GyroSample`] after feeding a poll.
    pub fn take_gyro_sample(&mut self) -> Option<GyroSample> {
        self.gyro_sample.take()
    }

    /// Hand the committed gyro calibration (or none) to the MotionPlus's corrector; the
    /// emulated block changes with it (the ideal scale's block when calibrated).
    pub(super) fn install_gyro(&mut self) {
        // A committed calibration passed the MotionPlus acceptance, which includes the
        // corrector's own validation; a refusal would keep the previous one.
        if self.motionplus.set_calibration(self.gyro.live).is_ok() {
            self.block_generation = self.block_generation.wrapping_add(1);
        }
    }

    /// The mode the Wii Remote activated the emulated MotionPlus in, `None` while it is
    /// inactive: the mode the real MotionPlus should be in
    /// ([`crate::MotionPlusPoller::set_mode`]; kept as it is while `None`, so that the Wii
    /// Remote's re-activation after a detect pulse does not switch the real one twice).
    pub fn motionplus_mode(&self) -> Option<PassthroughMode> {
        self.motionplus.registers().active()
    }

    /// The extension presented to the Wii Remote.
    pub fn extension(&self) -> Extension {
        self.extension
    }

    /// The emulated MotionPlus (its corrector, its register map).
    pub fn motionplus(&self) -> &EmulatedMotionPlus {
        &self.motionplus
    }

    /// The 7-bit I²C address the target side must answer at now: `0x52` for a Nunchuk, for a
    /// MotionPlus `0x53` while inactive and `0x52` once activated.
    pub fn target_address(&self) -> u8 {
        match self.extension {
            Extension::Nunchuk => I2C_ADDRESS,
            Extension::MotionPlus if self.motionplus.registers().active().is_some() => {
                ACTIVE_I2C_ADDRESS
            }
            Extension::MotionPlus => INACTIVE_I2C_ADDRESS,
        }
    }

    /// High when the extension-detect line towards the Wii Remote should be: a Nunchuk
    /// connected, or a MotionPlus connected and activated (an inactive MotionPlus with
    /// nothing in its port leaves the line low; the Wii Remote finds it at `0x53`).
    pub fn extension_detect(&self) -> bool {
        self.connected
            && (self.extension == Extension::Nunchuk
                || self.motionplus.registers().active().is_some())
    }

    /// A write transaction of the Wii Remote (`bytes[0]` register, then data) to the
    /// extension presented, at [`Self::target_address`].
    pub fn target_write(&mut self, bytes: &[u8]) {
        match self.extension {
            Extension::Nunchuk => self.emulated.on_write(bytes),
            Extension::MotionPlus => {
                let address = self.target_address();
                // Nothing is plugged into the emulated MotionPlus's port: a write it
                // forwards to the extension goes nowhere.
                let _ = self.motionplus.on_write(address, bytes);
            }
        }
    }

    /// A read transaction of the Wii Remote from the extension presented (see
    /// [`crate::EmulatedNunchuk::on_read`] for the atomicity the caller keeps).
    pub fn target_read(&mut self, buf: &mut [u8]) {
        match self.extension {
            Extension::Nunchuk => self.emulated.on_read(buf),
            Extension::MotionPlus => {
                let address = self.target_address();
                let _ = self.motionplus.on_read(address, buf);
            }
        }
    }

    /// Received bytes no write was reported for (see
    /// [`crate::EmulatedNunchuk::on_received`]), applied as the writes they were.
    pub fn target_received(&mut self, entries: impl IntoIterator<Item = (u8, bool)>) {
        match self.extension {
            Extension::Nunchuk => self.emulated.on_received(entries),
            Extension::MotionPlus => {
                crate::emulated::split_writes(entries, |w| self.target_write(w));
            }
        }
    }
}

/// The wire's sample of a gyro frame: the real report's counts and range bits, and the
/// corrector's rates.
fn gyro_sample(seq: u32, raw: &MotionPlusReport, c: &GyroCorrected) -> GyroSample {
    let bits = [
        GyroSample::SLOW_YAW,
        GyroSample::SLOW_ROLL,
        GyroSample::SLOW_PITCH,
    ];
    GyroSample {
        seq,
        raw: raw.rate,
        slow: (0..3).filter(|&i| raw.slow[i]).map(|i| bits[i]).sum(),
        corrected: c.rate,
    }
}
