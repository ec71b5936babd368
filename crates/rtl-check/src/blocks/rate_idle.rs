//! The transceiver's copy of its rate's idle line (`gateware/rtl/rate_idle.v`) against
//! `dp_phy::rate_idle::RateIdle`, driven as the transceiver's top will drive it: at every rate
//! on the transceiver's sampling of it, the line's changes as that rate samples them (glitches
//! of up to two glitch lengths, so that some cancel and some do not, and runs of up to three
//! bits), and loads now and then (after the change, or as a restore before it): a detection's channel state (its pending edge as the samples
//! it still cancels within, and the character's end as the high ticks), on a sample tick, as
//! the search gives it. Ticks start near the 32-bit wrap in some cases.

use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::autobaud::{AutoBaud, ChannelFigures};
use dp_phy::rate_idle::{RateIdle, RATE_IDLE_NONE};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::{Config, Tick};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The samples a glitch lasts at the slowest rate every clock (9.6k: 2,499): 12 bits.
const PEND_WIDTH: u32 = 12;

pub fn rate_idle() -> Block {
    Block {
        top: "rate_idle",
        rtl: &["rate_idle.v"],
        signals: &["cancels"],
        params: vec![("PendWidth", i64::from(PEND_WIDTH))],
        twin: "dp_phy::rate_idle::RateIdle",
        events: true,
    }
}

/// The stimulus and the model, written together.
struct IdleCase {
    idle: RateIdle,
    figures: ChannelFigures,
    now: Tick,
    line: bool,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    clock: u32,
    last: (u32, u32),
}

impl IdleCase {
    fn new(baud: Baud, now: Tick) -> IdleCase {
        let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, Config::default().search_schedule);
        let figures = search.channel_figures(baud);
        let mut case = IdleCase {
            idle: RATE_IDLE_NONE,
            figures,
            now,
            line: true,
            stimulus: vec![b'N'],
            trace: Trace::default(),
            events: Vec::new(),
            clock: 0,
            last: (0, 0),
        };
        case.stimulus.extend((now as u32).to_le_bytes());
        case.stimulus.push(b'T');
        for figure in [
            figures.glitch / figures.period,
            figures.period,
            case.to_sample(),
        ] {
            case.stimulus.extend((figure as u32).to_le_bytes());
        }
        case
    }

    /// Clocks from the next one to the rate's next sample tick.
    fn to_sample(&self) -> Tick {
        super::clocks_to_sample(self.now, self.figures.period, self.figures.phase)
    }

    /// The samples within which a next edge still cancels the pending one, as the RTL counts
    /// them after this clock.
    fn cancel_left(&self) -> u64 {
        let f = &self.figures;
        if self.idle.pending == Tick::MAX {
            return 0;
        }
        // The samples taken since the pending edge, through this clock.
        let since = (self.now - self.idle.pending) / f.period;
        (f.glitch / f.period).saturating_sub(since)
    }

    /// One clock, as the transceiver's top takes it: a restore, the line's change, a load.
    fn tick(&mut self, level: bool, restore: Option<RateIdle>, load: Option<RateIdle>) {
        if let Some(state) = restore {
            self.idle = state;
        }
        if level != self.line {
            self.idle.edge(self.now, level, self.figures.glitch);
        }
        if let Some(state) = load {
            self.idle = state;
        }
        self.line = level;
        self.trace.push(u8::from(self.cancel_left() != 0));
        let now = (self.idle.high_since as u32, self.idle.high_before as u32);
        if now != self.last {
            let mut payload = now.0.to_le_bytes().to_vec();
            payload.extend(now.1.to_le_bytes());
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
            self.last = now;
        }
        self.clock += 1;
        self.now += 1;
    }

    /// `n` clocks with the line held.
    fn hold(&mut self, n: u64) {
        let mut n = n;
        while n > 0 {
            let run = n.min(u64::from(u32::MAX)) as u32;
            self.stimulus.push(b'L');
            self.stimulus.push(u8::from(self.line));
            self.stimulus.extend(run.to_le_bytes());
            for _ in 0..run {
                self.tick(self.line, None, None);
            }
            n -= u64::from(run);
        }
    }

    /// The line changes to `level` on the rate's next sample tick, and there a load (or with
    /// `restore`, a restore before the change) takes `left` samples of a pending edge and
    /// `end` as its high ticks.
    fn special(&mut self, level: bool, load: Option<(u64, Tick)>, restore: bool) {
        self.hold(self.to_sample());
        let state = load.map(|(left, end)| {
            let f = &self.figures;
            let glitch = f.glitch / f.period;
            // The samples since it: the glitch's less those left, after this clock's sample
            // for a load; a restore takes registers as the last clock left them, and this
            // clock's sample counts one more.
            let since = glitch - left + u64::from(restore);
            RateIdle {
                pending: if left == 0 {
                    Tick::MAX
                } else {
                    self.now - since * f.period
                },
                high_since: end,
                high_before: end,
            }
        });
        let (left, end) = load.unwrap_or((0, 0));
        self.stimulus.push(b'K');
        self.stimulus.push(
            u8::from(level)
                | u8::from(load.is_some() && !restore) << 1
                | u8::from(load.is_some() && restore) << 2,
        );
        self.stimulus.extend((left as u32).to_le_bytes());
        self.stimulus.extend((end as u32).to_le_bytes());
        self.stimulus.extend((end as u32).to_le_bytes());
        if restore {
            self.tick(level, state, None);
        } else {
            self.tick(level, None, state);
        }
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

/// At every rate: random lines with loads among them (a few from ticks near the 32-bit wrap).
pub fn rate_idle_cases(quick: bool) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let runs = if quick { 1 } else { 3 };
    let mut cases = Vec::new();
    for baud in Baud::ALL {
        for run in 0..runs {
            let start: Tick = if run == 1 {
                (1 << 32) - rng.gen_range(1000..200_000)
            } else {
                rng.gen_range(0..1 << 31)
            };
            let mut case = IdleCase::new(baud, start);
            let f = case.figures;
            let glitch = f.glitch / f.period;
            let bit = f.stop_end / 11;
            for _ in 0..if quick { 300 } else { 2000 } {
                match rng.gen_range(0..10) {
                    0 => {
                        // A detection's state: its pending edge's samples left, the
                        // character's end a little before or after now.
                        let left = if rng.gen_bool(0.5) {
                            rng.gen_range(1..=glitch)
                        } else {
                            0
                        };
                        let end = (case.now + rng.gen_range(0..bit)).saturating_sub(bit / 2);
                        // Or another copy's registers taken back, before a change or none.
                        let restore = rng.gen_bool(0.3);
                        let level = if restore && rng.gen_bool(0.5) {
                            !case.line
                        } else {
                            case.line
                        };
                        case.special(level, Some((left, end)), restore);
                    }
                    1..=5 => {
                        // A pulse of up to two glitch lengths.
                        let level = !case.line;
                        case.special(level, None, false);
                        case.hold(rng.gen_range(0..2 * f.glitch + f.period));
                        case.special(!level, None, false);
                    }
                    _ => {
                        let level = !case.line;
                        case.special(level, None, false);
                        case.hold(rng.gen_range(0..3 * bit));
                    }
                }
            }
            case.hold(bit);
            cases.push(case.finish(format!("rate_idle-{baud}-{run}")));
        }
    }
    cases
}
