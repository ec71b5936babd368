//! The baud-rate search (`gateware/rtl/autobaud.v`, one `autobaud_channel.v` per rate) against
//! `dp_phy::autobaud::AutoBaud`: the line and the rate heard as the transceiver gives them to
//! its search, clock by clock, while a master sends telegrams at every rate, off the adapter's
//! clock by up to 5,000 ppm, with glitches of up to half a bit, from power-up and after a
//! change of rate; and seeded random lines (edges at any spacing, idles of TSYN at random
//! rates, the rate heard coming and going) for the rejections and the second starts.
//!
//! The channels' figures are the model's: [`channels_svh`] writes
//! `gateware/rtl/autobaud_channels.svh` from [`AutoBaud::channel_figures`], and a test holds
//! the file equal to it.

use super::bits_for;
use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::autobaud::{
    AutoBaud, AutoBaudQ, ChannelFigures, Reject, Schedule, AUTOBAUD_RESET, SHARED_SLOTS,
};
use dp_phy::bus::FaultInjector;
use dp_phy::filter::{self, FilterOut, FilterQ, FILTER_RESET};
use dp_phy::testbench::{poll_sequence, random_telegram, Kind, Testbench};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::{BitTiming, Config, Tick};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

/// The search as the transceiver builds it (`oversampled`: the channels up to 1.5 Mbit/s
/// sampling the line every few clocks, the seven slowest taking turns in autobaud_shared.v), or
/// with every channel sampling every clock.
pub fn autobaud(oversampled: bool) -> Block {
    Block {
        top: "autobaud",
        rtl: &[
            "autobaud.v",
            "autobaud_shared.v",
            "autobaud_channel.v",
            "autobaud_channel_step.v",
            "char_reader_step.v",
        ],
        signals: &["valid", "detect", "measuring", "heard_sample"],
        params: vec![("Oversampled", i64::from(oversampled))],
        twin: "dp_phy::autobaud::AutoBaud",
        events: true,
    }
}

/// When each channel samples the line in the build with `Oversampled` set or not.
pub fn schedule(oversampled: bool) -> Schedule {
    if oversampled {
        dp_phy::autobaud::OVERSAMPLED
    } else {
        dp_phy::autobaud::EVERY_CLOCK
    }
}

/// A channel's figures in its samples, as the RTL takes them.
struct SampleFigures {
    glitch: u64,
    tsyn: u64,
    stop_middle: u64,
    stop_end: u64,
}

fn sample_figures(f: &ChannelFigures) -> SampleFigures {
    // The model's figures are clocks, whole samples each.
    SampleFigures {
        glitch: f.glitch / f.period,
        tsyn: f.tsyn / f.period,
        stop_middle: f.stop_middle / f.period,
        stop_end: f.stop_end / f.period,
    }
}

/// The samples a channel's last edge is taken as pending at reset: the line's last edge is
/// taken as at tick 0, the channel's first sample is within a glitch of it, and the
/// Glitch-th past tick 0 is the last that is.
fn edge_reset(f: &ChannelFigures, n: &SampleFigures) -> u64 {
    if f.phase == 0 {
        n.glitch + 1
    } else {
        n.glitch
    }
}

/// The registers' widths a channel needs: phase, idle line, pending edge, measurement, second
/// start.
fn widths(f: &ChannelFigures) -> [u32; 5] {
    let n = sample_figures(f);
    [
        bits_for(f.reader.modulo),
        bits_for(n.tsyn),
        bits_for(n.glitch + 1),
        bits_for(f.start_bit_clocks + n.stop_end),
        bits_for(f.start_bit_clocks),
    ]
}

/// The rates whose channels take their turns in autobaud_shared.v, slowest first: those that
/// sample every few clocks (the ones that sample every clock have hardware of their own).
fn shared_channels(schedule: &Schedule) -> Vec<usize> {
    (0..Baud::ALL.len())
        .filter(|&r| schedule.period[r] > 1)
        .collect()
}

/// The clocks between a shared channel's turns: its period if that divides the frame (turns
/// in several slots of each frame), else one frame (its period is then a whole number of them).
fn turn_period(schedule: &Schedule, r: usize) -> u64 {
    let period = schedule.period[r];
    if SHARED_SLOTS.is_multiple_of(period) {
        period
    } else {
        assert!(
            period.is_multiple_of(SHARED_SLOTS),
            "a shared channel's period divides the frame or is a whole number of frames"
        );
        SHARED_SLOTS
    }
}

