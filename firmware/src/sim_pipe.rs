//! The simulation's pipe (QEMU boards only, feature `sim`): hal-sim's next message, read over
//! semihosting while the MCU idles.
//!
//! A frame on the link UART costs QEMU a main-loop turn per byte on its way in (its UARTs take
//! one byte at a time), and the simulation's own messages (`Continue` above all, one per
//! grant of the drive application's cycle) were most of those bytes. hal-sim now writes every
//! message's announcement ([`Next`]) to a host FIFO instead, which the idle loop reads with one
//! semihosting call: QEMU's CPU, and its instruction-counted virtual time, stop in the read
//! until hal-sim writes. The simulation's own messages come whole on the pipe; for a product
//! message ([`Next::OnLink`]) the idle loop waits for its frame on the link UART, as the board
//! would, so the link's interrupt, queue and task run as on the board. The replies (`Done`,
//! the stack's peak) go back on a second FIFO in one write each, where a frame on the UART
//! would cost QEMU a socket write per byte; the product's writes stay on the link UART.
//!
//! The contract with the link task: a message from the pipe waits in [`take`] until the task
//! takes it, and the task calls [`handled`] after each message it has handled, from either
//! source. The idle loop reads the pipe again only when every message announced so far has
//! been handled, so a message never waits behind a blocked read, and hal-sim (which writes
//! the next announcement only after the last message's `Done`) never writes one while a
//! message is still on its way.
//!
//! Nothing here is counted: the counts run from a frame's end or a step's start, in the link
//! task, and the idle loop is below it.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use cortex_m_semihosting::{nr, syscall};
use critical_section::Mutex;
use dp_link::sim::{Next, SimFromAdapter, SimToAdapter, NEXT_MAX_FRAME};
use rtic_sync::channel::Sender;

/// The FIFOs' names in QEMU's working directory, NUL-terminated for semihosting; hal-sim makes
/// them there (`hal_sim::firmware::SIM_PIPE_NEXT` and `SIM_PIPE_REPLIES`).
const NEXT_NAME: &str = "sim-next.fifo\0";
const REPLIES_NAME: &str = "sim-replies.fifo\0";

/// A simulation message from the pipe, until the link task takes it.
static WAITING: Mutex<Cell<Option<SimToAdapter>>> = Mutex::new(Cell::new(None));

/// Messages the link task has handled since power-up, from the pipe and the link UART.
static HANDLED: AtomicU32 = AtomicU32::new(0);

/// The semihosting handles of the two FIFOs, from [`open`] on.
static NEXT: AtomicUsize = AtomicUsize::new(0);
static REPLIES: AtomicUsize = AtomicUsize::new(0);

/// Opens both FIFOs, before the firmware says Ready: hal-sim's first message may come at once.
pub fn open() {
    NEXT.store(open_fifo(NEXT_NAME, nr::open::R_BINARY), Ordering::Relaxed);
    REPLIES.store(
        open_fifo(REPLIES_NAME, nr::open::W_APPEND_BINARY),
        Ordering::Relaxed,
    );
}

fn open_fifo(name: &str, mode: usize) -> usize {
    // SAFETY: OPEN reads the name (its length without the NUL) and nothing else.
    let handle = unsafe { syscall!(OPEN, name.as_ptr(), mode, name.len() - 1) };
    if handle as isize == -1 {
        defmt::panic!("sim: a FIFO from hal-sim is missing in QEMU's directory");
    }
    handle
}

/// The simulation message waiting for the link task, if there is one.
pub fn take() -> Option<SimToAdapter> {
    critical_section::with(|cs| WAITING.borrow(cs).take())
}

/// The link task has handled one message; the idle loop may read the pipe again.
pub fn handled() {
    HANDLED.fetch_add(1, Ordering::Release);
}

/// A reply to hal-sim, framed in `frame` (the link task's), in one write: a FIFO keeps a write
/// of up to PIPE_BUF bytes whole.
pub fn reply(frame: &mut [u8], message: &SimFromAdapter) {
    let Ok(bytes) = dp_link::encode(message, frame) else {
        defmt::panic!("sim: a reply does not fit a frame");
    };
    let handle = REPLIES.load(Ordering::Relaxed);
    // SAFETY: WRITE reads `bytes` and nothing else.
    let not_written = unsafe { syscall!(WRITE, handle, bytes.as_ptr(), bytes.len()) };
    if not_written != 0 {
        // Plain messages: the emulated production board's flash has no room for arguments.
        defmt::panic!("sim: hal-sim took only part of a reply");
    }
}

/// The idle loop under simulation: announcement by announcement, each handled by the link task
/// before the next read. `wake` is the link task's.
pub fn serve(wake: &mut Sender<'static, (), 1>) -> ! {
    let mut pipe = Pipe {
        bytes: [0; NEXT_MAX_FRAME],
        len: 0,
    };
    // Counted here, not read from HANDLED before a read: a product message's frame may have
    // come and been handled before the idle loop read its announcement.
    let mut announced = 0u32;
    loop {
        let next = pipe.next();
        announced = announced.wrapping_add(1);
        match next {
            Next::OnLink => {}
            Next::Sim(message) => {
                critical_section::with(|cs| WAITING.borrow(cs).set(Some(message)));
                // Full: a wake-up is pending already, which finds the message too.
                let _ = wake.try_send(());
            }
        }
        // The link task is above the idle loop, so this is the wait for the link UART's
        // frame (which may have been handled already); a message from the pipe is handled
        // before the send returns.
        while !all_handled(announced) {
            // Interrupts masked between the look and the sleep: an interrupt that came just
            // before the sleep would otherwise leave it waiting for one that never comes. A
            // masked interrupt still ends the sleep, and is taken when they are unmasked.
            cortex_m::interrupt::free(|_| {
                if !all_handled(announced) {
                    cortex_m::asm::wfi();
                }
            });
        }
    }
}

/// Whether the link task has handled the first `announced` messages.
fn all_handled(announced: u32) -> bool {
    HANDLED.load(Ordering::Acquire).wrapping_sub(announced) as i32 >= 0
}

/// The bytes read from the announcements' FIFO past the last frame.
struct Pipe {
    bytes: [u8; NEXT_MAX_FRAME],
    len: usize,
}

impl Pipe {
    /// The next announcement, blocking until hal-sim writes it.
    fn next(&mut self) -> Next {
        loop {
            if let Some(end) = self.bytes[..self.len].iter().position(|b| *b == 0) {
                // Decoded in place (`Next` borrows nothing), then the bytes after it move up.
                let next = dp_link::decode::<Next>(&mut self.bytes[..=end]);
                self.bytes.copy_within(end + 1..self.len, 0);
                self.len -= end + 1;
                match next {
                    Ok(next) => return next,
                    Err(_) => defmt::panic!("sim: a pipe frame that is no announcement"),
                }
            }
            let room = &mut self.bytes[self.len..];
            if room.is_empty() {
                defmt::panic!("sim: a pipe frame longer than NEXT_MAX_FRAME");
            }
            let handle = NEXT.load(Ordering::Relaxed);
            // SAFETY: READ writes at most `room.len()` bytes into `room`.
            let not_read = unsafe { syscall!(READ, handle, room.as_mut_ptr(), room.len()) };
            let read = room.len().saturating_sub(not_read);
            if read == 0 {
                defmt::panic!("sim: hal-sim closed the pipe");
            }
            self.len += read;
        }
    }
}
