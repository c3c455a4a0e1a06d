//! Calibration JSON → `device put` → adapter: arbitrary text through the strict calibration
//! file parser; whatever parses is sent to the adapter's protocol as `device put --force`
//! would, then committed. The adapter must never panic, must accept exactly what the core's
//! acceptance predicate accepts (`Acceptance::nunchuk`), must keep its old calibration when
//! it refuses, and once it accepts, every raw input must correct to within the ±16 g bound.
#![no_main]

use embassy_futures::block_on;
use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use libfuzzer_sys::fuzz_target;
use wiical_adapter::{CalibrationStore, DeviceInfo, IdealScale, Protocol};
use wiical_analysis::calfile;
use wiical_core::quality::Acceptance;
use wiical_wire::{Hello, Request, Response, WireCalibration};

const PAGE: usize = 512;
const PAGES: usize = 4;

/// A RAM NOR flash (programming clears bits, erase sets a page to 0xFF).
struct RamFlash(Vec<u8>);

#[derive(Debug)]
struct RamError;

impl NorFlashError for RamError {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}

impl ErrorType for RamFlash {
    type Error = RamError;
}

impl ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamError> {
        let s = offset as usize;
        let src = self.0.get(s..s + bytes.len()).ok_or(RamError)?;
        bytes.copy_from_slice(src);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.0.len()
    }
}

impl NorFlash for RamFlash {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), RamError> {
        self.0
            .get_mut(from as usize..to as usize)
            .ok_or(RamError)?
            .fill(0xFF);
        Ok(())
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamError> {
        let s = offset as usize;
        let dst = self.0.get_mut(s..s + bytes.len()).ok_or(RamError)?;
        for (d, b) in dst.iter_mut().zip(bytes) {
            *d &= b;
        }
        Ok(())
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(file) = calfile::parse(text) else {
        return;
    };
    let cal = file.calibration;
    let acceptance = Acceptance::nunchuk();
    let plausible = acceptance.check(&cal, None).is_ok();
    block_on(async {
        let store =
            CalibrationStore::new(RamFlash(vec![0xFF; PAGE * PAGES]), 0..(PAGE * PAGES) as u32)
                .expect("store configuration");
        let info = DeviceInfo::new("fuzz", [0; 8], 200_000);
        let mut p = Protocol::boot(store, info, IdealScale::default()).await;
        assert!(matches!(
            p.handle(Request::Hello(Hello::CURRENT)).await,
            Response::Hello(_)
        ));
        let before = p.corrector().live_calibration();
        let put = p
            .handle(Request::PutCalibration(WireCalibration::from(cal)))
            .await;
        let commit = p.handle(Request::CommitCalibration).await;
        let accepted = put == Response::Ack && commit == Response::Ack;
        assert_eq!(
            accepted, plausible,
            "adapter and core disagree: put {put:?}, commit {commit:?}"
        );
        if !accepted {
            assert_eq!(
                p.corrector().live_calibration(),
                before,
                "a refused calibration changed the live one"
            );
            return;
        }
        // Corners and centre of the 10-bit input box stay within the output bound.
        for raw in [[0u16, 0, 0], [1023, 1023, 1023], [0, 1023, 512], [512, 512, 512]] {
            let g = p.corrector().correct(raw).g;
            assert!(
                g.iter().all(|v| v.abs() <= acceptance.output_bound * 1.001),
                "{raw:?} -> {g:?}"
            );
        }
    });
});
