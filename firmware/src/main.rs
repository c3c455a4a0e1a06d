//! wiical adapter firmware for the RP2350 (Raspberry Pi Pico 2, cargo feature `rp2350`, the
//! default) or the RP2040 (Raspberry Pi Pico, feature `rp2040`, target `thumbv6m-none-eabi`).
//! Both chips use the same GPIO numbers and the same tasks; only the memory map, boot block
//! and device ID source differ (see `build.rs` and [`storage`]).
//!
//! The adapter sits between a Nunchuk and a Wii Remote: it polls the Nunchuk as I²C
//! controller, corrects its accelerometer with the stored calibration and presents the
//! result to the Wii Remote as an emulated Nunchuk (I²C target at `0x52`). With a MotionPlus
//! in place of the Nunchuk it corrects the gyro rates with the stored gyro calibration and
//! presents an emulated MotionPlus (`0x53` inactive, `0x52` once activated), while a host
//! reads, uploads and commits calibrations and streams samples over USB serial
//! (COBS frames, `wiical-wire`). All decisions are made by the hardware-independent
//! `wiical-adapter` crate; this firmware only wires embassy's drivers to it.
//!
//! `main` only builds the drivers and spawns the tasks; what the tasks share is in [`board`]
//! (interrupts, poll rate, flash) and [`shared`] (the adapter state, the sample channel).
//! Tasks, one concern each (see `firmware/README.md` for the pin map and wiring):
//!
//! | task | concern |
//! |---|---|
//! | [`extension::extension_task`] | I²C0 controller, 400 kHz: find a MotionPlus or a Nunchuk, init, poll at 200 Hz, correct, feed the emulated map |
//! | [`wiimote::wiimote_task`] | I²C1 target (`0x52`, or `0x53` for an inactive MotionPlus): the Wii Remote's reads and writes of the emulated map |
//! | [`wiimote::ext_detect_task`] | the extension-detect line towards the Wii Remote |
//! | [`serial::usb_task`] | the USB device stack |
//! | [`serial::serial_task`] | CDC-ACM: request frames in, responses and samples out |
//! | [`status::led_task`] | status LED pattern |
//! | [`temperature::temperature_task`] | the on-chip temperature sensor every 5 s: the background recalibration's covariate |
//!
//! The background recalibration (still moments of play re-fit the calibration) runs inside the
//! adapter logic on every Nunchuk report of [`extension::extension_task`], one bounded slice at a time; an
//! adoption is stored by the same `service` call that stores a finished self-calibration.
//!
//! Storage is not a task of its own: [`storage::open`] loads the calibration at boot, and a
//! commit (save, read back, then go live) runs inside the serial request that asks for it,
//! because `wiical-adapter`'s `Protocol` owns the store and makes that sequence atomic. On
//! both chips a flash erase/program stalls execute-in-place anyway, so a separate task
//! would not let anything else run meanwhile.
#![no_std]
#![no_main]

mod board;
mod extension;
mod serial;
mod shared;
mod status;
mod storage;
mod temperature;
mod wiimote;

use defmt::{info, unwrap};
use embassy_executor::Spawner;
use embassy_rp::gpio::{Level, Output};
use embassy_rp::{adc, i2c, i2c_slave, usb};
use embassy_sync::mutex::Mutex;
use static_cell::StaticCell;
use {defmt_rtt as _, panic_probe as _};

use board::Irqs;
use shared::Adapter;

#[embassy_executor::main(
    executor = "embassy_rp::executor::Executor",
    entry = "cortex_m_rt::entry"
)]
async fn main(spawner: Spawner) {
    let p = embassy_rp::init(Default::default());
    info!("wiical adapter {} starting", env!("CARGO_PKG_VERSION"));

    // Calibration store and adapter logic (loads the stored calibration, if any).
    let protocol = storage::open(p.FLASH, p.DMA_CH0, Irqs).await;
    static ADAPTER: StaticCell<Adapter> = StaticCell::new();
    let adapter: &'static Adapter = ADAPTER.init(Mutex::new(protocol));

    // Extension side (Nunchuk or MotionPlus): I²C0 controller on GP4 (SDA) / GP5 (SCL), 400 kHz,
    // external pull-ups.
    let mut cfg = i2c::Config::default();
    cfg.frequency = 400_000;
    cfg.sda_pullup = false;
    cfg.scl_pullup = false;
    let nunchuk_bus = i2c::I2c::new_async(p.I2C0, p.PIN_5, p.PIN_4, Irqs, cfg);
    spawner.spawn(unwrap!(extension::extension_task(nunchuk_bus, adapter)));

    // Wii Remote side: I²C1 target at 0x52 on GP2 (SDA) / GP3 (SCL) (the task moves it to 0x53
    // for an inactive MotionPlus); the Wii Remote has the pull-ups. Extension-detect output on GP6.
    let mut tcfg = i2c_slave::Config::default();
    tcfg.addr = u16::from(wiical_extbus::nunchuk::I2C_ADDRESS);
    tcfg.general_call = false;
    tcfg.sda_pullup = false;
    tcfg.scl_pullup = false;
    let wiimote_bus = i2c_slave::I2cSlave::new(p.I2C1, p.PIN_3, p.PIN_2, Irqs, tcfg);
    spawner.spawn(unwrap!(wiimote::wiimote_task(wiimote_bus, adapter)));
    let detect = Output::new(p.PIN_6, Level::Low);
    spawner.spawn(unwrap!(wiimote::ext_detect_task(detect)));

    // Host side: USB CDC-ACM.
    let (device, class) = serial::build(usb::Driver::new(p.USB, Irqs));
    spawner.spawn(unwrap!(serial::usb_task(device)));
    spawner.spawn(unwrap!(serial::serial_task(class, adapter)));

    // Status LED: the on-board LED of the Pico 2 and the Pico, both on GP25 (not the Pico W's,
    // which hangs off the radio chip).
    let led = Output::new(p.PIN_25, Level::Low);
    spawner.spawn(unwrap!(status::led_task(led)));

    // On-chip temperature sensor (ADC channel 4 on the RP2040, the last channel on the RP2350).
    let adc = adc::Adc::new(p.ADC, Irqs, adc::Config::default());
    let sensor = adc::Channel::new_temp_sensor(p.ADC_TEMP_SENSOR);
    spawner.spawn(unwrap!(temperature::temperature_task(adc, sensor, adapter)));
}
