//! Baud-rate search: one channel per rate, each deciding on the first character at its rate.
//!
//! Real ASICs step down from 12 Mbit/s one rate per monitoring period and lose telegrams while
//! they do. This block instead listens at all ten rates at once. Each rate's channel sees the
//! idle line with that rate's glitches removed (a pulse of at most half its bit: a real one
//! lasts a bit), and starts a measurement at a fall after TSYN (33 of its bits) of idle line. At
//! the middle of the stop bit (10.5 of its bits after the start edge; at its end if the line is
//! low there) it decides on the character it read as it came ([`CharReader`], the replay of its
//! edges in a few registers): each bit is the level the line held for longer within it (a
//! glitch of the rate is shorter than half a bit, so it cannot turn one, nor can an edge it
//! moved; a tie is nothing), the edges off the bit grid must be one glitch's at most, and
//! the character must have a start bit, even parity and a stop bit, and be a start delimiter
//! (SD1 `10`, SD2 `68`, SD3 `A2`, SD4 `DC`). Then the rate and the decoded first character are
//! handed to the receiver, which goes on with the rest of the telegram, so nothing is lost.
//!
//! ```text
//!  SD1 0x10 at rate r:  ‾‾(TSYN at r)‾‾|_______________|‾‾|_________|‾‾‾‾‾‾
//!                                      t0                          ^ decide: t0 + 10.5 bits
//!  removed first, the glitches of rate r (at most half its bit):  ‾‾|_|‾‾  __|‾|__
//! ```
//!
//! Every start delimiter is one of its rate only: at a faster rate its first pulse is a run of
//! zeros into the stop bit, at a slower one its one-bit pulses are at most half a bit, glitches
//! there, or off the sampling points. Channels are independent, so a long measurement at a slow
//! rate never holds up the fast ones (a master that changes its rate is heard at once), and a
//! glitch in the idle line or in the delimiter costs nothing at the rate it is a glitch of.
//!
//! A channel follows the idle line with its rate's glitches removed, by edges: an edge that
//! comes within the rate's glitch length of the last one it kept cancels that one (the pulse
//! between them never was). A fall after TSYN of that line, and after a high longer than a
//! glitch, starts a measurement, replacing one under way (which a glitch started). A fall after
//! a shorter high, inside the start bit, is a second candidate start: a high glitch in the start
//! bit and a low glitch just before it leave the same edges, so the decision reads the
//! character from both starts, a reader each (two different delimiters are none). A channel
//! works on edges and on its decision tick only, its readers passing the clocks between at once
//! ([`CharReader::advance`]), so fast mode stops there, and passes over decisions that cannot
//! show while a rate is known ([`AutoBaud::quiet_for`], [`AutoBaud::retire`]).
//!
//! A channel may sample the line every few clocks instead of every clock
//! ([`AutoBaud::sampled`] on a [`Schedule`]; [`OVERSAMPLED`]: 16 to 22 samples a bit, as a UART
//! oversamples, the seven slowest channels taking turns in one datapath): it then sees a change
//! of the line at its next sample, or not at all if the line is back before it, and counts its
//! figures in samples, which makes its registers narrow in the FPGA. Fast mode stops at each
//! such sample. [`AutoBaud::new`] samples every clock.
//!
//! A detection is only a candidate: the lock is confirmed by the transceiver when the whole
//! telegram arrives without error. Anything that fails a check is dropped and that rate's
//! channel listens again.

use crate::char_reader::{CharReader, CharReaderQ, Reading, CHAR_READER_RESET};
use crate::filter::FilterOut;
use crate::Tick;
use dp_consts::{Baud, SD1, SD2, SD3, SD4, TSYN_BITS};

/// Edges one measurement takes at most: a character's 10 changes of level, and the glitches of
/// the rate that are still to be cancelled; more, and it is not one of this rate.
const MAX_EDGES: u8 = 16;

/// Glitches a delimiter may hold, read from either start: one. The search decides the rate, so
/// it is stricter than the receiver, which takes two in a character.
const MAX_GLITCHES: u32 = 1;

/// The rates, one channel each (index into `Baud::ALL`, 9.6k first).
const RATES: usize = 10;

/// A character the search decoded and the rate it was sent at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Detection {
    pub baud: Baud,
    pub byte: u8,
    /// Tick of the start edge.
    pub start: Tick,
    /// Tick the stop bit ends.
    pub end: Tick,
    /// The detecting channel's pending edge at the decision (`Tick::MAX`: none): the last
    /// edge of its idle line that a next one within the rate's glitch length would cancel.
    /// The receiver's idle line at the rate goes on from it (`Transceiver`'s `RateIdle`).
    pub pending: Tick,
    /// The detecting channel's idle line rose after the character's end, before the decision:
    /// a decision that waited for a second candidate's stop bit, with the next start bit (or a
    /// glitch longer than the rate's) in between. The receiver's idle line at the rate then
    /// counts from the decision, as its receiver does (it is handed no edges), never longer
    /// than the channel's.
    pub rose_after_end: bool,
}

