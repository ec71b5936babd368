//! The receiver (`gateware/rtl/edge_rx.v`) against `dp_phy::edge_rx::EdgeRx`, driven as the
//! transceiver drives it: built for its rate with the search's sampling of it
//! (`EdgeRx::sampled`), and per clock an edge of the sampled line (`on_edge`), then the
//! search's hand-over or, at the deadline, `act`; a clear after it now and then (a rate dropped
//! or changed). Lines at every rate: characters from a master up to 5,000 ppm off, back to
//! back or apart, glitches of up to half a bit, runs of random length, and the search's
//! hand-overs (at a rate that may change with them); ticks from near the 32-bit wrap in some
//! cases. Every change of the line is put on the receiver's next sample tick: the line as it
//! samples it (a glitch shorter than a sample lasts one).

use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::edge_rx::{EdgeRx, EdgeRxQ, EDGE_RX_RESET};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::char_bits;
use dp_phy::{BitTiming, Config, Tick};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The idle clocks the RTL keeps: 24 bits, saturating.
const IDLE_MAX: u64 = (1 << 24) - 1;

/// The ticks the RTL keeps inside: 18 bits (its TickWidth), the model's truncated.
const TICK_MASK: u32 = (1 << 18) - 1;

pub fn edge_rx() -> Block {
    Block {
        top: "edge_rx",
        rtl: &["edge_rx.v", "char_reader_step.v"],
        signals: &[
            "active",
            "char",
            "stage0",
            "stage1",
            "next_active",
            "next_from_valid",
        ],
        params: vec![("PhaseWidth", i64::from(receiver_width()))],
        twin: "dp_phy::edge_rx::EdgeRx",
        events: true,
    }
}

/// The transceiver's receiver at `baud`: sampling the line as the search's channel of the
/// rate does.
pub(super) fn receiver(baud: Baud) -> EdgeRx {
    let schedule = Config::default().search_schedule;
    let r = baud.index();
    EdgeRx::sampled(
        BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud),
        schedule.period[r],
        schedule.phase[r],
    )
}

/// Bits that hold every rate's reduced modulo in the receiver's samples (7: 9.6k's bit is
/// 125/6 samples).
pub fn receiver_width() -> u32 {
    Baud::ALL
        .iter()
        .map(|&b| u64::BITS - receiver(b).reader().modulo.leading_zeros())
        .max()
        .expect("rates")
}

/// The search's hand-over of a character that ended at `end`: on this clock, or `late`, of the
/// last clock (acted on on this one, as the transceiver acts on a detection).
#[derive(Clone, Copy, Debug)]
struct HandOver {
    end: Tick,
    late: bool,
}

/// The stimulus and the model, written together.
struct RxCase {
    rx: EdgeRx,
    q: EdgeRxQ,
    /// The model's tick of the next clock (the RTL's is this, truncated to 32 bits).
    now: Tick,
    line: bool,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    clock: u32,
    last_lanes: [u32; 2],
    /// The character decided on the last clock, out on this one: the transceiver's register
    /// between the decision and the delimiter (`decided`), which edge_rx.v's outputs are.
    decided: Option<(dp_phy::uart::RxChar, Tick)>,
    /// The line fell on the last clock.
    fell_last: bool,
    seen: Seen,
}

/// What a case's model went through: the stimulus is worth as much as it makes the receiver do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Seen {
    /// Characters decided, by delimiter.v's error code.
    pub chars: [u32; 5],
    /// Clocks with two candidates in the current lane, and with the next one under way.
    pub two_candidates: u32,
    pub next_lane: u32,
    /// Decisions at the stop bit's end (the line low at its middle).
    pub stop_end: u32,
    /// Hand-overs with a fall on their clock, and without.
    pub hand_overs_falling: u32,
    pub hand_overs: u32,
    /// Hand-overs of the last clock (the transceiver acts on a detection a clock after it)
    /// with a fall there, and with its reader's next sample at a change of the line.
    pub late_falling: u32,
    pub late_stepped_edge: u32,
    pub clears: u32,
}

impl std::ops::AddAssign for Seen {
    fn add_assign(&mut self, other: Seen) {
        for (total, n) in self.chars.iter_mut().zip(other.chars) {
            *total += n;
        }
        self.two_candidates += other.two_candidates;
        self.next_lane += other.next_lane;
        self.stop_end += other.stop_end;
        self.hand_overs_falling += other.hand_overs_falling;
        self.hand_overs += other.hand_overs;
        self.late_falling += other.late_falling;
        self.late_stepped_edge += other.late_stepped_edge;
        self.clears += other.clears;
    }
}

