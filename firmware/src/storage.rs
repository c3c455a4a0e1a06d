//! The calibration store in the last 16 KiB of the first 2 MiB of flash, and the boot-time
//! load that decides between calibrated and pass-through operation.

use core::ops::Range;

use defmt::{info, warn};
use embassy_rp::peripherals::{DMA_CH0, FLASH};
use embassy_rp::Peri;
use wiical_adapter::{
    BootLoad, CalibrationStore, CorrectionMode, DeviceInfo, IdealScale, Protocol,
};

use crate::board::{Irqs, StoreFlash, POLL_HZ};

/// Offsets (from the start of flash) of the store: four 4 KiB erase sectors, excluded from
/// the program's FLASH region in memory.x.
pub const STORE_RANGE: Range<u32> = 0x1F_C000..0x20_0000;

/// Opens the store, loads the calibration and builds the adapter logic. Logs what it found:
/// without a usable stored calibration the adapter passes the Nunchuk through (factory
/// calibration mapped onto the ideal scale) and says so.
pub async fn open(
    flash: Peri<'static, FLASH>,
    dma: Peri<'static, DMA_CH0>,
    irqs: Irqs,
) -> Protocol<StoreFlash> {
    let mut flash = StoreFlash::new(flash, dma, irqs);
    let device_id = device_id(&mut flash);
    let Ok(store) = CalibrationStore::new(flash, STORE_RANGE) else {
        defmt::panic!("calibration store: STORE_RANGE does not fit the flash geometry");
    };
    let info = DeviceInfo::new(env!("CARGO_PKG_VERSION"), device_id, POLL_HZ * 1000);
    let protocol = Protocol::boot(store, info, IdealScale::default()).await;
    let status = protocol.status();
    match status.boot {
        BootLoad::Loaded => info!("stored calibration loaded"),
        BootLoad::Empty => warn!("no stored calibration"),
        BootLoad::Rejected(_) => warn!("stored calibration refused (damaged or invalid)"),
        BootLoad::StorageError => warn!("calibration store unreadable"),
    }
    if status.mode == CorrectionMode::PassThrough {
        warn!("uncalibrated: pass-through (the Nunchuk's own calibration is forwarded)");
    }
    protocol
}

/// The 64-bit ID that identifies the adapter to the host (all zeros if it cannot be read).
///
/// RP2350: the chip ID in OTP.
#[cfg(feature = "rp2350")]
fn device_id(_flash: &mut StoreFlash) -> [u8; 8] {
    embassy_rp::otp::get_chipid()
        .map(u64::to_le_bytes)
        .unwrap_or([0; 8])
}

/// The 64-bit ID that identifies the adapter to the host (all zeros if it cannot be read).
///
/// RP2040: the chip has no ID of its own; like the Pico SDK's `pico_get_unique_board_id`, use
/// the flash chip's 64-bit unique ID (command 0x4B), read while nothing else runs at boot.
#[cfg(feature = "rp2040")]
fn device_id(flash: &mut StoreFlash) -> [u8; 8] {
    let mut id = [0u8; 8];
    if flash.blocking_unique_id(&mut id).is_err() {
        warn!("flash unique ID unreadable");
        id = [0; 8];
    }
    id
}
