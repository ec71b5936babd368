//! The production board: an STM32F103CB at 72 MHz (8 MHz crystal, PLL x9). USART1 (PA9 TX,
//! PA10 RX) carries the link to the transceiver FPGA at 4.5 Mbit/s, the fastest USART1 runs at
//! 72 MHz. It receives by DMA (DMA1 channel 5, round and round a ring) and interrupts once a
//! frame, on the idle character the transceiver leaves after each: a byte every 2.2 µs is 160
//! cycles, and an interrupt per byte would take most of them. It sends by DMA too (channel 4,
//! a frame at a time), so the MCU waits only for a frame still going out; USART2 (PA2 TX, PA3 RX) the Modbus RTU link to the drive at 2.25 Mbit/s 8E1, the
//! fastest exact rate of APB1's 36 MHz. defmt goes out over RTT; a panic resets the chip.
//!
//! The rotary switch, the address EEPROM and the LEDs hang on the FPGA, which reads the switch
//! and the storage into the Boot message, writes the storage from `Status::nv_write` and drives
//! the LEDs from `Status::leds`: the firmware is the same on both boards.
//!
//! With feature `stm32f103-qemu` the same code runs on QEMU's `stm32vldiscovery`, which differs
//! from the part where the emulator forces it, and only there (README "The production board
//! under emulation"): its RCC reads 0, so the clock start-up does not wait for ready flags; it
//! has no DMA, so USART1 receives a byte per RXNE interrupt and sends polling TXE; it has no
//! DWT, so SysTick counts the cycles; 8 KiB of RAM (the memory map comes from the board table),
//! which holds the adapter only as the image's initial data (feature `adapter-in-image`) and a
//! link queue of two frames; defmt and a failure exit go over semihosting, as no probe reads
//! RTT.

pub use stm32f1::stm32f103 as pac;

#[cfg(not(feature = "stm32f103-qemu"))]
use cortex_m::peripheral::DWT;

/// This board's row of the board table.
#[cfg(not(feature = "stm32f103-qemu"))]
pub const BOARD: &board_figures::Board = &board_figures::STM32F103;
#[cfg(feature = "stm32f103-qemu")]
pub const BOARD: &board_figures::Board = &board_figures::STM32F103_QEMU;

/// The clock and the link rate come from the board's figures, the ones hal-sim charges.
const SYSCLK_HZ: u32 = board_figures::STM32F103.mcu_clock_hz;
const LINK_BAUD: u32 = board_figures::STM32F103.link.bit_rate;

// RCC_CR
const HSEON: u32 = 1 << 16;
const HSERDY: u32 = 1 << 17;
const PLLON: u32 = 1 << 24;
const PLLRDY: u32 = 1 << 25;
// RCC_CFGR: PLL from HSE, x9; APB1 /2 (36 MHz at most); system clock from the PLL.
const CFGR_PLLSRC_HSE: u32 = 1 << 16;
const CFGR_PLLMUL_9: u32 = 0b0111 << 18;
const CFGR_PPRE1_DIV2: u32 = 0b100 << 8;
const CFGR_SW_PLL: u32 = 0b10;
const CFGR_SWS_MASK: u32 = 0b11 << 2;
const CFGR_SWS_PLL: u32 = 0b10 << 2;
// FLASH_ACR: two wait states above 48 MHz, prefetch on.
const ACR_LATENCY_2_PRFTBE: u32 = 0b010 | (1 << 4);
// RCC_APB2ENR
const IOPAEN: u32 = 1 << 2;
const USART1EN: u32 = 1 << 14;
// RCC_APB1ENR
const USART2EN: u32 = 1 << 17;
// GPIOA_CRL, pin 2: alternate function push-pull, 50 MHz.
const CRL_PIN2_MASK: u32 = 0xF << 8;
const CRL_PIN2_AF_PP_50MHZ: u32 = 0xB << 8;
const APB1_HZ: u32 = 36_000_000;
const DRIVE_BAUD: u32 = 2_250_000;
// USART_SR error flags: parity, framing, noise, overrun.
const SR_ERRORS: u16 = 0b1111;
// USART_CR1: 9-bit words with parity (8 data + even parity), TXE interrupt.
const CR1_M_PCE: u16 = (1 << 12) | (1 << 10);
const CR1_TXEIE: u16 = 1 << 7;

