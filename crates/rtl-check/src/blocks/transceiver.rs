//! The transceiver's top (`gateware/rtl/transceiver.v`: the synchroniser, the search, the
//! receiver, its idle lines, the delimiter, the baud watchdog, the transmitter and the trial,
//! lock and fallback registers) against `dp_phy::Transceiver`, on the baud sweep's cases
//! ([`dp_phy::sweep`]) and scripted ones: the line each case puts on the bus, clock by clock,
//! with the model run strict, and the responses handed to the transmitter (min TSDR, the bytes,
//! the earliest tick). Compared every clock: a delivery, the baud state, a telegram and a
//! character under way, the line driven (TX and DE); and each delivery (status, length, end
//! tick, bytes), each change of the baud state (rate, fallback), of the idle line at the rate
//! heard (idle since when: what TSDR counts from) and each response taken or refused as events.
//!
//! The rates' figures are the model's: [`rates_svh`] writes `gateware/rtl/transceiver_rates.svh`
//! from the model's search, receiver and configuration, and a test holds the file equal to it.

use super::edge_rx::{receiver, receiver_width};
use super::status_code;
use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::autobaud::AutoBaud;
use dp_phy::bus::{FaultInjector, FaultWindow, LineFault, Outgoing};
use dp_phy::delimiter::Status;
use dp_phy::sweep::{self, Shard, SweepCase};
use dp_phy::testbench::{poll_sequence, random_telegram, Kind, Observer, Testbench};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::transceiver::Stats;
use dp_phy::uart::CharFault;
use dp_phy::{BaudState, BitTiming, Config, Tick, Transceiver};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::cell::RefCell;
use std::fmt::Write as _;
use std::rc::Rc;

pub fn transceiver() -> Block {
    Block {
        top: "transceiver",
        rtl: &[
            "transceiver.v",
            "line_sync.v",
            "autobaud.v",
            "autobaud_shared.v",
            "autobaud_channel.v",
            "autobaud_channel_step.v",
            "char_reader_step.v",
            "edge_rx.v",
            "rate_idle.v",
            "delimiter.v",
            "watchdog.v",
            "uart_tx.v",
        ],
        signals: &[
            "telegram",
            "trial",
            "locked",
            "in_telegram",
            "rx_active",
            "tx",
            "de",
        ],
        params: vec![("PhaseWidth", i64::from(receiver_width()))],
        twin: "dp_phy::transceiver::Transceiver",
        events: true,
    }
}

/// The search's schedule repeats every 2,640 clocks (every channel's sample period and the
/// shared datapath's frame of turns divide it: `the_near_wrap_reset_is_on_the_schedule`): a
/// run that starts on a multiple of it samples the line as one from tick 0 does.
const SCHEDULE_CLOCKS: u64 = 2640;

/// The tick [`transceiver_near_wrap`] comes out of reset at: 5,280,000 clocks (110 ms) or so before
/// its 32-bit ticks wrap, time for two telegrams and their answers at 9.6k, on the search's
/// schedule.
pub const NEAR_WRAP: u64 = ((1 << 32) / SCHEDULE_CLOCKS - 2000) * SCHEDULE_CLOCKS;

/// The top out of reset at [`NEAR_WRAP`] (`NowReset`; the model's `Transceiver::reset_at`):
/// its ticks, 32 bits where the model's are 64, wrap in the middle of its cases, which come
/// after 2^31 clocks too, where a tick kept since reset reads as one in the future.
pub fn transceiver_near_wrap() -> Block {
    let mut block = transceiver();
    block.params.push(("NowReset", NEAR_WRAP as i64));
    block
}

const SVH_HEADER: &str =
    "// Written by crates/rtl-check (`blocks::transceiver`) from the model at 48 MHz: each\n\
    // rate's receiver (EdgeRx::sampled, its figures in samples), its search channel's sample\n\
    // period, glitch (samples) and stop bit's end (clocks), TSYN and the gap in clocks\n\
    // (Transceiver::use_rate), and the baud watchdog. A test holds this file equal to the\n\
    // model's figures; do not edit.\n";

