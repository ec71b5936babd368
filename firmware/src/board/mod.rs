//! The boards the firmware builds for; a cargo feature chooses one (its name in
//! `crates/board`'s table, which the build script also reads for the board's memory).
#[cfg(any(
    all(feature = "lm3s6965", feature = "stm32f1-board"),
    all(feature = "stm32f103", feature = "stm32f103-qemu")
))]
compile_error!(
    "choose one board: --no-default-features --features <a name in crates/board's BOARDS>"
);

#[cfg(feature = "lm3s6965")]
mod lm3s6965;
#[cfg(feature = "lm3s6965")]
pub use lm3s6965::*;

// The production board, and its code under QEMU (feature stm32f103-qemu).
#[cfg(feature = "stm32f1-board")]
mod stm32f103;
#[cfg(feature = "stm32f1-board")]
pub use stm32f103::*;

/// Cycles counted over 100 `nop`s: the unit the firmware's time is counted in, checked once at
/// boot (100, give or take the read itself, where the counter counts instructions, as under
/// QEMU's icount). A hundred, not more: each is two bytes of the production board's flash.
pub fn calibrate() -> u32 {
    let start = timestamp();
    // SAFETY: a block of `nop`s touches no memory and no registers.
    unsafe {
        core::arch::asm!(
            ".rept 100",
            "nop",
            ".endr",
            options(nomem, nostack, preserves_flags)
        )
    };
    cycles_since(start)
}
