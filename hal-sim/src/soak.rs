//! The soak campaign (issue 31): the whole adapter (the firmware, in QEMU or in-process, with
//! the transceiver model, a profirust master and the drive simulator) driven by a seeded random
//! schedule of what the scenarios do one at a time, with invariants checked as it runs.
//!
//! Contract:
//! - The schedule is a function of the seed alone: event `i` of seed `S` is the same in every
//!   run, whatever the firmware does (each event draws from a generator of its own, seeded
//!   from `S` and `i`). In-process a run replays exactly; under QEMU the bus timing can move by
//!   a few clocks from run to run (a link byte enters QEMU on its main loop), so a replay runs
//!   the same events, not always the same clocks.
//! - The invariants are checked every millisecond of bus time and at the end of every event
//!   ([`Soak::watch`], [`Soak::recover`]); the first violation ends the run and is reported
//!   with its event's index and the events before it.
//! - A firmware that stops answering (a panic, a HardFault, QEMU gone) is a violation, not an
//!   error of the campaign.
//! - Every profile of seed 004's Set_Prm runs: the vendor's words, PROFIdrive and ABB Drives.
//!   In all three PZD2 out is the drive's set frequency and PZD2 in reads it back (the two
//!   translating profiles with a rated frequency of their rated units, so REF and ACT are the
//!   0.01 Hz themselves), which lets the outputs be followed to the drive and back; in the two
//!   the master walks the state machine from the status word as a PLC does ([`Plc`]).

use crate::cosim::{echo_user_prm, CoSim, MasterSetup, Program};
use crate::firmware::Firmware;
use crate::scenarios::{self, Checks, SWITCH_ADDRESS};
use dp_consts::Baud;
use dp_link::NvRecord;
use dp_phy::bus::{FaultWindow, LineFault};
use dp_phy::{BaudState, Tick};
use drive_sim::{LinkFault, ACCEL_TIME, SET_FREQUENCY};
use profidrive::pd_params::{ErrorNumber, RequestLabel, ResponseLabel};
use profidrive::pkw::{ReplyId, Task};
use profidrive::ppo::Ppo;
use profidrive::prm::{FailSafeMode, OperationMode};
use profidrive::profile::{control as pd, status as pds};
use profidrive::words::{control, status};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::{BTreeSet, VecDeque};
use std::io;

const TICKS_PER_US: u64 = (crate::cosim::CLOCK_HZ / 1_000_000) as u64;

/// The control word every soak master runs the drive with in the vendor profile, and what the
/// drive gets from the translating profiles in OPERATION ENABLED.
const RUN: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

/// PZD2 out in the fail-safe mode UseFailSafeValues: a set frequency no master sends (the
/// masters send whole hertz).
const FAIL_SAFE_FREQUENCY: u16 = 1234;

/// How many of the last events a violation prints.
const HISTORY: usize = 24;

/// The data exchange cycles a bound of [`Soak::run_until_cycles`] takes at least.
const BOUND_CYCLES: u64 = 4;

/// The longest such a bound waits, cycles or not (the master may have lost the slave).
const BOUND_CAP_US: u64 = 5_000_000;

/// Bus time between two looks at the invariants.
const WATCH_US: u64 = 1_000;

/// The drive's deceleration from its maximum frequency, 0.5 s (F0.14 in 0.1 s), set at its
/// panel as the campaign starts: the PROFIdrive OFF1 (a fail-safe STOP) waits in OFF1 ACTIVE
/// until the drive has ramped down, which with the drive's 5.0 s would make every such
/// recovery seconds long.
const DECELERATION: u16 = 5;

/// How long the PLC holds a PROFIdrive RESET, and then leaves it off, at least: the adapter
/// reads the outputs once per drive link cycle, and takes a RESET on its rise.
const RESET_HOLD_US: u64 = 50_000;

/// What a run is asked to do.
#[derive(Clone, Debug)]
pub struct Options {
    pub seed: u64,
    /// Stop after this many events.
    pub events: u64,
    /// Stop at the first event that would start after this moment (a time budget).
    pub deadline: Option<std::time::Instant>,
    /// Event indices from which a waveform is written to this file (a reproduction).
    pub trace_from: Option<(u64, std::path::PathBuf)>,
}

/// The first violation: which event, what failed, and the events up to it.
#[derive(Clone, Debug)]
pub struct Violation {
    pub event: u64,
    pub what: String,
    pub last_events: Vec<String>,
    /// The adapter's last state changes (the scenarios' event log: states, LEDs, locks).
    pub adapter_events: Vec<String>,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct Summary {
    pub seed: u64,
    pub events: u64,
    pub simulated_us: u64,
    pub invariants_checked: u64,
    pub violation: Option<Violation>,
    /// Each kind of event and how often it ran.
    pub kinds: std::collections::BTreeMap<&'static str, u64>,
    /// ERROR lines of the firmware's log (a panic, a HardFault), each a violation: found
    /// after the run, where the log is decoded (xtask).
    pub firmware_errors: Vec<String>,
}

impl Summary {
    /// The campaign's last line.
    pub fn line(&self) -> String {
        format!(
            "soak: seed={} events={} simulated_s={:.3} invariants_checked={} violations={}",
            self.seed,
            self.events,
            self.simulated_us as f64 / 1e6,
            self.invariants_checked,
            self.violations()
        )
    }

    /// The violation that ended the run, if any, and the firmware's ERROR lines.
    pub fn violations(&self) -> usize {
        usize::from(self.violation.is_some()) + self.firmware_errors.len()
    }
}

/// The parameters the master runs with: what a Set_Prm and a Chk_Cfg carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Plan {
    baud: Baud,
    ppo: Ppo,
    fail_safe: FailSafeMode,
    /// The watchdog the schedule asked for; [`Plan::watchdog_ms`] is the one in force.
    watchdog_ms: u64,
    /// Set_Prm asks for Sync and Freeze.
    sync_freeze: bool,
    /// DP-V1: the drive's 51.21 DP MODE is 1, Set_Prm carries DPV1_Status_1-3 (DPV1_Enable),
    /// and the master reads and writes parameters over MSAC1 beside the cyclic data.
    dpv1: bool,
    /// With DP-V1: DPV1_Status_1's WD_Base_1ms, the watchdog's factors in 1 ms.
    watchdog_1ms: bool,
    /// Seed 004 byte 8's operation mode: the vendor's words, PROFIdrive or ABB Drives.
    operation: OperationMode,
}

/// The bits of one data exchange cycle of the longest PPO, with the master's token and
/// FDL_Status polls beside it, rounded up: a watchdog shorter than a few of these cycles expires
/// between two of them (at 9.6k a PPO5 cycle is about 150 ms), which a configuration tool does
/// not allow and which would be the soak's error, not the adapter's.
const CYCLE_BITS: u64 = 3_000;

/// The cycles the watchdog covers at least.
const WATCHDOG_CYCLES: u64 = 5;

impl Plan {
    /// The watchdog in force: the one asked for, at least [`WATCHDOG_CYCLES`] cycles of the
    /// rate (a configuration tool's rule), in whole 10 ms.
    fn watchdog_ms(&self) -> u64 {
        let floor_ms =
            (WATCHDOG_CYCLES * CYCLE_BITS * 1_000).div_ceil(u64::from(self.baud.bits_per_second()));
        self.watchdog_ms.max(floor_ms.div_ceil(10) * 10)
    }

    fn setup(&self) -> MasterSetup {
        let mut setup = MasterSetup::new(self.baud, SWITCH_ADDRESS);
        setup.config = self.ppo.cfg().to_vec();
        let mut prm = echo_user_prm();
        prm.fail_safe = self.fail_safe;
        prm.operation = self.operation;
        if self.translates() {
            // The rated frequency as many 0.01 Hz as the rated speed's units: REF and ACT are
            // the drive's 0.01 Hz themselves.
            prm.rated_frequency = self.operation.rated_units() as u16;
            prm.fail_safe_pzd[0] = pd::OPERATE;
        } else {
            prm.fail_safe_pzd[0] = RUN;
        }
        prm.fail_safe_pzd[1] = FAIL_SAFE_FREQUENCY;
        let watchdog_1ms = self.dpv1 && self.watchdog_1ms;
        setup.user_prm = if self.dpv1 {
            // Seed 004's DP-V1 Set_Prm: DPV1_Status_1-3, then the header byte onward.
            use dp_consts::dpv1::status1;
            let base = if watchdog_1ms {
                status1::WD_BASE_1MS
            } else {
                0
            };
            let mut user_prm = vec![status1::DPV1_ENABLE | base, 0, 0];
            user_prm.extend_from_slice(&prm.encode()[1..]);
            user_prm
        } else {
            prm.encode().to_vec()
        };
        // profirust writes the factors in 10 ms; with the 1 ms base the slave reads them in 1 ms,
        // so the master is given ten times the watchdog meant.
        setup.watchdog_ms = self.watchdog_ms() * if watchdog_1ms { 10 } else { 1 };
        setup.sync_freeze = self.sync_freeze;
        setup
    }

