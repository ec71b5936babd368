//! The adapter's transceiver: autobaud, receiver, delimiter, transmitter and baud watchdog.
//!
//! Contract, per clock (`tick(line)`):
//! - While **searching**, [`AutoBaud`] listens at every rate at once; a detection makes the rate
//!   a *trial* and its first character the first of a telegram. A trial becomes **locked** only
//!   when that telegram (SD1/SD2/SD3/SD4; an SC does not count) arrives complete and error-free;
//!   any error during the trial returns to searching. Noise can start a trial but never lock.
//! - The search never stops: while a rate is **locked** it goes on beside the receiver. A start
//!   delimiter that decodes at *another* rate (each bit the level it held longer, start, parity
//!   and stop bits right, TSYN of idle at that rate before it, that rate's glitches aside) starts
//!   a trial at that rate at once, with the locked rate kept as its fallback: the trial's telegram
//!   complete and error-free moves the lock (a **relock**); any error in it returns to the old
//!   lock, its watchdog unchanged. Noise has to forge both to move the lock. A detection of a
//!   character that started before the trial did is the trial's own delimiter at a slower rate:
//!   it is ignored.
//! - While **locked**, the baud-control watchdog (ticks of 10 ms) is restarted by every good
//!   telegram; when it expires (between telegrams: a long one at 9.6k outlasts it) the
//!   transceiver searches again: the last resort, for a master the relock did not catch.
//! - The receiver ([`EdgeRx`]) takes each character from the line's edges, every bit by the level
//!   the line held longer within it: a glitch shorter than half a bit cannot turn a bit, nor an
//!   edge it moved, so glitches inside a telegram cost nothing. Where a glitch leaves two falls
//!   within a start bit, it reads the character from both. It takes the line as the search's
//!   channel of its rate samples it ([`EdgeRx::sampled`]), and so do the idle time, the gap and
//!   TSDR: its characters and idle line are that channel's sample ticks, which follow the line
//!   within a sample (every clock at 3, 6 and 12 Mbit/s); no filter holds the line back. A
//!   character goes to the delimiter a clock after the receiver decides it (a register between
//!   the two, as in the gateware); until then it is under way. So does a detection's character:
//!   the delimiter takes one character a clock.
//! - Every telegram is delivered with its status and end tick ([`TickOut::telegram`], then
//!   [`Transceiver::telegram`]); only those starting after TSYN idle bits are taken.
//! - A response handed to [`Transceiver::respond`] starts no earlier than min TSDR bit times after
//!   the line went idle (the end of the request), and no earlier than the tick it names. The
//!   driver is enabled only while it sends; the receiver ignores its own echo.
//!
//! [`Transceiver::advance`] is the fast mode: it skips spans in which nothing but counters would
//! change, with outputs identical to ticking every clock.

use crate::autobaud::{AutoBaud, AutoBaudQ, Detection, AUTOBAUD_RESET};
use crate::delimiter::{Delimiter, Delivery, RxTelegram};
use crate::edge_rx::{EdgeRx, EdgeRxQ, EDGE_RX_RESET};
use crate::filter::{self, FilterQ, FILTER_RESET};
use crate::rate_idle::{RateIdle, RATE_IDLE_NONE};
use crate::uart::{RxChar, UartTx};
use crate::watchdog::Watchdog;
use crate::{BitTiming, Tick};
use dp_consts::{Baud, MIN_TSDR_BITS, SC};

/// Where the baud-rate search stands: the transceiver's status output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BaudState {
    Searching,
    /// A rate picked from a first character, waiting for its telegram to confirm it.
    Trial(Baud),
    Locked(Baud),
}

impl BaudState {
    pub fn baud(self) -> Option<Baud> {
        match self {
            BaudState::Searching => None,
            BaudState::Trial(b) | BaudState::Locked(b) => Some(b),
        }
    }
}

/// Configuration, fixed at reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Sample clock.
    pub clock_hz: u32,
    /// Baud-control watchdog, in ticks of 10 ms.
    pub baud_watchdog_10ms: u32,
    /// Idle bit times allowed between the characters of one telegram before it is a gap.
    pub max_gap_bits: u32,
    /// When each rate's channel of the search samples the line: [`crate::autobaud::OVERSAMPLED`],
    /// as the gateware builds it, or [`crate::autobaud::EVERY_CLOCK`] to compare
    /// (`cargo xtask baud-sweep --every-clock`).
    pub search_schedule: crate::autobaud::Schedule,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            clock_hz: crate::timing::DEFAULT_CLOCK_HZ,
            baud_watchdog_10ms: 20,
            max_gap_bits: 1,
            search_schedule: crate::autobaud::OVERSAMPLED,
        }
    }
}