/// The drive link's interrupt.
pub const DRIVE_INTERRUPT: pac::Interrupt = pac::Interrupt::USART2;
// GPIOA_CRH, pin 9: alternate function push-pull, 50 MHz.
const CRH_PIN9_MASK: u32 = 0xF << 4;
const CRH_PIN9_AF_PP_50MHZ: u32 = 0xB << 4;
// USART
const SR_RXNE: u16 = 1 << 5;
const SR_TXE: u16 = 1 << 7;
// The line idle for a character after received bytes: an answer's end.
const SR_IDLE: u16 = 1 << 4;
const CR1_IDLEIE: u16 = 1 << 4;
const CR1_UE_TE_RE_RXNEIE: u16 = (1 << 13) | (1 << 3) | (1 << 2) | (1 << 5);
// USART1 for the link: no receive interrupt, the idle-line one instead; receive by DMA.
#[cfg(not(feature = "stm32f103-qemu"))]
const CR1_UE_TE_RE_IDLEIE: u16 = (1 << 13) | (1 << 3) | (1 << 2) | (1 << 4);
#[cfg(not(feature = "stm32f103-qemu"))]
const CR3_DMAR_DMAT: u16 = (1 << 6) | (1 << 7);
// RCC_AHBENR
#[cfg(not(feature = "stm32f103-qemu"))]
const DMA1EN: u32 = 1 << 0;
// DMA_CCR: memory increment, circular, priority high, enable (peripheral to memory, bytes).
#[cfg(not(feature = "stm32f103-qemu"))]
const CCR_MINC_CIRC_PL_HIGH_EN: u32 = (1 << 7) | (1 << 5) | (0b10 << 12) | 1;

#[cfg(not(feature = "stm32f103-qemu"))]
const CCR_EN: u32 = 1;
// DMA_CCR for sending: memory increment, memory to peripheral, enable.
#[cfg(not(feature = "stm32f103-qemu"))]
const CCR_MINC_DIR_EN: u32 = (1 << 7) | (1 << 4) | 1;

/// The link's transmit buffer, read by DMA1 channel 4: one frame.
#[cfg(not(feature = "stm32f103-qemu"))]
const TX_BUF_LEN: usize = dp_link::MAX_FRAME_LEN;
#[cfg(not(feature = "stm32f103-qemu"))]
static mut TX_BUF: [u8; TX_BUF_LEN] = [0; TX_BUF_LEN];

/// The link's receive ring, written by DMA1 channel 5.
#[cfg(not(feature = "stm32f103-qemu"))]
const RX_RING_LEN: usize = 512;
#[cfg(not(feature = "stm32f103-qemu"))]
static mut RX_RING: [u8; RX_RING_LEN] = [0; RX_RING_LEN];

/// One half of USART1 (receive in the interrupt, transmit in the link task).
pub struct Uart {
    /// The next byte of the ring to read.
    #[cfg(not(feature = "stm32f103-qemu"))]
    read_at: usize,
}

#[cfg(not(feature = "stm32f103-qemu"))]
fn tx_dma() -> &'static pac::dma1::CH {
    // SAFETY: DMA1's register block is always mapped; channel 4 is the link's transmit
    // channel, used by `Uart::write_frame` only (the link task's).
    unsafe { (*pac::DMA1::ptr()).ch4() }
}

#[cfg(not(feature = "stm32f103-qemu"))]
fn rx_dma() -> &'static pac::dma1::CH {
    // SAFETY: DMA1's register block is always mapped; channel 5 is the link's receive ring,
    // set up once in `init` and only read (its count) afterwards.
    unsafe { (*pac::DMA1::ptr()).ch5() }
}

fn usart1() -> &'static pac::usart1::RegisterBlock {
    // SAFETY: USART1's register block is always mapped; the receive half reads SR and DR, the
    // transmit half polls SR.TXE and writes DR, so the two never step on each other.
    unsafe { &*pac::USART1::ptr() }
}