/// The shared datapath's turns: for each clock of the frame, the channel whose turn it is
/// (`None`: a free slot). Panics where two channels would share a slot.
fn turns(schedule: &Schedule, shared: &[usize]) -> Vec<Option<usize>> {
    let mut turns = vec![None; SHARED_SLOTS as usize];
    for (c, &r) in shared.iter().enumerate() {
        let every = turn_period(schedule, r);
        // The first sample is on the channel's first turn.
        assert!(
            schedule.phase[r] < every,
            "a shared channel samples on its first turn"
        );
        let mut slot = schedule.phase[r];
        while slot < SHARED_SLOTS {
            let turn = &mut turns[slot as usize];
            assert!(turn.is_none(), "two shared channels in slot {slot}");
            *turn = Some(c);
            slot += every;
        }
    }
    // The step takes a turn's word on the clock after the last turn's (so no two turns in a
    // row), and the RAM reads it two clocks ahead, on the edge that writes the word of the
    // turn three clocks before (so no turns three clocks apart; two apart, the word comes
    // from autobaud_shared.v's written_q instead).
    for slot in 0..turns.len() {
        for (apart, what) in [(1, "two turns in a row"), (3, "turns three clocks apart")] {
            let later = turns[(slot + apart) % turns.len()];
            assert!(
                turns[slot].is_none() || turns[slot] != later,
                "a shared channel with {what} (slot {slot})"
            );
        }
    }
    turns
}

const SVH_HEADER: &str = "// Written by crates/rtl-check (`blocks::autobaud`) from\n\
    // dp_phy::autobaud::AutoBaud::channel_figures at 48 MHz, every figure in the channel's\n\
    // samples. A test holds this file equal to the model's figures; do not edit.\n";

/// The channels' instances with the model's figures (`gateware/rtl/autobaud_channels.svh`):
/// one set sampling every clock, one oversampling (the seven slowest in autobaud_shared.v),
/// chosen by autobaud.v's `Oversampled`.
pub fn channels_svh() -> String {
    let mut s = String::from(SVH_HEADER);
    s.push_str("// One channel per rate, 9.6k first.\n");
    for oversampled in [true, false] {
        let schedule = schedule(oversampled);
        let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, schedule);
        let _ = write!(
            s,
            "\n  {}begin : g_{}\n",
            if oversampled {
                "if (Oversampled != 0) "
            } else {
                "else "
            },
            if oversampled {
                "oversampled"
            } else {
                "every_clock"
            }
        );
        let shared = shared_channels(&schedule);
        if !shared.is_empty() {
            s.push_str(&shared_instance(&search, &schedule, &shared));
        }
        for (r, baud) in Baud::ALL.iter().enumerate() {
            if shared.contains(&r) {
                continue;
            }
            let f = search.channel_figures(*baud);
            let c = f.reader;
            let n = sample_figures(&f);
            let [phase_w, idle_w, pend_w, time_w, alt_w] = widths(&f);
            let _ = write!(
                s,
                "\n    // {baud}, a sample every {} clock(s) from tick {}\n    autobaud_channel #(\n      \
                 .PhaseWidth({phase_w}), .Inc({}), .Modulo({}), .Quarter({}), .ThreeQuarters({}),\n      \
                 .HalfLessInc({}), .TwoInc({}), .ModuloLessInc({}), .ModuloLessTwoInc({}),\n      \
                 .Glitch({}), .Tsyn({}), .StopMiddle({}), .StopEnd({}),\n      \
                 .StartBitClocks({}), .Period({}), .Phase({}),\n      \
                 .IdleWidth({idle_w}), .PendWidth({pend_w}), .TimeWidth({time_w}), .AltWidth({alt_w}),\n      \
                 .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)\n    \
                 ) u_channel_{r} (\n      \
                 .clk_i, .rst_ni, .level_i,\n      \
                 .heard_i(heard[{r}]), .heard_any_i(heard_valid_i), .detect_o(detect[{r}]),\n      \
                 .reject_o(reject[{r}]), .reject_code_o(reject_code[{r} * 2 +: 2]),\n      \
                 .byte_o(bytes[{r} * 8 +: 8]),\n      \
                 .start_clocks_o(start_clocks[{r} * ClocksWidth +: ClocksWidth]),\n      \
                 .cancel_left_o(cancel_left[{r} * PendWidth +: PendWidth]), .sample_o(samples_o[{r}]),\n      \
                 .rose_after_end_o(rose_after_end[{r}]), .measuring_o(measuring_o[{r}])\n    );\n",
                f.period,
                f.phase,
                c.inc,
                c.modulo,
                c.quarter,
                c.three_quarters,
                c.half_less_inc,
                c.two_inc,
                c.modulo_less_inc,
                c.modulo_less_two_inc,
                n.glitch,
                n.tsyn,
                n.stop_middle,
                n.stop_end,
                f.start_bit_clocks,
                f.period,
                f.phase,
            );
        }
        s.push_str("  end\n");
    }
    s
}

