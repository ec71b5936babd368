//! The drive application of the two manuals behind the DP slave: seed 000 (the IOA-B103
//! card, "vendor profile") and seed 004 (ABB's RPBA-01, "PROFIdrive profile").
//!
//! - [`ppo`]: PPO types 1-6 and the configurations that select them.
//! - [`prm`]: the User_Prm_Data layout: fail-safe, control-zero and operation mode, cut-off,
//!   fail-safe values, the PZD mapping.
//! - [`codes`]: the vendor's function codes (F0.29 is 0xF029).
//! - [`pkw`]: the vendor parameter channel.
//! - [`pd_params`]: the PROFIdrive parameter channel and parameters (915 .. 972).
//! - [`pd_access`]: the PROFIdrive parameter request and response over DP-V1 (seed 004, tables
//!   18-21); [`dpv1`]: the server that executes them.
//! - [`words`]: the vendor control and status words.
//! - [`profile`]: the PROFIdrive state machine and its translation to the vendor words.
//! - [`drive`]: the drive as the application sees it, and the error and fault codes.
//! - [`fieldbus_group`]: seed 004's group 51 in the drive, what the adapter shows there and
//!   takes from it.
//! - [`app`]: [`ProfidriveApp`], dp-slave's `Application`.
//! - [`gsd`]: the device's GSD file.
//!
//! no_std, no allocation, no clock: time comes in as `dp_slave::Instant`.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

pub mod app;
pub mod codes;
pub mod dpv1;
pub mod drive;
pub mod faults;
pub mod fieldbus_group;
pub mod gsd;
pub mod identification;
pub mod link_diag;
pub mod pd_access;
pub mod pd_params;
pub mod pkw;
pub mod ppo;
pub mod prm;
pub mod profile;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod words;

pub use app::ProfidriveApp;
