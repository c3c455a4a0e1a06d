//! Without the crate's `gyro-calibration` feature (the RP2040 firmware's build) the gyro
//! requests are refused with `UnsupportedRequest`, nothing is staged or stored, and the
//! accelerometer's calibration is served as before.
//! `cargo test -p wiical-adapter --no-default-features --test gyro_unsupported`
#![cfg(not(feature = "gyro-calibration"))]

mod common;

use common::{block_on, CutFlash};
use wiical_adapter::{CalibrationStore, DeviceInfo, IdealScale, Protocol};
use wiical_wire::{ErrorCode, Hello, Request, Response, WireGyroCalibration};

type Flash = CutFlash<4, 512, 4>;

#[test]
fn the_gyro_requests_are_unsupported_and_write_nothing() {
    let mut flash = Flash::new(9);
    let store = CalibrationStore::new(&mut flash, 0..Flash::SIZE).unwrap();
    let info = DeviceInfo::new("test", [0; 8], 200_000);
    let mut p = block_on(Protocol::boot(store, info, IdealScale::default()));
    assert!(matches!(
        block_on(p.handle(Request::Hello(Hello::CURRENT))),
        Response::Hello(_)
    ));
    let k = core::f32::consts::PI / 180.0 / 18.6;
    let g = WireGyroCalibration {
        bias: [8192.0; 3],
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
    };
    for r in [
        Request::PutGyroCalibration(g),
        Request::CommitGyroCalibration,
        Request::GetGyroCalibration,
    ] {
        assert_eq!(
            block_on(p.handle(r)),
            Response::Error(ErrorCode::UnsupportedRequest)
        );
    }
    assert!(p.gyro_calibration().is_none());
    assert!(matches!(
        block_on(p.handle(Request::GetCalibration)),
        Response::Calibration(_)
    ));
    drop(p);
    assert_eq!(flash.ops, 0, "nothing written");
}