/// autobaud_shared.v's instance for the channels `shared` (the slowest rates, in order: the
/// datapath's channel c is the rate of index c), at the widest of their widths, its decision
/// fanned out to theirs.
fn shared_instance(search: &AutoBaud, schedule: &Schedule, shared: &[usize]) -> String {
    let slots = SHARED_SLOTS as usize;
    let channels = shared.len();
    assert!(
        shared.iter().enumerate().all(|(i, &r)| i == r),
        "the shared channels are the slowest rates, the channel of index c the rate of index c"
    );
    let mut w = [0u32; 5];
    let mut frames = 0;
    let mut period = 0;
    for &r in shared {
        let f = search.channel_figures(Baud::ALL[r]);
        for (m, x) in w.iter_mut().zip(widths(&f)) {
            *m = (*m).max(x);
        }
        frames = frames.max(f.period / turn_period(schedule, r));
        period = period.max(f.period);
    }
    let [phase_w, idle_w, pend_w, time_w, alt_w] = w;
    let last = channels - 1;
    let mut s = format!(
        "\n    // {} to {}, taking turns in a frame of {slots} clocks (autobaud_slots.svh)\n    \
         logic [1:0] shared_code;\n    logic [7:0] shared_byte;\n    \
         logic [ClocksWidth-1:0] shared_clocks;\n    \
         logic [PendWidth-1:0] shared_cancel;\n    \
         logic shared_rose;\n    \
         autobaud_shared #(\n      \
         .Slots({slots}), .Channels({channels}), .PhaseWidth({phase_w}), .IdleWidth({idle_w}),\n      \
         .PendWidth({pend_w}), .TimeWidth({time_w}), .AltWidth({alt_w}), .FrameWidth({}),\n      \
         .PeriodWidth({}), .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)\n    \
         ) u_shared (\n      \
         .clk_i, .rst_ni, .level_i,\n      \
         .heard_i(heard[{last}:0]), .heard_any_i(heard_valid_i), .detect_o(detect[{last}:0]),\n      \
         .reject_o(reject[{last}:0]), .reject_code_o(shared_code), .byte_o(shared_byte),\n      \
         .start_clocks_o(shared_clocks), .cancel_left_o(shared_cancel),\n      \
         .rose_after_end_o(shared_rose),\n      \
         .samples_o(samples_o[{last}:0]), .measuring_o(measuring_o[{last}:0])\n    );\n    \
         for (genvar r = 0; r < {channels}; r++) begin : g_shared\n      \
         assign reject_code[r * 2 +: 2] = shared_code;\n      \
         assign bytes[r * 8 +: 8] = shared_byte;\n      \
         assign start_clocks[r * ClocksWidth +: ClocksWidth] = shared_clocks;\n      \
         assign cancel_left[r * PendWidth +: PendWidth] = shared_cancel;\n      \
         assign rose_after_end[r] = shared_rose;\n    \
         end\n",
        Baud::ALL[shared[0]],
        Baud::ALL[last],
        bits_for(frames - 1).max(1),
        bits_for(period),
    );
    s.push('\n');
    s
}

