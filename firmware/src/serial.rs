//! The host side: USB CDC-ACM carrying `wiical-wire` frames (COBS, CRC, postcard).

use defmt::{info, warn};
use embassy_futures::select::{select3, Either3};
use embassy_rp::peripherals::USB;
use embassy_rp::usb::Driver;
use embassy_usb::class::cdc_acm::{CdcAcmClass, ControlChanged, Sender, State};
use embassy_usb::driver::EndpointError;
use embassy_usb::{Builder, UsbDevice};
use static_cell::StaticCell;
use wiical_wire::{encode_frame, FrameDecoder, Request, Response, MAX_FRAME_LEN};

use crate::shared::{Adapter, SAMPLES};

/// The USB driver type.
pub type UsbDriver = Driver<'static, USB>;

/// USB IDs: pid.codes' open-source test VID/PID (to be replaced by an allocated PID).
const VID: u16 = 0x1209;
const PID: u16 = 0x0001;
/// Full-speed bulk packet size.
const PACKET: u16 = 64;

/// Builds the USB device with one CDC-ACM function.
pub fn build(
    driver: UsbDriver,
) -> (
    UsbDevice<'static, UsbDriver>,
    CdcAcmClass<'static, UsbDriver>,
) {
    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("wiical");
    config.product = Some("wiical Nunchuk adapter");
    config.max_power = 100;
    config.max_packet_size_0 = 64;

    static CONFIG_DESCRIPTOR: StaticCell<[u8; 128]> = StaticCell::new();
    static BOS_DESCRIPTOR: StaticCell<[u8; 32]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static STATE: StaticCell<State> = StaticCell::new();
    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESCRIPTOR.init([0; 128]),
        BOS_DESCRIPTOR.init([0; 32]),
        &mut [], // no Microsoft OS descriptors
        CONTROL_BUF.init([0; 64]),
    );
    let class = CdcAcmClass::new(&mut builder, STATE.init(State::new()), PACKET);
    (builder.build(), class)
}

/// Runs the USB device stack.
#[embassy_executor::task]
pub async fn usb_task(mut device: UsbDevice<'static, UsbDriver>) -> ! {
    device.run().await
}

/// Decodes request frames from the host, answers each through the adapter logic, and sends
/// streamed samples in between. The host's hang-up (DTR falling: the last process that had
/// the port open closed it, or was killed before its `EndSession`) ends the session as the
/// USB disconnect does, so the next opener's bare `CommitCalibration` finds nothing staged.
#[embassy_executor::task]
pub async fn serial_task(class: CdcAcmClass<'static, UsbDriver>, adapter: &'static Adapter) -> ! {
    let (mut tx, mut rx, line) = class.split_with_control();
    let mut decoder = FrameDecoder::<MAX_FRAME_LEN>::new();
    let mut packet = [0u8; PACKET as usize];
    let mut out = [0u8; MAX_FRAME_LEN];
    loop {
        rx.wait_connection().await;
        info!("host connected");
        decoder.reset();
        let mut dtr = line.dtr();
        'session: loop {
            match select3(
                rx.read_packet(&mut packet),
                SAMPLES.receive(),
                line.control_changed(),
            )
            .await
            {
                Either3::First(Ok(n)) => {
                    for &byte in &packet[..n] {
                        let Some(frame) = decoder.push_byte::<Request>(byte) else {
                            continue;
                        };
                        let response = {
                            let mut a = adapter.lock().await;
                            match frame {
                                Ok(request) => a.handle(request).await,
                                Err(e) => a.bad_frame(e),
                            }
                        };
                        if send(&mut tx, &response, &mut out).await.is_err() {
                            break 'session;
                        }
                    }
                }
                Either3::First(Err(_)) => break 'session,
                Either3::Second(sample) => {
                    if send(&mut tx, &sample.response(), &mut out).await.is_err() {
                        break 'session;
                    }
                }
                Either3::Third(()) => {
                    if hung_up(&line, &mut dtr) {
                        hang_up(adapter, &mut decoder).await;
                    }
                }
            }
        }
        adapter.lock().await.reset_session();
        SAMPLES.clear();
        info!("host disconnected");
    }
}

/// Whether this line-state change is the host's hang-up: DTR was set and is now clear (a
/// line-coding change also wakes the task, with DTR unchanged). The host's serial driver
/// clears DTR when the last process holding the port closes it (HUPCL, its default).
fn hung_up(line: &ControlChanged<'static>, dtr: &mut bool) -> bool {
    let was = core::mem::replace(dtr, line.dtr());
    was && !*dtr
}

/// The host hung up without `EndSession`: its session, staged upload and stream end here,
/// and a half-received frame is dropped (the next opener starts its own).
async fn hang_up(adapter: &'static Adapter, decoder: &mut FrameDecoder<MAX_FRAME_LEN>) {
    adapter.lock().await.reset_session();
    SAMPLES.clear();
    decoder.reset();
    info!("host hung up (DTR cleared): session ended");
}

/// Sends one message as a frame, split into bulk packets (a zero-length packet ends a frame
/// that fills its last packet exactly).
async fn send(
    tx: &mut Sender<'static, UsbDriver>,
    msg: &Response,
    buf: &mut [u8],
) -> Result<(), EndpointError> {
    let Ok(frame) = encode_frame(msg, buf) else {
        warn!("response does not fit in a frame");
        return Ok(());
    };
    let size = usize::from(tx.max_packet_size());
    for chunk in frame.chunks(size) {
        tx.write_packet(chunk).await?;
    }
    if frame.len() % size == 0 {
        tx.write_packet(&[]).await?;
    }
    Ok(())
}
