//! The adapter's non-volatile storage: the station address record (Set_Slave_Add, 918) and
//! the settings 971 keeps (927, 928, 930, 933-943), in NOR flash.
//!
//! Contract:
//! - [`Store`] keeps two items, by key, in a [`sequential_storage`] map over any NOR flash
//!   (the STM32F103's own on the production board, a host file under QEMU, memory in-process):
//!   the map writes a new item after the old one, pages in turn (wear levelling), each with a
//!   CRC, and a page is erased only once its items are copied on. A write cut at any point
//!   leaves the old value or the new one, never neither and never a mix: the power-cut test
//!   below cuts a write at every byte and every erase.
//! - [`Store::load`] gives what the storage holds; an item that does not read back (the
//!   flash's contents are from another layout or damaged) is as if never written: the
//!   adapter starts from its defaults, and the next write puts things right.
//! - Values are postcard, as on the link: the records are dp-link's.
//! - [`block_on`] drives the crate's futures: every flash here completes its operation within
//!   the call (a NOR flash programs and erases synchronously, the CPU stalled meanwhile), so a
//!   future is ready on its first poll and an executor would add nothing but code.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]

use core::future::Future;
use core::ops::Range;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use dp_link::{NvContents, NvParams, NvRecord, NvWrite};
use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage, SerializationError};

#[cfg(any(test, feature = "std"))]
mod mem_flash;
#[cfg(any(test, feature = "std"))]
pub use mem_flash::{MemFlash, PAGE_BYTES, WRITE_BYTES};

/// The items' keys.
const KEY_ADDRESS: u8 = 1;
const KEY_PARAMS: u8 = 2;

/// The buffer an item is written and read through: a key and the longest value, postcard, with
/// the flash's word alignment to spare (NvParams: 13 varints of up to 3 bytes).
const BUFFER_LEN: usize = 48;

/// Why the storage could not be read or written.
pub type Error<E> = sequential_storage::Error<E>;

/// The storage over `flash`, in `range` of it (whole erase pages, at least two).
pub struct Store<F: NorFlash> {
    map: MapStorage<u8, F, Cache<Uncached, Uncached, Uncached, u8>>,
    buffer: Aligned,
}

/// Some flashes program from word-aligned RAM only.
#[repr(align(4))]
struct Aligned([u8; BUFFER_LEN]);

impl<F: NorFlash> Store<F> {
    /// # Panics
    /// Where `range` is not whole pages of `flash`, or fewer than two.
    pub fn new(flash: F, range: Range<u32>) -> Store<F> {
        Store {
            map: MapStorage::new(flash, MapConfig::new(range), Cache::new_uncached()),
            buffer: Aligned([0; BUFFER_LEN]),
        }
    }

    /// What the storage holds: each record that reads back.
    pub fn load(&mut self) -> NvContents {
        NvContents {
            address: self.fetch::<NvRecord>(KEY_ADDRESS),
            params: self.fetch::<Option<NvParams>>(KEY_PARAMS).flatten(),
        }
    }

    /// Every item is bytes to the map and postcard to us: one instance of the map's generic
    /// fetch and store serves every record (each instance is kilobytes of a board's flash).
    fn fetch<T: serde::de::DeserializeOwned>(&mut self, key: u8) -> Option<T> {
        let fetched = block_on(self.map.fetch_item::<&[u8]>(&mut self.buffer.0, &key));
        postcard::from_bytes(fetched.ok().flatten()?).ok()
    }

    fn store<T: serde::Serialize>(&mut self, key: u8, value: &T) -> Result<(), Error<F::Error>> {
        let mut bytes = [0u8; BUFFER_LEN];
        let used: &[u8] = postcard::to_slice(value, &mut bytes)
            .map_err(|_| Error::SerializationError(SerializationError::BufferTooSmall))?;
        block_on(self.map.store_item(&mut self.buffer.0, &key, &used))
    }

    /// Keeps the station address record.
    pub fn write_address(&mut self, record: NvRecord) -> Result<(), Error<F::Error>> {
        self.store(KEY_ADDRESS, &record)
    }

    /// Keeps the settings (971).
    pub fn write_params(&mut self, params: NvParams) -> Result<(), Error<F::Error>> {
        self.store(KEY_PARAMS, &Some(params))
    }

    /// Forgets the settings: the next power-up has their defaults (switch 99). Written as an
    /// item of its own (no settings), not a removal: removing marks an item written already,
    /// a second programming the STM32F1's flash allows only as all zeros.
    pub fn forget_params(&mut self) -> Result<(), Error<F::Error>> {
        self.store(KEY_PARAMS, &None::<NvParams>)
    }

    /// Carries out the write a status asked for: `params` are the adapter's settings now
    /// (971 stores them as they are).
    pub fn carry_out(
        &mut self,
        write: NvWrite,
        params: Option<NvParams>,
    ) -> Result<(), Error<F::Error>> {
        match write {
            NvWrite::Address(record) => self.write_address(record),
            NvWrite::Params => params.map_or(Ok(()), |p| self.write_params(p)),
            NvWrite::FactoryDefaults(record) => {
                self.write_address(record)?;
                self.forget_params()
            }
        }
    }

    /// The flash back (the host's view of what a board would keep).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}

/// Runs `future` to its end on this thread. Every flash of this crate's users completes an
/// operation within its call, so the first poll finishes it; a future that is not ready is
/// polled again (no waker is needed: nothing else could wake it).
pub fn block_on<T>(future: impl Future<Output = T>) -> T {
    let mut future = pin!(future);
    let mut context = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(value) = future.as_mut().poll(&mut context) {
            return value;
        }
    }
}

#[cfg(test)]
mod tests;