impl Detection {
    /// The tick the rate's line counts as idle from, for a detection decided on tick
    /// `decided_at`: the character's end, or the decision if the line rose after that end.
    pub fn idle_from(&self, decided_at: Tick) -> Tick {
        if self.rose_after_end {
            decided_at
        } else {
            self.end
        }
    }
}

/// Why a measured character was not taken (for statistics and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// An edge where a bit is sampled (its samples disagree), or off the bit grid.
    OffGrid,
    /// Start, parity or stop bit wrong.
    NotAChar,
    /// A valid character, but no start delimiter.
    NotADelimiter,
}

/// Registers of one rate's measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelQ {
    pub measuring: bool,
    /// The start edge of the measurement.
    pub t0: Tick,
    /// The character read as it arrives ([`CharReader`]): from the start edge, and from the
    /// second candidate start (with `alt`), up to tick `read_until`.
    pub readers: [CharReaderQ; 2],
    pub read_until: Tick,
    /// Edges since the start edge.
    pub n_edges: u8,
    /// A second candidate start, relative to `t0` (0: none): a fall inside the start bit after a
    /// high no longer than a glitch. Either fall may be the start (a high glitch in the start
    /// bit, or a low one just before it), so the decision reads the character from both.
    pub alt: u32,
    /// The tick of the decision: the middle of the last candidate's stop bit, or its end.
    pub decide_at: Tick,
    /// The line was low at the stop bit's middle: the decision weighs the whole stop bit.
    pub deferred: bool,
}

const CHANNEL_RESET: ChannelQ = ChannelQ {
    measuring: false,
    t0: 0,
    readers: [CHAR_READER_RESET; 2],
    read_until: 0,
    n_edges: 0,
    alt: 0,
    decide_at: 0,
    deferred: false,
};

/// Registers of the search. Each rate follows the idle line in three registers, kept as arrays
/// (one per rate) because every edge of the line updates all ten: the last edge kept while a
/// glitch's second edge could still cancel it (`Tick::MAX`: none can); the tick the line has
/// been high since, the rate's glitches aside; and the one before the last rise (what a
/// cancelled rise goes back to). The line at a rate is the line itself after every edge: a
/// cancelling edge restores the level before the cancelled one, which is its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AutoBaudQ {
    pub pending: [Tick; RATES],
    pub high_since: [Tick; RATES],
    pub high_before: [Tick; RATES],
    /// The line's last edge, glitch or not, as each rate sampled it.
    pub last_edge: [Tick; RATES],
    /// The level each rate last sampled, and the sample tick at which it takes the line's
    /// change (`Tick::MAX`: none to take). A rate that samples every clock takes it at once.
    pub held: [bool; RATES],
    pub sample_at: [Tick; RATES],
    pub channels: [ChannelQ; RATES],
    /// Some channel is measuring.
    pub measuring: bool,
    /// The earliest decision due (`Tick::MAX`: none).
    pub deadline: Tick,
}

pub const AUTOBAUD_RESET: AutoBaudQ = AutoBaudQ {
    pending: [Tick::MAX; RATES],
    high_since: [0; RATES],
    high_before: [0; RATES],
    last_edge: [0; RATES],
    held: [true; RATES],
    sample_at: [Tick::MAX; RATES],
    channels: [CHANNEL_RESET; RATES],
    measuring: false,
    deadline: Tick::MAX,
};

impl AutoBaudQ {
    /// The search with the line idle since `now` (a reset on a running bus).
    pub fn idle_since(now: Tick) -> AutoBaudQ {
        AutoBaudQ {
            high_since: [now; RATES],
            high_before: [now; RATES],
            last_edge: [now; RATES],
            ..AUTOBAUD_RESET
        }
    }
}

/// Per-rate constants, computed once from the sample clock.
#[derive(Clone, Copy, Debug)]
struct RateWindow {
    /// Bit period: `modulo / inc` of the channel's samples, exact.
    inc: u64,
    modulo: u64,
    /// Clocks from one of the channel's samples of the line to the next (1: every clock).
    period: u64,
    /// Relative ticks at which the stop bit's middle and its end are reached (whole samples).
    stop_middle: u64,
    stop_end: u64,
}

/// When each channel samples the line: the channel of rate `r` at the ticks `t` with
/// `t % period[r] == phase[r]` (a period of 1: every clock).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    pub period: [u64; RATES],
    pub phase: [u64; RATES],
}

/// Every channel samples every clock ([`AutoBaud::new`]).
pub const EVERY_CLOCK: Schedule = Schedule {
    period: [1; RATES],
    phase: [0; RATES],
};

