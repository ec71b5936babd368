//! The DP-V0 slave state machine (EN 50170 vol. 2; shared/PROTOCOL.md "DP-V0 slave").
//!
//! ```text
//! Power_On --any request--> Wait_Prm --Set_Prm ok--> Wait_Cfg --Chk_Cfg ok--> Data_Exch
//!     ^  Set_Slave_Add here and in Wait_Prm     ^   bad Set_Prm: Prm_Fault     |
//!                                               +---- bad Chk_Cfg: Cfg_Fault --+
//!                                               +---- watchdog expiry, unlock -+
//! ```
//! Frame count: a request with FCV=1 from the station we last answered, carrying the FCB of
//! that request and addressed to the same service (DSAP and SSAP), is a repetition; it gets
//! the stored response and is not executed again. A request for another service cannot repeat
//! the one answered, so it is executed: a master that comes back to a station it had given up
//! on without resetting the FCB (EN 50170 asks FCV=0, FCB=1 then; profirust 0.6 keeps the old
//! FCB and asks for the diagnosis) gets the diagnosis, not the stored Data_Exchange answer for
//! ever.
//! Master lock: after Set_Prm with Lock_Req, Set_Prm, Chk_Cfg, Global_Control and
//! Data_Exchange of other masters change nothing, and their diagnosis shows Master_Lock.

use crate::app::{Application, FailSafeReason};
use crate::cfg::{IoSizes, MAX_IO_LEN};
use crate::Instant;
use dp_consts::{control_command as gc, diag, station_status, BROADCAST_ADDRESS};
use dp_consts::{MAX_DATA_UNIT_LEN, SET_PRM_FIXED_LEN, WATCHDOG_BASE_MS};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, ResponseStatus, Sap};

/// The longest configuration (Chk_Cfg data) the slave stores.
pub const MAX_CFG_LEN: usize = 64;

use dp_consts::dpv1::{status1, status2, status3, STATUS_LEN as DPV1_STATUS_LEN};
/// The highest address Set_Slave_Add may give (126 is reserved for commissioning).
const MAX_SETTABLE_ADDRESS: u8 = 125;

/// The DP slave states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    PowerOn,
    WaitPrm,
    WaitCfg,
    DataExch,
}

/// What the slave is at power-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Station address, 0..=126.
    pub address: u8,
    /// The Ident_Number Set_Prm must carry.
    pub ident_number: u16,
    /// An earlier Set_Slave_Add fixed the address (No_Add_Chg): refuse further changes.
    pub no_add_chg: bool,
    /// User_Prm_Data begins with the three DP-V1 status bytes (DPV1_Status_1 bit 2 selects the
    /// 1 ms watchdog base, bit 7 enables MSAC1); the application gets the bytes after them.
    pub dpv1_status_bytes: bool,
}

/// Why DPV1_Status_1..3 of a Set_Prm are refused (Prm_Fault): a reserved bit, or a feature
/// the slave does not have (Publisher_Enable, the alarms, Prm_Structure, IsoM_Req; seed 004
/// marks each "不支持").
fn dpv1_status_valid(status: &[u8]) -> bool {
    let [s1, s2, s3] = [status[0], status[1], status[2]];
    s1 & (status1::RESERVED | status1::PUBLISHER_ENABLE) == 0
        && s2 & (status2::RESERVED | status2::ALARM_ENABLES) == 0
        && s3 & (status3::PRM_STRUCTURE | status3::ISOM_REQ | status3::RESERVED) == 0
}

/// A stored response, so that a repetition gets the same bytes.
#[derive(Clone, Copy, Debug)]
enum Stored {
    ShortAck,
    Data {
        fc: FrameControl,
        dsap: Option<Sap>,
        ssap: Option<Sap>,
        len: usize,
    },
}

#[derive(Clone, Copy, Debug)]
struct LastExchange {
    requester: u8,
    fcb: bool,
    service: (Option<Sap>, Option<Sap>),
    response: Stored,
}

/// The outcome of one service, before it is stored and framed.
enum Answer {
    None,
    ShortAck,
    /// `len` bytes of `payload_buffer`.
    Data(ResponseStatus, usize),
    /// The SAP is not active for this requester or in this state.
    NotActivated,
    UserError,
}

/// The DP-V0 slave. `A` is the application behind it.
pub struct Slave<A> {
    app: A,
    address: u8,
    ident_number: u16,
    no_add_chg: bool,
    dpv1_status_bytes: bool,
    /// DPV1_Enable of the last accepted Set_Prm: SAP 51 is served.
    dpv1_enabled: bool,
    /// The response to the last MSAC1 request, until a poll takes it.
    msac1_len: Option<usize>,
    msac1_buffer: [u8; crate::msac1::MAX_PDU_LEN],
    state: State,
    /// The master that parameterised us (Master_Add of the diagnosis).
    owner: Option<u8>,
    locked: bool,
    prm_fault: bool,
    cfg_fault: bool,
    diag_pending: bool,
    watchdog_micros: Option<u64>,
    watchdog_deadline: Option<Instant>,
    min_tsdr_bits: u8,
    group: u8,
    freeze_allowed: bool,
    sync_allowed: bool,
    freeze_active: bool,
    sync_active: bool,
    /// Global_Control Clear_Data is in force.
    clear_by_command: bool,
    /// The master sent an empty Data_Exchange (its Clear state for Fail_Safe slaves).
    clear_by_empty_outputs: bool,
    cfg: heapless::Vec<u8, MAX_CFG_LEN>,
    io: IoSizes,
    outputs: [u8; MAX_IO_LEN],
    frozen_inputs: [u8; MAX_IO_LEN],
    last: Option<LastExchange>,
    payload_buffer: [u8; MAX_DATA_UNIT_LEN],
}

impl<A: Application> Slave<A> {
    // Always inlined: the firmware builds the adapter once, at boot, and inlined the
    // constructors write it in place instead of into temporaries copied up a level (the boot
    // frame is 0.45 KiB smaller, on the production board's 20 KiB).
    #[inline(always)]
    pub const fn new(config: Config, app: A) -> Slave<A> {
        Slave {
            app,
            address: config.address,
            ident_number: config.ident_number,
            no_add_chg: config.no_add_chg,
            dpv1_status_bytes: config.dpv1_status_bytes,
            dpv1_enabled: false,
            msac1_len: None,
            msac1_buffer: [0; crate::msac1::MAX_PDU_LEN],
            state: State::PowerOn,
            owner: None,
            locked: false,
            prm_fault: false,
            cfg_fault: false,
            diag_pending: false,
            watchdog_micros: None,
            watchdog_deadline: None,
            min_tsdr_bits: dp_consts::MIN_TSDR_BITS,
            group: 0,
            freeze_allowed: false,
            sync_allowed: false,
            freeze_active: false,
            sync_active: false,
            clear_by_command: false,
            clear_by_empty_outputs: false,
            cfg: heapless::Vec::new(),
            io: IoSizes {
                inputs: 0,
                outputs: 0,
            },
            outputs: [0; MAX_IO_LEN],
            frozen_inputs: [0; MAX_IO_LEN],
            last: None,
            payload_buffer: [0; MAX_DATA_UNIT_LEN],
        }
    }

