//! One character read as it arrives, a clock at a time: the hardware form of the replay that
//! the search and the receiver make of a character's edges at their decision
//! ([`crate::uart::bits_by_longer_level`] and [`crate::uart::glitches_off_grid`]).
//!
//! Contract: started at a start edge (a fall), [`CharReader::clock`] takes the line of each
//! following clock (its level, and whether it changed on that clock) and keeps, in a few
//! registers, what the replay would compute from every edge so far: the bits decided (each the
//! level the line held longer within it, a tie marked), and the glitches it takes to explain
//! the edges off the bit grid. [`CharReader::read`] gives at any clock the character the
//! replay gives from the same edges, the line taken as lasting at its level, exactly: the
//! property tests below hold the two equal. [`CharReader::advance`] passes `n` clocks of a
//! constant line at once, register for register what `n` calls of `clock` leave (the model's
//! fast mode). After 11 bits nothing changes: the replay stops at the stop bit's end too.
//!
//! Why: the replay keeps up to 16 or 32 edge times and walks them all in one clock, with
//! multiplications; ten rate channels of it cannot be an FPGA's registers, let alone reach
//! 48 MHz. The reader updates each register with one adder or comparison from registers.
//!
//! ```text
//!  line   ‾‾|______|‾‾‾‾‾‾|___|‾|_______...      rem counts a bit's phase down by inc a
//!           ^start  bit 1  bit 2  ...              clock; lead/lag: the bit's units high less
//!           |<--modulo-->|                         low, were the line to stay high/low to its
//!                                                  end; at the end the bit is one's sign (0: tie)
//! ```
//!
//! Phase is in the units of a [`BitTiming`] reduced by the greatest common divisor of its
//! `inc` and `modulo` ([`BitTiming::reduced`]): every comparison here is between sums of
//! `inc` and multiples of `modulo`, so the reduction changes no decision, and the RTL's
//! registers (gateware/rtl/char_reader.v) stay as narrow as the rate allows. The fractions and
//! sums of a bit it compares with and adds are worked out once per rate ([`CharReader::new`]).

use crate::BitTiming;

/// Bits of a character: start, 8 data, parity, stop.
pub const CHAR_BITS: u8 = 11;

/// The glitch count saturates here: the search takes one, the receiver two.
pub const GLITCHES_MAX: u8 = 3;

/// The reader's registers. Each is what one clock can update with one adder on an FPGA at
/// 48 MHz: the phase left in the bit counts down (its end is a comparison with `inc`), and
/// the bit's balance (units high less units low) is kept twice, as it would end were the
/// line to stay high (`lead`) and to stay low (`lag`): the bit that ends is the sign of one
/// of them, a register, with no addition before it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CharReaderQ {
    /// Bits decided; [`CHAR_BITS`]: the character is read and the reader holds still.
    pub bit: u8,
    /// Phase units left in the current bit at the start of the next clock (1..=modulo).
    pub rem: u64,
    /// The bit's balance, units high less units low, if the line stays high to its end.
    pub lead: i64,
    /// The same if the line stays low to its end.
    pub lag: i64,
    /// The bits decided, shifted in at bit 10: after 11, bit 0 (the start bit) is bit 0.
    pub shift: u16,
    /// A decided bit held both levels equally long: the character is unreadable.
    pub tie: bool,
    /// Glitches it takes to explain the edges off the grid (saturating at [`GLITCHES_MAX`]).
    pub glitches: u8,
    /// The last edge was off the grid, began a glitch, and a next edge now would end it.
    pub pair_open: bool,
    /// Units left of the half bit within which a next edge off the grid ends that glitch.
    pub pair_left: u64,
}

/// The reader at reset, never started: it holds still as after a character.
pub const CHAR_READER_RESET: CharReaderQ = CharReaderQ {
    bit: CHAR_BITS,
    rem: 0,
    lead: 0,
    lag: 0,
    shift: 0,
    tie: false,
    glitches: 0,
    pair_open: false,
    pair_left: 0,
};

/// What a reader gives: the 11 bits (bit 0 first), `None` after a tie; and the glitches off
/// the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reading {
    pub bits: Option<u16>,
    pub glitches: u8,
}

/// The reader's fixed configuration: one rate's bit in reduced phase units, and the figures a
/// clock adds or compares with, worked out once (the RTL's configuration inputs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CharReader {
    pub inc: u64,
    pub modulo: u64,
    /// An edge with more than this left in its bit is past its first quarter...
    pub quarter: u64,
    /// ...and with less than this, before its last: off the grid.
    pub three_quarters: u64,
    /// Half a bit, rounded down, less `inc`: what is left, a clock after an edge off the grid,
    /// of the half bit within which a second one ends the same glitch.
    pub half_less_inc: u64,
    pub two_inc: u64,
    pub modulo_less_inc: u64,
    pub modulo_less_two_inc: u64,
}

