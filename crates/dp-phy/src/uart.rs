//! UART receiver and transmitter for PROFIBUS characters (11 bits: start 0, 8 data LSB first,
//! even parity, stop 1; the idle line is 1).
//!
//! ```text
//!  line ‾‾‾‾|_S_|d0_|d1_|d2_|d3_|d4_|d5_|d6_|d7_|_P_|‾ST‾|‾‾‾‾
//!           ^ start edge: phase accumulator starts
//!                 ^ samples at 7/16, 8/16, 9/16 of each bit (majority) when a bit has >= 16
//!                   clocks; one sample at 8/16 below that (4 clocks per bit at 12M/48 MHz)
//! ```
//!
//! The receiver (a master station's, [`crate::station`]) re-synchronises on every start edge. A
//! start bit must stay 0 on every clock up to its last vote, or it is a false start and the
//! receiver is ready again at once. A character whose start edge comes within a bit of a false
//! start is reported as `Noise`: a glitch next to a start edge shifts the sampling of the whole
//! character (several bit errors that parity may not see). Like a UART's, its bits are the
//! samples' majority. Parity, framing (stop bit 0) and break (every bit 0) are reported too.
//! The adapter's own receiver takes characters from the line's edges instead
//! ([`crate::edge_rx`]), each bit by the level held longer, as [`bits_by_longer_level`] and
//! [`glitches_off_grid`] here replay them (its character readers are held equal to these).
//! The transmitter drives a character stream back to back with driver enable asserted only while
//! it sends; it can hold the line idle for a number of its own bit times first (a master's TSYN)
//! and, for fault injection, flip a data bit or drop a character.

use crate::{BitTiming, Tick};

/// What went wrong with one received character.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CharError {
    /// The parity bit does not make the ones even.
    Parity,
    /// The stop bit was 0.
    Framing,
    /// Every bit, stop bit included, was 0: the line was held low.
    Break,
    /// The start edge came within a bit of a false start (a glitch may have moved the
    /// sampling), or a bit held both levels equally long: the character cannot be trusted even
    /// if its parity is right.
    Noise,
}

/// The even-parity bit of `byte`.
pub fn parity_bit(byte: u8) -> bool {
    byte.count_ones() % 2 == 1
}

/// The 11 line levels of `byte`, first on the wire first.
pub fn char_bits(byte: u8) -> [bool; 11] {
    let mut bits = [true; 11];
    bits[0] = false;
    for (i, b) in bits[1..9].iter_mut().enumerate() {
        *b = byte >> i & 1 == 1;
    }
    bits[9] = parity_bit(byte);
    bits
}

/// Line level `bit` (0 = start .. 10 = stop) of `byte`: [`char_bits`] one at a time, for the
/// transmitter, which asks at every bit boundary.
fn char_bit(byte: u8, bit: u8) -> bool {
    match bit {
        0 => false,
        1..=8 => byte >> (bit - 1) & 1 == 1,
        9 => parity_bit(byte),
        _ => true,
    }
}

/// Bits `0..bits` of a character, each the level the line held longer within it: `edges` are
/// the line's changes after the start edge, ascending, in phase units (clocks times `inc` of the
/// rate), `level` the line's level at the start edge, and a bit `modulo` units long. `None`
/// where a bit held both levels equally long. The autobaud search decides a delimiter so, and
/// the adapter's receiver every character: a glitch shorter than half a bit cannot turn a bit,
/// nor can an edge it moved.
pub fn bits_by_longer_level(edges: &[u64], mut level: bool, modulo: u64, bits: u32) -> Option<u16> {
    let mut next = 0;
    let mut out = 0u16;
    for k in 0..u64::from(bits) {
        let (from, to) = (k * modulo, (k + 1) * modulo);
        if next == edges.len() || edges[next] >= to {
            // No edge inside: the bit is the level.
            out |= (level as u16) << k;
            continue;
        }
        let (mut at, mut high) = (from, 0);
        while next < edges.len() && edges[next] < to {
            let e = edges[next].max(from);
            if level {
                high += e - at;
            }
            at = e;
            level = !level;
            next += 1;
        }
        if level {
            high += to - at;
        }
        if 2 * high == modulo {
            return None;
        }
        out |= ((2 * high > modulo) as u16) << k;
    }
    Some(out)
}

