//! The baud-rate sweep's cases and their stimulus, written once for the two that run them:
//! `cargo xtask baud-sweep` (the model in fast mode, judged by what it locks and delivers) and
//! rtl-check (the model in strict mode against the gateware's transceiver, clock for clock).
//!
//! Contract: [`cases`] lists every rate x clock offset x noise level x start phase, from
//! power-up and after the master changes its rate (from a far rate and a neighbour, and
//! between the slowest and the fastest rate both ways), each with its seed; [`drive`] runs one
//! through a [`Testbench`]: the master on the case's first rate, a telegram to lock it after a
//! change, then [`TELEGRAMS`] polls (more with noise) at the case's rate, glitches of up to half
//! a bit among them, and a tail of idle line. The same case gives the same line every time.

use crate::bus::FaultInjector;
use crate::testbench::{poll_sequence, random_telegram, Kind, Testbench};
use crate::timing::DEFAULT_CLOCK_HZ;
use crate::{Baud, BitTiming, Config, Tick};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Where the adapter stands when the master starts sending at the case's rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    PowerUp,
    /// The adapter is locked at `from`, then the master switches to the case's rate.
    RateChange {
        from: Baud,
    },
}

impl std::fmt::Display for Scenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Scenario::PowerUp => write!(f, "power-up"),
            Scenario::RateChange { from } => write!(f, "change-from-{from}"),
        }
    }
}

/// One of `count` shares of a list of cases, for runs that split it (`--shard index/count`):
/// the cases whose position in the list is `index - 1` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// The whole list.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// Whether the case at `position` in its list is this shard's.
    pub fn holds(&self, position: usize) -> bool {
        position % self.count == self.index - 1
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `i/N`, with i in 1..=N.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("--shard takes i/N with i in 1..=N (2/4, say), not `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// One case of the sweep.
#[derive(Clone, Copy, Debug)]
pub struct SweepCase {
    pub scenario: Scenario,
    pub baud: Baud,
    pub ppm: i32,
    /// Glitches (shorter than half a bit) per telegram time: 0, 1 or 3.
    pub noise: u32,
    /// Start phase in sample clocks.
    pub phase: u64,
    pub seed: u64,
}

impl std::fmt::Display for SweepCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}-{}-{}ppm-noise{}-phase{}",
            self.scenario, self.baud, self.ppm, self.noise, self.phase
        )
    }
}

/// Polls per case without noise; with noise, that many more per glitch a telegram.
pub const TELEGRAMS: usize = 12;

/// Idle bit times between the polls, as fast as a master polls.
pub const POLL_IDLE_BITS: u32 = 33;

/// Every case (`quick`: the CI's subset).
pub fn cases(quick: bool) -> Vec<SweepCase> {
    let offsets: &[i32] = if quick {
        &[-5000, 0, 5000]
    } else {
        &[-5000, -2500, 0, 2500, 5000]
    };
    let noises: &[u32] = if quick { &[0, 1] } else { &[0, 1, 3] };
    let phases: &[u64] = if quick {
        &[0, 777]
    } else {
        &[0, 1, 2, 3, 777, 12_345]
    };
    let mut out = Vec::new();
    let mut seed = 0;
    for (i, &baud) in Baud::ALL.iter().enumerate() {
        // The rate the adapter was on before: a far one and a neighbour, in turn; and the
        // slowest and the fastest rate from each other.
        let mut scenarios = vec![
            Scenario::PowerUp,
            Scenario::RateChange {
                from: Baud::ALL[(i + 5 + (i % 2) * 4) % 10],
            },
        ];
        let (slowest, fastest) = (Baud::ALL[0], Baud::ALL[9]);
        if baud == slowest {
            scenarios.push(Scenario::RateChange { from: fastest });
        }
        if baud == fastest {
            scenarios.push(Scenario::RateChange { from: slowest });
        }
        for scenario in scenarios {
            for &ppm in offsets {
                for &noise in noises {
                    for &phase in phases {
                        seed += 1;
                        out.push(SweepCase {
                            scenario,
                            baud,
                            ppm,
                            noise,
                            phase,
                            seed,
                        });
                    }
                }
            }
        }
    }
    out
}

/// A case run: the bench as it ended, and where the case's own telegrams began.
pub struct SweepRun {
    pub tb: Testbench,
    /// The master's timing at the case's rate.
    pub target: BitTiming,
    /// The tick the master switched to the case's rate (power-up: after the phase).
    pub from_tick: Tick,
    /// Telegrams handed to the master before the case's own.
    pub from_sent: usize,
    /// The case's telegrams.
    pub sent: Vec<Vec<u8>>,
}

/// Run `case` on a bench with `tb_setup` applied to it first (an observer of every clock,
/// for one), fast or strict.
pub fn drive(
    case: &SweepCase,
    cfg: &Config,
    fast: bool,
    tb_setup: impl FnOnce(&mut Testbench),
) -> SweepRun {
    let mut rng = ChaCha8Rng::seed_from_u64(case.seed);
    let target = BitTiming::new(DEFAULT_CLOCK_HZ, case.baud, case.ppm);
    let first_timing = match case.scenario {
        Scenario::PowerUp => target,
        Scenario::RateChange { from } => BitTiming::new(DEFAULT_CLOCK_HZ, from, -case.ppm),
    };
    let mut tb = Testbench::new(*cfg, first_timing, FaultInjector::none());
    tb_setup(&mut tb);
    tb.run_until(case.phase, fast);
    if let Scenario::RateChange { .. } = case.scenario {
        tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 4));
        tb.run_out(40, fast);
        tb.set_master_timing(target);
    }
    // From here on, the telegrams at the case's rate, as fast as a master polls. With more
    // noise, more telegrams give the search its chance (a glitch within TSYN before a telegram
    // rightly costs that telegram).
    let from_tick = tb.now();
    let from_sent = tb.sent.len();
    let count = TELEGRAMS * (1 + case.noise as usize);
    let sent = poll_sequence(&mut rng, count);
    for (i, t) in sent.iter().enumerate() {
        tb.send(if i == 0 { 40 } else { POLL_IDLE_BITS }, t);
    }
    if case.noise > 0 {
        let bits_per_telegram = POLL_IDLE_BITS as u64 + 40 * 11;
        let span = target.clocks_for(count as u64 * bits_per_telegram, 1);
        let mut f = FaultInjector::none();
        let max_len = (target.clocks_per_bit() / 2).saturating_sub(1).max(1);
        f.glitches(
            case.seed,
            from_tick,
            from_tick + span,
            count * case.noise as usize,
            max_len,
        );
        tb.bus.faults = f;
    }
    tb.run_out(40, fast);
    SweepRun {
        tb,
        target,
        from_tick,
        from_sent,
        sent,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shards of a list take each case once, and a malformed `i/N` is refused.
    #[test]
    fn shards_split_a_list_once() {
        let shards: Vec<Shard> = (1..=3).map(|i| format!("{i}/3").parse().unwrap()).collect();
        for position in 0..100 {
            assert_eq!(shards.iter().filter(|s| s.holds(position)).count(), 1);
        }
        assert!(Shard::ALL.holds(7));
        assert_eq!(" 2 / 4".parse::<Shard>(), Ok(Shard { index: 2, count: 4 }));
        for bad in ["0/4", "5/4", "1/0", "2", "a/4", "1/4/2", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
