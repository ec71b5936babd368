//! The boards the adapter is built for, as figures: one place for every number that stands
//! for hardware, and the board contract every tool reads ([`BOARDS`]).
//!
//! A board is a row of [`BOARDS`]: its name is its firmware Cargo feature and its
//! `firmware/src/board/` module; its [`Memory`] is the linker's `memory.x` (the firmware's
//! build script writes it from here); its flash budget and RAM are what xtask holds the image
//! to; its [`Runs`] says whether qemu-test runs it under QEMU (and on which machine) or a probe
//! flashes it. README "Adding a board" lists the four places a new board touches.
//!
//! The firmware's board module configures its peripherals from these figures (the link UART's
//! divisor, the clock tree), and hal-sim charges the simulated board exactly what the real one
//! would cost: every link message takes its encoded bytes times the link's byte time, plus the
//! MCU's interrupt entry, and the firmware's counted instructions are converted to time at
//! [`Board::mcu_clock_hz`] and [`Board::cycles_per_instruction_pct`]. A scenario that passes
//! only because a figure here is rosier than the board is a defect: change the board, not the
//! simulation.
#![no_std]
#![deny(unsafe_code)]

/// The serial interface between the transceiver (FPGA) and the MCU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Link {
    /// Bits per second on the wire.
    pub bit_rate: u32,
    /// Bits on the wire per byte of payload (start, 8 data, stop: 10 for a UART in 8N1).
    pub bits_per_byte: u32,
    /// Idle bytes the transceiver leaves after each frame to the MCU: the MCU receives by DMA
    /// and interrupts on the idle line, so a frame reaches the firmware when they have passed.
    pub idle_bytes_after_frame: u32,
    /// How the MCU sends. By DMA (`true`), a frame at a time from one buffer: it waits only
    /// for a frame still going out before it starts the next. Else a byte at a time, waiting
    /// for each: its next instruction follows the last byte's hand-over.
    pub dma_writes: bool,
}

impl Link {
    /// Nanoseconds that `bytes` bytes occupy the link, rounded up.
    pub const fn transfer_ns(&self, bytes: usize) -> u64 {
        let bits = bytes as u64 * self.bits_per_byte as u64;
        (bits * 1_000_000_000).div_ceil(self.bit_rate as u64)
    }
}

/// Where the linker puts the image: flash and RAM, origin and length.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Memory {
    pub flash_origin: u32,
    pub flash_bytes: u32,
    pub ram_origin: u32,
    pub ram_bytes: u32,
}

/// The non-volatile storage (crates/nv-store): the last pages of the production board's
/// flash, which the image may not take (its linker script ends the image's flash before them).
/// Under QEMU, whose flash controllers are not emulated, hal-sim keeps a file of the same pages
/// that the firmware reads and writes over semihosting.
pub const NV_STORAGE_PAGES: u32 = 2;
/// The STM32F103CB's flash page, its erase unit (1 KiB on every medium-density F103).
pub const NV_PAGE_BYTES: u32 = 1024;
/// The storage's bytes.
pub const NV_STORAGE_BYTES: u32 = NV_STORAGE_PAGES * NV_PAGE_BYTES;

impl Memory {
    /// Where the storage starts: the end of the flash less its pages.
    pub const fn nv_storage_origin(&self) -> u32 {
        self.flash_origin + self.flash_bytes - NV_STORAGE_BYTES
    }
}

/// Where the image runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Runs {
    /// Under `qemu-system-arm -machine <machine>`, with the link on its first serial port and
    /// the drive link on its second; qemu-test runs scenarios on it.
    Qemu { machine: &'static str },
    /// On the board itself, flashed through a debug probe (`cargo xtask flash`).
    Probe,
}

/// The FPGA families `cargo xtask gateware` builds for: yosys's `synth_ice40` and
/// nextpnr-ice40, or `synth_ecp5` and nextpnr-ecp5.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FpgaFamily {
    Ice40,
    Ecp5,
}