/// The rates' figures as functions of the rate's index, for transceiver.v to include.
pub fn rates_svh() -> String {
    let cfg = Config::default();
    let schedule = cfg.search_schedule;
    let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, schedule);
    let mut s = String::from(SVH_HEADER);
    s.push_str(
        "\n  // The receiver's figures, packed: inc, two_inc, modulo, quarter, three_quarters,\n  \
         // half_less_inc, modulo_less_inc, modulo_less_two_inc (PW bits each, two_inc PW + 1),\n  \
         // then start_end, stop_middle, stop_end (16 bits each), least significant first.\n",
    );
    s.push_str(
        "  localparam int RdInc = 0, RdTwoInc = PW, RdModulo = 2 * PW + 1,\n    \
         RdQuarter = 3 * PW + 1, RdThreeQuarters = 4 * PW + 1, RdHalfLessInc = 5 * PW + 1,\n    \
         RdModuloLessInc = 6 * PW + 1, RdModuloLessTwoInc = 7 * PW + 1,\n    \
         RdStartEnd = 8 * PW + 1, RdStopMiddle = 8 * PW + 17, RdStopEnd = 8 * PW + 33,\n    \
         RateReaderWidth = 8 * PW + 49;\n",
    );
    let watchdog = u64::from(cfg.baud_watchdog_10ms) * u64::from(cfg.clock_hz / 100);
    let _ = writeln!(
        s,
        "  localparam logic [23:0] BaudWatchdogClocks = 24'd{watchdog};"
    );
    let mut function = |name: &str, ty: &str, args: &str, row: &dyn Fn(Baud) -> String| {
        let _ = write!(
            s,
            "\n  function automatic {ty} {name}(input logic [3:0] r{args});\n    case (r)\n"
        );
        for (i, b) in Baud::ALL.iter().enumerate() {
            let _ = writeln!(s, "      4'd{i}: {name} = {}; // {b}", row(*b));
        }
        let _ = write!(
            s,
            "      default: {name} = '0;\n    endcase\n  endfunction\n"
        );
    };
    function("rate_reader", "logic [RateReaderWidth-1:0]", "", &|b| {
        let rx = receiver(b);
        let r = rx.reader();
        let [start_end, stop_middle, stop_end] = rx.offsets();
        format!(
            "{{16'd{stop_end}, 16'd{stop_middle}, 16'd{start_end}, PW'({}), PW'({}), PW'({}), \
                 PW'({}), PW'({}), PW'({}), (PW + 1)'({}), PW'({})}}",
            r.modulo_less_two_inc,
            r.modulo_less_inc,
            r.half_less_inc,
            r.three_quarters,
            r.quarter,
            r.modulo,
            r.two_inc,
            r.inc
        )
    });
    function("rate_bit", "logic [12:0]", "", &|b| {
        format!(
            "13'd{}",
            BitTiming::whole_clocks(cfg.clock_hz, b).clocks_per_bit()
        )
    });
    function("rate_stop_end", "logic [15:0]", "", &|b| {
        format!("16'd{}", search.channel_figures(b).stop_end)
    });
    function("rate_glitch", "logic [PendWidth-1:0]", "", &|b| {
        let f = search.channel_figures(b);
        format!("PendWidth'({})", f.glitch / f.period)
    });
    function("rate_tsyn", "logic [23:0]", "", &|b| {
        format!("24'd{}", search.tsyn_clocks(b))
    });
    function("rate_gap", "logic [23:0]", "", &|b| {
        let timing = BitTiming::whole_clocks(cfg.clock_hz, b);
        format!("24'd{}", timing.clocks_for(u64::from(cfg.max_gap_bits), 1))
    });
    s
}

/// What the observer of a strict run records: the stimulus and the model's outputs.
#[derive(Default)]
struct Recorder {
    run: Option<(bool, u32)>,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    clock: u32,
    state: [u8; 3],
    idle_since: Option<u32>,
}

impl Recorder {
    fn new() -> Recorder {
        Recorder {
            state: [0, 0, 0xFF],
            ..Recorder::default()
        }
    }

    fn clock(&mut self, line: bool, adapter: &Transceiver, telegram: bool) {
        match &mut self.run {
            Some((level, n)) if *level == line && *n < u32::MAX => *n += 1,
            _ => {
                self.flush();
                self.run = Some((line, 1));
            }
        }
        let state = adapter.baud_state();
        let probe = adapter.probe();
        self.trace.push(
            u8::from(telegram)
                | u8::from(matches!(state, BaudState::Trial(_))) << 1
                | u8::from(matches!(state, BaudState::Locked(_))) << 2
                | u8::from(probe.in_telegram) << 3
                | u8::from(probe.rx_active) << 4
                | u8::from(adapter.drive().unwrap_or(true)) << 5
                | u8::from(adapter.drive().is_some()) << 6,
        );
        if telegram {
            let t = adapter.telegram();
            let mut payload = vec![1, status_code(t.status), t.bytes().len() as u8];
            payload.extend((t.end as u32).to_le_bytes());
            payload.extend(t.bytes());
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
        }
        let now = [
            match state {
                BaudState::Searching => 0,
                BaudState::Trial(_) => 1,
                BaudState::Locked(_) => 2,
            },
            state.baud().map_or(0, |b| b.index() as u8),
            probe.fallback.map_or(0xFF, |b| b.index() as u8),
        ];
        if now != self.state {
            let mut payload = vec![2];
            payload.extend(now);
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
            self.state = now;
        }
        let idle_since = probe.idle_since.map(|t| t as u32);
        if idle_since != self.idle_since {
            let mut payload = vec![3, u8::from(idle_since.is_some())];
            payload.extend(idle_since.unwrap_or(0).to_le_bytes());
            self.events.push(Event {
                clock: self.clock,
                payload,
            });
            self.idle_since = idle_since;
        }
        self.clock += 1;
    }

    /// Min TSDR set to `bits` before the next clock (held).
    fn min_tsdr(&mut self, bits: u8) {
        self.flush();
        self.stimulus.push(b'M');
        self.stimulus.push(bits);
    }

    /// A response handed over before the next clock: respond_i with its length and earliest
    /// tick; `taken` is what the model answered. Its bytes go into the buffer first when it
    /// is taken (the buffer is the transmitter's while a response waits or goes out).
    fn respond(&mut self, bytes: &[u8], not_before: u64, taken: bool) {
        self.flush();
        if taken {
            for (i, &b) in bytes.iter().enumerate() {
                self.stimulus.extend([b'B', i as u8, b]);
            }
        }
        self.stimulus.push(b'P');
        self.stimulus.push(bytes.len() as u8);
        self.stimulus.extend((not_before as u32).to_le_bytes());
        self.events.push(Event {
            clock: self.clock,
            payload: vec![4, u8::from(taken)],
        });
    }

    fn flush(&mut self) {
        if let Some((level, n)) = self.run.take() {
            self.stimulus.push(b'L');
            self.stimulus.push(u8::from(level));
            self.stimulus.extend(n.to_le_bytes());
        }
    }
}

/// [`finish`], with the model's counters at the bench's end.
fn finish_with_stats(
    tb: Testbench,
    recorder: Rc<RefCell<Recorder>>,
    name: String,
) -> (Case, Stats) {
    let stats = tb.adapter.stats();
    // The bench's observer holds the recorder.
    drop(tb);
    (finish(recorder, name), stats)
}

/// An observer that gives `recorder` every clock of a bench.
fn observer(recorder: &Rc<RefCell<Recorder>>) -> Observer {
    let recorder = recorder.clone();
    Box::new(move |line, adapter, out| recorder.borrow_mut().clock(line, adapter, out.telegram))
}

