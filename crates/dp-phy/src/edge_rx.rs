//! The receiver at a known rate, by the line's edges.
//!
//! Contract: it takes characters from the edges of the synchronised line ([`LineEdges`], the
//! same edges the search sees), each bit by the level the line held longer within it. A glitch
//! shorter than half a bit cannot turn a bit so, nor can an edge it moved; a bit that held both
//! levels equally long makes the character `Noise`, and so do edges off the bit grid that two
//! glitches cannot explain (a faster rate's characters, which would otherwise read as whatever
//! level their bits held longer).
//!
//! A character starts at a fall of the line, once the last character's stop bit is half over.
//! A fall inside the start bit of that candidate (after a rise) is a second candidate: a glitch
//! there (a high one in the start bit, or a low one just before it) leaves the line with two
//! falls within a bit, and either may be the start. Each candidate is read on its own grid:
//!
//! ```text
//!  line   ‾‾‾‾‾‾|__|‾|___________|‾‾‾‾‾...    a high glitch a third into the start bit
//!               c0   c1                       two candidates: c0 reads the character, c1
//!               |<- 10.5 bits ->|             reads it shifted by half a bit
//! ```
//!
//! - A candidate whose start bit held high longer is a false start: it is dropped when the next
//!   fall comes after its start bit, or at its decision; a character needs one with a start
//!   bit, parity and stop bit right.
//! - Two candidates that read the same character are one (the later start is kept, so that
//!   nothing after it is timed early); two that read different good characters are `Noise`:
//!   the line does not say which it was.
//! - The decision falls at the middle of the last candidate's stop bit, or, with the line low
//!   there (a glitch in the stop bit, or a framing error), at its end: its whole stop bit is
//!   weighed.
//! - Falls that came while a decision was pending are taken from the edges kept afterwards, so
//!   a character that starts while two candidates are still open is not lost.
//!
//! The receiver acts on falls and on its decision tick only: fast mode stops there.

use crate::uart::{bits_by_longer_level, glitches_off_grid, parity_bit, CharError, RxChar};
use crate::{BitTiming, Tick};

/// Edges kept: a character's 10 changes, a second candidate's, and glitches besides (a power
/// of two: a ring).
pub const EDGES_KEPT: usize = 32;

/// Glitches a character may hold: two (the search, which decides the rate, takes one).
const MAX_GLITCHES: u32 = 2;

/// The line's last edges, a ring: each with its tick and whether the line rose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineEdges {
    at: [Tick; EDGES_KEPT],
    /// Bit `i`: the edge in slot `i` was a rise.
    rose: u32,
    /// Edges since reset: edge `n` is in slot `n % EDGES_KEPT` while it is kept.
    seen: u64,
}

impl LineEdges {
    pub const EMPTY: LineEdges = LineEdges {
        at: [0; EDGES_KEPT],
        rose: 0,
        seen: 0,
    };

    pub fn push(&mut self, at: Tick, rose: bool) {
        let slot = (self.seen % EDGES_KEPT as u64) as usize;
        self.at[slot] = at;
        self.rose = self.rose & !(1 << slot) | u32::from(rose) << slot;
        self.seen += 1;
    }

    /// Edges seen since reset: the next edge's number.
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// Edge `n`'s tick and whether the line rose there, while it is kept.
    pub fn get(&self, n: u64) -> Option<(Tick, bool)> {
        if n >= self.seen || self.seen - n > EDGES_KEPT as u64 {
            return None;
        }
        let slot = (n % EDGES_KEPT as u64) as usize;
        Some((self.at[slot], self.rose >> slot & 1 == 1))
    }
}

/// Registers of the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeRxQ {
    /// The candidate start edges of the character under way (numbers in [`LineEdges`]), the
    /// first fall first; `n_starts` of them (0: none under way).
    pub starts: [u64; 2],
    pub n_starts: u8,
    /// Idle clocks before the first candidate.
    pub idle_before: Tick,
    /// A fall before this tick is in the last character's stop bit, no start.
    pub ready_at: Tick,
    /// The tick the receiver acts on next (`Tick::MAX`: none under way), and what it does.
    pub deadline: Tick,
    pub stage: Stage,
}

