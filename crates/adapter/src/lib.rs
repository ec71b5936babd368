//! The adapter's MCU logic: from link messages to the DP slave and back, the station address
//! from the rotary switch and the non-volatile storage, and the LEDs of both manuals.
//!
//! The firmware is a thin shell around [`Adapter`]: it decodes a [`ToAdapter`] event and calls
//! [`Adapter::handle`], which runs the DP slave's decision on it, writes what changed in the
//! transceiver's buffers (registers, inputs, diagnosis, configuration: the transceiver answers
//! the bus from them by itself), then runs the drive application's own cycle, writes again
//! what that changed, and ends with the [`Status`] (LEDs, storage, the next wake-up). Nothing
//! here knows of Cortex-M, QEMU or clocks: time arrives in the events.
//!
//! Station address (seed 000, "从站地址设置"): the switch has two decimal digits. 1-98 set the
//! address, and Set_Slave_Add is refused because the switch rules. 0 takes the address from
//! the non-volatile storage (1-126; 126 when it is empty), and Set_Slave_Add may change it.
//! 99 restores the factory defaults at power-up and then behaves as 0. A reading above 99
//! cannot come from two decimal digits; it is treated as 0, the setting that keeps the stored
//! configuration, and the boot log says so.
//!
//! The drive's fieldbus group 51 (seed 004, `profidrive::fieldbus_group`): the adapter shows its
//! module type, address, baud rate and PPO type there, and takes the PZD3-10 mapping (the
//! PROFIdrive 915/916 it keeps) from it at link-up and on each FBA PAR REFRESH; a 915/916
//! write goes back into the group. With the switch at 0, the node address 51.02 takes effect
//! on a refresh: the slave restarts at it and the storage keeps it. At power-up the address
//! stays seed 000's (switch or storage) and 51.02 shows it: the two manuals disagree there, and
//! the stored address is the one Set_Slave_Add keeps.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

use dp_link::{
    FromAdapter, HostLed, Led, Leds, NvContents, NvParams, NvRecord, NvWrite, Regs, SlaveState,
    Status, ToAdapter,
};
use dp_slave::{Application, Config, FailSafeReason, Instant, IoSizes, Slave, State};
use drive_link::{LinkedDrive, ModbusMaster};
use embedded_hal_nb::serial::{Read, Write};
use profidrive::app::ModuleRequest;
use profidrive::fieldbus_group as fieldbus;
use profidrive::ppo::Ppo;
use profidrive::ProfidriveApp;

/// What the storage holds after a factory reset: the commissioning address, changeable.
pub const FACTORY_DEFAULTS: NvRecord = NvRecord {
    address: dp_consts::MAX_STATION_ADDRESS,
    no_add_chg: false,
};

/// The six PPO configurations of both manuals, from `profidrive::ppo`.
pub const PPO_CONFIGURATIONS: &[&[u8]] = &[
    Ppo::Ppo1.cfg(),
    Ppo::Ppo2.cfg(),
    Ppo::Ppo3.cfg(),
    Ppo::Ppo4.cfg(),
    Ppo::Ppo5.cfg(),
    Ppo::Ppo6.cfg(),
];

/// The drive application on its link: what the firmware runs, on the drive UART `uart`.
pub type DriveApp<U> = ProfidriveApp<LinkedDrive<U>>;

/// The firmware's version (`git describe`, as its build names it), also in 964.2.
pub use profidrive::identification::VERSION as FIRMWARE_VERSION;

/// The drive application: PROFIdrive over the Modbus RTU link to seed 000's drive on `uart`.
/// A constant where `uart` is one (see [`Adapter::unpowered`]).
// Always inlined, with the constructors it calls: the firmware builds the adapter once, at
// boot, and inlined they write it in place instead of into temporaries copied up a level (the
// boot frame is 0.45 KiB smaller, on the production board's 20 KiB).
#[inline(always)]
pub const fn drive_app<U: Read<u8> + Write<u8>>(uart: U) -> DriveApp<U> {
    ProfidriveApp::new(LinkedDrive::new(ModbusMaster::new(
        uart,
        drive_link::Config::DEFAULT,
    )))
}

/// One step of the drive application's cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Steps remain.
    More,
    /// The cycle is over; it must run again at this time at the latest, if ever.
    Done(Option<u64>),
}

/// What runs beside the DP slave after every message: the drive application's own cycle.
pub trait Background {
    /// Runs the whole cycle at `now_us`; returns when it must run again at the latest, if ever.
    fn run(&mut self, now_us: u64) -> Option<u64> {
        let mut step = 0;
        loop {
            match self.run_step(now_us, step) {
                Step::More => step += 1,
                Step::Done(at) => return at,
            }
        }
    }
    /// Runs step `step` (0, 1, ...) of the cycle at `now_us`. The cycle is cut in steps so that
    /// an event that needs the firmware's decision waits for one step, not a whole cycle.
    fn run_step(&mut self, _now_us: u64, _step: u8) -> Step {
        Step::Done(None)
    }
    /// The cycle's first steps that make the drive link's turn: the drive's answer in, the
    /// process data across, the next request out. A drive answer runs them at once, ahead of
    /// the rest of a cycle under way ([`Adapter::drive_answer`]).
    fn drive_turn_steps(&self) -> u8 {
        0
    }
    /// New outputs came, at `now_us`: where the drive link is free, they go to it at once
    /// (the turn's process data and request steps), without waiting for a cycle. Returns
    /// whether a request is on its way.
    fn outputs_turn(&mut self, _now_us: u64) -> bool {
        false
    }
    /// A Data_Exchange's outputs came at `now_us`, changed or not: the DP cycle's beat.
    fn data_exchange(&mut self, _now_us: u64) {}
    /// After the decision on a Data_Exchange's outputs: background work on the drive link
    /// that is best done right after them (a read of the in block kept clear of the next).
    /// Returns whether a request is on its way.
    fn after_outputs_turn(&mut self, _now_us: u64) -> bool {
        false
    }
    /// Bytes written to the drive UART since power-up.
    fn drive_tx_bytes(&self) -> u32 {
        0
    }
    /// The drive link's error value, 0 while it works.
    fn drive_link_error(&self) -> u8 {
        0
    }
    /// Seed 004's host LED: the link to the drive.
    fn host_led(&self) -> HostLed {
        HostLed::Off
    }
    /// The station address at power-up, and the rate each telegram came at (rate index of
    /// `dp_consts::Baud`), for the parameters that show them (PROFIdrive 918 and 963).
    fn station(&mut self, _address: u8) {}
    fn rate(&mut self, _baud_index: u8) {}
    /// Whether the adapter accessed the drive, and the drive answered, lately (at `now_us`).
    fn drive_activity(&self, _now_us: u64) -> (bool, bool) {
        (false, false)
    }
    /// A station address asked for from the drive's side (51.02 after a refresh), once.
    fn requested_station(&mut self) -> Option<u16> {
        None
    }
    /// Whether the station address may be set by a parameter (the switch is at 0).
    fn node_address_writable(&mut self, _writable: bool) {}
    /// A parameter write for the adapter to carry out (918, 972), once.
    fn take_module_request(&mut self) -> Option<ModuleRequest> {
        None
    }
    /// The module restarted (972).
    fn restarted(&mut self) {}
    /// Set_Prm carries DPV1_Status_1-3 (the drive's 51.21 DP MODE is DP-V1).
    fn dpv1_mode(&self) -> bool {
        false
    }
    /// The settings the storage keeps for 971, as they are now (none: nothing to keep).
    fn nv_params(&self) -> Option<NvParams> {
        None
    }
    /// The settings the storage kept, at power-up.
    fn restore_nv_params(&mut self, _params: NvParams) {}
}

/// A UART that counts what it sent (the simulated drive link's lockstep needs the count).
pub trait CountsSent {
    fn bytes_sent(&self) -> u32;
}