/// An FPGA the transceiver's gateware is built for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fpga {
    /// The part as its maker names it.
    pub part: &'static str,
    pub family: FpgaFamily,
    /// nextpnr's device, package and speed grade options (`--hx8k --package ct256`;
    /// `--25k --package CABGA256 --speed 6`; the iCE40 has one speed).
    pub device: &'static str,
    pub package: &'static str,
    pub speed: Option<u8>,
    /// Logic: an iCE40's logic cells (a LUT4, a carry and a flip-flop each), an ECP5's LUT4s
    /// (nextpnr's TRELLIS_COMB: half a slice each, with its carry and flip-flop beside it).
    pub logic: u32,
    /// Block RAMs: 4 kbit on an iCE40, 18 kbit on an ECP5.
    pub block_rams: u32,
    /// The transceiver's sample clock: one tick of the model (crates/dp-phy).
    pub sample_clock_hz: u32,
}

/// The sample clock: 48 MHz, where every rate's bit is a whole number of clocks but
/// 45.45 kbit/s's, and 12 Mbit/s has 4.
const SAMPLE_CLOCK_HZ: u32 = 48_000_000;

/// An iCE40 HX8K in its 256-ball BGA: the largest iCE40 (the UP5K's 5,280 cells cannot hold
/// the baud-rate search). The transceiver's receive path and transmitter took 95 % of it
/// before the responder and the link, at 37-40 MHz, and each cut of its longest paths costs
/// cells it does not have (README "Gateware: the part"). Built for the record:
/// `cargo xtask gateware --part iCE40HX8K-CT256`.
pub const ICE40_HX8K: Fpga = Fpga {
    part: "iCE40HX8K-CT256",
    family: FpgaFamily::Ice40,
    device: "hx8k",
    package: "ct256",
    speed: None,
    logic: 7680,
    block_rams: 32,
    sample_clock_hz: SAMPLE_CLOCK_HZ,
};

/// A Lattice ECP5 LFE5U-25F, speed grade 6, in its 256-ball BGA: the smallest ECP5, and
/// the next part up with an open toolchain (yosys, nextpnr, Project Trellis) after the iCE40s.
pub const ECP5_25F: Fpga = Fpga {
    part: "LFE5U-25F-6BG256C",
    family: FpgaFamily::Ecp5,
    device: "25k",
    package: "CABGA256",
    speed: Some(6),
    logic: 24288,
    block_rams: 56,
    sample_clock_hz: SAMPLE_CLOCK_HZ,
};

/// The transceiver's FPGA on the production board: what `cargo xtask gateware` builds for by
/// default, and the sample clock every figure of the transceiver model counts in.
pub const TRANSCEIVER_FPGA: Fpga = ECP5_25F;

/// Every part `cargo xtask gateware --part` takes.
pub const FPGAS: &[Fpga] = &[ECP5_25F, ICE40_HX8K];

/// One board.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Board {
    /// The firmware's Cargo feature and board module.
    pub name: &'static str,
    /// The part, as probe-rs names it.
    pub chip: &'static str,
    /// What the firmware's boot log calls the board.
    pub description: &'static str,
    /// The MCU's core clock.
    pub mcu_clock_hz: u32,
    /// Core cycles per counted instruction, in percent. QEMU's `-icount` counts one cycle per
    /// instruction; a Cortex-M3 running from flash with wait states needs more.
    pub cycles_per_instruction_pct: u32,
    /// Core cycles from an interrupt request to the handler's first instruction.
    pub irq_entry_cycles: u32,
    pub link: Link,
    pub memory: Memory,
    /// Maximal link frames the MCU's queue from the link interrupt to the link task holds:
    /// events queue there while the drive application's cycle runs. Its RAM decides.
    pub link_queue_frames: u32,
    /// The flash the image may take: xtask fails a build over it.
    pub flash_budget: u32,
    pub runs: Runs,
}