/// The shared channels' turns and figures (`gateware/rtl/autobaud_slots.svh`):
/// autobaud_shared.v's two tables, the channel whose turn each clock of the frame is, and the
/// figures of each channel, in the oversampled build.
pub fn slots_svh() -> String {
    let schedule = schedule(true);
    let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, schedule);
    let shared = shared_channels(&schedule);
    let mut s = String::from(SVH_HEADER);
    s.push_str(
        "// autobaud_shared.v's tables: the channel whose turn a clock of the frame is (turn_of:\n\
         // {a channel's turn, which}), and the figures of the channel in turn, at its\n\
         // widths (P phase, G pending edge, I idle line, T measurement, F frames, E an idle line\n\
         // and a measurement added, Q the sample period in clocks).\n\
         function automatic logic [C:0] turn_of(input logic [SlotWidth-1:0] slot);\n  \
         case (slot)\n",
    );
    for (slot, turn) in turns(&schedule, &shared).iter().enumerate() {
        match turn {
            Some(c) => {
                let _ = writeln!(
                    s,
                    "    {slot}: turn_of = {{1'b1, C'({c})}}; // {}",
                    Baud::ALL[shared[*c]]
                );
            }
            None => {
                let _ = writeln!(s, "    {slot}: turn_of = '0; // free");
            }
        }
    }
    s.push_str("    default: turn_of = '0;\n  endcase\nendfunction\n\n");
    // A channel's idle line at reset, for its word before its first turn: {edge_reset, tsyn},
    // as the figures below give them.
    s.push_str(
        "function automatic logic [G+I-1:0] idle_reset_of(input logic [C-1:0] channel);\n  \
         case (channel)\n",
    );
    for (c, &r) in shared.iter().enumerate() {
        let f = search.channel_figures(Baud::ALL[r]);
        let n = sample_figures(&f);
        let _ = writeln!(
            s,
            "    {c}: idle_reset_of = {{G'({}), I'({})}}; // {}",
            edge_reset(&f, &n),
            n.tsyn,
            Baud::ALL[r]
        );
    }
    s.push_str("    default: idle_reset_of = '0;\n  endcase\nendfunction\n\n");
    s.push_str(
        "always_comb begin\n  \
         inc = '0; modulo = '0; quarter = '0; three_quarters = '0; half_less_inc = '0;\n  \
         two_inc = '0; modulo_less_inc = '0; modulo_less_two_inc = '0; glitch = '0;\n  \
         tsyn_less_one = '0; to_middle = '0; middle_to_end = '0;\n  \
         start_bit = '0; frames_less_one = '0; tsyn_past_end = '0; sample_period = '0;\n  \
         case (channel_q)\n",
    );
    for (c, &r) in shared.iter().enumerate() {
        let baud = Baud::ALL[r];
        let f = search.channel_figures(baud);
        let rd = f.reader;
        let n = sample_figures(&f);
        let _ = write!(
            s,
            "    // {baud}: a sample every {} clocks from tick {}\n    \
             {c}: begin\n      \
             inc = P'({}); modulo = P'({}); quarter = P'({}); three_quarters = P'({});\n      \
             half_less_inc = P'({}); two_inc = (P + 1)'({});\n      \
             modulo_less_inc = P'({}); modulo_less_two_inc = P'({});\n      \
             glitch = G'({}); tsyn_less_one = I'({});\n      \
             to_middle = T'({}); middle_to_end = T'({}); start_bit = T'({});\n      \
             frames_less_one = F'({}); tsyn_past_end = E'({}); sample_period = Q'({});\n    \
             end\n",
            f.period,
            f.phase,
            rd.inc,
            rd.modulo,
            rd.quarter,
            rd.three_quarters,
            rd.half_less_inc,
            rd.two_inc,
            rd.modulo_less_inc,
            rd.modulo_less_two_inc,
            n.glitch,
            n.tsyn - 1,
            n.stop_middle - 1,
            n.stop_end - n.stop_middle - 1,
            f.start_bit_clocks,
            f.period / turn_period(&schedule, r) - 1,
            n.tsyn - 1 + n.stop_end,
            f.period,
        );
    }
    s.push_str("    default: ;\n  endcase\nend\n");
    s
}

fn reject_code(reject: Reject) -> u8 {
    match reject {
        Reject::OffGrid => 0,
        Reject::NotAChar => 1,
        Reject::NotADelimiter => 2,
    }
}

