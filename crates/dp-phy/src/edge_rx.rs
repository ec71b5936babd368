//! The receiver at a known rate, by the line's edges.
//!
//! Contract: it takes characters from the edges of the synchronised line, each bit by the
//! level the line held longer within it, read as the character arrives by a [`CharReader`] per
//! candidate start (the gateware's form: a few registers a reader, one adder deep). A glitch
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
//!   fall comes after its start bit, or at the end of the last candidate's start bit; a
//!   character needs one with a start bit, parity and stop bit right. Each reader's start bit
//!   is kept as it decides it.
//! - Two candidates that read the same character are one (the later start is kept, so that
//!   nothing after it is timed early); two that read different good characters are `Noise`:
//!   the line does not say which it was.
//! - The decision falls at the middle of the last candidate's stop bit, or, with the line low
//!   there (a glitch in the stop bit, or a framing error), at its end: its whole stop bit is
//!   weighed.
//! - The next character may start before that decision: from the middle of the first
//!   candidate's stop bit on, falls open the next character's candidates in a second lane of
//!   two readers, which goes on as the character under way at the decision.
//!
//! Two lanes of two readers: four characters' registers in all, where the receiver before kept
//! the line's last 32 edges with 64-bit ticks and replayed them at each decision. The
//! `receiver_replay` test holds the two equal (every character, error, start, end, idle time
//! and deadline) on random lines at every rate.
//!
//! A receiver at a newly detected rate starts at the search's decision ([`EdgeRx::hand_over`])
//! with nothing but that clock's fall: a character that started between the middle of the
//! detected character's stop bit and the decision (a glitch in its start bit or at its stop
//! bit's middle puts the decision up to a bit later) is lost, and so is its telegram. The
//! search hands over no edges, so the line's edges are kept nowhere (README "Gateware": three
//! of the sweep's 1980 cases lock a telegram later for it, all hit by glitches).
//!
//! The transceiver's receiver samples the line ([`EdgeRx::sampled`]) on the ticks on which the
//! search's channel of its rate samples it (`autobaud::OVERSAMPLED`: 16 to 22 samples a bit,
//! every clock at 3, 6 and 12 Mbit/s): it sees a change at its next sample, or not at all if
//! the line is back before it, its readers count samples, and a start is the sample that saw
//! the fall. So a reader's phase registers are as narrow as the search channel's (7 bits
//! instead of 13 at 9.6k, README "Gateware"), and the receiver sees the line as the search's
//! channel does, whose idle line the transceiver's TSYN, gap and TSDR reckoning follows.
//! [`EdgeRx::new`] samples every clock.
//!
//! The receiver acts on edges and on its decision ticks only, its readers passing the samples
//! between at once ([`CharReader::advance`]): fast mode stops there.

use crate::char_reader::{CharReader, CharReaderQ, CHAR_BITS, CHAR_READER_RESET};
use crate::uart::{parity_bit, CharError, RxChar};
use crate::{BitTiming, Tick};

/// Glitches a character may hold: two (the search, which decides the rate, takes one).
const MAX_GLITCHES: u32 = 2;

/// One character's candidate starts, each read as it arrives by a reader of its own, in two
/// slots that keep their registers: a candidate is started in a free slot and dropped by
/// marking it free, so nothing moves between slots (in the gateware, no reader is copied).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lane {
    /// The slots with a candidate under way (none: no character).
    pub live: [bool; 2],
    /// The slot of the first candidate (the earlier fall) while one is under way; the second,
    /// if any, is in the other.
    pub first: usize,
    /// Each slot's start tick and reader.
    pub starts: [Tick; 2],
    pub readers: [CharReaderQ; 2],
    /// Each slot's start bit as its reader decided it: low, and no tie.
    pub start_low: [bool; 2],
    /// The fall that opened the candidates (whatever was dropped since), and the idle clocks
    /// before it: the character's.
    pub opened_at: Tick,
    pub idle_before: Tick,
    /// What the lane does at its deadline (`Tick::MAX`: nothing).
    pub stage: Stage,
    pub deadline: Tick,
}

pub const LANE_EMPTY: Lane = Lane {
    live: [false; 2],
    first: 0,
    starts: [0; 2],
    readers: [CHAR_READER_RESET; 2],
    start_low: [false; 2],
    opened_at: 0,
    idle_before: 0,
    stage: Stage::StartBit,
    deadline: Tick::MAX,
};

impl Lane {
    /// Candidates under way.
    pub fn n_starts(&self) -> usize {
        usize::from(self.live[0]) + usize::from(self.live[1])
    }

