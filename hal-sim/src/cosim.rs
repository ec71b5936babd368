//! The co-simulation: one clock for the whole bus.
//!
//! ```text
//! profirust ─► MasterPhy (UART TX, bit by bit) ─► line ◄─ faults
//!      ▲                                            │
//!      └── MasterPhy (UART RX) ◄────────────────────┤
//!                                                   ▼
//!                     transceiver model (autobaud, delimiter, TX after min TSDR)
//!                        │ good telegram             ▲ the responder's answer, at once
//!                        ▼                           │ (from the buffers the firmware wrote)
//!                     Bridge: responder ◄─ writes ─ link ◄─ Firmware (QEMU or in-process)
//!                                       ── events ─► link ─►
//! ```
//! Simulated time stops while the firmware works: its time enters as the instructions it
//! reports, at the production board's clock, and the link's bytes at the board's link rate
//! ([`crate::bridge`]). Time is ticks of the transceiver's sample clock; the firmware sees it
//! as microseconds in each event.

use crate::bridge::Bridge;
use crate::firmware::Firmware;
use crate::master::MasterPhy;
use dp_consts::Baud;
use dp_link::NvRecord;
use dp_phy::bus::{Bus, FaultInjector};
use dp_phy::delimiter::Status as TelegramStatus;
use dp_phy::responder::DECISION_CLOCKS;
use dp_phy::{BaudState, BitTiming, Tick, Transceiver};
use drive_sim::DriveSim;
use profidrive::codes::FunctionCode;
use profidrive::drive::PZD1_LINK_ERROR;
use profidrive::ppo::Ppo;
use profidrive::prm::UserPrm;
use profidrive::words::control;
use profirust::dp::{DpMaster, Peripheral, PeripheralHandle, PeripheralOptions};
use profirust::fdl::{FdlActiveStation, ParametersBuilder};
use std::io;

/// The transceiver's sample clock.
pub const CLOCK_HZ: u32 = 48_000_000;

/// What the master does and how it sees the slave.
#[derive(Clone, Debug)]
pub struct MasterSetup {
    pub baud: Baud,
    pub ppm: i32,
    pub address: u8,
    pub slave_address: u8,
    pub ident_number: u16,
    pub config: Vec<u8>,
    pub user_prm: Vec<u8>,
    pub watchdog_ms: u64,
    /// Set_Prm asks for Sync and Freeze (Sync_Req, Freeze_Req), which Global_Control then
    /// commands.
    pub sync_freeze: bool,
}

impl MasterSetup {
    pub fn new(baud: Baud, slave_address: u8) -> MasterSetup {
        MasterSetup {
            baud,
            ppm: 0,
            address: 2,
            slave_address,
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            config: Ppo::Ppo1.cfg().to_vec(),
            user_prm: echo_user_prm().encode().to_vec(),
            watchdog_ms: 200,
            sync_freeze: false,
        }
    }
}

/// The vendor profile's default parameters, with PZD2 in read from D0.01 (the set frequency)
/// so that PZD2 out (to F0.29) comes back through the drive: [`Program::EchoThroughDrive`].
pub fn echo_user_prm() -> UserPrm {
    let mut prm = UserPrm::DEFAULT;
    prm.rd_pzd[0] = FunctionCode(drive_sim::SET_FREQUENCY_STATUS);
    prm
}

/// What the master puts in the outputs each data exchange cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Program {
    /// PPO1, control word "run", PZD2 a set frequency that steps every 16 cycles. The
    /// inputs' PZD2 must always be one the master sent (read back from D0.01), and PZD1 never
    /// the link error 0xC0xx: the whole chain through the drive, checked every cycle.
    EchoThroughDrive,
    /// The scenario writes `outputs` and reads `inputs` itself.
    Manual,
}

/// The control word the echo program runs the drive with.
pub const ECHO_CONTROL_WORD: u16 =
    control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

