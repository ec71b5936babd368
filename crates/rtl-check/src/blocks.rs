//! The blocks ported so far, each with its stimuli and its Rust twin run on them.
//!
//! Contract: every case drives the dp-phy model and writes the harness's records from the same
//! calls, so the two sides see one stimulus by construction. The model runs strict: one tick a
//! clock, no fast mode.

pub mod autobaud;
mod char_reader;
mod edge_rx;
mod rate_idle;
mod transceiver;
mod watchdog;
pub use autobaud::{autobaud, autobaud_cases};
pub use char_reader::{char_reader, char_reader_cases, run_time_width, width_of};
pub use edge_rx::{edge_rx, edge_rx_cases};
pub use rate_idle::{rate_idle, rate_idle_cases};
pub use transceiver::{
    bench_case, near_wrap_cases, rates_svh, transceiver, transceiver_cases, transceiver_near_wrap,
};
pub use watchdog::{baud_watchdog_width, dp_watchdog_width, watchdog, watchdog_cases};

use crate::{Block, Case, Trace};
use dp_consts::Baud;
use dp_phy::delimiter::{Delimiter, Delivery, Status};
use dp_phy::filter::{self, FilterQ, FILTER_RESET};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::{CharError, RxChar, UartTx};
use dp_phy::BitTiming;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bits that hold `n` (a counter of `n` clocks; one saturating at all ones is past `n`).
fn bits_for(n: u64) -> u32 {
    u64::BITS - n.leading_zeros()
}

/// Clocks from tick `now` to the first tick at or after it with `t % period == phase`: a
/// rate's next sample on the search's schedule.
fn clocks_to_sample(now: u64, period: u64, phase: u64) -> u64 {
    (phase + period - now % period) % period
}

/// The transceiver's blocks in the order the signal meets them, and whether the gateware has
/// them yet (README "Gateware").
pub const TRANSCEIVER_BLOCKS: [(&str, bool); 11] = [
    ("line_sync (synchroniser)", true),
    ("autobaud", true),
    ("edge_rx", true),
    ("rate_idle (the receiver's idle line)", true),
    ("delimiter", true),
    ("uart_tx (min TSDR, driver enable)", true),
    ("watchdogs (baud, DP)", true),
    ("top: receive path (transceiver.v)", true),
    ("top: transmitter (min TSDR, echo)", true),
    ("pins", false),
    ("responder", false),
];

/// The transmitter as the transceiver builds it.
pub fn uart_tx(late_by_one: bool) -> Block {
    Block {
        top: "uart_tx",
        rtl: &["uart_tx.v"],
        signals: &["tx", "de"],
        params: {
            let width = ("PhaseWidth", i64::from(run_time_width()));
            if late_by_one {
                vec![("LateByOne", 1), width]
            } else {
                vec![width]
            }
        },
        twin: "dp_phy::uart::UartTx",
        events: false,
    }
}

/// The synchroniser with `filter_len` (the transceiver's is 0).
pub fn line_sync(filter_len: u16) -> Block {
    Block {
        top: "line_sync",
        rtl: &["line_sync.v"],
        signals: &["level", "fell", "rose"],
        params: vec![("FilterLen", i64::from(filter_len))],
        twin: "dp_phy::filter",
        events: false,
    }
}

/// The transmitter's stimulus and its model, written together.
struct TxCase {
    model: UartTx,
    stimulus: Vec<u8>,
    trace: Trace,
}

