//! The boards the firmware builds for; a cargo feature chooses one.
#[cfg(all(feature = "lm3s6965", feature = "stm32f103"))]
compile_error!(
    "choose one board: --features lm3s6965 or --no-default-features --features stm32f103"
);

#[cfg(feature = "lm3s6965")]
mod lm3s6965;
#[cfg(feature = "lm3s6965")]
pub use lm3s6965::*;

#[cfg(feature = "stm32f103")]
mod stm32f103;
#[cfg(feature = "stm32f103")]
pub use stm32f103::*;