/// The profirust master: its FDL station and DP application, over its PHY.
pub struct Master {
    pub phy: MasterPhy,
    pub fdl: FdlActiveStation,
    pub dp: DpMaster<'static>,
    pub handle: PeripheralHandle,
    pub setup: MasterSetup,
    /// Data exchange cycles completed.
    pub cycles: u64,
    pub program: Program,
    /// The outputs sent last, and the inputs received last.
    pub outputs: Vec<u8>,
    pub inputs: Vec<u8>,
    /// The echo program: PZD2 values sent, inputs that carried one of them, inputs wrong.
    sent: std::collections::BTreeSet<u16>,
    pub inputs_checked: u64,
    pub inputs_wrong: u64,
    /// A commissioning tool, not profirust: only the PHY is used, by [`CoSim::tool_request`].
    pub tool: bool,
    /// Where the echo program's PZD1 and PZD2 are in the outputs (8, after the PKW, for
    /// PPO1; none for a PPO it does not run).
    pub echo_at: Option<usize>,
    /// A DP-V1 class-1 requester beside profirust's DP master, on the same FDL station.
    pub msac1: Option<crate::msac1_master::Msac1Requester>,
}

/// profirust's name for a rate.
pub fn profirust_baud(baud: Baud) -> profirust::Baudrate {
    use profirust::Baudrate as B;
    match baud {
        Baud::B9600 => B::B9600,
        Baud::B19200 => B::B19200,
        Baud::B45450 => B::B45450,
        Baud::B93750 => B::B93750,
        Baud::B187500 => B::B187500,
        Baud::B500000 => B::B500000,
        Baud::B1500000 => B::B1500000,
        Baud::B3000000 => B::B3000000,
        Baud::B6000000 => B::B6000000,
        Baud::B12000000 => B::B12000000,
    }
}

impl Master {
    pub fn new(setup: MasterSetup, now: Tick) -> Master {
        let timing = BitTiming::new(CLOCK_HZ, setup.baud, setup.ppm);
        let mut phy = MasterPhy::new(timing);
        phy.now = now;
        phy.last_activity = now;
        let mut dp = DpMaster::new(vec![]);
        let io = dp_slave::cfg::io_sizes(&setup.config).unwrap_or_default();
        let options = PeripheralOptions {
            ident_number: setup.ident_number,
            // profirust borrows these for the master's lifetime ('static here); a few bytes
            // per master started, for the length of a test run.
            user_parameters: Some(setup.user_prm.clone().leak()),
            config: Some(setup.config.clone().leak()),
            max_tsdr: setup.baud.adapter_max_tsdr_bits(),
            fail_safe: true,
            sync_mode: setup.sync_freeze,
            freeze_mode: setup.sync_freeze,
            ..Default::default()
        };
        let handle = dp.add(
            Peripheral::new(
                setup.slave_address,
                options,
                vec![0u8; io.inputs],
                vec![0u8; io.outputs],
            )
            .with_diag_buffer(vec![0u8; 64]),
        );
        let mut fdl = FdlActiveStation::new(
            ParametersBuilder::new(setup.address, profirust_baud(setup.baud))
                .highest_station_address(setup.address.max(2) + 1)
                .watchdog_timeout(profirust::time::Duration::from_millis(setup.watchdog_ms))
                .build_verified(&dp),
        );
        fdl.set_online();
        dp.enter_operate();
        Master {
            phy,
            fdl,
            dp,
            handle,
            outputs: vec![0u8; io.outputs],
            inputs: vec![0u8; io.inputs],
            program: Program::EchoThroughDrive,
            sent: Default::default(),
            setup,
            cycles: 0,
            inputs_checked: 0,
            inputs_wrong: 0,
            tool: false,
            echo_at: (io.outputs == 12).then_some(8),
            msac1: None,
        }
    }

    /// Whether profirust sees the slave in data exchange.
    pub fn running(&mut self) -> bool {
        self.dp.get_mut(self.handle).is_running()
    }