    /// Where PZD1 starts in the outputs and the inputs, in words (after the PKW if any).
    fn pzd_at(&self) -> usize {
        if self.ppo.has_pkw() {
            4
        } else {
            0
        }
    }

    /// Whether the adapter runs the PROFIdrive state machine (PROFIdrive, ABB Drives).
    fn translates(&self) -> bool {
        self.operation.translates()
    }

    /// The status word says the drive is faulted: seed 000's fault bit, or TRIPPED.
    fn faulted(&self, sw: u16) -> bool {
        if self.translates() {
            sw & pds::TRIPPED != 0
        } else {
            sw & status::FAULT != 0
        }
    }

    /// The status word says the drive warns: seed 000's bit 14, or table 8's ALARM.
    fn warns(&self, sw: u16) -> bool {
        sw & if self.translates() {
            pds::ALARM
        } else {
            status::WARNING
        } != 0
    }

    /// The status word shows the drive link lost: seed 000's C0xxh, or (issue 18) TRIPPED
    /// and never C0xxh in the translating profiles.
    fn shows_link_loss(&self, sw: u16) -> bool {
        let c0xx = sw & 0xFF00 == profidrive::drive::PZD1_LINK_ERROR;
        if self.translates() {
            sw & pds::TRIPPED != 0 && !c0xx
        } else {
            c0xx
        }
    }

    /// The status word says the drive runs on the master's commands: OPERATION ENABLED in
    /// the translating profiles (any status word in the vendor's, where the master sends its
    /// run command whatever the drive says).
    fn operating(&self, sw: u16) -> bool {
        let enabled = pds::RDY_ON | pds::RDY_RUN | pds::RDY_REF;
        !self.translates() || (sw & enabled == enabled && sw & pds::TRIPPED == 0)
    }

    /// The inputs say OPERATION ENABLED, and they carry `frequency` back: the status word
    /// came after the outputs that sent it. A status word the adapter's inputs still hold from
    /// before (a new master's first Data_Exchange is all zeros, in PROFIdrive an OFF2 the
    /// adapter has yet to answer) is no proof.
    fn operating_after(&self, inputs: &[u16], frequency: u16) -> bool {
        let at = self.pzd_at();
        inputs.get(at + 1) == Some(&frequency)
            && inputs.get(at).is_some_and(|&sw| self.operating(sw))
    }
}

/// The master's PLC program in the translating profiles: from the status word it reads, the
/// control word that walks seed 004's state machine (figure 9) to OPERATION ENABLED and keeps
/// it there, acknowledging a fault with a RESET held and released by turns.
#[derive(Clone, Copy, Debug)]
struct Plc {
    /// The control word the master sends (the vendor's RUN, or FAULT_RESET with it, there).
    control: u16,
    /// Faults are acknowledged (off while an event looks at a fault latched).
    acknowledge: bool,
    /// When RESET last went on or off: bus time and data exchange cycles.
    reset_since: (u64, u64),
    /// The status word it last read, so that the run's report shows each change.
    status: Option<u16>,
}

impl Plc {
    /// The control word after status word `sw`, at `now` (bus time, cycles).
    fn next(&mut self, sw: u16, now: (u64, u64)) -> u16 {
        if now.1 < self.reset_since.1 {
            // A new master counts its cycles from 0.
            self.reset_since.1 = 0;
        }
        let resetting = self.control & pd::RESET != 0;
        let control = if sw & pds::TRIPPED != 0 && self.acknowledge {
            let held = now.0 >= self.reset_since.0 + RESET_HOLD_US
                && now.1 >= self.reset_since.1 + BOUND_CYCLES;
            pd::OPERATE | if resetting != held { pd::RESET } else { 0 }
        } else if sw & pds::TRIPPED != 0 {
            pd::OPERATE
        } else if sw & pds::SWC_ON_INHIB != 0 {
            // Figure 9: out of SWITCH-ON INHIBIT with ON 0.
            pd::READY
        } else {
            pd::OPERATE
        };
        if (control & pd::RESET != 0) != resetting {
            self.reset_since = now;
        }
        self.control = control;
        control
    }
}

/// One event of the schedule.
#[derive(Clone, Debug)]
enum Event {
    /// Data exchange with a new set frequency, for a while.
    Steady { frequency: u16, us: u64 },
    /// The master comes back at another rate.
    RateChange(Baud),
    /// Glitches up to two bit times long.
    NoiseBurst { us: u64, count: usize, seed: u64 },
    /// One glitch, somewhere in the next few milliseconds.
    Glitch { after_us: u64, len_bits: u64 },
    /// The bus cable out: the line idles at the adapter for a while (both ways).
    CablePull { us: u64 },
    /// The master stops, and comes back after a while.
    MasterAway { us: u64 },
    /// A commissioning tool (a second master, station 3) asks for every DP-V0 service
    /// profirust does not send.
    SecondMaster,
    /// The master parameterises and configures the adapter anew, at the rate it runs at.
    SetPrm(Plan),
    /// The drive warns (AL.`code`), and the warning goes.
    DriveWarning { code: u8 },
    /// Parameters over DP-V1 (MSAC1): 964, 918, a write of seed 004's 12.02, and an
    /// invalid index; a steady run where the plan is not DP-V1.
    Dpv1 { value: u16 },
    /// The switch to 0 and a power cycle, Set_Slave_Add to `address` from a tool, and a power
    /// cut: after the storage write, or `cut` thousandths of the way through it (the write's
    /// page erases and word programs done in order up to there); then the switch back.
    SetSlaveAdd { address: u8, cut: Option<u32> },
    /// Global_Control Sync (or Freeze), a new set frequency held (or the inputs frozen), then
    /// Sync again and Unsync (or Unfreeze); ignored where Set_Prm did not ask for it.
    SyncFreeze { freeze: bool },
    /// Global_Control Clear_Data (the PLC stopped), then the master starts anew.
    PlcStop,
    /// A power cycle after a while.
    PowerCycle { after_us: u64 },
    /// The drive trips, and the master resets the fault.
    DriveFault,
    /// The drive link fails this way for a while.
    DriveLink { fault: LinkFault, us: u64 },
    /// A parameter request over the PKW channel, in the plan's profile.
    Pkw(PkwRequest),
}

/// A PKW request and the reply it must get.
#[derive(Clone, Copy, Debug)]
enum PkwRequest {
    /// Seed 000's channel (the vendor profile): task, function code, value.
    Vendor {
        task: Task,
        code: u16,
        value: u16,
        want: (ReplyId, u16),
    },
    /// Seed 004's PROFIdrive channel (the translating profiles): a PROFIdrive parameter, or
    /// a drive parameter xxyy as PNU xx and index yy.
    Profidrive {
        label: RequestLabel,
        pnu: u16,
        index: u8,
        value: u32,
        want: (ResponseLabel, u32),
    },
}

impl PkwRequest {
    /// A PROFIdrive request for drive parameter `number` (xxyy, seed 004's numbering).
    fn drive_parameter(
        label: RequestLabel,
        number: u16,
        value: u32,
        want: (ResponseLabel, u32),
    ) -> Self {
        PkwRequest::Profidrive {
            label,
            pnu: number >> 8,
            index: number as u8,
            value,
            want,
        }
    }

    /// The four PKW words out.
    fn words(&self) -> [u16; 4] {
        match *self {
            PkwRequest::Vendor {
                task, code, value, ..
            } => scenarios::vendor_request(task, code, value),
            PkwRequest::Profidrive {
                label,
                pnu,
                index,
                value,
                ..
            } => scenarios::pd_request(label, pnu, index, value),
        }
    }