#[cfg(not(feature = "stm32f103-qemu"))]
impl Uart {
    /// The next received byte, if one is waiting in the ring.
    pub fn read_byte(&mut self) -> Option<u8> {
        // The channel counts down from the ring's length and reloads at zero.
        let written = RX_RING_LEN - rx_dma().ndtr().read().bits() as usize;
        if self.read_at == written {
            return None;
        }
        // SAFETY: in the ring's bounds; the DMA writes ahead of `read_at`, not at it. The ring
        // is only ever read through this volatile read.
        let byte = unsafe {
            core::ptr::read_volatile(core::ptr::addr_of!(RX_RING).cast::<u8>().add(self.read_at))
        };
        self.read_at = (self.read_at + 1) % RX_RING_LEN;
        Some(byte)
    }

    /// Sends a frame by DMA (channel 4) from the transmit buffer. Only a frame still going out
    /// is waited for, as the buffer holds one; the MCU goes on while this one leaves.
    pub fn write_frame(&mut self, bytes: &[u8]) {
        let tx = tx_dma();
        while tx.cr().read().bits() & CCR_EN != 0 && tx.ndtr().read().bits() != 0 {}
        let len = bytes.len().min(TX_BUF_LEN);
        // SAFETY: the channel is off or done, so nothing reads the buffer now; the channel
        // only ever reads it, after the writes below.
        unsafe {
            tx.cr().write(|w| w.bits(0));
            let buf = core::ptr::addr_of_mut!(TX_BUF).cast::<u8>();
            core::ptr::copy_nonoverlapping(bytes.as_ptr(), buf, len);
            tx.mar().write(|w| w.bits(buf as u32));
            tx.ndtr().write(|w| w.bits(len as u32));
            tx.cr().write(|w| w.bits(CCR_MINC_DIR_EN));
        }
    }

    /// The idle-line flag clears by reading SR, then DR. The line is idle, so DR holds no byte
    /// the DMA has not taken.
    pub fn clear_rx_interrupt(&mut self) {
        let u = usart1();
        let _ = u.sr().read();
        let _ = u.dr().read();
    }
}

/// USART1 without DMA, under QEMU (which models none): a byte per RXNE interrupt in, a byte at
/// a time out while TXE says the data register is free.
#[cfg(feature = "stm32f103-qemu")]
impl Uart {
    /// The received byte, if the data register holds one (reading DR clears RXNE).
    pub fn read_byte(&mut self) -> Option<u8> {
        let u = usart1();
        (u.sr().read().bits() & SR_RXNE != 0).then(|| u.dr().read().bits() as u8)
    }

    /// Sends a frame a byte at a time.
    pub fn write_frame(&mut self, bytes: &[u8]) {
        let u = usart1();
        for byte in bytes {
            while u.sr().read().bits() & SR_TXE == 0 {}
            // SAFETY: any 8-bit value is a valid DR write.
            u.dr().write(|w| unsafe { w.bits(u16::from(*byte)) });
        }
    }

    /// RXNE clears as `read_byte` reads DR: nothing to acknowledge.
    pub fn clear_rx_interrupt(&mut self) {}
}

fn usart2() -> &'static pac::usart1::RegisterBlock {
    // SAFETY: USART2's register block is always mapped; only the drive interrupt touches it.
    unsafe { &*pac::USART2::ptr() }
}

/// The drive interrupt's work: a received byte in, queued bytes out while the data register
/// is empty (on the part, one or two: the shift register takes the first at once; under QEMU,
/// whose TXE never clears, all of them), the TXE interrupt on only while bytes wait. Returns
/// whether the line went idle after received bytes (the drive's answer is complete).
pub fn drive_interrupt(queues: &mut crate::drive_uart::InterruptEnds) -> bool {
    let u = usart2();
    let sr = u.sr().read().bits();
    if sr & SR_RXNE != 0 {
        // Reading SR then DR clears the error flags with RXNE, and IDLE.
        let byte = u.dr().read().bits() as u8;
        queues.on_received(byte, sr & SR_ERRORS != 0);
    } else if sr & SR_IDLE != 0 {
        // SR then DR clears IDLE; DR holds nothing new.
        let _ = u.dr().read();
    }
    let mut waiting = false;
    while u.sr().read().bits() & SR_TXE != 0 {
        let Some(byte) = queues.next_to_send() else {
            waiting = false;
            break;
        };
        // SAFETY: any 8-bit value is a valid DR write.
        u.dr().write(|w| unsafe { w.bits(u16::from(byte)) });
        waiting = true;
    }
    let cr1 = CR1_UE_TE_RE_RXNEIE | CR1_IDLEIE | CR1_M_PCE | if waiting { CR1_TXEIE } else { 0 };
    // SAFETY: the documented CR1 bits named above.
    u.cr1().write(|w| unsafe { w.bits(cr1) });
    sr & SR_IDLE != 0
}

