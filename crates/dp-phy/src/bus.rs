//! The RS-485 line shared by several stations, and a seeded fault injector.
//!
//! Each station keeps its own clock offset in its [`BitTiming`](crate::BitTiming); the bus is the
//! one time base (the adapter's sample clock). Every clock, the stations' drivers are resolved to
//! one line level: nobody driving leaves the biased line at idle 1; two drivers at once raise the
//! collision count and the dominant 0 wins. The fault injector then bends the line: glitches
//! shorter than a bit, inverted spans (bit errors), a line stuck at one level. Faults that need to
//! know character boundaries (a flipped data bit, a dropped character) are the transmitter's:
//! [`CharFault`](crate::uart::CharFault).

use crate::uart::{CharFault, UartTx};
use crate::{BitTiming, Tick};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;

/// What a fault does to the line while it lasts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineFault {
    Invert,
    Stuck(bool),
}

/// One fault over `[start, start + len)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultWindow {
    pub start: Tick,
    pub len: Tick,
    pub fault: LineFault,
}

/// A plan of line faults, generated from a seed or written by a test.
#[derive(Clone, Debug, Default)]
pub struct FaultInjector {
    /// Sorted by start; windows do not overlap.
    windows: Vec<FaultWindow>,
    cursor: usize,
}

impl FaultInjector {
    pub fn none() -> Self {
        Self::default()
    }

    /// Add one fault; windows that overlap an earlier one are dropped.
    pub fn add(&mut self, w: FaultWindow) {
        let pos = self.windows.partition_point(|x| x.start < w.start);
        let clear_before = pos == 0 || {
            let p = &self.windows[pos - 1];
            p.start + p.len <= w.start
        };
        let clear_after = self
            .windows
            .get(pos)
            .is_none_or(|n| w.start + w.len <= n.start);
        if w.len > 0 && clear_before && clear_after {
            self.windows.insert(pos, w);
        }
    }

    /// `count` glitches of 1..=`max_len` clocks spread over `[from, to)`, from `seed`.
    pub fn glitches(&mut self, seed: u64, from: Tick, to: Tick, count: usize, max_len: Tick) {
        // Apart by nothing: only an overlapping one is dropped, as `add` drops it.
        self.isolated_glitches(seed, from, to, count, max_len, 0);
    }

    /// As [`glitches`](Self::glitches), but each at least `apart` clocks from every other (one
    /// too close is dropped): glitches that a receiver can take, each alone in its bits. Two
    /// inside one bit can invert it, which no receiver undoes.
    pub fn isolated_glitches(
        &mut self,
        seed: u64,
        from: Tick,
        to: Tick,
        count: usize,
        max_len: Tick,
        apart: Tick,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..count {
            let start = rng.gen_range(from..to);
            let len = rng.gen_range(1..=max_len.max(1));
            let near = apart > 0
                && self
                    .windows
                    .iter()
                    .any(|w| start < w.start + w.len + apart && w.start < start + len + apart);
            if !near {
                self.add(FaultWindow {
                    start,
                    len,
                    fault: LineFault::Invert,
                });
            }
        }
    }

    pub fn windows(&self) -> &[FaultWindow] {
        &self.windows
    }

    /// The line after the faults active at `now` (call with non-decreasing `now`).
    #[inline(always)]
    pub fn apply(&mut self, now: Tick, line: bool) -> bool {
        while let Some(w) = self.windows.get(self.cursor) {
            if now < w.start {
                return line;
            }
            if now < w.start + w.len {
                return match w.fault {
                    LineFault::Invert => !line,
                    LineFault::Stuck(level) => level,
                };
            }
            self.cursor += 1;
        }
        line
    }

    /// The end of the last fault that began before `now` (clipped to `now`): where the line
    /// was last disturbed by a fault, if ever.
    pub fn disturbed_until(&self, now: Tick) -> Option<Tick> {
        let before = self.windows.partition_point(|w| w.start < now);
        let w = self.windows.get(before.checked_sub(1)?)?;
        Some((w.start + w.len).min(now))
    }