/// Outputs of one clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TickOut {
    /// A telegram was delivered on this clock: read it with [`Transceiver::telegram`].
    pub telegram: bool,
    /// The baud state changed on this clock.
    pub baud_changed: bool,
}

/// Counters for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub telegrams_good: u64,
    pub telegrams_bad: u64,
    pub char_errors: u64,
    /// Characters outside a telegram without TSYN before them.
    pub not_synced: u64,
    /// Measurements the search rejected while searching (it rejects most characters of a
    /// telegram while locked, which is not worth counting).
    pub search_rejects: u64,
    pub trials: u64,
    /// The lock moved to another rate on a confirmed trial, without the watchdog.
    pub relocks: u64,
    /// Trials started from a lock that failed and returned to it.
    pub relock_trials_failed: u64,
    pub watchdog_expiries: u64,
    /// Detections decided after their channel's line rose past the character's end
    /// (`Detection::rose_after_end`): the receiver's idle line counted from the decision.
    pub detections_after_rise: u64,
    /// Detections whose character reached the delimiter more than a gap after its end (at 6M
    /// and 12M, where the gap is a bit, after glitches): that clock finds no gap.
    pub detections_past_gap: u64,
    /// Locks taken back on a clock on which the line fell at their rate: the receiver starts
    /// afresh with that fall, its idle time from the lock's idle line.
    pub relock_falls: u64,
    /// Detections acted on whose rate's line fell on the detection's clock: the receiver's
    /// first candidate starts there, handed over with the detection.
    pub detection_falls: u64,
}

/// Internal signals worth a waveform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Probe {
    /// The line in the clock domain, as the search and the receiver see it.
    pub synced: bool,
    pub rx_active: bool,
    pub rx_bit: u8,
    pub measuring: bool,
    pub in_telegram: bool,
    pub driver_enable: bool,
    /// The lock a trial returns to if it fails.
    pub fallback: Option<Baud>,
    /// The tick the line has been idle since at the receiver's rate (what TSDR counts from);
    /// `None` while it is not idle.
    pub idle_since: Option<Tick>,
}