    /// Whether `reply` (the four PKW words in, if any came) is the one wanted; what it was.
    fn judge(&self, reply: &Option<Vec<u16>>) -> (bool, String) {
        match self {
            PkwRequest::Vendor { want, .. } => {
                let got = scenarios::vendor_reply(reply);
                (got == Some(*want), format!("{got:?}"))
            }
            PkwRequest::Profidrive { want, .. } => {
                let got = scenarios::pd_reply(reply);
                (got == Some(*want), format!("{got:?}"))
            }
        }
    }
}

impl Event {
    fn kind(&self) -> &'static str {
        match self {
            Event::Steady { .. } => "steady",
            Event::RateChange(_) => "rate-change",
            Event::NoiseBurst { .. } => "noise-burst",
            Event::Glitch { .. } => "glitch",
            Event::CablePull { .. } => "cable-pull",
            Event::MasterAway { .. } => "master-away",
            Event::SecondMaster => "second-master",
            Event::SetPrm(_) => "set-prm",
            Event::SetSlaveAdd { .. } => "set-slave-add",
            Event::Dpv1 { .. } => "dpv1",
            Event::DriveWarning { .. } => "drive-warning",
            Event::SyncFreeze { freeze: false } => "sync",
            Event::SyncFreeze { freeze: true } => "freeze",
            Event::PlcStop => "plc-stop",
            Event::PowerCycle { .. } => "power-cycle",
            Event::DriveFault => "drive-fault",
            Event::DriveLink { .. } => "drive-link",
            Event::Pkw(PkwRequest::Vendor { .. }) => "pkw",
            Event::Pkw(PkwRequest::Profidrive { .. }) => "pkw-profidrive",
        }
    }

    /// Event `index` of the schedule of `seed`, for a master running `plan`.
    fn draw(seed: u64, index: u64, plan: &Plan) -> Event {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let ms = |rng: &mut ChaCha8Rng, lo: u64, hi: u64| rng.gen_range(lo..=hi) * 1_000;
        let steady = |rng: &mut ChaCha8Rng| Event::Steady {
            frequency: rng.gen_range(1..=50) * 100,
            us: ms(rng, 5, 60),
        };
        match rng.gen_range(0..125) {
            0..=19 => steady(&mut rng),
            20..=29 => Event::RateChange(Baud::ALL[rng.gen_range(0..Baud::ALL.len())]),
            30..=35 => Event::NoiseBurst {
                us: ms(&mut rng, 2, 20),
                count: rng.gen_range(10..=400),
                seed: rng.gen(),
            },
            36..=41 => Event::Glitch {
                after_us: rng.gen_range(0..5_000),
                len_bits: rng.gen_range(1..=2),
            },
            42..=46 => Event::CablePull {
                us: ms(&mut rng, 1, 600),
            },
            47..=52 => Event::MasterAway {
                us: ms(&mut rng, 1, 600),
            },
            53..=57 => Event::SecondMaster,
            58..=65 => Event::SetPrm(Plan {
                baud: plan.baud,
                ppo: Ppo::ALL[rng.gen_range(0..Ppo::ALL.len())],
                fail_safe: [
                    FailSafeMode::Stop,
                    FailSafeMode::LastSpeed,
                    FailSafeMode::UseFailSafeValues,
                ][rng.gen_range(0..3)],
                watchdog_ms: [50, 100, 200, 500][rng.gen_range(0..4)],
                sync_freeze: rng.gen(),
                dpv1: rng.gen_bool(0.4),
                watchdog_1ms: rng.gen(),
                operation: [
                    OperationMode::Vendor,
                    OperationMode::Profidrive,
                    OperationMode::AbbDrives,
                ][rng.gen_range(0..3)],
            }),
            66..=70 => Event::PlcStop,
            71..=76 => Event::PowerCycle {
                after_us: rng.gen_range(0..20_000),
            },
            77..=81 => Event::DriveFault,
            82..=88 => Event::DriveLink {
                fault: [
                    LinkFault::Disconnected,
                    LinkFault::NoAnswer,
                    LinkFault::CrcError,
                    LinkFault::Noise,
                ][rng.gen_range(0..4)],
                us: ms(&mut rng, 10, 500),
            },
            100..=107 => Event::SyncFreeze { freeze: rng.gen() },
            108..=112 => Event::SetSlaveAdd {
                // Not the master's, the tools' (1, 3) or the switch's.
                address: loop {
                    let a = rng.gen_range(4..=125);
                    if a != SWITCH_ADDRESS {
                        break a;
                    }
                },
                cut: rng.gen_bool(0.6).then(|| rng.gen_range(0..=1000)),
            },
            113..=120 => Event::Dpv1 {
                value: rng.gen_range(0..=1000),
            },
            121..=124 => Event::DriveWarning {
                code: rng.gen_range(1..=20),
            },
            // The PKW kinds' share, where the PPO has no PKW channel.
            _ if !plan.ppo.has_pkw() => steady(&mut rng),
            _ if plan.translates() => {
                // Seed 004's answers, as the PROFIdrive scenario proves them one by one.
                use {ErrorNumber as E, RequestLabel as Rq, ResponseLabel as Rs};
                let ramp = rng.gen_range(1..=600);
                let error = |e: E| (Rs::Error, u32::from(u16::from(e)));
                Event::Pkw(match rng.gen_range(0..5) {
                    // F0.13, the acceleration time.
                    0 => PkwRequest::drive_parameter(Rq::WriteWord, 113, ramp, (Rs::Word, ramp)),
                    // F0.29, the set frequency, above the drive's 50.00 Hz.
                    1 => {
                        PkwRequest::drive_parameter(Rq::WriteWord, 129, 9000, error(E::OutOfRange))
                    }
                    // D0.00, a status value.
                    2 => PkwRequest::drive_parameter(Rq::WriteWord, 2100, 5, error(E::ReadOnly)),
                    3 => PkwRequest::Profidrive {
                        label: Rq::Read,
                        pnu: 918,
                        index: 0,
                        value: 0,
                        want: (Rs::Word, u32::from(SWITCH_ADDRESS)),
                    },
                    _ => PkwRequest::Profidrive {
                        label: Rq::Read,
                        pnu: 999,
                        index: 0,
                        value: 0,
                        want: error(E::IllegalPnu),
                    },
                })
            }
            _ => {
                // Seed 000's answers, as the drive scenario proves them one by one.
                let ramp = rng.gen_range(1..=600);
                let vendor = |task, code, value, want| PkwRequest::Vendor {
                    task,
                    code,
                    value,
                    want,
                };
                Event::Pkw(match rng.gen_range(0..4) {
                    0 => vendor(Task::Write, ACCEL_TIME, ramp, (ReplyId::Value, ramp)),
                    1 => vendor(Task::Read, 0xF058, 0, (ReplyId::Refused, 0x02)),
                    2 => vendor(Task::Write, SET_FREQUENCY, 9000, (ReplyId::Refused, 0x03)),
                    _ => vendor(Task::Write, 0xD000, 1, (ReplyId::Refused, 0x11)),
                })
            }
        }
    }
}

/// Why an event ended early.
#[derive(Debug)]
enum Stop {
    Violation(String),
}

impl From<io::Error> for Stop {
    fn from(e: io::Error) -> Stop {
        Stop::Violation(format!("the firmware stopped answering: {e}"))
    }
}

type Step = Result<(), Stop>;

fn violation<T>(what: impl Into<String>) -> Result<T, Stop> {
    Err(Stop::Violation(what.into()))
}

/// A campaign under way.
pub struct Soak<F: Firmware> {
    pub sim: CoSim<F>,
    plan: Plan,
    /// The set frequency the master sends, and every one any master sent.
    frequency: u16,
    sent: BTreeSet<u16>,
    /// The data exchange cycles the inputs were last looked at.
    inputs_seen_at: u64,
    /// The lock the invariants last saw.
    lock_seen: Option<Baud>,
    /// The drive's 51.21 DP MODE as the adapter last took it (DP-V1 or not).
    drive_dpv1: bool,
    plc: Plc,
    /// The drive's control word as last looked at (for the report).
    drive_control: Option<u16>,
    checked: u64,
    history: VecDeque<String>,
}

