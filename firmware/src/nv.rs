//! The adapter's non-volatile storage on this board: crates/nv-store over the flash.
//!
//! Contract: `load` gives what the storage holds, at the Boot; every status the adapter writes passes `note`, and after each event or cycle step
//! `carry_out` writes what the last status asked for (the settings read from the adapter
//! then: 971 stores them as they are). A write that fails is logged and the adapter goes on:
//! its settings stay in force until the next power-up, as a drive's do when its memory fails.
//! Without the `nv-storage` feature (stm32f103-qemu) there is no storage: defaults at every
//! power-up, writes logged.
//!
//! The flash: on the production board the STM32F103's own, its last pages
//! (`board_figures::Memory::nv_storage_origin`), programmed a half-word at a time with the CPU
//! stalled meanwhile (the transceiver answers the bus on its own). Under QEMU, whose flash
//! controllers are not emulated, a host file of the same pages that hal-sim keeps across power
//! cycles (`hal_sim::firmware::NV_STORAGE_FILE`), read and written over semihosting with the
//! same rules (a half-word programmed once between erases).

#[cfg(feature = "nv-storage")]
pub use kept::*;
#[cfg(not(feature = "nv-storage"))]
pub use none::*;

#[cfg(feature = "nv-storage")]
mod kept {
    use core::cell::Cell;
    use critical_section::Mutex;
    use defmt::warn;
    use dp_link::{NvContents, NvWrite, Status};

    /// The write the last status asked for, until it is carried out.
    static PENDING: Mutex<Cell<Option<NvWrite>>> = Mutex::new(Cell::new(None));
    /// What the storage holds, at the Boot. Not read at init: under QEMU, hal-sim puts the
    /// storage's file in place (a scenario's seed, the pages kept over a power cycle) after
    /// the process starts, and before it sends the Boot.
    pub fn load() -> NvContents {
        super::storage::store().load()
    }

    /// A status on its way to the transceiver: its storage write, if any, is carried out next.
    pub fn note(status: &Status) {
        if let Some(write) = status.nv_write {
            critical_section::with(|cs| PENDING.borrow(cs).set(Some(write)));
        }
    }

    /// Writes what the last status asked for.
    pub fn carry_out(adapter: &adapter::Adapter<crate::DriveApp>) {
        let Some(write) = critical_section::with(|cs| PENDING.borrow(cs).take()) else {
            return;
        };
        if super::storage::store()
            .carry_out(write, adapter.nv_params())
            .is_err()
        {
            warn!("storage: the write failed; the settings hold until the next power-up");
        }
    }
}

/// A board without the storage (stm32f103-qemu): the adapter starts from its defaults at
/// every power-up, and a write is only logged. No statics: that board's RAM has none to spare.
#[cfg(not(feature = "nv-storage"))]
mod none {
    use defmt::warn;
    use dp_link::{NvContents, Status};

    pub fn load() -> NvContents {
        NvContents::default()
    }

    pub fn note(status: &Status) {
        if status.nv_write.is_some() {
            warn!("storage: none on this board; the settings hold until the next power-up");
        }
    }

    pub fn carry_out(_: &adapter::Adapter<crate::DriveApp>) {}
}

/// The map over this board's flash.
#[cfg(feature = "nv-storage")]
mod storage {
    const BYTES: u32 = board_figures::NV_STORAGE_BYTES;
    const PAGE: u32 = board_figures::NV_PAGE_BYTES;

    use embedded_storage_async::nor_flash::{
        ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
    };
    use nv_store::Store;

    pub fn store() -> Store<Flash> {
        Store::new(Flash, 0..BYTES)
    }

    /// The storage's pages, at offsets from their start.
    pub struct Flash;

    #[derive(Clone, Copy, Debug, defmt::Format)]
    pub enum FlashError {
        OutOfBounds,
        NotAligned,
        /// The flash refused (a half-word programmed twice, or the controller's error).
        Refused,
    }

    impl NorFlashError for FlashError {
        fn kind(&self) -> NorFlashErrorKind {
            match self {
                FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
                FlashError::NotAligned => NorFlashErrorKind::NotAligned,
                FlashError::Refused => NorFlashErrorKind::Other,
            }
        }
    }

    impl ErrorType for Flash {
        type Error = FlashError;
    }

    fn check(offset: u32, len: usize, align: u32) -> Result<(), FlashError> {
        if offset as usize + len > BYTES as usize {
            return Err(FlashError::OutOfBounds);
        }
        if !offset.is_multiple_of(align) || !(len as u32).is_multiple_of(align) {
            return Err(FlashError::NotAligned);
        }
        Ok(())
    }

    impl ReadNorFlash for Flash {
        const READ_SIZE: usize = 1;

        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            check(offset, bytes.len(), 1)?;
            backend::read(offset, bytes)
        }