/// The transceiver block.
#[derive(Clone, Debug)]
pub struct Transceiver {
    cfg: Config,
    now: Tick,
    state: BaudState,
    search: AutoBaud,
    /// Receiver, transmitter and delimiter thresholds exist once a rate is known.
    rx: Option<EdgeRx>,
    tx: Option<UartTx>,
    delimiter: Delimiter,
    rx_q: EdgeRxQ,
    /// The synchroniser the search and the receiver share: the line in the clock domain.
    sync_q: FilterQ,
    search_q: AutoBaudQ,
    /// The tick the trial under way started on: a detection of a character that began before
    /// it is of the trial's own start delimiter, at a slower rate.
    trial_since: Tick,
    /// During a trial started from a lock: that lock, to return to if the trial fails.
    fallback: Option<Baud>,
    /// The last character taken ends on this tick (its stop bit's end).
    last_end: Tick,
    /// The idle line at the receiver's rate, and during a trial from a lock at the locked
    /// rate (what the lock goes on with if the trial fails).
    rx_idle: RateIdle,
    fallback_idle: RateIdle,
    /// Debug builds' check, no register: whether `rx_idle` and `fallback_idle` went on from a
    /// detection whose line rose after its end (`Detection::rose_after_end`). Such a copy
    /// counts no longer than the rate's channel; any other, exactly as long.
    #[cfg(debug_assertions)]
    late_copies: (bool, bool),
    /// The character the receiver decided on the last clock, with the idle clocks before it:
    /// delivered on this one, first thing. A register between the receiver's decision and the
    /// delimiter, as the gateware has it (README "Gateware": the decision's logic and the
    /// delimiter's do not fit one 48 MHz clock together).
    decided: Option<(RxChar, Tick)>,
    /// The character a detection decoded, delivered on the next clock as the receiver's are:
    /// the delimiter takes one character a clock, and on a detection's clock it may take the
    /// receiver's last one at the old rate. The search checked TSYN before it, and it is never
    /// the transceiver's echo (it started the trial).
    detected: Option<RxChar>,
    /// The search's detection of the last clock, and whether the line fell at its rate on
    /// that clock: acted on on this one, after the search (README "Gateware": the search's
    /// decision and the trial it starts do not fit one 48 MHz clock together). The receiver
    /// it starts is handed over as of the detection's clock and takes this clock's sample, so
    /// it reads as if it had started there.
    detection: Option<(Detection, bool)>,
    /// A delivered telegram's verdict on the baud state, acted on first thing on the next
    /// clock: a register between the delimiter and the baud control, as the gateware has it
    /// (README "Gateware": the delimiter's decision and the rate's change do not fit one
    /// 48 MHz clock together). It belongs to the receiver whose telegram it judges: a new
    /// trial or a search drops it.
    verdict: Option<Verdict>,
    /// The last tick the transmitter drove the line (none since reset): a character that
    /// started by then is the transceiver's own echo. The gateware keeps it as its age,
    /// saturating, so that it never wraps, and compares a start with 18 bits of the tick while
    /// the age is under 2^17 clocks (README "Gateware").
    drove_until: Option<Tick>,
    /// The baud-control watchdog, and its clocks.
    watchdog: Watchdog,
    watchdog_clocks: Tick,
    min_tsdr_bits: u8,
    /// Min TSDR in clocks, and the transmitter's bit in clocks it is worked out from, as the
    /// gateware has them: the bit follows the transmitter's rate a clock later and keeps the
    /// last rate while there is none; min TSDR is their product with the setting, worked out
    /// a bit of the setting a clock (shift and add, most significant first: the gateware's
    /// multiply, [`TSDR_STEPS`] clocks after a change of either, where a one-clock multiply
    /// took about 200 LUT4). `tsdr_operands`: the bit and the setting as the last clock began
    /// (a change starts the multiply again); `tsdr_steps`: the setting's bits still to add.
    /// A response waits while they do not yet hold the rate's and the setting's figures
    /// ([`tsdr_settled`](Self::tsdr_settled)).
    tx_bit_clocks: Tick,
    tsdr_clocks: Tick,
    tsdr_operands: (Tick, u8),
    tsdr_steps: u32,
    /// A response waits for this tick (and for min TSDR of idle line).
    pending_not_before: Option<Tick>,
    response: Vec<u8>,
    stats: Stats,
}

/// What a delivered telegram says about the rate it came at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    /// Good: it confirms a trial, unless it is an SC (a short acknowledgement proves little).
    Good { confirms: bool },
    /// Bad: a trial fails on it.
    Bad,
}

/// The line is taken into the clock domain with no glitch filter: every glitch is weighed, bit by
/// bit, where it falls. A filter would move an edge that a glitch follows within its length: by
/// half a bit at 12 Mbit/s (4 clocks at 48 MHz) even for a filter of one clock.
const SYNC_FILTER_LEN: u16 = 0;

/// The clocks min TSDR's multiply takes after a change of rate or setting: a bit of the
/// setting (8 bits) a clock.
const TSDR_STEPS: u32 = u8::BITS;

impl Transceiver {
    pub fn new(cfg: Config) -> Self {
        // As the gateware's reset: its rate register starts at the first rate.
        let first_bit = BitTiming::whole_clocks(cfg.clock_hz, Baud::ALL[0]).clocks_per_bit();
        Transceiver {
            cfg,
            now: 0,
            state: BaudState::Searching,
            search: AutoBaud::sampled(cfg.clock_hz, cfg.search_schedule),
            rx: None,
            tx: None,
            delimiter: Delimiter::new(0, 0),
            rx_q: EDGE_RX_RESET,
            sync_q: FILTER_RESET,
            search_q: AUTOBAUD_RESET,
            trial_since: 0,
            fallback: None,
            last_end: 0,
            rx_idle: RATE_IDLE_NONE,
            fallback_idle: RATE_IDLE_NONE,
            #[cfg(debug_assertions)]
            late_copies: (false, false),
            decided: None,
            detected: None,
            detection: None,
            verdict: None,
            drove_until: None,
            watchdog: Watchdog::STOPPED,
            watchdog_clocks: cfg.baud_watchdog_10ms as Tick * (cfg.clock_hz as Tick / 100),
            min_tsdr_bits: MIN_TSDR_BITS,
            tx_bit_clocks: first_bit,
            tsdr_clocks: first_bit * Tick::from(MIN_TSDR_BITS),
            tsdr_operands: (first_bit, MIN_TSDR_BITS),
            tsdr_steps: 0,
            pending_not_before: None,
            response: Vec::with_capacity(dp_consts::MAX_TELEGRAM_LEN),
            stats: Stats::default(),
        }
    }