/// The glitches it takes to explain the edges (as for [`bits_by_longer_level`]) that are more
/// than a quarter bit from a bit boundary: two such edges less than half a bit apart are one
/// glitch inside a bit, a lone one an edge a glitch moved. A character at its rate has none
/// but its glitches'; a faster rate's characters seen on a slower grid leave many, where each
/// bit would otherwise be whatever level the faster bits inside it held longer.
pub fn glitches_off_grid(edges: &[u64], modulo: u64) -> u32 {
    let off = |e: u64| {
        let into = e % modulo;
        4 * into.min(modulo - into) > modulo
    };
    let mut glitches = 0;
    let mut i = 0;
    while i < edges.len() {
        if off(edges[i]) {
            glitches += 1;
            let pair = edges
                .get(i + 1)
                .is_some_and(|&next| off(next) && 2 * (next - edges[i]) <= modulo);
            i += if pair { 2 } else { 1 };
        } else {
            i += 1;
        }
    }
    glitches
}

/// A character the receiver finished, at the middle of its stop bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RxChar {
    pub byte: u8,
    pub error: Option<CharError>,
    /// The tick the start edge was seen.
    pub start: Tick,
    /// The tick the stop bit ends (computed from the phase at its middle).
    pub end: Tick,
}

/// Sample points within a bit, in sixteenths.
const VOTE_POINTS: [u64; 3] = [7, 8, 9];
const MID_POINT: u64 = 8;

/// Receiver registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RxQ {
    pub active: bool,
    /// Bit being received, 0 = start .. 10 = stop.
    pub bit: u8,
    /// Phase within the bit.
    pub ph: u64,
    /// Ones seen among this bit's samples.
    pub votes: u8,
    /// Bits 0..=10 received so far, bit i at position i.
    pub shift: u16,
    pub start: Tick,
    /// The tick of the last false start, if any.
    pub false_start: Option<Tick>,
    /// This character's start edge came within a bit of a false start.
    pub suspect: bool,
}

pub const RX_RESET: RxQ = RxQ {
    active: false,
    bit: 0,
    ph: 0,
    votes: 0,
    shift: 0,
    start: 0,
    false_start: None,
    suspect: false,
};

/// The receiver's fixed configuration for one rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UartRx {
    pub timing: BitTiming,
    /// Majority of three samples (at least 16 clocks per bit) or one at the middle.
    pub vote: bool,
    /// The sample points in sixteenths of a phase modulo (`point * modulo`), the constants a
    /// comparator holds: the receiver compares against them on every clock.
    thresholds: [u64; 3],
}

impl UartRx {
    pub fn new(timing: BitTiming) -> Self {
        let vote = timing.clocks_per_bit() >= 16;
        let m = timing.modulo;
        let thresholds = if vote {
            VOTE_POINTS.map(|pt| pt * m)
        } else {
            [MID_POINT * m; 3]
        };
        UartRx {
            timing,
            vote,
            thresholds,
        }
    }

    /// Where in a bit this receiver samples, as thresholds of 16 x the phase.
    fn points(&self) -> &[u64] {
        &self.thresholds[..if self.vote { VOTE_POINTS.len() } else { 1 }]
    }

