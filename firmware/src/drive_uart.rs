//! The drive UART as the drive link sees it: embedded-hal-nb's serial traits over two byte
//! queues that the board's drive interrupt fills and drains.
//!
//! Contract: `write` queues a byte; [`kick`] (the firmware calls it after each piece of work,
//! `flush` does too) pends the drive interrupt, which runs at once (it has the highest
//! priority) and moves what the hardware takes; the rest goes out from the transmit
//! interrupt; the interrupt notes an answer's end (the line idle after received bytes) for
//! [`take_answered`]. One interrupt per request, not one per byte: a 25-byte PPO4 request cost 25
//! interrupt entries and critical sections, a third of the drive link's step. `read` takes received bytes in order, and reports a line error (noise,
//! framing, parity: seed 000's 0x21) once before the bytes that came with it. [`received`]
//! counts every byte the interrupt took, for the simulated link's lockstep.

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use critical_section::Mutex;
use embedded_hal_nb::serial::{ErrorKind, ErrorType, Read, Write};
use heapless::Deque;

/// The longest request is 33 bytes, the longest answer 25.
const QUEUE_LEN: usize = 64;

static RX: Mutex<RefCell<Deque<u8, QUEUE_LEN>>> = Mutex::new(RefCell::new(Deque::new()));
static TX: Mutex<RefCell<Deque<u8, QUEUE_LEN>>> = Mutex::new(RefCell::new(Deque::new()));
static RECEIVED: AtomicU32 = AtomicU32::new(0);
static LINE_ERROR: AtomicBool = AtomicBool::new(false);
/// Bytes were queued since the drive interrupt last ran.
static QUEUED: AtomicBool = AtomicBool::new(false);
/// The line went idle after received bytes: an answer is complete.
static ANSWERED: AtomicBool = AtomicBool::new(false);

/// The interrupt's side: the line went idle after received bytes.
#[cfg_attr(feature = "sim", allow(dead_code))]
pub fn on_line_idle() {
    ANSWERED.store(true, Ordering::Release);
}

/// Whether an answer completed since the last look.
#[cfg_attr(feature = "sim", allow(dead_code))]
pub fn take_answered() -> bool {
    ANSWERED.swap(false, Ordering::AcqRel)
}

/// Starts sending what `write` queued (the drive interrupt moves it to the hardware).
pub fn kick() {
    if QUEUED.swap(false, Ordering::AcqRel) {
        crate::board::pend_drive_interrupt();
    }
}

/// Bytes the drive interrupt has received since reset.
#[cfg_attr(not(feature = "sim"), allow(dead_code))]
pub fn received() -> u32 {
    RECEIVED.load(Ordering::Acquire)
}

/// The interrupt's side: a received byte (`line_error`: the UART flagged it).
pub fn on_received(byte: u8, line_error: bool) {
    if line_error {
        LINE_ERROR.store(true, Ordering::Relaxed);
    }
    // A full queue cannot happen: the master reads each answer before the next request.
    critical_section::with(|cs| {
        let _ = RX.borrow_ref_mut(cs).push_back(byte);
    });
    RECEIVED.fetch_add(1, Ordering::Release);
}

/// The interrupt's side: the next byte to send, if any.
pub fn next_to_send() -> Option<u8> {
    critical_section::with(|cs| TX.borrow_ref_mut(cs).pop_front())
}

/// The drive link's handle on the UART.
pub struct DriveUart {
    sent: u32,
}

impl DriveUart {
    pub const fn new() -> DriveUart {
        DriveUart { sent: 0 }
    }
}

impl ErrorType for DriveUart {
    type Error = ErrorKind;
}

impl Read<u8> for DriveUart {
    fn read(&mut self) -> nb::Result<u8, ErrorKind> {
        if LINE_ERROR.swap(false, Ordering::Relaxed) {
            return Err(nb::Error::Other(ErrorKind::Noise));
        }
        critical_section::with(|cs| RX.borrow_ref_mut(cs).pop_front()).ok_or(nb::Error::WouldBlock)
    }
}

impl Write<u8> for DriveUart {
    fn write(&mut self, byte: u8) -> nb::Result<(), ErrorKind> {
        critical_section::with(|cs| TX.borrow_ref_mut(cs).push_back(byte))
            .map_err(|_| nb::Error::WouldBlock)?;
        self.sent = self.sent.wrapping_add(1);
        QUEUED.store(true, Ordering::Release);
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), ErrorKind> {
        kick();
        match critical_section::with(|cs| TX.borrow_ref(cs).is_empty()) {
            true => Ok(()),
            false => Err(nb::Error::WouldBlock),
        }
    }
}

impl adapter::CountsSent for DriveUart {
    fn bytes_sent(&self) -> u32 {
        self.sent
    }
}
