//! The adapter's transceiver: autobaud, receiver, delimiter, transmitter and baud watchdog.
//!
//! Contract, per clock (`tick(line)`):
//! - While **searching**, [`AutoBaud`] times pulses; a detection makes the rate a *trial*
//!   and its first character the first of a telegram. A trial becomes **locked** only when that
//!   telegram (SD1/SD2/SD3/SD4; an SC does not count) arrives complete and error-free; any error
//!   during the trial returns to searching. Noise can start a trial but never lock.
//! - While **locked**, the baud-control watchdog (ticks of 10 ms) is restarted by every good
//!   telegram; when it expires (between telegrams: a long one at 9.6k outlasts it) the
//!   transceiver searches again, so a master that changes its rate is followed.
//! - Every telegram is delivered with its status and end tick ([`TickOut::telegram`], then
//!   [`Transceiver::telegram`]); only those starting after TSYN idle bits are taken.
//! - A response handed to [`Transceiver::respond`] starts no earlier than min TSDR bit times after
//!   the line went idle (the end of the request), and no earlier than the tick it names. The
//!   driver is enabled only while it sends; the receiver ignores its own echo.
//!
//! [`Transceiver::advance`] is the fast mode: it skips spans in which nothing but counters would
//! change, with outputs identical to ticking every clock.

use crate::autobaud::{AutoBaud, AutoBaudQ, AUTOBAUD_RESET};
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
    pub search_rejects: u64,
    pub trials: u64,
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
    filter_q: FilterQ,
    filter_len: u8,
    rx_q: RxQ,
    search_q: AutoBaudQ,
    /// The line has been idle (high, no character under way) since this tick.
    quiet_since: Tick,
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
const SEARCH_FILTER_LEN: u8 = 1;

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
            search_q: AUTOBAUD_RESET,
            quiet_since: 0,
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
            filtered: self.filter_q.out,
            rx_active: self.rx_q.active,
            rx_bit: self.rx_q.bit,
            measuring: self.search_q.measuring,
            in_telegram: self.delimiter.inside(),
            driver_enable: self.drive().is_some(),
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
        let (f, fq) = filter::next(line, self.filter_len, &self.filter_q);
        self.filter_q = fq;
        let echo = self.drive().is_some();

        match self.rx {
            None => {
                let (det, sq) = self
                    .search
                    .next(now, self.idle(), f.fell, f.rose, &self.search_q);
                self.search_q = sq;
                if !f.level {
                    self.quiet_since = now + 1;
                }
                match det {
                    Some(Ok(d)) => {
                        self.start_trial(d.baud, &mut out);
                        self.quiet_since = d.end;
                        let c = RxChar {
                            byte: d.byte,
                            error: None,
                            start: d.start,
                            end: d.end,
                        };
                        // The search has checked TSYN before this character already.
                        self.on_char(&c, Tick::MAX, &mut out);
                    }
                    Some(Err(_)) => self.stats.search_rejects += 1,
                    None => {}
                }
            }
            Some(rx) => {
                let (c, rq) = rx.next(now, f.level, f.fell, f.fell || f.rose, &self.rx_q);
                if rq.active && !self.rx_q.active {
                    self.rx_idle_before = self.idle();
                }
                self.rx_q = rq;
                if let Some(c) = c {
                    self.quiet_since = c.end;
                    if !echo {
                        self.on_char(&c, self.rx_idle_before, &mut out);
                    }
                } else if !rq.active {
                    if !f.level {
                        self.quiet_since = now + 1;
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
        self.now = now + 1;
        out
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
                        }
                    }
                    self.watchdog_at = self.now + self.watchdog_clocks;
                } else {
                    self.stats.telegrams_bad += 1;
                    if let BaudState::Trial(_) = self.state {
                        self.search_again(out);
                    }
                }
            }
        }
    }

    fn start_trial(&mut self, baud: Baud, out: &mut TickOut) {
        let timing = BitTiming::new(self.cfg.clock_hz, baud, 0);
        self.stats.trials += 1;
        self.state = BaudState::Trial(baud);
        out.baud_changed = true;
        self.rx = Some(UartRx::new(timing));
        self.tx = Some(UartTx::new(timing));
        self.rx_q = RX_RESET;
        self.filter_len = filter::len_for(timing.clocks_per_bit());
        self.delimiter = Delimiter::new(
            self.search.tsyn_clocks(baud),
            timing.clocks_for(self.cfg.max_gap_bits as u64, 1),
        );
        self.watchdog_at = self.now + self.watchdog_clocks;
    }

    fn search_again(&mut self, out: &mut TickOut) {
        self.state = BaudState::Searching;
        out.baud_changed = true;
        self.rx = None;
        self.tx = None;
        self.pending_not_before = None;
        self.rx_q = RX_RESET;
        self.search_q = AUTOBAUD_RESET;
        self.filter_len = SEARCH_FILTER_LEN;
        self.delimiter.reset();
        self.watchdog_at = Tick::MAX;
    }

    /// Ticks that a constant `line` lets pass with nothing but counters moving.
    pub fn quiet_for(&self, line: bool) -> Tick {
        // While the glitch filter counts towards an edge, the blocks behind it see its old
        // output: a constant level, as on a quiet line.
        let (filter_quiet, level) = filter::quiet_for(line, self.filter_len, &self.filter_q);
        if filter_quiet == 0 {
            return 0;
        }
        let now = self.now;
        let mut quiet = match &self.rx {
            None => self.search.quiet_for(now, &self.search_q),
            Some(rx) if self.rx_q.active => rx.quiet_for_votes(level, &self.rx_q),
            Some(_) if self.delimiter.inside() && level => {
                (self.quiet_since + self.delimiter.gap_clocks + 1).saturating_sub(now)
            }
            Some(_) => Tick::MAX,
        };
        if !self.delimiter.inside() {
            quiet = quiet.min(self.watchdog_at.saturating_sub(now));
        }
        if let Some(start) = self.response_start() {
            quiet = quiet.min(start.saturating_sub(now));
        }
        if let Some(tx) = &self.tx {
            quiet = quiet.min(tx.quiet_for());
        }
        quiet.min(filter_quiet)
    }

    /// Let `ticks` pass that [`quiet_for`](Self::quiet_for) allowed for this `line`.
    fn skip(&mut self, ticks: Tick, line: bool) {
        let level = self.filter_q.out;
        filter::skip(line, ticks, &mut self.filter_q);
        if let Some(rx) = &self.rx {
            rx.skip_votes(ticks, level, self.now, &mut self.rx_q);
        }
        self.now += ticks;
        if let Some(tx) = &mut self.tx {
            tx.skip(ticks);
        }
        if !level && !self.rx_q.active {
            self.quiet_since = self.now;
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