    /// Next state at `now` for the filtered `level` (`fell`: it fell on this clock).
    #[inline(always)]
    pub fn next(&self, now: Tick, level: bool, fell: bool, q: &RxQ) -> (Option<RxChar>, RxQ) {
        let mut d = *q;
        if !q.active {
            if fell {
                d.active = true;
                d.bit = 0;
                // The edge happened, on average, half a clock before it was seen.
                d.ph = self.timing.inc / 2;
                d.votes = 0;
                d.shift = 0;
                d.start = now;
                d.suspect = q
                    .false_start
                    .is_some_and(|t| now - t <= self.timing.clocks_per_bit());
            }
            return (None, d);
        }
        let m = self.timing.modulo;
        let p = q.ph + self.timing.inc;
        if q.bit == 0 && level && 16 * q.ph < self.last_vote() {
            // False start: the line rose before the start bit's last vote.
            d.active = false;
            d.false_start = Some(now);
            return (None, d);
        }
        let mut out = None;
        let points = self.points().len();
        let (from, to) = (16 * q.ph, 16 * p);
        for (i, &thr) in self.points().iter().enumerate() {
            if from < thr && thr <= to {
                d.votes += level as u8;
                if i + 1 == points {
                    let one = d.votes as usize * 2 > points;
                    d.votes = 0;
                    d.shift |= (one as u16) << q.bit;
                    if q.bit == 0 && one {
                        d.active = false;
                        d.false_start = Some(now);
                    } else if q.bit == 10 {
                        d.active = false;
                        out = Some(self.finish(now, p, d.shift, q.start, q.suspect));
                    }
                }
                break;
            }
        }
        if p >= m {
            d.ph = p - m;
            d.bit = q.bit + 1;
        } else {
            d.ph = p;
        }
        (out, d)
    }

    /// Clocks that [`next`](Self::next) would spend only moving the phase, for a constant
    /// filtered `level` with no fall: up to the clock that takes a sample or crosses a bit
    /// boundary (left to `next`). None in the start bit on a high level, where every clock
    /// looks for a false start; no limit while idle.
    pub fn quiet_for(&self, level: bool, q: &RxQ) -> Tick {
        if !q.active {
            return Tick::MAX;
        }
        if q.bit == 0 && level {
            return 0;
        }
        let inc = self.timing.inc;
        // The clock whose phase reaches the modulus, and the one whose step (16 x phase)
        // reaches the next sample point, are the first two that do more.
        let mut quiet = (self.timing.modulo - q.ph).div_ceil(inc) - 1;
        if let Some(&point) = self.points().iter().find(|&&thr| thr > 16 * q.ph) {
            quiet = quiet.min((point - 16 * q.ph).div_ceil(16 * inc) - 1);
        }
        quiet
    }

    /// Lets `ticks` pass that [`quiet_for`](Self::quiet_for) allowed.
    pub fn skip(&self, ticks: Tick, q: &mut RxQ) {
        if q.active {
            q.ph += ticks * self.timing.inc;
        }
    }

    /// The threshold of the bit's last sample.
    fn last_vote(&self) -> u64 {
        *self.points().last().expect("at least one sample point")
    }

    fn finish(
        &self,
        now: Tick,
        ph_at_stop_middle: u64,
        shift: u16,
        start: Tick,
        suspect: bool,
    ) -> RxChar {
        let byte = (shift >> 1) as u8;
        let parity = shift >> 9 & 1 == 1;
        let stop = shift >> 10 & 1 == 1;
        let error = if shift == 0 {
            Some(CharError::Break)
        } else if !stop {
            Some(CharError::Framing)
        } else if parity != parity_bit(byte) {
            Some(CharError::Parity)
        } else if suspect {
            Some(CharError::Noise)
        } else {
            None
        };
        let end = now
            + self
                .timing
                .ticks_until(ph_at_stop_middle, self.timing.modulo);
        RxChar {
            byte,
            error,
            start,
            end,
        }
    }
}

/// Transmitter registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TxQ {
    /// Idle bit times still to wait before the first character.
    pub idle_bits: u32,
    /// Index of the character on the wire.
    pub index: u16,
    /// Bit of that character, 0 = start .. 10 = stop.
    pub bit: u8,
    pub ph: u64,
    pub sending: bool,
}

pub const TX_RESET: TxQ = TxQ {
    idle_bits: 0,
    index: 0,
    bit: 0,
    ph: 0,
    sending: false,
};

