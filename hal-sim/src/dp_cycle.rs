//! Ten adapters on one line: the DP cycle a profirust master reaches with them, against the
//! floor the line allows (`cargo xtask dp-cycle`).
//!
//! One bus, one profirust `DpMaster` with one peripheral per adapter, and ten adapters, each
//! its own transceiver model and [`Bridge`] with the firmware's logic in-process (the
//! transceiver answers Data_Exchange from its buffers, so the firmware's own time does not
//! enter the cycle; the link and the MCU are charged as on the board all the same). The run
//! measures the master's cycle once every adapter is in data exchange, and classifies every
//! bit time of the measured cycles by what the line carried.
//!
//! The floor is the line time of one cycle at min TSDR: for each slave TSYN (33 idle bit
//! times), the request, min TSDR (11) and the response.

use crate::bridge::Bridge;
use crate::cosim::{echo_user_prm, CLOCK_HZ};
use crate::firmware::InProcess;
use crate::master::MasterPhy;
use dp_consts::Baud;
use dp_phy::bus::{Bus, FaultInjector};
use dp_phy::delimiter::Status as TelegramStatus;
use dp_phy::responder::DECISION_CLOCKS;
use dp_phy::{BitTiming, Tick, Transceiver};
use profidrive::ppo::Ppo;
use profirust::dp::{DpMaster, Peripheral, PeripheralOptions};
use profirust::fdl::{FdlActiveStation, ParametersBuilder};
use std::io;

/// The master's address, and the first adapter's (the others follow it).
pub const MASTER_ADDRESS: u8 = 1;
pub const FIRST_ADDRESS: u8 = 2;

/// Where the bit times of the measured cycles went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Breakdown {
    /// Data_Exchange requests and responses on the line.
    pub request_bits: u64,
    pub response_bits: u64,
    /// From each request's end to its response's start: the adapters' part.
    pub tsdr_bits: u64,
    /// The idle line before each request, up to TSYN (33 bit times): the line's own rule.
    pub tsyn_bits: u64,
    /// The master's GAP poll: its FDL_Status requests, the answers, and the slot time it
    /// waits where no station answers (idle included).
    pub gap_bits: u64,
    /// The rest of the master's: its token, Global_Control, and its idle time beyond TSYN.
    pub master_bits: u64,
}

/// One run's result.
#[derive(Clone, Debug)]
pub struct CycleRun {
    pub baud: Baud,
    pub ppo: Ppo,
    pub slaves: usize,
    /// The master's median cycle, and the floor, in µs.
    pub cycle_us: f64,
    pub floor_us: f64,
    /// Per measured cycle, on average (their sum is the mean cycle, `mean_cycle_bits`).
    pub breakdown: Breakdown,
    pub mean_cycle_bits: u64,
    pub cycles_measured: usize,
    /// The adapters' longest TSDR, in bit times.
    pub worst_tsdr_bits: u64,
}

impl CycleRun {
    pub fn ratio(&self) -> f64 {
        self.cycle_us / self.floor_us
    }
}

struct Adapter {
    phy: Transceiver,
    bridge: Bridge<InProcess>,
    /// A response waits to start: the end of its request.
    pending: Option<Tick>,
}

fn ns(ticks: Tick) -> u64 {
    ticks * 1000 / u64::from(CLOCK_HZ / 1_000_000)
}

/// The bytes of a Data_Exchange request and of its response with `ppo`'s process data.
pub fn data_exchange_bytes(ppo: Ppo) -> (usize, usize) {
    let io = dp_slave::cfg::io_sizes(ppo.cfg()).expect("a PPO sizes");
    let outputs = vec![0u8; io.outputs];
    let inputs = vec![0u8; io.inputs];
    let request = fdl::Repr::Data(fdl::DataRepr {
        da: FIRST_ADDRESS,
        sa: MASTER_ADDRESS,
        dsap: None,
        ssap: None,
        fc: fdl::FrameControl::Request {
            fcb: true,
            fcv: true,
            function: fdl::RequestFunction::SrdHigh,
        },
        payload: &outputs,
    });
    let response = fdl::Repr::Data(fdl::DataRepr {
        da: MASTER_ADDRESS,
        sa: FIRST_ADDRESS,
        dsap: None,
        ssap: None,
        fc: fdl::FrameControl::slave_response(fdl::ResponseStatus::DataLow),
        payload: &inputs,
    });
    (request.buffer_len(), response.buffer_len())
}