#[cfg(any(test, feature = "testing"))]
impl Background for dp_slave::testing::EchoApp {}

impl<U: Read<u8> + Write<u8> + CountsSent> Background for DriveApp<U> {
    fn run_step(&mut self, now_us: u64, step: u8) -> Step {
        let now = Instant::from_micros(now_us);
        // The drive link's turn first (DRIVE_TURN_STEPS): the answer in, the newest outputs
        // to the link, the next request out. Then what can wait for the transaction under
        // way: the parameter channel (its request goes with the next turn), DP-V1, the
        // fieldbus group, and the process data whole (the answer into the inputs, the
        // drive's faults, the mapping, the cut-off).
        match step {
            0 => self.drive_mut().pump(),
            1 => {
                self.drive_mut().poll_answer(now_us);
            }
            2 => {
                outputs_to_link(self);
            }
            3 => self.drive_mut().prepare_next(now_us),
            4 => self.drive_mut().send(now_us),
            5 => self.service_pkw(now),
            6 => self.service_dpv1(),
            7 => sync_fieldbus_group(self),
            8 => self.service_pzd(now),
            _ => {
                self.service_pkw(now);
                return Step::Done(self.drive().poll_at());
            }
        }
        Step::More
    }

    fn drive_turn_steps(&self) -> u8 {
        DRIVE_TURN_STEPS
    }

    fn outputs_turn(&mut self, now_us: u64) -> bool {
        if !self.drive().is_free() {
            return false;
        }
        // The turn's process data and request steps at once (no read of the in block: it
        // waits for its time).
        if !outputs_to_link(self) {
            return false;
        }
        self.drive_mut().start_for_outputs(now_us);
        !self.drive().is_free()
    }

    fn data_exchange(&mut self, now_us: u64) {
        self.drive_mut().data_exchange(now_us);
    }

    fn after_outputs_turn(&mut self, now_us: u64) -> bool {
        self.drive_mut().read_after_outputs(now_us)
    }

    fn drive_tx_bytes(&self) -> u32 {
        self.drive().master().uart().bytes_sent()
    }

    fn drive_link_error(&self) -> u8 {
        self.drive().link_error().map_or(0, |e| e.code())
    }

    fn host_led(&self) -> HostLed {
        use profidrive::link_diag::DriveLink;
        // Lost or not is the link's error now, the Run LED's own test, so that the two change
        // in the same status; the diagnosis (noted once a cycle) says only whether there has
        // been an exchange yet and whether the loss has lasted a second.
        match (self.drive_link(), self.drive_link_error()) {
            (DriveLink::NotYet, _) => HostLed::Off,
            (_, 0) => HostLed::Green,
            (DriveLink::LostPermanently, _) => HostLed::Red,
            _ => HostLed::RedBlink,
        }
    }

    fn station(&mut self, address: u8) {
        self.params_mut().node_address = u16::from(address);
        self.drive_mut()
            .fieldbus_mut()
            .show(fieldbus::index::NODE_ADDRESS, u16::from(address));
    }

    fn rate(&mut self, baud_index: u8) {
        let Some(baud) = dp_consts::Baud::ALL.get(usize::from(baud_index)).copied() else {
            return;
        };
        // 963 counts the other way: 0 = 12M .. 9 = 9.6k (the SPC3's code).
        self.params_mut().baud_code = u16::from(baud.spc3_code());
        self.drive_mut()
            .fieldbus_mut()
            .show(fieldbus::index::BAUD_RATE, fieldbus::baud_rate_kbit(baud));
    }

    fn requested_station(&mut self) -> Option<u16> {
        self.drive_mut().fieldbus_mut().take_requested_address()
    }

    fn node_address_writable(&mut self, writable: bool) {
        self.params_mut().node_address_writable = writable;
    }

    fn take_module_request(&mut self) -> Option<ModuleRequest> {
        ProfidriveApp::take_module_request(self)
    }

    fn restarted(&mut self) {
        ProfidriveApp::restarted(self)
    }

    fn dpv1_mode(&self) -> bool {
        self.dp_mode_dpv1()
    }

    fn nv_params(&self) -> Option<NvParams> {
        let p = self.params();
        Some(NvParams {
            pkw_rights: p.pkw_rights,
            pzd_rights: p.pzd_rights,
            operating_mode: p.operating_mode,
            control_bit_selectors: p.control_bit_selectors,
            status_bit_selectors: p.status_bit_selectors,
        })
    }

    fn restore_nv_params(&mut self, kept: NvParams) {
        let p = self.params_mut();
        p.pkw_rights = kept.pkw_rights;
        p.pzd_rights = kept.pzd_rights;
        p.operating_mode = kept.operating_mode;
        p.control_bit_selectors = kept.control_bit_selectors;
        p.status_bit_selectors = kept.status_bit_selectors;
    }

    fn drive_activity(&self, now_us: u64) -> (bool, bool) {
        self.drive().activity(now_us)
    }
}

/// The PZD3-10 mapping between the drive's group 51 and 915/916: what the group read goes
/// into 915/916, and 915/916 (a PROFIdrive write, or what was just read) are shown there,
/// with the PPO type in force.
fn sync_fieldbus_group<U: Read<u8> + Write<u8>>(app: &mut DriveApp<U>) {
    if let Some(settings) = app.drive_mut().fieldbus_mut().take_settings() {
        let params = app.params_mut();
        // 915/916 index 3..10 (PZD1 and PZD2 are fixed).
        params.pzd_out[2..].copy_from_slice(&settings.pzd_out);
        params.pzd_in[2..].copy_from_slice(&settings.pzd_in);
        // 51.21: 1 is DP-V1, anything else DP-V0; the group shows the mode in force.
        let dpv1 = settings.dp_mode == fieldbus::DP_MODE_DPV1;
        app.set_dp_mode_dpv1(dpv1);
        let shown = if dpv1 {
            fieldbus::DP_MODE_DPV1
        } else {
            fieldbus::DP_MODE_DPV0
        };
        app.drive_mut()
            .fieldbus_mut()
            .show(fieldbus::index::DP_MODE, shown);
    }
    // PZD3-10 in force (`mapping_numbers`): the master's RdPZD/WrPZD in the vendor mode, where
    // the panel cannot change them (README "Differences from the manuals"). Before a
    // configuration nothing is in force: the drive's settings stay as they are.
    let (out, inp) = match app.ppo() {
        Some(_) => app.mapping_numbers(),
        None => (app.params().pzd_out, app.params().pzd_in),
    };
    let ppo = app.ppo().map(|p| u16::from(p.number()));
    let group = app.drive_mut().fieldbus_mut();
    group.show_mapping(&out[2..], &inp[2..]);
    if let Some(ppo) = ppo {
        group.show(fieldbus::index::PPO_TYPE, ppo);
    }
}

/// The outputs only, to the drive link's out image (the drive's answer and its faults wait
/// for the cycle's whole process-data step); false before a PZD configuration.
fn outputs_to_link<U: Read<u8> + Write<u8>>(app: &mut DriveApp<U>) -> bool {
    let Some((out, words)) = app.pzd_for_drive() else {
        return false;
    };
    app.drive_mut().set_outputs(&out[..words]);
    true
}

/// The drive application's cycle steps that make the drive link's turn (`run_step` 0..=4).
const DRIVE_TURN_STEPS: u8 = 5;

/// The switch position that restores the factory defaults.
pub const SWITCH_FACTORY_RESET: u8 = 99;
/// The highest address the switch can set.
pub const SWITCH_MAX_ADDRESS: u8 = 98;

/// Where the station address came from at power-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AddressSource {
    Switch,
    Storage,
    /// The storage was empty or invalid: the default address.
    Default,
    FactoryReset,
}

impl AddressSource {
    /// Seed 004 line 1490: a parameter (918) sets the address "with the switch at 0" only;
    /// switch 99 restores the factory address at every power-up, so a stored one would not last.
    pub fn parameter_may_set(self) -> bool {
        matches!(self, AddressSource::Storage | AddressSource::Default)
    }
}