/// Clocks of the frame in which the seven slowest channels take turns ([`OVERSAMPLED`]).
pub const SHARED_SLOTS: u64 = 24;

/// The search as an FPGA builds it (README "Gateware"): the seven channels up to 1.5 Mbit/s
/// take turns in one datapath, one a clock in a frame of [`SHARED_SLOTS`] clocks (1.5M every
/// other clock, 500k every sixth, 187.5k every twelfth, the four slowest once a frame, sampling
/// on every few of their turns; two slots are free), with 16 to 22 samples a bit at 48 MHz
/// (9.6k and 19.2k 20.8, 45.45k 22, 93.75k and 187.5k 21.3, 500k and 1.5M 16); the three
/// fastest sample every clock (16, 8 and 4 a bit), each in hardware of its own.
pub const OVERSAMPLED: Schedule = Schedule {
    period: [240, 120, 48, 24, 12, 6, 2, 1, 1, 1],
    phase: [17, 11, 9, 5, 3, 1, 0, 0, 0, 0],
};

/// One channel's fixed figures, as the RTL takes them as parameters
/// (gateware/rtl/autobaud_channels.svh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelFigures {
    pub reader: CharReader,
    pub glitch: Tick,
    pub tsyn: Tick,
    pub stop_middle: Tick,
    pub stop_end: Tick,
    /// A fall fewer samples (clocks, sampling every clock) than this after the start edge is
    /// inside the start bit.
    pub start_bit_clocks: Tick,
    /// Clocks between the channel's samples of the line, and the first of them.
    pub period: Tick,
    pub phase: Tick,
}

/// The search block's fixed configuration.
#[derive(Clone, Debug)]
pub struct AutoBaud {
    windows: [RateWindow; RATES],
    /// Pulses of at most this many clocks are glitches at each rate (shorter than half a bit:
    /// a real pulse lasts a bit).
    glitch: [Tick; RATES],
    /// Idle clocks that make TSYN at each rate (half a bit of tolerance for sampling and clock
    /// offset).
    tsyn: [Tick; RATES],
    /// Each rate's character reader.
    readers: [CharReader; RATES],
    /// Each channel's first sample tick.
    phase: [Tick; RATES],
    /// Every channel samples every clock: no change waits for a sample.
    every_clock: bool,
}

impl AutoBaud {
    /// The search with every channel sampling the line at every clock.
    pub fn new(clock_hz: u32) -> Self {
        Self::sampled(clock_hz, EVERY_CLOCK)
    }

    /// The search with the channel of rate `r` sampling the line on `schedule`'s ticks for
    /// it: it sees a change at its next sample, or not at all if the line is back before it,
    /// and its figures (glitch, TSYN, the stop bit's middle and end) are whole samples.
    pub fn sampled(clock_hz: u32, schedule: Schedule) -> Self {
        let periods = schedule.period;
        for (phase, period) in schedule.phase.iter().zip(periods) {
            assert!(
                *phase < period.max(1),
                "a channel's phase is one of its period's clocks"
            );
        }
        let timings: [crate::BitTiming; RATES] = core::array::from_fn(|r| {
            if periods[r] <= 1 {
                return crate::BitTiming::new(clock_hz, Baud::ALL[r], 0);
            }
            // A sampled channel times its bit in whole clocks, as the adapter does
            // (`BitTiming::whole_clocks`): 45.45k is 16 samples of 66 clocks exactly instead
            // of a fraction that would need 18-bit phase registers. One sample: `period`
            // clocks of phase.
            crate::BitTiming {
                inc: periods[r],
                ..crate::BitTiming::whole_clocks(clock_hz, Baud::ALL[r])
            }
        });
        let p = |r: usize| periods[r].max(1);
        AutoBaud {
            windows: core::array::from_fn(|r| {
                let t = timings[r];
                RateWindow {
                    inc: t.inc,
                    modulo: t.modulo,
                    period: p(r),
                    stop_middle: p(r) * t.clocks_for(21, 2),
                    stop_end: p(r) * t.clocks_for(11, 1),
                }
            }),
            glitch: core::array::from_fn(|r| {
                p(r) * Tick::from(crate::filter::glitch_len_for(timings[r].clocks_per_bit()))
            }),
            tsyn: core::array::from_fn(|r| {
                p(r) * timings[r].clocks_for(2 * TSYN_BITS as u64 - 1, 2)
            }),
            readers: timings.map(CharReader::new),
            phase: schedule.phase,
            every_clock: periods.iter().all(|&p| p <= 1),
        }
    }