    /// A transceiver coming out of reset at tick `now` of a bus that kept running (a power
    /// cycle of the board): as `new`, with the line's idle time counted from `now`.
    pub fn reset_at(cfg: Config, now: Tick) -> Self {
        Transceiver {
            now,
            last_end: now,
            search_q: AutoBaudQ::idle_since(now),
            ..Transceiver::new(cfg)
        }
    }

    pub fn now(&self) -> Tick {
        self.now
    }

    pub fn baud_state(&self) -> BaudState {
        self.state
    }

    pub fn stats(&self) -> Stats {
        self.stats
    }

    pub fn config(&self) -> Config {
        self.cfg
    }

    /// Bit timing of the rate in use, once one is known.
    pub fn timing(&self) -> Option<BitTiming> {
        self.rx.map(|rx| rx.timing)
    }

    /// The telegram delivered last.
    pub fn telegram(&self) -> &RxTelegram {
        self.delimiter.telegram()
    }

    /// Set min TSDR in bit times (Set_Prm); never below the 11 bit times of the standard.
    pub fn set_min_tsdr(&mut self, bits: u8) {
        self.min_tsdr_bits = bits.max(MIN_TSDR_BITS);
    }

    /// Internal signals, for waveforms.
    pub fn probe(&self) -> Probe {
        Probe {
            synced: self.sync_q.out,
            rx_active: self.rx_q.active(),
            rx_bit: self.rx.map_or(0, |rx| rx.bit_at(self.now, &self.rx_q)),
            measuring: self.search_q.measuring,
            in_telegram: self.delimiter.inside(),
            driver_enable: self.drive().is_some(),
            fallback: self.fallback,
            idle_since: self.idle_since(),
        }
    }

    /// Hand a response to the transmitter. It starts at `not_before` at the earliest, and not
    /// before the line has been idle for min TSDR. Refused (false) while no rate is known, for an
    /// empty or over-long response, or while another response is waiting or under way.
    pub fn respond(&mut self, bytes: &[u8], not_before: Tick) -> bool {
        let Some(tx) = &self.tx else { return false };
        if bytes.is_empty()
            || bytes.len() > dp_consts::MAX_TELEGRAM_LEN
            || self.pending_not_before.is_some()
            || tx.busy()
        {
            return false;
        }
        self.response.clear();
        self.response.extend_from_slice(bytes);
        self.pending_not_before = Some(not_before);
        true
    }

    /// Whether a response is waiting or on the line.
    pub fn responding(&self) -> bool {
        self.pending_not_before.is_some() || self.tx.as_ref().is_some_and(|t| t.busy())
    }

    /// The driver: `Some(level)` while sending, `None` with the driver off.
    #[inline(always)]
    pub fn drive(&self) -> Option<bool> {
        self.tx.as_ref().and_then(|t| t.drive())
    }

    /// The rate the receiver is on (locked or on trial): the search's decisions at it, and its
    /// rejections, change nothing then.
    pub fn heard(&self) -> Option<Baud> {
        self.rx.and(self.state.baud())
    }

    /// The tick the line has been idle since at the receiver's rate: high, that rate's
    /// glitches aside, since the last character ended. `now` while it is not idle (low, or a
    /// character under way).
    fn quiet_since(&self) -> Tick {
        self.idle_since().unwrap_or(self.now)
    }

    /// As [`quiet_since`](Self::quiet_since), `None` while the line is not idle.
    fn idle_since(&self) -> Option<Tick> {
        match self.heard() {
            Some(b)
                if self.search_q.held[b.index()]
                    && !self.rx_q.active()
                    && self.decided.is_none() =>
            {
                let since = self.last_end.max(self.rx_idle.high_since);
                #[cfg(debug_assertions)]
                {
                    let channel = self.last_end.max(self.search_q.high_since[b.index()]);
                    if self.late_copies.0 {
                        debug_assert!(
                            since >= channel,
                            "the receiver's idle line is longer than its rate's channel's at {}",
                            self.now
                        );
                    } else {
                        debug_assert_eq!(
                            since, channel,
                            "the receiver's idle line is not its rate's channel's at {}",
                            self.now
                        );
                    }
                }
                Some(since)
            }
            _ => None,
        }
    }