/// A bench whose every clock `recorder` takes.
fn observed_bench(recorder: &Rc<RefCell<Recorder>>, timing: BitTiming) -> Testbench {
    let mut tb = Testbench::new(Config::default(), timing, FaultInjector::none());
    tb.observe(observer(recorder));
    tb
}

fn finish(recorder: Rc<RefCell<Recorder>>, name: String) -> Case {
    let mut r = Rc::try_unwrap(recorder)
        .ok()
        .expect("the bench is gone")
        .into_inner();
    r.flush();
    Case {
        name,
        stimulus: r.stimulus,
        model: r.trace,
        model_events: r.events,
    }
}

/// A strict run of a bench with a master at `timing`, which `drive` drives, recorded as a
/// case of the top (phy-bench's workload, for one).
pub fn bench_case(name: String, timing: BitTiming, drive: impl FnOnce(&mut Testbench)) -> Case {
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, timing);
    drive(&mut tb);
    drop(tb);
    finish(recorder, name)
}

/// One sweep case, strict, with what the adapter saw and did at every clock.
pub fn sweep_case(case: &SweepCase) -> Case {
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let run = sweep::drive(case, &Config::default(), false, |tb| {
        tb.observe(observer(&recorder))
    });
    drop(run);
    finish(recorder, format!("transceiver-{case}"))
}

/// How a trial that [`trials_case`] starts ends.
#[derive(Clone, Copy, Debug)]
enum TrialEnd {
    /// Its telegram complete with a bad FCS: the delivery of its last character ends it.
    BadFcs,
    /// Its telegram cut short: the idle check's gap ends it.
    Gap,
}

/// The paths the sweep seldom takes: locked at `lock`, a start delimiter at `other` starts a
/// trial from the lock that `end` ends (the lock taken back, its receiver and idle line where
/// they were), then the lock's traffic again; then the same at `other` from searching (the
/// search again); then `lock`'s traffic until the baud watchdog expires, and once more.
/// Returns the case and the model's counters at its end.
fn trials_case(lock: Baud, other: Baud, end: TrialEnd, seed: u64) -> (Case, Stats) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let at = |b: Baud| BitTiming::new(DEFAULT_CLOCK_HZ, b, rng_ppm(seed, b));
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, at(lock));
    tb.run_until(rng.gen_range(0..500), false);
    let failing = |rng: &mut ChaCha8Rng| {
        let mut t = random_telegram(rng, Kind::Sd1, 3);
        match end {
            TrialEnd::BadFcs => {
                // Characters follow at once: one is under way when the trial fails.
                let fcs = t.len() - 2;
                t[fcs] ^= 0x5A;
                t.extend([rng.gen::<u8>(), rng.gen::<u8>()]);
            }
            TrialEnd::Gap => t.truncate(3),
        }
        t
    };
    // After a cut telegram, a false start at the trial's rate (low for 0.4 of its bit, a
    // quarter bit after the telegram): the line's high tick comes after the last character's
    // end, and the gap counts from it. Then a low pulse of two bits at the lock's rate, which
    // the lock's idle line (kept during the trial) takes: the lock goes on from it when the
    // trial fails.
    let pulse = |tb: &mut Testbench| {
        tb.run_out(0, false);
        if let TrialEnd::Gap = end {
            let lock_bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, lock).clocks_per_bit();
            let other_bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, other).clocks_per_bit();
            let false_start = FaultWindow {
                start: tb.now() + 1 + other_bit / 4,
                len: other_bit * 2 / 5,
                fault: LineFault::Stuck(false),
            };
            tb.bus.faults.add(FaultWindow {
                start: false_start.start + false_start.len + 1,
                len: 2 * lock_bit,
                fault: LineFault::Stuck(false),
            });
            tb.bus.faults.add(false_start);
        }
    };
    let polls = |tb: &mut Testbench, rng: &mut ChaCha8Rng, n: usize| {
        for t in poll_sequence(rng, n) {
            tb.send(40, &t);
        }
        tb.run_out(40, false);
    };
    for round in 0..2 {
        polls(&mut tb, &mut rng, 2);
        tb.set_master_timing(at(other));
        tb.send(40, &failing(&mut rng));
        pulse(&mut tb);
        tb.run_out(if round == 0 { 20 } else { 60 }, false);
        tb.set_master_timing(at(lock));
    }
    polls(&mut tb, &mut rng, 2);
    // The baud watchdog: the line idle past it, then the lock's traffic found again.
    let watchdog = baud_watchdog_clocks();
    tb.run_until(tb.now() + watchdog + 1000, false);
    tb.set_master_timing(at(other));
    tb.send(40, &failing(&mut rng));
    tb.run_out(40, false);
    tb.set_master_timing(at(lock));
    polls(&mut tb, &mut rng, 2);
    finish_with_stats(
        tb,
        recorder,
        format!("transceiver-trials-{lock}-then-{other}-{end:?}"),
    )
}

/// Locked at `baud`, the line quiet until the baud watchdog runs out a bit into the start
/// bit of the next telegram's first character: the watchdog waits for the telegram (no
/// expiry on the clock that character is delivered, before the delimiter is inside it), which
/// restarts it. Returns the case and the model's counters.
fn watchdog_first_char_case(baud: Baud, seed: u64) -> (Case, Stats) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let timing = BitTiming::new(DEFAULT_CLOCK_HZ, baud, rng_ppm(seed, baud));
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, timing);
    tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 8));
    tb.run_out(40, false);
    let watchdog = baud_watchdog_clocks();
    let expiry = tb.delivered[0].end + watchdog;
    tb.run_until(expiry - timing.clocks_for(41, 1), false);
    tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 8));
    tb.run_out(40, false);
    finish_with_stats(
        tb,
        recorder,
        format!("transceiver-watchdog-in-a-first-character-{baud}"),
    )
}