    /// The figures of the channel of `baud`.
    pub fn channel_figures(&self, baud: Baud) -> ChannelFigures {
        let r = baud.index();
        let w = &self.windows[r];
        ChannelFigures {
            reader: self.readers[r],
            glitch: self.glitch[r],
            tsyn: self.tsyn[r],
            stop_middle: w.stop_middle,
            stop_end: w.stop_end,
            // `at * inc < modulo` for a whole `at` of samples.
            start_bit_clocks: w.modulo.div_ceil(w.inc),
            period: w.period,
            phase: self.phase[r],
        }
    }

    /// Idle clocks that make TSYN at `baud`.
    pub fn tsyn_clocks(&self, baud: Baud) -> Tick {
        self.tsyn[baud.index()]
    }

    /// The longest pulse that is a glitch at `baud`, in clocks.
    pub fn glitch_clocks(&self, baud: Baud) -> Tick {
        self.glitch[baud.index()]
    }

    /// One clock at `now` with the line `line` (its level, and whether it fell or rose on it).
    /// Returns a detection or a
    /// rejection when a decision falls due; with the receiver on a rate (`heard`), only a
    /// detection at another rate: nothing else would change anything then. Updates the
    /// registers in place: the search runs on every clock beside the receiver, and copying its
    /// registers on each one would halve the model's speed.
    #[inline(always)]
    pub fn clock(
        &self,
        now: Tick,
        line: FilterOut,
        heard: Option<Baud>,
        q: &mut AutoBaudQ,
    ) -> Option<Result<Detection, Reject>> {
        let edge = line.fell || line.rose;
        if !edge && now < q.deadline {
            return None;
        }
        if edge {
            self.pass_edge(now, line.level, q);
        }
        if now < q.deadline {
            return None;
        }
        // The channels that sample the line's last change now (those sampling every clock
        // took it with the edge).
        if !self.every_clock {
            let mut sampled = false;
            for r in 0..RATES {
                if q.sample_at[r] == now {
                    self.sample_edge(r, now, line.level, q);
                    sampled = true;
                }
            }
            if sampled {
                self.update_deadline(q);
                if now < q.deadline {
                    return None;
                }
            }
        }
        // Decisions due, the fastest rate first: a detection goes before any rejection.
        let mut out = None;
        let level = line.level;
        for r in (0..RATES).rev() {
            let c = &mut q.channels[r];
            if !c.measuring || now < c.decide_at {
                continue;
            }
            if !level && !c.deferred {
                // Low at the stop bit's middle: a glitch there, or no stop bit; the whole stop
                // bit tells.
                c.deferred = true;
                c.decide_at = c.t0 + u64::from(c.alt) + self.windows[r].stop_end;
                continue;
            }
            c.measuring = false;
            if heard.is_some_and(|b| b.index() == r) {
                continue;
            }
            let decided = self.decide(r, c, now, level).map(|d| Detection {
                pending: q.pending[r],
                rose_after_end: q.high_since[r] > d.end,
                ..d
            });
            if heard.is_some() && decided.is_err() {
                continue;
            }
            if out.is_none() || (decided.is_ok() && !matches!(out, Some(Ok(_)))) {
                out = Some(decided);
            }
        }
        self.update_deadline(q);
        out
    }

    /// A change of the line at `now` (it rose, or fell), into every channel. Nothing is decided
    /// on an edge.
    ///
    /// The measurements keep the edges as they are (a decision weighs each bit whole, which a
    /// glitch of the rate cannot turn); the idle line is followed with each rate's glitches
    /// removed: an edge within the glitch length of the last one kept cancels both.
    fn pass_edge(&self, now: Tick, level: bool, q: &mut AutoBaudQ) {
        let mut changed = false;
        if self.every_clock {
            // Every channel takes the change now. A rise only goes on measurements under way;
            // the idle line in a loop of its own, selects and no branches over the ten rates.
            if !level || q.measuring {
                for r in 0..RATES {
                    changed |= self.measure_edge(r, now, level, q);
                }
            }
            for r in 0..RATES {
                self.idle_edge(r, now, level, q);
            }
            q.held = [level; RATES];
            if changed {
                self.update_deadline(q);
            }
            return;
        }
        for r in 0..RATES {
            if level == q.held[r] {
                // Back at the level the channel holds before it sampled the change: a pulse
                // between two of its samples, which it never sees.
                changed |= q.sample_at[r] != Tick::MAX;
                q.sample_at[r] = Tick::MAX;
                continue;
            }
            let period = self.windows[r].period;
            let at = if period == 1 {
                now
            } else {
                // The first tick from `now` on that is `phase` past a multiple of `period`.
                let phase = self.phase[r];
                (now + period - phase).next_multiple_of(period) - period + phase
            };
            if at == now {
                changed |= self.sample_edge(r, now, level, q);
            } else {
                changed |= q.sample_at[r] != at;
                q.sample_at[r] = at;
            }
        }
        if changed {
            self.update_deadline(q);
        }
    }