    /// The configuration at power-up, for a slave built before it was known (as a constant):
    /// before any telegram.
    pub fn configure(&mut self, config: Config) {
        self.address = config.address;
        self.ident_number = config.ident_number;
        self.no_add_chg = config.no_add_chg;
        self.dpv1_status_bytes = config.dpv1_status_bytes;
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// Whether User_Prm_Data begins with DPV1_Status_1..3 from the next Set_Prm on (the
    /// device's protocol mode: seed 004's 51.21 DP MODE, with the GSD that matches it).
    pub fn set_dpv1_status_bytes(&mut self, on: bool) {
        self.dpv1_status_bytes = on;
    }

    /// DPV1_Enable is in force: SAP 51 serves the class-1 master.
    pub fn dpv1_enabled(&self) -> bool {
        self.dpv1_enabled
    }

    /// The response to the last MSAC1 request, while no poll has taken it (a transceiver that
    /// answers polls from a buffer copies it there).
    pub fn msac1_response(&self) -> Option<&[u8]> {
        self.msac1_len.map(|len| &self.msac1_buffer[..len])
    }

    /// The station address (it changes after a successful Set_Slave_Add).
    pub fn address(&self) -> u8 {
        self.address
    }

    /// min TSDR from the last accepted Set_Prm, in bit times (11 before any).
    pub fn min_tsdr_bits(&self) -> u8 {
        self.min_tsdr_bits
    }

    /// The input and output sizes of the accepted configuration.
    pub fn io_sizes(&self) -> IoSizes {
        self.io
    }

    /// The master that parameterised the slave, if any.
    pub fn owner(&self) -> Option<u8> {
        self.owner
    }

    /// Whether a master holds the lock.
    pub fn is_locked(&self) -> bool {
        self.locked
    }

    /// Whether the outputs are held in fail-safe by Clear_Data or empty Data_Exchange.
    pub fn is_clear(&self) -> bool {
        self.clear_by_command || self.clear_by_empty_outputs
    }

    /// Prm_Fault: the last Set_Prm was refused.
    pub fn prm_fault(&self) -> bool {
        self.prm_fault
    }

    /// Cfg_Fault: the last Chk_Cfg was refused.
    pub fn cfg_fault(&self) -> bool {
        self.cfg_fault
    }

    /// The watchdog time from the last Set_Prm, if on.
    pub fn watchdog_micros(&self) -> Option<u64> {
        self.watchdog_micros
    }

    /// The Ident_Number Set_Prm must carry.
    pub fn ident_number(&self) -> u16 {
        self.ident_number
    }

    /// The diagnosis as its owner (or any master, while none owns the slave) reads it now,
    /// and whether it is new since the last call (Data_Exchange answers DH until it is read).
    /// For a transceiver that answers Slave_Diag from a buffer.
    ///
    /// This and [`Self::inputs_now`] build in the response buffer, which also holds the
    /// response a repetition gets from [`Self::process`]: a transceiver answers repetitions
    /// itself and hands over with [`Self::process_fresh`], so nothing stored is lost. Built in
    /// place, they cost the caller no buffer of its own and no copy.
    pub fn diag_now(&mut self) -> (&[u8], bool) {
        let new = self.app.diag_changed() || self.diag_pending;
        self.diag_pending = false;
        let len = self.diag_payload(false);
        (&self.payload_buffer[..len], new)
    }

    /// The inputs Data_Exchange and Rd_Inp answer with now (the frozen ones under Freeze);
    /// none outside Data_Exch. See [`Self::diag_now`] for the buffer they are built in.
    pub fn inputs_now(&mut self, now: Instant) -> &[u8] {
        if self.state != State::DataExch {
            return &[];
        }
        let len = self.io.inputs.min(MAX_IO_LEN);
        if self.freeze_active {
            return &self.frozen_inputs[..len];
        }
        self.app.inputs(now, &mut self.payload_buffer[..len]);
        &self.payload_buffer[..len]
    }

    pub fn app(&self) -> &A {
        &self.app
    }

    pub fn app_mut(&mut self) -> &mut A {
        &mut self.app
    }

    /// When [`Self::poll`] must run next: the watchdog deadline.
    pub fn poll_at(&self) -> Option<Instant> {
        self.watchdog_deadline
    }

    /// Runs the watchdog: on expiry the application goes fail-safe, the lock is released and
    /// the slave returns to Wait_Prm. Returns whether it expired.
    pub fn poll(&mut self, now: Instant) -> bool {
        match self.watchdog_deadline {
            Some(deadline) if now >= deadline => {
                self.expire_watchdog(now);
                true
            }
            _ => false,
        }
    }

    /// The watchdog expired (here, or in a transceiver that runs it, such as a VPC3+ or the
    /// adapter's): the application goes fail-safe, the lock is released and the slave returns
    /// to Wait_Prm.
    pub fn expire_watchdog(&mut self, now: Instant) {
        self.watchdog_deadline = None;
        self.owner = None;
        self.locked = false;
        // The application is told even outside Data_Exch: its outputs may still be live.
        if self.state != State::DataExch {
            self.app.fail_safe(now, FailSafeReason::WatchdogExpired);
        }
        self.leave_to_wait_prm(now, FailSafeReason::WatchdogExpired);
    }

    /// Parses `request`, processes it and writes the response telegram into `out`; returns its
    /// length. Malformed telegrams and telegrams for other stations give `None` and change
    /// nothing.
    pub fn handle(&mut self, now: Instant, request: &[u8], out: &mut [u8]) -> Option<usize> {
        let (repr, _) = Repr::parse_bytes(request).ok()?;
        let response = self.process(now, &repr)?;
        response.emit(out).ok()
    }

    /// Processes one request; returns the response to send, if any.
    pub fn process(&mut self, now: Instant, request: &Repr) -> Option<Repr<'_>> {
        self.poll(now);
        self.process_inner(now, request, true)
    }