/// The address, whether Set_Slave_Add may change it, and a record to write now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Addressing {
    pub address: u8,
    pub no_add_chg: bool,
    pub source: AddressSource,
    pub nv_write: Option<NvRecord>,
}

/// The status after a failed RAM test at power-up (seed 000 line 685, "上电常亮 MCU、DP 芯片
/// RAM 异常": Run steady on), which is also seed 004's "PROFIBUS communication ASIC
/// initialisation error" (its error LED at 4 Hz, line 1475): offline; the adapter does not
/// start.
pub fn ram_fault_status() -> Status {
    Status {
        leds: Leds {
            run: Led::On,
            error: Led::Blink4Hz,
            offline: Led::On,
            ..Leds::OFF
        },
        ..Status::POWER_ON
    }
}

/// Resolves the station address at power-up from the switch and the storage.
pub const fn addressing(switch: u8, nv: Option<NvRecord>) -> Addressing {
    match switch {
        1..=SWITCH_MAX_ADDRESS => Addressing {
            address: switch,
            no_add_chg: true,
            source: AddressSource::Switch,
            nv_write: None,
        },
        SWITCH_FACTORY_RESET => Addressing {
            address: FACTORY_DEFAULTS.address,
            no_add_chg: FACTORY_DEFAULTS.no_add_chg,
            source: AddressSource::FactoryReset,
            nv_write: Some(FACTORY_DEFAULTS),
        },
        _ => match nv {
            Some(r) if r.address >= 1 && r.address <= dp_consts::MAX_STATION_ADDRESS => {
                Addressing {
                    address: r.address,
                    no_add_chg: r.no_add_chg,
                    source: AddressSource::Storage,
                    nv_write: None,
                }
            }
            _ => Addressing {
                address: FACTORY_DEFAULTS.address,
                no_add_chg: false,
                source: AddressSource::Default,
                nv_write: None,
            },
        },
    }
}

/// The slave's state as the link names it.
pub fn link_state(state: State) -> SlaveState {
    match state {
        State::PowerOn => SlaveState::PowerOn,
        State::WaitPrm => SlaveState::WaitPrm,
        State::WaitCfg => SlaveState::WaitCfg,
        State::DataExch => SlaveState::DataExch,
    }
}

/// The application as the slave sees it, with the adapter's bookkeeping around it.
struct Recording<A> {
    inner: A,
    nv_write: Option<NvWrite>,
    /// The record written last since power-up (a restart takes its address).
    last_record: Option<NvRecord>,
    outputs_applied: u32,
    fail_safes: u16,
}

impl<A> Recording<A> {
    /// A record for the storage, written with the next status.
    fn write_record(&mut self, record: NvRecord) {
        self.nv_write = Some(NvWrite::Address(record));
        self.last_record = Some(record);
    }
}

impl<A: Application> Application for Recording<A> {
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
        self.inner.accept_user_prm(user_prm)
    }
    fn accept_cfg(&mut self, cfg: &[u8]) -> Option<IoSizes> {
        self.inner.accept_cfg(cfg)
    }
    fn default_cfg(&self) -> &[u8] {
        self.inner.default_cfg()
    }
    fn outputs(&mut self, now: Instant, outputs: &[u8]) {
        self.outputs_applied = self.outputs_applied.wrapping_add(1);
        self.inner.outputs(now, outputs)
    }
    fn inputs(&mut self, now: Instant, inputs: &mut [u8]) {
        self.inner.inputs(now, inputs)
    }
    fn fail_safe(&mut self, now: Instant, reason: FailSafeReason) {
        self.fail_safes = self.fail_safes.wrapping_add(1);
        if cfg!(feature = "broken-fail-safe") {
            return;
        }
        self.inner.fail_safe(now, reason)
    }
    fn ext_diag(&mut self, buffer: &mut [u8]) -> usize {
        self.inner.ext_diag(buffer)
    }
    fn ext_diag_reported(&self) -> bool {
        self.inner.ext_diag_reported()
    }
    fn diag_changed(&mut self) -> bool {
        self.inner.diag_changed()
    }
    fn static_diag(&self) -> bool {
        self.inner.static_diag()
    }
    fn store_address(&mut self, address: u8, no_add_chg: bool) {
        self.write_record(NvRecord {
            address,
            no_add_chg,
        });
        self.inner.store_address(address, no_add_chg)
    }
    fn msac1(&mut self, now: Instant, request: &dp_slave::msac1::Request, out: &mut [u8]) -> usize {
        self.inner.msac1(now, request, out)
    }
}

/// What the adapter hands its caller while it handles an event, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Out<'a> {
    /// A write for the transceiver: send it on the link.
    Write(FromAdapter<'a>),
    /// The writes of the event's decision are all out; the drive application's cycle follows
    /// (a simulation marks the time here).
    DecisionWritten,
    /// Bytes for the drive are queued: send them now, before the work that follows (new
    /// outputs' request goes out ahead of the inputs' write to the transceiver).
    DriveQueued,
}

/// Global_Control, to one station or many.
fn is_global_control(request: &fdl::Repr) -> bool {
    matches!(request, fdl::Repr::Data(d) if d.dsap == Some(fdl::Sap::GLOBAL_CONTROL))
}

/// An MSAC1 request (SAP 51 with data; a poll has none).
fn is_msac1_request(request: &fdl::Repr) -> bool {
    matches!(request, fdl::Repr::Data(d) if d.dsap == Some(fdl::Sap::MSAC1) && !d.payload.is_empty())
}

/// The largest buffer the responder holds.
const BUFFER_LEN: usize = dp_consts::MAX_DATA_UNIT_LEN;
type Buffer = heapless::Vec<u8, BUFFER_LEN>;

/// Where the drive application's cycle stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CycleStep {
    /// The application's own step `n` ([`Background::run_step`]).
    App(u8),
    /// The writes of what the cycle changed: the inputs,
    Write,
    /// the diagnosis, the configuration,
    Diag,
    Cfg,
    /// and the status (each a step of its own: together they would hold the MCU longer than
    /// a Data_Exchange may wait at 12 Mbit/s).
    Status,
}

/// Which of the responder's buffers to write.
#[derive(Clone, Copy, Debug)]
struct Parts {
    inputs: bool,
    diag: bool,
    cfg: bool,
}

impl Parts {
    const NONE: Parts = Parts {
        inputs: false,
        diag: false,
        cfg: false,
    };
}

/// What the transceiver was last given, so that only changes cross the link.
struct Written {
    regs: Option<Regs>,
    inputs: Option<Buffer>,
    diag: Option<Buffer>,
    cfg: Option<Buffer>,
    status: Option<Status>,
}

impl Written {
    /// Nothing given yet. A function, not a constant: a constant is an 832-byte image in flash
    /// that a board building the adapter at Boot would copy.
    const fn none() -> Written {
        Written {
            regs: None,
            inputs: None,
            diag: None,
            cfg: None,
            status: None,
        }
    }
}

/// `fresh`, if `written` did not hold it yet (`written` now does).
fn take_if_changed<'a>(written: &'a mut Option<Buffer>, fresh: &[u8]) -> Option<&'a [u8]> {
    if written.as_deref() == Some(fresh) {
        return None;
    }
    let held = written.get_or_insert_with(Buffer::new);
    held.clear();
    // A buffer never outgrows the responder's (`BUFFER_LEN`): the slave's are no longer.
    let _ = held.extend_from_slice(fresh);
    Some(held)
}