/// The stimulus and the model, written together: the line as the search sees it (after the
/// transceiver's synchroniser) and the rate heard.
struct SearchCase {
    search: AutoBaud,
    schedule: Schedule,
    q: AutoBaudQ,
    sync: FilterQ,
    now: u64,
    run: Option<(bool, u8, u32)>,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    mask: u16,
    /// Detections whose channel's line rose on the character's end tick itself: the bound
    /// of `Detection::rose_after_end` (a rise after the end), met exactly.
    rose_at_end: u32,
}

impl SearchCase {
    fn new(oversampled: bool) -> SearchCase {
        SearchCase {
            search: AutoBaud::sampled(DEFAULT_CLOCK_HZ, schedule(oversampled)),
            schedule: schedule(oversampled),
            q: AUTOBAUD_RESET,
            sync: FILTER_RESET,
            now: 0,
            run: None,
            stimulus: Vec::new(),
            trace: Trace::default(),
            events: Vec::new(),
            mask: 0,
            rose_at_end: 0,
        }
    }

    /// One clock with the line (before the synchroniser) at `line` and `heard`.
    fn clock(&mut self, line: bool, heard: Option<Baud>) {
        let (sf, sync) = filter::next(line, 0, &self.sync);
        self.sync = sync;
        self.search_clock(sf, heard);
    }

    /// One clock of the search itself.
    fn search_clock(&mut self, sf: FilterOut, heard: Option<Baud>) {
        let heard_code = heard.map_or(0xFF, |b| b.index() as u8);
        match &mut self.run {
            Some((level, h, n)) if *level == sf.level && *h == heard_code && *n < u32::MAX => {
                *n += 1
            }
            _ => {
                self.flush();
                self.run = Some((sf.level, heard_code, 1));
            }
        }
        let out = self.search.clock(self.now, sf, heard, &mut self.q);
        let mask = self
            .q
            .channels
            .iter()
            .enumerate()
            .fold(0u16, |m, (r, c)| m | u16::from(c.measuring) << r);
        let mut value = u8::from(mask != 0) << 2;
        // The heard rate's channel samples the line on this clock: the receiver's sample.
        if let Some(b) = heard {
            let r = b.index();
            value |= u8::from(self.now % self.schedule.period[r] == self.schedule.phase[r]) << 3;
        }
        let mut payload = mask.to_le_bytes().to_vec();
        match out {
            Some(Ok(d)) => {
                self.rose_at_end += u32::from(self.q.high_since[d.baud.index()] == d.end);
                value |= 0b11;
                payload.extend([1, d.baud.index() as u8, d.byte]);
                // In clocks, as the RTL puts it out (each channel's samples times its period).
                let period = self.schedule.period[d.baud.index()];
                let age = self.now - d.start;
                payload.extend((age as u32).to_le_bytes());
                // The pending edge as the samples a next one still cancels it within: the
                // rate's glitch less the samples since it.
                let left = if d.pending == Tick::MAX {
                    0
                } else {
                    let glitch = self.search.channel_figures(d.baud).glitch / period;
                    glitch.saturating_sub((self.now - d.pending) / period)
                };
                payload.extend((left as u32).to_le_bytes());
                payload.push(u8::from(d.rose_after_end));
            }
            Some(Err(e)) => {
                value |= 0b01;
                payload.extend([2, 0, reject_code(e)]);
                payload.extend([0; 9]);
            }
            None => payload.extend([0; 12]),
        }
        if out.is_some() || mask != self.mask {
            self.events.push(Event {
                clock: self.now as u32,
                payload,
            });
        }
        self.mask = mask;
        self.trace.push(value);
        self.now += 1;
    }

    fn flush(&mut self) {
        if let Some((level, heard, n)) = self.run.take() {
            self.stimulus.push(b'L');
            self.stimulus.push(u8::from(level));
            self.stimulus.push(heard);
            self.stimulus.extend(n.to_le_bytes());
        }
    }

    fn finish(mut self, name: String) -> Case {
        self.flush();
        assert!(
            self.now < u64::from(u32::MAX),
            "{name}: too long for the harness's clocks"
        );
        Case {
            name,
            stimulus: self.stimulus,
            model: self.trace,
            model_events: self.events,
        }
    }
}