/// Per-character fault for the transmitter, for tests that need true bit errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CharFault {
    /// Invert data bit `n` (0..8) of this character on the wire; its parity stays the original.
    FlipBit(u8),
    /// Leave the line idle for this character's 11 bits.
    Drop,
}

/// A half-duplex UART transmitter: `line` and `driver_enable` are its outputs.
#[derive(Clone, Debug)]
pub struct UartTx {
    pub timing: BitTiming,
    q: TxQ,
    /// The output, registered at each bit boundary: read on every clock, so not recomputed
    /// from the character on each one.
    out: Option<bool>,
    /// What [`quiet_for`](Self::quiet_for) answered, counted down as the clocks it allowed pass
    /// (the boundary it names stays where it is): `None` until asked again.
    quiet: core::cell::Cell<Option<Tick>>,
    buf: Vec<u8>,
    faults: Vec<(u16, CharFault)>,
}

impl UartTx {
    pub fn new(timing: BitTiming) -> Self {
        UartTx {
            timing,
            q: TX_RESET,
            out: None,
            quiet: core::cell::Cell::new(None),
            buf: Vec::with_capacity(dp_consts::MAX_TELEGRAM_LEN),
            faults: Vec::new(),
        }
    }

    /// Whether a transmission (or its leading idle time) is under way.
    pub fn busy(&self) -> bool {
        self.q.sending || self.q.idle_bits > 0
    }

    /// Start sending `bytes` after `idle_bits` of its own bit times with the driver off.
    ///
    /// # Panics
    /// When a transmission is under way: the caller owns the half-duplex schedule.
    pub fn send(&mut self, idle_bits: u32, bytes: &[u8], faults: &[(u16, CharFault)]) {
        assert!(
            !self.busy(),
            "UartTx::send while a transmission is under way"
        );
        self.buf.clear();
        self.buf.extend_from_slice(bytes);
        self.faults.clear();
        self.faults.extend_from_slice(faults);
        self.q = TxQ {
            idle_bits,
            index: 0,
            bit: 0,
            ph: 0,
            sending: idle_bits == 0 && !bytes.is_empty(),
        };
        self.out = self.drive_at(&self.q);
        self.quiet.set(None);
    }

    fn fault(&self, index: u16) -> Option<CharFault> {
        self.faults
            .iter()
            .find(|(i, _)| *i == index)
            .map(|&(_, f)| f)
    }

    /// The level this transmitter puts on the line, or `None` with its driver disabled.
    #[inline(always)]
    pub fn drive(&self) -> Option<bool> {
        self.out
    }

    /// One clock.
    #[inline(always)]
    pub fn tick(&mut self) {
        if !self.busy() {
            return;
        }
        let p = self.q.ph + self.timing.inc;
        if p < self.timing.modulo {
            self.q.ph = p;
            self.quiet
                .set(self.quiet.get().and_then(|q| q.checked_sub(1)));
            return;
        }
        self.q.ph = p - self.timing.modulo;
        self.q = self.after_boundary(&self.q);
        self.out = self.drive_at(&self.q);
        self.quiet.set(None);
    }

    /// The output at position `q` (as [`drive`](Self::drive) reads it).
    #[inline(always)]
    fn drive_at(&self, q: &TxQ) -> Option<bool> {
        if !q.sending {
            return None;
        }
        let byte = self.buf[q.index as usize];
        match self.fault(q.index) {
            None => Some(char_bit(byte, q.bit)),
            Some(CharFault::Drop) => None,
            Some(CharFault::FlipBit(n)) => {
                let mut bits = char_bits(byte);
                bits[1 + n as usize % 8] ^= true;
                Some(bits[q.bit as usize])
            }
        }
    }