    /// The slot of the last candidate (the first when it is alone).
    fn last(&self) -> usize {
        if self.n_starts() == 2 {
            1 - self.first
        } else {
            self.first
        }
    }

    /// Empty again: its slots free (their registers stay as they are).
    fn close(&mut self) {
        self.live = [false; 2];
        self.first = 0;
        self.stage = Stage::StartBit;
        self.deadline = Tick::MAX;
    }
}

/// Registers of the receiver: two lanes, one the character under way (`lanes[cur]`), the other
/// the next one, which may start before the first is decided (the decision waits for the middle
/// of the last candidate's stop bit, or its end). At the decision they swap roles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeRxQ {
    pub lanes: [Lane; 2],
    /// The lane of the character under way; the other takes the falls from `next_from` on while
    /// its decision is pending: the next character's candidates.
    pub cur: usize,
    /// The middle of the current lane's first candidate's stop bit once its candidates are
    /// final (`Tick::MAX` before).
    pub next_from: Tick,
    /// The readers have taken the line through this tick.
    pub read_until: Tick,
    /// The current lane's deadline: the tick the receiver acts on next.
    pub deadline: Tick,
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
    lanes: [LANE_EMPTY; 2],
    cur: 0,
    next_from: Tick::MAX,
    read_until: 0,
    deadline: Tick::MAX,
};

impl EdgeRxQ {
    /// Whether a character is under way.
    pub fn active(&self) -> bool {
        self.lanes[self.cur].n_starts() > 0
    }

    /// The lane of the character under way, and the next one's.
    pub fn current(&self) -> &Lane {
        &self.lanes[self.cur]
    }

    pub fn next(&self) -> &Lane {
        &self.lanes[1 - self.cur]
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
    /// The rate's bit in clocks.
    pub timing: BitTiming,
    /// The readers count in samples: a sample is `period` clocks of phase.
    reader: CharReader,
    /// The receiver samples the line at the ticks `t` with `t % period == phase` (a period
    /// of 1: every clock).
    pub period: Tick,
    pub phase: Tick,
    /// Clocks from a start edge to the end of its start bit, the middle of its stop bit, and
    /// its end, in whole samples.
    start_end: Tick,
    stop_middle: Tick,
    stop_end: Tick,
}

impl EdgeRx {
    /// The receiver that samples the line every clock.
    pub fn new(timing: BitTiming) -> Self {
        Self::sampled(timing, 1, 0)
    }

    /// The receiver that takes the line at the ticks `t` with `t % period == phase`, as the
    /// search's channel of its rate samples it (README "Gateware": a reader's phase is then as
    /// narrow as that channel's). Edges and hand-overs come only on those ticks, and the
    /// deadlines fall only there (whole samples from a start); a decision may act a clock
    /// after its deadline (the next lane's, passed while the current one was decided), and
    /// reads the samples to then.
    pub fn sampled(timing: BitTiming, period: Tick, phase: Tick) -> Self {
        assert!(phase < period, "a phase is one of its period's clocks");
        let samples = BitTiming {
            inc: timing.inc * period,
            modulo: timing.modulo,
        };
        EdgeRx {
            timing,
            reader: CharReader::new(samples),
            period,
            phase,
            start_end: period * samples.clocks_for(1, 1),
            stop_middle: period * samples.clocks_for(21, 2),
            stop_end: period * samples.clocks_for(11, 1),
        }
    }

    /// The readers' figures (in samples), as the gateware takes them.
    pub fn reader(&self) -> &CharReader {
        &self.reader
    }

    /// Clocks from a start to the end of its start bit, the middle of its stop bit and its
    /// end: the gateware's `start_end_i`, `stop_middle_i` and `stop_end_i`.
    pub fn offsets(&self) -> [Tick; 3] {
        [self.start_end, self.stop_middle, self.stop_end]
    }

    /// The line changed as sampled at `now`: it `rose`, or fell after `idle_before` idle clocks.
    pub fn on_edge(&self, now: Tick, rose: bool, idle_before: Tick, q: &mut EdgeRxQ) {
        debug_assert_eq!(
            now % self.period,
            self.phase,
            "an edge off the sample ticks"
        );
        self.read_to(now.saturating_sub(1), !rose, q);
        // Falls are judged on the readers through the clock before them: a start bit is over
        // when its reader decided it on an earlier clock.
        let mut started = [None, None];
        if !rose {
            let lane = if q.next_from <= now { 1 - q.cur } else { q.cur };
            started[lane] = self.on_fall(&mut q.lanes[lane], now, idle_before);
        }
        for (lane, started) in q.lanes.iter_mut().zip(started) {
            for slot in 0..2 {
                if started == Some(slot) {
                    self.reader.start(&mut lane.readers[slot]);
                } else if lane.live[slot] {
                    self.clock(lane, slot, rose);
                }
            }
        }
        q.read_until = now;
        q.deadline = q.lanes[q.cur].deadline;
    }