impl<F: Firmware> Soak<F> {
    /// Powers the board up (switch at [`SWITCH_ADDRESS`], empty storage) around `firmware`.
    pub fn new(firmware: F) -> io::Result<Soak<F>> {
        let mut sim = CoSim::new(firmware, SWITCH_ADDRESS, None)?;
        // Noise draws trials at other rates now and then; the soak counts them, it keeps no
        // golden file of events.
        sim.log_failed_trials = false;
        sim.drive_now()
            .set_at_panel(drive_sim::DECEL_TIME, DECELERATION)
            .map_err(|e| io::Error::other(format!("F0.14 at the drive's panel: {e:?}")))?;
        Ok(Soak {
            sim,
            plan: Plan {
                baud: Baud::B1500000,
                ppo: Ppo::Ppo1,
                fail_safe: FailSafeMode::Stop,
                watchdog_ms: 200,
                sync_freeze: false,
                dpv1: false,
                watchdog_1ms: false,
                operation: OperationMode::Vendor,
            },
            drive_dpv1: false,
            plc: Plc {
                control: RUN,
                acknowledge: true,
                reset_since: (0, 0),
                status: None,
            },
            drive_control: None,
            frequency: 100,
            sent: BTreeSet::from([0, FAIL_SAFE_FREQUENCY]),
            inputs_seen_at: 0,
            lock_seen: None,
            checked: 0,
            history: VecDeque::new(),
        })
    }

    /// Runs the campaign of `options`.
    pub fn run(mut self, options: &Options) -> io::Result<(Summary, F)> {
        let mut kinds = std::collections::BTreeMap::new();
        let mut events = 0;
        let mut outcome = self.start();
        while outcome.is_ok()
            && events < options.events
            && options
                .deadline
                .is_none_or(|d| std::time::Instant::now() < d)
        {
            let event = Event::draw(options.seed, events, &self.plan);
            *kinds.entry(event.kind()).or_insert(0) += 1;
            if let Some((from, path)) = &options.trace_from {
                if events == *from {
                    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
                    self.sim.tracer = Some(dp_phy::trace::Tracer::new(
                        file,
                        crate::cosim::CLOCK_HZ,
                        "adapter",
                    )?);
                }
            }
            self.remember(format!(
                "#{events} at {:.6} s: {event:?}",
                self.sim.now_us() as f64 / 1e6
            ));
            outcome = self.event(&event).and_then(|()| self.recover());
            events += 1;
        }
        if outcome.is_ok() {
            outcome = self.check_stack();
        }
        if let Some(tracer) = &mut self.sim.tracer {
            tracer.flush()?;
        }
        let violation = match outcome {
            Ok(()) => None,
            Err(Stop::Violation(what)) => Some(Violation {
                event: events.saturating_sub(1),
                what: format!("{what}; {}", self.bus_state()),
                last_events: self.history.iter().cloned().collect(),
                adapter_events: self
                    .sim
                    .events()
                    .iter()
                    .rev()
                    .take(HISTORY)
                    .rev()
                    .cloned()
                    .collect(),
            }),
        };
        let summary = Summary {
            seed: options.seed,
            events,
            simulated_us: self.sim.now_us(),
            invariants_checked: self.checked,
            violation,
            kinds,
            firmware_errors: Vec::new(),
        };
        Ok((summary, self.sim.bridge.firmware))
    }

    /// The bus as a violation leaves it: the adapter's lock and driver, the slave's state,
    /// the master's view.
    fn bus_state(&mut self) -> String {
        let master = self.sim.master.as_mut().map(|m| {
            let running = m.running();
            format!(
                "master at {} running {} cycles {} sending {} char errors {}",
                m.setup.baud,
                running,
                m.cycles,
                !m.phy.tx.done(),
                m.phy.char_errors
            )
        });
        format!(
            "adapter {:?} driving {:?} telegrams bad {} answered {}, slave {:?}, {}",
            self.sim.adapter.baud_state(),
            self.sim.adapter.drive(),
            self.sim.figures.bad_telegrams,
            self.sim.figures.responses,
            self.sim.bridge.status.state,
            master.unwrap_or_else(|| "no master".into())
        )
    }

    fn remember(&mut self, line: String) {
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(line);
    }

    fn check(&mut self, ok: bool, what: impl FnOnce(&Self) -> String) -> Step {
        self.checked += 1;
        if ok {
            Ok(())
        } else {
            violation(what(self))
        }
    }

    /// The master of the plan starts, and the adapter is brought to data exchange.
    fn start(&mut self) -> Step {
        self.start_master()?;
        self.recover()
    }

    fn start_master(&mut self) -> Step {
        self.start_master_at(SWITCH_ADDRESS)
    }

    /// The master of the plan starts, for the slave at `address`; first, where the plan's
    /// DP-V1 differs from the drive's 51.21 DP MODE, the mode is set at the drive's panel and
    /// taken with a refresh (51.27), the master off the bus meanwhile.
    fn start_master_at(&mut self, address: u8) -> Step {
        if self.plan.dpv1 != self.drive_dpv1 {
            use profidrive::fieldbus_group::{self as fieldbus, index as fb};
            self.sim.stop_master();
            let mode = u16::from(self.plan.dpv1);
            let panel = |s: &mut Self, i: u8, v: u16| {
                let _ = s.sim.drive_now().set_at_panel(fieldbus::code(i).0, v);
            };
            panel(self, fb::DP_MODE, mode);
            panel(self, fb::PAR_REFRESH, fieldbus::REFRESH);
            let group = |s: &mut Self, i: u8| s.sim.drive_now().read_register(fieldbus::code(i).0);
            let taken = self.run_until(2_000_000, |s| {
                group(s, fb::PAR_REFRESH) == Ok(fieldbus::DONE) && group(s, fb::DP_MODE) == Ok(mode)
            })?;
            self.check(taken, |_| {
                format!("51.21 DP MODE = {mode} not taken with a refresh within 2 s")
            })?;
            self.drive_dpv1 = self.plan.dpv1;
        }
        let mut setup = self.plan.setup();
        setup.slave_address = address;
        self.sim.start_master(setup);
        if let Some(m) = self.sim.master.as_mut() {
            m.program = Program::Manual;
            if self.plan.dpv1 {
                m.msac1 = Some(crate::msac1_master::Msac1Requester::new(address));
            }
        }
        self.put_outputs();
        Ok(())
    }

    /// The master's outputs: the PLC's control word and the set frequency, the rest zero.
    fn put_outputs(&mut self) {
        let at = self.plan.pzd_at() * 2;
        let (control, frequency) = (self.plc.control, self.frequency);
        self.sent.insert(frequency);
        if let Some(m) = self.sim.master.as_mut() {
            m.outputs.fill(0);
            m.outputs[at..at + 2].copy_from_slice(&control.to_be_bytes());
            m.outputs[at + 2..at + 4].copy_from_slice(&frequency.to_be_bytes());
        }
    }

    fn inputs(&self) -> Vec<u16> {
        self.sim
            .master
            .as_ref()
            .map_or(Vec::new(), |m| scenarios::words(&m.inputs))
    }

    fn clocks_per_bit(&self) -> Tick {
        dp_phy::BitTiming::new(crate::cosim::CLOCK_HZ, self.plan.baud, 0).clocks_per_bit()
    }

    fn cycles(&self) -> u64 {
        self.sim.master.as_ref().map_or(0, |m| m.cycles)
    }

    /// Runs `us` of bus time, looking at the invariants every millisecond.
    fn run_for(&mut self, us: u64) -> Step {
        let end = self.sim.now + us * TICKS_PER_US;
        while self.sim.now < end {
            let slice = (end - self.sim.now).min(WATCH_US * TICKS_PER_US);
            self.sim.run_for_us(slice.div_ceil(TICKS_PER_US))?;
            self.watch()?;
        }
        Ok(())
    }

    /// Runs until `done` holds (looked at every millisecond), at most `limit_us`; whether it
    /// held.
    fn run_until(
        &mut self,
        limit_us: u64,
        mut done: impl FnMut(&mut Self) -> bool,
    ) -> Result<bool, Stop> {
        let end = self.sim.now + limit_us * TICKS_PER_US;
        loop {
            if done(self) {
                return Ok(true);
            }
            if self.sim.now >= end {
                return Ok(false);
            }
            self.run_for(WATCH_US)?;
        }
    }