/// What the receiver does at its deadline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// The last candidate's start bit is over: the candidates whose start bit held high longer
    /// are dropped (a low glitch on an idle line is gone a bit later, not at the decision).
    StartBit,
    /// The middle of the last candidate's stop bit: the decision, with the line high there.
    StopMiddle,
    /// The end of that stop bit: the decision, the line having been low at its middle.
    StopEnd,
}

pub const EDGE_RX_RESET: EdgeRxQ = EdgeRxQ {
    starts: [0; 2],
    n_starts: 0,
    idle_before: 0,
    ready_at: 0,
    deadline: Tick::MAX,
    stage: Stage::StartBit,
};

impl EdgeRxQ {
    /// Whether a character is under way.
    pub fn active(&self) -> bool {
        self.n_starts > 0
    }
}

/// What one candidate start reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Read {
    FalseStart,
    Char(u8, Option<CharError>),
}

/// The receiver's fixed configuration for one rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeRx {
    pub timing: BitTiming,
    /// Clocks from a start edge to the end of its start bit, the middle of its stop bit, and
    /// its end.
    start_end: Tick,
    stop_middle: Tick,
    stop_end: Tick,
}

impl EdgeRx {
    pub fn new(timing: BitTiming) -> Self {
        EdgeRx {
            timing,
            start_end: timing.clocks_for(1, 1),
            stop_middle: timing.clocks_for(21, 2),
            stop_end: timing.clocks_for(11, 1),
        }
    }

    /// A fall of the line: edge `n` of `edges`, after `idle_before` idle clocks.
    pub fn on_fall(&self, n: u64, idle_before: Tick, edges: &LineEdges, q: &mut EdgeRxQ) {
        let Some((at, _)) = edges.get(n) else {
            return;
        };
        if q.stage == Stage::StartBit {
            self.drop_false_starts(at, edges, q);
        }
        if q.n_starts == 0 {
            if at >= q.ready_at {
                *q = EdgeRxQ {
                    starts: [n, n],
                    n_starts: 1,
                    idle_before,
                    deadline: at + self.start_end,
                    stage: Stage::StartBit,
                    ..*q
                };
            }
        } else if self.within_start_bit(self.start_tick(q.starts[0], edges), at) {
            q.starts[1] = n;
            q.n_starts = 2;
            q.deadline = at + self.start_end;
            q.stage = Stage::StartBit;
        }
    }

    /// The bit of the last candidate under way at `now`, for waveforms (0 with none).
    pub fn bit_at(&self, now: Tick, edges: &LineEdges, q: &EdgeRxQ) -> u8 {
        if !q.active() {
            return 0;
        }
        let start = self.start_tick(q.starts[q.n_starts as usize - 1], edges);
        ((now - start.min(now)) * self.timing.inc / self.timing.modulo).min(15) as u8
    }

    /// At the deadline (`now == q.deadline`), with the line at `level`: the character, if one
    /// was decided (a false start is none), and the idle clocks before it.
    pub fn act(
        &self,
        now: Tick,
        level: bool,
        edges: &LineEdges,
        q: &mut EdgeRxQ,
    ) -> Option<(RxChar, Tick)> {
        match q.stage {
            Stage::StartBit => {
                self.drop_false_starts(now, edges, q);
                if q.active() {
                    q.stage = Stage::StopMiddle;
                    q.deadline = self.last_start(q, edges) + self.stop_middle;
                }
                None
            }
            Stage::StopMiddle if !level => {
                q.stage = Stage::StopEnd;
                q.deadline = self.last_start(q, edges) + self.stop_end;
                None
            }
            Stage::StopMiddle | Stage::StopEnd => self.decide(edges, q),
        }
    }

    fn last_start(&self, q: &EdgeRxQ, edges: &LineEdges) -> Tick {
        self.start_tick(q.starts[q.n_starts as usize - 1], edges)
    }