/// The adapter after power-up.
pub struct Adapter<A> {
    slave: Slave<Recording<A>>,
    addressing: Addressing,
    /// Data exchange happened since power-up: leaving it is a fault (Net blinks).
    exchanged: bool,
    malformed_telegrams: u16,
    /// When the background must run next.
    background_at: Option<u64>,
    /// The drive application's cycle under way: its next step.
    cycle: Option<CycleStep>,
    /// An event asked for a cycle while one was under way: another follows.
    cycle_again: bool,
    /// A drive answer came while a cycle was under way: the drive link's turn runs after
    /// the current step ([`Adapter::drive_answer`]).
    turn_due: bool,
    /// Where the cycle goes on after a drive link's turn that came in the middle of it.
    resume: Option<CycleStep>,
    /// The rate the application was last told (`Background::rate`).
    rate_told: u8,
    /// The address the application was last told (`Background::station`).
    station_told: u8,
    /// The time of the last event (the LEDs' clock).
    now_us: u64,
    /// The last event handled.
    seen: u32,
    written: Written,
}

impl<A: Application + Background> Adapter<A> {
    /// Power-up with the switch reading and the storage contents.
    // Always inlined, with the constructors it calls: see `drive_app`.
    #[inline(always)]
    pub fn boot(switch: u8, nv: NvContents, app: A) -> Adapter<A> {
        let mut adapter = Adapter::unpowered(app);
        adapter.power_up(switch, nv);
        adapter
    }

    /// The adapter before power-up ([`Adapter::power_up`] once, before any event): a constant
    /// where `app` is one, so that a board short of RAM may hold it as its initial image rather
    /// than build it at Boot (the emulated production board: README "The production board
    /// under emulation").
    #[inline(always)]
    pub const fn unpowered(app: A) -> Adapter<A> {
        // What the switch and the storage decide is set again at power-up.
        let addressing = addressing(0, None);
        let slave = Slave::new(
            Config {
                address: addressing.address,
                ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
                no_add_chg: addressing.no_add_chg,
                dpv1_status_bytes: false,
            },
            Recording {
                inner: app,
                nv_write: None,
                last_record: None,
                outputs_applied: 0,
                fail_safes: 0,
            },
        );
        Adapter {
            slave,
            addressing,
            exchanged: false,
            malformed_telegrams: 0,
            // The background starts at once (the drive link loads the fieldbus group and keeps
            // the drive alive), not at the first telegram.
            background_at: Some(0),
            cycle: None,
            cycle_again: false,
            turn_due: false,
            resume: None,
            rate_told: u8::MAX,
            station_told: addressing.address,
            now_us: 0,
            seen: 0,
            written: Written::none(),
        }
    }

    /// Power-up with the switch reading and the storage contents, in place: the station
    /// address and where it came from, what the application is told of it, and the settings
    /// 971 kept (switch 99 leaves them at their defaults and has the storage forget them).
    pub fn power_up(&mut self, switch: u8, nv: NvContents) {
        let addressing = addressing(switch, nv.address);
        self.slave.configure(Config {
            address: addressing.address,
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            no_add_chg: addressing.no_add_chg,
            dpv1_status_bytes: false,
        });
        let factory = addressing.source == AddressSource::FactoryReset;
        self.slave.app_mut().nv_write = if factory {
            Some(NvWrite::FactoryDefaults(FACTORY_DEFAULTS))
        } else {
            addressing.nv_write.map(NvWrite::Address)
        };
        self.addressing = addressing;
        self.station_told = addressing.address;
        let app = self.app_mut();
        app.station(addressing.address);
        app.node_address_writable(addressing.source.parameter_may_set());
        if let Some(params) = nv.params.filter(|_| !factory) {
            app.restore_nv_params(params);
        }
    }

    /// The settings 971 keeps, as they are now (for the firmware's storage write).
    pub fn nv_params(&self) -> Option<NvParams> {
        self.app().nv_params()
    }

    pub fn addressing(&self) -> Addressing {
        self.addressing
    }

    pub fn slave(&self) -> &Slave<impl Application> {
        &self.slave
    }

    pub fn app(&self) -> &A {
        &self.slave.app().inner
    }

    pub fn app_mut(&mut self) -> &mut A {
        &mut self.slave.app_mut().inner
    }

    /// Handles one event and then the whole drive application's cycle it asks for (see
    /// [`Adapter::decide`] and [`Adapter::cycle_step`]), for a caller that schedules nothing.
    pub fn handle(&mut self, message: &ToAdapter, out: &mut dyn FnMut(Out)) {
        self.decide(message, out);
        while self.cycle_step(out) {}
    }

    /// Handles one event (a Boot included: the caller built this adapter for it): the slave's
    /// decision, its writes, [`Out::DecisionWritten`]; then (but after new outputs, which go
    /// to the drive link at once when it is free, [`Out::DriveQueued`]) a cycle of the drive
    /// application is due, run by [`Adapter::cycle_step`] when no event waits. Returns
    /// whether a cycle is due.
    pub fn decide(&mut self, message: &ToAdapter, out: &mut dyn FnMut(Out)) -> bool {
        let now_us = message.now_us();
        self.now_us = now_us;
        let now = Instant::from_micros(now_us);
        // Events the transceiver's registers wait for: the registers are written after them
        // even when nothing changed, so that it knows the decision was taken.
        let mut decided = false;
        let mut new_outputs = false;
        // An MSAC1 request changes nothing the transceiver answers but the response it
        // writes here, and Global_Control nothing it answers at all (Clear, Sync and Freeze
        // change what the firmware does with outputs and inputs): no registers, diagnosis or
        // status follow them at once (a Data_Exchange arriving meanwhile waits for less),
        // only the inputs and the cycle, whose last step writes the status.
        let mut acyclic = false;
        match *message {
            ToAdapter::Boot { seq, .. } => {
                self.seen = seq;
                decided = true;
            }
            ToAdapter::Telegram {
                seq, bytes, baud, ..
            } => {
                self.seen = seq;
                match fdl::Repr::parse_bytes(bytes) {
                    Ok((request, _)) => {
                        new_outputs = self.is_new_outputs(&request);
                        let msac1 = is_msac1_request(&request);
                        acyclic = msac1 || is_global_control(&request);
                        decided = !new_outputs && !acyclic;
                        if baud != self.rate_told {
                            self.rate_told = baud;
                            self.slave.app_mut().inner.rate(baud);
                        }
                        self.slave.process_fresh(now, &request);
                        if msac1 {
                            // The response the master's next poll gets from the transceiver.
                            if let Some(bytes) = self.slave.msac1_response() {
                                out(Out::Write(FromAdapter::Msac1 {
                                    request: seq,
                                    bytes,
                                }));
                            }
                        }
                    }
                    Err(_) => {
                        self.malformed_telegrams = self.malformed_telegrams.saturating_add(1);
                    }
                }
            }
            ToAdapter::WatchdogExpired { seq, .. } => {
                self.seen = seq;
                decided = true;
                self.slave.expire_watchdog(now);
            }
            ToAdapter::Timer { seq, .. } => self.seen = seq,
            #[allow(unreachable_patterns)]
            _ => {}
        }
        if self.slave.state() == State::DataExch {
            self.exchanged = true;
        }
        let parts = Parts {
            inputs: true,
            diag: !new_outputs && !acyclic,
            cfg: !new_outputs && !acyclic,
        };
        // New outputs to the drive, where its link is free: first, their request on the line
        // while the inputs go to the transceiver, where a Data_Exchange cycle leaves the time
        // (up to 1.5 Mbit/s: at least 330 µs with PPO4's 12 bytes each way, against the
        // turn's 40 µs); above, after the inputs, which the next Data_Exchange may need within
        // 140 µs at 12 Mbit/s.
        if new_outputs {
            self.slave.app_mut().inner.data_exchange(now_us);
        }
        let drive_first = self.rate_told <= dp_consts::Baud::B1500000.index() as u8;
        if new_outputs && drive_first && self.slave.app_mut().inner.outputs_turn(now_us) {
            out(Out::DriveQueued);
        }
        self.write_buffers(now, decided, parts, out);
        out(Out::DecisionWritten);
        if new_outputs && !drive_first && self.slave.app_mut().inner.outputs_turn(now_us) {
            out(Out::DriveQueued);
        }
        if new_outputs && self.slave.app_mut().inner.after_outputs_turn(now_us) {
            out(Out::DriveQueued);
        }
        if !new_outputs && !acyclic {
            // What the decision changed in the status (the state, the address, the DP LEDs)
            // is out before the cycle runs. The drive link's LEDs are the cycle's to change:
            // they keep what the last cycle showed, or they would go out for its length.
            self.write_status(out, false);
        }
        // New outputs ask for no cycle: they went to the drive above, or the turn after the
        // transaction under way takes them (the drive's answer starts it). Every other event
        // asks for a cycle.
        if !new_outputs {
            if self.cycle.is_some() {
                self.cycle_again = true;
            } else {
                self.cycle = Some(CycleStep::App(0));
            }
        }
        self.cycle.is_some()
    }