    /// Processes a request that a transceiver has already answered and filtered: it has run
    /// the watchdog and recognised repetitions (FCB), so neither is done here. The response is
    /// the one the transceiver gave.
    pub fn process_fresh(&mut self, now: Instant, request: &Repr) -> Option<Repr<'_>> {
        self.process_inner(now, request, false)
    }

    fn process_inner(
        &mut self,
        now: Instant,
        request: &Repr,
        repetitions: bool,
    ) -> Option<Repr<'_>> {
        let Repr::Data(request) = request else {
            return None;
        };
        let FrameControl::Request { fcb, fcv, function } = request.fc else {
            return None;
        };
        let broadcast = request.da == BROADCAST_ADDRESS;
        if request.da != self.address && !broadcast {
            return None;
        }
        let answers = !broadcast && function.expects_response();

        if function == RequestFunction::FdlStatus {
            return answers.then_some(Repr::Data(DataRepr {
                da: request.sa,
                sa: request.da,
                dsap: request.ssap,
                ssap: request.dsap,
                fc: FrameControl::slave_response(ResponseStatus::Ok),
                payload: &[],
            }));
        }
        if answers && !function.is_srd() {
            // SDA, Ident and LSAP status are not DP services; the master's slot time runs out.
            return None;
        }
        if answers && fcv && repetitions {
            if let Some(last) = self.last {
                if last.requester == request.sa
                    && last.fcb == fcb
                    && last.service == (request.dsap, request.ssap)
                {
                    return Some(self.stored_response(request, last.response));
                }
            }
        }
        let answer = self.execute(now, request, broadcast);
        if !answers {
            return None;
        }
        let stored = match answer {
            Answer::None => return None,
            Answer::ShortAck => Stored::ShortAck,
            Answer::Data(status, len) => Stored::Data {
                fc: FrameControl::slave_response(status),
                dsap: request.ssap,
                ssap: request.dsap,
                len,
            },
            Answer::NotActivated | Answer::UserError => Stored::Data {
                fc: FrameControl::slave_response(match answer {
                    Answer::NotActivated => ResponseStatus::SapNotActivated,
                    _ => ResponseStatus::UserError,
                }),
                dsap: request.ssap,
                ssap: request.dsap,
                len: 0,
            },
        };
        self.last = Some(LastExchange {
            requester: request.sa,
            fcb,
            service: (request.dsap, request.ssap),
            response: stored,
        });
        Some(self.stored_response(request, stored))
    }

    fn stored_response(&self, request: &DataRepr, stored: Stored) -> Repr<'_> {
        match stored {
            Stored::ShortAck => Repr::ShortAck,
            Stored::Data {
                fc,
                dsap,
                ssap,
                len,
            } => Repr::Data(DataRepr {
                da: request.sa,
                sa: request.da,
                dsap,
                ssap,
                fc,
                payload: &self.payload_buffer[..len],
            }),
        }
    }

    fn execute(&mut self, now: Instant, request: &DataRepr, broadcast: bool) -> Answer {
        let service = match (request.dsap, request.ssap) {
            (None, _) => None,
            (Some(dsap), Some(_)) => Some(dsap),
            // A DP service always names the master's SAP too.
            (Some(_), None) => return Answer::None,
        };
        // Global_Control is the only DP-V0 service sent to a group or to all stations: any
        // other broadcast changes nothing.
        if broadcast && service != Some(Sap::GLOBAL_CONTROL) {
            return Answer::None;
        }
        if self.state == State::PowerOn && service != Some(Sap::SET_SLAVE_ADD) {
            self.state = State::WaitPrm;
        }
        if self.owner == Some(request.sa) {
            if let Some(timeout) = self.watchdog_micros {
                self.watchdog_deadline = Some(now.plus_micros(timeout));
            }
        }
        let payload = request.payload;
        match service {
            None => self.data_exchange(now, request.sa, payload),
            Some(Sap::SLAVE_DIAG) => self.slave_diag(request.sa),
            Some(Sap::SET_PRM) => self.set_prm(now, request.sa, payload),
            Some(Sap::CHK_CFG) => self.chk_cfg(now, request.sa, payload),
            Some(Sap::GET_CFG) => self.get_cfg(),
            Some(Sap::GLOBAL_CONTROL) => self.global_control(now, request.sa, payload),
            Some(Sap::RD_INP) => self.read_inputs(now),
            Some(Sap::RD_OUTP) => self.read_outputs(),
            Some(Sap::SET_SLAVE_ADD) => self.set_slave_add(payload),
            Some(Sap::MSAC1) => self.msac1(now, request.sa, payload),
            Some(_) => Answer::NotActivated,
        }
    }

    /// MSAC1 (SAP 51) for the owner in Data_Exch with DPV1_Enable. A request is executed at
    /// once and acknowledged with SC: a slave cannot answer one within TSDR (a VPC3+ hands it
    /// to its MCU and answers the master's polls without data until the MCU has put the
    /// response in place; an SC answers an SRD that has no data). A poll (an SRD to SAP 51
    /// without data) gets the response once, or SC while there is none.
    fn msac1(&mut self, now: Instant, requester: u8, pdu: &[u8]) -> Answer {
        if !self.dpv1_enabled || self.state != State::DataExch || self.owner != Some(requester) {
            return Answer::NotActivated;
        }
        if pdu.is_empty() {
            return match self.msac1_len.take() {
                Some(len) => {
                    self.payload_buffer[..len].copy_from_slice(&self.msac1_buffer[..len]);
                    Answer::Data(ResponseStatus::DataLow, len)
                }
                None => Answer::ShortAck,
            };
        }
        let len = match crate::msac1::Request::parse(pdu) {
            Ok(request) => self.app.msac1(now, &request, &mut self.msac1_buffer),
            Err(e) => {
                let write = pdu.first() == Some(&u8::from(dp_consts::dpv1::Function::Write));
                crate::msac1::Response::error(write, e.error_code()).emit(&mut self.msac1_buffer)
            }
        };
        self.msac1_len = Some(len.min(crate::msac1::MAX_PDU_LEN));
        Answer::ShortAck
    }

    /// The station address changed outside the bus (an adapter's software addressing, such as
    /// seed 004's node address parameter and a parameter refresh): the slave starts again at
    /// `address` in Wait_Prm, as after a power-up, and the application goes fail-safe if data
    /// was exchanged.
    pub fn restart_at(&mut self, now: Instant, address: u8) {
        self.address = address;
        self.last = None;
        self.release(now);
    }

    /// Whether Set_Slave_Add is refused from now on.
    pub fn no_add_chg(&self) -> bool {
        self.no_add_chg
    }

    /// Back to Wait_Prm with no owner, no lock and no watchdog.
    fn release(&mut self, now: Instant) {
        self.owner = None;
        self.locked = false;
        self.watchdog_micros = None;
        self.watchdog_deadline = None;
        self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
    }

    /// Leaves any state for Wait_Prm; the application goes fail-safe if data was exchanged.
    fn leave_to_wait_prm(&mut self, now: Instant, reason: FailSafeReason) {
        if self.state == State::DataExch {
            self.app.fail_safe(now, reason);
        }
        self.state = State::WaitPrm;
        self.msac1_len = None;
        self.freeze_active = false;
        self.sync_active = false;
        self.clear_by_command = false;
        self.clear_by_empty_outputs = false;
    }

    fn data_exchange(&mut self, now: Instant, requester: u8, outputs: &[u8]) -> Answer {
        if self.state != State::DataExch || self.owner != Some(requester) {
            return Answer::NotActivated;
        }
        if outputs.is_empty() && self.io.outputs > 0 {
            if !self.is_clear() {
                self.app.fail_safe(now, FailSafeReason::ClearData);
            }
            self.clear_by_empty_outputs = true;
        } else if outputs.len() == self.io.outputs {
            self.clear_by_empty_outputs = false;
            self.outputs[..outputs.len()].copy_from_slice(outputs);
            if !self.is_clear() && !self.sync_active {
                self.app.outputs(now, outputs);
            }
        } else {
            // Outputs of the wrong length: the master's configuration is not ours.
            self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
            return Answer::NotActivated;
        }
        if self.app.diag_changed() {
            self.diag_pending = true;
        }
        let len = self.io.inputs;
        self.fill_inputs(now);
        match (len, self.diag_pending) {
            (0, false) => Answer::ShortAck,
            (_, false) => Answer::Data(ResponseStatus::DataLow, len),
            (_, true) => Answer::Data(ResponseStatus::DataHigh, len),
        }
    }

    fn fill_inputs(&mut self, now: Instant) {
        let len = self.io.inputs;
        if self.freeze_active {
            self.payload_buffer[..len].copy_from_slice(&self.frozen_inputs[..len]);
        } else {
            self.app.inputs(now, &mut self.payload_buffer[..len]);
        }
    }

    fn slave_diag(&mut self, requester: u8) -> Answer {
        if self.app.diag_changed() {
            self.diag_pending = true;
        }
        let len = self.diag_payload(self.locked && self.owner != Some(requester));
        if self.owner == Some(requester) || self.owner.is_none() {
            self.diag_pending = false;
        }
        Answer::Data(ResponseStatus::DataLow, len)
    }

    /// The diagnosis into the payload buffer, with Master_Lock if `other_master`; its length.
    fn diag_payload(&mut self, other_master: bool) -> usize {
        let ext_len = {
            let room = &mut self.payload_buffer[diag::STANDARD_LEN..];
            let room_len = room.len();
            self.app.ext_diag(room).min(room_len)
        };
        let mut st1 = 0;
        if self.state != State::DataExch {
            st1 |= diag::ST1_NOT_READY;
        }
        if self.cfg_fault {
            st1 |= diag::ST1_CFG_FAULT;
        }
        if ext_len > 0 && self.app.ext_diag_reported() {
            st1 |= diag::ST1_EXT_DIAG;
        }
        if self.prm_fault {
            st1 |= diag::ST1_PRM_FAULT;
        }
        if other_master {
            st1 |= diag::ST1_MASTER_LOCK;
        }
        let mut st2 = diag::ST2_ALWAYS_ONE;
        if matches!(self.state, State::PowerOn | State::WaitPrm) {
            st2 |= diag::ST2_PRM_REQ;
        }
        if self.app.static_diag() {
            st2 |= diag::ST2_STAT_DIAG;
        }
        if self.watchdog_micros.is_some() {
            st2 |= diag::ST2_WD_ON;
        }
        if self.freeze_active {
            st2 |= diag::ST2_FREEZE_MODE;
        }
        if self.sync_active {
            st2 |= diag::ST2_SYNC_MODE;
        }
        let [ident_hi, ident_lo] = self.ident_number.to_be_bytes();
        self.payload_buffer[..diag::STANDARD_LEN].copy_from_slice(&[
            st1,
            st2,
            0,
            self.owner.unwrap_or(diag::NO_MASTER),
            ident_hi,
            ident_lo,
        ]);
        diag::STANDARD_LEN + ext_len
    }

    fn set_prm(&mut self, now: Instant, requester: u8, prm: &[u8]) -> Answer {
        if self.locked && self.owner != Some(requester) {
            return Answer::ShortAck;
        }
        let Some((fixed, user)) = prm.split_at_checked(SET_PRM_FIXED_LEN) else {
            self.prm_fault = true;
            self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
            return Answer::ShortAck;
        };
        let status = fixed[0];
        if status & station_status::UNLOCK_REQ != 0 {
            self.owner = None;
            self.locked = false;
            self.watchdog_micros = None;
            self.watchdog_deadline = None;
            self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
            return Answer::ShortAck;
        }
        let (factor1, factor2) = (u64::from(fixed[1]), u64::from(fixed[2]));
        let ident = u16::from_be_bytes([fixed[4], fixed[5]]);
        let watchdog_on = status & station_status::WD_ON != 0;
        let (base_ms, app_prm, dpv1_enable) = if self.dpv1_status_bytes {
            match user.split_at_checked(DPV1_STATUS_LEN) {
                Some((dpv1, _)) if !dpv1_status_valid(dpv1) => (0, None, false),
                Some((dpv1, rest)) => (
                    if dpv1[0] & status1::WD_BASE_1MS != 0 {
                        1
                    } else {
                        u64::from(WATCHDOG_BASE_MS)
                    },
                    Some(rest),
                    dpv1[0] & status1::DPV1_ENABLE != 0,
                ),
                None => (0, None, false),
            }
        } else {
            (u64::from(WATCHDOG_BASE_MS), Some(user), false)
        };
        let valid = ident == self.ident_number
            && !(watchdog_on && (factor1 == 0 || factor2 == 0))
            && app_prm.is_some_and(|p| self.app.accept_user_prm(p));
        if !valid {
            self.prm_fault = true;
            self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
            return Answer::ShortAck;
        }
        self.prm_fault = false;
        self.dpv1_enabled = dpv1_enable;
        self.owner = Some(requester);
        if status & station_status::LOCK_REQ != 0 {
            self.locked = true;
        }
        self.watchdog_micros = watchdog_on.then_some(factor1 * factor2 * base_ms * 1000);
        self.watchdog_deadline = self.watchdog_micros.map(|t| now.plus_micros(t));
        if fixed[3] != 0 {
            self.min_tsdr_bits = fixed[3];
        }
        self.group = fixed[6];
        self.freeze_allowed = status & station_status::FREEZE_REQ != 0;
        self.sync_allowed = status & station_status::SYNC_REQ != 0;
        self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
        self.state = State::WaitCfg;
        Answer::ShortAck
    }

    fn chk_cfg(&mut self, now: Instant, requester: u8, cfg: &[u8]) -> Answer {
        if self.owner != Some(requester) || !matches!(self.state, State::WaitCfg | State::DataExch)
        {
            return Answer::ShortAck;
        }
        let accepted = if cfg.len() <= MAX_CFG_LEN {
            self.app.accept_cfg(cfg)
        } else {
            None
        };
        match accepted {
            Some(io) if io.inputs <= MAX_IO_LEN && io.outputs <= MAX_IO_LEN => {
                self.cfg.clear();
                // Cannot fail: cfg.len() <= MAX_CFG_LEN was checked above.
                let _ = self.cfg.extend_from_slice(cfg);
                if self.state == State::DataExch && io != self.io {
                    self.app.fail_safe(now, FailSafeReason::LeftDataExchange);
                }
                self.io = io;
                self.cfg_fault = false;
                self.outputs = [0; MAX_IO_LEN];
                self.state = State::DataExch;
            }
            _ => {
                self.cfg_fault = true;
                self.leave_to_wait_prm(now, FailSafeReason::LeftDataExchange);
            }
        }
        Answer::ShortAck
    }

    /// The configuration Get_Cfg answers with now.
    pub fn cfg_now(&self) -> &[u8] {
        if self.state == State::DataExch {
            &self.cfg
        } else {
            self.app.default_cfg()
        }
    }

    fn get_cfg(&mut self) -> Answer {
        // The fields, not `current_cfg`: the payload buffer is borrowed beside them.
        let cfg: &[u8] = if self.state == State::DataExch {
            &self.cfg
        } else {
            self.app.default_cfg()
        };
        let len = cfg.len().min(self.payload_buffer.len());
        self.payload_buffer[..len].copy_from_slice(&cfg[..len]);
        Answer::Data(ResponseStatus::DataLow, len)
    }

    fn global_control(&mut self, now: Instant, requester: u8, payload: &[u8]) -> Answer {
        let (Some(&command), Some(&group_select)) = (payload.first(), payload.get(1)) else {
            return Answer::UserError;
        };
        if self.state != State::DataExch || self.owner != Some(requester) {
            return Answer::ShortAck;
        }
        if group_select != 0 && group_select & self.group == 0 {
            return Answer::ShortAck;
        }
        let clear = command & gc::CLEAR_DATA != 0;
        if clear && !self.clear_by_command && !self.clear_by_empty_outputs {
            self.app.fail_safe(now, FailSafeReason::ClearData);
        }
        self.clear_by_command = clear;
        if self.sync_allowed && command & (gc::SYNC | gc::UNSYNC) != 0 {
            // Unsync wins over Sync where both are set. Either way the held outputs go out now.
            self.sync_active = command & gc::UNSYNC == 0;
            if !self.is_clear() {
                self.app.outputs(now, &self.outputs[..self.io.outputs]);
            }
        }
        if self.freeze_allowed && command & (gc::FREEZE | gc::UNFREEZE) != 0 {
            self.freeze_active = command & gc::UNFREEZE == 0;
            if self.freeze_active {
                let len = self.io.inputs;
                self.app.inputs(now, &mut self.frozen_inputs[..len]);
            }
        }
        Answer::ShortAck
    }

    fn read_inputs(&mut self, now: Instant) -> Answer {
        if self.state != State::DataExch {
            return Answer::NotActivated;
        }
        self.fill_inputs(now);
        Answer::Data(ResponseStatus::DataLow, self.io.inputs)
    }

    fn read_outputs(&mut self) -> Answer {
        if self.state != State::DataExch {
            return Answer::NotActivated;
        }
        let len = self.io.outputs;
        self.payload_buffer[..len].copy_from_slice(&self.outputs[..len]);
        Answer::Data(ResponseStatus::DataLow, len)
    }

    /// Set_Slave_Add: `new address, Ident_Number (2), No_Add_Chg [, Rem_Slave_Data]`.
    fn set_slave_add(&mut self, payload: &[u8]) -> Answer {
        if !matches!(self.state, State::PowerOn | State::WaitPrm) || self.owner.is_some() {
            return Answer::NotActivated;
        }
        if self.no_add_chg {
            return Answer::NotActivated;
        }
        let [new_address, ident_hi, ident_lo, no_add_chg, ..] = *payload else {
            return Answer::UserError;
        };
        if new_address > MAX_SETTABLE_ADDRESS
            || u16::from_be_bytes([ident_hi, ident_lo]) != self.ident_number
        {
            return Answer::UserError;
        }
        self.address = new_address;
        self.no_add_chg = no_add_chg != 0;
        self.app.store_address(new_address, self.no_add_chg);
        self.state = State::WaitPrm;
        self.last = None;
        Answer::ShortAck
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::EchoApp;
    use fdl::{RequestFunction as F, ResponseStatus as S};

    const IDENT: u16 = 0x80E0;
    const ME: u8 = 8;
    const MASTER: u8 = 2;
    const OTHER_MASTER: u8 = 3;
    const PPO1: &[u8] = &[0xF3, 0xF1];
    /// Lock_Req | WD_On, WD 10 x 10 x 10 ms = 1 s, min TSDR 11, ident 0x80E0, group 1.
    const SET_PRM: [u8; 8] = [0x88, 10, 10, 11, 0x80, 0xE0, 0x01, 0x00];

    const REQ_TEMPL: DataRepr<'static> = DataRepr {
        da: ME,
        sa: MASTER,
        dsap: None,
        ssap: Some(Sap::MASTER_MS0),
        fc: FrameControl::Request {
            fcb: false,
            fcv: false,
            function: F::SrdLow,
        },
        payload: &[],
    };

    fn slave() -> Slave<EchoApp> {
        slave_with(false)
    }

    fn slave_with(dpv1_status_bytes: bool) -> Slave<EchoApp> {
        Slave::new(
            Config {
                address: ME,
                ident_number: IDENT,
                no_add_chg: false,
                dpv1_status_bytes,
            },
            EchoApp {
                accepted_cfgs: &[PPO1, &[0xF1]],
                default_cfg: PPO1,
                ..EchoApp::default()
            },
        )
    }

    fn service(sap: Sap, payload: &[u8]) -> DataRepr<'_> {
        DataRepr {
            dsap: Some(sap),
            payload,
            ..REQ_TEMPL
        }
    }

    /// Sends `req` at `now` and returns the response, owned.
    fn send(slave: &mut Slave<EchoApp>, now: u64, req: DataRepr) -> Option<Owned> {
        slave
            .process(Instant::from_millis(now), &Repr::Data(req))
            .map(Owned::from)
    }

    /// A response without the borrow of the slave.
    #[derive(Debug, PartialEq)]
    enum Owned {
        ShortAck,
        Data(S, Vec<u8>),
    }

    impl From<Repr<'_>> for Owned {
        fn from(repr: Repr) -> Owned {
            match repr {
                Repr::Data(DataRepr {
                    fc: FrameControl::Response { status, .. },
                    payload,
                    ..
                }) => Owned::Data(status, payload.to_vec()),
                Repr::ShortAck => Owned::ShortAck,
                other => panic!("not a response: {other:?}"),
            }
        }
    }

    fn diag(slave: &mut Slave<EchoApp>, from: u8) -> Vec<u8> {
        match send(
            slave,
            0,
            DataRepr {
                sa: from,
                ..service(Sap::SLAVE_DIAG, &[])
            },
        ) {
            Some(Owned::Data(S::DataLow, d)) => d,
            other => panic!("diag: {other:?}"),
        }
    }

    /// Set_Prm and Chk_Cfg PPO1 from MASTER at t = 0.
    fn into_data_exchange(slave: &mut Slave<EchoApp>) {
        assert_eq!(
            send(slave, 0, service(Sap::SET_PRM, &SET_PRM)),
            Some(Owned::ShortAck)
        );
        assert_eq!(slave.state(), State::WaitCfg);
        assert_eq!(
            send(slave, 0, service(Sap::CHK_CFG, PPO1)),
            Some(Owned::ShortAck)
        );
        assert_eq!(slave.state(), State::DataExch);
    }

    fn data_exchange(slave: &mut Slave<EchoApp>, now: u64, outputs: &[u8]) -> Option<Owned> {
        send(
            slave,
            now,
            DataRepr {
                ssap: None,
                fc: FrameControl::Request {
                    fcb: false,
                    fcv: false,
                    function: F::SrdHigh,
                },
                payload: outputs,
                ..REQ_TEMPL
            },
        )
    }

    #[test]
    fn first_diagnosis_matches_the_et200s_vector() {
        // PROTOCOL.md: an ET200S in Wait_Prm answers `02 05 00 FF 80 E0`.
        let mut s = slave();
        assert_eq!(s.state(), State::PowerOn);
        assert_eq!(diag(&mut s, 1), [0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0]);
        assert_eq!(s.state(), State::WaitPrm);
    }

    #[test]
    fn protocol_md_fdl_status_reply() {
        let mut s = slave();
        let mut out = [0u8; 8];
        let n = s.handle(
            Instant::ZERO,
            &[0x10, 0x08, 0x02, 0x49, 0x53, 0x16],
            &mut out,
        );
        assert_eq!(&out[..n.unwrap()], [0x10, 0x02, 0x08, 0x00, 0x0A, 0x16]);
    }

    #[test]
    fn bring_up_and_exchange_data() {
        let mut s = slave();
        into_data_exchange(&mut s);
        // Not ready cleared, WD_On, the parameterising master, our ident.
        assert_eq!(diag(&mut s, MASTER), [0x00, 0x0C, 0x00, MASTER, 0x80, 0xE0]);
        assert_eq!(
            s.io_sizes(),
            IoSizes {
                inputs: 12,
                outputs: 12
            }
        );
        assert_eq!(s.min_tsdr_bits(), 11);
        let outputs: Vec<u8> = (0..12).collect();
        let want: Vec<u8> = outputs.iter().map(|b| !b).collect();
        assert_eq!(
            data_exchange(&mut s, 1, &outputs),
            Some(Owned::Data(S::DataLow, want))
        );
        assert_eq!(s.app().outputs.as_slice(), outputs.as_slice());
    }

    #[test]
    fn wrong_ident_sets_prm_fault() {
        let mut s = slave();
        let mut prm = SET_PRM;
        prm[5] = 0xE1;
        assert_eq!(
            send(&mut s, 0, service(Sap::SET_PRM, &prm)),
            Some(Owned::ShortAck)
        );
        assert_eq!(s.state(), State::WaitPrm);
        let d = diag(&mut s, MASTER);
        assert_eq!(d[0], diag::ST1_PRM_FAULT | diag::ST1_NOT_READY);
        assert_eq!(d[1] & diag::ST2_PRM_REQ, diag::ST2_PRM_REQ);
        // A good Set_Prm clears it.
        into_data_exchange(&mut s);
        assert_eq!(diag(&mut s, MASTER)[0], 0);
    }

    #[test]
    fn rejected_user_parameters_and_short_set_prm_set_prm_fault() {
        let mut s = slave();
        s.app_mut().reject_user_prm_byte = Some(0x00);
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM));
        assert_eq!(s.state(), State::WaitPrm);
        assert_eq!(
            diag(&mut s, MASTER)[0] & diag::ST1_PRM_FAULT,
            diag::ST1_PRM_FAULT
        );
        let mut s = slave();
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM[..6]));
        assert_eq!(
            diag(&mut s, MASTER)[0] & diag::ST1_PRM_FAULT,
            diag::ST1_PRM_FAULT
        );
        // WD_On with a zero factor.
        let mut s = slave();
        let mut prm = SET_PRM;
        prm[2] = 0;
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        assert_eq!(
            diag(&mut s, MASTER)[0] & diag::ST1_PRM_FAULT,
            diag::ST1_PRM_FAULT
        );
    }

    #[test]
    fn user_parameters_reach_the_application() {
        let mut s = slave();
        let prm = [0x88, 10, 10, 11, 0x80, 0xE0, 0x01, 0x10, 0x20, 0x30];
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        assert_eq!(s.app().user_prm.as_slice(), [0x10, 0x20, 0x30]);
    }

    #[test]
    fn wrong_configuration_sets_cfg_fault() {
        let mut s = slave();
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM));
        assert_eq!(
            send(&mut s, 0, service(Sap::CHK_CFG, &[0xF3, 0xF5])),
            Some(Owned::ShortAck)
        );
        assert_eq!(s.state(), State::WaitPrm);
        let d = diag(&mut s, MASTER);
        assert_eq!(d[0], diag::ST1_CFG_FAULT | diag::ST1_NOT_READY);
    }

    #[test]
    fn get_cfg_reports_the_default_then_the_accepted_configuration() {
        let mut s = slave();
        assert_eq!(
            send(&mut s, 0, service(Sap::GET_CFG, &[])),
            Some(Owned::Data(S::DataLow, PPO1.to_vec()))
        );
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM));
        send(&mut s, 0, service(Sap::CHK_CFG, &[0xF1]));
        assert_eq!(
            send(&mut s, 0, service(Sap::GET_CFG, &[])),
            Some(Owned::Data(S::DataLow, vec![0xF1]))
        );
    }

    #[test]
    fn a_repeated_fcb_gets_the_last_response_and_is_not_executed_again() {
        let mut s = slave();
        into_data_exchange(&mut s);
        let dx = |fcb, fcv, outputs| DataRepr {
            ssap: None,
            fc: FrameControl::Request {
                fcb,
                fcv,
                function: F::SrdHigh,
            },
            payload: outputs,
            ..REQ_TEMPL
        };
        let first = send(&mut s, 1, dx(true, false, &[1; 12]));
        let second = send(&mut s, 2, dx(false, true, &[2; 12]));
        assert_ne!(first, second);
        assert_eq!(s.app().output_count, 2);
        // The master lost our answer and repeats with the same FCB (and the same data).
        let repeat = send(&mut s, 3, dx(false, true, &[2; 12]));
        assert_eq!(repeat, second);
        assert_eq!(s.app().output_count, 2);
        // The next toggle is new again.
        send(&mut s, 4, dx(true, true, &[3; 12]));
        assert_eq!(s.app().output_count, 3);
        assert_eq!(s.app().outputs.as_slice(), [3; 12]);
    }

    /// Issue 16: profirust 0.6 gives up on a station after a lost answer and its lost retry,
    /// then asks for its diagnosis with the FCB it had (FCV=1). That cannot be a repetition of
    /// the Data_Exchange answered last: it gets the diagnosis, so the master can go on.
    #[test]
    fn the_same_fcb_for_another_service_is_a_new_request() {
        let mut s = slave();
        into_data_exchange(&mut s);
        let dx = DataRepr {
            ssap: None,
            fc: FrameControl::Request {
                fcb: false,
                fcv: true,
                function: F::SrdHigh,
            },
            payload: &[7; 12],
            ..REQ_TEMPL
        };
        let answered = send(&mut s, 1, dx);
        assert!(matches!(answered, Some(Owned::Data(S::DataLow, _))));
        let diag = DataRepr {
            fc: FrameControl::Request {
                fcb: false,
                fcv: true,
                function: F::SrdLow,
            },
            ..service(Sap::SLAVE_DIAG, &[])
        };
        let Some(Owned::Data(_, diagnosis)) = send(&mut s, 2, diag) else {
            panic!("no diagnosis");
        };
        assert!(
            diagnosis.len() >= 6,
            "the diagnosis, not the stored outputs' answer"
        );
        assert_eq!(diagnosis[3], MASTER, "Diag.Master_Add");
        // Its own repetition still gets the stored diagnosis.
        assert_eq!(
            send(&mut s, 3, diag),
            Some(Owned::Data(S::DataLow, diagnosis))
        );
    }

    /// Set_Prm's first 7 bytes and DPV1_Status_1..3, then one user byte.
    fn dpv1_prm(s1: u8, s2: u8, s3: u8) -> [u8; 11] {
        let mut prm = [0u8; 11];
        prm[..7].copy_from_slice(&SET_PRM[..7]);
        prm[7..10].copy_from_slice(&[s1, s2, s3]);
        prm
    }

    fn msac1(slave: &mut Slave<EchoApp>, now: u64, fcb: bool, pdu: &[u8]) -> Option<Owned> {
        let request = DataRepr {
            dsap: Some(Sap::MSAC1),
            ssap: Some(Sap::MSAC1),
            fc: FrameControl::Request {
                fcb,
                fcv: true,
                function: F::SrdLow,
            },
            payload: pdu,
            ..REQ_TEMPL
        };
        send(slave, now, request)
    }

    /// Seed 004's DPV1_Status bytes: DPV1_Enable opens SAP 51; Publisher_Enable, any alarm
    /// enable, Prm_Structure, IsoM_Req and reserved bits are "not supported": Prm_Fault.
    #[test]
    fn seed_004_dpv1_status_bytes_of_set_prm() {
        let refused = [
            dpv1_prm(0x80 | status1::PUBLISHER_ENABLE, 0, 0),
            dpv1_prm(0x81, 0, 0),
            dpv1_prm(0x80, 0x02, 0),
            dpv1_prm(0x80, 0x04, 0),
            dpv1_prm(0x80, 0x80, 0),
            dpv1_prm(0x80, 0, status3::PRM_STRUCTURE),
            dpv1_prm(0x80, 0, status3::ISOM_REQ),
            dpv1_prm(0x80, 0, 0x20),
        ];
        for prm in refused {
            let mut s = slave_with(true);
            send(&mut s, 0, service(Sap::SET_PRM, &prm));
            assert!(s.prm_fault(), "{prm:02X?}");
        }
        // Chk_Cfg_Mode and Alarm_Mode are taken; Fail_Safe too; WD_Base_1ms shortens the
        // watchdog to 10 x 10 x 1 ms.
        let mut s = slave_with(true);
        let prm = dpv1_prm(0x80 | 0x40 | 0x04, 0x01, 0x07);
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        assert!(!s.prm_fault());
        assert!(s.dpv1_enabled());
        assert_eq!(s.watchdog_micros(), Some(100_000));
        assert_eq!(
            s.app().user_prm.as_slice(),
            [0],
            "the user data after the status bytes"
        );
    }

    /// SAP 51: refused without DPV1_Enable; a request is executed and acknowledged with SC,
    /// the response comes on the master's next poll (an SRD without data), once, and its
    /// repetition (the same FCB) gets it again; a poll with nothing to give gets SC.
    #[test]
    fn msac1_request_then_poll() {
        let mut s = slave_with(true);
        let read = [0x5E, 1, 47, 240];
        // DP-V0 only: SAP 51 is not activated.
        send(&mut s, 0, service(Sap::SET_PRM, &dpv1_prm(0, 0, 0)));
        send(&mut s, 0, service(Sap::CHK_CFG, PPO1));
        assert_eq!(
            msac1(&mut s, 1, true, &read),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        let mut s = slave_with(true);
        send(&mut s, 0, service(Sap::SET_PRM, &dpv1_prm(0x80, 0, 0)));
        send(&mut s, 0, service(Sap::CHK_CFG, PPO1));
        assert_eq!(s.state(), State::DataExch);
        let write = [0x5F, 1, 47, 3, 7, 8, 9];
        assert_eq!(msac1(&mut s, 1, true, &write), Some(Owned::ShortAck));
        assert_eq!(s.msac1_response(), Some(&[0x5F, 1, 47, 3][..]));
        let answer = msac1(&mut s, 2, false, &[]);
        assert_eq!(answer, Some(Owned::Data(S::DataLow, vec![0x5F, 1, 47, 3])));
        assert_eq!(
            msac1(&mut s, 3, false, &[]),
            answer,
            "a repetition gets it again"
        );
        assert_eq!(
            msac1(&mut s, 4, true, &[]),
            Some(Owned::ShortAck),
            "nothing more"
        );
        msac1(&mut s, 5, false, &read);
        assert_eq!(
            msac1(&mut s, 6, true, &[]),
            Some(Owned::Data(S::DataLow, vec![0x5E, 1, 47, 3, 7, 8, 9]))
        );
        // A malformed request gets its negative response the same way.
        msac1(&mut s, 7, false, &[0x5F, 1, 47, 5, 1]);
        assert_eq!(
            msac1(&mut s, 8, true, &[]),
            Some(Owned::Data(S::DataLow, vec![0xDF, 0x80, 0xB1, 0]))
        );
        // Data exchange went on untouched.
        assert_eq!(s.state(), State::DataExch);
        assert_eq!(s.app().output_count, 0);
    }

    proptest::proptest! {
        /// Arbitrary bytes on SAP 51 never change the cyclic state: the state, the outputs
        /// held and the inputs the next Data_Exchange answers with.
        #[test]
        fn arbitrary_bytes_on_sap_51_leave_the_cyclic_state_alone(
            pdus in proptest::collection::vec(proptest::collection::vec(proptest::prelude::any::<u8>(), 0..250), 1..8)
        ) {
            let mut s = slave_with(true);
            send(&mut s, 0, service(Sap::SET_PRM, &dpv1_prm(0x80, 0, 0)));
            send(&mut s, 0, service(Sap::CHK_CFG, PPO1));
            let before = data_exchange(&mut s, 1, &[5; 12]);
            for (i, pdu) in pdus.iter().enumerate() {
                let _ = msac1(&mut s, 2 + i as u64, i % 2 == 0, pdu);
            }
            proptest::prop_assert_eq!(s.state(), State::DataExch);
            proptest::prop_assert_eq!(s.app().output_count, 1);
            let after = data_exchange(&mut s, 100, &[5; 12]);
            proptest::prop_assert_eq!(before, after);
        }
    }

    #[test]
    fn a_locked_slave_ignores_other_masters() {
        let mut s = slave();
        into_data_exchange(&mut s);
        let other = |sap, payload| DataRepr {
            sa: OTHER_MASTER,
            ..service(sap, payload)
        };
        let mut prm = SET_PRM;
        prm[6] = 0x02;
        assert_eq!(
            send(&mut s, 0, other(Sap::SET_PRM, &prm)),
            Some(Owned::ShortAck)
        );
        assert_eq!(s.state(), State::DataExch);
        assert_eq!(s.owner(), Some(MASTER));
        // Data_Exchange of another master: SAP not activated, no outputs taken.
        let count = s.app().output_count;
        let reply = send(
            &mut s,
            0,
            DataRepr {
                sa: OTHER_MASTER,
                ssap: None,
                payload: &[9; 12],
                ..REQ_TEMPL
            },
        );
        assert_eq!(reply, Some(Owned::Data(S::SapNotActivated, vec![])));
        assert_eq!(s.app().output_count, count);
        // Its diagnosis shows Master_Lock and who holds it; the owner's does not.
        let d = diag(&mut s, OTHER_MASTER);
        assert_eq!(d[0], diag::ST1_MASTER_LOCK);
        assert_eq!(d[3], MASTER);
        assert_eq!(diag(&mut s, MASTER)[0], 0);
    }

    #[test]
    fn unlock_releases_the_slave() {
        let mut s = slave();
        into_data_exchange(&mut s);
        let mut prm = SET_PRM;
        prm[0] = station_status::UNLOCK_REQ;
        send(&mut s, 5, service(Sap::SET_PRM, &prm));
        assert_eq!(s.state(), State::WaitPrm);
        assert_eq!(s.owner(), None);
        assert!(!s.is_locked());
        assert_eq!(
            s.app().fail_safes.as_slice(),
            [FailSafeReason::LeftDataExchange]
        );
        // Another master may now parameterise it.
        send(
            &mut s,
            6,
            DataRepr {
                sa: OTHER_MASTER,
                ..service(Sap::SET_PRM, &SET_PRM)
            },
        );
        assert_eq!(s.owner(), Some(OTHER_MASTER));
    }

    #[test]
    fn watchdog_expiry_goes_fail_safe_and_back_to_wait_prm() {
        let mut s = slave();
        into_data_exchange(&mut s);
        assert_eq!(s.poll_at(), Some(Instant::from_millis(1000)));
        // Each request of the owner retriggers it.
        data_exchange(&mut s, 900, &[1; 12]);
        assert_eq!(s.poll_at(), Some(Instant::from_millis(1900)));
        assert!(!s.poll(Instant::from_millis(1899)));
        assert_eq!(s.state(), State::DataExch);
        assert!(s.poll(Instant::from_millis(1900)));
        assert_eq!(s.state(), State::WaitPrm);
        assert_eq!(
            s.app().fail_safes.as_slice(),
            [FailSafeReason::WatchdogExpired]
        );
        assert!(s.app().outputs.is_empty());
        assert_eq!(s.poll_at(), None);
        assert_eq!(s.owner(), None);
    }

    #[test]
    fn watchdog_with_the_1ms_base_of_dpv1_status() {
        let mut s = slave_with(true);
        // DPV1_Status_1 with WD_Base_1ms, then two more status bytes: 10 x 10 x 1 ms.
        let prm = [0x88, 10, 10, 11, 0x80, 0xE0, 0x01, 0x04, 0x00, 0x00, 0x42];
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        assert_eq!(s.poll_at(), Some(Instant::from_millis(100)));
        assert_eq!(s.app().user_prm.as_slice(), [0x42]);
        // Without the bit the base is 10 ms.
        let mut s = slave_with(true);
        let prm = [0x88, 10, 10, 11, 0x80, 0xE0, 0x01, 0x00, 0x00, 0x00];
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        assert_eq!(s.poll_at(), Some(Instant::from_millis(1000)));
        // Missing status bytes are a parameter fault.
        let mut s = slave_with(true);
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM));
        assert_eq!(s.state(), State::WaitPrm);
    }

    #[test]
    fn global_control_clear_data_holds_the_outputs_in_fail_safe() {
        let mut s = slave();
        into_data_exchange(&mut s);
        data_exchange(&mut s, 1, &[1; 12]);
        let gc = |payload| DataRepr {
            da: BROADCAST_ADDRESS,
            fc: FrameControl::Request {
                fcb: false,
                fcv: false,
                function: F::SdnHigh,
            },
            ..service(Sap::GLOBAL_CONTROL, payload)
        };
        assert_eq!(send(&mut s, 2, gc(&[gc::CLEAR_DATA, 0])), None);
        assert!(s.is_clear());
        assert_eq!(s.app().fail_safes.as_slice(), [FailSafeReason::ClearData]);
        // Outputs during Clear do not reach the application.
        data_exchange(&mut s, 3, &[0; 12]);
        assert_eq!(s.app().output_count, 1);
        // Clear ends: outputs flow again.
        send(&mut s, 4, gc(&[0, 0]));
        data_exchange(&mut s, 5, &[5; 12]);
        assert_eq!(s.app().output_count, 2);
        // A group we are not in (we are group 1) is ignored.
        send(&mut s, 6, gc(&[gc::CLEAR_DATA, 0x02]));
        assert!(!s.is_clear());
    }

    #[test]
    fn sync_holds_outputs_and_freeze_holds_inputs() {
        let mut s = slave();
        let mut prm = SET_PRM;
        prm[0] |= station_status::SYNC_REQ | station_status::FREEZE_REQ;
        send(&mut s, 0, service(Sap::SET_PRM, &prm));
        send(&mut s, 0, service(Sap::CHK_CFG, &[0xF1]));
        let gc = |payload| service(Sap::GLOBAL_CONTROL, payload);
        data_exchange(&mut s, 1, &[1; 4]);
        assert_eq!(send(&mut s, 2, gc(&[gc::SYNC, 0])), Some(Owned::ShortAck));
        data_exchange(&mut s, 3, &[2; 4]);
        assert_eq!(
            s.app().outputs.as_slice(),
            [1; 4],
            "held until the next Sync"
        );
        send(&mut s, 4, gc(&[gc::SYNC, 0]));
        assert_eq!(s.app().outputs.as_slice(), [2; 4]);
        // Freeze latches the inputs (complement of [2; 4]).
        send(&mut s, 5, gc(&[gc::UNSYNC | gc::FREEZE, 0]));
        assert_eq!(
            data_exchange(&mut s, 6, &[3; 4]),
            Some(Owned::Data(S::DataLow, vec![!2; 4]))
        );
        assert_eq!(
            diag(&mut s, MASTER)[1] & diag::ST2_FREEZE_MODE,
            diag::ST2_FREEZE_MODE
        );
        send(&mut s, 7, gc(&[gc::UNFREEZE, 0]));
        assert_eq!(
            data_exchange(&mut s, 8, &[3; 4]),
            Some(Owned::Data(S::DataLow, vec![!3; 4]))
        );
    }

    #[test]
    fn read_inputs_and_outputs() {
        let mut s = slave();
        assert_eq!(
            send(&mut s, 0, service(Sap::RD_INP, &[])),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        into_data_exchange(&mut s);
        data_exchange(&mut s, 1, &[7; 12]);
        let other = |sap| DataRepr {
            sa: OTHER_MASTER,
            ..service(sap, &[])
        };
        assert_eq!(
            send(&mut s, 2, other(Sap::RD_OUTP)),
            Some(Owned::Data(S::DataLow, vec![7; 12]))
        );
        assert_eq!(
            send(&mut s, 2, other(Sap::RD_INP)),
            Some(Owned::Data(S::DataLow, vec![!7; 12]))
        );
    }

    #[test]
    fn set_slave_add_before_parameterisation_only() {
        let mut s = slave();
        let add = [42, 0x80, 0xE0, 0x00];
        assert_eq!(
            send(&mut s, 0, service(Sap::SET_SLAVE_ADD, &add)),
            Some(Owned::ShortAck)
        );
        assert_eq!(s.address(), 42);
        assert_eq!(s.app().stored_address, Some((42, false)));
        // The old address is gone.
        assert_eq!(send(&mut s, 0, service(Sap::SLAVE_DIAG, &[])), None);
        let at_42 = |sap, payload| DataRepr {
            da: 42,
            ..service(sap, payload)
        };
        // Wrong ident, and an address above 125: user error.
        assert_eq!(
            send(&mut s, 0, at_42(Sap::SET_SLAVE_ADD, &[43, 0x80, 0xE1, 0])),
            Some(Owned::Data(S::UserError, vec![]))
        );
        assert_eq!(
            send(&mut s, 0, at_42(Sap::SET_SLAVE_ADD, &[126, 0x80, 0xE0, 0])),
            Some(Owned::Data(S::UserError, vec![]))
        );
        // With No_Add_Chg the next change is refused.
        send(&mut s, 0, at_42(Sap::SET_SLAVE_ADD, &[43, 0x80, 0xE0, 1]));
        assert_eq!(s.address(), 43);
        let at_43 = |sap, payload| DataRepr {
            da: 43,
            ..service(sap, payload)
        };
        assert_eq!(
            send(&mut s, 0, at_43(Sap::SET_SLAVE_ADD, &[44, 0x80, 0xE0, 0])),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        // After Set_Prm it is refused too.
        let mut s = slave();
        send(&mut s, 0, service(Sap::SET_PRM, &SET_PRM));
        assert_eq!(
            send(&mut s, 0, service(Sap::SET_SLAVE_ADD, &add)),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        assert_eq!(s.address(), ME);
    }

    #[test]
    fn restart_at_a_new_address_leaves_data_exchange_and_answers_only_there() {
        let mut s = slave();
        into_data_exchange(&mut s);
        s.restart_at(Instant::from_micros(5), 42);
        assert_eq!((s.address(), s.state()), (42, State::WaitPrm));
        assert_eq!(
            s.app().fail_safes.as_slice(),
            [FailSafeReason::LeftDataExchange]
        );
        assert_eq!(s.owner(), None);
        assert!(!s.is_locked());
        // The old address is silent; the new one wants parameters again.
        assert_eq!(send(&mut s, 10, service(Sap::SLAVE_DIAG, &[])), None);
        let at_42 = DataRepr {
            da: 42,
            ..service(Sap::SET_PRM, &SET_PRM)
        };
        assert_eq!(send(&mut s, 20, at_42), Some(Owned::ShortAck));
        assert_eq!(s.state(), State::WaitCfg);
    }

    #[test]
    fn no_response_to_sdn_broadcast_or_other_stations_and_rs_for_inactive_saps() {
        let mut s = slave();
        let sdn = DataRepr {
            fc: FrameControl::Request {
                fcb: false,
                fcv: false,
                function: F::SdnLow,
            },
            ..service(Sap::SLAVE_DIAG, &[])
        };
        assert_eq!(send(&mut s, 0, sdn), None);
        assert_eq!(
            send(
                &mut s,
                0,
                DataRepr {
                    da: 9,
                    ..service(Sap::SLAVE_DIAG, &[])
                }
            ),
            None
        );
        assert_eq!(
            send(
                &mut s,
                0,
                DataRepr {
                    da: BROADCAST_ADDRESS,
                    ..service(Sap::SLAVE_DIAG, &[])
                }
            ),
            None
        );
        // DP-V1 MSAC1 (51) is not active in DP-V0.
        assert_eq!(
            send(&mut s, 0, service(Sap(51), &[0x5E, 0, 1, 4])),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        // Data_Exchange before parameterisation.
        assert_eq!(
            data_exchange(&mut s, 0, &[]),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
    }

    #[test]
    fn broadcasts_other_than_global_control_change_nothing() {
        let mut s = slave();
        let to_all = |sap, payload| DataRepr {
            da: BROADCAST_ADDRESS,
            fc: FrameControl::Request {
                fcb: false,
                fcv: false,
                function: F::SdnLow,
            },
            ..service(sap, payload)
        };
        assert_eq!(send(&mut s, 0, to_all(Sap::SET_PRM, &SET_PRM)), None);
        assert_eq!(s.state(), State::PowerOn);
        assert_eq!(s.owner(), None);
        into_data_exchange(&mut s);
        assert_eq!(send(&mut s, 1, to_all(Sap::CHK_CFG, &[0xF1])), None);
        assert_eq!(
            send(
                &mut s,
                1,
                DataRepr {
                    ssap: None,
                    ..to_all(Sap::SET_PRM, &[0; 12])
                }
            ),
            None
        );
        assert_eq!(
            s.io_sizes(),
            IoSizes {
                inputs: 12,
                outputs: 12
            }
        );
        assert_eq!(s.app().output_count, 0);
        let add = [42, 0x80, 0xE0, 0x00];
        assert_eq!(send(&mut s, 1, to_all(Sap::SET_SLAVE_ADD, &add)), None);
        assert_eq!(s.address(), ME);
    }

    #[test]
    fn new_diagnosis_answers_data_high_until_read() {
        let mut s = slave();
        into_data_exchange(&mut s);
        s.app_mut().diag_changed = true;
        let _ = s.app_mut().ext_diag.extend_from_slice(&[0x03, 0xAA, 0xBB]);
        assert!(matches!(
            data_exchange(&mut s, 1, &[0; 12]),
            Some(Owned::Data(S::DataHigh, _))
        ));
        assert!(matches!(
            data_exchange(&mut s, 2, &[0; 12]),
            Some(Owned::Data(S::DataHigh, _))
        ));
        let d = diag(&mut s, MASTER);
        assert_eq!(d[0], diag::ST1_EXT_DIAG);
        assert_eq!(&d[6..], [0x03, 0xAA, 0xBB]);
        assert!(matches!(
            data_exchange(&mut s, 3, &[0; 12]),
            Some(Owned::Data(S::DataLow, _))
        ));
    }

    #[test]
    fn outputs_of_the_wrong_length_end_data_exchange() {
        let mut s = slave();
        into_data_exchange(&mut s);
        assert_eq!(
            data_exchange(&mut s, 1, &[0; 5]),
            Some(Owned::Data(S::SapNotActivated, vec![]))
        );
        assert_eq!(s.state(), State::WaitPrm);
        assert_eq!(
            s.app().fail_safes.as_slice(),
            [FailSafeReason::LeftDataExchange]
        );
    }

    #[test]
    fn protocol_md_siemens_sequence_through_handle() {
        // Slave 8 with ident 0x80E0 (the ET200S of PROTOCOL.md), master 1: diag, then Get_Cfg.
        let mut s = Slave::new(
            Config {
                address: 8,
                ident_number: 0x80E0,
                no_add_chg: false,
                dpv1_status_bytes: false,
            },
            EchoApp {
                default_cfg: &[0x00, 0x10, 0x10],
                ..EchoApp::default()
            },
        );
        let mut out = [0u8; 64];
        let n = s
            .handle(
                Instant::ZERO,
                &[
                    0x68, 0x05, 0x05, 0x68, 0x88, 0x81, 0x6D, 0x3C, 0x3E, 0xF0, 0x16,
                ],
                &mut out,
            )
            .unwrap();
        let (resp, _) = Repr::parse_bytes(&out[..n]).unwrap();
        let (want, _) = Repr::parse_bytes(&[
            0x68, 0x0B, 0x0B, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3C, 0x02, 0x05, 0x00, 0xFF, 0x80,
            0xE0, 0xF1, 0x16,
        ])
        .unwrap();
        assert_eq!(resp, want);
        let n = s
            .handle(
                Instant::ZERO,
                &[
                    0x68, 0x05, 0x05, 0x68, 0x88, 0x81, 0x5D, 0x3B, 0x3E, 0xDF, 0x16,
                ],
                &mut out,
            )
            .unwrap();
        assert_eq!(
            &out[..n],
            [0x68, 0x08, 0x08, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3B, 0x00, 0x10, 0x10, 0xAA, 0x16]
        );
    }
}