    fn idle(&self) -> Tick {
        self.now.saturating_sub(self.quiet_since())
    }

    /// The tick at which a waiting response may start, as the transceiver stands (between
    /// clocks: the line's idle time as the last clock left it).
    fn response_start(&self) -> Option<Tick> {
        let not_before = self.pending_not_before?;
        self.tx.as_ref()?;
        // Not yet the rate's or the setting's: up to TSDR_STEPS + 1 clocks after a change.
        if !self.tsdr_settled() {
            return None;
        }
        Some(not_before.max(self.quiet_since() + self.tsdr_clocks))
    }

    /// Whether min TSDR's registers hold what the transmitter's rate and the setting give
    /// (they change on a clock of their own otherwise: fast mode ticks it, and a response
    /// waits for them).
    fn tsdr_settled(&self) -> bool {
        let bit = self
            .tx
            .as_ref()
            .map_or(self.tx_bit_clocks, |tx| tx.timing.clocks_per_bit());
        let settled = self.tsdr_steps == 0 && self.tsdr_operands == (bit, self.min_tsdr_bits);
        debug_assert!(
            !settled || self.tsdr_clocks == bit * Tick::from(self.min_tsdr_bits),
            "min TSDR's multiply settled on {} for {bit} x {}",
            self.tsdr_clocks,
            self.min_tsdr_bits
        );
        settled
    }

    /// The registers [`tsdr_clocks`](Self::tsdr_clocks) and the bit it is worked out from, at
    /// the end of a clock: from their values as it began, and the transmitter's rate after it.
    fn next_tsdr(&mut self) {
        let operands = (self.tx_bit_clocks, self.min_tsdr_bits);
        if operands != self.tsdr_operands {
            self.tsdr_operands = operands;
            self.tsdr_clocks = 0;
            self.tsdr_steps = TSDR_STEPS;
        } else if self.tsdr_steps > 0 {
            self.tsdr_steps -= 1;
            let bit_set = (operands.1 >> self.tsdr_steps) & 1;
            self.tsdr_clocks = 2 * self.tsdr_clocks + Tick::from(bit_set) * operands.0;
        }
        if let Some(tx) = &self.tx {
            self.tx_bit_clocks = tx.timing.clocks_per_bit();
        }
    }

