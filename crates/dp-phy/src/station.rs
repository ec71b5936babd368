//! A station's receiver at a rate it already knows (a master's UART): glitch filter, then an
//! 11-bit character receiver with a majority vote, with no autodetection and no delimiter.
//!
//! The receiver is gated by the station's own driver enable, as RS-485 transceivers with /RE
//! tied to DE are: a station does not hear itself. Characters with an error are delivered with
//! it, and the caller decides (a master's FDL drops the telegram).

use crate::filter::{self, FilterQ, FILTER_RESET};
use crate::uart::{RxChar, RxQ, UartRx, RX_RESET};
use crate::{BitTiming, Tick};

/// Registers of the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StationRxQ {
    pub filter: FilterQ,
    pub rx: RxQ,
}

/// A fixed-rate receiver.
#[derive(Clone, Debug)]
pub struct StationRx {
    uart: UartRx,
    filter_len: u16,
    q: StationRxQ,
    now: Tick,
}

impl StationRx {
    pub fn new(timing: BitTiming) -> StationRx {
        StationRx {
            uart: UartRx::new(timing),
            filter_len: filter::len_for(timing.clocks_per_bit()),
            q: StationRxQ {
                filter: FILTER_RESET,
                rx: RX_RESET,
            },
            now: 0,
        }
    }

    pub fn timing(&self) -> BitTiming {
        self.uart.timing
    }

    /// One clock: `line` as seen on the bus, `driving` whether this station drives it.
    #[inline]
    pub fn tick(&mut self, line: bool, driving: bool) -> Option<RxChar> {
        let now = self.now;
        self.now += 1;
        // Receiver disabled while driving: it sees an idle line.
        let line = line || driving;
        let (f, fq) = filter::next(line, self.filter_len, &self.q.filter);
        let (ch, rq) = self.uart.next(now, f.level, f.fell, &self.q.rx);
        self.q = StationRxQ { filter: fq, rx: rq };
        ch
    }

    /// Ticks a constant `line` leaves this receiver idle: none while it is inside a character.
    pub fn quiet_for(&self, line: bool) -> Tick {
        if line && !self.q.rx.active && filter::is_quiet(line, &self.q.filter) {
            Tick::MAX
        } else {
            0
        }
    }

    /// Lets `ticks` pass on an idle line (only after `quiet_for` allowed it).
    pub fn skip(&mut self, ticks: Tick) {
        self.now += ticks;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::TxStation;
    use crate::Baud;

    #[test]
    fn receives_what_a_transmitter_sends_at_every_rate() {
        for baud in Baud::ALL {
            let timing = BitTiming::new(48_000_000, baud, 0);
            let mut tx = TxStation::new(BitTiming::new(48_000_000, baud, 2000));
            let mut rx = StationRx::new(timing);
            let bytes = [0xE5, 0x00, 0xFF, 0x68, 0x16];
            tx.push(2, &bytes);
            let mut got = Vec::new();
            for _ in 0..timing.clocks_for(11 * 8, 1) {
                let line = tx.drive().unwrap_or(true);
                if let Some(ch) = rx.tick(line, false) {
                    assert_eq!(ch.error, None, "{baud}");
                    got.push(ch.byte);
                }
                tx.tick();
            }
            assert_eq!(got, bytes, "{baud}");
        }
    }

    #[test]
    fn does_not_hear_itself() {
        let timing = BitTiming::new(48_000_000, Baud::B1500000, 0);
        let mut tx = TxStation::new(timing);
        let mut rx = StationRx::new(timing);
        tx.push(0, &[0x10, 0x20]);
        for _ in 0..timing.clocks_for(30, 1) {
            let driving = tx.drive();
            assert_eq!(rx.tick(driving.unwrap_or(true), driving.is_some()), None);
            tx.tick();
        }
    }
}
