//! A NOR flash in memory with the production board's geometry (the STM32F103's: pages of
//! 1 KiB, programmed a half-word at a time, each once between erases), for the host: hal-sim
//! keeps the simulated boards' storage in one and hands its bytes to QEMU's, and reads back
//! what a firmware wrote.

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// The flash's page, its erase unit.
pub const PAGE_BYTES: usize = 1024;
/// Its programming unit.
pub const WRITE_BYTES: usize = 2;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemFlash {
    pub bytes: Vec<u8>,
}

impl MemFlash {
    /// `pages` erased pages.
    pub fn erased(pages: usize) -> MemFlash {
        MemFlash {
            bytes: vec![0xFF; pages * PAGE_BYTES],
        }
    }
}

/// A programming or erase the flash refuses, as the STM32's controller does (PGERR, out of
/// range or misaligned).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemFlashError {
    OutOfBounds,
    NotAligned,
    /// A half-word programmed twice without an erase.
    NotErased(u32),
}

impl NorFlashError for MemFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            MemFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            MemFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            MemFlashError::NotErased(_) => NorFlashErrorKind::Other,
        }
    }
}

impl ErrorType for MemFlash {
    type Error = MemFlashError;
}

impl ReadNorFlash for MemFlash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), MemFlashError> {
        let at = offset as usize;
        let from = self
            .bytes
            .get(at..at + bytes.len())
            .ok_or(MemFlashError::OutOfBounds)?;
        bytes.copy_from_slice(from);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.bytes.len()
    }
}

impl NorFlash for MemFlash {
    const WRITE_SIZE: usize = WRITE_BYTES;
    const ERASE_SIZE: usize = PAGE_BYTES;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), MemFlashError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE_BYTES) || !to.is_multiple_of(PAGE_BYTES) || from > to {
            return Err(MemFlashError::NotAligned);
        }
        self.bytes
            .get_mut(from..to)
            .ok_or(MemFlashError::OutOfBounds)?
            .fill(0xFF);
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), MemFlashError> {
        let at = offset as usize;
        if !at.is_multiple_of(WRITE_BYTES) || !bytes.len().is_multiple_of(WRITE_BYTES) {
            return Err(MemFlashError::NotAligned);
        }
        let to = self
            .bytes
            .get_mut(at..at + bytes.len())
            .ok_or(MemFlashError::OutOfBounds)?;
        for (k, (old, new)) in to
            .chunks_exact_mut(WRITE_BYTES)
            .zip(bytes.chunks_exact(WRITE_BYTES))
            .enumerate()
        {
            if old.iter().any(|&b| b != 0xFF) {
                return Err(MemFlashError::NotErased((at + k * WRITE_BYTES) as u32));
            }
            old.copy_from_slice(new);
        }
        Ok(())
    }
}