    /// The registers after one bit boundary.
    fn after_boundary(&self, q: &TxQ) -> TxQ {
        let mut d = *q;
        if d.idle_bits > 0 {
            d.idle_bits -= 1;
            d.sending = d.idle_bits == 0 && !self.buf.is_empty();
        } else if d.bit < 10 {
            d.bit += 1;
        } else {
            d.bit = 0;
            d.index += 1;
            d.sending = (d.index as usize) < self.buf.len();
        }
        d
    }

    /// Ticks before this transmitter's output can next change: bit boundaries that keep the
    /// level (a run of equal bits, idle bits) are passed over, up to a bounded look-ahead.
    pub fn quiet_for(&self) -> Tick {
        if !self.busy() {
            return Tick::MAX;
        }
        if let Some(quiet) = self.quiet.get() {
            return quiet;
        }
        const LOOK_AHEAD_BITS: u32 = 24;
        let run_bits = if self.q.idle_bits > 1 && self.out.is_none() {
            // Idle bit times keep the line undriven up to the last of them.
            self.q.idle_bits - 1
        } else {
            let mut q = self.q;
            let mut run = 0;
            while run < LOOK_AHEAD_BITS {
                q = self.after_boundary(&q);
                let busy = q.sending || q.idle_bits > 0;
                if !busy || self.drive_at(&q) != self.out {
                    break;
                }
                run += 1;
            }
            run
        };
        // Phase still to accumulate to reach the boundary that changes the output; the
        // boundary tick itself is left to `tick`.
        let phase = self.timing.modulo - self.q.ph + u64::from(run_bits) * self.timing.modulo;
        let quiet = phase.div_ceil(self.timing.inc) - 1;
        self.quiet.set(Some(quiet));
        quiet
    }

    /// Let `ticks` pass that [`quiet_for`](Self::quiet_for) allowed, crossing bit boundaries
    /// as `tick` would.
    pub fn skip(&mut self, ticks: Tick) {
        self.quiet
            .set(self.quiet.get().and_then(|q| q.checked_sub(ticks)));
        let mut left = ticks;
        // Idle bit times before the first character pass in one step: each boundary between
        // them changes nothing but the count (a master's 33 TSYN bits, at every telegram).
        if self.q.idle_bits > 1 {
            let crossed = (self.q.ph + left * self.timing.inc) / self.timing.modulo;
            if crossed < u64::from(self.q.idle_bits) {
                self.q.ph = self.q.ph + left * self.timing.inc - crossed * self.timing.modulo;
                self.q.idle_bits -= crossed as u32;
                return;
            }
        }
        // Bit boundaries inside characters, which quiet_for let pass without a change of the
        // output, in one step too: 11 bits a character.
        if self.q.idle_bits == 0 && self.q.sending {
            let crossed = (self.q.ph + left * self.timing.inc) / self.timing.modulo;
            self.q.ph = self.q.ph + left * self.timing.inc - crossed * self.timing.modulo;
            if crossed > 0 {
                let pos = u64::from(self.q.bit) + crossed;
                self.q.index += (pos / 11) as u16;
                self.q.bit = (pos % 11) as u8;
                self.q.sending = (self.q.index as usize) < self.buf.len();
                self.out = self.drive_at(&self.q);
            }
            return;
        }
        while left > 0 && self.busy() {
            let to_boundary = self.timing.ticks_until(self.q.ph, self.timing.modulo);
            if left < to_boundary {
                self.q.ph += left * self.timing.inc;
                return;
            }
            self.q.ph = self.q.ph + to_boundary * self.timing.inc - self.timing.modulo;
            self.q = self.after_boundary(&self.q);
            self.out = self.drive_at(&self.q);
            left -= to_boundary;
        }
    }