    /// A fall at `at` into `lane`. Returns the slot of the candidate it starts, whose reader
    /// is to be started. (A fall after the decision is past the middle of the last character's
    /// stop bit, the decision's earliest tick: nothing bars it.)
    fn on_fall(&self, lane: &mut Lane, at: Tick, idle_before: Tick) -> Option<usize> {
        if lane.stage == Stage::StartBit {
            self.drop_false_starts(lane);
        }
        if lane.n_starts() == 0 {
            lane.live = [true, false];
            lane.first = 0;
            lane.starts[0] = at;
            lane.start_low[0] = false;
            lane.opened_at = at;
            lane.idle_before = idle_before;
            lane.stage = Stage::StartBit;
            lane.deadline = at + self.start_end;
            Some(0)
        } else if lane.readers[lane.first].bit == 0 {
            // Inside the first candidate's start bit: a second candidate (a later one replaces
            // it), in the other slot.
            let second = 1 - lane.first;
            lane.live[second] = true;
            lane.starts[second] = at;
            lane.start_low[second] = false;
            lane.deadline = at + self.start_end;
            lane.stage = Stage::StartBit;
            Some(second)
        } else {
            None
        }
    }

    /// The bit of the last candidate under way at `now`, for waveforms (0 with none).
    pub fn bit_at(&self, now: Tick, q: &EdgeRxQ) -> u8 {
        if !q.active() {
            return 0;
        }
        let lane = q.current();
        let start = lane.starts[lane.last()];
        ((now - start.min(now)) * self.timing.inc / self.timing.modulo).min(15) as u8
    }

    /// At the deadline (`now == q.deadline`, or after it), with the line at `level`: the
    /// character, if one was decided (a false start is none), and the idle clocks before it.
    pub fn act(&self, now: Tick, level: bool, q: &mut EdgeRxQ) -> Option<(RxChar, Tick)> {
        self.read_to(now, level, q);
        let lane = &mut q.lanes[q.cur];
        let out = match lane.stage {
            Stage::StartBit => {
                // Every candidate's start bit is over by now.
                self.drop_false_starts(lane);
                if lane.n_starts() > 0 {
                    lane.stage = Stage::StopMiddle;
                    lane.deadline = lane.starts[lane.last()] + self.stop_middle;
                    q.next_from = lane.starts[lane.first] + self.stop_middle;
                }
                None
            }
            Stage::StopMiddle if !level => {
                lane.stage = Stage::StopEnd;
                lane.deadline = lane.starts[lane.last()] + self.stop_end;
                None
            }
            Stage::StopMiddle | Stage::StopEnd => self.decide(level, q),
        };
        q.deadline = q.lanes[q.cur].deadline;
        out
    }

    /// The candidates whose start bit is over (decided by their reader) and did not read
    /// low are dropped; the first left is the first.
    fn drop_false_starts(&self, lane: &mut Lane) {
        for slot in 0..2 {
            let over = lane.readers[slot].bit >= 1;
            // Kept: its start bit still under way, or read low.
            lane.live[slot] &= !over || lane.start_low[slot];
        }
        if !lane.live[lane.first] && lane.live[1 - lane.first] {
            lane.first = 1 - lane.first;
        }
        lane.deadline = if lane.n_starts() == 0 {
            Tick::MAX
        } else {
            lane.starts[lane.last()]
                + match lane.stage {
                    Stage::StartBit => self.start_end,
                    Stage::StopMiddle => self.stop_middle,
                    Stage::StopEnd => self.stop_end,
                }
        };
    }

    /// The readers under way through tick `until`, the line at `level` since the last tick
    /// they took: the samples between.
    fn read_to(&self, until: Tick, level: bool, q: &mut EdgeRxQ) {
        let n = self.samples_through(until) - self.samples_through(until.min(q.read_until));
        if n > 0 {
            for lane in &mut q.lanes {
                for slot in 0..2 {
                    if lane.live[slot] {
                        self.advance(lane, slot, level, n);
                    }
                }
            }
        }
        q.read_until = q.read_until.max(until);
    }

    /// The receiver's sample ticks from 0 through `t`.
    fn samples_through(&self, t: Tick) -> u64 {
        (t + self.period - self.phase) / self.period
    }