        fn capacity(&self) -> usize {
            BYTES as usize
        }
    }

    impl NorFlash for Flash {
        const WRITE_SIZE: usize = 2;
        const ERASE_SIZE: usize = PAGE as usize;

        async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            if from > to {
                return Err(FlashError::NotAligned);
            }
            check(from, (to - from) as usize, PAGE)?;
            (from..to)
                .step_by(PAGE as usize)
                .try_for_each(backend::erase_page)
        }

        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            check(offset, bytes.len(), 2)?;
            for (k, half) in bytes.chunks_exact(2).enumerate() {
                backend::program(
                    offset + 2 * k as u32,
                    u16::from_le_bytes([half[0], half[1]]),
                )?;
            }
            Ok(())
        }
    }

    /// The production board's flash controller (RM0008 section 3.3.3, PM0075).
    #[cfg(not(feature = "sim"))]
    mod backend {
        use super::FlashError;
        use crate::board::pac;

        const KEY1: u32 = 0x4567_0123;
        const KEY2: u32 = 0xCDEF_89AB;
        const ORIGIN: u32 = crate::board::BOARD.memory.nv_storage_origin();

        pub fn read(offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            for (k, b) in bytes.iter_mut().enumerate() {
                // SAFETY: the storage's pages are mapped flash, and no write is under way.
                *b = unsafe { core::ptr::read_volatile((ORIGIN + offset + k as u32) as *const u8) };
            }
            Ok(())
        }

        /// Unlocks the controller for one operation, waits for its end, and locks it again; the
        /// CPU stalls on the flash meanwhile, so the operation runs with the flash busy only here.
        fn operate(start: impl FnOnce(&pac::flash::RegisterBlock)) -> Result<(), FlashError> {
            // SAFETY: the link task is the only one that touches the flash controller.
            let flash = unsafe { &*pac::FLASH::ptr() };
            if flash.cr().read().lock().bit_is_set() {
                flash.keyr().write(|w| unsafe { w.bits(KEY1) });
                flash.keyr().write(|w| unsafe { w.bits(KEY2) });
            }
            start(flash);
            while flash.sr().read().bsy().bit_is_set() {}
            let sr = flash.sr().read();
            let refused = sr.pgerr().bit_is_set() || sr.wrprterr().bit_is_set();
            // The flags clear by writing 1.
            flash
                .sr()
                .write(|w| w.eop().set_bit().pgerr().set_bit().wrprterr().set_bit());
            flash.cr().write(|w| w.lock().set_bit());
            if refused {
                Err(FlashError::Refused)
            } else {
                Ok(())
            }
        }

        pub fn erase_page(offset: u32) -> Result<(), FlashError> {
            operate(|flash| {
                flash.cr().write(|w| w.per().set_bit());
                flash.ar().write(|w| unsafe { w.bits(ORIGIN + offset) });
                flash.cr().write(|w| w.per().set_bit().strt().set_bit());
            })
        }

        pub fn program(offset: u32, half: u16) -> Result<(), FlashError> {
            operate(|flash| {
                flash.cr().write(|w| w.pg().set_bit());
                // SAFETY: a half-word write to the storage's page, with PG set.
                unsafe { core::ptr::write_volatile((ORIGIN + offset) as *mut u16, half) };
            })
        }
    }

    /// Under QEMU: hal-sim's file of the storage's pages, over semihosting.
    #[cfg(feature = "sim")]
    mod backend {
        use super::{FlashError, PAGE};
        use core::sync::atomic::{AtomicUsize, Ordering};
        use cortex_m_semihosting::{nr, syscall};

        /// The file in QEMU's working directory, NUL-terminated (hal-sim's NV_STORAGE_FILE).
        const NAME: &str = "nv-storage.bin\0";
        /// Its handle, opened at first use (0: not yet).
        static HANDLE: AtomicUsize = AtomicUsize::new(0);

        fn handle() -> Result<usize, FlashError> {
            let mut h = HANDLE.load(Ordering::Relaxed);
            if h == 0 {
                // SAFETY: OPEN reads the name (its length without the NUL) and nothing else.
                h = unsafe { syscall!(OPEN, NAME.as_ptr(), nr::open::RW_BINARY, NAME.len() - 1) };
                if h as isize == -1 {
                    return Err(FlashError::Refused);
                }
                HANDLE.store(h, Ordering::Relaxed);
            }
            Ok(h)
        }

        fn seek(h: usize, offset: u32) -> Result<(), FlashError> {
            // SAFETY: SEEK takes the handle and the position only.
            match unsafe { syscall!(SEEK, h, offset as usize) } {
                0 => Ok(()),
                _ => Err(FlashError::Refused),
            }
        }

        pub fn read(offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            let h = handle()?;
            seek(h, offset)?;
            // SAFETY: READ writes at most `bytes.len()` bytes into `bytes`.
            match unsafe { syscall!(READ, h, bytes.as_mut_ptr(), bytes.len()) } {
                0 => Ok(()),
                _ => Err(FlashError::Refused),
            }
        }

        fn write(offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            let h = handle()?;
            seek(h, offset)?;
            // SAFETY: WRITE reads `bytes` and nothing else.
            match unsafe { syscall!(WRITE, h, bytes.as_ptr(), bytes.len()) } {
                0 => Ok(()),
                _ => Err(FlashError::Refused),
            }
        }

        pub fn erase_page(offset: u32) -> Result<(), FlashError> {
            let erased = [0xFFu8; 64];
            (0..PAGE)
                .step_by(erased.len())
                .try_for_each(|k| write(offset + k, &erased))
        }

        /// As the STM32F1's controller: a half-word that is not erased is not programmed (PGERR).
        pub fn program(offset: u32, half: u16) -> Result<(), FlashError> {
            let mut old = [0u8; 2];
            read(offset, &mut old)?;
            if old != [0xFF, 0xFF] {
                return Err(FlashError::Refused);
            }
            write(offset, &half.to_le_bytes())
        }
    }
}