    /// The candidates whose start bit is over by `now` and held high longer are dropped.
    fn drop_false_starts(&self, now: Tick, edges: &LineEdges, q: &mut EdgeRxQ) {
        let mut kept = 0;
        for i in 0..q.n_starts as usize {
            let n = q.starts[i];
            let t = self.start_tick(n, edges);
            let over = !self.within_start_bit(t, now);
            if !(over && self.read(n, 1, edges) != Some(0)) {
                q.starts[kept] = n;
                kept += 1;
            }
        }
        q.n_starts = kept as u8;
        q.deadline = if kept == 0 {
            Tick::MAX
        } else {
            self.last_start(q, edges)
                + match q.stage {
                    Stage::StartBit => self.start_end,
                    Stage::StopMiddle => self.stop_middle,
                    Stage::StopEnd => self.stop_end,
                }
        };
    }

    fn start_tick(&self, n: u64, edges: &LineEdges) -> Tick {
        edges.get(n).map_or(0, |(t, _)| t)
    }

    fn within_start_bit(&self, start: Tick, at: Tick) -> bool {
        (at - start.min(at)) * self.timing.inc < self.timing.modulo
    }

    /// The edges of the character from start edge `n` up to `bits` bits after it, in phase
    /// units from the start (`None` with the edges no longer kept).
    fn edges_after(
        &self,
        n: u64,
        bits: u32,
        edges: &LineEdges,
    ) -> Option<([u64; EDGES_KEPT], usize)> {
        let (start, _) = edges.get(n)?;
        let (inc, m) = (self.timing.inc, self.timing.modulo);
        let mut rel = [0u64; EDGES_KEPT];
        let mut count = 0;
        for k in n + 1..edges.seen() {
            let (at, _) = edges.get(k)?;
            let e = (at - start) * inc;
            if e >= u64::from(bits) * m {
                break;
            }
            rel[count] = e;
            count += 1;
        }
        Some((rel, count))
    }

    /// Bits `0..bits` from the start edge `n` on its grid, each by the level held longer (the
    /// line after the last edge taken as lasting); `None` on a tie, or with the edges gone.
    fn read(&self, n: u64, bits: u32, edges: &LineEdges) -> Option<u16> {
        let (rel, count) = self.edges_after(n, bits, edges)?;
        bits_by_longer_level(&rel[..count], false, self.timing.modulo, bits)
    }

    fn read_char(&self, n: u64, edges: &LineEdges) -> Read {
        let noise = |byte| Read::Char(byte, Some(CharError::Noise));
        let Some((rel, count)) = self.edges_after(n, 11, edges) else {
            return noise(0);
        };
        let m = self.timing.modulo;
        let Some(bits) = bits_by_longer_level(&rel[..count], false, m, 11) else {
            return noise(0);
        };
        let byte = (bits >> 1) as u8;
        let error = if bits & 1 == 1 {
            return Read::FalseStart;
        } else if glitches_off_grid(&rel[..count], m) > MAX_GLITCHES {
            return noise(byte);
        } else if bits == 0 {
            Some(CharError::Break)
        } else if bits >> 10 & 1 == 0 {
            Some(CharError::Framing)
        } else if (bits >> 9 & 1 == 1) != parity_bit(byte) {
            Some(CharError::Parity)
        } else {
            None
        };
        Read::Char(byte, error)
    }

