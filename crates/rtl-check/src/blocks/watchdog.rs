//! The watchdog (`gateware/rtl/watchdog.v`) against `dp_phy::watchdog::Watchdog`: seeded runs
//! of starts, restarts before and at the deadline, starts of a running one that must not move
//! it, stops, and the expiry held off (the baud watchdog inside a telegram), at the baud
//! watchdog's width and the DP watchdog's.

use super::bits_for;
use crate::{Block, Case, Event, Trace};
use dp_phy::watchdog::Watchdog;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The watchdog `width` bits wide ([`baud_watchdog_width`], [`dp_watchdog_width`]).
pub fn watchdog(width: u32) -> Block {
    Block {
        top: "watchdog",
        rtl: &["watchdog.v"],
        signals: &["expired", "running"],
        params: vec![("Width", i64::from(width))],
        twin: "dp_phy::watchdog::Watchdog",
        events: true,
    }
}

/// The baud-control watchdog's width: its clocks in the transceiver's configuration (200 ms at
/// 48 MHz: 24 bits).
pub fn baud_watchdog_width() -> u32 {
    let cfg = dp_phy::Config::default();
    bits_for(u64::from(cfg.baud_watchdog_10ms) * u64::from(cfg.clock_hz / 100))
}

/// The DP watchdog's width: the longest the registers can ask for, 2^32 - 1 us (38 bits).
pub fn dp_watchdog_width() -> u32 {
    let clocks_per_us = u64::from(dp_phy::timing::DEFAULT_CLOCK_HZ / 1_000_000);
    bits_for(u64::from(u32::MAX) * clocks_per_us)
}

/// A clock's command.
#[derive(Clone, Copy)]
enum Command {
    None,
    Start(u32),
    StartIfStopped(u32),
    Stop,
}

struct WatchdogCase {
    w: Watchdog,
    now: u64,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
}

impl WatchdogCase {
    /// One clock, as the harness runs it: the command, then the expiry where `check` lets it.
    fn clock(&mut self, command: Command, check: bool) {
        match command {
            Command::None => {}
            Command::Start(clocks) => self.w.start(self.now, u64::from(clocks)),
            Command::StartIfStopped(clocks) => self.w.start_if_stopped(self.now, u64::from(clocks)),
            Command::Stop => self.w.stop(),
        }
        let expired = check && self.w.expire(self.now);
        self.trace
            .push(u8::from(expired) | u8::from(self.w.running()) << 1);
        if !matches!(command, Command::None) || expired {
            let left = self.w.left(self.now + 1).unwrap_or(0);
            self.events.push(Event {
                clock: self.now as u32,
                payload: left.to_le_bytes().to_vec(),
            });
        }
        self.now += 1;
    }

    fn command(&mut self, command: Command, check: bool) {
        let (op, clocks) = match command {
            Command::None => unreachable!("a clock without a command is a run"),
            Command::Start(c) => (b'S', Some(c)),
            Command::StartIfStopped(c) => (b'I', Some(c)),
            Command::Stop => (b'P', None),
        };
        self.stimulus.extend_from_slice(&[op, u8::from(check)]);
        if let Some(c) = clocks {
            self.stimulus.extend_from_slice(&c.to_le_bytes());
        }
        self.clock(command, check);
    }

    fn run(&mut self, n: u32, check: bool) {
        if n == 0 {
            return;
        }
        self.stimulus.push(b'R');
        self.stimulus.push(u8::from(check));
        self.stimulus.extend_from_slice(&n.to_le_bytes());
        for _ in 0..n {
            self.clock(Command::None, check);
        }
    }
}

/// Seeded commands with runs between them that end before, at and after the deadline.
pub fn watchdog_cases(width: u32, quick: bool) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(width));
    let count = if quick { 2 } else { 8 };
    (0..count)
        .map(|n| {
            let mut case = WatchdogCase {
                w: Watchdog::STOPPED,
                now: 0,
                stimulus: Vec::new(),
                trace: Trace::default(),
                events: Vec::new(),
            };
            // Short runs, so that thousands of commands meet their deadlines; a few long ones
            // (past 2^20 clocks: the counter's upper bits).
            let (span, commands): (u32, u32) = if n % 4 == 3 {
                (2_000_000, 40)
            } else {
                (200, 2_000)
            };
            case.run(3, true);
            for _ in 0..commands {
                let clocks = rng.gen_range(0..span);
                let check = rng.gen_bool(0.8);
                let command = match rng.gen_range(0..10) {
                    0..=4 => Command::Start(clocks),
                    5..=7 => Command::StartIfStopped(clocks),
                    _ => Command::Stop,
                };
                case.command(command, check);
                // Up to a little past the deadline, the expiry sometimes held off.
                let gap = rng.gen_range(0..=span + span / 4 + 2);
                let held = rng.gen_bool(0.2);
                let split = rng.gen_range(0..=gap);
                case.run(split, !held);
                case.run(gap - split, true);
            }
            Case {
                name: format!("watchdog-w{width}-{n}"),
                stimulus: case.stimulus,
                model: case.trace,
                model_events: case.events,
            }
        })
        .collect()
}