impl CharReader {
    pub fn new(timing: BitTiming) -> CharReader {
        let BitTiming { inc, modulo } = timing.reduced();
        CharReader {
            inc,
            modulo,
            quarter: modulo / 4,
            three_quarters: (3 * modulo).div_ceil(4),
            // A bit lasts at least 3 clocks: half of it is more than a clock.
            half_less_inc: modulo / 2 - inc,
            two_inc: 2 * inc,
            modulo_less_inc: modulo - inc,
            modulo_less_two_inc: modulo - 2 * inc,
        }
    }

    /// The start edge's clock: the line low on it; the start bit's balance is one clock low.
    pub fn start(&self, q: &mut CharReaderQ) {
        *q = CharReaderQ {
            bit: 0,
            rem: self.modulo_less_inc,
            lead: self.modulo_less_two_inc as i64,
            lag: -(self.modulo as i64),
            ..CHAR_READER_RESET
        };
    }

    /// One clock after the start edge: the line at `level`, changed on this clock if `edge`.
    pub fn clock(&self, q: &mut CharReaderQ, level: bool, edge: bool) {
        if q.bit >= CHAR_BITS {
            return;
        }
        let pair_open = q.pair_open;
        if edge {
            self.edge(q);
        }
        self.pass(q, level, pair_open && !edge);
    }

    /// `n` clocks with the line constant at `level` and no edge: what `n` calls of
    /// [`CharReader::clock`] leave, register for register, in as many steps as bits end.
    pub fn advance(&self, q: &mut CharReaderQ, level: bool, mut n: u64) {
        while n > 0 && q.bit < CHAR_BITS {
            // Clocks before the one that ends the bit.
            let k = ((q.rem - 1) / self.inc).min(n);
            if k > 0 {
                let span = k * self.inc;
                within_bit(q, level, span);
                if q.pair_open {
                    pair_window_runs(q, span);
                }
                n -= k;
            }
            if n > 0 {
                self.pass(q, level, q.pair_open);
                n -= 1;
            }
        }
    }

    /// The character the replay reads from the edges so far, the line lasting at `level`:
    /// the current bit by `lead` or `lag`, every bit after it whole at `level`.
    pub fn read(&self, q: &CharReaderQ, level: bool) -> Reading {
        let mut r = *q;
        let whole = if level {
            self.modulo as i64
        } else {
            -(self.modulo as i64)
        };
        let mut total = if level { r.lead } else { r.lag };
        while r.bit < CHAR_BITS {
            decide(&mut r, total);
            total = whole;
        }
        Reading {
            bits: (!r.tie).then_some(r.shift),
            glitches: r.glitches,
        }
    }

    /// An edge at the start of the current clock, `modulo - rem` into its bit: off the grid
    /// when more than a quarter bit from a boundary; two off it within half a bit are one
    /// glitch.
    fn edge(&self, q: &mut CharReaderQ) {
        let off = q.rem > self.quarter && q.rem < self.three_quarters;
        if !off || q.pair_open {
            // On the grid, or the second edge of a glitch inside a bit.
            q.pair_open = false;
            q.pair_left = 0;
        } else {
            q.glitches = (q.glitches + 1).min(GLITCHES_MAX);
            q.pair_open = true;
            q.pair_left = self.half_less_inc;
        }
    }

    /// One clock at `level`: `inc` more phase; a bit that ends on it is decided by the sign
    /// of its balance (a bit lasts at least 3 clocks, so at most one ends). `pair_runs`: a
    /// glitch opened before this clock may still be ended, and its half bit runs on.
    fn pass(&self, q: &mut CharReaderQ, level: bool, pair_runs: bool) {
        let modulo = self.modulo as i64;
        if q.rem > self.inc {
            within_bit(q, level, self.inc);
        } else {
            decide(q, if level { q.lead } else { q.lag });
            // The units of this clock past the bit's end open the next bit.
            let twice_rem = 2 * q.rem as i64;
            q.rem += self.modulo_less_inc;
            (q.lead, q.lag) = if level {
                (modulo, -(self.modulo_less_two_inc as i64) - twice_rem)
            } else {
                (self.modulo_less_two_inc as i64 + twice_rem, -modulo)
            };
        }
        if pair_runs {
            pair_window_runs(q, self.inc);
        }
    }
}

/// `span` phase units at `level` that end before the current bit does.
fn within_bit(q: &mut CharReaderQ, level: bool, span: u64) {
    q.rem -= span;
    if level {
        q.lag += 2 * span as i64;
    } else {
        q.lead -= 2 * span as i64;
    }
}

/// `span` units pass of the half bit within which a second edge off the grid ends the glitch
/// the first one opened; past it, the window closes.
fn pair_window_runs(q: &mut CharReaderQ, span: u64) {
    if q.pair_left >= span {
        q.pair_left -= span;
    } else {
        q.pair_open = false;
        q.pair_left = 0;
    }
}