    /// The decision: the character the candidates read, if any. Falls kept after the
    /// character's stop bit's middle are then taken as if they came now.
    fn decide(&self, edges: &LineEdges, q: &mut EdgeRxQ) -> Option<(RxChar, Tick)> {
        let last = q.starts[q.n_starts as usize - 1];
        let first = q.starts[0];
        let (read, start) = if q.n_starts == 1 {
            (self.read_char(first, edges), first)
        } else {
            match (self.read_char(first, edges), self.read_char(last, edges)) {
                (Read::Char(a, None), Read::Char(b, None)) if a != b => {
                    (Read::Char(b, Some(CharError::Noise)), last)
                }
                (_, b @ Read::Char(_, None)) => (b, last),
                (a @ Read::Char(_, None), _) => (a, first),
                (Read::FalseStart, b) => (b, last),
                (a, _) => (a, first),
            }
        };
        let first_tick = self.start_tick(first, edges);
        let start_tick = self.start_tick(start, edges);
        let idle_before = q.idle_before;
        *q = EDGE_RX_RESET;
        let c = match read {
            Read::FalseStart => None,
            Read::Char(byte, error) => Some(RxChar {
                byte,
                error,
                start: start_tick,
                end: start_tick + self.stop_end,
            }),
        };
        let end = c.map_or(first_tick, |c| c.end);
        self.catch_up(first_tick, end, edges, q);
        c.map(|c| (c, idle_before))
    }