/// The floor of one cycle: for each slave TSYN + request + min TSDR + response, in bit times.
pub fn floor_bits(ppo: Ppo, slaves: usize) -> u64 {
    let (request, response) = data_exchange_bytes(ppo);
    let bits = |bytes: usize| u64::from(dp_consts::BITS_PER_CHAR) * bytes as u64;
    let per_slave = u64::from(dp_consts::TSYN_BITS)
        + bits(request)
        + u64::from(dp_consts::MIN_TSDR_BITS)
        + bits(response);
    per_slave * slaves as u64
}

/// The master's highest station address (HSA) by default: just above the last adapter.
pub fn default_hsa(slaves: usize) -> u8 {
    FIRST_ADDRESS + slaves as u8
}

/// Runs `slaves` adapters with `ppo` at `baud` until `cycles` cycles were measured, the
/// master's HSA at `hsa`.
pub fn run(baud: Baud, ppo: Ppo, slaves: usize, cycles: usize, hsa: u8) -> io::Result<CycleRun> {
    if slaves == 0
        || usize::from(FIRST_ADDRESS) + slaves > 126
        || hsa <= MASTER_ADDRESS
        || hsa > 126
    {
        return Err(io::Error::other(format!(
            "{slaves} adapters from address {FIRST_ADDRESS} with HSA {hsa}: the adapters need \
             addresses up to 125 and the HSA lies above the master's address {MASTER_ADDRESS}, \
             at most 126"
        )));
    }
    let timing = BitTiming::new(CLOCK_HZ, baud, 0);
    let cpb = timing.clocks_per_bit();
    let mut bus = Bus::new(FaultInjector::none());
    let mut master_phy = MasterPhy::new(timing);
    let mut dp = DpMaster::new(vec![]);
    let io = dp_slave::cfg::io_sizes(ppo.cfg()).expect("a PPO sizes");
    let user_prm: &'static [u8] = echo_user_prm().encode().to_vec().leak();
    let mut handles = Vec::new();
    for i in 0..slaves {
        let options = PeripheralOptions {
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            user_parameters: Some(user_prm),
            config: Some(ppo.cfg()),
            max_tsdr: baud.adapter_max_tsdr_bits(),
            fail_safe: true,
            ..Default::default()
        };
        handles.push(dp.add(Peripheral::new(
            FIRST_ADDRESS + i as u8,
            options,
            vec![0u8; io.inputs],
            vec![0u8; io.outputs],
        )));
    }
    let mut fdl = FdlActiveStation::new(
        ParametersBuilder::new(MASTER_ADDRESS, crate::cosim::profirust_baud(baud))
            // By default HSA is just above the last station, as one tunes it for speed. One
            // master on the line never ends its GAP scan in profirust 0.6 (`next_gap_poll` only
            // stops at the next master, which is itself), so it polls one address of the GAP
            // every token rotation: with HSA here, ten of every twelve polls reach an adapter
            // that answers in min TSDR, and two wait a slot time (address 0, and the master's
            // own); with HSA 126 nearly every rotation would wait one.
            .highest_station_address(hsa)
            .gap_wait_rotations(100)
            .watchdog_timeout(profirust::time::Duration::from_millis(200))
            .build_verified(&dp),
    );
    fdl.set_online();
    dp.enter_operate();

    let mut adapters: Vec<Adapter> = (0..slaves)
        .map(|i| {
            let mut bridge = Bridge::new(InProcess::new(), CLOCK_HZ, FIRST_ADDRESS + i as u8);
            bridge.boot(0);
            Adapter {
                phy: Transceiver::new(dp_phy::Config {
                    clock_hz: CLOCK_HZ,
                    ..dp_phy::Config::default()
                }),
                bridge,
                pending: None,
            }
        })
        .collect();

    let poll_ticks = cpb.max(u64::from(CLOCK_HZ / 1_000_000));
    let mut now: Tick = 0;
    let mut next_poll: Tick = 0;
    let limit = now + u64::from(CLOCK_HZ) * 20;
    let mut cycle_ends: Vec<Tick> = Vec::new();
    let mut measuring_from: Option<Tick> = None;
    // The line's telegrams as the first adapter's transceiver heard them: (start, end, kind).
    let mut heard: Vec<(Tick, Tick, Kind)> = Vec::new();
    let mut worst_tsdr: u64 = 0;
    let mut outputs_counter: u8 = 0;
    let mut answers = Answers::default();
    while now < limit && cycle_ends.len() < cycles + 1 {
        if now >= next_poll {
            master_phy.now = now;
            let t = profirust::time::Instant::from_micros((ns(now) / 1000) as i64);
            fdl.poll(t, &mut master_phy, &mut dp);
            let events = dp.take_last_events();
            if events.cycle_completed {
                let running = handles.iter().all(|h| dp.get_mut(*h).is_running());
                if running {
                    if measuring_from.is_none() {
                        measuring_from = Some(now);
                    }
                    cycle_ends.push(now);
                    outputs_counter = outputs_counter.wrapping_add(1);
                    for h in &handles {
                        dp.get_mut(*h).pi_q_mut().fill(outputs_counter);
                    }
                }
            }
            next_poll = now + poll_ticks;
        }
        for a in &mut adapters {
            a.bridge.poll(ns(now))?;
            a.phy.set_min_tsdr(a.bridge.responder.min_tsdr_bits());
        }
        let master_drive = master_phy.tx.drive();
        let mut drivers = vec![master_drive];
        drivers.extend(adapters.iter().map(|a| a.phy.drive()));
        let line = bus.resolve(now, drivers.iter().copied());
        let busy = !line || drivers.iter().any(Option::is_some);
        let mut quiet = (next_poll - now).max(1);
        quiet = quiet
            .min(master_phy.tx.quiet_for())
            .min(master_phy.rx.quiet_for(line, master_drive.is_some()));
        for a in &adapters {
            quiet = quiet.min(a.phy.quiet_for(line));
            if let Some(at) = a.bridge.next_ns() {
                let at_ticks = (at * u64::from(CLOCK_HZ / 1_000_000)).div_ceil(1000);
                quiet = quiet.min(at_ticks.saturating_sub(now).max(1));
            }
        }
        let step = if quiet > 1 && !busy { quiet } else { 1 };
        if busy {
            master_phy.last_activity = now;
        }
        for (i, a) in adapters.iter_mut().enumerate() {
            let out = if step == 1 {
                a.phy.tick(line)
            } else {
                a.phy.advance(line, step).1
            };
            if a.pending.is_some() && a.phy.drive().is_some() {
                let request_end = a.pending.take().expect("checked");
                worst_tsdr = worst_tsdr.max((now - request_end) / cpb);
            }
            if out.telegram {
                let t = a.phy.telegram();
                if t.status != TelegramStatus::Good {
                    continue;
                }
                let bytes = t.bytes().to_vec();
                let end = t.end;
                // The master's telegrams as adapters 0 and 1 hear them (a slave's transceiver
                // takes only telegrams after TSYN, so the answers are collected at the master;
                // and it does not hear the line while it answers itself).
                let start = end.saturating_sub(11 * bytes.len() as u64 * cpb);
                if i < 2 && !heard.iter().rev().take(4).any(|h| h.1.abs_diff(end) < cpb) {
                    heard.push((start, end, classify(&bytes)));
                }
                let baud_index = baud.index() as u8;
                if let Some(response) = a.bridge.telegram(ns(end), baud_index, &bytes) {
                    if a.phy.respond(&response, end + DECISION_CLOCKS) {
                        a.pending = Some(end);
                    }
                }
            }
        }
        if step == 1 {
            if let Some(ch) = master_phy.rx.tick(line, master_drive.is_some()) {
                if ch.error.is_none() {
                    master_phy.received.push(ch.byte);
                    answers.push(ch.byte, ch.start, ch.end, cpb, &mut heard);
                } else {
                    master_phy.char_errors += 1;
                }
            }
            master_phy.tx.tick();
        } else {
            master_phy.rx.skip(step);
            master_phy.tx.skip(step);
        }
        now += step;
        master_phy.now = now;
    }
    if cycle_ends.len() < cycles + 1 {
        return Err(io::Error::other(format!(
            "{baud} {ppo:?}: only {} cycles with every adapter in data exchange",
            cycle_ends.len()
        )));
    }
    answers.flush(&mut heard);
    heard.sort_by_key(|h| h.0);
    let (from, to) = (cycle_ends[0], cycle_ends[cycles]);
    let mut intervals: Vec<u64> = cycle_ends.windows(2).map(|w| w[1] - w[0]).collect();
    intervals.sort_unstable();
    let median_ticks = intervals[intervals.len() / 2];
    let bits = |ticks: u64| ticks / cpb;
    let mut b = Breakdown::default();
    let mut last_end = from;
    let mut last_request_end = None;
    let mut after_gap_request = false;
    for (start, end, kind) in heard.iter().filter(|(s, _, _)| *s >= from && *s < to) {
        let idle = bits(start.saturating_sub(last_end));
        let len = bits(end - start);
        match kind {
            Kind::Request => {
                let tsyn = idle.min(u64::from(dp_consts::TSYN_BITS));
                b.tsyn_bits += tsyn;
                // The slot time after an unanswered GAP poll is the GAP's.
                if after_gap_request {
                    b.gap_bits += idle - tsyn;
                } else {
                    b.master_bits += idle - tsyn;
                }
                b.request_bits += len;
                last_request_end = Some(*end);
            }
            Kind::Response if last_request_end.take().is_some() => {
                b.tsdr_bits += idle;
                b.response_bits += len;
            }
            Kind::Gap => b.gap_bits += idle + len,
            Kind::Response | Kind::Other if after_gap_request => b.gap_bits += idle + len,
            Kind::Response | Kind::Other => b.master_bits += idle + len,
        }
        after_gap_request = *kind == Kind::Gap;
        last_end = *end;
    }
    b.master_bits += bits(to.saturating_sub(last_end));
    let n = cycles as u64;
    let per_cycle = Breakdown {
        request_bits: b.request_bits / n,
        response_bits: b.response_bits / n,
        tsdr_bits: b.tsdr_bits / n,
        tsyn_bits: b.tsyn_bits / n,
        gap_bits: b.gap_bits / n,
        master_bits: b.master_bits / n,
    };
    let bit_us = 1e6 / f64::from(baud.bits_per_second());
    Ok(CycleRun {
        baud,
        ppo,
        slaves,
        cycle_us: ns(median_ticks) as f64 / 1000.0,
        floor_us: floor_bits(ppo, slaves) as f64 * bit_us,
        breakdown: per_cycle,
        mean_cycle_bits: bits(to - from) / n,
        cycles_measured: cycles,
        worst_tsdr_bits: worst_tsdr,
    })
}