/// Runs the drive interrupt (after bytes were queued to send).
pub fn pend_drive_interrupt() {
    cortex_m::peripheral::NVIC::pend(DRIVE_INTERRUPT);
}

pub struct Board {
    pub link: Uart,
}

pub fn link_tx() -> Uart {
    Uart {
        #[cfg(not(feature = "stm32f103-qemu"))]
        read_at: 0,
    }
}

/// Waits for a clock to report ready. QEMU's stm32vldiscovery models no RCC (it reads 0, so
/// no ready flag ever sets): the profile goes on at once.
fn wait_until(ready: impl Fn() -> bool) {
    if cfg!(not(feature = "stm32f103-qemu")) {
        while !ready() {}
    }
}

/// 72 MHz from the crystal, USART1 at 4.5 Mbit/s receiving by DMA, the DWT cycle
/// counter for turnaround figures.
pub fn init(mut core: cortex_m::Peripherals, device: pac::Peripherals) -> Board {
    let rcc = &device.RCC;
    // SAFETY (all `bits` writes below): the values are the documented bit patterns named above.
    rcc.cr().modify(|r, w| unsafe { w.bits(r.bits() | HSEON) });
    wait_until(|| rcc.cr().read().bits() & HSERDY != 0);
    device
        .FLASH
        .acr()
        .write(|w| unsafe { w.bits(ACR_LATENCY_2_PRFTBE) });
    rcc.cfgr()
        .write(|w| unsafe { w.bits(CFGR_PLLSRC_HSE | CFGR_PLLMUL_9 | CFGR_PPRE1_DIV2) });
    rcc.cr().modify(|r, w| unsafe { w.bits(r.bits() | PLLON) });
    wait_until(|| rcc.cr().read().bits() & PLLRDY != 0);
    rcc.cfgr()
        .modify(|r, w| unsafe { w.bits(r.bits() | CFGR_SW_PLL) });
    wait_until(|| rcc.cfgr().read().bits() & CFGR_SWS_MASK == CFGR_SWS_PLL);

    rcc.apb2enr()
        .modify(|r, w| unsafe { w.bits(r.bits() | IOPAEN | USART1EN) });
    device
        .GPIOA
        .crh()
        .modify(|r, w| unsafe { w.bits((r.bits() & !CRH_PIN9_MASK) | CRH_PIN9_AF_PP_50MHZ) });
    let usart = &device.USART1;
    usart
        .brr()
        .write(|w| unsafe { w.bits((SYSCLK_HZ / LINK_BAUD) as u16) });
    #[cfg(not(feature = "stm32f103-qemu"))]
    {
        rcc.ahbenr()
            .modify(|r, w| unsafe { w.bits(r.bits() | DMA1EN) });
        let rx = device.DMA1.ch5();
        rx.par()
            .write(|w| unsafe { w.bits(usart.dr().as_ptr() as u32) });
        rx.mar()
            .write(|w| unsafe { w.bits(core::ptr::addr_of!(RX_RING) as u32) });
        rx.ndtr().write(|w| unsafe { w.bits(RX_RING_LEN as u32) });
        rx.cr()
            .write(|w| unsafe { w.bits(CCR_MINC_CIRC_PL_HIGH_EN) });
        let tx = device.DMA1.ch4();
        tx.par()
            .write(|w| unsafe { w.bits(usart.dr().as_ptr() as u32) });
        usart.cr3().write(|w| unsafe { w.bits(CR3_DMAR_DMAT) });
        usart
            .cr1()
            .write(|w| unsafe { w.bits(CR1_UE_TE_RE_IDLEIE) });
    }
    #[cfg(feature = "stm32f103-qemu")]
    usart
        .cr1()
        .write(|w| unsafe { w.bits(CR1_UE_TE_RE_RXNEIE) });

    rcc.apb1enr()
        .modify(|r, w| unsafe { w.bits(r.bits() | USART2EN) });
    device
        .GPIOA
        .crl()
        .modify(|r, w| unsafe { w.bits((r.bits() & !CRL_PIN2_MASK) | CRL_PIN2_AF_PP_50MHZ) });
    let drive = &device.USART2;
    drive
        .brr()
        .write(|w| unsafe { w.bits((APB1_HZ / DRIVE_BAUD) as u16) });
    drive
        .cr1()
        .write(|w| unsafe { w.bits(CR1_UE_TE_RE_RXNEIE | CR1_M_PCE) });

    start_cycle_counter(&mut core);
    Board { link: link_tx() }
}