    /// After a character that started at `start` and ends at `end` (decided by this receiver,
    /// or by the search before it took over): the falls kept after the middle of its stop bit,
    /// taken as if they came now. The next character may have started before the decision.
    pub fn catch_up(&self, start: Tick, end: Tick, edges: &LineEdges, q: &mut EdgeRxQ) {
        q.ready_at = start + self.stop_middle;
        // The edges since then, found from the newest back: a few at most.
        let mut from = edges.seen();
        while from > 0 && edges.get(from - 1).is_some_and(|(at, _)| at >= q.ready_at) {
            from -= 1;
        }
        for k in from..edges.seen() {
            if let Some((at, false)) = edges.get(k) {
                self.on_fall(k, at.saturating_sub(end), edges, q);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::DEFAULT_CLOCK_HZ;
    use crate::uart::char_bits;
    use dp_consts::Baud;

    /// The line with `bytes` sent back to back from `t0` at `timing`, idle high around them,
    /// inverted over `glitches` (tick, clocks).
    fn line(
        timing: BitTiming,
        t0: Tick,
        bytes: &[u8],
        glitches: &[(Tick, Tick)],
    ) -> impl Fn(Tick) -> bool {
        let bits: Vec<bool> = bytes.iter().flat_map(|&b| char_bits(b)).collect();
        let glitches = glitches.to_vec();
        move |now: Tick| {
            let clean = now < t0 || {
                let bit = ((now - t0) * timing.inc / timing.modulo) as usize;
                bits.get(bit).copied().unwrap_or(true)
            };
            clean
                != glitches
                    .iter()
                    .any(|&(at, len)| (at..at + len).contains(&now))
        }
    }

    /// The characters the receiver takes from `line` over `ticks`, as the transceiver drives it.
    fn receive(rx: &EdgeRx, line: impl Fn(Tick) -> bool, ticks: Tick) -> Vec<RxChar> {
        let (mut edges, mut q) = (LineEdges::EMPTY, EDGE_RX_RESET);
        let mut level = true;
        let mut got = Vec::new();
        for now in 0..ticks {
            let l = line(now);
            if l != level {
                edges.push(now, l);
                if !l {
                    rx.on_fall(edges.seen() - 1, 0, &edges, &mut q);
                }
                level = l;
            }
            if now >= q.deadline {
                got.extend(rx.act(now, level, &edges, &mut q).map(|(c, _)| c));
            }
        }
        got
    }

    fn bytes(chars: &[RxChar]) -> Vec<(u8, Option<CharError>)> {
        chars.iter().map(|c| (c.byte, c.error)).collect()
    }

    const SENT: [u8; 4] = [0x68, 0xFF, 0x00, 0x5B];

    fn clean(sent: &[u8]) -> Vec<(u8, Option<CharError>)> {
        sent.iter().map(|&b| (b, None)).collect()
    }

    #[test]
    fn characters_back_to_back_are_taken_at_every_rate_and_offset() {
        for baud in Baud::ALL {
            for ppm in [-5000, 0, 5000] {
                let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
                let rx = EdgeRx::new(BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0));
                let t0 = master.clocks_for(20, 1);
                let got = receive(
                    &rx,
                    line(master, t0, &SENT, &[]),
                    t0 + master.clocks_for(60, 1),
                );
                assert_eq!(bytes(&got), clean(&SENT), "{baud} {ppm} ppm");
                assert_eq!(got[0].start, t0, "{baud} {ppm} ppm");
            }
        }
    }

    /// A glitch that leaves two falls in a start bit: a high one inside it, or a low one just
    /// before it. Either way the character is taken, from its real start.
    #[test]
    fn a_glitch_at_a_start_bit_costs_nothing() {
        for baud in [Baud::B9600, Baud::B187500, Baud::B1500000] {
            let t = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let rx = EdgeRx::new(t);
            let t0 = t.clocks_for(20, 1);
            // The second character's start bit (0xFF: its start bit alone is low).
            let start = t0 + t.clocks_for(11, 1);
            for eighths in 1..4 {
                let len = t.clocks_for(3, 8);
                let inside = (start + t.clocks_for(eighths, 8), len);
                let before = (start - len - t.clocks_for(eighths, 8), len);
                for glitch in [inside, before] {
                    let l = line(t, t0, &SENT, &[glitch]);
                    let got = receive(&rx, l, t0 + t.clocks_for(60, 1));
                    assert_eq!(bytes(&got), clean(&SENT), "{baud} glitch {glitch:?}");
                    assert_eq!(got[1].start, start, "{baud} glitch {glitch:?}");
                }
            }
        }
    }

    /// A low glitch in a stop bit, just after its rise or at its middle: the character is
    /// taken (its whole stop bit weighed) and so is the next one.
    #[test]
    fn a_glitch_in_a_stop_bit_costs_nothing() {
        let t = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B1500000, 0);
        let rx = EdgeRx::new(t);
        let t0 = t.clocks_for(20, 1);
        let stop = t0 + t.clocks_for(10, 1);
        for from_sixteenths in [1, 6, 8] {
            let glitch = (
                stop + t.clocks_for(from_sixteenths, 16),
                t.clocks_for(7, 16),
            );
            let got = receive(&rx, line(t, t0, &SENT, &[glitch]), t0 + t.clocks_for(60, 1));
            assert_eq!(bytes(&got), clean(&SENT), "glitch {glitch:?}");
        }
    }

    /// A low pulse of a glitch on an idle line is no character, and the one after it is taken.
    #[test]
    fn a_glitch_on_an_idle_line_is_no_character() {
        let t = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B93750, 0);
        let rx = EdgeRx::new(t);
        let t0 = t.clocks_for(20, 1);
        let glitch = (t0 - t.clocks_for(3, 1), t.clocks_for(2, 5));
        let got = receive(&rx, line(t, t0, &SENT, &[glitch]), t0 + t.clocks_for(60, 1));
        assert_eq!(bytes(&got), clean(&SENT));
    }

    /// Characters of a rate 2.67 times faster, seen at the slower rate, are never taken as
    /// good: their edges fall off the slower grid.
    #[test]
    fn a_faster_rates_characters_are_not_taken() {
        let fast = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B500000, 0);
        let rx = EdgeRx::new(BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B187500, 0));
        let sent: Vec<u8> = (0..=255).collect();
        let t0 = fast.clocks_for(20, 1);
        let got = receive(
            &rx,
            line(fast, t0, &sent, &[]),
            t0 + fast.clocks_for(11 * 260, 1),
        );
        let good = got.iter().filter(|c| c.error.is_none()).count();
        assert!(
            good * 20 < got.len(),
            "{good} of {} taken as good",
            got.len()
        );
    }

    #[test]
    fn edges_older_than_the_ring_are_gone() {
        let mut edges = LineEdges::EMPTY;
        for k in 0..40 {
            edges.push(10 * k, k % 2 == 1);
        }
        assert_eq!(edges.get(7), None);
        assert_eq!(edges.get(8), Some((80, false)));
        assert_eq!(edges.get(39), Some((390, true)));
        assert_eq!(edges.get(40), None);
    }
}