/// A master at `baud` (`ppm` off) sending polls with `noise` glitches per telegram, from
/// power-up or after the adapter was locked at `from`; the transceiver gives the rate heard.
fn master_case(
    oversampled: bool,
    baud: Baud,
    ppm: i32,
    noise: u32,
    from: Option<Baud>,
    seed: u64,
) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let target = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
    let first = from.map_or(target, |f| BitTiming::new(DEFAULT_CLOCK_HZ, f, -ppm));
    let cfg = Config {
        search_schedule: schedule(oversampled),
        ..Config::default()
    };
    let mut tb = Testbench::new(cfg, first, FaultInjector::none());
    let mut case = SearchCase::new(oversampled);
    let step = |tb: &mut Testbench, case: &mut SearchCase| {
        let heard = tb.adapter.heard();
        tb.step_strict();
        case.clock(tb.bus.line, heard);
    };
    let phase = rng.gen_range(0..1000);
    while tb.now() < phase {
        step(&mut tb, &mut case);
    }
    let run_out = |tb: &mut Testbench, case: &mut SearchCase| {
        while !tb.master.done() {
            step(tb, case);
        }
        let tail = tb.now() + tb.master.tx.timing.clocks_for(40, 1);
        while tb.now() < tail {
            step(tb, case);
        }
    };
    if from.is_some() {
        tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 4));
        run_out(&mut tb, &mut case);
        tb.set_master_timing(target);
    }
    let count = 3 * (1 + noise as usize);
    let start = tb.now();
    for (i, t) in poll_sequence(&mut rng, count).iter().enumerate() {
        tb.send(if i == 0 { 40 } else { 33 }, t);
    }
    if noise > 0 {
        let span = target.clocks_for(count as u64 * (33 + 40 * 11), 1);
        let max_len = (target.clocks_per_bit() / 2).saturating_sub(1).max(1);
        let mut f = FaultInjector::none();
        f.glitches(seed, start, start + span, count * noise as usize, max_len);
        tb.bus.faults = f;
    }
    run_out(&mut tb, &mut case);
    let scenario = from.map_or("power-up".to_string(), |f| format!("from-{f}"));
    let build = if oversampled { "oversampled-" } else { "" };
    case.finish(format!(
        "autobaud-{build}{baud}-{scenario}-{ppm}ppm-noise{noise}"
    ))
}

/// A seeded random line: runs of any length up to a few of `baud`'s bits, now and then an
/// idle of TSYN at a random rate and a start delimiter's worth of random levels at it, the rate
/// heard set and cleared at random.
fn random_case(oversampled: bool, baud: Baud, seed: u64, clocks: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut case = SearchCase::new(oversampled);
    let (mut level, mut heard) = (true, None);
    let bit = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_per_bit();
    while case.now < clocks {
        let n = if rng.gen_ratio(1, 20) {
            let other = Baud::ALL[rng.gen_range(0..10)];
            level = true;
            BitTiming::new(DEFAULT_CLOCK_HZ, other, 0).clocks_for(33, 1) + rng.gen_range(0..3)
        } else {
            level = !level;
            rng.gen_range(1..=3 * bit)
        };
        if rng.gen_ratio(1, 30) {
            heard = if heard.is_some() {
                None
            } else {
                Some(Baud::ALL[rng.gen_range(0..10)])
            };
        }
        for _ in 0..n {
            case.clock(level, heard);
        }
    }
    let build = if oversampled { "oversampled-" } else { "" };
    case.finish(format!("autobaud-{build}random-{baud}-{seed}"))
}

/// A start delimiter whose decision waits for its stop bit's end (a low glitch of `glitch`
/// clocks at the stop bit's middle, `shift` clocks off it) and meets the next character's
/// start, from a master `ppm` fast, within a glitch's length before it: the detecting channel's
/// idle line then has an edge a next one would still cancel (`Detection::pending`).
fn stop_glitch_case(oversampled: bool, baud: Baud, ppm: i32, glitch: u64, shift: i64) -> Case {
    let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
    let middle = master.clocks_for(21, 2) as i64 + shift;
    let name = format!("{baud}-stop-glitch-{ppm}ppm-{glitch}-at{shift}");
    turned_case(oversampled, master, middle, glitch, name)
}