    /// One clock with the line at `line`.
    #[inline]
    pub fn tick(&mut self, line: bool) -> TickOut {
        let mut out = TickOut::default();
        let now = self.now;
        // A waiting response starts on this clock if the line was idle long enough as the clock
        // began (the gateware decides on its registers; the idle line's change on this clock
        // counts from the next), unless this clock changes the rate or searches again.
        let start_response = self.response_start().is_some_and(|start| now >= start);
        // A telegram under way as the clock began: its last character's verdict, which
        // restarts the watchdog, comes on the next clock.
        let was_inside = self.delimiter.inside();
        let mut lock_taken_back = false;
        if let Some(v) = self.verdict.take() {
            // The telegram was the last thing its receiver took: nothing comes with its verdict.
            debug_assert!(
                self.decided.is_none() && self.detected.is_none(),
                "a character on a verdict's clock at {now}"
            );
            lock_taken_back = self.on_verdict(v, &mut out);
        }
        // A clock that delivers a character finds no gap: the gateware compares the gap with
        // the last end kept, not this one (a detection decided late, a second candidate's stop
        // bit after glitches, ends more than a gap before its delivery at 6M and 12M: the gap
        // is one bit there). The next clock's check finds it, if no character has begun.
        let delivers = self.decided.is_some() || self.detected.is_some();
        if let Some((c, idle_before)) = self.decided.take() {
            self.last_end = c.end;
            if self.drove_until.is_none_or(|d| c.start > d) {
                self.on_char(&c, idle_before, &mut out);
            }
        }
        if let Some(c) = self.detected.take() {
            if now.saturating_sub(c.end) > self.delimiter.gap_clocks {
                self.stats.detections_past_gap += 1;
            }
            self.last_end = c.end;
            self.on_char(&c, Tick::MAX, &mut out);
        }
        let (sf, sfq) = filter::next(line, SYNC_FILTER_LEN, &self.sync_q);
        self.sync_q = sfq;
        // The line as each rate's channel sampled it before this clock: the receiver takes the
        // line as the search's channel of its rate samples it.
        let held = self.search_q.held;
        // The search's own early exit, here: the rate heard is worth working out on its events
        // only (the search runs on every clock).
        let search_due = sf.fell || sf.rose || now >= self.search_q.deadline;
        // Idle before a fall, worked out before it counts: a character's TSYN.
        let idle_before = if search_due { self.idle() } else { 0 };
        let det = if search_due {
            self.search.clock(now, sf, self.heard(), &mut self.search_q)
        } else {
            None
        };
        let sampled_fall = |q: &AutoBaudQ, b: Baud| held[b.index()] && !q.held[b.index()];
        // The idle lines kept take this clock's changes at their rates (before a detection
        // hands the receiver's over to the fallback and starts a new one).
        let changed = |q: &AutoBaudQ, b: Baud| held[b.index()] != q.held[b.index()];
        if let Some(b) = self.heard() {
            if changed(&self.search_q, b) {
                let level = self.search_q.held[b.index()];
                self.rx_idle.edge(now, level, self.search.glitch_clocks(b));
            }
        }
        if let (BaudState::Trial(_), Some(f)) = (self.state, self.fallback) {
            if changed(&self.search_q, f) {
                let level = self.search_q.held[f.index()];
                self.fallback_idle
                    .edge(now, level, self.search.glitch_clocks(f));
            }
        }
        // Last clock's detection acts now; this clock's waits for the next.
        let pending = self.detection.take();
        match det {
            Some(Ok(d)) => self.detection = Some((d, sampled_fall(&self.search_q, d.baud))),
            Some(Err(_)) if self.rx.is_none() => self.stats.search_rejects += 1,
            _ => {}
        }
        let switched =
            pending.is_some_and(|(d, fell)| self.on_detection(&d, fell, &held, &mut out));

        // As the clock began: a lock taken back by a verdict starts afresh.
        let was_taking = self.rx_q.active();
        if let (Some(rx), Some(b), false) = (self.rx, self.heard(), switched) {
            let level = self.search_q.held[b.index()];
            if level != held[b.index()] {
                let idle = if level { 0 } else { idle_before };
                rx.on_edge(now, level, idle, &mut self.rx_q);
                self.stats.relock_falls += u64::from(lock_taken_back && !level);
            }
            if now >= self.rx_q.deadline {
                // Delivered on the next clock.
                self.decided = rx.act(now, level, &mut self.rx_q);
            }
            // The idle check and the watchdog wait while a character was under way as the
            // clock began (one decided on it included), not for this clock's step: the
            // receiver's logic and theirs do not fit one 48 MHz clock together (README
            // "Gateware"). A fall's clock has no idle line; a false start that ends on this
            // clock holds them one clock.
            if !was_taking && !delivers {
                let d = self.delimiter.on_idle(self.idle(), now);
                self.on_delivery(d, &mut out);
            }
            // A telegram under way is evidence of the rate: a long one at 9.6k outlasts
            // the watchdog, so it expires only between telegrams: none under way as the clock
            // began (so not on the clock one ends, before its verdict), and no character
            // delivered on this clock (the first of a telegram is one: a watchdog that ran
            // out during it would drop the telegram it belongs to).
            if !was_taking && !was_inside && !delivers && self.watchdog.expire(now) {
                self.stats.watchdog_expiries += 1;
                self.search_again(&mut out);
            }
        }

        if start_response && self.pending_not_before.take().is_some() {
            if let Some(tx) = &mut self.tx {
                tx.send(0, &self.response, &[]);
            }
        }
        if let Some(tx) = &mut self.tx {
            tx.tick();
        }
        if self.drive().is_some() {
            self.drove_until = Some(now);
        }
        self.next_tsdr();
        self.now = now + 1;
        out
    }