impl Board {
    /// Nanoseconds that `instructions` counted instructions take on this board, rounded up.
    pub const fn instructions_ns(&self, instructions: u64) -> u64 {
        let cycles = (instructions * self.cycles_per_instruction_pct as u64).div_ceil(100);
        (cycles * 1_000_000_000).div_ceil(self.mcu_clock_hz as u64)
    }

    /// The fewest counted instructions that take at least `ns`: every count below it ends
    /// before `ns` (a lookahead of `ns` in instructions, as hal-sim grants it to the firmware).
    /// The exact inverse of [`Board::instructions_ns`], one rounding up at a time.
    pub const fn instructions_taking_ns(&self, ns: u64) -> u32 {
        if ns == 0 {
            return 0;
        }
        // The fewest cycles whose time, rounded up, reaches `ns`; then the fewest
        // instructions whose cycles, rounded up, reach those.
        let cycles = (ns - 1) * self.mcu_clock_hz as u64 / 1_000_000_000 + 1;
        let n = (cycles - 1) * 100 / self.cycles_per_instruction_pct as u64 + 1;
        if n > u32::MAX as u64 {
            u32::MAX
        } else {
            n as u32
        }
    }

    /// Nanoseconds from an interrupt request to its handler.
    pub const fn irq_entry_ns(&self) -> u64 {
        self.instructions_ns(0)
            + (self.irq_entry_cycles as u64 * 1_000_000_000).div_ceil(self.mcu_clock_hz as u64)
    }
}

/// The production board: an STM32F103CB at 72 MHz from an 8 MHz crystal.
///
/// - Part: the CB, the C8's twin with 128 KiB of flash (the same LQFP48, pins, RAM and
///   peripherals). The C8's 64 KiB held the image until the settings storage of issue 30
///   (sequential-storage's map, about 13 KB of code, and its two pages): 59 KB of image and 2
///   KiB of storage would have left the C8 4 KB.
///
/// - Link: USART1 at 4.5 Mbit/s, 8N1, the fastest the F103's USART reaches (APB2 at 72 MHz,
///   oversampling by 16). The transceiver answers every DP-V0 request from buffers, so the
///   link carries only buffer updates and the requests the firmware decides; its byte time
///   enters no response time. The MCU receives by DMA (an interrupt per byte would take more
///   than the 160 cycles a byte lasts) and interrupts on the idle character after each frame;
///   it sends by DMA too, a frame at a time.
/// - Instructions: 150 % (two flash wait states at 72 MHz; the prefetch buffer hides part of
///   them: a conservative figure, not a measurement).
/// - Interrupt entry: 12 cycles, the Cortex-M3's exception entry with no wait states on the
///   stack.
pub const STM32F103: Board = Board {
    name: "stm32f103",
    chip: "STM32F103CB",
    description: "STM32F103CB (production)",
    mcu_clock_hz: 72_000_000,
    cycles_per_instruction_pct: 150,
    irq_entry_cycles: 12,
    link: Link {
        bit_rate: 4_500_000,
        bits_per_byte: 10,
        idle_bytes_after_frame: 1,
        dma_writes: true,
    },
    memory: Memory {
        flash_origin: 0x0800_0000,
        flash_bytes: 128 * 1024,
        ram_origin: 0x2000_0000,
        ram_bytes: 20 * 1024,
    },
    link_queue_frames: 4,
    // 96 KiB of the 128, so that what follows has a quarter of the chip (on the C8: 40 KiB of
    // its 64 before DP-V1, which took 5.3 KiB, then 48 KiB; the settings storage took 13 KB).
    flash_budget: 96 * 1024,
    runs: Runs::Probe,
};

/// The QEMU board (lm3s6965evb). It runs the firmware under hal-sim, which charges time as
/// the production board would: its own figures are only its memory.
pub const LM3S6965_QEMU: Board = Board {
    name: "lm3s6965",
    chip: "LM3S6965",
    description: "lm3s6965evb (QEMU)",
    memory: Memory {
        flash_origin: 0,
        flash_bytes: 256 * 1024,
        ram_origin: 0x2000_0000,
        ram_bytes: 64 * 1024,
    },
    flash_budget: 256 * 1024 - NV_STORAGE_BYTES,
    runs: Runs::Qemu {
        machine: "lm3s6965evb",
    },
    ..STM32F103
};

