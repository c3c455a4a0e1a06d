//! # wiical-adapter
//!
//! The hardware-independent logic of the wiical adapter, which sits between a Nunchuk and a
//! Wii Remote: it polls the Nunchuk (I²C controller), corrects its accelerometer with a
//! stored calibration, and presents the corrected data to the Wii Remote as an emulated
//! Nunchuk (I²C target), while a host can read, upload and commit calibrations and stream
//! samples over USB serial ([`wiical_wire`]).
//!
//! `no_std`, no allocation, no `unsafe`; everything hardware-facing is a trait
//! (`embedded-hal-async` I²C and delay, `embedded-storage-async` NOR flash), so the same
//! code runs in the firmware, in the desktop simulator (`wiical device-sim`) and in tests.
//!
//! | module | what |
//! |---|---|
//! | [`poller`] | [`NunchukPoller`]: init (plain, else legacy encrypted), ID, factory block, report polling, unplug/replug with back-off |
//! | [`corrector`] | [`Corrector`]: live calibration → g → counts on an ideal 10-bit scale; pass-through when uncalibrated |
//! | [`emulated`] | [`EmulatedNunchuk`]: the register map the Wii Remote reads |
//! | [`motionplus_poller`] | [`MotionPlusPoller`]: a real MotionPlus found at `0x53`, its block read, activated, polled at `0x52` |
//! | [`extension`] | [`ExtensionPoller`]: which extension is connected (MotionPlus looked for first), [`Extension`] |
//! | [`motionplus`] | [`EmulatedMotionPlus`], [`GyroCorrector`]: the adapter as a MotionPlus, its gyro rates corrected and re-encoded (slow/fast ranges), the Nunchuk passed through corrected |
//! | [`store`] | [`CalibrationStore`]: versioned, CRC-checked record in a power-loss-safe `sequential-storage` map |
//! | [`settings`] | [`settings::StoredSettings`]: background adoption on/off, host uploads protected, the stored calibration's origin |
//! | [`background`] | [`background::Background`]: recalibration from the still moments of play, adopted through the store |
//! | [`selfcal`] | [`SelfCal`]: calibration on the adapter from the Nunchuk's buttons (no PC), and the stale-calibration monitor |
//! | [`protocol`] | [`Protocol`]: wire requests → responses, stream of samples, and the glue between the above |
//!
//! ## Firmware sketch
//! ```ignore
//! let store = CalibrationStore::new(flash, 0x1F_C000..0x20_0000)?;
//! let mut proto = Protocol::boot(store, info, IdealScale::default()).await;
//! let mut poller = NunchukPoller::default();
//! loop {                                   // every 5 ms (200 Hz)
//!     let r = poller.poll(&mut i2c0, &mut delay, now_ms()).await;
//!     if let Some(sample) = proto.on_poll(&r, poller.is_connected()) { send(sample) }
//! }
//! // serial task: frames → proto.handle(req).await → frames
//! // I²C-target task: proto.emulated().on_write(..) / .on_read(..)
//! ```
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod background;
pub mod corrector;
pub mod emulated;
mod error;
pub mod extension;
pub mod motionplus;
pub mod motionplus_poller;
pub mod poller;
pub mod protocol;
mod record_crc;
pub mod selfcal;
pub mod settings;
pub mod still;
pub mod store;

pub use corrector::{Corrected, CorrectionMode, Corrector, IdealScale};
pub use emulated::EmulatedNunchuk;
pub use error::{Error, RecordError, StoreError};
pub use extension::{Extension, ExtensionEvent, ExtensionPoller};
pub use motionplus::{EmulatedMotionPlus, GyroCorrector, IdealGyroScale};
pub use motionplus_poller::{MotionPlusEvent, MotionPlusInfo, MotionPlusPoller};
pub use poller::{NunchukInfo, NunchukPoller, PollEvent, PollerConfig, DEFAULT_POLL_HZ};
pub use protocol::{BootLoad, DeviceInfo, Protocol, Status};
pub use selfcal::{
    SelfCal, SelfCalConfig, SelfCalFailure, SelfCalResult, SelfCalStatus, StaleEstimate,
};
pub use store::{CalibrationStore, Loaded, LoadedGyro};