/// The rates a set of cases runs at: `quick_rates` in the quick set, every rate in full.
fn rates(quick: bool, quick_rates: &'static [Baud]) -> &'static [Baud] {
    if quick {
        quick_rates
    } else {
        &Baud::ALL
    }
}

/// [`watchdog_first_char_case`]s: at 9.6k and 12M (`quick`), or at every rate.
fn watchdog_first_char_cases(quick: bool) -> Vec<(Case, Stats)> {
    rates(quick, &[Baud::B9600, Baud::B12000000])
        .iter()
        .map(|&b| watchdog_first_char_case(b, 500 + b.index() as u64))
        .collect()
}

/// The baud watchdog runs out while the adapter answers: a telegram locks the rate, and a
/// 20-byte answer is handed over to start half its length before the watchdog's deadline (the
/// telegram's verdict restarted it). The adapter hears its own echo, which reaches no
/// delimiter, so between two of its characters nothing is under way: the watchdog expires,
/// the search starts again and what was going out stops there (the model's `search_again`,
/// the transmitter's `clear_i`). Returns the case, the model's counters, and the clocks the
/// adapter drove against the answer's whole length.
fn watchdog_while_sending_case(baud: Baud, seed: u64) -> (Case, Stats, (u64, u64)) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let timing = BitTiming::new(DEFAULT_CLOCK_HZ, baud, rng_ppm(seed, baud));
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, timing);
    tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 8));
    while tb.delivered.is_empty() {
        tb.step_strict();
    }
    let answer: Vec<u8> = (0..20).map(|_| rng.gen()).collect();
    let whole = timing.clocks_for(11 * answer.len() as u64, 1);
    let watchdog = baud_watchdog_clocks();
    let not_before = tb.delivered[0].end + watchdog - whole / 2;
    let taken = tb.adapter.respond(&answer, not_before);
    recorder.borrow_mut().respond(&answer, not_before, taken);
    assert!(taken, "{baud}: the answer refused");
    let mut drove = 0;
    while tb.adapter.responding() || tb.now() < not_before + whole + 100 * timing.clocks_per_bit() {
        tb.step_strict();
        drove += u64::from(tb.adapter.drive().is_some());
    }
    let (case, stats) = finish_with_stats(
        tb,
        recorder,
        format!("transceiver-watchdog-while-sending-{baud}"),
    );
    (case, stats, (drove, whole))
}

/// [`watchdog_while_sending_case`]s: at 19.2k and 6M (`quick`), or at every rate.
fn watchdog_while_sending_cases(quick: bool) -> Vec<(Case, Stats, (u64, u64))> {
    rates(quick, &[Baud::B19200, Baud::B6000000])
        .iter()
        .map(|&b| watchdog_while_sending_case(b, 600 + b.index() as u64))
        .collect()
}

/// A lock at `lock` taken back on a clock on which the line falls at its rate: two polls at
/// `lock`, a telegram at `other` that fails the trial it starts (`end`), and a low pulse of
/// two `lock` bits whose fall the lock's channel samples on the verdict's clock, then two polls
/// again. A run without the pulse says when the verdict comes; the pulse starts `offset` clocks
/// from it. The pulse is a character whose idle time before it comes from the lock's idle line:
/// after a gap, an earlier pulse of two `lock` bits about a tenth of `other`'s bit after the
/// telegram's last character puts that line's rise after its end (so the idle time is the lock's line's,
/// past TSYN: the character opens a telegram with a framing error); after a bad FCS the idle
/// time is short of TSYN (not synced). Returns the case and the model's counters
/// (`relock_falls`: whether the fall met the verdict).
fn relock_fall_case(
    lock: Baud,
    other: Baud,
    end: TrialEnd,
    offset: i64,
    seed: u64,
) -> (Case, Stats) {
    let lock_bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, lock).clocks_per_bit();
    let run = |pulses: &[Tick], recorder: Option<&Rc<RefCell<Recorder>>>| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let at = |b: Baud| BitTiming::new(DEFAULT_CLOCK_HZ, b, rng_ppm(seed, b));
        let mut tb = match recorder {
            Some(r) => observed_bench(r, at(lock)),
            None => Testbench::new(Config::default(), at(lock), FaultInjector::none()),
        };
        for &start in pulses {
            tb.bus.faults.add(FaultWindow {
                start,
                len: 2 * lock_bit,
                fault: LineFault::Stuck(false),
            });
        }
        for t in poll_sequence(&mut rng, 2) {
            tb.send(40, &t);
        }
        tb.run_out(40, false);
        tb.set_master_timing(at(other));
        let mut failing = random_telegram(&mut rng, Kind::Sd1, 3);
        match end {
            TrialEnd::BadFcs => {
                let fcs = failing.len() - 2;
                failing[fcs] ^= 0x5A;
            }
            TrialEnd::Gap => failing.truncate(3),
        }
        tb.send(40, &failing);
        tb.run_out(40, false);
        tb.set_master_timing(at(lock));
        for t in poll_sequence(&mut rng, 2) {
            tb.send(40, &t);
        }
        tb.run_out(40, false);
        tb
    };
    // The verdict's clock: the baud state back at the lock after the trial.
    let verdict = |tb: &Testbench| {
        tb.baud_log
            .windows(2)
            .find(|w| w[0].1 == BaudState::Trial(other) && w[1].1 == BaudState::Locked(lock))
            .map(|w| w[1].0)
            .expect("the trial fails and the lock is taken back")
    };
    let mut pulses = Vec::new();
    if let TrialEnd::Gap = end {
        let dry = run(&[], None);
        let failed = dry
            .delivered
            .iter()
            .find(|d| d.status == Status::Gap)
            .expect("the trial's telegram is cut by a gap");
        // A gap's delivery comes a gap (a bit) and a clock after the last character's end.
        let other_bit = BitTiming::whole_clocks(DEFAULT_CLOCK_HZ, other).clocks_per_bit();
        pulses.push(failed.end - other_bit + other_bit / 10);
    }
    let at = verdict(&run(&pulses, None));
    pulses.push(at.saturating_add_signed(offset));
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let tb = run(&pulses, Some(&recorder));
    finish_with_stats(
        tb,
        recorder,
        format!("transceiver-relock-fall-{lock}-then-{other}-{end:?}{offset}"),
    )
}

