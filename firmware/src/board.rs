//! What the board and the chip fix, in one place for the tasks to import: the interrupt
//! bindings, the Nunchuk poll rate and the flash the calibration store lives in.

use embassy_rp::flash::{Async, Flash};
use embassy_rp::peripherals::{DMA_CH0, FLASH, I2C0, I2C1, USB};
use embassy_rp::{adc, bind_interrupts, dma, i2c, usb};

bind_interrupts!(pub struct Irqs {
    I2C0_IRQ => i2c::InterruptHandler<I2C0>;
    I2C1_IRQ => i2c::InterruptHandler<I2C1>;
    USBCTRL_IRQ => usb::InterruptHandler<USB>;
    DMA_IRQ_0 => dma::InterruptHandler<DMA_CH0>;
    ADC_IRQ_FIFO => adc::InterruptHandler;
});

/// Nunchuk poll rate, Hz (the Wii Remote reads extensions at up to 200 Hz).
pub const POLL_HZ: u32 = wiical_adapter::DEFAULT_POLL_HZ;

/// Flash size the driver addresses (a Pico has 2 MiB, a Pico 2 has 4 MiB; the store sits
/// inside the first 2).
pub const FLASH_SIZE: usize = 2 * 1024 * 1024;

/// The flash driver type behind the calibration store (async, DMA reads).
pub type StoreFlash = Flash<'static, FLASH, Async, FLASH_SIZE>;