    /// Channel `r` samples the line changed at `now` (one of its sample ticks): it `rose`, or
    /// fell. Returns whether its decision or its samples' deadline moved.
    fn sample_edge(&self, r: usize, now: Tick, rose: bool, q: &mut AutoBaudQ) -> bool {
        let pending = q.sample_at[r] != Tick::MAX;
        q.held[r] = rose;
        q.sample_at[r] = Tick::MAX;
        let changed = self.measure_edge(r, now, rose, q);
        self.idle_edge(r, now, rose, q);
        changed || pending
    }

    /// Channel `r`'s measurement takes the line's change at `now`. Returns whether its decision
    /// moved.
    #[inline(always)]
    fn measure_edge(&self, r: usize, now: Tick, rose: bool, q: &mut AutoBaudQ) -> bool {
        let mut changed = false;
        let w = &self.windows[r];
        let c = &mut q.channels[r];
        // A fall after a high longer than a glitch, after TSYN of idle line, starts a
        // measurement: one under way then started on a glitch (or is no delimiter), and is
        // replaced. After a shorter high, inside the start bit, the fall is a second candidate
        // start: the high was a glitch in the start bit, or the first low was one before it.
        let after_glitch = now - q.last_edge[r].min(now) <= self.glitch[r];
        if !rose && !after_glitch && now - q.high_since[r].min(now) >= self.tsyn[r] {
            changed = true;
            let mut from_start = CHAR_READER_RESET;
            self.readers[r].start(&mut from_start);
            *c = ChannelQ {
                measuring: true,
                t0: now,
                readers: [from_start, CHAR_READER_RESET],
                read_until: now,
                decide_at: now + w.stop_middle,
                ..CHANNEL_RESET
            };
        } else if c.measuring {
            if c.n_edges == MAX_EDGES {
                // More edges than a character and its glitches have: not one of this rate.
                changed = true;
                c.measuring = false;
            } else {
                c.n_edges += 1;
                // The samples before the edge at the level before it, then its own.
                self.read_to(r, c, now - w.period, !rose);
                let reader = &self.readers[r];
                reader.clock(&mut c.readers[0], rose, true);
                c.read_until = now;
                let at = (now - c.t0).min(u32::MAX as u64) as u32;
                if !rose && after_glitch && u64::from(at) / w.period * w.inc < w.modulo {
                    changed = true;
                    c.alt = at;
                    reader.start(&mut c.readers[1]);
                    c.decide_at = now + w.stop_middle;
                    c.deferred = false;
                } else if c.alt != 0 {
                    reader.clock(&mut c.readers[1], rose, true);
                }
            }
        }
        changed
    }

    /// Channel `r`'s idle line, the rate's glitches removed, takes the line's change at `now`.
    #[inline(always)]
    fn idle_edge(&self, r: usize, now: Tick, rose: bool, q: &mut AutoBaudQ) {
        // `Tick::MAX`: no edge can cancel (not the wrapped difference, which near tick 0 is
        // small; the RTL keeps a flag).
        let cancels = q.pending[r] != Tick::MAX && now - q.pending[r] <= self.glitch[r];
        let (since, before) = (q.high_since[r], q.high_before[r]);
        (q.high_since[r], q.high_before[r]) = match (rose, cancels) {
            (true, false) => (now, since),
            (false, true) => (before, before),
            _ => (since, before),
        };
        q.pending[r] = if cancels { Tick::MAX } else { now };
        q.last_edge[r] = now;
    }

    fn update_deadline(&self, q: &mut AutoBaudQ) {
        let mut deadline = Tick::MAX;
        let mut measuring = false;
        for c in &q.channels {
            if c.measuring {
                deadline = deadline.min(c.decide_at);
                measuring = true;
            }
        }
        if !self.every_clock {
            deadline = q.sample_at.iter().fold(deadline, |d, &at| d.min(at));
        }
        q.deadline = deadline;
        q.measuring = measuring;
    }

    /// Channel `r`'s readers through tick `until`, the line at `level` since the last tick
    /// they took.
    fn read_to(&self, r: usize, c: &mut ChannelQ, until: Tick, level: bool) {
        // Both are sample ticks of the channel: the samples between them.
        let n = until.saturating_sub(c.read_until) / self.windows[r].period;
        let reader = &self.readers[r];
        reader.advance(&mut c.readers[0], level, n);
        if c.alt != 0 {
            reader.advance(&mut c.readers[1], level, n);
        }
        c.read_until = c.read_until.max(until);
    }