    /// Whether a cycle of the drive application is under way or due.
    pub fn cycle_pending(&self) -> bool {
        self.cycle.is_some()
    }

    /// The time of the last event (the firmware's clock between events).
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The drive's answer is in the drive UART, at `now_us` (on a board the drive UART's
    /// interrupt says so; under simulation hal-sim's `DriveBytes`). A whole cycle starts when
    /// none is under way; else the drive link's turn runs after the cycle's next step, and the
    /// cycle goes on where it was after the turn. (At once, before that step, PPO4's median
    /// out->drive was 10 µs shorter, but a Data_Exchange at 12 Mbit/s met the turn's longer
    /// steps more often: its decision took up to 139.2 µs against a 139 µs cycle.) Nothing is
    /// written: the cycle's own steps write what the answer changed.
    pub fn drive_answer(&mut self, now_us: u64) {
        self.now_us = now_us;
        match self.cycle {
            None => self.cycle = Some(CycleStep::App(0)),
            // A turn about to start takes the answer with it.
            Some(CycleStep::App(0)) => {}
            Some(_) => self.turn_due = true,
        }
    }

    /// Runs the next step of the drive application's cycle, at the last event's time: its
    /// steps, then the writes of what it changed and the status. Returns whether steps remain.
    pub fn cycle_step(&mut self, out: &mut dyn FnMut(Out)) -> bool {
        let Some(step) = self.cycle else {
            return false;
        };
        let mut next = self.run_cycle_step(step, out);
        let turn = self.slave.app().inner.drive_turn_steps();
        if next == Some(CycleStep::App(turn)) && self.resume.is_some() {
            // The end of a turn that came in the middle of a cycle: the cycle goes on.
            next = self.resume.take();
        } else if self.turn_due
            && self.resume.is_none()
            && !matches!(next, Some(CycleStep::App(n)) if n < turn)
        {
            // A drive answer waits, and no turn is under way (one whose answer step has run
            // is over first): the turn, then the rest of the cycle (a whole one when this one
            // is over: the answer's inputs must be written).
            self.turn_due = false;
            self.resume = Some(next.unwrap_or(CycleStep::App(turn)));
            next = Some(CycleStep::App(0));
        }
        self.cycle = next;
        self.cycle.is_some()
    }

    /// Runs `step`; returns the one after it.
    fn run_cycle_step(&mut self, step: CycleStep, out: &mut dyn FnMut(Out)) -> Option<CycleStep> {
        let now_us = self.now_us;
        match step {
            CycleStep::App(n) => match self.slave.app_mut().inner.run_step(now_us, n) {
                Step::More => Some(CycleStep::App(n.saturating_add(1))),
                Step::Done(at) => {
                    self.background_at = at;
                    Some(CycleStep::Write)
                }
            },
            CycleStep::Write => {
                self.write_cycle(out);
                Some(CycleStep::Diag)
            }
            CycleStep::Diag | CycleStep::Cfg => {
                let diag = step == CycleStep::Diag;
                let parts = Parts {
                    diag,
                    cfg: !diag,
                    ..Parts::NONE
                };
                self.write_buffers(Instant::from_micros(now_us), false, parts, out);
                Some(if diag {
                    CycleStep::Cfg
                } else {
                    CycleStep::Status
                })
            }
            CycleStep::Status => {
                self.write_status(out, true);
                if core::mem::take(&mut self.cycle_again) {
                    Some(CycleStep::App(0))
                } else {
                    None
                }
            }
        }
    }

    /// The end of a cycle: the inputs the drive application changed go to the transceiver
    /// (the diagnosis, configuration and status follow in steps of their own).
    fn write_cycle(&mut self, out: &mut dyn FnMut(Out)) {
        let now = Instant::from_micros(self.now_us);
        let dpv1 = self.slave.app().inner.dpv1_mode();
        self.slave.set_dpv1_status_bytes(dpv1);
        if let Some(address) = self.slave.app_mut().inner.requested_station() {
            self.readdress(now, address);
        }
        match self.slave.app_mut().inner.take_module_request() {
            Some(ModuleRequest::StoreAddress(address)) => self.store_address(address),
            Some(ModuleRequest::Restart) => self.restart(now),
            Some(ModuleRequest::SaveSettings) => {
                self.slave.app_mut().nv_write = Some(NvWrite::Params);
            }
            None => {}
        }
        // Set_Slave_Add or the drive changed it: 918 and 51.02 follow.
        let address = self.slave.address();
        if address != self.station_told {
            self.station_told = address;
            self.slave.app_mut().inner.station(address);
        }
        let parts = Parts {
            inputs: true,
            ..Parts::NONE
        };
        self.write_buffers(now, false, parts, out);
    }

    /// The status, if it changed (or the storage must be written); `drive_leds`: with the
    /// drive link's LEDs as they are now, else as last written.
    fn write_status(&mut self, out: &mut dyn FnMut(Out), drive_leds: bool) {
        let mut status = self.status();
        if let Some(written) = self.written.status.filter(|_| !drive_leds) {
            status.leds.tx = written.leds.tx;
            status.leds.rx = written.leds.rx;
        }
        let unchanged = self.written.status.is_some_and(|s| {
            Status {
                outputs_applied: status.outputs_applied,
                ..s
            } == status
        });
        if !unchanged || status.nv_write.is_some() {
            self.written.status = Some(status);
            out(Out::Write(FromAdapter::Status(status)));
        }
    }

    /// A Data_Exchange with outputs of the configured length: the transceiver needs no
    /// decision from it.
    fn is_new_outputs(&self, request: &fdl::Repr) -> bool {
        match request {
            fdl::Repr::Data(d) => {
                d.dsap.is_none()
                    && !d.payload.is_empty()
                    && d.payload.len() == self.slave.io_sizes().outputs
            }
            _ => false,
        }
    }

    /// Writes the responder's buffers that changed, and the registers last (so that the
    /// buffers are in place when the registers release the answers that wait for them); the
    /// registers also when `decided`; of the buffers, the `parts` asked for. New outputs
    /// change only the inputs: the diagnosis and configuration are looked at again at the end
    /// of the next cycle of the drive application (a Data_Exchange at 12 Mbit/s leaves no
    /// time for them).
    fn write_buffers(
        &mut self,
        now: Instant,
        decided: bool,
        parts: Parts,
        out: &mut dyn FnMut(Out),
    ) {
        // Each buffer is compared where the slave built it: copying a whole buffer per event
        // was a third of the MCU's work on a Data_Exchange.
        if parts.inputs {
            let inputs = self.slave.inputs_now(now);
            if let Some(inputs) = take_if_changed(&mut self.written.inputs, inputs) {
                out(Out::Write(FromAdapter::Inputs(inputs)));
            }
        }
        if parts.diag {
            let (diag, new) = self.slave.diag_now();
            let changed = take_if_changed(&mut self.written.diag, diag).is_some();
            if new || changed {
                out(Out::Write(FromAdapter::Diag { new, bytes: diag }));
            }
        }
        if parts.cfg {
            if let Some(cfg) = take_if_changed(&mut self.written.cfg, self.slave.cfg_now()) {
                out(Out::Write(FromAdapter::Cfg(cfg)));
            }
        }
        let regs = self.regs();
        let changed = self.written.regs.is_none_or(|r| {
            Regs {
                seen: regs.seen,
                ..r
            } != regs
        });
        if decided || changed {
            out(Out::Write(FromAdapter::Regs(regs)));
            self.written.regs = Some(regs);
        }
    }