/// What a telegram on the line is, for the breakdown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A Data_Exchange request (no SAP, from the master).
    Request,
    /// A slave's answer to one.
    Response,
    /// The master's GAP poll (an FDL_Status request) and a station's answer to it.
    Gap,
    Other,
}

/// The characters the master receives (the slaves' answers), grouped into telegrams: a
/// telegram's characters follow each other without a gap.
#[derive(Default)]
struct Answers {
    bytes: Vec<u8>,
    start: Tick,
    end: Tick,
}

impl Answers {
    fn push(
        &mut self,
        byte: u8,
        start: Tick,
        end: Tick,
        cpb: Tick,
        heard: &mut Vec<(Tick, Tick, Kind)>,
    ) {
        if !self.bytes.is_empty() && start > self.end + 2 * cpb {
            self.flush(heard);
        }
        if self.bytes.is_empty() {
            self.start = start;
        }
        self.bytes.push(byte);
        self.end = end;
    }

    fn flush(&mut self, heard: &mut Vec<(Tick, Tick, Kind)>) {
        if !self.bytes.is_empty() {
            heard.push((self.start, self.end, classify(&self.bytes)));
            self.bytes.clear();
        }
    }
}

fn classify(bytes: &[u8]) -> Kind {
    match fdl::Repr::parse_bytes(bytes) {
        Ok((fdl::Repr::Data(d), _)) if d.dsap.is_none() && d.ssap.is_none() => match d.fc {
            fdl::FrameControl::Request {
                function: fdl::RequestFunction::SrdHigh | fdl::RequestFunction::SrdLow,
                ..
            } if d.da >= FIRST_ADDRESS => Kind::Request,
            fdl::FrameControl::Request {
                function: fdl::RequestFunction::FdlStatus,
                ..
            } => Kind::Gap,
            fdl::FrameControl::Response { .. } if d.payload.is_empty() => Kind::Gap,
            fdl::FrameControl::Response { .. } if d.sa >= FIRST_ADDRESS => Kind::Response,
            _ => Kind::Other,
        },
        Ok((fdl::Repr::ShortAck, _)) => Kind::Response,
        _ => Kind::Other,
    }
}