impl TxCase {
    fn new(baud: Baud) -> TxCase {
        // The adapter's timing: a bit of whole clocks.
        let timing = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud);
        let mut stimulus = vec![b'T'];
        stimulus.extend_from_slice(&(timing.inc as u32).to_le_bytes());
        stimulus.extend_from_slice(&(timing.modulo as u32).to_le_bytes());
        TxCase {
            model: UartTx::new(timing),
            stimulus,
            trace: Trace::default(),
        }
    }

    fn record(&mut self) {
        let value = match self.model.drive() {
            Some(level) => u8::from(level) | 2,
            None => 1,
        };
        self.trace.push(value);
    }

    /// Clocks with nothing started.
    fn run(&mut self, clocks: u32) {
        self.stimulus.push(b'R');
        self.stimulus.extend_from_slice(&clocks.to_le_bytes());
        for _ in 0..clocks {
            self.model.tick();
            self.record();
        }
    }

    /// The bytes into the buffer, a clock for the block RAM's read, then the start (the
    /// transceiver's send and tick of one clock), then clocks until the model is idle again
    /// and `after` more.
    fn send(&mut self, bytes: &[u8], after: u32) {
        for (addr, byte) in bytes.iter().enumerate() {
            self.stimulus.extend_from_slice(&[b'W', addr as u8, *byte]);
        }
        self.run(1);
        self.stimulus.extend_from_slice(&[b'S', bytes.len() as u8]);
        self.model.send(0, bytes, &[]);
        self.model.tick();
        self.record();
        let mut clocks = 0u32;
        while self.model.busy() {
            self.model.tick();
            self.record();
            clocks += 1;
        }
        self.stimulus.push(b'R');
        self.stimulus.extend_from_slice(&clocks.to_le_bytes());
        self.run(after);
    }

    fn finish(self, name: String) -> Case {
        Case {
            name,
            stimulus: self.stimulus,
            model: self.trace,
            model_events: Vec::new(),
        }
    }
}

/// Telegrams as the responder sends them: SC, an SD1, SD2s of several lengths and patterns,
/// one of the longest (255 characters); seeded random bytes.
fn telegrams(quick: bool, rng: &mut ChaCha8Rng) -> Vec<Vec<u8>> {
    let mut list = vec![vec![0xE5], vec![0x10, 0x02, 0x01, 0x49, 0x4C, 0x16]];
    let lengths: &[usize] = if quick { &[21] } else { &[1, 21, 64, 255] };
    for &len in lengths {
        for pattern in 0..3 {
            let bytes: Vec<u8> = (0..len)
                .map(|i| match pattern {
                    0 => [0x00, 0xFF][i % 2],
                    1 => 0x55,
                    _ => rng.gen(),
                })
                .collect();
            list.push(bytes);
        }
    }
    list
}

/// The transmitter's cases: at every rate, each telegram after some idle clocks, one right
/// after another (no clock between), and an empty start (nothing goes out).
pub fn uart_tx_cases(quick: bool) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let mut cases = Vec::new();
    for baud in Baud::ALL {
        let mut case = TxCase::new(baud);
        case.run(5);
        for bytes in telegrams(quick, &mut rng) {
            let gap = rng.gen_range(0..7);
            case.send(&bytes, gap);
        }
        case.send(&[], 3);
        cases.push(case.finish(format!("uart_tx-{baud}")));
    }
    cases
}

/// The synchroniser's cases: runs of either level from 1 to 40 clocks (glitches, short and
/// long pulses), seeded.
pub fn line_sync_cases(filter_len: u16, quick: bool) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(filter_len) + 1);
    let count = if quick { 2 } else { 10 };
    (0..count)
        .map(|n| {
            let mut q: FilterQ = FILTER_RESET;
            let mut stimulus = Vec::new();
            let mut trace = Trace::default();
            let mut level = true;
            for _ in 0..2_000 {
                level = !level;
                let clocks: u32 = if rng.gen_bool(0.1) {
                    rng.gen_range(41..200)
                } else {
                    rng.gen_range(1..=40)
                };
                stimulus.push(b'L');
                stimulus.push(u8::from(level));
                stimulus.extend_from_slice(&clocks.to_le_bytes());
                for _ in 0..clocks {
                    let (out, d) = filter::next(level, filter_len, &q);
                    q = d;
                    trace.push(
                        u8::from(out.level) | u8::from(out.fell) << 1 | u8::from(out.rose) << 2,
                    );
                }
            }
            Case {
                name: format!("line_sync-len{filter_len}-{n}"),
                stimulus,
                model: trace,
                model_events: Vec::new(),
            }
        })
        .collect()
}