    fn poll(&mut self, now_us: u64) {
        if self.tool {
            return;
        }
        let now = profirust::time::Instant::from_micros(now_us as i64);
        match self.msac1.as_mut() {
            Some(requester) => {
                self.fdl
                    .poll_multi(now, &mut self.phy, &mut [&mut self.dp, requester])
            }
            None => self.fdl.poll(now, &mut self.phy, &mut self.dp),
        }
        let events = self.dp.take_last_events();
        if events.cycle_completed {
            let handle = self.handle;
            let peripheral = self.dp.get_mut(handle);
            if peripheral.is_running() {
                self.cycles += 1;
                self.inputs.copy_from_slice(peripheral.pi_i());
                if let (Program::EchoThroughDrive, Some(at)) = (self.program, self.echo_at) {
                    let word = |b: &[u8], at: usize| u16::from_be_bytes([b[at], b[at + 1]]);
                    let (status, pzd2) = (word(&self.inputs, at), word(&self.inputs, at + 2));
                    if self.cycles > 1 {
                        if status & 0xFF00 == PZD1_LINK_ERROR
                            || !(pzd2 == 0 || self.sent.contains(&pzd2))
                        {
                            self.inputs_wrong += 1;
                        } else if pzd2 != 0 {
                            self.inputs_checked += 1;
                        }
                    }
                    let set_frequency = ((self.cycles / 16) % 49 + 1) as u16 * 100;
                    self.sent.insert(set_frequency);
                    self.outputs.fill(0);
                    self.outputs[at..at + 2].copy_from_slice(&ECHO_CONTROL_WORD.to_be_bytes());
                    self.outputs[at + 2..at + 4].copy_from_slice(&set_frequency.to_be_bytes());
                }
                peripheral.pi_q_mut().copy_from_slice(&self.outputs);
            }
        }
    }
}

/// A response the transceiver was given, until it starts on the line.
#[derive(Clone, Copy, Debug)]
struct Pending {
    request_end: Tick,
}

/// Figures of one run.
#[derive(Clone, Debug, Default)]
pub struct Figures {
    pub locked: Option<Baud>,
    /// Telegrams the master started before the adapter delivered its first good one.
    pub lost_before_lock: Option<u64>,
    /// Telegrams the responder handed to the firmware.
    pub forwarded: u64,
    pub responses: u64,
    /// The longest TSDR on the wire, in bit times, and the rate it was seen at.
    pub worst_tsdr_bits: u64,
    pub worst_tsdr_baud: Option<Baud>,
    /// The longest TSDR at each rate, in bit times.
    pub worst_tsdr_by_rate: std::collections::BTreeMap<Baud, u64>,
    /// From new outputs arriving at the MCU to the firmware's decision back in the
    /// transceiver (its inputs included): the worst and the median, in ns.
    pub worst_outputs_to_inputs_ns: Option<u64>,
    pub median_outputs_to_inputs_ns: Option<u64>,
    /// The master's Data_Exchange cycle to the adapter: the median interval, in ns.
    pub median_dp_cycle_ns: Option<u64>,
    /// Responses that started later than the MaxTsdr the adapter's GSD declares.
    pub late_responses: u64,
    /// Telegrams the transceiver delivered with an error (never forwarded).
    pub bad_telegrams: u64,
    /// Telegrams the transceiver delivered as good that the station on the line did not send
    /// (noise made into a telegram, or one corrupted past its checks): never allowed.
    pub corrupt_delivered: u64,
    /// The first of them, for the report.
    pub first_corrupt: Option<Vec<u8>>,
    /// Tokens (SD4) delivered that no station sent. A token has no FCS, only each
    /// character's parity, which a glitch over two adjacent bits keeps (02h read as 04h): no
    /// receiver can tell, and the adapter, a slave, takes no token. Counted, not a failure.
    pub corrupt_tokens: u64,
    /// Trials from a lock that failed back to it, while they go unlogged
    /// (`CoSim::log_failed_trials`).
    pub trials_failed_back: u64,
    pub collisions: u64,
    /// The firmware's stack at its deepest, where it has one to measure (under QEMU).
    pub stack_peak: Option<crate::firmware::StackPeak>,
    /// The bus time simulated, and the messages the firmware handled in it (a host round trip
    /// each under QEMU) with the steps of its drive application's cycle among them.
    pub simulated_us: u64,
    pub round_trips: u64,
    pub continues: u64,
    pub cycle_steps: u64,
}