/// A start delimiter decided after the next character's start bit and its first bit's rise
/// (`Detection::rose_after_end`): from a master 5,000 ppm fast, a high glitch `at` hundredths
/// of a bit into the delimiter's start bit and `len` long. The fall after it is a second
/// candidate start, whose stop bit the decision waits for.
fn start_glitch_case(oversampled: bool, baud: Baud, at: u64, len: u64) -> Case {
    let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 5000);
    let bit = master.clocks_per_bit();
    let name = format!("{baud}-start-glitch-{at}-{len}");
    turned_case(
        oversampled,
        master,
        (at * bit / 100) as i64,
        (len * bit / 100).max(1),
        name,
    )
}

/// SD2, 5, 5, SD2 from `master` after 40 idle bits, the line turned over for `glitch` clocks
/// from `at` clocks after the delimiter's start edge.
fn turned_case(oversampled: bool, master: BitTiming, at: i64, glitch: u64, name: String) -> Case {
    glitched_case(oversampled, master, &[(at, glitch)], name).0
}

/// [`turned_case`] with the line turned over in each of `glitches` (from, clocks), and the
/// detections whose line rose on their character's end tick.
fn glitched_case(
    oversampled: bool,
    master: BitTiming,
    glitches: &[(i64, u64)],
    name: String,
) -> (Case, u32) {
    let mut case = SearchCase::new(oversampled);
    let t0 = master.clocks_for(40, 1);
    let bits: Vec<bool> = [dp_consts::SD2, 0x05, 0x05, dp_consts::SD2]
        .iter()
        .flat_map(|&b| dp_phy::uart::char_bits(b))
        .collect();
    let end = t0 + master.clocks_for(bits.len() as u64 + 40, 1);
    for now in 0..end {
        let clean = now < t0 || {
            let bit = ((now - t0) * master.inc / master.modulo) as usize;
            bits.get(bit).copied().unwrap_or(true)
        };
        let turned = glitches.iter().any(|&(at, len)| {
            let from = t0 as i64 + at;
            (from..from + len as i64).contains(&(now as i64))
        });
        case.clock(clean != turned, None);
    }
    let build = if oversampled { "oversampled-" } else { "" };
    let rose_at_end = case.rose_at_end;
    (case.finish(format!("autobaud-{build}{name}")), rose_at_end)
}

pub fn autobaud_cases(quick: bool, oversampled: bool) -> Vec<Case> {
    let offsets: &[i32] = if quick { &[0] } else { &[-5000, 0, 5000] };
    let noises: &[u32] = if quick { &[0, 1] } else { &[0, 1, 3] };
    let mut cases = Vec::new();
    let mut seed = 0;
    for (i, &baud) in Baud::ALL.iter().enumerate() {
        let far = Baud::ALL[(i + 5 + (i % 2) * 4) % 10];
        for from in [None, Some(far)] {
            if quick && from.is_some() && i % 3 != 0 {
                continue;
            }
            for &ppm in offsets {
                for &noise in noises {
                    seed += 1;
                    cases.push(master_case(oversampled, baud, ppm, noise, from, seed));
                }
            }
        }
    }
    let random: &[Baud] = if quick {
        &[Baud::B1500000]
    } else {
        &[Baud::B187500, Baud::B1500000, Baud::B12000000]
    };
    for (i, &baud) in random.iter().enumerate() {
        cases.push(random_case(oversampled, baud, 1000 + i as u64, 2_000_000));
    }
    let shifts: &[i64] = if quick { &[0] } else { &[-2, 0, 3] };
    for &baud in &Baud::ALL {
        let bit = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_per_bit();
        for &shift in shifts {
            for ppm in [3000, 5000] {
                cases.push(stop_glitch_case(oversampled, baud, ppm, bit / 8 + 1, shift));
            }
        }
    }
    // Glitches late in the start bit, as hundredths of a bit (at, length).
    let late: &[(u64, u64)] = if quick {
        &[(76, 20), (86, 10)]
    } else {
        &[
            (64, 30),
            (70, 30),
            (76, 20),
            (80, 10),
            (80, 20),
            (86, 10),
            (90, 10),
        ]
    };
    for &baud in &Baud::ALL[..6] {
        for &(at, len) in late {
            cases.push(start_glitch_case(oversampled, baud, at, len));
        }
    }
    if oversampled {
        cases.extend(rise_at_end_cases(quick).into_iter().map(|(c, _)| c));
    }
    cases
}