    /// Runs until `done` holds, at most until `limit_us` and [`BOUND_CYCLES`] data exchange
    /// cycles have both passed (the inputs cross the bus once a cycle: at 9.6k a cycle takes
    /// longer than the drive takes to act), and never past [`BOUND_CAP_US`]; whether it held.
    fn run_until_cycles(
        &mut self,
        limit_us: u64,
        mut done: impl FnMut(&mut Self) -> bool,
    ) -> Result<bool, Stop> {
        let t0 = self.sim.now_us();
        // Cycles counted across a master that starts again (its count starts from 0).
        let (mut last, mut cycles) = (self.cycles(), 0);
        loop {
            if done(self) {
                return Ok(true);
            }
            let now = self.cycles();
            cycles += now.checked_sub(last).unwrap_or(now);
            last = now;
            let elapsed = self.sim.now_us() - t0;
            let bound = elapsed >= limit_us && cycles >= BOUND_CYCLES;
            if bound || elapsed >= BOUND_CAP_US {
                return Ok(false);
            }
            self.run_for(WATCH_US)?;
        }
    }

    /// The invariants that hold at every moment.
    fn watch(&mut self) -> Step {
        // The drive's control word in the run's report: what the adapter told the drive, next
        // to what the PLC read and sent.
        let drive_control = self.sim.drive_now().control_word();
        if self.drive_control.replace(drive_control) != Some(drive_control) {
            self.sim
                .event(format!("drive: control word {drive_control:04X}"));
        }
        let f = &self.sim.figures;
        let (late, corrupt) = (f.late_responses, f.corrupt_delivered);
        self.check(late == 0, |_| {
            format!("a response started later than MaxTsdr ({late})")
        })?;
        self.check(corrupt == 0, |s| {
            let sent = s.sim.master.as_ref().map(|m| m.phy.recent.clone());
            format!(
                "the transceiver delivered a telegram no station sent: {:02X?} (the master's last: {sent:02X?})",
                s.sim.figures.first_corrupt
            )
        })?;
        let malformed = self.sim.bridge.status.malformed_telegrams;
        self.check(malformed == 0, |_| {
            format!("the firmware got {malformed} malformed telegrams")
        })?;
        let collisions = self.sim.bus.collisions;
        self.check(collisions == 0, |_| {
            format!("two stations drove the line ({collisions})")
        })?;
        // A new lock is at the rate of the master on the line, and at none without one.
        if let BaudState::Locked(b) = self.sim.adapter.baud_state() {
            if self.lock_seen != Some(b) {
                let master = self.sim.master.as_ref().map(|m| m.setup.baud);
                self.check(master == Some(b), |_| {
                    format!("a false lock: at {b} with the master at {master:?}")
                })?;
            }
            self.lock_seen = Some(b);
        }
        // Every input the master reads carries a set frequency some master sent (or the
        // fail-safe one): never a value that came from nowhere.
        let cycles = self.cycles();
        if cycles != self.inputs_seen_at {
            self.inputs_seen_at = cycles;
            let at = self.plan.pzd_at();
            if let Some(&pzd2) = self.inputs().get(at + 1) {
                let known = self.sent.contains(&pzd2);
                self.check(known, |_| {
                    format!("the inputs' PZD2 is {pzd2}, a set frequency no master sent")
                })?;
            }
            self.plc_step();
        }
        Ok(())
    }

    /// In the translating profiles, the PLC answers the status word of the cycle just done.
    fn plc_step(&mut self) {
        if !self.plan.translates() {
            return;
        }
        let Some(sw) = self.status_word() else {
            return;
        };
        let before = self.plc.control;
        let control = self.plc.next(sw, (self.sim.now_us(), self.cycles()));
        if control != before {
            self.put_outputs();
        }
        if self.plc.status.replace(sw) != Some(sw) || control != before {
            self.sim.event(format!(
                "plc: status word {sw:04X}, control word {control:04X}"
            ));
        }
    }

    /// The status word in the inputs, if the PPO has one.
    fn status_word(&self) -> Option<u16> {
        self.inputs().get(self.plan.pzd_at()).copied()
    }

    /// The adapter's stack at its deepest stayed clear of the statics (under QEMU).
    fn check_stack(&mut self) -> Step {
        if let Some(p) = self.sim.bridge.firmware.stack_peak()? {
            self.check(p.used_bytes < p.room_bytes, |_| {
                format!(
                    "the stack ran into the statics: {} of the {} B above them",
                    p.used_bytes, p.room_bytes
                )
            })?;
        }
        Ok(())
    }

    /// After every event: a master at the plan's rate brings the adapter back to data
    /// exchange within its bound, a new set frequency goes to the drive and comes back in the
    /// inputs within its bound, and in the translating profiles the status word that comes
    /// with it says OPERATION ENABLED within the PLC's walk (no state is stuck).
    fn recover(&mut self) -> Step {
        if self.sim.master.is_none() {
            self.start_master()?;
        }
        let baud = self.plan.baud;
        // Parameterisation may wait for the baud watchdog (a rate change the adapter missed)
        // and the DP watchdog: the scenarios' limit, plus both.
        let bound_us = scenarios::limit_us(baud) + 2_000_000 + self.plan.watchdog_ms() * 1_000;
        let start = self.cycles();
        let ok = self.run_until(bound_us, |s| {
            let running = s.sim.master.as_mut().is_some_and(|m| m.running());
            running && s.cycles() >= start + 3
        })?;
        self.check(ok, |_| {
            format!("no data exchange at {baud} within {} ms", bound_us / 1000)
        })?;
        self.new_frequency(self.frequency % 4900 + 100)?;
        if self.plan.translates() {
            // The PLC's walk through figure 9: a RESET held and released, SWITCH-ON INHIBIT,
            // the OFF1 ramp down, then a cycle a step. Read on inputs that carry the set
            // frequency just sent: a status word from before the master's outputs arrived
            // (a new master's first Data_Exchange is all zeros, an OFF2) is no proof.
            let ramp_us = u64::from(DECELERATION) * 100_000;
            let bound_us = 4 * RESET_HOLD_US + ramp_us + 200_000;
            let operating = self.run_until_cycles(bound_us, |s| {
                s.plan.operating_after(&s.inputs(), s.frequency)
            })?;
            self.check(operating, |s| {
                format!(
                    "{:?}: not in OPERATION ENABLED within {} ms and {BOUND_CYCLES} cycles (status word {:04X?})",
                    s.plan.operation,
                    bound_us / 1000,
                    s.status_word()
                )
            })?;
        }
        Ok(())
    }

    /// The master sends `frequency`; the inputs must carry it back through the drive within
    /// 200 ms and 10 data exchange cycles (whichever is later).
    fn new_frequency(&mut self, frequency: u16) -> Step {
        self.frequency = frequency;
        self.sent.insert(frequency);
        self.put_outputs();
        self.frequency_comes_back(frequency)
    }

    /// The inputs carry `frequency` back through the drive within 200 ms and 10 data exchange
    /// cycles (whichever is later).
    fn frequency_comes_back(&mut self, frequency: u16) -> Step {
        let (t0, c0) = (self.sim.now_us(), self.cycles());
        let at = self.plan.pzd_at();
        loop {
            if self.inputs().get(at + 1) == Some(&frequency) {
                return Ok(());
            }
            let late = self.sim.now_us() >= t0 + 200_000 && self.cycles() >= c0 + 10;
            let running = self.sim.master.as_mut().is_some_and(|m| m.running());
            self.check(!late && running, |s| {
                format!(
                    "set frequency {frequency} did not come back through the drive in {} ms, {} cycles (inputs {:04X?})",
                    (s.sim.now_us() - t0) / 1000,
                    s.cycles() - c0,
                    s.inputs()
                )
            })?;
            self.run_for(WATCH_US)?;
        }
    }

