//! The extension side: I²C0 controller polling a Nunchuk or a MotionPlus at [`POLL_HZ`].

use defmt::{info, warn};
use embassy_rp::i2c::{Async, I2c};
use embassy_rp::peripherals::I2C0;
use embassy_time::{Delay, Duration, Instant, Ticker};
use wiical_adapter::{CorrectionMode, ExtensionEvent, ExtensionPoller, MotionPlusEvent, PollEvent};

use crate::board::POLL_HZ;
use crate::shared::{Adapter, ADDRESS_CHANGED, SAMPLES};
use crate::status;

/// Polls the extension (the poller looks for a MotionPlus, then a Nunchuk, and re-initialises
/// after an unplug, with back-off), feeds every result to the adapter logic (correction →
/// emulated register map, stream sample, self-calibration from the Nunchuk's buttons, stale
/// monitor, one slice of the background recalibration), lets it commit a finished
/// self-calibration or a background adoption (`service`: a flash write, during which this
/// task holds the adapter, as a host commit does), and publishes the status.
#[embassy_executor::task]
pub async fn extension_task(mut bus: I2c<'static, I2C0, Async>, adapter: &'static Adapter) -> ! {
    let mut poller = ExtensionPoller::default();
    let mut delay = Delay;
    let mut ticker = Ticker::every(Duration::from_hz(u64::from(POLL_HZ)));
    let mut was_connected = false;
    let mut dropped: u32 = 0;
    loop {
        ticker.next().await;
        let event = poller
            .poll(&mut bus, &mut delay, Instant::now().as_millis())
            .await;
        let (sample, st, generation, detect, selfcal, stale) = {
            let mut a = adapter.lock().await;
            let address = a.target_address();
            let sample = a.on_extension_poll(&event, &poller);
            if a.target_address() != address {
                ADDRESS_CHANGED.signal(());
            }
            a.service().await;
            let sc = a.selfcal();
            (
                sample,
                a.status(),
                a.block_generation(),
                a.extension_detect(),
                sc.status(),
                sc.stale(),
            )
        };
        status::publish(&st, generation, detect);
        status::publish_selfcal(&selfcal, stale.recalibration_suggested);
        if let Some(s) = sample {
            if SAMPLES.try_send(s).is_err() {
                dropped = dropped.wrapping_add(1);
                if dropped.is_power_of_two() {
                    warn!("host too slow: {} samples dropped", dropped);
                }
            }
        }
        log_connection(&event, st.mode);
        let connected = poller.is_connected();
        if was_connected && !connected {
            warn!("extension unplugged");
        }
        was_connected = connected;
    }
}

/// Says what was found on a (re)connection.
fn log_connection<E>(event: &ExtensionEvent<E>, mode: CorrectionMode) {
    match event {
        ExtensionEvent::Nunchuk(Ok(PollEvent::Connected(info))) => {
            info!(
                "Nunchuk connected ({}), factory calibration {}",
                if info.encryption == wiical_extbus::Encryption::None {
                    "plain"
                } else {
                    "legacy encrypted"
                },
                if info.calibration.is_some() {
                    "valid"
                } else {
                    "missing"
                }
            );
            if mode == CorrectionMode::PassThrough {
                warn!("uncalibrated: pass-through");
            }
        }
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Connected(_))) => {
            info!("MotionPlus connected and activated");
        }
        _ => {}
    }
}
