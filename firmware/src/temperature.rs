//! The chip's on-chip temperature sensor, read at a low rate: the covariate of the background
//! recalibration (a MEMS bias moves with temperature) and the input of the live calibration's
//! temperature terms.
//!
//! The sensor measures the die, not the Nunchuk's accelerometer at the end of its cable; both
//! follow the room and the player's hands over minutes, which is the scale the background
//! recalibration's slope is learnt on. Every [`PERIOD`] the task averages [`READINGS`]
//! conversions and hands the result to the adapter logic.

use embassy_rp::adc::{Adc, Async, Channel};
use embassy_time::{Duration, Ticker};

use crate::shared::Adapter;

/// Time between temperature readings (temperatures move in minutes).
pub const PERIOD: Duration = Duration::from_secs(5);
/// Conversions averaged per reading (the sensor's LSB is ≈ 0.47 °C; the average lowers the
/// quantisation and the ADC's noise).
pub const READINGS: u32 = 16;

/// The chips' rated junction range, °C: a reading outside it is a fault (an ADC that reads
/// 0 gives 437 °C), not a temperature, and is given to the adapter as none.
pub const PLAUSIBLE_C: core::ops::RangeInclusive<f32> = -40.0..=125.0;

/// °C from a 12-bit reading of the sensor channel with a 3.3 V reference: the RP2040 and
/// RP2350 datasheets' `T = 27 − (V − 0.706 V) / 1.721 mV/°C`. Uncalibrated per chip (the
/// datasheets give the typical slope and offset); the background recalibration uses
/// differences of temperature, which the offset does not affect.
pub fn celsius(raw12: f32) -> f32 {
    let volts = raw12 * 3.3 / 4096.0;
    27.0 - (volts - 0.706) / 0.001_721
}

/// Reads the temperature every [`PERIOD`] and gives it to the adapter (`None` while the ADC
/// fails or reads outside [`PLAUSIBLE_C`], so that the temperature terms are left out rather
/// than fed a stale or false value).
#[embassy_executor::task]
pub async fn temperature_task(
    mut adc: Adc<'static, Async>,
    mut sensor: Channel<'static>,
    adapter: &'static Adapter,
) -> ! {
    let mut ticker = Ticker::every(PERIOD);
    loop {
        let mut sum = 0u32;
        let mut ok = true;
        for _ in 0..READINGS {
            match adc.read(&mut sensor).await {
                Ok(raw) => sum += u32::from(raw),
                Err(_) => ok = false,
            }
        }
        let t = ok
            .then(|| celsius(sum as f32 / READINGS as f32))
            .filter(|t| PLAUSIBLE_C.contains(t));
        adapter.lock().await.set_temperature(t);
        ticker.next().await;
    }
}