    /// `n` samples of the reader in `slot` at `level`; its start bit's reading is kept as it
    /// is decided.
    fn advance(&self, lane: &mut Lane, slot: usize, level: bool, n: u64) {
        let r = &mut lane.readers[slot];
        if r.bit == 0 {
            let to_decide = r.rem.div_ceil(self.reader.inc);
            if n >= to_decide {
                self.reader.advance(r, level, to_decide);
                lane.start_low[slot] = start_bit_low(r);
                self.reader.advance(r, level, n - to_decide);
                return;
            }
        }
        self.reader.advance(r, level, n);
    }

    /// The reader in `slot` through one sample with an edge to `level`.
    fn clock(&self, lane: &mut Lane, slot: usize, level: bool) {
        let r = &mut lane.readers[slot];
        let before = r.bit;
        self.reader.clock(r, level, true);
        if before == 0 && r.bit == 1 {
            lane.start_low[slot] = start_bit_low(r);
        }
    }

    fn read_char(&self, r: &CharReaderQ, level: bool) -> Read {
        let noise = |byte| Read::Char(byte, Some(CharError::Noise));
        let reading = self.reader.read(r, level);
        let Some(bits) = reading.bits else {
            return noise(0);
        };
        let byte = (bits >> 1) as u8;
        let error = if bits & 1 == 1 {
            return Read::FalseStart;
        } else if u32::from(reading.glitches) > MAX_GLITCHES {
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

    /// The decision: the character the candidates read, if any. The next character's
    /// candidates, from the falls since the middle of this one's stop bit, go on as the
    /// character under way.
    fn decide(&self, level: bool, q: &mut EdgeRxQ) -> Option<(RxChar, Tick)> {
        let lane = &q.lanes[q.cur];
        let (first, last) = (lane.first, lane.last());
        // At the last candidate's stop bit: every reader is in its stop bit or past it (the
        // gateware reads those two cases only).
        debug_assert!([first, last]
            .iter()
            .all(|&slot| lane.readers[slot].bit >= CHAR_BITS - 1));
        let first_read = self.read_char(&lane.readers[first], level);
        let (read, start) = if last == first {
            (first_read, first)
        } else {
            match (first_read, self.read_char(&lane.readers[last], level)) {
                (Read::Char(a, None), Read::Char(b, None)) if a != b => {
                    (Read::Char(b, Some(CharError::Noise)), last)
                }
                (_, b @ Read::Char(_, None)) => (b, last),
                (a @ Read::Char(_, None), _) => (a, first),
                (Read::FalseStart, b) => (b, last),
                (a, _) => (a, first),
            }
        };
        let first_tick = lane.starts[first];
        let start_tick = lane.starts[start];
        let idle_before = lane.idle_before;
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
        q.lanes[q.cur].close();
        q.cur = 1 - q.cur;
        let next = &mut q.lanes[q.cur];
        next.idle_before = next.opened_at.saturating_sub(end);
        q.next_from = Tick::MAX;
        c.map(|c| (c, idle_before))
    }

    /// After the search decided, at `now`, a character that started at `start`, with the line
    /// idle since `idle_from` (the character's end, or the decision if the line rose after
    /// that end: `Detection::rose_after_end`): the receiver on its rate, which did not exist
    /// before, starts on this clock. A fall on it (the line `fell`) opens its next character; a
    /// fall before `now` is not seen (README "Gateware": the search hands over no edges). The
    /// search decides at the middle of the character's stop bit or later, so that fall is no
    /// part of it.
    pub fn hand_over(&self, start: Tick, idle_from: Tick, now: Tick, fell: bool, q: &mut EdgeRxQ) {
        debug_assert!(
            start + self.stop_middle <= now,
            "decided before its stop bit's middle"
        );
        debug_assert_eq!(
            now % self.period,
            self.phase,
            "a hand-over off the sample ticks"
        );
        *q = EdgeRxQ {
            read_until: now,
            ..EDGE_RX_RESET
        };
        if fell {
            self.on_edge(now, false, now.saturating_sub(idle_from), q);
        }
    }
}

/// Whether a reader that just decided the start bit read it low, with no tie.
fn start_bit_low(r: &CharReaderQ) -> bool {
    !r.tie && r.shift >> (CHAR_BITS - 1) & 1 == 0
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
        let mut q = EDGE_RX_RESET;
        let mut level = true;
        let mut got = Vec::new();
        for now in 0..ticks {
            let l = line(now);
            if l != level {
                rx.on_edge(now, l, 0, &mut q);
                level = l;
            }
            if now >= q.deadline {
                got.extend(rx.act(now, level, &mut q).map(|(c, _)| c));
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
}