    fn event(&mut self, event: &Event) -> Step {
        match *event {
            Event::Steady { frequency, us } => {
                self.new_frequency(frequency)?;
                self.run_for(us)
            }
            Event::RateChange(baud) => {
                self.plan.baud = baud;
                self.start_master()
            }
            Event::NoiseBurst { us, count, seed } => {
                let from = self.sim.now;
                let to = from + us * TICKS_PER_US;
                let bit = self.clocks_per_bit();
                self.sim.bus.faults.glitches(seed, from, to, count, 2 * bit);
                self.run_for(us)
            }
            Event::Glitch { after_us, len_bits } => {
                let bit = self.clocks_per_bit();
                self.sim.bus.faults.add(FaultWindow {
                    start: self.sim.now + after_us * TICKS_PER_US,
                    len: len_bits * bit,
                    fault: LineFault::Invert,
                });
                self.run_for(after_us + 1_000)
            }
            Event::CablePull { us } => {
                self.sim.bus.faults.add(FaultWindow {
                    start: self.sim.now,
                    len: us * TICKS_PER_US,
                    fault: LineFault::Stuck(true),
                });
                self.silence(us)
            }
            Event::MasterAway { us } => {
                self.sim.stop_master();
                self.silence(us)
            }
            Event::SecondMaster => {
                let master = self.take_master_on_a_quiet_line()?;
                let mut c = Checks::default();
                let (t0, fail_safes) = (self.sim.now_us(), self.sim.bridge.status.fail_safes);
                scenarios::probe_services(&mut self.sim, &mut c, self.plan.baud)?;
                let away_us = self.sim.now_us() - t0;
                if self.sim.bridge.status.fail_safes > fail_safes {
                    // The tool held the bus past the master's watchdog (at the slow rates its
                    // requests take that long): the slave left data exchange, rightly, part
                    // way through, and the answers are those of whichever state each met.
                    let due = away_us >= self.plan.watchdog_ms() * 1_000;
                    c = Checks::default();
                    c.check(
                        format!(
                            "the watchdog expired only past its {} ms",
                            self.plan.watchdog_ms()
                        ),
                        due,
                    );
                }
                if let Some(master) = master {
                    self.sim.put_master_back(master);
                }
                for (what, ok) in c.0 {
                    self.check(ok, |_| format!("a second master's request: {what}"))?;
                }
                Ok(())
            }
            Event::SetPrm(plan) => {
                if plan.operation.translates() != self.plan.translates() {
                    self.plc.control = if plan.translates() { pd::READY } else { RUN };
                }
                self.plan = Plan {
                    baud: self.plan.baud,
                    ..plan
                };
                self.start_master()
            }
            Event::PlcStop => self.plc_stop(),
            Event::SyncFreeze { freeze } => self.sync_freeze(freeze),
            Event::SetSlaveAdd { address, cut } => self.set_slave_add(address, cut),
            Event::Dpv1 { value } => self.dpv1(value),
            Event::PowerCycle { after_us } => {
                self.run_for(after_us)?;
                let before = self.sim.bridge.stored()?;
                self.sim.power_cycle()?;
                let after = self.sim.bridge.stored()?;
                self.check(after == before, |_| {
                    format!("the storage changed over a power cycle: {before:?} -> {after:?}")
                })?;
                let address = self.sim.bridge.status.address;
                self.check(address == SWITCH_ADDRESS, |_| {
                    format!("after a power cycle the adapter is at address {address}")
                })
            }
            Event::DriveFault => self.drive_fault(),
            Event::DriveWarning { code } => self.drive_warning(code),
            Event::DriveLink { fault, us } => self.drive_link(fault, us),
            Event::Pkw(request) => self.pkw(request),
        }
    }

    /// No telegram reaches the adapter for `us`: past the DP watchdog, the drive must get the
    /// fail-safe within the watchdog's time (and a margin for profirust's rounding of it and
    /// the drive link's cycle).
    fn silence(&mut self, us: u64) -> Step {
        let fail_safes = self.sim.bridge.status.fail_safes;
        let watchdog_us = self.plan.watchdog_ms() * 1_000;
        let bound_us = watchdog_us + watchdog_us / 10 + 20_000;
        if us <= bound_us {
            return self.run_for(us);
        }
        let t0 = self.sim.now_us();
        let applied = self.run_until(bound_us, |s| s.sim.bridge.status.fail_safes > fail_safes)?;
        self.check(applied, |s| {
            format!(
                "no fail-safe within {} ms of the master's silence (watchdog {} ms)",
                bound_us / 1000,
                s.plan.watchdog_ms()
            )
        })?;
        self.run_for(20_000)?;
        self.check_fail_safe_drive("the watchdog")?;
        let spent = self.sim.now_us() - t0;
        self.run_for(us.saturating_sub(spent))
    }

    /// What the drive runs with in the plan's fail-safe mode.
    fn check_fail_safe_drive(&mut self, cause: &str) -> Step {
        let (mode, frequency) = (self.plan.fail_safe, self.frequency);
        let d = self.sim.drive_now();
        let (cw, f) = (
            d.control_word(),
            d.read_register(SET_FREQUENCY).unwrap_or(0),
        );
        let ok = match mode {
            FailSafeMode::Stop => cw & control::RUN == 0,
            FailSafeMode::LastSpeed => cw == RUN && f == frequency,
            FailSafeMode::UseFailSafeValues => cw == RUN && f == FAIL_SAFE_FREQUENCY,
        };
        self.check(ok, |s| {
            format!(
                "after {cause}, fail-safe {mode:?}: the drive has CW {cw:04X}, F0.29 {f} (last sent {frequency}); {:?}, the master's control word {:04X}, the last status word {:04X?}, drive link error {:02X}",
                s.plan.operation,
                s.plc.control,
                s.status_word(),
                s.sim.bridge.status.drive_link_error
            )
        })
    }

    /// The master steps aside for a tool (a second master) once its last request has had its
    /// answer: the line idle for MaxTsdr and two bits after it, nothing on its way out, as a
    /// master passes the token, not between a request and its answer.
    fn take_master_on_a_quiet_line(&mut self) -> Result<Option<crate::cosim::Master>, Stop> {
        let end = self.sim.now + 1_000_000 * TICKS_PER_US;
        let quiet_bits = u64::from(self.plan.baud.adapter_max_tsdr_bits()) + 2;
        let quiet = quiet_bits * self.clocks_per_bit();
        let taken = self.sim.run_until(end, |s| {
            let master_quiet = s.master.as_ref().is_none_or(|m| {
                m.phy.tx.done() && s.now.saturating_sub(m.phy.last_activity) >= quiet
            });
            master_quiet && s.adapter.drive().is_none() && !s.response_pending()
        })?;
        self.check(taken, |_| {
            "the line was never quiet for a second master in 1 s".into()
        })?;
        Ok(self.sim.take_master())
    }

    /// A Global_Control `command` from the master's address, by a tool while the master
    /// steps aside.
    fn global_control(&mut self, command: u8) -> Step {
        let Some(master) = self.take_master_on_a_quiet_line()? else {
            return Ok(());
        };
        scenarios::global_control(&mut self.sim, &master.setup, command)?;
        self.sim.put_master_back(master);
        Ok(())
    }

    /// Sync holds the outputs the master sends until the next Sync (Unsync lets them go);
    /// Freeze holds the inputs the master reads until Unfreeze (seed 004's Sync/Freeze; the
    /// GSD offers both). Either is ignored where Set_Prm did not ask for it.
    fn sync_freeze(&mut self, freeze: bool) -> Step {
        use dp_consts::control_command as gc;
        let old = self.frequency;
        self.global_control(if freeze { gc::FREEZE } else { gc::SYNC })?;
        let new = old % 4900 + 100;
        self.frequency = new;
        self.sent.insert(new);
        self.put_outputs();
        if !self.plan.sync_freeze {
            return self.frequency_comes_back(new);
        }
        // Held for 10 cycles and 50 ms: the drive keeps the old set frequency under Sync;
        // the inputs keep it under Freeze, while the drive takes the new one.
        let at = self.plan.pzd_at();
        let (t0, c0) = (self.sim.now_us(), self.cycles());
        loop {
            let pzd2_in = self.inputs().get(at + 1).copied();
            let drive = self
                .sim
                .drive_now()
                .read_register(SET_FREQUENCY)
                .unwrap_or(0);
            let held = if freeze {
                pzd2_in == Some(old)
            } else {
                drive == old
            };
            self.check(held, |_| {
                format!(
                    "{} did not hold: the drive has {drive}, the inputs' PZD2 {pzd2_in:?} (old {old}, new {new})",
                    if freeze { "Freeze" } else { "Sync" }
                )
            })?;
            if self.sim.now_us() >= t0 + 50_000 && self.cycles() >= c0 + 10 {
                break;
            }
            self.run_for(WATCH_US)?;
        }
        if freeze {
            let drive = self.sim.drive_now().read_register(SET_FREQUENCY).ok();
            self.check(drive == Some(new), |_| {
                format!("under Freeze the outputs stopped: the drive has {drive:?}, not {new}")
            })?;
            self.global_control(gc::UNFREEZE)?;
        } else {
            // The next Sync lets the held outputs go, then Unsync ends the mode.
            self.global_control(gc::SYNC)?;
            self.global_control(gc::UNSYNC)?;
        }
        self.frequency_comes_back(new)
    }