    /// The character channel `r` measured by `now`, the line at `level`, each bit taken by the
    /// level it held longer: read from its start and, if it has one, from its second
    /// candidate start. Two different delimiters are none (the line does not say which it
    /// was).
    fn decide(
        &self,
        r: usize,
        c: &mut ChannelQ,
        now: Tick,
        level: bool,
    ) -> Result<Detection, Reject> {
        self.read_to(r, c, now, level);
        // The stop bit is under way or over for every candidate (the last one's middle, or
        // its end, is now): the RTL reads only those two cases (autobaud_channel_step.v `judge`).
        debug_assert!(c.readers[0].bit >= 10 && (c.alt == 0 || c.readers[1].bit >= 10));
        let reader = &self.readers[r];
        let from_start = delimiter_read(reader.read(&c.readers[0], level));
        let (byte, offset) = if c.alt == 0 {
            (from_start?, 0)
        } else {
            match (
                from_start,
                delimiter_read(reader.read(&c.readers[1], level)),
            ) {
                (Ok(a), Ok(b)) if a != b => return Err(Reject::OffGrid),
                // The first start when both read it: the receiver goes on from the middle of
                // its stop bit, and takes a next start that came before the decision.
                (Ok(a), _) => (a, 0),
                (_, Ok(b)) => (b, c.alt),
                (Err(e), _) => return Err(e),
            }
        };
        let w = &self.windows[r];
        let start = c.t0 + u64::from(offset);
        Ok(Detection {
            baud: Baud::ALL[r],
            byte,
            start,
            end: start + w.stop_end,
            pending: Tick::MAX,
            rose_after_end: false,
        })
    }

    /// Ticks with the line constant at `level` before the search decides anything that
    /// shows. With the receiver on a rate (`heard`) only a detection at another rate shows, so
    /// fast mode passes over the decisions that cannot be one (`unseen`), and
    /// [`AutoBaud::retire`] ends them afterwards: inside a telegram at a slow rate the faster
    /// channels start on most of its falls, and every telegram's delimiter is measured at its
    /// own rate too; fast mode would stop on each of their decisions.
    pub fn quiet_for(&self, now: Tick, level: bool, heard: Option<Baud>, q: &AutoBaudQ) -> Tick {
        if q.deadline == Tick::MAX {
            return Tick::MAX;
        }
        let mut deadline = Tick::MAX;
        for (r, c) in q.channels.iter().enumerate() {
            if c.measuring && !unseen(r, c, level, heard) {
                deadline = deadline.min(c.decide_at);
            }
        }
        if !self.every_clock {
            // A channel's sample of the line's change is always ticked: it may start a
            // measurement.
            deadline = q.sample_at.iter().fold(deadline, |d, &at| d.min(at));
        }
        deadline.saturating_sub(now + 1)
    }

    /// Ends the measurements whose decision fell due before `now` unseen ([`AutoBaud::quiet_for`]
    /// with the line at `level`), as ticking would have.
    pub fn retire(&self, now: Tick, level: bool, heard: Option<Baud>, q: &mut AutoBaudQ) {
        if now <= q.deadline || !q.measuring {
            return;
        }
        for (r, c) in q.channels.iter_mut().enumerate() {
            while c.measuring && c.decide_at < now && unseen(r, c, level, heard) {
                if !level && !c.deferred {
                    // As `clock` does at the stop bit's middle with the line low, whatever the
                    // rate heard: the decision moves to the stop bit's end, where a rate heard
                    // no more would see it (found by a 20,000-case run of `fast_equals_strict`).
                    c.deferred = true;
                    c.decide_at = c.t0 + u64::from(c.alt) + self.windows[r].stop_end;
                } else {
                    c.measuring = false;
                }
            }
        }
        self.update_deadline(q);
    }
}

/// The start delimiter a reading is, if it is one: a tie or more than one glitch off the grid
/// is no character of the rate; then start, parity and stop bits, then the delimiters.
fn delimiter_read(reading: Reading) -> Result<u8, Reject> {
    let shift = reading.bits.ok_or(Reject::OffGrid)?;
    if u32::from(reading.glitches) > MAX_GLITCHES {
        return Err(Reject::OffGrid);
    }
    let byte = (shift >> 1) as u8;
    let parity_ok = (shift >> 9 & 1 == 1) == crate::uart::parity_bit(byte);
    if shift & 1 != 0 || shift >> 10 & 1 != 1 || !parity_ok {
        return Err(Reject::NotAChar);
    }
    if ![SD1, SD2, SD3, SD4].contains(&byte) {
        return Err(Reject::NotADelimiter);
    }
    Ok(byte)
}

