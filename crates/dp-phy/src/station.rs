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

    /// Ticks a constant `line` (`driving`: this station drives it) lets pass with nothing but
    /// the receiver's phase moving: none while the filter has not settled on the line, and
    /// inside a character up to its next sample or bit boundary.
    pub fn quiet_for(&self, line: bool, driving: bool) -> Tick {
        let line = line || driving;
        if !filter::is_quiet(line, &self.q.filter) {
            return 0;
        }
        self.uart.quiet_for(line, &self.q.rx)
    }

    /// Lets `ticks` pass (only after `quiet_for` allowed them).
    pub fn skip(&mut self, ticks: Tick) {
        self.uart.skip(ticks, &mut self.q.rx);
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

    proptest::proptest! {
        /// Fast mode is exact: a receiver that skips what `quiet_for` allows hears the same
        /// characters at the same ticks as one ticked clock by clock, on a line that a
        /// transmitter drives with glitches between (and the receiver's own telegram).
        #[test]
        fn skipping_what_quiet_for_allows_hears_what_ticking_hears(
            baud in proptest::sample::select(Baud::ALL.to_vec()),
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 1..6),
            glitch_at in 0u64..4000,
            glitch_len in 0u64..40,
            own in proptest::prelude::any::<bool>(),
        ) {
            let timing = BitTiming::new(48_000_000, baud, 0);
            let cpb = timing.clocks_per_bit();
            let span = timing.clocks_for(11 * (bytes.len() as u64 + 4), 1);
            let glitch = (glitch_at * cpb / 100, glitch_len * cpb / 20);
            let line_at = |tx: &TxStation, t: u64| {
                let in_glitch = t >= glitch.0 && t < glitch.0 + glitch.1;
                tx.drive().unwrap_or(true) && !in_glitch
            };
            let run = |fast: bool| {
                let mut tx = TxStation::new(BitTiming::new(48_000_000, baud, 500));
                tx.push(2, &bytes);
                let mut rx = StationRx::new(timing);
                let mut heard = Vec::new();
                let mut t = 0;
                while t < span {
                    let line = line_at(&tx, t);
                    let driving = own && tx.drive().is_some();
                    let glitch_edge = [glitch.0, glitch.0 + glitch.1]
                        .into_iter()
                        .filter(|e| *e > t)
                        .min()
                        .map_or(u64::MAX, |e| e - t);
                    let quiet = rx.quiet_for(line, driving).min(tx.quiet_for()).min(glitch_edge);
                    if fast && quiet > 1 {
                        let n = quiet.min(span - t);
                        rx.skip(n);
                        tx.skip(n);
                        t += n;
                    } else {
                        if let Some(ch) = rx.tick(line, driving) {
                            heard.push(ch);
                        }
                        tx.tick();
                        t += 1;
                    }
                }
                heard
            };
            proptest::prop_assert_eq!(run(true), run(false));
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