/// [`relock_fall_case`]s (short: the quick set has them all): the lock at 12M and at 3M,
/// each trial ended both ways, with the pulse at the offsets around the verdict that put its
/// fall on the verdict's clock and next to it.
fn relock_fall_cases() -> Vec<(Case, Stats)> {
    let pairs = [
        (Baud::B12000000, Baud::B187500),
        (Baud::B3000000, Baud::B45450),
    ];
    let mut out = Vec::new();
    for (i, &(lock, other)) in pairs.iter().enumerate() {
        for end in [TrialEnd::BadFcs, TrialEnd::Gap] {
            for offset in -2..=0 {
                out.push(relock_fall_case(lock, other, end, offset, 500 + i as u64));
            }
        }
    }
    out
}

/// A start delimiter the search decides on after the next character's start bit and its
/// first bit's rise: from power-up, a master 5,000 ppm fast sends an SD2 telegram (its LE, 5,
/// sends a 1 first) with a high glitch in the delimiter's start bit, `at` hundredths of a bit
/// into it and `len` long. The fall after the glitch is a second candidate start, and the
/// decision waits for its stop bit. The receiver's idle line then counts from the decision
/// (`Detection::rose_after_end`), and the gap and TSYN of the polls after it count from
/// there. Returns the case and the model's counters at its end.
fn late_decision_case(baud: Baud, at: u64, len: u64, seed: u64) -> (Case, Stats) {
    faulted_delimiter_case(
        BitTiming::new(DEFAULT_CLOCK_HZ, baud, 5000),
        (at, len, true),
        seed,
        format!("transceiver-late-decision-{baud}-{at}-{len}"),
    )
}

/// From power-up, a master at `timing` sends an SD2 telegram (two data bytes) with the line
/// held at `level` from `at` hundredths of a bit into it for `len` hundredths (`fault`: at,
/// len, level), then two polls, 40 idle bits apart. Returns the case and the model's counters
/// at its end.
fn faulted_delimiter_case(
    timing: BitTiming,
    fault: (u64, u64, bool),
    seed: u64,
    name: String,
) -> (Case, Stats) {
    let (at, len, level) = fault;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, timing);
    let bit = timing.clocks_per_bit();
    tb.bus.faults.add(FaultWindow {
        start: timing.clocks_for(40, 1) + at * bit / 100,
        len: (len * bit / 100).max(1),
        fault: LineFault::Stuck(level),
    });
    tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 2));
    for t in poll_sequence(&mut rng, 2) {
        tb.send(40, &t);
    }
    tb.run_out(40, false);
    finish_with_stats(tb, recorder, name)
}

/// A start delimiter the search decides on the clock its rate's line falls for the next
/// character (`Stats::detection_falls`): from power-up, a master `ppm` off sends an SD2
/// telegram, its characters back to back, with a low glitch `at` hundredths of a bit into the
/// delimiter and `len` long, over its stop bit's middle. The search's channel then waits for
/// the whole stop bit, and decides on the sample that sees the next character's start bit. The
/// receiver is handed over with that fall (the top's `dp_fell_q`), and polls follow. Returns
/// the case and the model's counters at its end.
fn detection_fall_case(baud: Baud, ppm: i32, at: u64, len: u64, seed: u64) -> (Case, Stats) {
    faulted_delimiter_case(
        BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm),
        (at, len, false),
        seed,
        format!("transceiver-detection-fall-{baud}-{ppm}ppm-{at}-{len}"),
    )
}

/// dp-phy's `fast_equals_strict` stream: six random telegrams of every kind from a master
/// `ppm` off, 30 to 39 idle bits apart, the fourth with a data bit flipped, and 20 glitches of
/// up to a bit over them. Returns the case and how many detections the model delivered more
/// than a gap (a bit at 6M and 12M) after their character's end.
fn glitch_burst_case(baud: Baud, seed: u64, ppm: i32) -> (Case, Stats) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm));
    let t = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0);
    for i in 0..6 {
        let kind = Kind::ALL[rng.gen_range(0..5)];
        let n = rng.gen_range(1..20);
        let bytes = random_telegram(&mut rng, kind, n);
        tb.send_outgoing(Outgoing {
            idle_bits: rng.gen_range(30..40),
            bytes,
            faults: if i == 3 {
                vec![(1, CharFault::FlipBit(2))]
            } else {
                vec![]
            },
        });
    }
    let mut faults = FaultInjector::none();
    faults.glitches(seed, 0, t.clocks_for(6 * 300, 1), 20, t.clocks_per_bit());
    tb.bus.faults = faults;
    tb.run_out(60, false);
    finish_with_stats(
        tb,
        recorder,
        format!("transceiver-glitch-burst-{baud}-{seed}-{ppm}"),
    )
}

/// [`glitch_burst_case`]s the model's property tests found (CI's debug builds: a detection
/// delivered more than a gap after its end, where the model checked the gap against it and
/// the gateware against the last end kept).
fn glitch_burst_cases() -> Vec<(Case, Stats)> {
    vec![glitch_burst_case(Baud::B6000000, 931930634936587214, -4178)]
}