/// Whether the decision of channel `r` cannot show, the line staying at `level`: with the
/// receiver on a rate (`heard`), that rate's own, and a rejection (nothing but a detection at
/// another rate shows then): certain where no edge came since the start edge and none will, as
/// its stop bit is low.
fn unseen(r: usize, c: &ChannelQ, level: bool, heard: Option<Baud>) -> bool {
    heard.is_some_and(|b| b.index() == r || (c.n_edges == 0 && !level))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timing::DEFAULT_CLOCK_HZ;
    use crate::uart::char_bits;

    /// Every decision on one character at `baud` after `idle_bits` of idle line, edges at exact
    /// bit times, with the line inverted over `glitches` (tick, clocks): (tick, outcome).
    fn decisions(
        baud: Baud,
        byte: u8,
        idle_bits: u64,
        glitches: &[(Tick, Tick)],
    ) -> Vec<(Tick, Result<Detection, Reject>)> {
        let ab = AutoBaud::new(DEFAULT_CLOCK_HZ);
        let t0 = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_for(idle_bits, 1);
        decisions_of(&ab, baud, byte, t0, glitches)
    }

    /// As [`decisions`], on the search `ab` with the character's start edge at `t0`.
    fn decisions_of(
        ab: &AutoBaud,
        baud: Baud,
        byte: u8,
        t0: Tick,
        glitches: &[(Tick, Tick)],
    ) -> Vec<(Tick, Result<Detection, Reject>)> {
        let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
        let bits = char_bits(byte);
        let level_at = |now: Tick| {
            let clean = if now < t0 {
                true
            } else {
                let bit = ((now - t0) * t.inc / t.modulo) as usize;
                bits.get(bit).copied().unwrap_or(true)
            };
            let glitched = glitches
                .iter()
                .any(|&(at, len)| (at..at + len).contains(&now));
            clean != glitched
        };
        let mut q = AUTOBAUD_RESET;
        let mut prev = true;
        let mut out = Vec::new();
        for now in 0..t0 + t.clocks_for(13, 1) {
            let l = level_at(now);
            let line = FilterOut {
                level: l,
                fell: prev && !l,
                rose: !prev && l,
            };
            if let Some(d) = ab.clock(now, line, None, &mut q) {
                out.push((now, d));
            }
            prev = l;
        }
        out
    }

    /// The one detection among the decisions, if exactly one.
    fn detected(d: &[(Tick, Result<Detection, Reject>)]) -> Option<(Baud, u8)> {
        let found: Vec<_> = d.iter().filter_map(|(_, r)| r.ok()).collect();
        match found[..] {
            [one] => Some((one.baud, one.byte)),
            _ => None,
        }
    }

    /// What the channel of `baud` decided on a character that starts after `idle_bits`.
    fn verdict(baud: Baud, byte: u8, idle_bits: u64) -> Option<Result<Detection, Reject>> {
        let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
        let at = t.clocks_for(idle_bits, 1) + t.clocks_for(21, 2);
        decisions(baud, byte, idle_bits, &[])
            .into_iter()
            .find(|(tick, _)| *tick == at)
            .map(|(_, d)| d)
    }

    #[test]
    fn every_start_delimiter_names_its_rate_and_only_it() {
        for baud in Baud::ALL {
            for sd in [SD1, SD2, SD3, SD4] {
                let d = decisions(baud, sd, 40, &[]);
                assert_eq!(detected(&d), Some((baud, sd)), "{baud} {sd:02x}");
            }
        }
    }

    #[test]
    fn other_characters_are_not_taken() {
        for byte in [0x55, 0xE5] {
            assert!(detected(&decisions(Baud::B1500000, byte, 40, &[])).is_none());
            assert_eq!(
                verdict(Baud::B1500000, byte, 40),
                Some(Err(Reject::NotADelimiter))
            );
        }
    }

    #[test]
    fn a_start_delimiter_without_tsyn_is_not_taken() {
        assert!(detected(&decisions(Baud::B93750, SD2, 20, &[])).is_none());
    }

    /// A glitch of the rate (up to half its bit) in the idle line before the delimiter or in
    /// one of its bits costs nothing.
    #[test]
    fn a_glitch_of_the_rate_costs_the_delimiter_nothing() {
        for baud in Baud::ALL {
            let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let glitch = crate::filter::glitch_len_for(t.clocks_per_bit()) as Tick;
            let t0 = t.clocks_for(40, 1);
            let at_bit = |quarters: u64| t0 + t.clocks_for(quarters, 4);
            // In the idle line 20 bits before, and a quarter into bits 0, 3 and 7.
            for at in [t0 - t.clocks_for(20, 1), at_bit(1), at_bit(13), at_bit(29)] {
                let d = decisions(baud, SD2, 40, &[(at, glitch)]);
                assert_eq!(detected(&d), Some((baud, SD2)), "{baud} glitch at {at}");
            }
        }
    }

    /// A low glitch on the idle line less than half a bit before the delimiter leaves two falls
    /// within its start bit; a high glitch in the start bit leaves the same. Both are read, and
    /// the delimiter is taken from its real start. A low glitch at the stop bit's middle waits
    /// for its end.
    #[test]
    fn a_glitch_at_the_start_or_stop_bit_costs_the_delimiter_nothing() {
        for baud in [Baud::B9600, Baud::B187500, Baud::B1500000] {
            let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let t0 = t.clocks_for(40, 1);
            let len = t.clocks_for(2, 5);
            for gap in [t.clocks_for(1, 8), t.clocks_for(2, 5)] {
                let before = (t0 - gap - len, len);
                let inside = (t0 + gap, len);
                let stop = (t0 + t.clocks_for(10, 1) + gap, len);
                for glitch in [before, inside, stop] {
                    let d = decisions(baud, SD2, 40, &[glitch]);
                    assert_eq!(detected(&d), Some((baud, SD2)), "{baud} {glitch:?}");
                    let start = d.iter().find_map(|(_, r)| r.ok()).map(|d| d.start);
                    assert_eq!(start, Some(t0), "{baud} {glitch:?}");
                }
            }
        }
    }

    /// A glitch that touches an edge moves it by less than half a bit: each bit still holds
    /// its level longer, and the delimiter is taken.
    #[test]
    fn a_glitch_on_an_edge_moves_it_and_the_delimiter_is_taken() {
        for baud in [Baud::B9600, Baud::B93750, Baud::B1500000] {
            let t = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
            let t0 = t.clocks_for(40, 1);
            // SD2 0x68: bits 0-3 low, bit 4 high: a low glitch of a third of a bit right after
            // the rise at bit 4 moves that edge a third of a bit late.
            let rise = t0 + t.clocks_for(4, 1);
            let d = decisions(baud, SD2, 40, &[(rise, t.clocks_for(1, 3))]);
            assert_eq!(detected(&d), Some((baud, SD2)), "{baud}");
        }
    }

    /// The search as the gateware builds it: a channel takes the line on its own ticks only
    /// (`OVERSAMPLED`'s period and phase), so a delimiter's start is the first of them at or
    /// after the fall, on whichever clock of the channel's period the fall comes.
    #[test]
    fn a_sampled_channel_starts_on_its_own_ticks() {
        let ab = AutoBaud::sampled(DEFAULT_CLOCK_HZ, OVERSAMPLED);
        // 9.6k in slot 0, 93.75k in slot 3, 500k in slot 5, 1.5M on its own every 2 clocks.
        for r in [0, 3, 5, 6] {
            let baud = Baud::ALL[r];
            let (period, phase) = (OVERSAMPLED.period[r], OVERSAMPLED.phase[r]);
            let idle = crate::BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_for(40, 1);
            for offset in [0, 1, phase, phase + 1, period - 1] {
                let t0 = idle.next_multiple_of(period) + offset;
                let d = decisions_of(&ab, baud, SD2, t0, &[]);
                assert_eq!(detected(&d), Some((baud, SD2)), "{baud} from {t0}");
                let start = d.iter().find_map(|(_, r)| r.ok()).map(|d| d.start);
                let first_sample = (t0..).find(|t| t % period == phase);
                assert_eq!(start, first_sample, "{baud}: fall at {t0}");
            }
        }
    }

    /// A pulse between two of a channel's samples is never seen by it; one across a sample is
    /// seen there, and by a channel that samples inside it.
    #[test]
    fn a_pulse_between_samples_is_not_seen() {
        let ab = AutoBaud::sampled(DEFAULT_CLOCK_HZ, OVERSAMPLED);
        // 500k every sixth clock; 1.5M every other, in between.
        let (r, other) = (5, 6);
        let (period, phase) = (OVERSAMPLED.period[r], OVERSAMPLED.phase[r]);
        let pulse = |from: Tick, len: Tick| {
            let mut q = AUTOBAUD_RESET;
            let mut prev = true;
            for now in 0..from + len + 2 * period {
                let level = !(from..from + len).contains(&now);
                let line = FilterOut {
                    level,
                    fell: prev && !level,
                    rose: !prev && level,
                };
                ab.clock(now, line, None, &mut q);
                prev = level;
            }
            q
        };
        // Low from just after one of 500k's samples to just before its next.
        let from = 1000 * period + phase + 1;
        let q = pulse(from, period - 1);
        assert_eq!(q.last_edge[r], 0, "500k saw a pulse between its samples");
        assert!(q.held[r] && q.sample_at[r] == Tick::MAX);
        // 1.5M samples inside the pulse: it sees the rise at its first sample after it.
        let rise_seen = (from + period - 1..)
            .find(|t| t % OVERSAMPLED.period[other] == OVERSAMPLED.phase[other]);
        assert_eq!(Some(q.last_edge[other]), rise_seen, "1.5M missed the pulse");
        // A pulse one clock longer covers 500k's next sample: the fall is seen there, and the
        // rise at the sample after the pulse.
        let q = pulse(from, period);
        let rise_seen = (from + period..).find(|t| t % period == phase);
        assert_eq!(Some(q.last_edge[r]), rise_seen, "500k's rise");
        assert!(q.held[r]);
    }
}
