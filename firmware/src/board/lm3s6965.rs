//! The QEMU board, `lm3s6965evb`: UART0 carries the transceiver link (QEMU's first `-serial`),
//! UART1 the drive link (the second `-serial`; QEMU does not pace it, hal-sim puts it on
//! simulated time), defmt goes out over semihosting, and panics exit QEMU with a failure code.
//!
//! The `lm3s6965` crate is the device crate RTIC's own QEMU examples use; it defines the
//! interrupts only, not the registers, so the few UART registers are written here (no
//! register-level PAC for this part is published).

pub use lm3s6965 as pac;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// This board's row of the board table.
pub const BOARD: &board_figures::Board = &board_figures::LM3S6965_QEMU;

/// QEMU's `-icount shift=7`: every instruction takes 2^7 ns of virtual time.
const ICOUNT_NS_PER_INSTRUCTION: u32 = 128;
/// SysTick on the processor clock: QEMU's lm3s6965evb runs it at 12.5 MHz.
const SYSTICK_NS: u32 = 80;

/// A PL011-style UART of the Stellaris part.
pub struct Uart {
    base: usize,
}

const UART0_BASE: usize = 0x4000_C000;
const UART1_BASE: usize = 0x4000_D000;
const DR: usize = 0x000;
const FR: usize = 0x018;
const LCRH: usize = 0x02C;
const CTL: usize = 0x030;
const IM: usize = 0x038;
const MIS: usize = 0x040;
const ICR: usize = 0x044;
const FR_RXFE: u32 = 1 << 4;
const FR_TXFF: u32 = 1 << 5;
const LCRH_WLEN8_FEN: u32 = 0x70;
const CTL_UARTEN_TXE_RXE: u32 = 0x301;
const INT_RX_RT: u32 = (1 << 4) | (1 << 6);
/// The receive timeout: the line idle after received bytes.
const INT_RT: u32 = 1 << 6;
const INT_TX: u32 = 1 << 5;
/// 8 bits, even parity, FIFOs on: Modbus RTU's 8E1.
const LCRH_WLEN8_FEN_EVEN_PARITY: u32 = 0x76;
/// DR's error bits: overrun, break, parity, framing.
const DR_ERRORS: u32 = 0xF00;

/// The drive link's interrupt.
pub const DRIVE_INTERRUPT: pac::Interrupt = pac::Interrupt::UART1;

impl Uart {
    fn read(&self, offset: usize) -> u32 {
        // SAFETY: `base + offset` is a UART register of this part, always mapped and readable.
        unsafe { core::ptr::read_volatile((self.base + offset) as *const u32) }
    }

    fn write(&self, offset: usize, value: u32) {
        // SAFETY: as in `read`; only this driver touches the UART it owns.
        unsafe { core::ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// The next received byte, if the FIFO holds one.
    pub fn read_byte(&mut self) -> Option<u8> {
        (self.read(FR) & FR_RXFE == 0).then(|| self.read(DR) as u8)
    }

    /// Sends a frame a byte at a time (QEMU's UART takes them at once; hal-sim charges the
    /// production board's link).
    pub fn write_frame(&mut self, bytes: &[u8]) {
        bytes.iter().for_each(|b| self.write_byte(*b));
    }

    /// Sends one byte, waiting while the FIFO is full.
    fn write_byte(&mut self, byte: u8) {
        while self.read(FR) & FR_TXFF != 0 {}
        self.write(DR, u32::from(byte));
    }

    /// Acknowledges the receive and receive-timeout interrupts.
    pub fn clear_rx_interrupt(&mut self) {
        self.write(ICR, INT_RX_RT);
    }
}

/// The drive interrupt's work: received bytes in, queued bytes out while the FIFO takes them,
/// the transmit interrupt on only while bytes wait. Returns whether the receive timeout came
/// (the line idle after received bytes: the drive's answer is complete).
pub fn drive_interrupt(queues: &mut crate::drive_uart::InterruptEnds) -> bool {
    let uart = Uart { base: UART1_BASE };
    let idle = uart.read(MIS) & INT_RT != 0;
    uart.write(ICR, INT_RX_RT | INT_TX);
    while uart.read(FR) & FR_RXFE == 0 {
        let data = uart.read(DR);
        queues.on_received(data as u8, data & DR_ERRORS != 0);
    }
    let mut waiting = false;
    while uart.read(FR) & FR_TXFF == 0 {
        match queues.next_to_send() {
            Some(byte) => uart.write(DR, u32::from(byte)),
            None => break,
        }
    }
    if uart.read(FR) & FR_TXFF != 0 {
        waiting = true;
    }
    uart.write(IM, INT_RX_RT | if waiting { INT_TX } else { 0 });
    idle
}

/// Runs the drive interrupt (after bytes were queued to send).
pub fn pend_drive_interrupt() {
    cortex_m::peripheral::NVIC::pend(DRIVE_INTERRUPT);
}

/// What `init` hands to the app.
pub struct Board {
    /// The receive half of the link UART (the hardware task's).
    pub link: Uart,
}

/// The transmit half of the link UART (the link task's). Receiving reads DR and FR and writes
/// ICR, transmitting writes DR and reads FR: the two halves never disturb each other.
pub fn link_tx() -> Uart {
    Uart { base: UART0_BASE }
}

/// Sets up the link UART with receive interrupts and SysTick as a free-running cycle counter.
pub fn init(core: cortex_m::Peripherals, _device: pac::Peripherals) -> Board {
    let mut syst = core.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
    let link = Uart { base: UART0_BASE };
    link.write(LCRH, LCRH_WLEN8_FEN);
    link.write(IM, INT_RX_RT);
    link.write(CTL, CTL_UARTEN_TXE_RXE);
    let drive = Uart { base: UART1_BASE };
    drive.write(LCRH, LCRH_WLEN8_FEN_EVEN_PARITY);
    drive.write(IM, INT_RX_RT);
    drive.write(CTL, CTL_UARTEN_TXE_RXE);
    Board { link }
}

/// A timestamp for [`cycles_since`].
pub fn timestamp() -> u32 {
    SYST::get_current()
}

/// CPU cycles since `start`, counting one per instruction as QEMU's icount does: SysTick
/// ticks of 80 ns, at 128 ns per instruction. Repeatable under `-icount shift=7`.
pub fn cycles_since(start: u32) -> u32 {
    let ticks = start.wrapping_sub(SYST::get_current()) & 0x00FF_FFFF;
    ticks * SYSTICK_NS / ICOUNT_NS_PER_INSTRUCTION
}

/// Ends the QEMU run with a failure code (panic, HardFault).
/// After a failed RAM test: QEMU exits with a failure code, as for a panic.
pub fn halt_ram_fault() -> ! {
    exit_failure()
}

pub fn exit_failure() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

// The adapter's RTIC app on this board's interrupts: the link UART, the drive UART, and a
// free one that runs the software tasks.
crate::adapter_app!(UART0, UART1, GPIOA);