/// The transmitter: a master at `baud` polls, and the adapter answers each good telegram (1
/// to 20 random bytes, its earliest tick up to three bits after the delivery), with min TSDR
/// set at random (under 11 too) and set again halfway. Some answers are handed over twice, a
/// clock apart (the second refused while the first waits or goes out), or empty (refused),
/// one before any rate is found (refused), and the master's idle time before its next
/// telegram is sometimes shorter than the answer: the adapter then hears its own echo and a
/// collision. Returns the case and what it did.
///
/// `reset_at`: the tick the adapter comes out of reset at (`Transceiver::reset_at`), the line
/// idle until `traffic_from`, both on the search's schedule (0, 0: from power-up).
fn response_case(baud: Baud, seed: u64, reset_at: Tick, traffic_from: Tick) -> (Case, Responses) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let timing = BitTiming::new(DEFAULT_CLOCK_HZ, baud, rng_ppm(seed, baud));
    let bit = timing.clocks_per_bit();
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let mut tb = observed_bench(&recorder, timing);
    assert!(
        reset_at.is_multiple_of(SCHEDULE_CLOCKS) && traffic_from.is_multiple_of(SCHEDULE_CLOCKS)
    );
    if reset_at != 0 {
        tb.adapter = Transceiver::reset_at(Config::default(), reset_at);
    }
    tb.run_until(traffic_from, false);
    let set_tsdr = |tb: &mut Testbench, bits: u8| {
        tb.adapter.set_min_tsdr(bits);
        recorder.borrow_mut().min_tsdr(bits);
    };
    let mut did = Responses::default();
    let mut respond = |tb: &mut Testbench, bytes: &[u8], not_before: Tick| {
        let ok = tb.adapter.respond(bytes, not_before);
        recorder.borrow_mut().respond(bytes, not_before, ok);
        if ok {
            did.taken += 1;
        } else {
            did.refused += 1;
        }
    };
    set_tsdr(&mut tb, rng.gen_range(5..40));
    respond(&mut tb, &[0xDC], 0);
    let polls = poll_sequence(&mut rng, 8);
    for t in &polls {
        tb.send(rng.gen_range(33..160), t);
    }
    let mut seen = 0;
    let mut last_activity = tb.now();
    while !tb.master.done() || tb.adapter.responding() || tb.now() < last_activity + 200 * bit {
        tb.step_strict();
        if tb.master.tx.busy() || tb.adapter.drive().is_some() {
            last_activity = tb.now();
        }
        if tb.delivered.len() == seen {
            continue;
        }
        seen = tb.delivered.len();
        if seen == polls.len() / 2 {
            set_tsdr(&mut tb, rng.gen_range(11..60));
        }
        if tb.delivered[seen - 1].status != Status::Good {
            continue;
        }
        let n = rng.gen_range(1..=20);
        let bytes: Vec<u8> = (0..n).map(|_| rng.gen()).collect();
        let not_before = tb.now() + rng.gen_range(0..3 * bit);
        match rng.gen_range(0..8) {
            0 => respond(&mut tb, &[], not_before),
            1 => {
                // The transceiver takes one a clock: the second on the next.
                respond(&mut tb, &bytes, not_before);
                tb.step_strict();
                respond(&mut tb, &bytes[..1], not_before);
            }
            _ => respond(&mut tb, &bytes, not_before),
        }
    }
    did.collisions = tb.bus.collisions;
    did.good_ends = tb
        .delivered
        .iter()
        .filter(|d| d.status == Status::Good)
        .map(|d| d.end)
        .collect();
    drop(tb);
    let name = if reset_at == 0 {
        format!("transceiver-responses-{baud}-{seed}")
    } else {
        format!("transceiver-responses-{baud}-{seed}-from-{reset_at}")
    };
    (finish(recorder, name), did)
}

/// What a [`response_case`] did: responses taken and refused, and clocks the master and the
/// adapter drove the line together.
#[derive(Debug, Default)]
struct Responses {
    taken: u64,
    refused: u64,
    collisions: u64,
    /// The end ticks of the good telegrams delivered.
    good_ends: Vec<Tick>,
}

/// The baud watchdog's timeout in clocks, with the default configuration.
fn baud_watchdog_clocks() -> u64 {
    let cfg = Config::default();
    u64::from(cfg.baud_watchdog_10ms) * u64::from(cfg.clock_hz / 100)
}

/// A master's clock off by up to 3,000 ppm, fixed by the seed and the rate.
fn rng_ppm(seed: u64, b: Baud) -> i32 {
    ChaCha8Rng::seed_from_u64(seed ^ (b.index() as u64) << 32).gen_range(-3000..=3000)
}

/// Rate pairs for [`trials_case`]: far apart both ways, and neighbours.
const TRIAL_PAIRS: [(Baud, Baud); 4] = [
    (Baud::B12000000, Baud::B187500),
    (Baud::B500000, Baud::B1500000),
    (Baud::B93750, Baud::B6000000),
    (Baud::B3000000, Baud::B45450),
];

/// The sweep's cases (`quick`: a few of its quick set, which fit CI's time) and the scripted
/// ones, those of `shard` (by position in that list): the sweep's are run by the model only
/// for the shard, on every core.
pub fn transceiver_cases(quick: bool, shard: Shard) -> Vec<Case> {
    let all = sweep::cases(quick);
    let chosen: Vec<&SweepCase> = if quick {
        all.iter().step_by(11).collect()
    } else {
        all.iter().collect()
    };
    let sweep_count = chosen.len();
    let mine: Vec<&SweepCase> = chosen
        .into_iter()
        .enumerate()
        .filter(|(k, _)| shard.holds(*k))
        .map(|(_, c)| c)
        .collect();
    let mut cases: Vec<Case> = mine.into_par_iter().map(sweep_case).collect();
    let scripted = trials_cases(quick)
        .into_iter()
        .chain(late_decision_cases(quick))
        .map(|(c, _)| c)
        .chain(response_cases(quick).into_iter().map(|(c, _)| c))
        .chain(glitch_burst_cases().into_iter().map(|(c, _)| c))
        .chain(relock_fall_cases().into_iter().map(|(c, _)| c))
        .chain(watchdog_first_char_cases(quick).into_iter().map(|(c, _)| c))
        .chain(
            watchdog_while_sending_cases(quick)
                .into_iter()
                .map(|(c, _, _)| c),
        )
        .chain(detection_fall_cases(quick).into_iter().map(|(c, _)| c));
    cases.extend(
        scripted
            .enumerate()
            .filter(|(k, _)| shard.holds(sweep_count + k))
            .map(|(_, c)| c),
    );
    cases
}