    /// Set_Slave_Add and a power cut in or after its storage write: the storage loads the
    /// old record or the new one, never a third thing or nothing where it had one; the adapter
    /// comes up at what it loaded and reaches data exchange there.
    fn set_slave_add(&mut self, address: u8, cut: Option<u32>) -> Step {
        // The master leaves; with the switch at 0 the board comes up at the stored address
        // (126 with none), waiting for its parameters, where Set_Slave_Add is allowed.
        self.sim.stop_master();
        self.sim.bridge.switch = 0;
        self.sim.power_cycle()?;
        let old = self.sim.bridge.stored()?.address;
        let at = self.sim.bridge.status.address;
        self.check(at == old.map_or(126, |r| r.address), |_| {
            format!("switch 0: the adapter at {at}, with {old:?} stored")
        })?;
        let before = self.sim.bridge.firmware.storage()?;
        let answer = scenarios::set_slave_add_request(&mut self.sim, self.plan.baud, at, address)?;
        self.check(answer.as_deref() == Some(&[dp_consts::SC][..]), |_| {
            format!("Set_Slave_Add {at} -> {address}: the answer {answer:02X?}, not SC")
        })?;
        let new = NvRecord {
            address,
            no_add_chg: false,
        };
        let written = self.run_until(20_000, |s| {
            s.sim.bridge.stored().is_ok_and(|c| c.address == Some(new))
        })?;
        self.check(written, |_| {
            format!("Set_Slave_Add to {address}: not in the storage within 20 ms")
        })?;
        if let Some(permille) = cut {
            let after = self.sim.bridge.firmware.storage()?;
            let torn = torn_write(&before, &after, permille);
            self.sim.bridge.firmware.set_storage(torn)?;
        }
        self.sim.power_cycle()?;
        let loaded = self.sim.bridge.stored()?.address;
        let up_at = self.sim.bridge.status.address;
        self.check(loaded == old || loaded == Some(new), |_| {
            format!("a power cut in the storage write left {loaded:?} (old {old:?}, new {new:?})")
        })?;
        self.check(cut.is_some() || loaded == Some(new), |_| {
            format!("the write was complete, and the storage loads {loaded:?}")
        })?;
        self.check(up_at == loaded.map_or(126, |r| r.address), |_| {
            format!("the adapter came up at {up_at} with {loaded:?} stored")
        })?;
        self.start_master_at(up_at)?;
        let bound_us = scenarios::limit_us(self.plan.baud) + 2_000_000;
        let exchange = self.run_until(bound_us, |s| {
            s.sim.master.as_mut().is_some_and(|m| m.running()) && s.cycles() >= 3
        })?;
        self.check(exchange, |_| {
            format!(
                "no data exchange at address {up_at} within {} ms",
                bound_us / 1000
            )
        })?;
        // The switch back: the address is the switch's again, the record stays.
        self.sim.stop_master();
        self.sim.bridge.switch = SWITCH_ADDRESS;
        self.sim.power_cycle()?;
        let back = self.sim.bridge.status.address;
        self.check(back == SWITCH_ADDRESS, |_| {
            format!("the switch back at {SWITCH_ADDRESS}: the adapter at {back}")
        })
    }

    /// Parameters over DP-V1 (seed 004's examples and errors): each request answered, as
    /// the manual says, within 300 ms.
    fn dpv1(&mut self, value: u16) -> Step {
        use profidrive::pd_access::{RequestId, Values};
        if !self.plan.dpv1 {
            return self.new_frequency(self.frequency % 4900 + 100);
        }
        let ident = u32::from(dp_consts::ADAPTER_IDENT_NUMBER);
        let x = scenarios::dpv1_request(
            &mut self.sim,
            1,
            RequestId::Read,
            &[scenarios::param(964, 0)],
            &[],
        )?;
        let got = x.words(0);
        self.check(got == Some(vec![ident]), |_| {
            format!("DP-V1 read of 964: {got:04X?}, not the Ident_Number {ident:04X}")
        })?;
        let x = scenarios::dpv1_request(
            &mut self.sim,
            2,
            RequestId::Read,
            &[scenarios::param(918, 0)],
            &[],
        )?;
        let got = x.words(0);
        self.check(got == Some(vec![u32::from(SWITCH_ADDRESS)]), |_| {
            format!("DP-V1 read of 918 (the node address): {got:?}")
        })?;
        // 12.02, a drive parameter (seed 004's example 2b), written and read back. Seed 004
        // lines 1078-1090: with a PKW channel (PPO1, 2, 5) DP-V1 only reads, and a write is
        // refused with 0Bh (no operation priority), the drive untouched.
        let before = self.sim.drive_now().read_register(0xFB02).ok();
        let bytes = value.to_be_bytes();
        let at = scenarios::drive_param(1202);
        let x = scenarios::dpv1_request(
            &mut self.sim,
            3,
            RequestId::Change,
            &[at],
            &[Values::word(&bytes)],
        )?;
        let writes = !self.plan.ppo.has_pkw();
        let answered = if writes {
            x.response().is_some_and(|r| r.id == 0x02)
        } else {
            x.response().is_some_and(|r| r.id == 0x82) && x.error(0) == Some(0x0B)
        };
        let held = self.sim.drive_now().read_register(0xFB02).ok();
        let want = if writes { Some(value) } else { before };
        let response = x.done.as_ref().map(|d| d.response.clone());
        self.check(answered && held == want, |s| {
            format!(
                "DP-V1 write of 12.02 = {value} with {:?}: the response {response:02X?}, the drive holds {held:?}, not {want:?}",
                s.plan.ppo
            )
        })?;
        let x = scenarios::dpv1_request(&mut self.sim, 4, RequestId::Read, &[at], &[])?;
        let got = x.words(0);
        self.check(got == want.map(|v| vec![u32::from(v)]), |_| {
            format!("DP-V1 read of 12.02 after the write: {got:?}, not {want:?}")
        })?;
        // A write to index 48: invalid index (seed 004's error classes).
        let x = scenarios::dpv1_job(
            &mut self.sim,
            crate::msac1_master::Job::Raw(vec![0x5F, 1, 48, 2, 1, 2]),
        )?;
        let got = x.done.map(|d| d.response);
        let want = [0xDF, 0x80, dp_consts::dpv1::error::INVALID_INDEX, 0];
        self.check(got.as_deref() == Some(&want[..]), |_| {
            format!("DP-V1 write to index 48: {got:02X?}, not {want:02X?}")
        })
    }

    fn plc_stop(&mut self) -> Step {
        // As the master last saw it, before it steps aside (its inputs go with it).
        let before = format!(
            "a PLC stop (the drive had CW {:04X}, the status word was {:04X?})",
            self.sim.drive_now().control_word(),
            self.status_word()
        );
        let Some(master) = self.take_master_on_a_quiet_line()? else {
            return Ok(());
        };
        let fail_safes = self.sim.bridge.status.fail_safes;
        scenarios::plc_stop(&mut self.sim, &master.setup)?;
        let applied = self.run_until(20_000, |s| s.sim.bridge.status.fail_safes > fail_safes)?;
        self.check(applied, |_| {
            "no fail-safe within 20 ms of a PLC stop".into()
        })?;
        self.run_for(20_000)?;
        self.check_fail_safe_drive(&before)
    }