impl RxCase {
    fn new(baud: Baud, now: Tick) -> RxCase {
        let mut case = RxCase {
            rx: receiver(baud),
            q: EDGE_RX_RESET,
            now,
            line: true,
            stimulus: Vec::new(),
            trace: Trace::default(),
            events: Vec::new(),
            clock: 0,
            last_lanes: [u32::MAX; 2],
            decided: None,
            fell_last: false,
            seen: Seen::default(),
        };
        case.stimulus.push(b'N');
        case.stimulus.extend_from_slice(&(now as u32).to_le_bytes());
        case.use_rate(baud);
        case
    }

    /// The rate's figures from the next clock on (the model's receiver for it), and its
    /// sample ticks: the clocks to the next one. Another rate is taken on one of its own
    /// sample ticks, for the hand-over that follows (the search decides there): the line is
    /// held at the old one's until then.
    fn use_rate(&mut self, baud: Baud) {
        let next = receiver(baud);
        if next != self.rx {
            self.hold(super::clocks_to_sample(self.now, next.period, next.phase));
            self.rx = next;
        }
        let r = *self.rx.reader();
        let [start_end, stop_middle, stop_end] = self.rx.offsets();
        self.stimulus.push(b'T');
        for figure in [
            r.inc,
            r.modulo,
            r.quarter,
            r.three_quarters,
            r.half_less_inc,
            r.two_inc,
            r.modulo_less_inc,
            r.modulo_less_two_inc,
            start_end,
            stop_middle,
            stop_end,
            self.rx.period,
            self.to_sample(),
        ] {
            self.stimulus
                .extend_from_slice(&(figure as u32).to_le_bytes());
        }
    }

    /// One clock of the model as the transceiver ticks it, and what the harness records. A
    /// hand-over is of a character ending at its tick, and of the last clock if `late` (then
    /// this clock steps the receiver it leaves, as the transceiver does).
    fn tick(&mut self, level: bool, idle: Tick, hand_over: Option<HandOver>, clear: bool) {
        let now = self.now;
        let changed = level != self.line;
        let late = hand_over.is_some_and(|h| h.late);
        if changed && !late {
            self.rx.on_edge(now, level, idle, &mut self.q);
        }
        let fell = self.line && !level;
        self.line = level;
        let got = self.decided.take();
        let seen = &mut self.seen;
        seen.two_candidates += u32::from(self.q.current().n_starts() == 2);
        seen.next_lane += u32::from(self.q.next().n_starts() > 0);
        if hand_over.is_some() {
            seen.hand_overs += 1;
            seen.hand_overs_falling += u32::from(fell && !late);
            seen.late_falling += u32::from(late && self.fell_last);
            seen.late_stepped_edge += u32::from(late && self.fell_last && changed);
        }
        seen.clears += u32::from(clear);
        if now >= self.q.deadline && self.q.current().stage == dp_phy::edge_rx::Stage::StopEnd {
            seen.stop_end += 1;
        }
        if let Some(HandOver { end, late }) = hand_over {
            // The search decided a character ending at `end`, which began 11 bits before it.
            let start = end - self.rx.timing.clocks_for(11, 1);
            if late {
                self.rx
                    .hand_over(start, end, now - 1, self.fell_last, &mut self.q);
                if changed {
                    let idle = if level { 0 } else { now.saturating_sub(end) };
                    self.rx.on_edge(now, level, idle, &mut self.q);
                }
            } else {
                self.rx.hand_over(start, end, now, fell, &mut self.q);
            }
        } else if now >= self.q.deadline {
            self.decided = self.rx.act(now, level, &mut self.q);
        }
        self.fell_last = fell;
        if clear {
            self.q = EdgeRxQ {
                read_until: now,
                ..EDGE_RX_RESET
            };
        }
        let stage = self.q.current().stage as u8;
        self.trace.push(
            u8::from(self.q.active())
                | u8::from(got.is_some()) << 1
                | stage << 2
                | u8::from(self.q.next().n_starts() > 0) << 4
                | u8::from(self.q.next_from != Tick::MAX) << 5,
        );
        let lanes = [
            if self.q.active() {
                self.q.current().deadline as u32 & TICK_MASK
            } else {
                u32::MAX
            },
            if self.q.next_from != Tick::MAX {
                self.q.next_from as u32 & TICK_MASK
            } else {
                u32::MAX
            },
        ];
        if got.is_some() || lanes != self.last_lanes {
            let mut payload = Vec::new();
            match got {
                Some((c, idle_before)) => {
                    self.seen.chars[usize::from(super::char_error_code(c.error))] += 1;
                    payload.extend_from_slice(&[c.byte, super::char_error_code(c.error)]);
                    payload.extend_from_slice(&(c.start as u32).to_le_bytes());
                    payload.extend_from_slice(&(c.end as u32).to_le_bytes());
                    payload.extend_from_slice(&(idle_before.min(IDLE_MAX) as u32).to_le_bytes());
                }
                None => payload.extend_from_slice(&[0; 14]),
            }
            for lane in lanes {
                payload.extend_from_slice(&lane.to_le_bytes());
            }
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
            self.last_lanes = lanes;
        }
        self.clock += 1;
        self.now += 1;
    }

