//! The blocks ported so far, each with its stimuli and its Rust twin run on them.
//!
//! Contract: every case drives the dp-phy model and writes the harness's records from the same
//! calls, so the two sides see one stimulus by construction. The model runs strict: one tick a
//! clock, no fast mode.

use crate::{Block, Case, Trace};
use dp_consts::Baud;
use dp_phy::filter::{self, FilterQ, FILTER_RESET};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::UartTx;
use dp_phy::BitTiming;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The transceiver's blocks in the order the signal meets them, and whether the gateware has
/// them yet (README "Gateware").
pub const TRANSCEIVER_BLOCKS: [(&str, bool); 8] = [
    ("line_sync (synchroniser)", true),
    ("autobaud", false),
    ("edge_rx", false),
    ("delimiter", false),
    ("uart_tx (min TSDR, driver enable)", true),
    ("watchdogs", false),
    ("responder", false),
    ("top", false),
];

/// The transmitter as the transceiver builds it.
pub fn uart_tx(late_by_one: bool) -> Block {
    Block {
        top: "uart_tx",
        rtl: &["uart_tx.v"],
        signals: &["tx", "de"],
        params: if late_by_one {
            vec![("LateByOne", 1)]
        } else {
            Vec::new()
        },
        twin: "dp_phy::uart::UartTx",
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
        let timing = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
        let mut stimulus = vec![b'T'];
        // The model's inc and modulo over 10^6 (no ppm offset: both are whole multiples).
        stimulus.extend_from_slice(&((timing.inc / 1_000_000) as u32).to_le_bytes());
        stimulus.extend_from_slice(&((timing.modulo / 1_000_000) as u32).to_le_bytes());
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
            }
        })
        .collect()
}