    /// The drive trips: its status word says so, and the master's reset clears it (the
    /// vendor's FAULT_RESET; in the translating profiles the PLC's RESET, once the fault has
    /// been seen latched).
    fn drive_fault(&mut self) -> Step {
        self.plc.acknowledge = false;
        self.sim.drive_now().inject_fault(12);
        let faulted = self.run_until_cycles(100_000, |s| {
            s.status_word().is_some_and(|w| s.plan.faulted(w))
        })?;
        self.check(faulted, |s| {
            format!(
                "a drive fault not in the status word within 100 ms and {BOUND_CYCLES} cycles ({:04X?})",
                s.inputs()
            )
        })?;
        self.plc.acknowledge = true;
        if !self.plan.translates() {
            self.plc.control = RUN | control::FAULT_RESET;
            self.put_outputs();
        }
        let bound_us = 100_000 + 2 * RESET_HOLD_US;
        let reset = self.run_until_cycles(bound_us, |s| {
            s.status_word().is_some_and(|w| !s.plan.faulted(w))
                && s.sim.drive_now().fault().is_none()
        })?;
        self.check(reset, |s| {
            format!(
                "the fault reset did not clear the fault in {} ms and {BOUND_CYCLES} cycles ({:04X?})",
                bound_us / 1000,
                s.inputs()
            )
        })?;
        if !self.plan.translates() {
            self.plc.control = RUN;
            self.put_outputs();
        }
        Ok(())
    }

    /// A warning shows in the status word (seed 000's bit 14, table 8's ALARM) and goes with
    /// it; the drive runs on, no fail-safe.
    fn drive_warning(&mut self, code: u8) -> Step {
        let fail_safes = self.sim.bridge.status.fail_safes;
        let warns = |s: &mut Self| s.status_word().is_some_and(|w| s.plan.warns(w));
        self.sim.drive_now().set_warning(Some(code));
        let shown = self.run_until_cycles(100_000, warns)?;
        self.check(shown, |s| {
            format!("warning AL.{code:02} not in the status word within 100 ms and {BOUND_CYCLES} cycles ({:04X?})", s.inputs())
        })?;
        self.sim.drive_now().set_warning(None);
        let gone = self.run_until_cycles(100_000, |s| !warns(s))?;
        self.check(gone, |_| {
            format!("warning AL.{code:02} still in the status word 100 ms and {BOUND_CYCLES} cycles after it went")
        })?;
        let (cw, f) = {
            let d = self.sim.drive_now();
            (d.control_word(), d.read_register(SET_FREQUENCY).ok())
        };
        let frequency = self.frequency;
        let running = cw == RUN && f == Some(frequency);
        self.check(
            running && self.sim.bridge.status.fail_safes == fail_safes,
            |_| format!("a warning stopped the drive: CW {cw:04X}, F0.29 {f:?} (sent {frequency})"),
        )
    }

    /// The drive link fails for `us`: a loss long enough shows in the status word (seed
    /// 000's C0xxh; TRIPPED in the translating profiles), and there, with the link back, the
    /// TRIPPED holds until the master's RESET (issue 30).
    fn drive_link(&mut self, fault: LinkFault, us: u64) -> Step {
        let t0 = self.sim.now_us();
        self.plc.acknowledge = false;
        self.sim.drive_now().link_fault = fault;
        // The link is down after its retries. A fault of 100 ms or more lasts until the
        // inputs have crossed the bus a few times.
        let must_show = fault != LinkFault::Noise && us >= 100_000;
        let link_error = |s: &mut Self| s.status_word().is_some_and(|w| s.plan.shows_link_loss(w));
        let shown = if must_show {
            self.run_until_cycles(us, link_error)?
        } else {
            self.run_until(us, link_error)?
        };
        self.check(shown || !must_show, |_| {
            format!(
                "the drive link {fault:?} for {} ms and {BOUND_CYCLES} cycles, never shown in PZD1",
                us / 1000
            )
        })?;
        let spent = self.sim.now_us() - t0;
        self.run_for(us.saturating_sub(spent))?;
        self.sim.drive_now().link_fault = LinkFault::None;
        if self.plan.translates() && shown {
            let released = self.run_until_cycles(2 * RESET_HOLD_US, |s| {
                s.status_word().is_some_and(|w| !s.plan.faulted(w))
            })?;
            self.check(!released, |s| {
                format!(
                    "{:?}: the drive link back, TRIPPED went with no RESET ({:04X?})",
                    s.plan.operation,
                    s.inputs()
                )
            })?;
        }
        self.plc.acknowledge = true;
        Ok(())
    }

    fn pkw(&mut self, request: PkwRequest) -> Step {
        let put = |s: &mut Self, pkw: [u16; 4]| {
            if let Some(m) = s.sim.master.as_mut() {
                for (i, w) in pkw.iter().enumerate() {
                    m.outputs[2 * i..2 * i + 2].copy_from_slice(&w.to_be_bytes());
                }
            }
        };
        put(self, [0; 4]);
        let cleared =
            self.run_until_cycles(200_000, |s| s.inputs().get(..4) == Some(&[0, 0, 0, 0]))?;
        self.check(cleared, |_| {
            "the PKW reply did not clear within 200 ms and the bound's cycles".into()
        })?;
        put(self, request.words());
        let replied =
            self.run_until_cycles(200_000, |s| s.inputs().first().is_some_and(|&w| w != 0))?;
        let reply = replied.then(|| self.inputs()[..4].to_vec());
        let (right, got) = request.judge(&reply);
        self.check(right, |_| format!("PKW {request:?}: the reply {got}"))?;
        put(self, [0; 4]);
        Ok(())
    }
}

/// The storage as a power cut leaves it `permille` thousandths of the way through the write
/// that took it from `before` to `after`. Flash clears bits word by word and sets them only by
/// erasing a page: the write is taken as its words programmed in address order, and where it
/// erased a page (a move of the storage's items, whose order the diff cannot tell) the cut
/// falls before the whole write or after it.
pub fn torn_write(before: &[u8], after: &[u8], permille: u32) -> Vec<u8> {
    use nv_store::{PAGE_BYTES, WRITE_BYTES};
    let erased = before
        .chunks(PAGE_BYTES)
        .zip(after.chunks(PAGE_BYTES))
        .any(|(b, a)| b.iter().zip(a).any(|(b, a)| !b & a != 0));
    if erased {
        return if permille < 500 { before } else { after }.to_vec();
    }
    let changed: Vec<usize> = (0..before.len().min(after.len()))
        .step_by(WRITE_BYTES)
        .filter(|&at| before[at..at + WRITE_BYTES] != after[at..at + WRITE_BYTES])
        .collect();
    let done = changed.len() * permille.min(1000) as usize / 1000;
    let mut torn = before.to_vec();
    for &at in &changed[..done] {
        torn[at..at + WRITE_BYTES].copy_from_slice(&after[at..at + WRITE_BYTES]);
    }
    torn
}

/// Runs the campaign of `options` around `firmware`.
pub fn run<F: Firmware>(firmware: F, options: &Options) -> io::Result<(Summary, F)> {
    Soak::new(firmware)?.run(options)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 1, event 301, under QEMU: a new master at 12M, its first Data_Exchange all zeros
    /// (an OFF2), the inputs still those from before the master left. Only the status word
    /// that comes back with the new set frequency counts.
    #[test]
    fn operation_enabled_counts_only_on_inputs_that_carry_the_new_set_frequency() {
        let plan = Plan {
            baud: Baud::B12000000,
            ppo: Ppo::Ppo5,
            fail_safe: FailSafeMode::LastSpeed,
            watchdog_ms: 50,
            sync_freeze: false,
            dpv1: false,
            watchdog_1ms: false,
            operation: OperationMode::Profidrive,
        };
        let at = plan.pzd_at();
        let inputs = |sw: u16, pzd2: u16| {
            let mut words = vec![0; at + 10];
            words[at] = sw;
            words[at + 1] = pzd2;
            words
        };
        // What the report of that run shows, in order: the status word from before (with
        // 800, the old set frequency), OFF2 with the new one, SWITCH-ON INHIBIT, the walk.
        assert!(!plan.operating_after(&inputs(0x0237, 800), 900));
        assert!(!plan.operating_after(&inputs(0x0220, 900), 900));
        assert!(!plan.operating_after(&inputs(0x0270, 900), 900));
        assert!(!plan.operating_after(&inputs(0x0231, 900), 900));
        assert!(plan.operating_after(&inputs(0x0237, 900), 900));
        // TRIPPED is never operating; the vendor profile asks nothing of the status word.
        assert!(!plan.operating_after(&inputs(0x023F, 900), 900));
        let vendor = Plan {
            operation: OperationMode::Vendor,
            ..plan
        };
        assert!(vendor.operating_after(&inputs(0, 900), 900));
        assert!(!vendor.operating_after(&inputs(0, 800), 900));
    }
}