    pub fn registers(&self) -> TxQ {
        self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glitch under half a bit inside a bit, or one that moved an edge by as much, leaves
    /// every bit its level; a bit that held both levels equally long is none.
    #[test]
    fn bits_are_the_levels_held_longer() {
        let m = 16;
        // 0x68's levels 0 0 0 0 1 0 1 1 0 1 1: changes at bits 4, 5, 6, 8, 9.
        let clean = [4 * m, 5 * m, 6 * m, 8 * m, 9 * m];
        let want = Some(0b110_1101_0000);
        assert_eq!(bits_by_longer_level(&clean, false, m, 11), want);
        // A high glitch of 7/16 in bit 2, and the edge at bit 6 moved 7/16 late.
        let glitched = [2 * m + 4, 2 * m + 11, 4 * m, 5 * m, 6 * m + 7, 8 * m, 9 * m];
        assert_eq!(bits_by_longer_level(&glitched, false, m, 11), want);
        // Half of bit 2 high: neither level.
        assert_eq!(
            bits_by_longer_level(&[2 * m + 8, 3 * m], false, m, 11),
            None
        );
    }
    /// A glitch inside a bit is one, an edge a glitch moved is one, and edges off the grid far
    /// apart are one each.
    #[test]
    fn edges_off_the_grid_count_as_the_glitches_that_explain_them() {
        let m = 16;
        assert_eq!(glitches_off_grid(&[4 * m, 5 * m, 9 * m], m), 0);
        assert_eq!(glitches_off_grid(&[2 * m + 6, 2 * m + 12, 4 * m], m), 1);
        assert_eq!(glitches_off_grid(&[2 * m + 6, 4 * m, 5 * m + 7], m), 2);
        // A faster rate's edges, half a bit off, each its own.
        let faster: Vec<u64> = (1..10).map(|k| k * m + m / 2).collect();
        assert_eq!(glitches_off_grid(&faster, m), 9);
    }
    use crate::timing::DEFAULT_CLOCK_HZ;
    use dp_consts::Baud;

    fn loopback(baud: Baud, tx_ppm: i32, bytes: &[u8], faults: &[(u16, CharFault)]) -> Vec<RxChar> {
        let mut tx = UartTx::new(BitTiming::new(DEFAULT_CLOCK_HZ, baud, tx_ppm));
        let rx = UartRx::new(BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0));
        tx.send(2, bytes, faults);
        let (mut fq, mut rq) = (crate::filter::FILTER_RESET, RX_RESET);
        let len = crate::filter::len_for(rx.timing.clocks_per_bit());
        let mut got = Vec::new();
        let mut now = 0;
        while tx.busy() || rq.active {
            let line = tx.drive().unwrap_or(true);
            let (f, fd) = crate::filter::next(line, len, &fq);
            let (c, rd) = rx.next(now, f.level, f.fell, &rq);
            fq = fd;
            rq = rd;
            got.extend(c);
            tx.tick();
            now += 1;
        }
        got
    }

    #[test]
    fn every_byte_round_trips_at_every_rate() {
        let bytes: Vec<u8> = (0..=255).collect();
        for baud in Baud::ALL {
            for ppm in [-5000, 0, 5000] {
                let got = loopback(baud, ppm, &bytes, &[]);
                let want: Vec<(u8, Option<CharError>)> = bytes.iter().map(|&b| (b, None)).collect();
                let got: Vec<_> = got.iter().map(|c| (c.byte, c.error)).collect();
                assert_eq!(got, want, "{baud} {ppm} ppm");
            }
        }
    }

    #[test]
    fn a_flipped_bit_is_a_parity_error() {
        let got = loopback(
            Baud::B1500000,
            0,
            &[0x68, 0x12, 0x34],
            &[(1, CharFault::FlipBit(3))],
        );
        let errors: Vec<_> = got.iter().map(|c| c.error).collect();
        assert_eq!(errors, [None, Some(CharError::Parity), None]);
    }

    #[test]
    fn character_end_is_eleven_bits_after_the_start_edge() {
        for baud in Baud::ALL {
            let got = loopback(baud, 0, &[0x10], &[]);
            let t = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let len = got[0].end - got[0].start;
            let want = t.clocks_for(11, 1);
            assert!(len.abs_diff(want) <= 1, "{baud}: {len} vs {want}");
        }
    }
}