    /// `n` clocks with the line held where it is.
    fn hold(&mut self, n: u64) {
        let mut n = n;
        while n > 0 {
            let run = n.min(u64::from(u32::MAX)) as u32;
            self.stimulus.push(b'L');
            self.stimulus.push(u8::from(self.line));
            self.stimulus.extend_from_slice(&run.to_le_bytes());
            for _ in 0..run {
                self.tick(self.line, 0, None, false);
            }
            n -= u64::from(run);
        }
    }

    /// Clocks from the next one to the receiver's next sample tick.
    fn to_sample(&self) -> Tick {
        super::clocks_to_sample(self.now, self.rx.period, self.rx.phase)
    }

    /// One clock with the line at `level`, a fall's idle clocks before it, the search's
    /// hand-over, a clear. A change of the line and a hand-over of this clock wait for the
    /// receiver's next sample tick (as the search's channel of the rate would see the change,
    /// and decide); a late hand-over comes on the clock after one.
    fn special(&mut self, level: bool, idle: Tick, hand_over: Option<HandOver>, clear: bool) {
        let late = hand_over.is_some_and(|h| h.late);
        if (level != self.line || hand_over.is_some()) && !late {
            self.hold(self.to_sample());
        }
        let fell_last = late && self.fell_last;
        self.stimulus.push(b'K');
        self.stimulus.push(
            u8::from(level)
                | u8::from(hand_over.is_some()) << 1
                | u8::from(clear) << 2
                | u8::from(fell_last) << 3,
        );
        self.stimulus
            .extend_from_slice(&(idle.min(IDLE_MAX) as u32).to_le_bytes());
        // The hand-over's fall's idle clocks, as the transceiver gives them: from the
        // character's end to the fall, on the last clock or this one.
        let hand_over_idle = hand_over.map_or(0, |h| {
            let fall = if fell_last { self.now - 1 } else { self.now };
            fall.saturating_sub(h.end).min(IDLE_MAX)
        });
        self.stimulus
            .extend_from_slice(&(hand_over_idle as u32).to_le_bytes());
        self.tick(level, idle, hand_over, clear);
    }

    /// The line changes to `level` on the next clock.
    fn edge(&mut self, level: bool, rng: &mut ChaCha8Rng) {
        // The idle before a fall, as the transceiver counts it: any figure, past the RTL's 24
        // bits now and then.
        let idle = match rng.gen_range(0..4) {
            0 => 0,
            1 => rng.gen_range(0..200_000),
            2 => rng.gen_range(0..IDLE_MAX + 1000),
            _ => rng.gen_range(0..1 << 40),
        };
        self.special(level, idle, None, false);
    }

    fn finish(self, name: String) -> Case {
        Case {
            name,
            stimulus: self.stimulus,
            model: self.trace,
            model_events: self.events,
        }
    }
}