    /// Ticks from `now` before the faults change anything.
    pub fn quiet_for(&self, now: Tick) -> Tick {
        match self.windows[self.cursor.min(self.windows.len())..]
            .iter()
            .find(|w| now < w.start + w.len)
        {
            Some(w) if now < w.start => w.start - now,
            Some(_) => 0,
            None => Tick::MAX,
        }
    }
}

/// The shared line: resolves drivers, counts collisions, applies faults.
#[derive(Clone, Debug)]
pub struct Bus {
    pub faults: FaultInjector,
    pub collisions: u64,
    /// The level after the last [`resolve`](Self::resolve).
    pub line: bool,
}

impl Bus {
    pub fn new(faults: FaultInjector) -> Self {
        Bus {
            faults,
            collisions: 0,
            line: true,
        }
    }

    /// The line level at `now` for the stations' driver outputs.
    #[inline(always)]
    pub fn resolve(&mut self, now: Tick, drivers: impl IntoIterator<Item = Option<bool>>) -> bool {
        let mut level = true;
        let mut driving = 0;
        for d in drivers.into_iter().flatten() {
            driving += 1;
            level &= d;
        }
        if driving > 1 {
            self.collisions += 1;
        }
        self.line = self.faults.apply(now, level);
        self.line
    }
}

/// A telegram a [`TxStation`] is to send.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Outgoing {
    /// Idle bit times (of the station's own clock) before it.
    pub idle_bits: u32,
    pub bytes: Vec<u8>,
    pub faults: Vec<(u16, CharFault)>,
}

/// A station that only sends: a master's transmitter with its own clock offset, working through
/// a queue of telegrams, each after its own idle time.
#[derive(Clone, Debug)]
pub struct TxStation {
    pub tx: UartTx,
    pub queue: VecDeque<Outgoing>,
    /// Telegrams handed to the transmitter so far.
    pub started: usize,
}

impl TxStation {
    pub fn new(timing: BitTiming) -> Self {
        TxStation {
            tx: UartTx::new(timing),
            queue: VecDeque::new(),
            started: 0,
        }
    }

    pub fn push(&mut self, idle_bits: u32, bytes: &[u8]) {
        self.queue.push_back(Outgoing {
            idle_bits,
            bytes: bytes.to_vec(),
            faults: Vec::new(),
        });
    }

    /// Whether everything queued has been sent.
    pub fn done(&self) -> bool {
        self.queue.is_empty() && !self.tx.busy()
    }

    #[inline(always)]
    pub fn drive(&self) -> Option<bool> {
        self.tx.drive()
    }

    #[inline(always)]
    pub fn tick(&mut self) {
        if !self.tx.busy() {
            if let Some(o) = self.queue.pop_front() {
                self.tx.send(o.idle_bits, &o.bytes, &o.faults);
                self.started += 1;
            }
        }
        self.tx.tick();
    }

    /// Ticks before the output can change.
    pub fn quiet_for(&self) -> Tick {
        if !self.tx.busy() && !self.queue.is_empty() {
            return 0;
        }
        self.tx.quiet_for()
    }

    pub fn skip(&mut self, ticks: Tick) {
        self.tx.skip(ticks);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_drivers_collide_and_zero_dominates() {
        let mut bus = Bus::new(FaultInjector::none());
        assert!(bus.resolve(0, [None, None]));
        assert_eq!(bus.collisions, 0);
        assert!(!bus.resolve(1, [Some(true), Some(false)]));
        assert_eq!(bus.collisions, 1);
    }

    #[test]
    fn faults_apply_in_their_windows_only() {
        let mut f = FaultInjector::none();
        f.add(FaultWindow {
            start: 5,
            len: 2,
            fault: LineFault::Invert,
        });
        f.add(FaultWindow {
            start: 6,
            len: 5,
            fault: LineFault::Invert,
        }); // overlaps: dropped
        f.add(FaultWindow {
            start: 10,
            len: 3,
            fault: LineFault::Stuck(false),
        });
        assert_eq!(f.quiet_for(0), 5);
        let got: Vec<bool> = (0..15).map(|t| f.apply(t, true)).collect();
        let want: Vec<bool> = (0..15)
            .map(|t| !(5..7).contains(&t) && !(10..13).contains(&t))
            .collect();
        assert_eq!(got, want);
        assert_eq!(f.quiet_for(15), Tick::MAX);
    }
}