/// The whole bus and the board around the firmware.
pub struct CoSim<F: Firmware> {
    pub now: Tick,
    pub bus: Bus,
    pub master: Option<Master>,
    pub adapter: Transceiver,
    /// The transceiver's MCU side: responder, link, firmware, storage, drive.
    pub bridge: Bridge<F>,
    pub figures: Figures,
    /// Data exchange as the adapter saw it (recorded while `log_dx` is set).
    pub log_dx: bool,
    pub dx: DxLog,
    /// The end of each new Data_Exchange request the responder took.
    dx_request_ends: Vec<Tick>,
    /// Set frequencies every master of this run sent (the echo program).
    echo_history: std::collections::BTreeSet<u16>,
    pending: Option<Pending>,
    next_master_poll: Tick,
    last_baud_state: BaudState,
    /// The transceiver's count of failed trials from a lock, at its last change of state.
    relock_trials_failed: u64,
    /// Trials from a lock go into the events (the golden file); a scenario whose noise may
    /// draw one by chance clears this: a trial is then logged only if it passes (as the new
    /// lock), and one that fails back is counted in `figures.trials_failed_back`. Why: the co-simulation's bus timing varies by a
    /// few clocks run to run (a link byte enters QEMU on its main loop), and random noise
    /// then makes a start delimiter at another rate in some runs and not in others.
    pub log_failed_trials: bool,
    /// A waveform of the line and the transceiver, clock by clock, while set (the soak's
    /// reproduction writes one for the event that failed).
    pub tracer: Option<dp_phy::trace::Tracer<std::io::BufWriter<std::fs::File>>>,
    /// The last telegrams of masters and tools no longer on the bus: one of them can still be
    /// in the transceiver's delimiter when its sender goes.
    retired_telegrams: std::collections::VecDeque<Vec<u8>>,
}

fn ticks_from_us(us: u64) -> Tick {
    us * (CLOCK_HZ as u64 / 1_000_000)
}

fn us_from_ticks(ticks: Tick) -> u64 {
    ticks / (CLOCK_HZ as u64 / 1_000_000)
}

fn ns_from_ticks(ticks: Tick) -> u64 {
    ticks * 1000 / (CLOCK_HZ as u64 / 1_000_000)
}

fn ticks_from_ns(ns: u64) -> Tick {
    (ns * (CLOCK_HZ as u64 / 1_000_000)).div_ceil(1000)
}

/// Data exchange as the adapter saw it: each change of the outputs (at the end of the
/// request that brought them) and of the inputs (at the end of the response that carried
/// them).
#[derive(Clone, Debug, Default)]
pub struct DxLog {
    pub outputs: Vec<(u64, Vec<u8>)>,
    pub inputs: Vec<(u64, Vec<u8>)>,
}

impl<F: Firmware> CoSim<F> {
    /// Powers the board up with the switch at `switch` and the storage holding `nv`.
    pub fn new(mut firmware: F, switch: u8, nv: Option<NvRecord>) -> io::Result<CoSim<F>> {
        firmware.set_storage(crate::firmware::nv_image(nv))?;
        let mut sim = CoSim {
            now: 0,
            bus: Bus::new(FaultInjector::none()),
            master: None,
            adapter: Transceiver::new(dp_phy::Config {
                clock_hz: CLOCK_HZ,
                ..dp_phy::Config::default()
            }),
            bridge: Bridge::new(firmware, CLOCK_HZ, switch),
            figures: Figures::default(),
            log_dx: false,
            dx: DxLog::default(),
            dx_request_ends: Vec::new(),
            echo_history: Default::default(),
            pending: None,
            next_master_poll: 0,
            last_baud_state: BaudState::Searching,
            relock_trials_failed: 0,
            log_failed_trials: true,
            tracer: None,
            retired_telegrams: Default::default(),
        };
        sim.bridge.boot(0);
        sim.settle()?;
        Ok(sim)
    }