    /// A start delimiter the search decoded on the last clock (the line `fell` at its rate
    /// there; `held`: each rate's line as sampled before this clock): a trial at its rate,
    /// unless the receiver is on that rate already. Returns whether the receiver was replaced.
    fn on_detection(
        &mut self,
        d: &Detection,
        fell: bool,
        held: &[bool; 10],
        out: &mut TickOut,
    ) -> bool {
        match self.state {
            BaudState::Trial(b) | BaudState::Locked(b) if b == d.baud => return false,
            BaudState::Trial(_) if d.start <= self.trial_since => return false,
            BaudState::Searching => self.fallback = None,
            BaudState::Locked(b) => {
                self.fallback = Some(b);
                self.fallback_idle = self.rx_idle;
                #[cfg(debug_assertions)]
                {
                    self.late_copies.1 = self.late_copies.0;
                }
            }
            // A trial from a lock keeps that lock as its fallback.
            BaudState::Trial(_) => {}
        }
        self.start_trial(d.baud, out);
        // The rate's line on this clock, after the detection's clock.
        let b = d.baud.index();
        let level = self.search_q.held[b];
        let changed = level != held[b];
        // Decided on the last clock: the line counts as idle from the character's end, or from
        // there if it rose after that end (the receiver is handed no edges before it).
        let idle_from = d.idle_from(self.now - 1);
        self.rx_idle = RateIdle::from_detection(d, self.now - 1);
        #[cfg(debug_assertions)]
        {
            self.late_copies.0 = d.rose_after_end;
        }
        self.stats.detections_after_rise += u64::from(d.rose_after_end);
        self.stats.detection_falls += u64::from(fell);
        if changed {
            self.rx_idle
                .edge(self.now, level, self.search.glitch_clocks(d.baud));
        }
        self.last_end = d.end;
        if let Some(rx) = self.rx {
            // Handed over on the detection's clock, then this clock's step, as `tick` takes
            // it: the receiver is what it would be had it started there.
            rx.hand_over(d.start, idle_from, self.now - 1, fell, &mut self.rx_q);
            if changed {
                let idle = if level {
                    0
                } else {
                    self.now.saturating_sub(idle_from)
                };
                rx.on_edge(self.now, level, idle, &mut self.rx_q);
            }
        }
        self.detected = Some(RxChar {
            byte: d.byte,
            error: None,
            start: d.start,
            end: d.end,
        });
        true
    }

    fn on_char(&mut self, c: &RxChar, idle_before: Tick, out: &mut TickOut) {
        if c.error.is_some() {
            self.stats.char_errors += 1;
        }
        let d = self.delimiter.on_char(c, idle_before);
        self.on_delivery(d, out);
    }

    fn on_delivery(&mut self, d: Delivery, out: &mut TickOut) {
        match d {
            Delivery::None => {}
            Delivery::NotSynced => self.stats.not_synced += 1,
            Delivery::Telegram => {
                out.telegram = true;
                let t = self.delimiter.telegram();
                self.verdict = Some(if t.is_good() {
                    self.stats.telegrams_good += 1;
                    Verdict::Good {
                        confirms: t.bytes()[0] != SC,
                    }
                } else {
                    self.stats.telegrams_bad += 1;
                    Verdict::Bad
                });
            }
        }
    }

    /// The last clock's telegram, for the baud state: a good one confirms a trial and restarts
    /// the watchdog; a bad one fails a trial, back to its lock (the lock's receiver and idle
    /// line from this clock on) or to searching. Returns whether it took a lock back.
    fn on_verdict(&mut self, v: Verdict, out: &mut TickOut) -> bool {
        match v {
            Verdict::Good { confirms } => {
                if let (BaudState::Trial(b), true) = (self.state, confirms) {
                    self.state = BaudState::Locked(b);
                    out.baud_changed = true;
                    if self.fallback.take().is_some() {
                        self.stats.relocks += 1;
                    }
                }
                self.watchdog.start(self.now, self.watchdog_clocks);
                false
            }
            Verdict::Bad => {
                if let BaudState::Trial(_) = self.state {
                    match self.fallback.take() {
                        Some(locked) => {
                            self.stats.relock_trials_failed += 1;
                            self.use_rate(locked);
                            self.rx_idle = self.fallback_idle;
                            #[cfg(debug_assertions)]
                            {
                                self.late_copies.0 = self.late_copies.1;
                            }
                            self.state = BaudState::Locked(locked);
                            out.baud_changed = true;
                            return true;
                        }
                        None => self.search_again(out),
                    }
                }
                false
            }
        }
    }

