//! The character reader (`gateware/rtl/char_reader.v`) against `dp_phy::char_reader`: at every
//! rate, characters from stations off the reader's clock, with glitches of up to half a bit,
//! random edges (a faster rate's characters, noise), and starts that cut a character short.

use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::char_reader::{CharReader, CharReaderQ, CHAR_READER_RESET};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::char_bits;
use dp_phy::BitTiming;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The reader with phase registers of `width` bits: the widest rate's ([`run_time_width`]) as
/// the receiver builds it for a rate chosen at run time, or one rate's own ([`width_of`]) as a
/// search channel builds it for its constant rate.
pub fn char_reader(width: u32) -> Block {
    Block {
        top: "char_reader",
        rtl: &["char_reader.v", "char_reader_step.v"],
        signals: &[
            "bit0",
            "bit1",
            "bit2",
            "bit3",
            "tie",
            "glitches0",
            "glitches1",
            "pair_open",
        ],
        params: vec![("PhaseWidth", i64::from(width))],
        twin: "dp_phy::char_reader::CharReader",
        events: true,
    }
}

/// Bits that hold `baud`'s reduced modulo, the receiver's timing (whole clocks).
pub fn width_of(baud: Baud) -> u32 {
    let modulo = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud)
        .reduced()
        .modulo;
    u64::BITS - modulo.leading_zeros()
}

/// Bits that hold every rate's reduced modulo (9.6 kbit/s: 5,000 clocks, 13 bits).
pub fn run_time_width() -> u32 {
    Baud::ALL.iter().map(|&b| width_of(b)).max().expect("rates")
}

/// The stimulus and the model, written together.
struct ReaderCase {
    reader: CharReader,
    q: CharReaderQ,
    line: bool,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    clock: u32,
}

impl ReaderCase {
    fn new(baud: Baud) -> ReaderCase {
        let reader = CharReader::new(BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, baud));
        let mut stimulus = vec![b'T'];
        for figure in [
            reader.inc,
            reader.modulo,
            reader.quarter,
            reader.three_quarters,
            reader.half_less_inc,
            reader.two_inc,
            reader.modulo_less_inc,
            reader.modulo_less_two_inc,
        ] {
            stimulus.extend_from_slice(&(figure as u32).to_le_bytes());
        }
        ReaderCase {
            reader,
            q: CHAR_READER_RESET,
            line: true,
            stimulus,
            trace: Trace::default(),
            events: Vec::new(),
            clock: 0,
        }
    }

    /// What the harness records after a clock; `edge`: the line changed on it.
    fn record(&mut self, bit_before: u8, edge: bool) {
        let q = &self.q;
        self.trace
            .push(q.bit | u8::from(q.tie) << 4 | q.glitches << 5 | u8::from(q.pair_open) << 7);
        if edge || q.bit != bit_before {
            let mut payload = q.shift.to_le_bytes().to_vec();
            payload.extend_from_slice(&(q.rem as u32).to_le_bytes());
            payload.extend_from_slice(&(q.lead as i32).to_le_bytes());
            payload.extend_from_slice(&(q.lag as i32).to_le_bytes());
            payload.extend_from_slice(&(q.pair_left as u32).to_le_bytes());
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
        }
        self.clock += 1;
    }

    /// A start edge: one clock with the line falling.
    fn start(&mut self) {
        self.stimulus.push(b'S');
        let before = self.q.bit;
        self.reader.start(&mut self.q);
        self.line = false;
        self.record(before, true);
    }

    /// `n` clocks with the line at `level`.
    fn hold(&mut self, level: bool, n: u32) {
        if n == 0 {
            return;
        }
        self.stimulus.push(b'L');
        self.stimulus.push(u8::from(level));
        self.stimulus.extend_from_slice(&n.to_le_bytes());
        for k in 0..n {
            let edge = k == 0 && level != self.line;
            let before = self.q.bit;
            self.reader.clock(&mut self.q, level, edge);
            self.line = level;
            self.record(before, edge);
        }
    }

    /// The line after a start, toggling at `toggles` (clocks after the start, ascending),
    /// then high for `tail` clocks.
    fn character(&mut self, toggles: &[u64], tail: u32) {
        self.start();
        let mut at = 0;
        let mut level = false;
        for &t in toggles {
            self.hold(level, (t - at - 1) as u32);
            level = !level;
            self.hold(level, 1);
            at = t;
        }
        self.hold(level, tail);
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

/// The toggles of `byte` sent by a station `ppm` off, glitches of up to half a bit added
/// (two toggles on one clock are none).
fn toggles(rng: &mut ChaCha8Rng, baud: Baud, byte: u8, ppm: i32, glitches: usize) -> Vec<u64> {
    let sender = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
    let bit = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_per_bit();
    let bits = char_bits(byte);
    let mut all: Vec<u64> = (1..11)
        .filter(|&k| bits[k] != bits[k - 1])
        .map(|k| sender.clocks_for(k as u64, 1))
        .collect();
    for _ in 0..glitches {
        let at = rng.gen_range(1..11 * bit);
        all.extend([at, at + rng.gen_range(1..=bit / 2 + 1)]);
    }
    all.sort_unstable();
    let mut out: Vec<u64> = Vec::new();
    for e in all {
        if out.last() == Some(&e) {
            out.pop();
        } else {
            out.push(e);
        }
    }
    out
}

/// At each of `rates`: clean characters, characters with one to three glitches, random edges,
/// and a start that cuts the character before short; `width` names the cases.
pub fn char_reader_cases(rates: &[Baud], width: u32, quick: bool) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(11 + u64::from(width));
    let chars = if quick { 12 } else { 60 };
    let mut cases = Vec::new();
    for &baud in rates {
        let bit = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_per_bit();
        let mut case = ReaderCase::new(baud);
        case.hold(true, 7);
        for n in 0..chars {
            let byte: u8 = rng.gen();
            let ppm = rng.gen_range(-3000..3000);
            let line = match n % 4 {
                0 => toggles(&mut rng, baud, byte, ppm, 0),
                1 | 2 => {
                    let glitches = rng.gen_range(1..4);
                    toggles(&mut rng, baud, byte, ppm, glitches)
                }
                _ => {
                    let mut random: Vec<u64> = (0..rng.gen_range(1..30))
                        .map(|_| rng.gen_range(1..12 * bit))
                        .collect();
                    random.sort_unstable();
                    random.dedup();
                    random
                }
            };
            // A start in the middle of the character now and then: the reader starts over.
            let cut = if rng.gen_bool(0.15) {
                rng.gen_range(1..11 * bit)
            } else {
                u64::MAX
            };
            let kept: Vec<u64> = line.into_iter().filter(|&t| t < cut).collect();
            let level_after = kept.len() % 2 == 1;
            let tail = if cut == u64::MAX {
                rng.gen_range(1..3 * bit) as u32
            } else {
                (cut - kept.last().copied().unwrap_or(0) - 1) as u32
            };
            case.character(&kept, tail);
            if !level_after && cut == u64::MAX {
                // The line must be high before the next start's fall.
                case.hold(true, rng.gen_range(1..bit) as u32);
            }
        }
        cases.push(case.finish(format!("char_reader-w{width}-{baud}")));
    }
    cases
}