    /// The slave's registers for the transceiver.
    pub fn regs(&self) -> Regs {
        let slave = &self.slave;
        let io = slave.io_sizes();
        Regs {
            seen: self.seen,
            address: slave.address(),
            state: link_state(slave.state()),
            owner: slave.owner(),
            locked: slave.is_locked(),
            no_add_chg: slave.no_add_chg(),
            ident_number: slave.ident_number(),
            watchdog_us: slave
                .watchdog_micros()
                .map(|us| u32::try_from(us).unwrap_or(u32::MAX)),
            min_tsdr_bits: slave.min_tsdr_bits(),
            inputs_len: io.inputs as u8,
            outputs_len: io.outputs as u8,
            dpv1: slave.dpv1_enabled(),
        }
    }

    /// Seed 004's software addressing: with the switch at 0, the drive's 51.02 after a refresh
    /// becomes the address. The slave restarts at it (a master must parameterise it again
    /// there) and the storage keeps it. With the switch set, or an address a slave cannot
    /// have, nothing changes, and 51.02 shows the address in force again.
    fn readdress(&mut self, now: Instant, address: u16) {
        let Ok(address) = u8::try_from(address) else {
            return;
        };
        if self.addressing.source == AddressSource::Switch
            || !(1..=dp_consts::MAX_STATION_ADDRESS).contains(&address)
            || address == self.slave.address()
        {
            return;
        }
        self.slave.restart_at(now, address);
        let no_add_chg = self.slave.no_add_chg();
        self.slave.app_mut().write_record(NvRecord {
            address,
            no_add_chg,
        });
    }

    /// 918 (seed 004 line 1490): with the switch at 0, the address goes to the storage and is
    /// in force from the next restart (972 or a power cycle).
    fn store_address(&mut self, address: u8) {
        if !self.addressing.source.parameter_may_set()
            || !(1..=dp_consts::MAX_STATION_ADDRESS).contains(&address)
        {
            return;
        }
        let no_add_chg = self.slave.no_add_chg();
        self.slave.app_mut().write_record(NvRecord {
            address,
            no_add_chg,
        });
    }

    /// 972 (seed 004 line 1552): the module restarts, at the address the switch or the
    /// storage gives now; a master must parameterise it again.
    fn restart(&mut self, now: Instant) {
        let stored = self.slave.app().last_record.map(|r| r.address);
        let address = match (self.addressing.source, stored) {
            (AddressSource::Switch, _) | (_, None) => self.slave.address(),
            (_, Some(stored)) => stored,
        };
        self.slave.restart_at(now, address);
        self.slave.app_mut().inner.restarted();
    }

    /// The status now; takes a pending storage write.
    pub fn status(&mut self) -> Status {
        let leds = self.leds();
        let nv_write = self.slave.app_mut().nv_write.take();
        let app = self.slave.app();
        Status {
            address: self.slave.address(),
            state: link_state(self.slave.state()),
            leds,
            nv_write,
            wake_at_us: self.background_at,
            drive_link_error: app.inner.drive_link_error(),
            outputs_applied: app.outputs_applied,
            fail_safes: app.fail_safes,
            malformed_telegrams: self.malformed_telegrams,
        }
    }