    /// A trial at `baud`: the receiver takes over from the search, whose filter it starts from.
    /// A trial from a lock keeps that lock's watchdog, so that trials that keep failing cannot
    /// hold a lost rate for ever.
    fn start_trial(&mut self, baud: Baud, out: &mut TickOut) {
        self.stats.trials += 1;
        self.state = BaudState::Trial(baud);
        self.trial_since = self.now;
        out.baud_changed = true;
        self.use_rate(baud);
        if self.fallback.is_none() {
            self.watchdog.start(self.now, self.watchdog_clocks);
        }
    }

    /// Receiver, transmitter and delimiter for `baud`, from idle (the line's edges until now
    /// were at another rate); a waiting response is dropped.
    fn use_rate(&mut self, baud: Baud) {
        // A divider of the sample clock: the rate's bit in whole clocks.
        let timing = BitTiming::whole_clocks(self.cfg.clock_hz, baud);
        let figures = self.search.channel_figures(baud);
        self.rx = Some(EdgeRx::sampled(timing, figures.period, figures.phase));
        self.tx = Some(UartTx::new(timing));
        self.pending_not_before = None;
        self.verdict = None;
        self.rx_q = EdgeRxQ {
            read_until: self.now,
            ..EDGE_RX_RESET
        };
        // The delimiter keeps the telegram it delivered last: a failed trial's, read after this.
        self.delimiter.tsyn_clocks = self.search.tsyn_clocks(baud);
        self.delimiter.gap_clocks = timing.clocks_for(self.cfg.max_gap_bits as u64, 1);
        self.delimiter.reset();
    }

    /// Back to searching only: the search, which never stopped, goes on as it is.
    fn search_again(&mut self, out: &mut TickOut) {
        self.state = BaudState::Searching;
        out.baud_changed = true;
        self.fallback = None;
        self.rx = None;
        self.tx = None;
        self.pending_not_before = None;
        self.rx_q = EDGE_RX_RESET;
        self.verdict = None;
        self.delimiter.reset();
        self.watchdog.stop();
    }

    /// Ticks that a constant `line` lets pass with nothing but counters moving.
    pub fn quiet_for(&self, line: bool) -> Tick {
        // An edge is ticked: the search and the receiver both act on it; so is a character
        // decided and not yet delivered.
        let now = self.now;
        if self.decided.is_some()
            || self.detected.is_some()
            || self.detection.is_some()
            || self.verdict.is_some()
            || !self.tsdr_settled()
        {
            return 0;
        }
        let (sync_quiet, _) = filter::quiet_for(line, SYNC_FILTER_LEN, &self.sync_q);
        if sync_quiet == 0 {
            return 0;
        }
        let mut quiet =
            sync_quiet.min(
                self.search
                    .quiet_for(now, line, self.heard(), &self.search_q),
            );
        if self.rx.is_none() {
            return quiet;
        }
        quiet = quiet.min(self.rx_q.deadline.saturating_sub(now));
        let line_idle =
            self.heard().is_some_and(|b| self.search_q.held[b.index()]) && !self.rx_q.active();
        if self.delimiter.inside() && line_idle {
            let gap_at = self.quiet_since() + self.delimiter.gap_clocks + 1;
            quiet = quiet.min(gap_at.saturating_sub(now));
        }
        if !self.delimiter.inside() {
            quiet = quiet.min(self.watchdog.left(now).unwrap_or(Tick::MAX));
        }
        if let Some(start) = self.response_start() {
            quiet = quiet.min(start.saturating_sub(now));
        }
        if let Some(tx) = &self.tx {
            quiet = quiet.min(tx.quiet_for());
        }
        quiet
    }

    /// Let `ticks` pass that [`quiet_for`](Self::quiet_for) allowed for this `line`.
    fn skip(&mut self, ticks: Tick, line: bool) {
        filter::skip(line, ticks, &mut self.sync_q);
        self.now += ticks;
        if let Some(tx) = &mut self.tx {
            tx.skip(ticks);
        }
        if self.drive().is_some() {
            self.drove_until = Some(self.now - 1);
        }
        self.search
            .retire(self.now, line, self.heard(), &mut self.search_q);
    }

    /// Fast mode: up to `max` clocks (at least 1) with the line at `line`, skipping spans where
    /// nothing can change. Returns the clocks consumed and the outputs of the last one.
    pub fn advance(&mut self, line: bool, max: Tick) -> (Tick, TickOut) {
        let quiet = self.quiet_for(line).min(max);
        if quiet == 0 {
            (1, self.tick(line))
        } else {
            self.skip(quiet, line);
            (quiet, TickOut::default())
        }
    }
}
