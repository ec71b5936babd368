//! The receiver reads what the replay of the line's edges reads: `edge_rx::EdgeRx` (readers
//! that take each character as it arrives, the gateware's form) against the receiver it
//! replaced, kept here as the oracle (`edge_replay`: the line's last 32 edges, each candidate's
//! bits by the level held longer, `uart::bits_by_longer_level`, at its decision), on seeded
//! random lines at every rate with the search's hand-overs among them: the same characters,
//! errors, starts, ends and idle times, and the same deadlines after every event. The oracle's
//! own hand-over (`edge_replay::EdgeRx::hand_over`) is the search's as it is now: from the
//! decision's clock on.

use dp_phy::edge_rx;
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::RxChar;
use dp_phy::{Baud, BitTiming, Tick};
use edge_replay::LineEdges;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The receiver before the character readers (edge_rx.rs at 863a53d), unchanged but for its
/// paths: it replays the ring at each decision.
#[allow(dead_code)]
mod edge_replay {
    use dp_phy::uart::{bits_by_longer_level, glitches_off_grid, parity_bit, CharError, RxChar};
    use dp_phy::{BitTiming, Tick};

    const EDGES_KEPT: usize = 32;
    const MAX_GLITCHES: u32 = 2;

    /// The line's last edges, a ring: each with its tick and whether the line rose (the ring
    /// the receiver kept, edge_rx.rs at 863a53d).
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

        /// The search's hand-over at `now` (new since 863a53d, as `edge_rx::EdgeRx::hand_over`
        /// has it): the falls after the middle of the decided character's stop bit, as
        /// `catch_up` takes them, but only those on the decision's clock.
        pub fn hand_over(
            &self,
            start: Tick,
            end: Tick,
            now: Tick,
            edges: &LineEdges,
            q: &mut EdgeRxQ,
        ) {
            *q = EDGE_RX_RESET;
            q.ready_at = start + self.stop_middle;
            let newest = edges.seen().wrapping_sub(1);
            if let Some((at, false)) = edges.get(newest) {
                if at == now && at >= q.ready_at {
                    self.on_fall(newest, at.saturating_sub(end), edges, q);
                }
            }
        }
    }
}

/// A random line at `baud`: runs of either level from a clock to three bits, bursts of
/// glitches, and whole characters at the rate now and then, as (tick, level after) edges.
fn random_line(rng: &mut ChaCha8Rng, baud: Baud, bits: u64) -> Vec<(Tick, bool)> {
    let t = BitTiming::new(DEFAULT_CLOCK_HZ, baud, rng.gen_range(-5000..=5000));
    let bit = t.clocks_per_bit();
    let mut edges_at: Vec<(Tick, bool)> = Vec::new();
    let (mut now, mut level) = (3 * bit, true);
    while now < bits * bit {
        if rng.gen_ratio(1, 4) {
            // A character: start, 8 data, even parity, stop, at the master's rate.
            let byte: u8 = rng.gen();
            let mut char_bits = vec![false];
            char_bits.extend((0..8).map(|i| byte >> i & 1 == 1));
            char_bits.push(byte.count_ones() % 2 == 1);
            char_bits.push(true);
            for (i, &b) in char_bits.iter().enumerate() {
                if b != level {
                    edges_at.push((now + t.clocks_for(i as u64, 1), b));
                    level = b;
                }
            }
            now += t.clocks_for(11, 1) + rng.gen_range(0..2 * bit);
        } else {
            now += rng.gen_range(1..=3 * bit);
            level = !level;
            edges_at.push((now, level));
        }
    }
    edges_at
}

/// The line's changes as a channel sampling it at the ticks `s * period + phase` sees them,
/// each at its sample's index `s`: a pulse between two samples is never seen.
fn sampled(edges_at: &[(Tick, bool)], period: Tick, phase: Tick) -> Vec<(Tick, bool)> {
    let mut seen: Vec<(Tick, bool)> = Vec::new();
    let mut held = true;
    for (i, &(at, level)) in edges_at.iter().enumerate() {
        let s = at.saturating_sub(phase).div_ceil(period);
        // The last change before that sample decides its level.
        let superseded = edges_at
            .get(i + 1)
            .is_some_and(|&(next, _)| next.saturating_sub(phase).div_ceil(period) == s);
        if !superseded && level != held {
            seen.push((s, level));
            held = level;
        }
    }
    seen
}

