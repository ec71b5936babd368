//! The simulated hardware around the adapter's MCU.
//!
//! - [`cosim::CoSim`]: one clock for the bus, the profirust master on its bit-level PHY
//!   ([`master::MasterPhy`]), the transceiver model, the fault injector, and the board's
//!   switch, storage and LEDs.
//! - [`firmware`]: the firmware behind the transceiver, the real image in QEMU
//!   ([`firmware::Qemu`]) or its logic in-process ([`firmware::InProcess`]).
//! - [`scenarios`]: the scenarios of `cargo xtask qemu-test`, one catalog, a file per family.
//! - [`drive_sim`] (crates/drive-sim): the drive behind the adapter and the Modbus RTU line to
//!   it on simulated time.
//! - [`bridge`]: the transceiver's MCU side (responder, link, MCU) on board time.
//! - [`soak`]: the soak campaign, a seeded random schedule of everything the scenarios do,
//!   with invariants checked as it runs.
#![deny(unsafe_code)]

/// The simulated drive, its own crate (`crates/drive-sim`).
pub use drive_sim;

pub mod bridge;
pub mod cosim;
pub mod dp_cycle;
pub mod firmware;
pub mod master;
pub mod msac1_master;
pub mod scenarios;
pub mod serial;
pub mod soak;
