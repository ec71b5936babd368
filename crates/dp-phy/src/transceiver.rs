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
//! - The receiver runs behind a glitch filter of half a bit at its rate (a real pulse lasts a
//!   bit): glitches inside a telegram cost nothing. Where a glitch follows an edge within half a
//!   bit the filter drops that edge too, moving it; so each character is taken again from the
//!   line's last edges, every bit by the level it held longer (`Transceiver::retake`), which
//!   a glitch cannot turn. Its characters and
//!   its idle line are dated back by the filter's extra delay, so times are the line's.
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
use crate::filter::{self, FilterQ, FILTER_RESET};
use crate::uart::{RxChar, RxQ, UartRx, UartTx, RX_RESET};
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
}

impl Default for Config {
    fn default() -> Self {
        Config {
            clock_hz: crate::timing::DEFAULT_CLOCK_HZ,
            baud_watchdog_10ms: 20,
            max_gap_bits: 1,
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
}

/// Internal signals worth a waveform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Probe {
    pub filtered: bool,
    pub rx_active: bool,
    pub rx_bit: u8,
    pub measuring: bool,
    pub in_telegram: bool,
    pub driver_enable: bool,
    /// The lock a trial returns to if it fails.
    pub fallback: Option<Baud>,
}

/// The transceiver block.
#[derive(Clone, Debug)]
pub struct Transceiver {
    cfg: Config,
    now: Tick,
    state: BaudState,
    search: AutoBaud,
    /// Receiver, transmitter and delimiter thresholds exist once a rate is known.
    rx: Option<UartRx>,
    tx: Option<UartTx>,
    delimiter: Delimiter,
    /// The receiver's filter, its length set for the rate (runs while a rate is known).
    filter_q: FilterQ,
    filter_len: u16,
    rx_q: RxQ,
    /// The search's own filter, always [`SEARCH_FILTER_LEN`]: it must see every rate's pulses.
    search_filter_q: FilterQ,
    search_q: AutoBaudQ,
    /// The last edges of the search's line, oldest first from `line_edges_seen % EDGES_KEPT`:
    /// the receiver's characters are taken again from them, each data bit by the level the line
    /// held longer within it (`Transceiver::retake`).
    line_edges: [Tick; EDGES_KEPT],
    line_edges_seen: u64,
    /// The tick the trial under way started on: a detection of a character that began before
    /// it is of the trial's own start delimiter, at a slower rate.
    trial_since: Tick,
    /// During a trial started from a lock: that lock, to return to if the trial fails.
    fallback: Option<Baud>,
    /// The receiver's line has been idle (high, no character under way) since this tick.
    quiet_since: Tick,
    /// The last tick the transmitter drove the line: a character that started by then is the
    /// transceiver's own echo.
    drove_until: Tick,
    /// Idle clocks before the character the receiver is taking in.
    rx_idle_before: Tick,
    watchdog_at: Tick,
    watchdog_clocks: Tick,
    min_tsdr_bits: u8,
    /// A response waits for this tick (and for min TSDR of idle line).
    pending_not_before: Option<Tick>,
    response: Vec<u8>,
    stats: Stats,
}

/// The search filters only single-clock glitches: a 12 Mbit/s bit is 4 clocks at 48 MHz.
const SEARCH_FILTER_LEN: u16 = 1;

/// The changes of level from the start bit of a good character `byte` to its stop bit.
fn transitions(byte: u8) -> u32 {
    // Bits 0-10 in a word: start 0, data, parity, stop 1; a change wherever two neighbours differ.
    let parity = u16::from(crate::uart::parity_bit(byte));
    let word = u16::from(byte) << 1 | parity << 9 | 1 << 10;
    ((word ^ word >> 1) & 0x3FF).count_ones()
}

/// Edges of the line kept to take a character again: its 10 changes and glitches besides (a
/// power of two: a ring).
const EDGES_KEPT: usize = 32;

impl Transceiver {
    pub fn new(cfg: Config) -> Self {
        Transceiver {
            cfg,
            now: 0,
            state: BaudState::Searching,
            search: AutoBaud::new(cfg.clock_hz),
            rx: None,
            tx: None,
            delimiter: Delimiter::new(0, 0),
            filter_q: FILTER_RESET,
            filter_len: SEARCH_FILTER_LEN,
            rx_q: RX_RESET,
            search_filter_q: FILTER_RESET,
            search_q: AUTOBAUD_RESET,
            trial_since: 0,
            line_edges: [0; EDGES_KEPT],
            line_edges_seen: 0,
            fallback: None,
            quiet_since: 0,
            drove_until: 0,
            rx_idle_before: 0,
            watchdog_at: Tick::MAX,
            watchdog_clocks: cfg.baud_watchdog_10ms as Tick * (cfg.clock_hz as Tick / 100),
            min_tsdr_bits: MIN_TSDR_BITS,
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
            quiet_since: now,
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
            filtered: if self.rx.is_some() {
                self.filter_q.out
            } else {
                self.search_filter_q.out
            },
            rx_active: self.rx_q.active,
            rx_bit: self.rx_q.bit,
            measuring: self.search_q.measuring,
            in_telegram: self.delimiter.inside(),
            driver_enable: self.drive().is_some(),
            fallback: self.fallback,
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

    /// The receiver's filter drops every pulse shorter than half a bit, so it holds each edge
    /// back that long: its characters and its idle line are dated this many clocks earlier, as
    /// the search's filter dates them.
    fn rx_late(&self) -> Tick {
        Tick::from(self.filter_len - SEARCH_FILTER_LEN)
    }

    /// The rate the receiver is on (locked or on trial): the search's decisions at it, and its
    /// rejections, change nothing then.
    fn heard(&self) -> Option<Baud> {
        self.rx.and(self.state.baud())
    }

    fn idle(&self) -> Tick {
        self.now.saturating_sub(self.quiet_since)
    }

    /// The tick at which a waiting response may start.
    fn response_start(&self) -> Option<Tick> {
        let not_before = self.pending_not_before?;
        let tsdr = self
            .tx
            .as_ref()?
            .timing
            .clocks_for(self.min_tsdr_bits as u64, 1);
        Some(not_before.max(self.quiet_since + tsdr))
    }

    /// One clock with the line at `line`.
    #[inline]
    pub fn tick(&mut self, line: bool) -> TickOut {
        let mut out = TickOut::default();
        let now = self.now;
        let (sf, sfq) = filter::next(line, SEARCH_FILTER_LEN, &self.search_filter_q);
        self.search_filter_q = sfq;
        if sf.fell || sf.rose {
            self.keep_line_edge(now);
        }
        // The search's own early exit, here: the rate heard is worth working out on its events
        // only (the search runs on every clock).
        let det = if sf.fell || sf.rose || now >= self.search_q.deadline {
            self.search
                .clock(now, sf.fell, sf.rose, self.heard(), &mut self.search_q)
        } else {
            None
        };
        let switched = match det {
            Some(Ok(d)) => self.on_detection(&d, &mut out),
            Some(Err(_)) => {
                if self.rx.is_none() {
                    self.stats.search_rejects += 1;
                }
                false
            }
            None => false,
        };

        if let (Some(rx), false) = (&self.rx, switched) {
            let (f, fq) = filter::next(line, self.filter_len, &self.filter_q);
            let (c, rq) = rx.next(now, f.level, f.fell, &self.rx_q);
            self.filter_q = fq;
            let late = self.rx_late();
            if rq.active && !self.rx_q.active {
                self.rx_idle_before = self.idle().saturating_sub(late);
            }
            self.rx_q = rq;
            if let Some(c) = c {
                let c = self.retake(&RxChar {
                    start: c.start.saturating_sub(late),
                    end: c.end.saturating_sub(late),
                    ..c
                });
                self.quiet_since = c.end;
                if c.start > self.drove_until {
                    self.on_char(&c, self.rx_idle_before, &mut out);
                }
            } else if !rq.active {
                if !f.level {
                    self.quiet_since = (now + 1).saturating_sub(late);
                }
                let d = self.delimiter.on_idle(self.idle(), now);
                self.on_delivery(d, &mut out);
            }
            // A telegram under way is evidence of the rate: a long one at 9.6k outlasts
            // the watchdog, so it expires only between telegrams.
            if now >= self.watchdog_at && !self.delimiter.inside() {
                self.stats.watchdog_expiries += 1;
                self.search_again(&mut out);
            }
        }

        if let Some(start) = self.response_start() {
            if now >= start {
                if let Some(tx) = &mut self.tx {
                    tx.send(0, &self.response, &[]);
                }
                self.pending_not_before = None;
            }
        }
        if let Some(tx) = &mut self.tx {
            tx.tick();
        }
        if self.drive().is_some() {
            self.drove_until = now;
        }
        self.now = now + 1;
        out
    }

    /// A start delimiter the search decoded: a trial at its rate, unless the receiver is on
    /// that rate already. Returns whether the receiver was replaced.
    fn on_detection(&mut self, d: &Detection, out: &mut TickOut) -> bool {
        match self.state {
            BaudState::Trial(b) | BaudState::Locked(b) if b == d.baud => return false,
            BaudState::Trial(_) if d.start <= self.trial_since => return false,
            BaudState::Searching => self.fallback = None,
            BaudState::Locked(b) => self.fallback = Some(b),
            // A trial from a lock keeps that lock as its fallback.
            BaudState::Trial(_) => {}
        }
        self.start_trial(d.baud, out);
        self.quiet_since = d.end;
        let c = RxChar {
            byte: d.byte,
            error: None,
            start: d.start,
            end: d.end,
        };
        // The search has checked TSYN before this character already.
        self.on_char(&c, Tick::MAX, out);
        true
    }

    fn keep_line_edge(&mut self, at: Tick) {
        self.line_edges[(self.line_edges_seen & (EDGES_KEPT as u64 - 1)) as usize] = at;
        self.line_edges_seen += 1;
    }

    /// The receiver's character `c` with its start, data and parity bits taken again from the
    /// line's edges, each by the level the line held longer within it: a glitch shorter than
    /// half a bit cannot turn a bit so, even where it moved an edge (the receiver's half-bit
    /// filter drops an edge that a glitch follows within half a bit, so its samples can land on
    /// the wrong side of a bit boundary). A bit that held both levels equally long, or a start
    /// bit taken high, is `Noise`; so is a character older than the edges kept. Break, framing
    /// (its stop bit) and a start after a false start stay the receiver's.
    fn retake(&self, c: &RxChar) -> RxChar {
        use crate::uart::CharError;
        if matches!(c.error, Some(CharError::Break | CharError::Framing)) {
            return *c;
        }
        let Some(timing) = self.rx.map(|rx| rx.timing) else {
            return *c;
        };
        let noise = RxChar {
            error: Some(CharError::Noise),
            ..*c
        };
        let kept = self.line_edges_seen.min(EDGES_KEPT as u64);
        let mask = EDGES_KEPT as u64 - 1;
        let oldest = self.line_edges_seen - kept;
        let edge = |i: u64| self.line_edges[((oldest + i) & mask) as usize];
        // The edges after the start (found from the newest back: a character is recent); the
        // level at the start from their number.
        let mut first = kept;
        while first > 0 && edge(first - 1) > c.start {
            first -= 1;
        }
        if first == 0 && self.line_edges_seen > kept {
            return noise;
        }
        // A good character whose line changed exactly where its bits change had no glitch:
        // the receiver's samples are its levels (most characters, so worth the shortcut).
        if c.error.is_none() && kept - first == u64::from(transitions(c.byte)) {
            return *c;
        }
        let (m, inc) = (timing.modulo, timing.inc);
        let level = self.search_filter_q.out ^ ((kept - first) % 2 == 1);
        // The edges inside bits 0-9, in phase units from the start: bit k is [k, k + 1) x m.
        let mut rel = [0u64; EDGES_KEPT];
        let mut n = 0;
        for i in first..kept {
            let e = (edge(i) - c.start) * inc;
            if e >= 10 * m {
                break;
            }
            rel[n] = e;
            n += 1;
        }
        let Some(bits) = crate::uart::bits_by_longer_level(&rel[..n], level, m, 10) else {
            return noise;
        };
        let byte = (bits >> 1) as u8;
        let error = if bits & 1 != 0 {
            Some(CharError::Noise)
        } else if (bits >> 9 & 1 == 1) != crate::uart::parity_bit(byte) {
            Some(CharError::Parity)
        } else if c.error == Some(CharError::Noise) {
            c.error
        } else {
            None
        };
        RxChar { byte, error, ..*c }
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
                if t.is_good() {
                    self.stats.telegrams_good += 1;
                    let confirms = t.bytes()[0] != SC;
                    if let BaudState::Trial(b) = self.state {
                        if confirms {
                            self.state = BaudState::Locked(b);
                            out.baud_changed = true;
                            if self.fallback.take().is_some() {
                                self.stats.relocks += 1;
                            }
                        }
                    }
                    self.watchdog_at = self.now + self.watchdog_clocks;
                } else {
                    self.stats.telegrams_bad += 1;
                    if let BaudState::Trial(_) = self.state {
                        match self.fallback.take() {
                            Some(locked) => {
                                self.stats.relock_trials_failed += 1;
                                self.use_rate(locked);
                                self.state = BaudState::Locked(locked);
                                out.baud_changed = true;
                            }
                            None => self.search_again(out),
                        }
                    }
                }
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
        self.filter_q = self.search_filter_q;
        self.use_rate(baud);
        if self.fallback.is_none() {
            self.watchdog_at = self.now + self.watchdog_clocks;
        }
    }

    /// Receiver, transmitter and delimiter for `baud`, from idle; a waiting response is dropped.
    fn use_rate(&mut self, baud: Baud) {
        let timing = BitTiming::new(self.cfg.clock_hz, baud, 0);
        self.rx = Some(UartRx::new(timing));
        self.tx = Some(UartTx::new(timing));
        self.pending_not_before = None;
        self.rx_q = RX_RESET;
        self.filter_len = filter::glitch_len_for(timing.clocks_per_bit());
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
        self.rx_q = RX_RESET;
        self.filter_len = SEARCH_FILTER_LEN;
        self.delimiter.reset();
        self.watchdog_at = Tick::MAX;
    }

    /// Ticks that a constant `line` lets pass with nothing but counters moving.
    pub fn quiet_for(&self, line: bool) -> Tick {
        // While a filter counts towards an edge, the blocks behind it see its old output: a
        // constant level, as on a quiet line.
        let now = self.now;
        let (mut search_quiet, _) =
            filter::quiet_for(line, SEARCH_FILTER_LEN, &self.search_filter_q);
        if search_quiet == 0 {
            return 0;
        }
        if self.search_flip_is_idle_only(line) {
            search_quiet = Tick::MAX;
        }
        let mut quiet =
            search_quiet.min(
                self.search
                    .quiet_for(now, line, self.heard(), &self.search_q),
            );
        let Some(rx) = &self.rx else {
            return quiet;
        };
        let (filter_quiet, level) = filter::quiet_for(line, self.filter_len, &self.filter_q);
        if filter_quiet == 0 {
            return 0;
        }
        quiet = quiet.min(filter_quiet);
        quiet = quiet.min(if self.rx_q.active {
            rx.quiet_for_votes(level, &self.rx_q)
        } else if self.delimiter.inside() && level {
            (self.quiet_since + self.delimiter.gap_clocks + 1).saturating_sub(now)
        } else {
            Tick::MAX
        });
        if !self.delimiter.inside() {
            quiet = quiet.min(self.watchdog_at.saturating_sub(now));
        }
        if let Some(start) = self.response_start() {
            quiet = quiet.min(start.saturating_sub(now));
        }
        if let Some(tx) = &self.tx {
            quiet = quiet.min(tx.quiet_for());
        }
        quiet
    }

    /// Whether the search filter's coming change of output, towards `line`, shows nothing at
    /// once: with a rate known, any. The search decides only when a measurement's time is up,
    /// never on an edge; a measurement a fall starts there decides after the skip, or, the line
    /// staying low, can only be rejected (`AutoBaud::quiet_for`). Fast mode then passes the edge
    /// to the search and goes on, instead of stopping twice on every edge of the locked rate.
    fn search_flip_is_idle_only(&self, line: bool) -> bool {
        let q = &self.search_filter_q;
        self.rx.is_some() && q.sync == line && q.out != line
    }

    /// Let `ticks` pass that [`quiet_for`](Self::quiet_for) allowed for this `line`.
    fn skip(&mut self, ticks: Tick, line: bool) {
        let search_flip =
            filter::skip_through(line, SEARCH_FILTER_LEN, ticks, &mut self.search_filter_q);
        let level = self.filter_q.out;
        if let Some(rx) = &self.rx {
            filter::skip(line, ticks, &mut self.filter_q);
            rx.skip_votes(ticks, level, self.now, &mut self.rx_q);
        }
        self.now += ticks;
        if let Some(tx) = &mut self.tx {
            tx.skip(ticks);
        }
        if self.drive().is_some() {
            self.drove_until = self.now - 1;
        }
        if let Some(at) = search_flip {
            let at = self.now - ticks + at;
            self.keep_line_edge(at);
            self.search.pass_edge(at, line, &mut self.search_q);
        }
        self.search
            .retire(self.now, line, self.heard(), &mut self.search_q);
        if self.rx.is_some() && !level && !self.rx_q.active {
            self.quiet_since = self.now.saturating_sub(self.rx_late());
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortcut that keeps a clean character counts the changes of its 11 levels.
    #[test]
    fn transitions_count_the_changes_of_a_characters_levels() {
        for byte in 0..=u8::MAX {
            let bits = crate::uart::char_bits(byte);
            let changes = bits.windows(2).filter(|w| w[0] != w[1]).count() as u32;
            assert_eq!(transitions(byte), changes, "{byte:02x}");
        }
    }
}
