//! The transceiver's receive path (`gateware/rtl/transceiver.v`: the synchroniser, the search,
//! the receiver, its idle lines, the delimiter, the baud watchdog and the trial, lock and
//! fallback registers) against `dp_phy::Transceiver`, on the baud sweep's cases
//! ([`dp_phy::sweep`]): the line each case puts on the bus, clock by clock, with the model run
//! strict. Compared every clock: a delivery, the baud state, a telegram and a character under
//! way; and each delivery (status, length, end tick, bytes), each change of the baud state
//! (rate, fallback) and of the idle line at the rate heard (idle since when: what TSDR counts
//! from) as events.
//!
//! The rates' figures are the model's: [`rates_svh`] writes `gateware/rtl/transceiver_rates.svh`
//! from the model's search, receiver and configuration, and a test holds the file equal to it.

use super::edge_rx::{receiver, receiver_width};
use super::status_code;
use crate::{Block, Case, Event, Trace};
use dp_consts::Baud;
use dp_phy::autobaud::AutoBaud;
use dp_phy::sweep::{self, SweepCase};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::{BaudState, BitTiming, Config, Transceiver};
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
        ],
        signals: &["telegram", "trial", "locked", "in_telegram", "rx_active"],
        params: vec![("PhaseWidth", i64::from(receiver_width()))],
        twin: "dp_phy::transceiver::Transceiver",
        events: true,
    }
}

const SVH_HEADER: &str = "// Written by crates/rtl-check (`blocks::transceiver`) from the model at 48 MHz: each\n\
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
        let _ = write!(s, "      default: {name} = '0;\n    endcase\n  endfunction\n");
    };
    function(
        "rate_reader",
        "logic [RateReaderWidth-1:0]",
        "",
        &|b| {
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
        },
    );
    function(
        "rate_age_clocks",
        "logic [31:0]",
        ", input logic [15:0] age",
        &|b| format!("32'(age) * 32'd{}", schedule.period[b.index()]),
    );
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
                | u8::from(probe.rx_active) << 4,
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

    fn flush(&mut self) {
        if let Some((level, n)) = self.run.take() {
            self.stimulus.push(b'L');
            self.stimulus.push(u8::from(level));
            self.stimulus.extend(n.to_le_bytes());
        }
    }
}

/// One sweep case, strict, with what the adapter saw and did at every clock.
pub fn sweep_case(case: &SweepCase) -> Case {
    let recorder = Rc::new(RefCell::new(Recorder::new()));
    let observer = recorder.clone();
    let run = sweep::drive(case, &Config::default(), false, move |tb| {
        tb.observe(Box::new(move |line, adapter, out| {
            observer.borrow_mut().clock(line, adapter, out.telegram)
        }))
    });
    drop(run);
    let mut r = Rc::try_unwrap(recorder)
        .ok()
        .expect("the bench is gone")
        .into_inner();
    r.flush();
    Case {
        name: format!("transceiver-{case}"),
        stimulus: r.stimulus,
        model: r.trace,
        model_events: r.events,
    }
}

/// The sweep's cases (`quick`: a few of its quick set, which fit CI's time).
pub fn transceiver_cases(quick: bool) -> Vec<Case> {
    let all = sweep::cases(quick);
    let chosen: Vec<&SweepCase> = if quick {
        all.iter().step_by(11).collect()
    } else {
        all.iter().collect()
    };
    chosen.into_iter().map(sweep_case).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