#[cfg(not(feature = "stm32f103-qemu"))]
fn start_cycle_counter(core: &mut cortex_m::Peripherals) {
    core.DCB.enable_trace();
    core.DWT.enable_cycle_counter();
}

/// A timestamp for [`cycles_since`].
#[cfg(not(feature = "stm32f103-qemu"))]
pub fn timestamp() -> u32 {
    DWT::cycle_count()
}

/// CPU cycles since `start`, from the DWT cycle counter.
#[cfg(not(feature = "stm32f103-qemu"))]
pub fn cycles_since(start: u32) -> u32 {
    DWT::cycle_count().wrapping_sub(start)
}

/// QEMU's `-icount shift=7`: every instruction takes 2^7 ns of virtual time.
#[cfg(feature = "stm32f103-qemu")]
const ICOUNT_NS_PER_INSTRUCTION: u32 = 128;
/// SysTick on the processor clock: QEMU's stm32vldiscovery runs it at 24 MHz.
#[cfg(feature = "stm32f103-qemu")]
const SYSTICK_HZ: u32 = 24_000_000;

/// No DWT under QEMU: SysTick, free-running over its 24 bits, counts instead.
#[cfg(feature = "stm32f103-qemu")]
fn start_cycle_counter(core: &mut cortex_m::Peripherals) {
    use cortex_m::peripheral::syst::SystClkSource;
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00FF_FFFF);
    core.SYST.clear_current();
    core.SYST.enable_counter();
}

/// A timestamp for [`cycles_since`].
#[cfg(feature = "stm32f103-qemu")]
pub fn timestamp() -> u32 {
    cortex_m::peripheral::SYST::get_current()
}

/// Instructions since `start`, one cycle each as QEMU's icount counts them: SysTick ticks at
/// 24 MHz, 128 ns per instruction. Repeatable under `-icount shift=7`.
#[cfg(feature = "stm32f103-qemu")]
pub fn cycles_since(start: u32) -> u32 {
    let ticks = start.wrapping_sub(cortex_m::peripheral::SYST::get_current()) & 0x00FF_FFFF;
    // ticks * (1e9 / 24 MHz) / 128 ns, in integers: ticks * 1000 / (24 * 128).
    ticks * 1_000 / (SYSTICK_HZ / 1_000_000 * ICOUNT_NS_PER_INSTRUCTION)
}

/// A panic or HardFault on the board: reset and come up again.
/// After a failed RAM test: the board stays as it is, Run LED steady on, until power is
/// cycled (a reset would only test the same cells again).
#[cfg(not(feature = "stm32f103-qemu"))]
pub fn halt_ram_fault() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "stm32f103-qemu"))]
pub fn exit_failure() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Under QEMU a RAM fault, a panic or a HardFault ends the run with a failure code.
#[cfg(feature = "stm32f103-qemu")]
pub fn halt_ram_fault() -> ! {
    exit_failure()
}

#[cfg(feature = "stm32f103-qemu")]
pub fn exit_failure() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

// The adapter's RTIC app on this board's interrupts: the link UART, the drive UART, and a
// free one that runs the software tasks.
crate::adapter_app!(USART1, USART2, EXTI0);
