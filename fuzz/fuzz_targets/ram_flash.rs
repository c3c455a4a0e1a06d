//! The flash of the fuzz targets that drive the adapter's calibration store
//! (`calibration_put`, `gyro_calibration_put`): a RAM NOR flash of [`PAGES`] pages of [`PAGE`]
//! bytes, programmed as NOR flash is (programming clears bits, erase sets a page to 0xFF).

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

pub const PAGE: usize = 512;
pub const PAGES: usize = 4;

/// A RAM NOR flash (programming clears bits, erase sets a page to 0xFF).
pub struct RamFlash(pub Vec<u8>);

#[derive(Debug)]
pub struct RamError;

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
