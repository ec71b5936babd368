//! Cycle-accurate model of the adapter's FPGA transceiver, written the way an HDL block is.
//!
//! One sample clock (48 MHz by default) drives every block. Each block keeps its registers in a
//! `Copy` struct and has a pure next-state function; `tick()` commits it once per clock edge, so
//! an FPGA engineer can port a block line by line. The blocks, in the order the signal meets them:
//!
//! ```text
//!  line ─► Synchroniser ─┬─► AutoBaud (a channel per rate: first delimiter ► rate + character)
//!                        └─► EdgeRx (known rate: 11-bit characters, each bit by the level
//!                                    held longer, a glitch weighed where it falls)
//!                                   └─► Delimiter (TSYN, SD1/SD2/SD3/SD4/SC, LE/LEr, FCS, ED)
//!  response ─► UartTx (min TSDR after the request, driver enable) ─► line
//! ```
//!
//! [`Transceiver`] composes them with the baud-control watchdog; [`bus`] models the shared RS-485
//! line with stations of their own clock offsets and a seeded fault injector; [`trace`] dumps VCD
//! waveforms for GTKWave.
//!
//! Time is counted in ticks of the sample clock (`u64`, from reset). Bit timing is a phase
//! accumulator in integers ([`BitTiming`]), so 45.45 kbit/s at 48 MHz (1056.1 clocks per bit)
//! stays exact over a whole telegram with no floating point in the datapath.
//!
//! Every block also answers "how many ticks would pass with nothing but counters moving" for a
//! constant line (`quiet_for`), and can `skip` that many at once; [`Transceiver::advance`] uses
//! it for the fast mode, which gives bit-for-bit the outputs of ticking every clock.
#![deny(unsafe_code)]

pub mod autobaud;
pub mod bus;
pub mod char_reader;
pub mod delimiter;
pub mod edge_rx;
pub mod filter;
pub mod rate_idle;
pub mod responder;
pub mod station;
pub mod sweep;
pub mod testbench;
pub mod timing;
pub mod trace;
pub mod transceiver;
pub mod uart;
pub mod watchdog;

pub use dp_consts::Baud;
pub use timing::BitTiming;
pub use transceiver::{BaudState, Config, TickOut, Transceiver};

/// A point in time, in sample-clock ticks since reset.
pub type Tick = u64;