    /// The LEDs from the slave's state and the drive link. Seed 000: Net off before data
    /// exchange, on in it, blinking when DP communication went wrong; Run flashes 20 ms a
    /// second in data exchange with the drive link working, and blinks 2 Hz in data exchange
    /// when the drive link fails or refuses the PZD mapping; TX flashes while the adapter
    /// accesses the drive, RX while the drive answers, both off without traffic. Seed 004:
    /// online on in data exchange, offline on otherwise, error blinking 1 Hz for a
    /// configuration fault and 2 Hz for a user-parameter fault.
    fn leds(&self) -> Leds {
        let exchanging = self.slave.state() == State::DataExch;
        let faulted = self.slave.prm_fault() || self.slave.cfg_fault();
        let app = &self.slave.app().inner;
        let (accessed, answered) = app.drive_activity(self.now_us);
        let flashing = |on: bool| if on { Led::Blink4Hz } else { Led::Off };
        Leds {
            net: match (exchanging, faulted || self.exchanged) {
                (true, _) => Led::On,
                (false, true) => Led::Blink2Hz,
                (false, false) => Led::Off,
            },
            run: match (exchanging, app.drive_link_error()) {
                (false, _) => Led::Off,
                (true, 0) => Led::Flash1Hz,
                (true, _) => Led::Blink2Hz,
            },
            tx: flashing(accessed),
            rx: flashing(answered),
            error: if self.slave.cfg_fault() {
                Led::Blink1Hz
            } else if self.slave.prm_fault() {
                Led::Blink2Hz
            } else {
                Led::Off
            },
            online: if exchanging { Led::On } else { Led::Off },
            offline: if exchanging { Led::Off } else { Led::On },
            host: app.host_led(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dp_slave::testing::EchoApp;

    #[test]
    fn switch_positions_of_seed_000() {
        let stored = Some(NvRecord {
            address: 42,
            no_add_chg: false,
        });
        let a = addressing(17, stored);
        assert_eq!(
            (a.address, a.no_add_chg, a.source),
            (17, true, AddressSource::Switch)
        );
        let a = addressing(98, stored);
        assert_eq!(a.address, 98);
        let a = addressing(0, stored);
        assert_eq!((a.address, a.source), (42, AddressSource::Storage));
        let a = addressing(0, None);
        assert_eq!((a.address, a.source), (126, AddressSource::Default));
        let a = addressing(
            0,
            Some(NvRecord {
                address: 0,
                no_add_chg: false,
            }),
        );
        assert_eq!(a.source, AddressSource::Default);
        let a = addressing(99, stored);
        assert_eq!(
            (a.address, a.source, a.nv_write),
            (126, AddressSource::FactoryReset, Some(FACTORY_DEFAULTS))
        );
    }

    /// A drive UART that a constant can hold: it never receives and drops what it sends.
    struct QuietUart;

    impl embedded_hal_nb::serial::ErrorType for QuietUart {
        type Error = embedded_hal_nb::serial::ErrorKind;
    }

    impl Read<u8> for QuietUart {
        fn read(&mut self) -> embedded_hal_nb::nb::Result<u8, Self::Error> {
            Err(embedded_hal_nb::nb::Error::WouldBlock)
        }
    }

    impl Write<u8> for QuietUart {
        fn write(&mut self, _: u8) -> embedded_hal_nb::nb::Result<(), Self::Error> {
            Ok(())
        }

        fn flush(&mut self) -> embedded_hal_nb::nb::Result<(), Self::Error> {
            Ok(())
        }
    }

    impl CountsSent for QuietUart {
        fn bytes_sent(&self) -> u32 {
            0
        }
    }

    /// The drive application's adapter as a board holds it in its image (firmware feature
    /// `adapter-in-image`): this constant is the proof that it can be one.
    const UNPOWERED: Adapter<DriveApp<QuietUart>> = Adapter::unpowered(drive_app(QuietUart));

    /// Seed 004 line 921 (issue 30 item 2): the settings 971 kept come back at power-up; switch
    /// 99 leaves them at their defaults and has the storage forget them with the address.
    #[test]
    fn seed_004_line_921_kept_settings_come_back_at_power_up() {
        let kept = NvParams {
            pkw_rights: 0,
            pzd_rights: 0,
            operating_mode: 1,
            control_bit_selectors: [1, 2, 3, 4, 5],
            status_bit_selectors: [3, 2, 1, 0, 3],
        };
        let stored = NvContents {
            address: None,
            params: Some(kept),
        };
        let mut adapter = UNPOWERED;
        adapter.power_up(0, stored);
        assert_eq!(adapter.nv_params(), Some(kept));
        let mut factory = UNPOWERED;
        factory.power_up(99, stored);
        let defaults = profidrive::pd_params::Parameters::default();
        assert_eq!(
            factory.nv_params().map(|p| (p.pkw_rights, p.pzd_rights)),
            Some((defaults.pkw_rights, defaults.pzd_rights))
        );
        let w = handle(
            &mut factory,
            &ToAdapter::Boot {
                seq: 1,
                now_us: 0,
                switch: 99,
            },
        );
        assert_eq!(
            w.status.iter().find_map(|s| s.nv_write),
            Some(NvWrite::FactoryDefaults(FACTORY_DEFAULTS))
        );
    }

    /// Seed 004 line 1542 (971 = 1, the motor stopped): the adapter asks the storage to keep
    /// its settings, once, with the next status.
    #[test]
    fn seed_004_line_1542_971_stores_the_settings_once() {
        let mut adapter = UNPOWERED;
        adapter.power_up(0, NvContents::default());
        let boot = ToAdapter::Boot {
            seq: 1,
            now_us: 0,
            switch: 0,
        };
        handle(&mut adapter, &boot);
        adapter.app_mut().params_mut().pending_action =
            Some(profidrive::pd_params::Action::SaveToFlash);
        let w = handle(
            &mut adapter,
            &ToAdapter::Timer {
                seq: 2,
                now_us: 1_000,
            },
        );
        let writes: Vec<_> = w.status.iter().filter_map(|s| s.nv_write).collect();
        assert_eq!(writes, [NvWrite::Params]);
        let w = handle(
            &mut adapter,
            &ToAdapter::Timer {
                seq: 3,
                now_us: 2_000,
            },
        );
        assert!(w.status.iter().all(|s| s.nv_write.is_none()));
    }

    /// Powered up in place, the image takes the address seed 000's switch and storage give,
    /// refuses or allows Set_Slave_Add and the 918 write as they say, and shows the address in
    /// 918 and in the registers of its first write.
    #[test]
    fn the_unpowered_image_powers_up_at_the_address_the_switch_gives() {
        let stored = Some(NvRecord {
            address: 42,
            no_add_chg: true,
        });
        // (switch, storage) -> (address, No_Add_Chg, 918 writable, record written)
        let cases = [
            ((17, stored), (17, true, false, None)),
            ((0, stored), (42, true, true, None)),
            ((0, None), (126, false, true, None)),
            (
                (99, stored),
                (
                    126,
                    false,
                    false,
                    Some(NvWrite::FactoryDefaults(FACTORY_DEFAULTS)),
                ),
            ),
        ];
        for ((switch, nv), (address, no_add_chg, writable, record)) in cases {
            let mut adapter = UNPOWERED;
            adapter.power_up(
                switch,
                NvContents {
                    address: nv,
                    params: None,
                },
            );
            let boot = ToAdapter::Boot {
                seq: 1,
                now_us: 0,
                switch,
            };
            let w = handle(&mut adapter, &boot);
            let regs = w.regs.last().copied().unwrap();
            let params = adapter.app().params();
            assert_eq!(
                (
                    regs.address,
                    regs.no_add_chg,
                    params.node_address,
                    params.node_address_writable,
                    w.status.iter().find_map(|s| s.nv_write),
                ),
                (address, no_add_chg, u16::from(address), writable, record),
                "switch {switch}, storage {nv:?}"
            );
        }
    }

    fn telegram(seq: u32, bytes: &[u8]) -> ToAdapter<'_> {
        ToAdapter::Telegram {
            seq,
            now_us: 1000,
            baud: 9,
            bytes,
        }
    }

    /// A DP service request from master 2 to `address`, framed by fdl.
    fn request(address: u8, sap: fdl::Sap, fcb: bool, payload: &[u8]) -> Vec<u8> {
        let repr = fdl::Repr::Data(fdl::DataRepr {
            da: address,
            sa: 2,
            dsap: Some(sap),
            ssap: Some(fdl::Sap::MASTER_MS0),
            fc: fdl::FrameControl::Request {
                fcb,
                fcv: true,
                function: fdl::RequestFunction::SrdLow,
            },
            payload,
        });
        let mut bytes = vec![0; repr.buffer_len()];
        repr.emit(&mut bytes).unwrap();
        bytes
    }

    /// Set_Slave_Add to `new_address` with the adapter's ident.
    fn set_slave_add(address: u8, new_address: u8) -> Vec<u8> {
        let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
        request(
            address,
            fdl::Sap::SET_SLAVE_ADD,
            true,
            &[new_address, hi, lo, 0],
        )
    }

    /// What one event wrote, as owned values: registers, statuses, and the count of writes.
    #[derive(Default, Debug)]
    struct Written {
        regs: Vec<Regs>,
        status: Vec<Status>,
        diag: Vec<(bool, Vec<u8>)>,
        writes: usize,
    }

    fn handle<A: Application + Background>(adapter: &mut Adapter<A>, m: &ToAdapter) -> Written {
        let mut w = Written::default();
        adapter.handle(m, &mut |out| {
            if let Out::Write(write) = out {
                w.writes += 1;
                match write {
                    FromAdapter::Regs(r) => w.regs.push(r),
                    FromAdapter::Status(s) => w.status.push(s),
                    FromAdapter::Diag { new, bytes } => w.diag.push((new, bytes.to_vec())),
                    _ => {}
                }
            }
        });
        w
    }

    fn booted<A: Application + Background>(switch: u8, app: A) -> Adapter<A> {
        let mut adapter = Adapter::boot(switch, NvContents::default(), app);
        let boot = ToAdapter::Boot {
            seq: 1,
            now_us: 0,
            switch,
        };
        let w = handle(&mut adapter, &boot);
        assert_eq!(w.regs.last().map(|r| r.seen), Some(1), "{w:?}");
        adapter
    }

    /// EchoApp's slave with a cycle of nine steps whose first four are the drive link's turn,
    /// recording the steps it runs.
    #[derive(Default)]
    struct Steps {
        echo: EchoApp,
        ran: std::vec::Vec<u8>,
    }

    impl Application for Steps {
        fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
            self.echo.accept_user_prm(user_prm)
        }
        fn accept_cfg(&mut self, cfg: &[u8]) -> Option<IoSizes> {
            self.echo.accept_cfg(cfg)
        }
        fn default_cfg(&self) -> &[u8] {
            self.echo.default_cfg()
        }
        fn outputs(&mut self, now: Instant, outputs: &[u8]) {
            self.echo.outputs(now, outputs)
        }
        fn inputs(&mut self, now: Instant, inputs: &mut [u8]) {
            self.echo.inputs(now, inputs)
        }
        fn fail_safe(&mut self, now: Instant, reason: dp_slave::FailSafeReason) {
            self.echo.fail_safe(now, reason)
        }
        fn store_address(&mut self, address: u8, no_add_chg: bool) {
            self.echo.store_address(address, no_add_chg)
        }
    }

    impl Background for Steps {
        fn run_step(&mut self, _now_us: u64, step: u8) -> Step {
            self.ran.push(step);
            if step < 8 {
                Step::More
            } else {
                Step::Done(None)
            }
        }
        fn drive_turn_steps(&self) -> u8 {
            4
        }
    }

    /// A drive answer in the middle of a cycle: the drive link's turn (steps 0-3) runs after
    /// the cycle's next step, then the cycle goes on where it was; one that comes with no
    /// cycle under way starts a whole cycle; one that comes before the turn's first step adds
    /// none.
    #[test]
    fn a_drive_answer_runs_the_drive_links_turn_next_and_the_cycle_goes_on() {
        let mut adapter = booted(0, Steps::default());
        while adapter.cycle_step(&mut |_| {}) {}
        adapter.app_mut().ran.clear();
        adapter.drive_answer(10);
        for _ in 0..6 {
            adapter.cycle_step(&mut |_| {});
        }
        adapter.drive_answer(20);
        while adapter.cycle_step(&mut |_| {}) {}
        assert_eq!(
            adapter.app().ran,
            [0, 1, 2, 3, 4, 5, 6, 0, 1, 2, 3, 7, 8],
            "the turn after step 6, then steps 7 and 8"
        );
        adapter.app_mut().ran.clear();
        adapter.drive_answer(30);
        adapter.drive_answer(31);
        while adapter.cycle_step(&mut |_| {}) {}
        assert_eq!(adapter.app().ran, (0..=8).collect::<std::vec::Vec<u8>>());
    }

    #[test]
    fn set_slave_add_is_written_to_storage_once() {
        let mut adapter = booted(0, EchoApp::default());
        assert_eq!(adapter.status().address, 126);
        let t = set_slave_add(126, 42);
        let w = handle(&mut adapter, &telegram(2, &t));
        let regs = w.regs.last().expect("registers after a decision");
        assert_eq!((regs.seen, regs.address), (2, 42));
        let stored: Vec<_> = w.status.iter().filter_map(|s| s.nv_write).collect();
        assert_eq!(
            stored,
            [NvWrite::Address(NvRecord {
                address: 42,
                no_add_chg: false
            })]
        );
        let w = handle(
            &mut adapter,
            &ToAdapter::Timer {
                seq: 3,
                now_us: 2000,
            },
        );
        assert!(w.status.iter().all(|s| s.nv_write.is_none()), "{w:?}");
    }

    #[test]
    fn the_switch_forbids_set_slave_add() {
        let mut adapter = booted(5, EchoApp::default());
        let t = set_slave_add(5, 42);
        let w = handle(&mut adapter, &telegram(2, &t));
        assert_eq!(
            w.regs.last().map(|r| (r.address, r.no_add_chg)),
            Some((5, true))
        );
        assert!(w.status.iter().all(|s| s.nv_write.is_none()));
    }

    /// Set_Prm from master 2 with the adapter's ident and one user parameter byte.
    fn set_prm(address: u8, user: u8, fcb: bool) -> Vec<u8> {
        let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
        request(
            address,
            fdl::Sap::SET_PRM,
            fcb,
            &[0x88, 1, 20, 11, hi, lo, 0, user],
        )
    }

    #[test]
    fn refused_user_parameters_reach_the_registers_and_the_diagnosis() {
        let app = EchoApp {
            reject_user_prm_byte: Some(0x55),
            ..EchoApp::default()
        };
        let mut adapter = booted(8, app);
        let w = handle(&mut adapter, &telegram(2, &set_prm(8, 0x55, false)));
        assert_eq!(
            w.regs.last().map(|r| (r.seen, r.state)),
            Some((2, SlaveState::WaitPrm))
        );
        let (_, diag) = w.diag.last().expect("the diagnosis changed");
        assert_ne!(diag[0] & dp_consts::diag::ST1_PRM_FAULT, 0);
        let w = handle(&mut adapter, &telegram(3, &set_prm(8, 0x00, true)));
        assert_eq!(
            w.regs.last().map(|r| (r.seen, r.state, r.owner)),
            Some((3, SlaveState::WaitCfg, Some(2)))
        );
        assert_eq!(adapter.app().user_prm, [0x00]);
    }

    #[test]
    fn only_changes_cross_the_link() {
        let mut adapter = booted(8, EchoApp::default());
        let w = handle(&mut adapter, &ToAdapter::Timer { seq: 2, now_us: 10 });
        assert_eq!(w.writes, 0, "{w:?}");
        // A decision writes the registers even when they did not change.
        let w = handle(
            &mut adapter,
            &ToAdapter::WatchdogExpired { seq: 3, now_us: 20 },
        );
        assert_eq!(w.regs.len(), 1);
    }

    /// A Data_Exchange request from master 2 to `address` with `outputs`.
    fn data_exchange(address: u8, fcb: bool, outputs: &[u8]) -> Vec<u8> {
        let repr = fdl::Repr::Data(fdl::DataRepr {
            da: address,
            sa: 2,
            dsap: None,
            ssap: None,
            fc: fdl::FrameControl::Request {
                fcb,
                fcv: true,
                function: fdl::RequestFunction::SrdHigh,
            },
            payload: outputs,
        });
        let mut bytes = vec![0; repr.buffer_len()];
        repr.emit(&mut bytes).unwrap();
        bytes
    }

    #[test]
    fn the_cycle_runs_a_step_at_a_time_and_new_outputs_ask_for_none() {
        let mut adapter = booted(8, EchoApp::default());
        let mut writes = Vec::new();
        let mut out = |o: Out| {
            if let Out::Write(w) = o {
                writes.push(format!("{w:?}"));
            }
        };
        // Set_Prm: the decision (registers) and the new state, then a cycle is due.
        assert!(adapter.decide(&telegram(2, &set_prm(8, 0, false)), &mut out));
        // EchoApp's cycle is one step, then the cycle's writes in four.
        assert!(adapter.cycle_step(&mut out));
        // An event during the cycle asks for another one after it.
        assert!(adapter.decide(&ToAdapter::Timer { seq: 3, now_us: 10 }, &mut out));
        // The inputs, the diagnosis, the configuration, the status: then the next cycle.
        for _ in 0..3 {
            assert!(adapter.cycle_step(&mut out));
        }
        assert!(adapter.cycle_step(&mut out), "the next cycle follows");
        for _ in 0..4 {
            assert!(adapter.cycle_step(&mut out));
        }
        assert!(!adapter.cycle_step(&mut out));
        assert!(!adapter.cycle_pending());
        // Chk_Cfg (one byte out, one in), then new outputs: they only fill the process image.
        let chk_cfg = request(8, fdl::Sap::CHK_CFG, true, &[0x30]);
        assert!(adapter.decide(&telegram(4, &chk_cfg), &mut out));
        while adapter.cycle_step(&mut out) {}
        assert_eq!(adapter.slave().state(), State::DataExch);
        assert!(!adapter.decide(&telegram(5, &data_exchange(8, true, &[0x0F])), &mut out));
        assert_eq!(adapter.app().outputs, [0x0F]);
        assert!(!adapter.cycle_pending());
        assert!(writes.iter().any(|w| w.contains("DataExch")), "{writes:?}");
    }

    /// Seed 000 line 685 and seed 004 line 1475: after a RAM fault at power-up (the MCU's and
    /// the transceiver's RAM: seed 004's "ASIC initialisation error") the Run LED is steady on
    /// (its only steady-on meaning), the error LED blinks 4 Hz (its only 4 Hz meaning), and the
    /// adapter shows itself offline, nothing else lit.
    #[test]
    fn seed_000_line_685_seed_004_line_1475_a_ram_fault_lights_run_steady_and_error_4_hz() {
        let s = ram_fault_status();
        assert_eq!(
            s.leds,
            Leds {
                run: Led::On,
                error: Led::Blink4Hz,
                offline: Led::On,
                ..Leds::default()
            }
        );
        assert_eq!(s.state, SlaveState::PowerOn);
    }

    #[test]
    fn leds_before_data_exchange() {
        let mut adapter = Adapter::boot(8, NvContents::default(), EchoApp::default());
        let leds = adapter.status().leds;
        assert_eq!(
            (leds.net, leds.online, leds.offline, leds.error),
            (Led::Off, Led::Off, Led::On, Led::Off)
        );
    }
}
