//! Baud-rate search by pulse-width measurement, deciding on the first character.
//!
//! Real ASICs step down from 12 Mbit/s one rate per monitoring period and lose telegrams while
//! they do. This block instead times the pulses of one character: every start delimiter (SD1 `10`,
//! SD2 `68`, SD3 `A2`, SD4 `DC`) has a pulse exactly one bit wide, so the shortest pulse names
//! the rate. Once 10.5 bit times of that rate have passed since the start edge (the middle of the
//! stop bit), the recorded edges are replayed: every edge must sit on a whole bit time, the
//! character must have a start bit, even parity, a stop bit, and be a start delimiter, and the
//! line must have been idle for TSYN before it. Then the rate and the decoded first character are
//! handed to the receiver, which goes on with the rest of the telegram, so nothing is lost.
//!
//! ```text
//!  SD1 0x10: ‾‾|___________________|‾‾‾|___________|‾‾‾‾‾‾‾‾      (start, 4 x 0, 1, 3 x 0, P=1, stop)
//!              t0                  e1  e2          e3     ^ decide at t0 + 10.5 bits
//!                                  └ 1 bit ┘ = shortest pulse → rate
//! ```
//!
//! A candidate is only that: the lock is confirmed by the transceiver when the whole telegram
//! arrives without error. Anything that fails a check is dropped and the search goes on at the
//! next falling edge.

use crate::Tick;
use dp_consts::{Baud, SD1, SD2, SD3, SD4, TSYN_BITS};

/// Edges one character can have at most (11 bits: 10 changes of level).
const MAX_EDGES: usize = 10;

/// A character the search decoded and the rate it was sent at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Detection {
    pub baud: Baud,
    pub byte: u8,
    /// Tick of the start edge.
    pub start: Tick,
    /// Tick the stop bit ends.
    pub end: Tick,
}

/// Why a measured character was not taken (for statistics and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// A pulse shorter than a 12 Mbit/s bit, or more edges than a character has.
    Noise,
    /// No pulse matched a rate in time.
    NoRate,
    /// An edge off the bit grid of the chosen rate.
    OffGrid,
    /// Start, parity or stop bit wrong.
    NotAChar,
    /// A valid character, but no start delimiter.
    NotADelimiter,
    /// The line was not idle for TSYN before it.
    NoSync,
}

/// Registers of the search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AutoBaudQ {
    pub measuring: bool,
    pub t0: Tick,
    /// Idle clocks before the start edge.
    pub idle_before: Tick,
    /// Edge times relative to `t0`.
    pub edges: [u32; MAX_EDGES],
    pub n_edges: u8,
    /// Shortest completed pulse so far, in clocks (`u32::MAX`: none yet).
    pub min_width: u32,
    /// Rate of the shortest pulse (index into `Baud::ALL`), once one matches.
    pub candidate: Option<u8>,
    /// Tick of the decision (the candidate's stop-bit middle) or of giving up without one.
    pub deadline: Tick,
}

pub const AUTOBAUD_RESET: AutoBaudQ = AutoBaudQ {
    measuring: false,
    t0: 0,
    idle_before: 0,
    edges: [0; MAX_EDGES],
    n_edges: 0,
    min_width: u32::MAX,
    candidate: None,
    deadline: Tick::MAX,
};

/// Per-rate constants, computed once from the sample clock.
#[derive(Clone, Copy, Debug)]
struct RateWindow {
    /// Bit period: `modulo / inc` clocks, exact.
    inc: u64,
    modulo: u64,
    /// Pulse widths (clocks) this rate accepts as one bit.
    lo: u32,
    hi: u32,
    /// Relative tick at which the stop bit's middle is reached.
    decide_at: u32,
    /// Idle clocks that make TSYN (half a bit of tolerance for sampling and clock offset).
    tsyn: u64,
}

/// The search block's fixed configuration.
#[derive(Clone, Debug)]
pub struct AutoBaud {
    windows: [RateWindow; 10],
    /// Give up on a measurement after this many clocks without a decision.
    give_up_at: u32,
    /// The shortest TSYN of all rates (the fastest's): a fall after less idle starts nothing.
    min_tsyn: Tick,
}