/// The delimiter.
pub fn delimiter() -> Block {
    Block {
        top: "delimiter",
        rtl: &["delimiter.v"],
        signals: &[
            "deliver",
            "not_synced",
            "status0",
            "status1",
            "status2",
            "status3",
        ],
        params: Vec::new(),
        twin: "dp_phy::delimiter::Delimiter",
        events: true,
    }
}

/// The delimiter's status codes, as `delimiter.v` puts them out.
fn status_code(status: Status) -> u8 {
    match status {
        Status::Good => 0,
        Status::Char(e) => char_error_code(Some(e)),
        Status::Gap => 5,
        Status::BadDelimiter => 6,
        Status::LengthMismatch => 7,
        Status::BadLength => 8,
        Status::BadFcs => 9,
        Status::NoEndDelimiter => 10,
        other => panic!("a status delimiter.v does not have: {other:?}"),
    }
}

/// A character's error as delimiter.v (and edge_rx.v) code it.
fn char_error_code(error: Option<CharError>) -> u8 {
    match error {
        None => 0,
        Some(CharError::Parity) => 1,
        Some(CharError::Framing) => 2,
        Some(CharError::Break) => 3,
        Some(CharError::Noise) => 4,
        Some(other) => panic!("a character error delimiter.v does not have: {other:?}"),
    }
}

/// The delimiter's stimulus and its model, written together. Idle counts are kept below
/// 2^24 (the RTL's saturating inputs), times below 2^32.
struct DelimiterCase {
    model: Delimiter,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<crate::Event>,
    clock: u32,
    /// The tick (one a clock, from 1 so that no character ends at 0).
    now: u64,
    /// When the last character ended.
    last_end: u64,
}

impl DelimiterCase {
    fn new() -> DelimiterCase {
        DelimiterCase {
            model: Delimiter::new(0, 0),
            stimulus: Vec::new(),
            trace: Trace::default(),
            events: Vec::new(),
            clock: 0,
            now: 1,
            last_end: 0,
        }
    }

    /// One clock's outcome: what the model's calls returned.
    fn record(&mut self, delivered: bool, not_synced: bool) {
        let mut value = u8::from(delivered) | u8::from(not_synced) << 1;
        if delivered {
            let t = self.model.telegram();
            let code = status_code(t.status);
            value |= code << 2;
            let mut payload = vec![code, t.bytes().len() as u8];
            payload.extend_from_slice(&(t.end as u32).to_le_bytes());
            payload.extend_from_slice(t.bytes());
            self.events.push(crate::Event {
                clock: self.clock,
                payload,
            });
        }
        self.trace.push(value);
        self.clock += 1;
        self.now += 1;
    }

    fn config(&mut self, tsyn: u32, gap: u32) {
        self.stimulus.push(b'C');
        self.stimulus.extend_from_slice(&tsyn.to_le_bytes());
        self.stimulus.extend_from_slice(&gap.to_le_bytes());
        self.model = Delimiter::new(u64::from(tsyn), u64::from(gap));
        self.record(false, false);
    }

    fn reset(&mut self) {
        self.stimulus.push(b'Z');
        self.model.reset();
        self.record(false, false);
    }

    /// A character ending on this clock after `idle_before` idle clocks, and where
    /// `idle_check`, the idle check of the same clock (the line idle for 0 clocks).
    fn char(&mut self, byte: u8, error: Option<CharError>, idle_before: u64, idle_check: bool) {
        let idle_before = idle_before.min(0xFF_FFFF);
        self.stimulus
            .extend_from_slice(&[b'K', u8::from(idle_check) << 1 | 1, byte]);
        self.stimulus.push(char_error_code(error));
        self.stimulus
            .extend_from_slice(&(idle_before as u32).to_le_bytes());
        self.stimulus
            .extend_from_slice(&(self.now as u32).to_le_bytes());
        self.stimulus.extend_from_slice(&0u32.to_le_bytes());
        self.stimulus
            .extend_from_slice(&(self.now as u32).to_le_bytes());
        let c = RxChar {
            byte,
            error,
            start: self.now.saturating_sub(1),
            end: self.now,
        };
        let on_char = self.model.on_char(&c, idle_before);
        let on_idle = if idle_check {
            self.model.on_idle(0, self.now)
        } else {
            Delivery::None
        };
        self.last_end = self.now;
        self.record(
            on_char == Delivery::Telegram || on_idle == Delivery::Telegram,
            on_char == Delivery::NotSynced,
        );
    }