/// A start delimiter decided at its stop bit's end with its line rising on that end tick
/// itself, the bound of `Detection::rose_after_end` (a rise after the end) met exactly: from
/// a master 5,000 ppm slow, the line low from `at` hundredths of a bit into the delimiter for
/// `len` hundredths, over its stop bit's middle to the end. The transceiver's schedule only:
/// a scan of glitches over the stop bit (10.00 to 11.10 bits in, 0.03 to 0.60 bit long, with
/// and without a second start in the start bit, masters at -5,000, 0 and +5,000 ppm) met the
/// bound at 9.6k and 19.2k alone, with these. Returns the case and its detections that met it.
fn rise_at_end_case(baud: Baud, at: i64, len: i64) -> (Case, u32) {
    let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, -5000);
    let bit = master.clocks_per_bit() as i64;
    glitched_case(
        true,
        master,
        &[(at * bit / 100, (len * bit / 100) as u64)],
        format!("{baud}-rise-at-end-{at}-{len}"),
    )
}

/// [`rise_at_end_case`]s: 19.2k (`quick`), or 9.6k and 19.2k.
fn rise_at_end_cases(quick: bool) -> Vec<(Case, u32)> {
    let cases: &[(Baud, i64, i64)] = if quick {
        &[(Baud::B19200, 1046, 60)]
    } else {
        &[
            (Baud::B9600, 1044, 60),
            (Baud::B9600, 1048, 60),
            (Baud::B19200, 1046, 60),
            (Baud::B19200, 1048, 60),
        ]
    };
    cases
        .iter()
        .map(|&(baud, at, len)| rise_at_end_case(baud, at, len))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The channels' figures in the gateware are the model's. After a change of the model's
    /// figures, `RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check` writes the files anew.
    #[test]
    fn the_gateware_channels_have_the_models_figures() {
        for (file, want) in [
            ("autobaud_channels.svh", channels_svh()),
            ("autobaud_slots.svh", slots_svh()),
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../gateware/rtl")
                .join(file);
            if std::env::var_os("RTL_CHECK_WRITE_SVH").is_some() {
                std::fs::write(&path, &want).expect("writing the channels");
            }
            let have = std::fs::read_to_string(&path).expect(file);
            assert!(
                have == want,
                "gateware/rtl/{file} is not the model's: \
                 RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check writes it"
            );
        }
    }
}

#[cfg(test)]
mod coverage {
    use super::*;

    /// The rise-at-end cases, quick and full, each decide a delimiter whose line rose on its
    /// end tick (`rose_after_end` false; with `>=` for `>` in autobaud_shared.v's bound,
    /// rtl-check finds the quick case).
    #[test]
    fn the_rise_bound_is_met() {
        for (case, met) in rise_at_end_cases(true)
            .into_iter()
            .chain(rise_at_end_cases(false))
        {
            assert!(met >= 1, "{}: the bound not met", case.name);
        }
    }

    /// The quick set has detections whose channel's idle line has an edge a next one would
    /// still cancel (the transceiver's copy of the line goes on from it), in the transceiver's
    /// build and the every-clock one.
    #[test]
    fn the_quick_cases_detect_with_a_pending_edge() {
        for oversampled in [true, false] {
            let pending = autobaud_cases(true, oversampled)
                .iter()
                .flat_map(|c| &c.model_events)
                // Payload: mask (2), kind, rate, byte, start age (4), pending left (4).
                .filter(|e| e.payload[2] == 1 && e.payload[9..13] != [0; 4])
                .count();
            assert!(pending >= 10, "oversampled {oversampled}: {pending}");
        }
    }

    /// The quick set has detections decided after their channel's line rose past the
    /// character's end (the transceiver's copy of the line counts from the decision), in the
    /// transceiver's build and the every-clock one.
    #[test]
    fn the_quick_cases_detect_after_the_next_rise() {
        for oversampled in [true, false] {
            let cases = autobaud_cases(true, oversampled);
            let late: Vec<&str> = cases
                .iter()
                .filter(|c| {
                    // Payload: mask (2), kind, rate, byte, start age (4), pending left (4),
                    // rose after the end.
                    c.model_events
                        .iter()
                        .any(|e| e.payload[2] == 1 && e.payload[13] == 1)
                })
                .map(|c| c.name.as_str())
                .collect();
            assert!(late.len() >= 6, "oversampled {oversampled}: {late:?}");
        }
    }
}