impl AutoBaud {
    pub fn new(clock_hz: u32) -> Self {
        let timings = Baud::ALL.map(|b| crate::BitTiming::new(clock_hz, b, 0));
        let bit = |i: usize| timings[i].clocks_per_bit();
        // Neighbouring rates are at least 2x apart: the boundary between two is the geometric
        // mean of their bits, and the outermost windows allow a quarter of a bit and a clock of
        // sampling error. `decide` then holds every edge to the chosen rate's bit grid.
        let boundary = |slow: usize| (bit(slow) * bit(slow + 1)).isqrt();
        let windows: [RateWindow; 10] = core::array::from_fn(|i| {
            let t = timings[i];
            RateWindow {
                inc: t.inc,
                modulo: t.modulo,
                lo: if i == 9 {
                    (bit(i) * 3 / 4).saturating_sub(1).max(1)
                } else {
                    boundary(i) + 1
                } as u32,
                hi: if i == 0 {
                    bit(i) + t.clocks_for(1, 4) + 1
                } else {
                    boundary(i - 1)
                } as u32,
                decide_at: t.clocks_for(21, 2) as u32,
                tsyn: t.clocks_for(2 * TSYN_BITS as u64 - 1, 2),
            }
        });
        let give_up_at = windows[0].decide_at + windows[0].hi;
        let min_tsyn = windows.iter().map(|w| w.tsyn).min().unwrap_or(0);
        AutoBaud {
            windows,
            give_up_at,
            min_tsyn,
        }
    }

    /// The shortest idle after which a fall starts a measurement.
    pub fn min_tsyn(&self) -> Tick {
        self.min_tsyn
    }

    /// Idle clocks that make TSYN at `baud`.
    pub fn tsyn_clocks(&self, baud: Baud) -> Tick {
        self.windows[baud.index()].tsyn
    }

    fn classify(&self, width: u32) -> Option<u8> {
        self.windows
            .iter()
            .position(|w| (w.lo..=w.hi).contains(&width))
            .map(|i| i as u8)
    }

    /// One clock at `now`; `idle` is how long the line has been idle (clocks). Updates the
    /// registers in place: the search runs on every clock beside the receiver, and copying its
    /// 60 bytes of registers on each one halved the model's speed.
    #[inline(always)]
    pub fn clock(
        &self,
        now: Tick,
        idle: Tick,
        fell: bool,
        rose: bool,
        q: &mut AutoBaudQ,
    ) -> Option<Result<Detection, Reject>> {
        if !(fell || rose) && now < q.deadline {
            return None;
        }
        if !q.measuring {
            // Not measuring: the deadline is Tick::MAX, so this is an edge. Every start
            // delimiter comes after TSYN of idle, at least the fastest rate's: a fall after
            // less is not looked at (inside a telegram at a fast rate, none is).
            if fell {
                if idle < self.min_tsyn {
                    return Some(Err(Reject::NoSync));
                }
                self.start(now, idle, q);
            }
            return None;
        }
        let rel = (now - q.t0).min(u32::MAX as u64) as u32;
        if fell || rose {
            let last = if q.n_edges == 0 {
                0
            } else {
                q.edges[q.n_edges as usize - 1]
            };
            // In SD1-SD4 no high run is longer than the time from the start edge to it (SD4's
            // three 1s after three 0s come closest). A fall after a high run more than twice
            // that long cannot be inside the same delimiter: it may be the start of the next
            // one, so it starts a new measurement now instead of the search waiting out one
            // that cannot succeed (what lets a master's first telegram at a new rate through).
            if fell && q.n_edges > 0 && rel - last > 2 * last && idle >= self.min_tsyn {
                self.start(now, idle, q);
                return None;
            }
            if q.n_edges as usize == MAX_EDGES {
                return reject(Reject::Noise, q);
            }
            let width = rel - last;
            // The first pulse of a start delimiter is 2 to 5 of its bits and the idle before
            // it at least 32.5: a first pulse longer than a quarter of that idle cannot be the
            // start of one that has TSYN before it (what frees the search at once inside a
            // telegram at the locked rate).
            if q.n_edges == 0 && 4 * width as Tick > q.idle_before {
                return reject(Reject::NoSync, q);
            }
            q.edges[q.n_edges as usize] = rel;
            q.n_edges += 1;
            if width < q.min_width {
                q.min_width = width;
                if width < self.windows[9].lo {
                    return reject(Reject::Noise, q);
                }
                if let Some(c) = self.classify(width) {
                    q.candidate = Some(c);
                    q.deadline = q.t0 + self.windows[c as usize].decide_at as Tick;
                }
            }
        }
        match q.candidate {
            Some(c) if rel >= self.windows[c as usize].decide_at => {
                let out = self.decide(c, q);
                *q = AUTOBAUD_RESET;
                Some(out)
            }
            None if rel >= self.give_up_at => reject(Reject::NoRate, q),
            _ => None,
        }
    }

    /// A new measurement from the falling edge at `now`.
    fn start(&self, now: Tick, idle: Tick, q: &mut AutoBaudQ) {
        *q = AUTOBAUD_RESET;
        q.measuring = true;
        q.t0 = now;
        q.idle_before = idle;
        q.deadline = now + self.give_up_at as Tick;
    }