/// A random line at `baud` for about `bits` of its bits: characters from a master `ppm` off,
/// back to back or apart, with glitches now and then; random runs; hand-overs (some at another
/// rate) and clears.
fn random_line(case: &mut RxCase, rng: &mut ChaCha8Rng, baud: Baud, bits: u64) {
    let mut baud = baud;
    let mut bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud).clocks_per_bit();
    let end = case.now + bits * bit;
    while case.now < end {
        match rng.gen_range(0..10) {
            0..=4 => {
                // A character or a few back to back, at the master's rate.
                let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, rng.gen_range(-5000..=5000));
                for _ in 0..rng.gen_range(1..4) {
                    let byte: u8 = rng.gen();
                    let levels = char_bits(byte);
                    let mut toggles: Vec<u64> = Vec::new();
                    let mut level = case.line;
                    for (i, &b) in levels.iter().enumerate() {
                        if b != level {
                            toggles.push(master.clocks_for(i as u64, 1));
                            level = b;
                        }
                    }
                    let length = master.clocks_for(11, 1);
                    // Glitches of up to half a bit now and then.
                    if rng.gen_bool(0.4) {
                        for _ in 0..rng.gen_range(1..3) {
                            let at = rng.gen_range(1..length);
                            let len = rng.gen_range(1..=bit / 2 + 1);
                            toggles.extend([at, at + len]);
                        }
                    }
                    toggles.sort_unstable();
                    // The glitches' toggles flip the level the character holds there: two on
                    // one clock are none.
                    let mut edges: Vec<u64> = Vec::new();
                    for at in toggles {
                        if edges.last() == Some(&at) {
                            edges.pop();
                        } else {
                            edges.push(at);
                        }
                    }
                    let start = case.now;
                    let first = case.line;
                    let mut level = first;
                    let mut at = 0;
                    if first {
                        // The start edge.
                        case.edge(false, rng);
                        level = false;
                        at = 1;
                    }
                    for e in edges.into_iter().filter(|&e| e >= at) {
                        // An edge put on a later sample tick may pass the next one's clock.
                        case.hold(e.saturating_sub(case.now - start));
                        level = !level;
                        case.edge(level, rng);
                    }
                    let done = start + length;
                    if case.now < done {
                        case.hold(done - case.now);
                    }
                    if !case.line {
                        case.edge(true, rng);
                    }
                    case.hold(rng.gen_range(0..bit / 2 + 1));
                }
                case.hold(rng.gen_range(0..3 * bit));
            }
            5..=7 => {
                // A run of either level.
                let level = !case.line;
                case.edge(level, rng);
                case.hold(rng.gen_range(0..3 * bit));
            }
            8 => {
                // The search's hand-over, now and then at another rate, on a clock with a fall
                // or not.
                if rng.gen_bool(0.3) {
                    baud = Baud::ALL[rng.gen_range(0..Baud::ALL.len())];
                    bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud).clocks_per_bit();
                    case.use_rate(baud);
                }
                let level = if rng.gen_bool(0.5) {
                    !case.line
                } else {
                    case.line
                };
                if rng.gen_bool(0.5) {
                    let end = case.now - rng.gen_range(0..bit);
                    case.special(level, 0, Some(HandOver { end, late: false }), false);
                } else {
                    // Decided on a sample tick (a fall there or not), acted on on the next
                    // clock: a change there only where that is a sample tick too.
                    case.hold(case.to_sample());
                    let end = case.now - rng.gen_range(0..bit);
                    case.special(level, rng.gen_range(0..1000), None, false);
                    let next = if case.rx.period == 1 && rng.gen_bool(0.5) {
                        !case.line
                    } else {
                        case.line
                    };
                    case.special(next, 0, Some(HandOver { end, late: true }), false);
                }
                case.hold(rng.gen_range(0..bit));
            }
            _ => {
                // A clear (a trial failed, the rate dropped): at a random clock.
                let level = if rng.gen_bool(0.2) {
                    !case.line
                } else {
                    case.line
                };
                case.special(level, rng.gen_range(0..1000), None, true);
                case.hold(rng.gen_range(0..2 * bit));
            }
        }
    }
    case.hold(14 * bit);
}

/// At every rate: random lines (a few from ticks near the 32-bit wrap).
pub fn edge_rx_cases(quick: bool) -> Vec<Case> {
    cases_seen(quick).0
}

/// The cases, and what their model went through altogether.
fn cases_seen(quick: bool) -> (Vec<Case>, Seen) {
    let mut all = Seen::default();
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let runs = if quick { 1 } else { 4 };
    let mut cases = Vec::new();
    for baud in Baud::ALL {
        for run in 0..runs {
            let start: Tick = if run % 2 == 1 {
                (1 << 32) - rng.gen_range(1000..200_000)
            } else {
                rng.gen_range(20_000..1 << 31)
            };
            let mut case = RxCase::new(baud, start);
            case.hold(rng.gen_range(1..1000));
            random_line(&mut case, &mut rng, baud, if quick { 400 } else { 1500 });
            all += case.seen;
            cases.push(case.finish(format!("edge_rx-{baud}-{run}")));
        }
    }
    (cases, all)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick set makes the receiver do all it does: every kind of character, two
    /// candidates, the next lane, decisions at the stop bit's end, hand-overs with and without
    /// a fall, clears.
    #[test]
    fn the_quick_cases_cover_the_receiver() {
        let (_, seen) = cases_seen(true);
        println!("{seen:?}");
        assert!(seen.chars.iter().all(|&n| n > 0), "{seen:?}");
        assert!(seen.two_candidates > 0 && seen.next_lane > 0 && seen.stop_end > 0);
        assert!(seen.hand_overs_falling > 0 && seen.hand_overs > seen.hand_overs_falling);
        assert!(seen.late_falling > 0 && seen.late_stepped_edge > 0);
        assert!(seen.clears > 0);
    }
}