    /// Runs until the firmware has handled the power-up and its writes are in the transceiver
    /// (a board takes that long before it can answer anything but FDL_Status).
    fn settle(&mut self) -> io::Result<()> {
        let end = self.now + ticks_from_us(10_000);
        self.run_until(end, |s| s.bridge.idle()).map(|_| ())
    }

    /// A power cycle of the board: the firmware restarts from the switch and the storage.
    pub fn power_cycle(&mut self) -> io::Result<()> {
        self.bridge.power_cycle(ns_from_ticks(self.now))?;
        self.adapter = Transceiver::reset_at(self.adapter.config(), self.now);
        self.pending = None;
        self.last_baud_state = BaudState::Searching;
        self.relock_trials_failed = 0;
        self.settle()
    }

    /// Adds `text` to what happened (the soak notes its PLC's steps and the drive's control
    /// word there).
    pub(crate) fn event(&mut self, text: String) {
        self.bridge.events.push(text);
    }

    /// What happened, in order, for the run's report: state and LED changes, locks, storage.
    pub fn events(&self) -> &[String] {
        &self.bridge.events
    }

    /// The figures of the run so far, the link's and the master's cycle included.
    pub fn figures(&self) -> Figures {
        let mut f = self.figures.clone();
        let mut o2i = self.bridge.figures.outputs_to_inputs_ns.clone();
        o2i.sort_unstable();
        f.worst_outputs_to_inputs_ns = o2i.last().copied();
        f.median_outputs_to_inputs_ns = o2i.get(o2i.len() / 2).copied();
        let mut cycles: Vec<u64> = self
            .dx_request_ends
            .windows(2)
            .map(|w| ns_from_ticks(w[1] - w[0]))
            .collect();
        cycles.sort_unstable();
        f.median_dp_cycle_ns = cycles.get(cycles.len() / 2).copied();
        f.simulated_us = self.now_us();
        f.round_trips = self.bridge.figures.round_trips;
        f.continues = self.bridge.figures.continues;
        f.cycle_steps = self.bridge.figures.cycle_steps;
        f
    }

    /// Starts (or replaces) the DP master.
    pub fn start_master(&mut self, setup: MasterSetup) {
        self.event(format!("master: {} at {}", setup.address, setup.baud));
        self.remember_echo();
        self.retire_telegrams();
        let mut master = Master::new(setup, self.now);
        // The drive still holds what earlier masters sent: not "a value never sent".
        master.sent.clone_from(&self.echo_history);
        self.master = Some(master);
        self.next_master_poll = self.now;
    }

    /// A class 2 master's request (a commissioning tool), for services profirust does not
    /// offer (Set_Slave_Add, Get_Cfg, Rd_Inp, ...): sent bit by bit after TSYN, the answer
    /// read back from the line (it must start within `slot_bits`). Replaces any running master.
    pub fn tool_request(
        &mut self,
        setup: MasterSetup,
        request: &[u8],
        slot_bits: u64,
    ) -> io::Result<Option<Vec<u8>>> {
        self.event(format!("tool: request {:02X?}", request));
        self.retire_telegrams();
        let mut tool = Master::new(setup, self.now);
        tool.tool = true;
        tool.phy.send(request);
        let cpb = tool.phy.timing().clocks_per_bit();
        let sent_bits = (request.len() as u64 + 4) * 11;
        self.master = Some(tool);
        // The answer must start within the slot time, and may then take its full length.
        let longest_answer = 11 * dp_consts::MAX_TELEGRAM_LEN as u64;
        let end = self.now
            + (sent_bits + u64::from(dp_consts::TSYN_BITS) + slot_bits + longest_answer) * cpb;
        let answered = self.run_until(end, |s| {
            let received = &s.master.as_ref().unwrap().phy.received;
            fdl::Repr::parse_bytes(received).is_ok()
        })?;
        self.retire_telegrams();
        let answer = self.master.take().unwrap().phy.received;
        self.event(format!("tool: answer {:02X?}", answer));
        Ok(answered.then_some(answer))
    }

