//! The simulated hardware around the adapter's MCU.
//!
//! - [`cosim::CoSim`]: one clock for the bus, the profirust master on its bit-level PHY
//!   ([`master::MasterPhy`]), the transceiver model, the fault injector, and the board's
//!   switch, storage and LEDs.
//! - [`firmware`]: the firmware behind the transceiver, the real image in QEMU
//!   ([`firmware::Qemu`]) or its logic in-process ([`firmware::InProcess`]).
//! - [`scenario`]: the scenarios of `cargo xtask qemu-test`, each with its checks.
//! - [`drive_sim`]: the drive behind the adapter, and [`drive_wire`]: the Modbus RTU line to
//!   it on simulated time.
#![deny(unsafe_code)]

pub mod bridge;
pub mod cosim;
pub mod dp_cycle;
pub mod drive_scenarios;
pub mod drive_sim;
pub mod drive_wire;
pub mod firmware;
pub mod master;
pub mod scenario;
pub mod serial;