/// The receiver against the replay on a random line at `baud`, with the search's hand-overs
/// at random ticks (a character decided by the search, which started 10.5 to 12 bits before).
///
/// The receiver samples the line every `period` clocks at `phase` (`EdgeRx::sampled`, as the
/// transceiver builds it for the search's channel of its rate); the replay, which knows
/// nothing of samples, takes the same samples one a tick, its bit that many samples long. The
/// receiver's figures are then the replay's in clocks: its ticks `s * period + phase` for the
/// replay's `s`, its idle times `period` times as long. With a period of 1 the two take the
/// same line at the same rate.
fn compare(seed: u64, baud: Baud, bits: u64, period: Tick, phase: Tick) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let line = random_line(&mut rng, baud, bits);
    let edges_at = sampled(&line, period, phase);
    let clocks = if period == 1 {
        BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0)
    } else {
        BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud)
    };
    let in_samples = BitTiming {
        inc: clocks.inc * period,
        modulo: clocks.modulo,
    };
    let bit = in_samples.clocks_per_bit();
    let samples = bits * bit;
    let tick = |s: Tick| s * period + phase;
    let handovers: Vec<Tick> = (0..rng.gen_range(0..4))
        .map(|_| rng.gen_range(20 * bit..samples))
        .collect();
    let ours = edge_rx::EdgeRx::sampled(clocks, period, phase);
    let replay = edge_replay::EdgeRx::new(in_samples);
    let (mut q, mut rq) = (edge_rx::EDGE_RX_RESET, edge_replay::EDGE_RX_RESET);
    let mut edges = LineEdges::EMPTY;
    let (mut got, mut want) = (Vec::new(), Vec::new());
    let (mut next_edge, mut line) = (0, true);
    let mut handover = handovers.iter().copied().peekable();
    let end = samples + 20 * bit;
    // The replay's characters in the receiver's clocks.
    let in_clocks = |(s, (c, idle)): (Tick, (RxChar, Tick))| {
        let c = RxChar {
            start: tick(c.start),
            end: tick(c.end),
            ..c
        };
        (tick(s), (c, idle * period))
    };
    let mut now = 0;
    while now < end {
        if let Some(&(at, rose)) = edges_at.get(next_edge).filter(|(at, _)| *at == now) {
            edges.push(at, rose);
            line = rose;
            // The idle before a fall, as the transceiver would count it: any figure will do
            // as long as both receivers get it.
            let idle = now / 7;
            if !rose {
                replay.on_fall(edges.seen() - 1, idle, &edges, &mut rq);
            }
            ours.on_edge(tick(now), rose, idle * period, &mut q);
            next_edge += 1;
        }
        if handover.next_if(|&h| h == now).is_some() {
            // Decided at the middle of its stop bit or later, as the search decides.
            let start =
                now - rng.gen_range(in_samples.clocks_for(21, 2)..=in_samples.clocks_for(12, 1));
            let end = start + in_samples.clocks_for(11, 1);
            let fell = edges.get(edges.seen().wrapping_sub(1)) == Some((now, false));
            replay.hand_over(start, end, now, &edges, &mut rq);
            ours.hand_over(tick(start), tick(end), tick(now), fell, &mut q);
        } else {
            if now >= rq.deadline {
                want.extend(
                    replay
                        .act(now, line, &edges, &mut rq)
                        .map(|c| in_clocks((now, c))),
                );
            }
            if tick(now) >= q.deadline {
                got.extend(ours.act(tick(now), line, &mut q).map(|c| (tick(now), c)));
            }
        }
        let deadline = (rq.deadline != Tick::MAX).then(|| tick(rq.deadline));
        assert_eq!(
            (q.deadline != Tick::MAX).then_some(q.deadline),
            deadline,
            "seed {seed} {baud}: deadline at {now}"
        );
        assert_eq!(
            q.active(),
            rq.active(),
            "seed {seed} {baud}: under way at {now}"
        );
        // On to the next event: an edge, a deadline, a hand-over.
        let mut next = end;
        if let Some(&(at, _)) = edges_at.get(next_edge) {
            next = next.min(at);
        }
        if let Some(&h) = handover.peek() {
            next = next.min(h);
        }
        next = next.min(rq.deadline.max(now + 1));
        now = next.max(now + 1);
    }
    assert_eq!(got, want, "seed {seed} {baud}");
}

proptest! {
    #![proptest_config(prop_cases::config(256))]

    #[test]
    fn the_receiver_reads_what_the_edge_replay_reads(seed in any::<u64>(), rate in 0usize..10) {
        compare(seed, Baud::ALL[rate], 150, 1, 0);
    }

    /// The receiver as the transceiver builds it, sampling the line on the search's schedule
    /// (`autobaud::OVERSAMPLED`): what the replay reads from the same samples.
    #[test]
    fn the_sampled_receiver_reads_what_the_edge_replay_reads_from_its_samples(
        seed in any::<u64>(), rate in 0usize..10,
    ) {
        let schedule = dp_phy::autobaud::OVERSAMPLED;
        compare(seed, Baud::ALL[rate], 150, schedule.period[rate], schedule.phase[rate]);
    }
}