/// [`response_case`]s: at three rates (`quick`), or at every rate.
fn response_cases(quick: bool) -> Vec<(Case, Responses)> {
    rates(quick, &[Baud::B187500, Baud::B1500000, Baud::B12000000])
        .iter()
        .map(|&b| response_case(b, 300 + b.index() as u64, 0, 0))
        .collect()
}

/// The cases of [`transceiver_near_wrap`]: [`response_case`]s from [`NEAR_WRAP`], at 1.5M and
/// 12M (`quick`) or at every rate.
pub fn near_wrap_cases(quick: bool) -> Vec<Case> {
    near_wrap_responses(quick)
        .into_iter()
        .map(|(c, _)| c)
        .collect()
}

fn near_wrap_responses(quick: bool) -> Vec<(Case, Responses)> {
    rates(quick, &[Baud::B1500000, Baud::B12000000])
        .iter()
        .map(|&b| {
            // The same traffic from power-up says where its first two good telegrams end: the
            // wrap goes between them.
            let seed = 400 + b.index() as u64;
            let (_, dry) = response_case(b, seed, 0, 0);
            let between = (dry.good_ends[0] + dry.good_ends[1]) / 2;
            let from = ((1 << 32) - between) / SCHEDULE_CLOCKS * SCHEDULE_CLOCKS;
            assert!(
                from >= NEAR_WRAP,
                "{b}: traffic from {from}, before the reset"
            );
            response_case(b, seed, NEAR_WRAP, from)
        })
        .collect()
}

/// [`late_decision_case`]s: at 93.75k and 500k (`quick`), or at the six slowest rates, with
/// glitches (hundredths of a bit: at, length) that the model decides late on.
fn late_decision_cases(quick: bool) -> Vec<(Case, Stats)> {
    let cases: &[(Baud, u64, u64)] = if quick {
        &[(Baud::B93750, 78, 20), (Baud::B500000, 76, 20)]
    } else {
        &[
            (Baud::B9600, 80, 20),
            (Baud::B19200, 80, 20),
            (Baud::B45450, 76, 20),
            (Baud::B93750, 78, 20),
            (Baud::B93750, 88, 10),
            (Baud::B187500, 66, 30),
            (Baud::B187500, 86, 10),
            (Baud::B500000, 76, 20),
            (Baud::B500000, 86, 10),
        ]
    };
    cases
        .iter()
        .enumerate()
        .map(|(i, &(baud, at, len))| late_decision_case(baud, at, len, 200 + i as u64))
        .collect()
}

/// [`detection_fall_case`]s: at 19.2k and 6M (`quick`), or at every rate where a scan of
/// glitches over the stop bit's middle found one (10.30 to 10.70 bits into the delimiter, 0.05
/// to 0.30 bit long, masters at -3,000, 0 and +3,000 ppm: none at 93.75k or 187.5k); each a
/// master offset and a glitch (hundredths of a bit: at, length) from the middle of the range
/// that decides on the fall.
fn detection_fall_cases(quick: bool) -> Vec<(Case, Stats)> {
    let cases: &[(Baud, i32, u64, u64)] = if quick {
        &[
            (Baud::B19200, -3000, 1045, 10),
            (Baud::B6000000, 0, 1055, 10),
        ]
    } else {
        &[
            (Baud::B9600, -3000, 1045, 10),
            (Baud::B19200, -3000, 1045, 10),
            (Baud::B45450, 0, 1045, 20),
            (Baud::B500000, 0, 1045, 20),
            (Baud::B1500000, 0, 1050, 20),
            (Baud::B3000000, 0, 1050, 10),
            (Baud::B6000000, 0, 1055, 10),
            (Baud::B12000000, 0, 1060, 10),
        ]
    };
    cases
        .iter()
        .enumerate()
        .map(|(i, &(baud, ppm, at, len))| detection_fall_case(baud, ppm, at, len, 300 + i as u64))
        .collect()
}

