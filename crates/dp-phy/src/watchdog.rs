//! A watchdog as the transceiver counts it: the baud-control watchdog (restarted by every good
//! telegram, it sends the transceiver back to searching) and the DP watchdog (restarted by
//! every request of the owning master, it sends the slave back to Wait_Prm) are each one.
//!
//! Contract, per clock at `now`: the commands come first ([`Watchdog::start`],
//! [`Watchdog::start_if_stopped`], [`Watchdog::stop`]); then, where the block that owns it
//! lets it expire on this clock (the baud watchdog only between telegrams),
//! [`Watchdog::expire`] says whether it ran out, `clocks` after its start or later, and stops
//! it if so.
//!
//! The register is the deadline, a tick; the RTL (gateware/rtl/watchdog.v) counts the clocks
//! left instead, `deadline - now` saturating at 0 ([`Watchdog::left`]): the same register seen
//! from the clock, and no 64-bit tick counter in the FPGA. Fast mode skips to the deadline.

use crate::Tick;

/// The watchdog's register.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Watchdog {
    /// The tick it expires on, or after; `None`: stopped.
    pub deadline: Option<Tick>,
}

impl Watchdog {
    pub const STOPPED: Watchdog = Watchdog { deadline: None };

    /// Runs it `clocks` from `now`.
    pub fn start(&mut self, now: Tick, clocks: Tick) {
        self.deadline = Some(now + clocks);
    }

    /// Starts it as [`Watchdog::start`] unless it runs.
    pub fn start_if_stopped(&mut self, now: Tick, clocks: Tick) {
        if self.deadline.is_none() {
            self.start(now, clocks);
        }
    }

    pub fn stop(&mut self) {
        self.deadline = None;
    }

    pub fn running(&self) -> bool {
        self.deadline.is_some()
    }

    /// Whether it ran out by `now`; it stops if so.
    pub fn expire(&mut self, now: Tick) -> bool {
        let out = self.deadline.is_some_and(|at| now >= at);
        if out {
            self.deadline = None;
        }
        out
    }

    /// Clocks from `now` until it may expire (the RTL's count: 0 once due; `None`: stopped).
    pub fn left(&self, now: Tick) -> Option<Tick> {
        self.deadline.map(|at| at.saturating_sub(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_expires_clocks_after_its_start_once_and_not_before() {
        let mut w = Watchdog::STOPPED;
        w.start(100, 5);
        assert!((100..105).all(|t| !w.clone().expire(t)));
        assert_eq!(w.left(103), Some(2));
        assert!(w.expire(105));
        assert!(!w.running() && !w.expire(106));
    }

    #[test]
    fn start_if_stopped_keeps_a_running_deadline() {
        let mut w = Watchdog::STOPPED;
        w.start_if_stopped(10, 50);
        w.start_if_stopped(20, 50);
        assert_eq!(w.deadline, Some(60));
        w.start(20, 50);
        assert_eq!(w.deadline, Some(70));
        w.stop();
        assert_eq!(w.left(30), None);
    }
}