    fn decide(&self, c: u8, q: &AutoBaudQ) -> Result<Detection, Reject> {
        let w = &self.windows[c as usize];
        let baud = Baud::ALL[c as usize];
        let edges = &q.edges[..q.n_edges as usize];
        // Every edge on a whole bit time: within a quarter bit plus a clock of the grid.
        let mut last_bit = 0;
        for &e in edges {
            let scaled = e as u64 * w.inc;
            let bit = (scaled + w.modulo / 2) / w.modulo;
            let dev = scaled.abs_diff(bit * w.modulo);
            if bit <= last_bit || bit > 10 || 4 * dev > w.modulo + 4 * w.inc {
                return Err(Reject::OffGrid);
            }
            last_bit = bit;
        }
        // Replay the waveform at each bit's middle.
        let mut shift = 0u16;
        for k in 0..11u64 {
            let middle = ((2 * k + 1) * w.modulo / (2 * w.inc)) as u32;
            let changes = edges.iter().filter(|&&e| e <= middle).count();
            shift |= ((changes % 2 == 1) as u16) << k;
        }
        let byte = (shift >> 1) as u8;
        let parity_ok = (shift >> 9 & 1 == 1) == crate::uart::parity_bit(byte);
        if shift & 1 != 0 || shift >> 10 & 1 != 1 || !parity_ok {
            return Err(Reject::NotAChar);
        }
        if ![SD1, SD2, SD3, SD4].contains(&byte) {
            return Err(Reject::NotADelimiter);
        }
        if q.idle_before < w.tsyn {
            return Err(Reject::NoSync);
        }
        let t = crate::BitTiming {
            inc: w.inc,
            modulo: w.modulo,
        };
        Ok(Detection {
            baud,
            byte,
            start: q.t0,
            end: q.t0 + t.clocks_for(11, 1),
        })
    }

    /// Ticks with a constant line before the search does more than count.
    pub fn quiet_for(&self, now: Tick, q: &AutoBaudQ) -> Tick {
        q.deadline.saturating_sub(now + 1)
    }
}

fn reject(why: Reject, q: &mut AutoBaudQ) -> Option<Result<Detection, Reject>> {
    *q = AUTOBAUD_RESET;
    Some(Err(why))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::DEFAULT_CLOCK_HZ;
    use crate::uart::char_bits;

    /// Feed one character at `baud` after a long idle line, edges at exact bit times.
    fn detect(baud: Baud, byte: u8, idle_bits: u64) -> Option<Result<Detection, Reject>> {
        let ab = AutoBaud::new(DEFAULT_CLOCK_HZ);
        let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
        let bits = char_bits(byte);
        let t0 = t.clocks_for(idle_bits, 1);
        let level_at = |now: Tick| {
            if now < t0 {
                return true;
            }
            let bit = ((now - t0) * t.inc / t.modulo) as usize;
            bits.get(bit).copied().unwrap_or(true)
        };
        let mut q = AUTOBAUD_RESET;
        let mut prev = true;
        for now in 0..t0 + t.clocks_for(13, 1) {
            let l = level_at(now);
            let out = ab.clock(now, now.min(t0), prev && !l, !prev && l, &mut q);
            prev = l;
            if out.is_some() {
                return out;
            }
        }
        None
    }

    #[test]
    fn every_start_delimiter_names_its_rate() {
        for baud in Baud::ALL {
            for sd in [SD1, SD2, SD3, SD4] {
                let got = detect(baud, sd, 40).unwrap().unwrap();
                assert_eq!((got.baud, got.byte), (baud, sd), "{baud} {sd:02x}");
            }
        }
    }

    #[test]
    fn other_characters_are_not_taken() {
        assert_eq!(
            detect(Baud::B1500000, 0x55, 40),
            Some(Err(Reject::NotADelimiter))
        );
        assert_eq!(
            detect(Baud::B1500000, 0xE5, 40),
            Some(Err(Reject::NotADelimiter))
        );
    }

    #[test]
    fn a_start_delimiter_without_tsyn_is_not_taken() {
        assert_eq!(detect(Baud::B93750, SD2, 20), Some(Err(Reject::NoSync)));
    }

    #[test]
    fn windows_tile_the_widths_without_overlap() {
        for clock in [48_000_000, 96_000_000] {
            let ab = AutoBaud::new(clock);
            for w in ab.windows.windows(2) {
                assert_eq!(w[1].hi + 1, w[0].lo, "{clock}");
            }
        }
    }
}
