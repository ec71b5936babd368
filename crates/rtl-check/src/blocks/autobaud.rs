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
use dp_phy::autobaud::{AutoBaud, AutoBaudQ, Reject, AUTOBAUD_RESET};
use dp_phy::bus::FaultInjector;
use dp_phy::filter::{self, FilterOut, FilterQ, FILTER_RESET};
use dp_phy::testbench::{poll_sequence, random_telegram, Kind, Testbench};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::{BitTiming, Config};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

/// The search as the transceiver builds it, or (`oversampled`) with the channels up to
/// 1.5 Mbit/s sampling the line every few clocks.
pub fn autobaud(oversampled: bool) -> Block {
    Block {
        top: "autobaud",
        rtl: &["autobaud.v", "autobaud_channel.v", "char_reader.v"],
        signals: &["valid", "detect", "measuring"],
        params: vec![("Oversampled", i64::from(oversampled))],
        twin: "dp_phy::autobaud::AutoBaud",
        events: true,
    }
}

/// The clocks between each channel's samples in the build with `Oversampled` set or not.
pub fn periods(oversampled: bool) -> [u64; 10] {
    if oversampled {
        dp_phy::autobaud::OVERSAMPLED
    } else {
        dp_phy::autobaud::EVERY_CLOCK
    }
}

/// The channels' instances with the model's figures (`gateware/rtl/autobaud_channels.svh`):
/// one set sampling every clock, one oversampling, chosen by autobaud.v's `Oversampled`.
pub fn channels_svh() -> String {
    let mut s = String::from(
        "// Written by crates/rtl-check (`blocks::autobaud::channels_svh`) from\n\
         // dp_phy::autobaud::AutoBaud::channel_figures at 48 MHz: one channel per rate, 9.6k\n\
         // first, every figure in the channel's samples. A test holds this file equal to the\n\
         // model's figures; do not edit.\n",
    );
    for oversampled in [true, false] {
        let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, periods(oversampled));
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
        for (r, baud) in Baud::ALL.iter().enumerate() {
            let f = search.channel_figures(*baud);
            let c = f.reader;
            // The model's figures are clocks, whole samples each.
            let (glitch, tsyn, stop_middle, stop_end) = (
                f.glitch / f.period,
                f.tsyn / f.period,
                f.stop_middle / f.period,
                f.stop_end / f.period,
            );
            let _ = write!(
                s,
                "\n    // {baud}, a sample every {} clock(s)\n    autobaud_channel #(\n      \
                 .PhaseWidth({}), .Inc({}), .Modulo({}), .Quarter({}), .ThreeQuarters({}),\n      \
                 .HalfLessInc({}), .TwoInc({}), .ModuloLessInc({}), .ModuloLessTwoInc({}),\n      \
                 .Glitch({glitch}), .Tsyn({tsyn}), .StopMiddle({stop_middle}), .StopEnd({stop_end}),\n      \
                 .StartBitClocks({}), .Period({}),\n      \
                 .IdleWidth({}), .PendWidth({}), .TimeWidth({}), .AltWidth({}),\n      \
                 .StartAgeWidth(TimeWidth), .AltOutWidth(AltWidth)\n    \
                 ) u_channel_{r} (\n      \
                 .clk_i, .rst_ni, .level_i,\n      \
                 .heard_i(heard[{r}]), .heard_any_i(heard_valid_i), .detect_o(detect[{r}]),\n      \
                 .reject_o(reject[{r}]), .reject_code_o(reject_code[{r} * 2 +: 2]),\n      \
                 .byte_o(bytes[{r} * 8 +: 8]), .since_t0_o(since_t0[{r} * TimeWidth +: TimeWidth]),\n      \
                 .offset_o(offset[{r} * AltWidth +: AltWidth]), .measuring_o(measuring_o[{r}])\n    );\n",
                f.period,
                bits_for(c.modulo),
                c.inc,
                c.modulo,
                c.quarter,
                c.three_quarters,
                c.half_less_inc,
                c.two_inc,
                c.modulo_less_inc,
                c.modulo_less_two_inc,
                f.start_bit_clocks,
                f.period,
                bits_for(tsyn),
                bits_for(glitch + 1),
                bits_for(f.start_bit_clocks + stop_end),
                bits_for(f.start_bit_clocks),
            );
        }
        s.push_str("  end\n");
    }
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
    periods: [u64; 10],
    q: AutoBaudQ,
    sync: FilterQ,
    now: u64,
    run: Option<(bool, u8, u32)>,
    stimulus: Vec<u8>,
    trace: Trace,
    events: Vec<Event>,
    mask: u16,
}

impl SearchCase {
    fn new(oversampled: bool) -> SearchCase {
        SearchCase {
            search: AutoBaud::sampled(DEFAULT_CLOCK_HZ, periods(oversampled)),
            periods: periods(oversampled),
            q: AUTOBAUD_RESET,
            sync: FILTER_RESET,
            now: 0,
            run: None,
            stimulus: Vec::new(),
            trace: Trace::default(),
            events: Vec::new(),
            mask: 0,
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
        let mut payload = mask.to_le_bytes().to_vec();
        match out {
            Some(Ok(d)) => {
                value |= 0b11;
                payload.extend([1, d.baud.index() as u8, d.byte]);
                // In the detecting channel's samples, as the RTL counts.
                let age = (self.now - d.start) / self.periods[d.baud.index()];
                payload.extend((age as u32).to_le_bytes());
            }
            Some(Err(e)) => {
                value |= 0b01;
                payload.extend([2, 0, reject_code(e)]);
                payload.extend(0u32.to_le_bytes());
            }
            None => payload.extend([0, 0, 0, 0, 0, 0, 0]),
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
        search_periods: periods(oversampled),
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
    cases
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The channels' figures in the gateware are the model's. After a change of the model's
    /// figures, `RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check` writes the file anew.
    #[test]
    fn the_gateware_channels_have_the_models_figures() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../gateware/rtl/autobaud_channels.svh");
        let want = channels_svh();
        if std::env::var_os("RTL_CHECK_WRITE_SVH").is_some() {
            std::fs::write(&path, &want).expect("writing the channels");
        }
        let have = std::fs::read_to_string(&path).expect("gateware/rtl/autobaud_channels.svh");
        assert!(
            have == want,
            "gateware/rtl/autobaud_channels.svh is not the model's: \
             RTL_CHECK_WRITE_SVH=1 cargo test -p rtl-check writes it"
        );
    }
}
