//! The PROFIBUS DP-V0 slave: the state machine between FDL telegrams and the application.
//!
//! [`Slave::process`] takes a parsed request and the current time and returns the response, if
//! any; [`Slave::poll`] runs the watchdog and [`Slave::poll_at`] says when it must next run.
//! Nothing here reads a clock, allocates or panics on any input: time comes in as [`Instant`],
//! buffers are fixed, and every malformed or foreign telegram is answered with nothing and
//! changes nothing. The application behind the slave plugs in through [`Application`].
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

mod app;
pub mod cfg;
#[cfg(feature = "harness")]
pub mod harness;
pub mod msac1;
mod slave;
#[cfg(any(test, feature = "testing"))]
pub mod testing;

pub use app::{Application, FailSafeReason};
pub use cfg::IoSizes;
pub use slave::{Config, Slave, State, MAX_CFG_LEN};

/// A point in time, in microseconds since an arbitrary epoch (the caller's clock).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Instant {
    micros: u64,
}

impl Instant {
    pub const ZERO: Instant = Instant { micros: 0 };

    pub const fn from_micros(micros: u64) -> Instant {
        Instant { micros }
    }

    pub const fn from_millis(millis: u64) -> Instant {
        Instant {
            micros: millis * 1000,
        }
    }

    pub const fn micros(self) -> u64 {
        self.micros
    }

    /// This instant plus `micros`, saturating (an instant never wraps).
    pub const fn plus_micros(self, micros: u64) -> Instant {
        Instant {
            micros: self.micros.saturating_add(micros),
        }
    }
}