/// The bit whose balance is `total`: high if positive, a tie at 0.
fn decide(q: &mut CharReaderQ, total: i64) {
    q.tie |= total == 0;
    q.shift = q.shift >> 1 | u16::from(total > 0) << (CHAR_BITS - 1);
    q.bit += 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::DEFAULT_CLOCK_HZ;
    use crate::uart::{bits_by_longer_level, glitches_off_grid};
    use dp_consts::Baud;
    use proptest::prelude::*;

    /// The replay's reading at clock `now` after the start (edges at clocks `edges`, the first
    /// a rise, strictly after 0 and at most `now`).
    fn replay(timing: BitTiming, edges: &[u64], now: u64) -> Reading {
        let scaled: Vec<u64> = edges
            .iter()
            .filter(|&&e| e <= now)
            .map(|e| e * timing.inc)
            .take_while(|&at| at < 11 * timing.modulo)
            .collect();
        let bits = bits_by_longer_level(&scaled, false, timing.modulo, 11);
        let glitches = glitches_off_grid(&scaled, timing.modulo).min(u32::from(GLITCHES_MAX));
        Reading {
            bits,
            glitches: glitches as u8,
        }
    }

    /// The reader clocked from the start edge up to clock `now`, the line toggling at `edges`.
    fn clocked(reader: &CharReader, edges: &[u64], now: u64) -> (CharReaderQ, bool) {
        let mut q = CHAR_READER_RESET;
        reader.start(&mut q);
        let mut level = false;
        for c in 1..=now {
            let edge = edges.contains(&c);
            level ^= edge;
            reader.clock(&mut q, level, edge);
        }
        (q, level)
    }

    fn timing_of(rate: usize, ppm: i32) -> BitTiming {
        BitTiming::new(DEFAULT_CLOCK_HZ, Baud::ALL[rate], ppm)
    }

    /// Edges of a character from a station `ppm` off at rate `rate`, with glitches of up to
    /// half a bit; or random edges: strictly increasing clocks after 0; and a clock to read at.
    fn edges_strategy() -> impl Strategy<Value = (usize, Vec<u64>, u64)> {
        (2usize..10, -3000i32..3000, any::<u8>()).prop_flat_map(|(rate, ppm, byte)| {
            let bit = timing_of(rate, 0).clocks_per_bit();
            let sender = timing_of(rate, ppm);
            let bits = crate::uart::char_bits(byte);
            let clean: Vec<u64> = (1..11)
                .filter(|&k| bits[k] != bits[k - 1])
                .map(|k| sender.clocks_for(k as u64, 1))
                .collect();
            let span = 12 * bit;
            let glitches = proptest::collection::vec((1..span, 1..=bit / 2 + 1), 0..4);
            let noise = proptest::collection::vec(1..span, 0..24);
            (glitches, noise, any::<bool>(), 1..span).prop_map(
                move |(glitches, noise, is_noise, now)| {
                    let mut all = if is_noise { noise } else { clean.clone() };
                    if !is_noise {
                        for (at, len) in glitches {
                            all.extend([at, at + len]);
                        }
                    }
                    all.sort_unstable();
                    // Two toggles on one clock are none.
                    let mut toggles: Vec<u64> = Vec::new();
                    for e in all {
                        if toggles.last() == Some(&e) {
                            toggles.pop();
                        } else {
                            toggles.push(e);
                        }
                    }
                    (rate, toggles, now)
                },
            )
        })
    }

    proptest! {
        #![proptest_config(prop_cases::config(512))]

        /// At every clock, the reader reads what the replay reads from the same edges.
        #[test]
        fn the_reader_reads_what_the_replay_reads((rate, edges, now) in edges_strategy()) {
            let timing = timing_of(rate, 0);
            let reader = CharReader::new(timing);
            let (q, level) = clocked(&reader, &edges, now);
            prop_assert_eq!(reader.read(&q, level), replay(timing, &edges, now));
        }

        /// Passing clocks at once leaves the registers that clocking them one by one leaves.
        #[test]
        fn advance_is_clocking_n_times(
            (rate, edges, now) in edges_strategy(),
            n in 0u64..20_000,
            level in any::<bool>(),
        ) {
            let reader = CharReader::new(timing_of(rate, 0));
            let (mut fast, _) = clocked(&reader, &edges, now);
            let mut strict = fast;
            reader.advance(&mut fast, level, n);
            for _ in 0..n {
                reader.clock(&mut strict, level, false);
            }
            prop_assert_eq!(fast, strict);
        }
    }

    /// Every character at every rate, clean, reads as itself with no glitch.
    #[test]
    fn a_clean_character_reads_as_itself_at_every_rate() {
        for baud in Baud::ALL {
            let timing = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let reader = CharReader::new(timing);
            for byte in [0x00u8, 0x10, 0x68, 0xA2, 0xDC, 0xE5, 0xFF] {
                let bits = crate::uart::char_bits(byte);
                let edges: Vec<u64> = (1..11)
                    .filter(|&k| bits[k] != bits[k - 1])
                    .map(|k| timing.clocks_for(k as u64, 1))
                    .collect();
                let middle_of_stop = timing.clocks_for(21, 2);
                let (q, level) = clocked(&reader, &edges, middle_of_stop);
                let want: u16 = (0..11).map(|k| u16::from(bits[k]) << k).sum();
                let reading = reader.read(&q, level);
                assert_eq!(
                    reading,
                    Reading {
                        bits: Some(want),
                        glitches: 0
                    },
                    "{baud} {byte:02x}"
                );
            }
        }
    }
}