fn trials_cases(quick: bool) -> Vec<(Case, Stats)> {
    let pairs = if quick {
        &TRIAL_PAIRS[..2]
    } else {
        &TRIAL_PAIRS[..]
    };
    let mut out = Vec::new();
    for (i, &(lock, other)) in pairs.iter().enumerate() {
        for end in [TrialEnd::BadFcs, TrialEnd::Gap] {
            out.push(trials_case(lock, other, end, 100 + i as u64));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick set's responses are taken and refused, and the master talks over some (the
    /// adapter hears its own echo).
    #[test]
    fn the_quick_responses_take_their_paths() {
        let cases = response_cases(true);
        for (case, did) in &cases {
            assert!(did.taken >= 3 && did.refused >= 1, "{}: {did:?}", case.name);
        }
        assert!(
            cases.iter().any(|(_, did)| did.collisions > 0),
            "no collision"
        );
    }

    /// The cases near the wrap (the full set, which holds the quick one) answer telegrams on
    /// both sides of it: before it, 2^31 clocks and more after the tick the top is reset to.
    #[test]
    fn the_near_wrap_cases_answer_on_both_sides_of_it() {
        let mut failed = Vec::new();
        for (case, did) in near_wrap_responses(false) {
            let before = did.good_ends.iter().filter(|&&t| t < 1 << 32).count();
            let after = did.good_ends.len() - before;
            if !(before >= 1 && after >= 1 && did.taken >= 2) {
                failed.push(format!(
                    "{}: {before} good before the wrap, {after} after, {did:?}",
                    case.name
                ));
            }
        }
        assert!(failed.is_empty(), "{failed:#?}");
    }

    /// Each pair's relock-fall cases take a lock back with a fall at its rate on the verdict's
    /// clock in at least one of them, for each way the trial ends.
    #[test]
    fn the_relock_falls_meet_the_verdict() {
        for (i, cases) in relock_fall_cases().chunks(3).enumerate() {
            for (case, stats) in cases {
                assert_eq!(stats.relock_trials_failed, 1, "{}: {stats:?}", case.name);
            }
            let hits: Vec<&str> = cases
                .iter()
                .filter(|(_, stats)| stats.relock_falls >= 1)
                .map(|(case, _)| case.name.as_str())
                .collect();
            assert!(!hits.is_empty(), "set {i}: no fall on the verdict's clock");
            println!("{hits:?}");
        }
    }

    /// The detection-fall cases, quick and full, are decided on the clock their rate's line
    /// falls for the next character (the top's `dp_fell_q`: forced to 0, rtl-check finds
    /// both quick cases), and the telegram and the polls after it are taken.
    #[test]
    fn the_detections_meet_a_fall() {
        for (case, stats) in detection_fall_cases(true)
            .into_iter()
            .chain(detection_fall_cases(false))
        {
            assert_eq!(stats.detection_falls, 1, "{}: {stats:?}", case.name);
            assert_eq!(stats.telegrams_good, 3, "{}: {stats:?}", case.name);
        }
    }

    /// The glitch bursts deliver a detection more than a gap after its end.
    #[test]
    fn the_glitch_bursts_deliver_a_detection_past_the_gap() {
        for (case, stats) in glitch_burst_cases() {
            assert!(stats.detections_past_gap >= 1, "{}: {stats:?}", case.name);
        }
    }

    /// The late decisions' cases, quick and full, are decided after the next character's
    /// rise (their idle line counts from the decision), and the polls after them are taken.
    #[test]
    fn the_late_decisions_take_their_path() {
        for (case, stats) in late_decision_cases(true)
            .into_iter()
            .chain(late_decision_cases(false))
        {
            assert_eq!(stats.detections_after_rise, 1, "{}: {stats:?}", case.name);
            assert_eq!(stats.telegrams_good, 2, "{}: {stats:?}", case.name);
        }
    }

    /// The quick set takes the paths the sweep seldom does: trials from a lock that fail and
    /// take it back (by a bad FCS and by a gap), trials from searching that fail, and the
    /// baud watchdog's expiry.
    #[test]
    fn the_quick_trials_take_the_rare_paths() {
        for (case, stats) in trials_cases(true) {
            assert!(stats.relock_trials_failed >= 2, "{}: {stats:?}", case.name);
            assert!(stats.watchdog_expiries >= 1, "{}: {stats:?}", case.name);
            // Searching, a failed trial, then the lock's traffic found again.
            assert!(
                stats.trials >= stats.relock_trials_failed + 3,
                "{}: {stats:?}",
                case.name
            );
        }
    }

    /// The watchdog's cases, quick and full, deliver both telegrams with no expiry: the
    /// watchdog ran out inside the second one's first character and waited for it.
    #[test]
    fn the_watchdog_waits_for_a_first_character() {
        for (case, stats) in watchdog_first_char_cases(true)
            .into_iter()
            .chain(watchdog_first_char_cases(false))
        {
            assert_eq!(stats.telegrams_good, 2, "{}: {stats:?}", case.name);
            assert_eq!(stats.watchdog_expiries, 0, "{}: {stats:?}", case.name);
        }
    }

    /// The watchdog's cases while sending, quick and full, expire once while the adapter
    /// answers and cut its answer short: it drove for more than a tenth and less than nine
    /// tenths of the answer's length.
    #[test]
    fn the_watchdog_cuts_an_answer_short() {
        for (case, stats, (drove, whole)) in watchdog_while_sending_cases(true)
            .into_iter()
            .chain(watchdog_while_sending_cases(false))
        {
            assert_eq!(stats.watchdog_expiries, 1, "{}: {stats:?}", case.name);
            assert!(
                drove > whole / 10 && drove < whole * 9 / 10,
                "{}: drove {drove} of {whole} clocks",
                case.name
            );
        }
    }

    /// The near-wrap build comes out of reset on a clock where every channel of the search and
    /// the shared datapath's frame begin again, as they do at tick 0.
    #[test]
    fn the_near_wrap_reset_is_on_the_schedule() {
        let schedule = dp_phy::autobaud::OVERSAMPLED;
        assert_eq!(SCHEDULE_CLOCKS % dp_phy::autobaud::SHARED_SLOTS, 0);
        for period in schedule.period {
            assert_eq!(SCHEDULE_CLOCKS % period, 0, "period {period}");
        }
        assert_eq!(NEAR_WRAP % SCHEDULE_CLOCKS, 0);
    }

    /// The rates' figures in the gateware are the model's. After a change of the model's
    /// figures, `RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check` writes the file anew.
    #[test]
    fn the_gateware_rates_have_the_models_figures() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../gateware/rtl/transceiver_rates.svh");
        let want = rates_svh();
        if std::env::var_os("RTL_CHECK_WRITE_SVH").is_some() {
            std::fs::write(&path, &want).expect("writing the rates");
        }
        let have = std::fs::read_to_string(&path).expect("transceiver_rates.svh");
        assert!(
            have == want,
            "gateware/rtl/transceiver_rates.svh is not the model's: \
             RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check writes it"
        );
    }
}