    /// Keeps the set frequencies the master sent, for the next master's echo check.
    fn remember_echo(&mut self) {
        if let Some(m) = &self.master {
            self.echo_history.extend(m.sent.iter().copied());
        }
    }

    /// Silences the master (it disappears from the bus).
    pub fn stop_master(&mut self) {
        self.event("master: gone".into());
        self.remember_echo();
        self.retire_telegrams();
        self.master = None;
    }

    /// Whether the transceiver holds an answer it has not started yet.
    pub fn response_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// Takes the master off the bus, to be put back later (a tool steps in meanwhile).
    pub fn take_master(&mut self) -> Option<Master> {
        self.retire_telegrams();
        self.master.take()
    }

    /// Puts back a master taken off the bus: its PHY counts the line's idle time (TSYN before
    /// its next telegram) from now, as it would have heard the tool's traffic.
    pub fn put_master_back(&mut self, mut master: Master) {
        master.phy.last_activity = self.now;
        master.phy.now = self.now;
        self.master = Some(master);
    }

    /// Keeps the master's last telegrams, before it is replaced or goes.
    fn retire_telegrams(&mut self) {
        if let Some(m) = &self.master {
            self.retired_telegrams.extend(m.phy.recent.iter().cloned());
            let excess = self
                .retired_telegrams
                .len()
                .saturating_sub(crate::master::RECENT_TELEGRAMS);
            self.retired_telegrams.drain(..excess);
        }
    }

    /// Whether `bytes` is a telegram a station on the bus sent lately.
    fn sent_lately(&self, bytes: &[u8]) -> bool {
        let recent = self.master.iter().flat_map(|m| m.phy.recent.iter());
        recent
            .chain(self.retired_telegrams.iter())
            .any(|sent| sent[..] == *bytes)
    }

    pub fn now_us(&self) -> u64 {
        us_from_ticks(self.now)
    }

    /// The drive as it is now.
    pub fn drive_now(&mut self) -> &mut DriveSim {
        let now = self.now_us();
        self.bridge.drive_at(now)
    }

    /// Runs for `duration_us` of bus time.
    pub fn run_for_us(&mut self, duration_us: u64) -> io::Result<()> {
        let end = self.now + ticks_from_us(duration_us);
        self.run_until(end, |_| false).map(|_| ())
    }