    /// `n` clocks of the line idle since the last character, checked each clock.
    fn idle(&mut self, n: u32) {
        let idle = (self.now - self.last_end).min(0xFF_FFFF - u64::from(n));
        self.stimulus.push(b'I');
        self.stimulus.extend_from_slice(&n.to_le_bytes());
        self.stimulus
            .extend_from_slice(&(idle as u32).to_le_bytes());
        self.stimulus
            .extend_from_slice(&(self.now as u32).to_le_bytes());
        for i in 0..u64::from(n) {
            let d = self.model.on_idle(idle + i, self.now);
            self.record(d == Delivery::Telegram, false);
        }
    }

    /// `n` clocks inside a character: no strobe, no idle check.
    fn busy(&mut self, n: u32) {
        self.stimulus.push(b'N');
        self.stimulus.extend_from_slice(&n.to_le_bytes());
        for _ in 0..n {
            self.record(false, false);
        }
    }

    /// `bytes` as characters `char_clocks` apart, the first after `idle_before` idle clocks.
    fn telegram(&mut self, bytes: &[u8], idle_before: u64, char_clocks: u32) {
        for (i, byte) in bytes.iter().enumerate() {
            self.busy(char_clocks - 1);
            self.char(*byte, None, if i == 0 { idle_before } else { 0 }, true);
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

/// A good SD2 telegram with `data` (DA, SA, FC first).
fn sd2(data: &[u8]) -> Vec<u8> {
    let le = data.len() as u8;
    let mut t = vec![0x68, le, le, 0x68];
    t.extend_from_slice(data);
    t.push(data.iter().fold(0u8, |a, b| a.wrapping_add(*b)));
    t.push(0x16);
    t
}

/// The delimiter's cases: PROTOCOL.md's telegrams good, each way a telegram goes wrong, and a
/// seeded run of good, corrupted and random telegrams with gaps, errors, resets and
/// characters without TSYN.
pub fn delimiter_cases(quick: bool) -> Vec<Case> {
    // shared/PROTOCOL.md vectors.
    let get_cfg_response = [
        0x68, 0x08, 0x08, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3B, 0x00, 0x10, 0x10, 0xAA, 0x16,
    ];
    let sd3 = [
        0xA2, 0x08, 0x02, 0x4D, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x73, 0x16,
    ];
    let sd1 = [0x10, 0x08, 0x02, 0x49, 0x53, 0x16];
    // (TSYN, gap, clocks a character) at 12M and at 9.6k, 48 MHz.
    let rates: [(u32, u32, u32); 2] = [(132, 4, 44), (165_000, 5_000, 55_000)];
    let mut cases = Vec::new();
    for &(tsyn, gap, char_clocks) in &rates {
        let mut c = DelimiterCase::new();
        c.config(tsyn, gap);
        c.idle(tsyn + 3);
        let long = sd2(&(0..249).map(|i| i as u8).collect::<Vec<_>>());
        for t in [
            &get_cfg_response[..],
            &sd3,
            &sd1,
            &[0xDC, 0x02, 0x01],
            &[0xE5],
            &long,
        ] {
            c.telegram(t, u64::from(tsyn) + 1, char_clocks);
            c.idle(tsyn + 5);
        }
        // Each way wrong: bad FCS, bad ED, LEr, LE too short and too long, no second SD2, not
        // a delimiter, a character error first and inside, a gap inside (by the idle check and
        // by a character after it), no TSYN, TSYN one clock short, a reset inside.
        let mut bad_fcs = get_cfg_response;
        bad_fcs[12] ^= 1;
        let mut bad_ed = sd1;
        bad_ed[5] = 0x17;
        let mut both = sd1;
        both[4] ^= 1;
        both[5] = 0x17;
        let wrong: [&[u8]; 9] = [
            &bad_fcs,
            &bad_ed,
            &both,
            &[0x68, 0x08, 0x09],
            &[0x68, 0x03],
            &[0x68, 0xFA],
            &[0x68, 0x08, 0x08, 0x69],
            &[0x42],
            &[0x10, 0x08],
        ];
        for t in wrong {
            c.telegram(t, u64::from(tsyn), char_clocks);
            c.idle(tsyn + gap + 5);
        }
        for error in [
            CharError::Parity,
            CharError::Framing,
            CharError::Break,
            CharError::Noise,
        ] {
            c.busy(char_clocks - 1);
            c.char(0x10, Some(error), u64::from(tsyn), true);
            c.idle(tsyn + 1);
            c.telegram(&[0x10, 0x08], u64::from(tsyn), char_clocks);
            c.busy(char_clocks - 1);
            c.char(0x02, Some(error), 0, true);
            c.idle(tsyn + 1);
        }
        c.telegram(&[0x10, 0x08, 0x02], u64::from(tsyn), char_clocks);
        c.idle(gap + 2);
        c.idle(tsyn);
        c.telegram(&[0x10, 0x08, 0x02], u64::from(tsyn), char_clocks);
        c.char(0x49, None, u64::from(gap) + 1, false);
        c.idle(tsyn);
        c.telegram(&sd1, u64::from(tsyn) - 1, char_clocks);
        c.telegram(&sd1, u64::from(tsyn) / 2, char_clocks);
        c.idle(tsyn);
        c.telegram(&sd1[..3], u64::from(tsyn), char_clocks);
        c.reset();
        c.telegram(&sd1[3..], 0, char_clocks);
        c.idle(tsyn);
        cases.push(c.finish(format!("delimiter-tsyn{tsyn}")));
    }
    // Seeded: good and corrupted telegrams, random bytes, errors, gaps, resets.
    let mut rng = ChaCha8Rng::seed_from_u64(30);
    let runs = if quick { 1 } else { 8 };
    for run in 0..runs {
        let (tsyn, gap, char_clocks) = (132u32, 4u32, 44u32);
        let mut c = DelimiterCase::new();
        c.config(tsyn, gap);
        for _ in 0..400 {
            let mut t = match rng.gen_range(0..4) {
                0 => sd2(&(0..rng.gen_range(3..40))
                    .map(|_| rng.gen())
                    .collect::<Vec<u8>>()),
                1 => {
                    let mut t: Vec<u8> = vec![0x10, rng.gen(), rng.gen(), rng.gen()];
                    t.push(t[1].wrapping_add(t[2]).wrapping_add(t[3]));
                    t.push(0x16);
                    t
                }
                2 => [0xE5, 0xDC, 0xA2, 0x68, 0x10][rng.gen_range(0..5)..].to_vec(),
                _ => (0..rng.gen_range(1..20)).map(|_| rng.gen()).collect(),
            };
            if rng.gen_bool(0.3) && !t.is_empty() {
                let i = rng.gen_range(0..t.len());
                t[i] ^= 1 << rng.gen_range(0..8);
            }
            let idle = if rng.gen_bool(0.8) {
                tsyn
            } else {
                rng.gen_range(0..tsyn)
            };
            for (i, byte) in t.iter().enumerate() {
                c.busy(char_clocks - 1);
                let error = if rng.gen_bool(0.02) {
                    Some(
                        [CharError::Parity, CharError::Framing, CharError::Noise]
                            [rng.gen_range(0..3)],
                    )
                } else {
                    None
                };
                let idle_before = match i {
                    0 => u64::from(idle),
                    _ if rng.gen_bool(0.02) => u64::from(gap) + 1,
                    _ => 0,
                };
                c.char(*byte, error, idle_before, rng.gen_bool(0.9));
                if rng.gen_bool(0.02) {
                    c.idle(rng.gen_range(1..2 * gap));
                }
                if rng.gen_bool(0.005) {
                    c.reset();
                }
            }
            c.idle(rng.gen_range(1..2 * tsyn));
        }
        cases.push(c.finish(format!("delimiter-seeded-{run}")));
    }
    cases
}