/// The production board's own code under QEMU's `stm32vldiscovery` (an STM32F100: the F1's
/// USARTs at the F103's addresses, SysTick; no RCC, DMA or DWT, 128 KiB of flash and 8 KiB of
/// RAM). The image is the production one but where the emulator forces otherwise (README
/// "The production board under emulation"); hal-sim charges the production board's time.
pub const STM32F103_QEMU: Board = Board {
    name: "stm32f103-qemu",
    description: "STM32F103CB code on QEMU stm32vldiscovery",
    memory: Memory {
        flash_origin: 0x0800_0000,
        flash_bytes: 128 * 1024,
        ram_origin: 0x2000_0000,
        ram_bytes: 8 * 1024,
    },
    // Two: with four, the statics and the stack overflow 8 KiB. qemu-test's scenarios send no
    // more than two at a time (a frame dropped for want of room fails its scenario).
    link_queue_frames: 2,
    // The production image's budget plus the adapter's initial image, which this one holds
    // in flash (firmware feature `adapter-in-image`): 8 KiB of RAM cannot build it at Boot;
    // and 1 KiB for the simulation's own code, which the production image has not (the pipe
    // to hal-sim over semihosting, the instruction counts, defmt over semihosting). The
    // production image keeps its own budget.
    flash_budget: 96 * 1024 + 5 * 1024 + 1024,
    runs: Runs::Qemu {
        machine: "stm32vldiscovery",
    },
    ..STM32F103
};

/// Every board the firmware builds for, the QEMU board first (qemu-test's main image).
pub const BOARDS: [Board; 3] = [LM3S6965_QEMU, STM32F103, STM32F103_QEMU];

/// The board named `name` (its firmware feature).
pub fn by_name(name: &str) -> Option<&'static Board> {
    BOARDS.iter().find(|b| b.name == name)
}

/// The board whose timing the simulation charges.
pub const PRODUCTION: Board = STM32F103;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_byte_at_4_5_mbit_takes_ten_bits() {
        // 10 bits at 4.5 Mbit/s = 2.222 us, rounded up to whole nanoseconds.
        assert_eq!(STM32F103.link.transfer_ns(1), 2_223);
        assert_eq!(STM32F103.link.transfer_ns(45), 100_000);
    }

    #[test]
    fn every_board_is_found_by_its_name_and_fits_its_memory() {
        for board in &BOARDS {
            assert_eq!(by_name(board.name), Some(board));
            assert!(
                board.flash_budget <= board.memory.flash_bytes - NV_STORAGE_BYTES,
                "{}",
                board.name
            );
        }
        assert_eq!(by_name("no-such-board"), None);
    }

    #[test]
    fn instructions_cost_more_than_a_cycle_each() {
        // 72 instructions at 150 % = 108 cycles = 1.5 us at 72 MHz.
        assert_eq!(STM32F103.instructions_ns(72), 1_500);
        assert_eq!(STM32F103.irq_entry_ns(), 167);
    }

    #[test]
    fn the_instructions_taking_a_time_are_the_first_count_that_reaches_it() {
        for ns in [0, 1, 20, 21, 1_000, 51_389, 10_000_000] {
            let n = STM32F103.instructions_taking_ns(ns);
            assert!(
                STM32F103.instructions_ns(u64::from(n)) >= ns,
                "{ns} ns: {n}"
            );
            if n > 0 {
                assert!(
                    STM32F103.instructions_ns(u64::from(n) - 1) < ns,
                    "{ns} ns: {n}"
                );
            }
        }
        // 1.5 cycles an instruction at 72 MHz: 48 instructions a microsecond.
        assert_eq!(STM32F103.instructions_taking_ns(1_000), 48);
    }
}