    /// Runs until `done` or tick `end`; returns whether `done` held.
    pub fn run_until(
        &mut self,
        end: Tick,
        mut done: impl FnMut(&mut Self) -> bool,
    ) -> io::Result<bool> {
        while self.now < end {
            self.step(end)?;
            if done(self) {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Master poll period: one bit time of its rate, at least a microsecond (profirust's
    /// time resolution).
    fn master_poll_ticks(&self) -> Tick {
        self.master
            .as_ref()
            .map(|m| m.phy.timing().clocks_per_bit().max(ticks_from_us(1)))
            .unwrap_or(Tick::MAX)
    }

    /// One step: a strict clock where anything moves, a skip over quiet spans otherwise.
    fn step(&mut self, end: Tick) -> io::Result<()> {
        if self.master.is_some() && self.now >= self.next_master_poll {
            let now_us = self.now_us();
            if let Some(master) = &mut self.master {
                master.phy.now = self.now;
                master.poll(now_us);
                master.phy.drop_stale_characters();
            }
            self.next_master_poll = self.now + self.master_poll_ticks();
        }
        self.bridge.poll(ns_from_ticks(self.now))?;
        self.adapter
            .set_min_tsdr(self.bridge.responder.min_tsdr_bits());
        let master_drive = self.master.as_ref().and_then(|m| m.phy.tx.drive());
        let adapter_drive = self.adapter.drive();
        let collisions = self.bus.collisions;
        let line = self.bus.resolve(self.now, [master_drive, adapter_drive]);
        if collisions == 0 && self.bus.collisions > 0 {
            let telegram = self
                .master
                .as_ref()
                .and_then(|m| m.phy.recent.back().cloned());
            self.event(format!(
                "collision at {} us: the master (its last telegram {telegram:02X?}) and the adapter drove the line",
                self.now_us()
            ));
        }
        let mut limit = end - self.now;
        limit = limit.min(self.next_master_poll.saturating_sub(self.now).max(1));
        if let Some(at) = self.bridge.next_ns() {
            limit = limit.min(ticks_from_ns(at).saturating_sub(self.now).max(1));
        }
        // Fast mode on a driven line too: every block skips only clocks that change nothing
        // but its counters, so the line holds still until the next edge one of them makes.
        let quiet = match &self.master {
            Some(m) => {
                let rx_quiet = m.phy.rx.quiet_for(line, master_drive.is_some());
                m.phy.tx.quiet_for().min(rx_quiet)
            }
            None => Tick::MAX,
        }
        .min(self.bus.faults.quiet_for(self.now))
        .min(limit);
        let busy = !line || master_drive.is_some() || adapter_drive.is_some();
        // A waveform samples every clock.
        let quiet = if self.tracer.is_some() { 1 } else { quiet };
        let (ticks, out) = if quiet > 1 {
            self.adapter.advance(line, quiet)
        } else {
            (1, self.adapter.tick(line))
        };
        if let Some(master) = &mut self.master {
            if busy {
                master.phy.last_activity = self.now + ticks - 1;
            }
            if ticks == 1 {
                if let Some(ch) = master.phy.rx.tick(line, master_drive.is_some()) {
                    if ch.error.is_none() {
                        master.phy.received.push(ch.byte);
                    } else {
                        master.phy.char_errors += 1;
                    }
                }
                master.phy.tx.tick();
            } else {
                master.phy.rx.skip(ticks);
                master.phy.tx.skip(ticks);
            }
            master.phy.now = self.now + ticks;
        }
        if let Some(p) = self.pending {
            if adapter_drive.is_some() {
                self.response_started(p.request_end);
                self.pending = None;
            }
        }
        self.now += ticks;
        if let Some(tracer) = &mut self.tracer {
            tracer.sample(self.now, line, &self.adapter)?;
        }
        if out.baud_changed {
            self.baud_changed();
        }
        if out.telegram {
            self.telegram()?;
        }
        Ok(())
    }

    fn log_data_exchange(
        &mut self,
        end_us: u64,
        turnaround_us: u64,
        request: &[u8],
        response: &[u8],
    ) {
        let payload = |bytes: &[u8]| match fdl::Repr::parse_bytes(bytes) {
            Ok((fdl::Repr::Data(d), _)) if d.dsap.is_none() && d.ssap.is_none() => {
                Some(d.payload.to_vec())
            }
            _ => None,
        };
        let Some(outputs) = payload(request).filter(|p| !p.is_empty()) else {
            return;
        };
        if self.dx.outputs.last().map(|(_, o)| o) != Some(&outputs) {
            self.dx.outputs.push((end_us, outputs));
        }
        let Some(inputs) = payload(response) else {
            return;
        };
        let bps = self
            .adapter
            .baud_state()
            .baud()
            .map_or(1, |b| b.bits_per_second() as u64);
        let bits_us = |bits: u64| (bits * 1_000_000).div_ceil(bps);
        let min_tsdr = u64::from(self.bridge.responder.min_tsdr_bits());
        let start = end_us + turnaround_us.max(bits_us(min_tsdr));
        let done = start + bits_us(11 * response.len() as u64);
        if self.dx.inputs.last().map(|(_, i)| i) != Some(&inputs) {
            self.dx.inputs.push((done, inputs));
        }
    }

    fn baud_changed(&mut self) {
        let state = self.adapter.baud_state();
        let was = self.last_baud_state;
        match (was, state) {
            // A trial from the lock that failed: the lock stays where it was.
            (BaudState::Trial(t), BaudState::Locked(b))
                if self.adapter.stats().relock_trials_failed > self.relock_trials_failed =>
            {
                if self.log_failed_trials {
                    self.event(format!(
                        "transceiver: trial at {t} failed, still locked at {b}"
                    ));
                } else {
                    self.figures.trials_failed_back += 1;
                }
            }
            (_, BaudState::Locked(b)) if was != state => {
                self.figures.locked = Some(b);
                self.event(format!("transceiver: locked at {b}"));
            }
            (BaudState::Locked(b), BaudState::Trial(t)) if self.log_failed_trials => {
                self.event(format!(
                    "transceiver: trial at {t}, the lock at {b} kept until it passes"
                ));
            }
            _ => {}
        }
        if state == BaudState::Searching && self.last_baud_state != BaudState::Searching {
            self.event("transceiver: searching".into());
        }
        self.last_baud_state = state;
        self.relock_trials_failed = self.adapter.stats().relock_trials_failed;
    }

    fn response_started(&mut self, request_end: Tick) {
        let Some(timing) = self.adapter.timing() else {
            return;
        };
        let cpb = timing.clocks_per_bit().max(1);
        let bits = (self.now - request_end) / cpb;
        let baud = self.adapter.baud_state().baud();
        if bits > self.figures.worst_tsdr_bits {
            self.figures.worst_tsdr_bits = bits;
            self.figures.worst_tsdr_baud = baud;
        }
        if let Some(b) = baud {
            let worst = self.figures.worst_tsdr_by_rate.entry(b).or_default();
            *worst = (*worst).max(bits);
        }
        // The answer is due MaxTsdr after the request; where a fault hit the line after the
        // request, MaxTsdr after the character it may have started (a receiver reads a low
        // glitch as a start bit, to that character's end), as for any station on the line.
        let due = match self.bus.faults.disturbed_until(self.now) {
            Some(until) if until > request_end => until + u64::from(dp_consts::BITS_PER_CHAR) * cpb,
            _ => request_end,
        };
        if let Some(b) = baud {
            if self.now.saturating_sub(due) / cpb > u64::from(b.adapter_max_tsdr_bits()) {
                self.figures.late_responses += 1;
            }
        }
    }

    fn telegram(&mut self) -> io::Result<()> {
        let t = self.adapter.telegram();
        if t.status != TelegramStatus::Good {
            self.figures.bad_telegrams += 1;
            return Ok(());
        }
        if !self.sent_lately(t.bytes()) {
            if t.bytes().first() == Some(&dp_consts::SD4) {
                self.figures.corrupt_tokens += 1;
            } else {
                self.figures.corrupt_delivered += 1;
                self.figures
                    .first_corrupt
                    .get_or_insert_with(|| t.bytes().to_vec());
            }
        }
        if self.figures.lost_before_lock.is_none() {
            let sent = self.master.as_ref().map_or(1, |m| m.phy.telegrams_sent);
            self.figures.lost_before_lock = Some(sent.saturating_sub(1));
        }
        let bytes = t.bytes().to_vec();
        let end = t.end;
        let baud = self
            .adapter
            .baud_state()
            .baud()
            .map_or(0, |b| b.index() as u8);
        let (forwarded, exchanges) = (
            self.bridge.figures.events,
            self.bridge.figures.data_exchanges,
        );
        let response = self.bridge.telegram(ns_from_ticks(end), baud, &bytes);
        if self.bridge.figures.events > forwarded {
            self.figures.forwarded += 1;
        }
        if self.bridge.figures.data_exchanges > exchanges {
            self.dx_request_ends.push(end);
        }
        let Some(response) = response else {
            return Ok(());
        };
        if self.log_dx {
            self.log_data_exchange(us_from_ticks(end), 0, &bytes, &response);
        }
        self.figures.responses += 1;
        if self.adapter.respond(&response, end + DECISION_CLOCKS) {
            self.pending = Some(Pending { request_end: end });
        }
        Ok(())
    }
}
