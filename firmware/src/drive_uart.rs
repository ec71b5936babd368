//! The drive UART as the drive link sees it: embedded-hal-nb's serial traits over two byte
//! queues that the board's drive interrupt fills and drains.
//!
//! Contract: `write` queues a byte; [`kick`] (the firmware calls it after each piece of work,
//! `flush` does too) pends the drive interrupt, which runs at once (it has the highest
//! priority) and moves what the hardware takes; the rest goes out from the transmit
//! interrupt; the interrupt notes an answer's end (the line idle after received bytes) for
//! [`take_answered`]. One interrupt per request, not one per byte: a 25-byte PPO4 request cost
//! 25 interrupt entries, a third of the drive link's step. The queues are heapless's
//! single-producer single-consumer rings, split at init between the drive link
//! ([`LinkEnds`], attached to the [`DriveUart`] at the Boot) and the interrupt
//! ([`InterruptEnds`]): a byte costs no critical section. `read` takes received bytes in
//! order, and reports a line error (noise, framing, parity: seed 000's 0x21) once before the
//! bytes that came with it. [`received`] counts every byte the interrupt took, for the
//! simulated link's lockstep.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use embedded_hal_nb::serial::{ErrorKind, ErrorType, Read, Write};
use heapless::spsc::{Consumer, Producer, Queue};

/// The longest request is 33 bytes, the longest answer 25 (a queue of N holds N - 1).
pub const QUEUE_LEN: usize = 64;

/// A byte queue between the drive link and the drive interrupt: single producer, single
/// consumer, without a critical section (one per byte was a third of the drive link's steps).
pub type ByteQueue = Queue<u8, QUEUE_LEN>;

static RECEIVED: AtomicU32 = AtomicU32::new(0);
static LINE_ERROR: AtomicBool = AtomicBool::new(false);
/// Bytes were queued since the drive interrupt last ran.
static QUEUED: AtomicBool = AtomicBool::new(false);
/// The line went idle after received bytes: an answer is complete.
static ANSWERED: AtomicBool = AtomicBool::new(false);

/// The drive link's ends of the queues: received bytes out, bytes to send in.
pub struct LinkEnds {
    rx: Consumer<'static, u8, QUEUE_LEN>,
    tx: Producer<'static, u8, QUEUE_LEN>,
}

/// The drive interrupt's ends: received bytes in, bytes to send out.
pub struct InterruptEnds {
    rx: Producer<'static, u8, QUEUE_LEN>,
    tx: Consumer<'static, u8, QUEUE_LEN>,
}

/// Splits the two queues (RTIC's init owns them) between the drive link and the interrupt.
pub fn split(rx: &'static mut ByteQueue, tx: &'static mut ByteQueue) -> (LinkEnds, InterruptEnds) {
    let (rx_in, rx_out) = rx.split();
    let (tx_in, tx_out) = tx.split();
    (
        LinkEnds {
            rx: rx_out,
            tx: tx_in,
        },
        InterruptEnds {
            rx: rx_in,
            tx: tx_out,
        },
    )
}

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

impl InterruptEnds {
    /// A received byte (`line_error`: the UART flagged it).
    pub fn on_received(&mut self, byte: u8, line_error: bool) {
        if line_error {
            LINE_ERROR.store(true, Ordering::Relaxed);
        }
        // A full queue cannot happen: the master reads each answer before the next request.
        let _ = self.rx.enqueue(byte);
        RECEIVED.fetch_add(1, Ordering::Release);
    }

    /// The next byte to send, if any.
    pub fn next_to_send(&mut self) -> Option<u8> {
        self.tx.dequeue()
    }
}

/// The drive link's handle on the UART: its ends of the queues from the Boot on (the adapter
/// that owns it is built before, as a constant on the 8 KiB board); before, it neither sends
/// nor receives.
pub struct DriveUart {
    sent: u32,
    ends: Option<LinkEnds>,
}

impl DriveUart {
    pub const fn new() -> DriveUart {
        DriveUart {
            sent: 0,
            ends: None,
        }
    }

    /// Connects the queues.
    pub fn attach(&mut self, ends: LinkEnds) {
        self.ends = Some(ends);
    }
}

impl ErrorType for DriveUart {
    type Error = ErrorKind;
}

impl Read<u8> for DriveUart {
    fn read(&mut self) -> nb::Result<u8, ErrorKind> {
        if LINE_ERROR.load(Ordering::Relaxed) && LINE_ERROR.swap(false, Ordering::Relaxed) {
            return Err(nb::Error::Other(ErrorKind::Noise));
        }
        let ends = self.ends.as_mut().ok_or(nb::Error::WouldBlock)?;
        ends.rx.dequeue().ok_or(nb::Error::WouldBlock)
    }
}

impl Write<u8> for DriveUart {
    fn write(&mut self, byte: u8) -> nb::Result<(), ErrorKind> {
        let ends = self.ends.as_mut().ok_or(nb::Error::WouldBlock)?;
        ends.tx.enqueue(byte).map_err(|_| nb::Error::WouldBlock)?;
        self.sent = self.sent.wrapping_add(1);
        QUEUED.store(true, Ordering::Release);
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), ErrorKind> {
        kick();
        match self.ends.as_ref().is_none_or(|ends| ends.tx.len() == 0) {
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
