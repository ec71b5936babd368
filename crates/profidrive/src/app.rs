//! The drive application: dp-slave's [`Application`] for the two manuals.
//!
//! Data exchange never waits for the drive. `outputs` and `inputs` only copy between the
//! telegram and two process images; [`ProfidriveApp::service`] does the drive's I/O from
//! them: the PZD out (control word and the WrPZD targets), the PZD in (status word and the
//! RdPZD sources), the PKW request, the fail-safe and the communication cut-off. The firmware
//! calls it after each data exchange and from its own cycle.
//!
//! Fail-safe (seed 004, extended Prm_Data byte 8): on a PLC stop (Global_Control Clear), a
//! watchdog expiry or the cut-off, the drive gets STOP (the control word with its run command
//! removed), LAST SPEED (the last outputs kept) or USE FAIL-SAFE (the PZD values of the
//! parameter data). Seed 004 makes STOP the same as LAST SPEED in its vendor mode, because
//! it does not know a vendor's control word; seed 000's words are known here, so STOP stops.
//! The next outputs from the master end the fail-safe.

use crate::codes::FunctionCode;
use crate::dpv1::Dpv1Server;
use crate::drive::{Access, Drive, DriveError, ParamRequest, PZD1_LINK_ERROR};
use crate::faults::FaultBuffer;
use crate::link_diag::LinkDiagnosis;
use crate::pd_params::{pzd_target, Action, Frame, Parameters};
use crate::pkw::{PkwServer, Planned, PKW_BYTES};
use crate::ppo::{Ppo, MAX_PZD_WORDS};
use crate::prm::{ControlZeroMode, FailSafeMode, OperationMode, UserPrm};
use crate::profile::Profile;
use crate::words::control;
use crate::words::status;
use dp_slave::{Application, FailSafeReason, Instant, IoSizes};

/// Why the outputs are in fail-safe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FailSafeCause {
    /// Global_Control Clear_Data: the PLC stopped.
    PlcStop,
    /// The DP watchdog expired.
    Watchdog,
    /// No data exchange within the cut-off time of the parameter data.
    CutOff,
    /// Data exchange ended (new parameters, a configuration fault).
    LeftDataExchange,
}

pub use crate::link_diag::{
    DPV1_STATUS_BLOCK_LEN, DPV1_STATUS_TYPE, EXT_DIAG_DRIVE_FAULT, EXT_DIAG_LEN,
    EXT_DIAG_LINK_LOST_PERMANENTLY, EXT_DIAG_LINK_LOST_TEMPORARILY, LINK_LOST_PERMANENTLY_US,
};

pub struct ProfidriveApp<D> {
    drive: D,
    prm: UserPrm,
    ppo: Option<Ppo>,
    /// PZD out of the last frame used (control-zero frames may be ignored).
    pzd_out: [u16; MAX_PZD_WORDS],
    /// What the drive was last told: the outputs, or their fail-safe replacement.
    pzd_applied: [u16; MAX_PZD_WORDS],
    pzd_in: [u16; MAX_PZD_WORDS],
    pkw: PkwServer,
    fail_safe: Option<FailSafeCause>,
    last_outputs_at: Option<Instant>,
    link_error: Option<DriveError>,
    /// The extended diagnosis of the drive link and the drive's fault.
    link_diag: LinkDiagnosis,
    diag_changed: bool,
    /// The PROFIdrive state machine (operation mode PROFIdrive).
    profile: Profile,
    /// The drive's last vendor status word.
    drive_status: u16,
    /// The drive's reference value (0.01 Hz) that 4000h (PROFIdrive) or 20000 (ABB Drives)
    /// stands for: the user parameter's, or the drive's F0.10; 0 until known (references to
    /// the drive are 0 and actual values read 0 meanwhile).
    rated_reference: u16,
    /// The read of F0.10 while the user parameters leave the rated frequency to the drive.
    rated_read: Option<ParamRequest>,
    /// The PROFIdrive parameters (915 .. 972).
    params: Parameters,
    /// The fault buffer's state (945, 947, 948, 952 live in `params`).
    faults: FaultBuffer,
    /// The process data's last exchange with the drive, until the parameter half of the
    /// service notes it ([`ProfidriveApp::service_pkw`]).
    exchanged: Option<Result<(), DriveError>>,
    /// The vendor control word's fault reset bit in the last outputs applied (its rise resets a
    /// lost link's fault in 945).
    vendor_reset: bool,
    /// The user parameters' WrPZD/RdPZD as PROFIdrive numbers, PZD1..PZD10 (915/916's layout),
    /// worked out once a Set_Prm: the drive's group 51 shows them in the vendor mode.
    vendor_numbers: ([u16; MAX_PZD_WORDS], [u16; MAX_PZD_WORDS]),
    /// The PROFIdrive parameter server on DP-V1.
    dpv1: Dpv1Server,
    /// The drive's 51.21 DP MODE asks for DP-V1: Set_Prm carries DPV1_Status_1-3 before the
    /// user data, and the user data has no reserved first byte (seed 004's DP-V1 Set_Prm).
    dp_mode_dpv1: bool,
}

/// A parameter write the adapter carries out (seed 004 lines 1490 and 1552).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModuleRequest {
    /// 918 with the switch at 0: the address to store, in force after a restart.
    StoreAddress(u8),
    /// 972: restart the module.
    Restart,
    /// 971: keep the adapter's settings (927, 928, 930, 933-943) in the non-volatile storage.
    SaveSettings,
}

impl<D: Drive> ProfidriveApp<D> {
    // Always inlined: the firmware builds the adapter once, at boot, and inlined the
    // constructors write it in place instead of into temporaries copied up a level (the boot
    // frame is 0.45 KiB smaller, on the production board's 20 KiB).
    #[inline(always)]
    pub const fn new(drive: D) -> ProfidriveApp<D> {
        ProfidriveApp {
            drive,
            prm: UserPrm::DEFAULT,
            ppo: None,
            pzd_out: [0; MAX_PZD_WORDS],
            pzd_applied: [0; MAX_PZD_WORDS],
            pzd_in: [0; MAX_PZD_WORDS],
            pkw: PkwServer::new(),
            fail_safe: Some(FailSafeCause::LeftDataExchange),
            last_outputs_at: None,
            link_error: None,
            link_diag: LinkDiagnosis::new(),
            diag_changed: false,
            vendor_reset: false,
            vendor_numbers: ([0; MAX_PZD_WORDS], [0; MAX_PZD_WORDS]),
            profile: Profile::new(),
            drive_status: 0,
            rated_reference: 0,
            rated_read: None,
            params: Parameters::new(),
            faults: FaultBuffer::new(),
            exchanged: None,
            dpv1: Dpv1Server::new(),
            dp_mode_dpv1: false,
        }
    }

    /// Seed 004's 51.21 DP MODE: DP-V1 (true) or DP-V0. It selects the Set_Prm layout from the
    /// next Set_Prm on (the master must use the GSD of that mode).
    pub fn set_dp_mode_dpv1(&mut self, dpv1: bool) {
        self.dp_mode_dpv1 = dpv1;
    }

    pub fn dp_mode_dpv1(&self) -> bool {
        self.dp_mode_dpv1
    }

    /// The PZD mapping in force as PROFIdrive numbers, PZD1..PZD10 out and in (915/916's
    /// layout): 915/916 in the PROFIdrive modes, the user parameters' WrPZD/RdPZD in the
    /// vendor mode.
    pub fn mapping_numbers(&self) -> ([u16; MAX_PZD_WORDS], [u16; MAX_PZD_WORDS]) {
        if self.prm.operation.translates() {
            (self.params.pzd_out, self.params.pzd_in)
        } else {
            self.vendor_numbers
        }
    }

    /// The DP-V1 parameter server (its figures).
    pub fn dpv1(&self) -> &Dpv1Server {
        &self.dpv1
    }

    /// The PROFIdrive parameters.
    pub fn params(&self) -> &Parameters {
        &self.params
    }

    /// For the adapter: 918 (node address), 963 (baud rate), and actions to carry out.
    pub fn params_mut(&mut self) -> &mut Parameters {
        &mut self.params
    }

    /// 970 as the application carries it out; 971 and 972 are the adapter's
    /// ([`ProfidriveApp::take_module_request`]).
    fn carry_out_action(&mut self) {
        match self.params.pending_action {
            Some(Action::FactoryReset) => {
                self.params.pending_action = None;
                self.params.restore_defaults();
            }
            // The adapter's own settings go to its storage ([`ModuleRequest::SaveSettings`]);
            // seed 000's drive keeps every parameter a channel writes in its own non-volatile
            // memory at once, and has no command to store.
            Some(Action::SaveToFlash) | Some(Action::Restart) | None => {}
        }
    }

    /// What the adapter around the application must carry out for a parameter write: store a
    /// 918 station address (in force at the next restart), or restart the module (972).
    pub fn take_module_request(&mut self) -> Option<ModuleRequest> {
        if let Some(address) = self.params.pending_node_address.take() {
            return Some(ModuleRequest::StoreAddress(address as u8));
        }
        match self.params.pending_action {
            Some(Action::Restart) => {
                self.params.pending_action = None;
                Some(ModuleRequest::Restart)
            }
            Some(Action::SaveToFlash) => {
                self.params.pending_action = None;
                Some(ModuleRequest::SaveSettings)
            }
            _ => None,
        }
    }

    /// The module restarted (972): its parameters as after a power-up.
    pub fn restarted(&mut self) {
        self.params.restarted();
    }

    /// The link to the drive, for seed 004's host LED.
    pub fn drive_link(&self) -> crate::link_diag::DriveLink {
        self.link_diag.link()
    }

    /// The drive's reference value for the rated speed (0.01 Hz; 0 while not yet known).
    pub fn rated_reference(&self) -> u16 {
        self.rated_reference
    }

    /// The drive's maximum frequency, read once after the user parameters left the rated
    /// frequency to the drive, and again until the drive gives a non-zero one.
    fn read_rated_frequency(&mut self) {
        let Some(request) = &mut self.rated_read else {
            return;
        };
        match request.poll(&mut self.drive) {
            None => {}
            Some(Ok(hz)) if hz > 0 => {
                self.rated_reference = hz;
                self.rated_read = None;
            }
            Some(_) => {
                self.rated_read = Some(ParamRequest::new(Access::Read(FunctionCode(
                    crate::codes::named::MAX_FREQUENCY,
                ))))
            }
        }
    }

    /// The PROFIdrive state machine.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    pub fn drive(&self) -> &D {
        &self.drive
    }

    pub fn drive_mut(&mut self) -> &mut D {
        &mut self.drive
    }

    pub fn prm(&self) -> &UserPrm {
        &self.prm
    }

    pub fn ppo(&self) -> Option<Ppo> {
        self.ppo
    }

    pub fn fail_safe_cause(&self) -> Option<FailSafeCause> {
        self.fail_safe
    }

    /// The last error of the drive link, while it lasts.
    pub fn link_error(&self) -> Option<DriveError> {
        self.link_error
    }

    fn pzd_words(&self) -> usize {
        self.ppo.map_or(0, Ppo::pzd_words)
    }

    /// What the drive should get now: the master's outputs or their fail-safe replacement.
    fn outputs_to_apply(&self) -> [u16; MAX_PZD_WORDS] {
        let Some(_) = self.fail_safe else {
            return self.pzd_out;
        };
        match self.prm.fail_safe {
            FailSafeMode::LastSpeed => self.pzd_applied,
            FailSafeMode::UseFailSafeValues => self.prm.fail_safe_pzd,
            FailSafeMode::Stop => {
                let mut pzd = self.pzd_applied;
                pzd[0] = match self.prm.operation {
                    OperationMode::Vendor => pzd[0] & !control::RUN,
                    // OFF1: bit 0 (ON) cleared, ramp down (seed 004 table 7).
                    OperationMode::Profidrive | OperationMode::AbbDrives => pzd[0] & !0x0001,
                };
                pzd
            }
        }
    }

    /// The drive's I/O for the current process images, the PKW request, the DP-V1 request
    /// and the cut-off.
    pub fn service(&mut self, now: Instant) {
        self.service_pzd(now);
        self.service_pkw(now);
        self.service_dpv1();
    }

    /// The DP-V1 parameter request under way, one parameter on (see [`Dpv1Server::step`]).
    pub fn service_dpv1(&mut self) {
        if let Some(ppo) = self.ppo {
            self.dpv1
                .step(&mut self.params, &mut self.drive, ppo.number());
        }
    }

    /// The process data half of [`ProfidriveApp::service`]: the fail-safe cut-off, and the
    /// outputs to the drive and its answer into the inputs. A caller that must not hold the
    /// CPU long runs the two halves apart.
    pub fn service_pzd(&mut self, now: Instant) {
        if let (Some(at), None) = (self.last_outputs_at, self.fail_safe) {
            let cut_off = u64::from(self.prm.cut_off_ms) * 1000;
            if cut_off > 0 && now.micros().saturating_sub(at.micros()) >= cut_off {
                self.fail_safe = Some(FailSafeCause::CutOff);
            }
        }
        let words = self.pzd_words();
        if words == 0 {
            return;
        }
        let apply = self.outputs_to_apply();
        let result = self.exchange_with_drive(now, &apply, words);
        self.faults.update_times(now, &mut self.params);
        self.pzd_applied = apply;
        self.exchanged = Some(result);
    }

    /// The parameter half of [`ProfidriveApp::service`], after [`ProfidriveApp::service_pzd`]:
    /// the parameter channel, and the drive link's state for the diagnosis.
    pub fn service_pkw(&mut self, now: Instant) {
        let Some(result) = self.exchanged.take() else {
            return;
        };
        if let Some(ppo) = self.ppo.filter(|p| p.has_pkw()) {
            match self.prm.operation {
                OperationMode::Vendor => self.pkw.service(&mut self.drive, now.micros()),
                OperationMode::Profidrive | OperationMode::AbbDrives => {
                    let params = &mut self.params;
                    let plan =
                        |bytes: &[u8; 8]| match params.plan(&Frame::decode(bytes), ppo.number()) {
                            Planned::Reply(reply) => Planned::Reply(reply.encode()),
                            Planned::Drive(access) => Planned::Drive(access),
                        };
                    let finish = |bytes: &[u8; 8], result| {
                        Parameters::drive_reply(&Frame::decode(bytes), result).encode()
                    };
                    let reads = |bytes: &[u8; 8]| {
                        use crate::pd_params::RequestLabel as Rq;
                        matches!(
                            Frame::decode(bytes).request_label(),
                            Rq::Read | Rq::ReadArray | Rq::ArrayCount
                        )
                    };
                    self.pkw
                        .service_with(&mut self.drive, now.micros(), plan, finish, reads);
                }
            }
        }
        if self.prm.operation.translates() {
            self.read_rated_frequency();
        }
        self.carry_out_action();
        self.note_link(now, result.err());
    }

    /// The words `apply` makes for the drive: PZD1/PZD2 are the PROFIdrive CW and REF where
    /// the profile translates, and the state machine makes the drive's.
    fn drive_words(&mut self, apply: &[u16; MAX_PZD_WORDS]) -> [u16; MAX_PZD_WORDS] {
        let mut to_drive = *apply;
        if self.prm.operation.translates() {
            let d = self.profile.command(
                apply[0],
                apply[1] as i16,
                self.drive_status,
                self.rated_reference,
                self.prm.operation.rated_units(),
            );
            to_drive[0] = d.control_word;
            to_drive[1] = d.reference;
        }
        to_drive
    }

    /// The words the outputs make for the drive now (the fail-safe and the state machine
    /// applied) and how many, for a drive link that takes them at once: the rest of
    /// [`ProfidriveApp::service_pzd`] (the drive's answer, its faults, the cut-off) waits for
    /// the cycle. `None` before a PZD configuration.
    pub fn pzd_for_drive(&mut self) -> Option<([u16; MAX_PZD_WORDS], usize)> {
        let words = self.pzd_words();
        if words == 0 {
            return None;
        }
        let apply = self.outputs_to_apply();
        // What the drive was given: the fail-safe's last speed holds it.
        self.pzd_applied = apply;
        Some((self.drive_words(&apply), words))
    }

    fn exchange_with_drive(
        &mut self,
        now: Instant,
        apply: &[u16; MAX_PZD_WORDS],
        words: usize,
    ) -> Result<(), DriveError> {
        let profidrive = self.prm.operation.translates();
        let units = self.prm.operation.rated_units();
        let (targets, sources) = self.pzd_mapping();
        let to_drive = self.drive_words(apply);
        let mut from_drive = self.pzd_in;
        // The drive's own status word, not the one the master saw (translated, or 0xC0xx).
        from_drive[0] = self.drive_status;
        let was_faulted = self.drive_status & status::FAULT != 0;
        let from_drive_was_warning = self.drive_status & status::WARNING != 0;
        let result = self.drive.exchange_pzd(
            &to_drive[..words],
            &targets[..words - 1],
            &mut from_drive[..words],
            &sources[..words - 1],
        );
        self.drive_status = from_drive[0];
        self.params.motor_running = self.drive_status & status::RUNNING != 0;
        let faulted = self.drive_status & status::FAULT != 0;
        self.faults.observe(now, was_faulted, faulted);
        let was_warning = from_drive_was_warning;
        self.faults
            .observe_warning(was_warning, self.drive_status & status::WARNING != 0);
        if self.faults.service(&mut self.drive, &mut self.params) {
            self.diag_changed = true;
        }
        self.faults
            .service_warnings(&mut self.drive, &mut self.params);
        // A lost link is a fault of its own (issue 30): latched in the PROFIdrive state
        // machine; its 945 entry goes to the history with the master's RESET once the link is
        // back, as a drive fault's does (seed 004 line 972).
        let link_lost = result.is_err_and(DriveError::is_link_fault);
        let reset = if profidrive {
            self.profile.set_link_lost(link_lost);
            self.profile.take_reset_done()
        } else {
            let rose = apply[0] & crate::words::control::FAULT_RESET != 0 && !self.vendor_reset;
            self.vendor_reset = apply[0] & crate::words::control::FAULT_RESET != 0;
            rose && !link_lost
        };
        if reset && self.faults.link_fault_reset(&mut self.params) {
            self.diag_changed = true;
        }
        if profidrive {
            self.profile.observe(self.drive_status);
            from_drive[0] = self.profile.status_word(self.drive_status);
            let actual = self.profile.actual(
                self.drive_status,
                from_drive[1],
                self.rated_reference,
                units,
            );
            from_drive[1] = actual as u16;
            // ABOVE_LIMIT (table 8, bit 10): the drive has no supervision limit this adapter
            // can read, so the limit is the rated speed.
            if i32::from(actual).abs() >= units {
                from_drive[0] |= crate::profile::status::ABOVE_LIMIT;
            }
        }
        self.pzd_in = from_drive;
        if let Err(e) = result {
            self.pzd_in[0] = if profidrive {
                // Seed 000's C0xxh laid into table 8 would read "ready to run, no fault"
                // (issue 18): the PROFIdrive way is TRIPPED, the cause in 945/947 and the
                // extended diagnosis.
                let off_bits =
                    crate::profile::status::OFF_2_STA | crate::profile::status::OFF_3_STA;
                crate::profile::status::TRIPPED | (self.profile.status_word(0) & off_bits)
            } else {
                PZD1_LINK_ERROR | u16::from(e.code())
            };
        }
        // 967/968: the control word in force and the status word the master gets, in every
        // mode (the vendor's words in the vendor mode).
        self.params.control_word = apply[0];
        self.params.status_word = self.pzd_in[0];
        result
    }

    /// What PZD2..PZD10 write and read. Vendor: the RdPZD/WrPZD table of the user parameters.
    /// PROFIdrive: PZD2 is REF/ACT on the same registers as the vendor's PZD2, PZD3..PZD10
    /// follow 915/916 (0 and anything unmappable: nothing).
    fn pzd_mapping(&self) -> ([Option<FunctionCode>; 9], [Option<FunctionCode>; 9]) {
        let mut targets = self.prm.wr_pzd.map(Some);
        let mut sources = self.prm.rd_pzd.map(Some);
        if self.prm.operation.translates() {
            for i in 1..MAX_PZD_WORDS - 1 {
                targets[i] = pzd_target(self.params.pzd_out[i + 1]).ok().flatten();
                sources[i] = pzd_target(self.params.pzd_in[i + 1]).ok().flatten();
            }
        }
        (targets, sources)
    }

    fn note_link(&mut self, now: Instant, error: Option<DriveError>) {
        let was_lost = self.link_error.is_some_and(DriveError::is_link_fault);
        if let Some(e) = error.filter(|e| e.is_link_fault() && !was_lost) {
            self.faults.link_lost(now, e.code(), &mut self.params);
            self.diag_changed = true;
        }
        self.link_error = error;
        let faulted = self.drive_status & status::FAULT != 0;
        if self.link_diag.note(now, error, faulted) {
            self.diag_changed = true;
        }
    }
}

impl<D: Drive> Application for ProfidriveApp<D> {
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
        let parsed = if self.dp_mode_dpv1 {
            UserPrm::parse_dpv1(user_prm)
        } else {
            UserPrm::parse(user_prm)
        };
        match parsed {
            Ok(prm) => {
                if prm.operation != self.prm.operation {
                    self.profile = Profile::default();
                }
                if prm.rated_frequency != 0 {
                    self.rated_reference = prm.rated_frequency;
                    self.rated_read = None;
                } else {
                    // Left to the drive: ask it at every parameterisation (its F0.10 may have
                    // changed), going on with what it said last, never with the master's old
                    // value.
                    if self.prm.rated_frequency != 0 {
                        self.rated_reference = 0;
                    }
                    if self.rated_read.is_none() {
                        self.rated_read = Some(ParamRequest::new(Access::Read(FunctionCode(
                            crate::codes::named::MAX_FREQUENCY,
                        ))));
                    }
                }
                let number = |code| crate::pd_params::parameter_number(code).unwrap_or(0);
                for k in 1..MAX_PZD_WORDS {
                    self.vendor_numbers.0[k] = number(prm.wr_pzd[k - 1]);
                    self.vendor_numbers.1[k] = number(prm.rd_pzd[k - 1]);
                }
                self.prm = prm;
                true
            }
            Err(_) => false,
        }
    }

    fn accept_cfg(&mut self, cfg: &[u8]) -> Option<IoSizes> {
        let ppo = Ppo::from_cfg(cfg)?;
        if self.ppo != Some(ppo) {
            self.pkw.reset();
            self.pzd_in = [0; MAX_PZD_WORDS];
        }
        self.ppo = Some(ppo);
        Some(IoSizes {
            inputs: ppo.io_bytes(),
            outputs: ppo.io_bytes(),
        })
    }

    fn default_cfg(&self) -> &[u8] {
        Ppo::Ppo1.cfg()
    }

    fn msac1(
        &mut self,
        _now: Instant,
        request: &dp_slave::msac1::Request,
        out: &mut [u8],
    ) -> usize {
        self.dpv1.serve(request, out)
    }

    fn outputs(&mut self, now: Instant, outputs: &[u8]) {
        let Some(ppo) = self.ppo else { return };
        if outputs.iter().all(|b| *b == 0) && self.prm.control_zero == ControlZeroMode::IgnoreFrame
        {
            return;
        }
        let pzd = if ppo.has_pkw() {
            let mut request = [0u8; PKW_BYTES];
            request.copy_from_slice(&outputs[..PKW_BYTES]);
            self.pkw.received(request);
            &outputs[PKW_BYTES..]
        } else {
            outputs
        };
        // 928 = 0: the PZD part is invalid, new process data is not taken (in every mode: the
        // PROFIdrive parameters are there over DP-V1 in the vendor mode too).
        let pzd_valid = self.params.pzd_rights != 0;
        if pzd_valid {
            for (word, bytes) in self.pzd_out.iter_mut().zip(pzd.chunks_exact(2)) {
                *word = u16::from_be_bytes([bytes[0], bytes[1]]);
            }
        }
        self.last_outputs_at = Some(now);
        self.fail_safe = None;
    }

    fn inputs(&mut self, _now: Instant, inputs: &mut [u8]) {
        let Some(ppo) = self.ppo else { return };
        let pzd = if ppo.has_pkw() {
            inputs[..PKW_BYTES].copy_from_slice(&self.pkw.reply());
            &mut inputs[PKW_BYTES..]
        } else {
            inputs
        };
        for (bytes, word) in pzd.chunks_exact_mut(2).zip(self.pzd_in) {
            bytes.copy_from_slice(&word.to_be_bytes());
        }
    }

    fn fail_safe(&mut self, _now: Instant, reason: FailSafeReason) {
        self.fail_safe = Some(match reason {
            FailSafeReason::ClearData => FailSafeCause::PlcStop,
            FailSafeReason::WatchdogExpired => FailSafeCause::Watchdog,
            FailSafeReason::LeftDataExchange => FailSafeCause::LeftDataExchange,
        });
    }

    fn ext_diag(&mut self, buffer: &mut [u8]) -> usize {
        self.link_diag.write(buffer, self.dp_mode_dpv1)
    }

    fn ext_diag_reported(&self) -> bool {
        self.link_diag.reported()
    }

    fn diag_changed(&mut self) -> bool {
        core::mem::take(&mut self.diag_changed)
    }

    fn store_address(&mut self, _address: u8, _no_add_chg: bool) {
        // The adapter persists the address; the drive application has nothing to keep.
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{MockDrive, OUTPUT_FREQUENCY, SET_FREQUENCY};
    use crate::words::status;

    const START: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

    fn app_with(prm: UserPrm, ppo: Ppo) -> ProfidriveApp<MockDrive> {
        let mut app = ProfidriveApp::new(MockDrive::default());
        assert!(app.accept_user_prm(&prm.encode()));
        assert_eq!(
            app.accept_cfg(ppo.cfg()).map(|io| io.outputs),
            Some(ppo.io_bytes())
        );
        app
    }

    /// PPO3 outputs: control word and reference.
    fn ppo3(cw: u16, reference: u16) -> [u8; 4] {
        let [a, b] = cw.to_be_bytes();
        let [c, d] = reference.to_be_bytes();
        [a, b, c, d]
    }

    fn exchange(app: &mut ProfidriveApp<MockDrive>, now_ms: u64, outputs: &[u8]) -> Vec<u16> {
        let now = Instant::from_millis(now_ms);
        app.outputs(now, outputs);
        app.service(now);
        let mut inputs = vec![0u8; outputs.len()];
        app.inputs(now, &mut inputs);
        inputs
            .chunks(2)
            .map(|w| u16::from_be_bytes([w[0], w[1]]))
            .collect()
    }

    #[test]
    fn seed_000_pzd1_is_the_control_and_status_word_and_pzd2_follows_the_mapping() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        // WrPZD2 = F0.29 (set frequency), RdPZD2 = D0.00 (output frequency).
        let inputs = exchange(&mut app, 1, &ppo3(START, 5000));
        assert_eq!(app.drive().control_word, START);
        assert_eq!(app.drive().get(SET_FREQUENCY), 5000);
        assert_eq!(inputs[0] & status::RUNNING, status::RUNNING);
        assert_eq!(inputs[1], 5000);
        // PZD writes are run-time values: no wear of the drive's memory.
        assert_eq!(app.drive().persistent_writes, 0);
        let inputs = exchange(&mut app, 2, &ppo3(START & !control::RUN, 5000));
        assert_eq!(inputs[0] & status::RUNNING, 0);
        assert_eq!(inputs[1], 0);
        assert_eq!(app.drive().get(OUTPUT_FREQUENCY), 0);
    }

    #[test]
    fn mapping_from_the_user_parameters() {
        let mut prm = UserPrm::DEFAULT;
        prm.wr_pzd[0] = crate::codes::FunctionCode(0xF105);
        prm.rd_pzd[0] = crate::codes::FunctionCode(0xD105);
        let mut app = app_with(prm, Ppo::Ppo3);
        app.drive_mut().set(0xD105, 77);
        let inputs = exchange(&mut app, 1, &ppo3(START, 1234));
        assert_eq!(app.drive().get(0xF105), 1234);
        assert_eq!(inputs[1], 77);
    }

    #[test]
    fn fail_safe_modes_of_seed_004() {
        for mode in [
            FailSafeMode::Stop,
            FailSafeMode::LastSpeed,
            FailSafeMode::UseFailSafeValues,
        ] {
            for reason in [FailSafeReason::ClearData, FailSafeReason::WatchdogExpired] {
                let mut prm = UserPrm::DEFAULT;
                prm.fail_safe = mode;
                prm.fail_safe_pzd[0] = control::RUN_ENABLE | control::START_ENABLE;
                prm.fail_safe_pzd[1] = 1500;
                let mut app = app_with(prm, Ppo::Ppo3);
                exchange(&mut app, 1, &ppo3(START, 5000));
                Application::fail_safe(&mut app, Instant::from_millis(2), reason);
                app.service(Instant::from_millis(2));
                let (cw, reference) = (app.drive().control_word, app.drive().get(SET_FREQUENCY));
                match mode {
                    FailSafeMode::Stop => {
                        assert_eq!((cw, reference), (START & !control::RUN, 5000))
                    }
                    FailSafeMode::LastSpeed => assert_eq!((cw, reference), (START, 5000)),
                    FailSafeMode::UseFailSafeValues => assert_eq!(
                        (cw, reference),
                        (control::RUN_ENABLE | control::START_ENABLE, 1500)
                    ),
                }
                assert!(app.fail_safe_cause().is_some(), "{mode:?} {reason:?}");
                // The master returns: its outputs apply again.
                exchange(&mut app, 3, &ppo3(START, 4000));
                assert_eq!(app.fail_safe_cause(), None);
                assert_eq!(
                    (app.drive().control_word, app.drive().get(SET_FREQUENCY)),
                    (START, 4000)
                );
            }
        }
    }

    #[test]
    fn communication_cut_off() {
        let mut prm = UserPrm::DEFAULT;
        prm.cut_off_ms = 100;
        let mut app = app_with(prm, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(START, 5000));
        app.service(Instant::from_millis(99));
        assert_eq!(app.fail_safe_cause(), None);
        app.service(Instant::from_millis(100));
        assert_eq!(app.fail_safe_cause(), Some(FailSafeCause::CutOff));
        assert_eq!(app.drive().control_word, START & !control::RUN);
    }

    #[test]
    fn control_zero_mode() {
        let mut prm = UserPrm::DEFAULT;
        prm.control_zero = ControlZeroMode::IgnoreFrame;
        let mut app = app_with(prm, Ppo::Ppo3);
        exchange(&mut app, 1, &ppo3(START, 5000));
        exchange(&mut app, 2, &[0; 4]);
        assert_eq!(
            (app.drive().control_word, app.drive().get(SET_FREQUENCY)),
            (START, 5000)
        );
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        exchange(&mut app, 1, &ppo3(START, 5000));
        exchange(&mut app, 2, &[0; 4]);
        assert_eq!(
            (app.drive().control_word, app.drive().get(SET_FREQUENCY)),
            (0, 0)
        );
    }

    #[test]
    fn a_lost_drive_shows_c0xx_and_the_extended_diagnosis_then_recovers() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(START, 5000));
        app.drive_mut().disconnected = true;
        let inputs = exchange(&mut app, 10, &ppo3(START, 5000));
        assert_eq!(inputs[0], 0xC022);
        assert!(app.diag_changed());
        let mut diag = [0u8; 8];
        assert_eq!(app.ext_diag(&mut diag), 2);
        assert_eq!(diag[..2], [2, EXT_DIAG_LINK_LOST_TEMPORARILY]);
        // A second later the loss is permanent.
        exchange(&mut app, 1010, &ppo3(START, 5000));
        assert!(app.diag_changed());
        app.ext_diag(&mut diag);
        assert_eq!(diag[1], EXT_DIAG_LINK_LOST_PERMANENTLY);
        app.drive_mut().disconnected = false;
        let inputs = exchange(&mut app, 1020, &ppo3(START, 5000));
        assert_eq!(
            inputs[0] & 0xFF00,
            (status::COMMAND_FROM_BUS | status::REFERENCE_FROM_BUS | status::AT_SETPOINT) & 0xFF00
        );
        assert!(app.diag_changed());
        // Seed 004 line 731: still 2 bytes, no flag set, and not reported as a diagnosis.
        assert_eq!(app.ext_diag(&mut diag), 2);
        assert_eq!(diag[..2], [2, 0]);
        assert!(!app.ext_diag_reported());
        // A single bad answer is reported with its own code.
        app.drive_mut().fail_next = Some(DriveError::CrcError);
        assert_eq!(exchange(&mut app, 1030, &ppo3(START, 5000))[0], 0xC023);
    }

    /// Seed 004 lines 1098-1113: with 51.21 = 1 (DP-V1) the extended diagnosis is a status
    /// block, header (5), status type 81h, slot 0, specifier 0, and the communication flags at
    /// byte 10 of Slave_Diag; with 51.21 = 0 the DP-V0 form stays (header 2, flags at byte 7).
    #[test]
    fn seed_004_lines_1098_1113_dpv1_diagnosis_is_a_status_block() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        app.set_dp_mode_dpv1(true);
        let mut diag = [0u8; 16];
        exchange(&mut app, 0, &ppo3(START, 5000));
        assert_eq!(app.ext_diag(&mut diag), 5);
        assert_eq!(diag[..5], [5, 0x81, 0x00, 0x00, 0x00]);
        app.drive_mut().disconnected = true;
        exchange(&mut app, 10, &ppo3(START, 5000));
        assert_eq!(app.ext_diag(&mut diag), 5);
        assert_eq!(
            diag[..5],
            [5, 0x81, 0x00, 0x00, EXT_DIAG_LINK_LOST_TEMPORARILY]
        );
        assert!(app.ext_diag_reported());
        app.set_dp_mode_dpv1(false);
        assert_eq!(app.ext_diag(&mut diag), 2);
        assert_eq!(diag[..2], [2, EXT_DIAG_LINK_LOST_TEMPORARILY]);
        // A buffer without room for the block gets nothing rather than half of it.
        app.set_dp_mode_dpv1(true);
        assert_eq!(app.ext_diag(&mut diag[..4]), 0);
    }

    /// Issue 18, seed 000 line 465 and seed 004 lines 725-745: in the PROFIdrive mode a lost
    /// drive is a fault the PROFIdrive way (TRIPPED in the status word, not C0xxh, which a
    /// table-8 status word reads as "ready to run, no fault"), its cause in 945/947 and the
    /// extended diagnosis. Issue 30 (the PROFIdrive state machine, seed 004 line 972): the
    /// fault is latched; when the link is back TRIPPED holds until a RESET, which moves 945's
    /// entry to the history (945.1 reads 0), then SWITCH-ON INHIBIT until ON goes 0 -> 1.
    #[test]
    fn seed_004_lines_725_745_972_a_lost_drive_in_the_profidrive_mode_is_a_latched_fault() {
        use crate::profile::control as pd;
        let prm = UserPrm {
            operation: OperationMode::Profidrive,
            ..UserPrm::DEFAULT
        };
        let mut app = app_with(prm, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(pd::READY, 0x2000));
        app.drive_mut().disconnected = true;
        let inputs = exchange(&mut app, 10, &ppo3(pd::READY, 0x2000));
        assert_eq!(inputs[0] & 0xFF00, 0, "no C0xxh: {:#06X}", inputs[0]);
        assert_ne!(inputs[0] & crate::profile::status::TRIPPED, 0);
        assert_eq!(inputs[0] & crate::profile::status::RDY_RUN, 0);
        let p = app.params();
        assert_eq!((p.fault_codes[0], p.fault_numbers[0]), (0x7510, 0x22));
        assert_eq!(p.fault_count, 1);
        let mut diag = [0u8; 8];
        assert_eq!(app.ext_diag(&mut diag), 2);
        assert_eq!(diag[1], EXT_DIAG_LINK_LOST_TEMPORARILY);
        // Still lost: no second entry.
        exchange(&mut app, 20, &ppo3(pd::READY, 0x2000));
        assert_eq!(app.params().fault_count, 1);
        // A RESET while the link is still lost changes nothing.
        exchange(&mut app, 25, &ppo3(pd::READY | pd::RESET, 0x2000));
        exchange(&mut app, 26, &ppo3(pd::READY, 0x2000));
        app.drive_mut().disconnected = false;
        use crate::profile::status as pds;
        for t in [30, 40] {
            let inputs = exchange(&mut app, t, &ppo3(pd::OPERATE, 0x2000));
            assert_ne!(inputs[0] & pds::TRIPPED, 0, "latched: {:#06X}", inputs[0]);
            assert_eq!(app.params().fault_codes[0], 0x7510);
            assert_eq!(
                app.drive().control_word & crate::words::control::RUN_ENABLE,
                0,
                "the drive is stopped while in FAULT"
            );
        }
        // RESET (bit 7 rising) with ON 1: FAULT -> SWITCH-ON INHIBIT, held while ON stays 1.
        exchange(&mut app, 50, &ppo3(pd::OPERATE | pd::RESET, 0x2000));
        let inputs = exchange(&mut app, 60, &ppo3(pd::OPERATE, 0x2000));
        assert_eq!(inputs[0] & pds::TRIPPED, 0);
        assert_ne!(inputs[0] & pds::SWC_ON_INHIB, 0, "{:#06X}", inputs[0]);
        let p = app.params();
        assert_eq!(
            (
                p.fault_codes[0],
                p.fault_codes[8],
                p.fault_numbers[8],
                p.fault_count
            ),
            (0, 0x7510, 0x22, 1),
            "945.1 reads 0, the lost link in the history"
        );
        // ON 0 -> 1: READY TO SWITCH ON, then READY TO OPERATE and OPERATION ENABLED.
        exchange(&mut app, 70, &ppo3(pd::READY, 0x2000));
        exchange(&mut app, 80, &ppo3(pd::OPERATE, 0x2000));
        let inputs = exchange(&mut app, 90, &ppo3(pd::OPERATE, 0x2000));
        assert_ne!(inputs[0] & pds::RDY_REF, 0, "{:#06X}", inputs[0]);
    }

    /// Seed 004 line 972 in the vendor mode: the lost link's 945 entry (7510h) stays at
    /// sub-index 1 after the link is back until the master's fault reset (the control word's
    /// bit 15 rising, not while still lost), then reads 0 with the entry in the history.
    #[test]
    fn seed_004_line_972_a_lost_links_945_entry_goes_to_the_history_on_reset() {
        use crate::words::control::FAULT_RESET;
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(START, 5000));
        app.drive_mut().disconnected = true;
        exchange(&mut app, 10, &ppo3(START, 5000));
        exchange(&mut app, 20, &ppo3(START | FAULT_RESET, 5000));
        assert_eq!(
            app.params().fault_codes[0],
            0x7510,
            "a reset while lost keeps it"
        );
        app.drive_mut().disconnected = false;
        exchange(&mut app, 30, &ppo3(START | FAULT_RESET, 5000));
        exchange(&mut app, 40, &ppo3(START, 5000));
        assert_eq!(
            app.params().fault_codes[0],
            0x7510,
            "held, no rising reset yet"
        );
        exchange(&mut app, 50, &ppo3(START | FAULT_RESET, 5000));
        let p = app.params();
        assert_eq!(
            (
                p.fault_codes[0],
                p.fault_codes[8],
                p.fault_numbers[8],
                p.fault_count
            ),
            (0, 0x7510, 0x22, 1)
        );
    }

    /// Seed 004 tables 7 and 8 (decided, README "Differences from the manuals"): INCHING_1/2
    /// (control bits 8, 9) "see the drive's manual", and seed 000's drive has no inching in its
    /// control word nor a jog speed among its parameters: the bits change nothing the drive
    /// gets. ABOVE_LIMIT (status bit 10) is "actual at or above the supervision limit"; the
    /// drive has no supervision limit either, so the limit is the rated speed (4000h): on at
    /// 50.00 Hz of a 50.00 Hz drive, off just below.
    #[test]
    fn seed_004_tables_7_8_inching_changes_nothing_and_above_limit_is_the_rated_speed() {
        use crate::profile::{control as pd, status as pds};
        let prm = UserPrm {
            operation: OperationMode::Profidrive,
            ..UserPrm::DEFAULT
        };
        let mut app = app_with(prm, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(pd::READY, 0x4000));
        exchange(&mut app, 10, &ppo3(pd::READY | pd::ON, 0x4000));
        exchange(&mut app, 20, &ppo3(pd::OPERATE, 0x4000));
        exchange(&mut app, 30, &ppo3(pd::OPERATE, 0x4000));
        let plain = (app.drive().control_word, app.drive().get(SET_FREQUENCY));
        for (t, inching) in [(40, 1u16 << 8), (50, 1 << 9), (60, 3 << 8)] {
            exchange(&mut app, t, &ppo3(pd::OPERATE | inching, 0x4000));
            assert_eq!(
                (app.drive().control_word, app.drive().get(SET_FREQUENCY)),
                plain,
                "INCHING bits {inching:#06X}"
            );
        }
        // The mock drive runs at its set frequency: the reference sets ACT.
        for (t, reference, hz, above) in [
            (70, 0x4000, 5000, true),
            (80, 0x3FFF, 4999, false),
            (90, 0x2000, 2500, false),
        ] {
            exchange(&mut app, t, &ppo3(pd::OPERATE, reference));
            let inputs = exchange(&mut app, t + 5, &ppo3(pd::OPERATE, reference));
            assert_eq!(app.drive().get(SET_FREQUENCY), hz);
            assert_eq!(inputs[1], (u32::from(hz) * 0x4000 / 5000) as u16, "ACT");
            assert_eq!(
                inputs[0] & pds::ABOVE_LIMIT != 0,
                above,
                "{hz} at 50.00 Hz rated"
            );
        }
    }

    /// Issue 30, the vendor mode over DP-V1: 967 and 968 read the control word in force and
    /// the status word the master gets (the vendor's), and 928 = 0 stops new process data as
    /// in the PROFIdrive mode (seed 004's 928: "the PZD part is invalid").
    #[test]
    fn vendor_mode_967_968_show_the_words_and_928_0_stops_new_pzd() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        let inputs = exchange(&mut app, 0, &ppo3(START, 2500));
        exchange(&mut app, 10, &ppo3(START, 2500));
        let inputs2 = exchange(&mut app, 20, &ppo3(START, 2500));
        assert_eq!(app.params().control_word, START);
        assert_eq!(app.params().status_word, inputs2[0]);
        assert_ne!(inputs2[0], 0, "{inputs:04X?}");
        app.params_mut().pzd_rights = 0;
        exchange(&mut app, 30, &ppo3(START, 4000));
        exchange(&mut app, 40, &ppo3(START, 4000));
        assert_eq!(
            app.drive().get(SET_FREQUENCY),
            2500,
            "928 = 0: 4000 not taken"
        );
        app.params_mut().pzd_rights = 1;
        exchange(&mut app, 50, &ppo3(START, 4000));
        exchange(&mut app, 60, &ppo3(START, 4000));
        assert_eq!(app.drive().get(SET_FREQUENCY), 4000);
    }

    /// Seed 004 line 731: the extended diagnosis is always 2 bytes ("fixed to 2"); with no
    /// flag set, Station_Status_1 does not report it (Ext_Diag clear).
    #[test]
    fn seed_004_line_731_the_extended_diagnosis_is_always_two_bytes() {
        let app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        let mut slave = dp_slave::Slave::new(
            dp_slave::Config {
                address: 8,
                ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
                no_add_chg: false,
                dpv1_status_bytes: false,
            },
            app,
        );
        let (diag, _) = slave.diag_now();
        assert_eq!(diag.len(), 8);
        assert_eq!(diag[6..8], [2, 0]);
        assert_eq!(diag[0] & dp_consts::diag::ST1_EXT_DIAG, 0);
        slave.app_mut().drive_mut().disconnected = true;
        slave.app_mut().service_pzd(Instant::from_millis(1));
        slave.app_mut().service_pkw(Instant::from_millis(1));
        let (diag, _) = slave.diag_now();
        assert_eq!((diag.len(), diag[7]), (8, EXT_DIAG_LINK_LOST_TEMPORARILY));
        assert_ne!(diag[0] & dp_consts::diag::ST1_EXT_DIAG, 0);
    }

    /// Seed 004 line 972: 945 sub-index 1 of 0 means no fault. After the fault is reset it
    /// reads 0 and the fault is in the history (sub-index 9); table 22 (lines 1526-1533): the
    /// drive's warnings in 953 (current) and 954-957, 958-960 not supported.
    #[test]
    fn seed_004_line_972_and_table_22_fault_reset_and_warnings() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(START, 5000));
        app.drive_mut().fault = Some(12);
        exchange(&mut app, 10, &ppo3(START, 5000));
        exchange(&mut app, 20, &ppo3(START, 5000));
        assert_eq!(
            (app.params().fault_codes[0], app.params().fault_numbers[0]),
            (crate::faults::DRIVECOM_GENERIC, 12)
        );
        // The master resets the fault (the control word's reset bit rising).
        exchange(
            &mut app,
            30,
            &ppo3(START | crate::words::control::FAULT_RESET, 5000),
        );
        exchange(&mut app, 40, &ppo3(START, 5000));
        exchange(&mut app, 50, &ppo3(START, 5000));
        let p = app.params();
        assert_eq!(
            (p.fault_codes[0], p.fault_codes[8], p.fault_numbers[8]),
            (0, crate::faults::DRIVECOM_GENERIC, 12),
            "945.1 is 0, 945.9 the fault"
        );
        assert_eq!(p.fault_count, 1);
        // A warning AL.036, then it goes.
        app.drive_mut().warning = Some(36);
        exchange(&mut app, 60, &ppo3(START, 5000));
        exchange(&mut app, 70, &ppo3(START, 5000));
        assert_eq!(app.params().alarms[0], 36);
        app.drive_mut().warning = None;
        exchange(&mut app, 80, &ppo3(START, 5000));
        exchange(&mut app, 90, &ppo3(START, 5000));
        assert_eq!(app.params().alarms[..2], [0, 36]);
        // Seed 004 table 22: another comes; 953 it, 954 the one before, no 0 between. Then a
        // third while the second is still on: both move on.
        app.drive_mut().warning = Some(37);
        exchange(&mut app, 100, &ppo3(START, 5000));
        exchange(&mut app, 110, &ppo3(START, 5000));
        assert_eq!(app.params().alarms[..3], [37, 36, 0]);
        app.drive_mut().warning = None;
        exchange(&mut app, 120, &ppo3(START, 5000));
        exchange(&mut app, 130, &ppo3(START, 5000));
        app.drive_mut().warning = Some(38);
        exchange(&mut app, 140, &ppo3(START, 5000));
        exchange(&mut app, 150, &ppo3(START, 5000));
        assert_eq!(app.params().alarms[..4], [38, 37, 36, 0]);
        // 958-960: not supported.
        let mut p = app.params().clone();
        let read = |p: &mut Parameters, pnu| {
            let frame = Frame {
                label: 1,
                pnu,
                index: 0,
                value: 0,
            };
            match p.plan(&frame, 3) {
                crate::pkw::Planned::Reply(r) => (r.label, r.value),
                crate::pkw::Planned::Drive(_) => (0xFF, 0),
            }
        };
        assert_eq!(read(&mut p, 957), (1, 0));
        assert_eq!(read(&mut p, 958), (7, 0), "error 0: no such parameter here");
    }

    #[test]
    fn pkw_through_ppo1() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo1);
        app.drive_mut().set(0xF029, 0x25);
        let mut out = [0u8; 12];
        out[..8].copy_from_slice(&[0x10, 0xF0, 0x29, 0, 0, 0, 0, 0]);
        out[8..10].copy_from_slice(&START.to_be_bytes());
        out[10..12].copy_from_slice(&0x25u16.to_be_bytes());
        let inputs = exchange(&mut app, 1, &out);
        let bytes: Vec<u8> = inputs.iter().flat_map(|w| w.to_be_bytes()).collect();
        assert_eq!(bytes[..8], [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0x25]);
        // The fault record reads through PKW: a fault Fu.012 shows as 0x8C in DE.00.
        app.drive_mut().fault = Some(12);
        out[..8].copy_from_slice(&[0x10, 0xDE, 0x00, 0, 0, 0, 0, 0]);
        let inputs = exchange(&mut app, 2, &out);
        assert_eq!(inputs[3], 0x008C);
        assert_eq!(inputs[4] & status::FAULT, status::FAULT);
        // Fault reset on 0 -> 1 of bit 15.
        out[8..10].copy_from_slice(&(START | control::FAULT_RESET).to_be_bytes());
        let inputs = exchange(&mut app, 3, &out);
        assert_eq!(inputs[4] & status::FAULT, 0);
        assert_eq!(app.drive().fault_resets, 1);
    }

    #[test]
    fn profidrive_mode_runs_the_drive_through_the_state_machine() {
        use crate::profile::{control as pd, status as pds};
        let mut prm = UserPrm::DEFAULT;
        prm.operation = OperationMode::Profidrive;
        let mut app = app_with(prm, Ppo::Ppo3);
        let (off, run) = (pd::READY, pd::OPERATE);
        exchange(&mut app, 1, &ppo3(off, 0));
        exchange(&mut app, 2, &ppo3(off | pd::ON, 0));
        // Three quarters of the rated speed in reverse: 37.50 Hz, reverse, running.
        let reference = (-0x3000i16) as u16;
        exchange(&mut app, 3, &ppo3(run, reference));
        let inputs = exchange(&mut app, 4, &ppo3(run, reference));
        assert!(app.drive().running());
        assert_eq!(app.drive().get(SET_FREQUENCY), 3750);
        assert_eq!(
            app.drive().control_word & control::REVERSE,
            control::REVERSE
        );
        assert_eq!(inputs[0] & 0x7, pds::RDY_ON | pds::RDY_RUN | pds::RDY_REF);
        assert_eq!(inputs[1] as i16, -0x3000);
        // The PLC stops: fail-safe STOP is OFF1 here, and the drive stops.
        Application::fail_safe(&mut app, Instant::from_millis(5), FailSafeReason::ClearData);
        app.service(Instant::from_millis(5));
        assert!(!app.drive().running());
    }

    /// Seed 004 line 1522: 945 is coded per DRIVECOM; seed 000 gives the drive's faults only
    /// as Fu numbers, so 945 is 1000h (generic) and 947 the number; a lost link is 7510h.
    #[test]
    fn seed_004_line_1522_945_is_drivecom_coded_and_947_the_fu_number() {
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        exchange(&mut app, 0, &ppo3(START, 5000));
        app.drive_mut().fault = Some(12);
        exchange(&mut app, 10, &ppo3(START, 5000));
        exchange(&mut app, 20, &ppo3(START, 5000));
        let p = app.params();
        assert_eq!((p.fault_codes[0], p.fault_numbers[0]), (0x1000, 12));
        app.drive_mut().fault = None;
        app.drive_mut().disconnected = true;
        exchange(&mut app, 30, &ppo3(START, 5000));
        let p = app.params();
        assert_eq!(p.fault_codes[0], crate::faults::DRIVECOM_SERIAL_INTERFACE);
        assert_eq!((p.fault_codes[8], p.fault_numbers[8]), (0x1000, 12));
    }

    #[test]
    fn seed_004_lines_1478_1479_the_host_led_follows_the_drive_link() {
        use crate::link_diag::{DriveLink, LINK_LOST_PERMANENTLY_US};
        let mut app = app_with(UserPrm::DEFAULT, Ppo::Ppo3);
        assert_eq!(app.drive_link(), DriveLink::NotYet);
        exchange(&mut app, 1, &ppo3(START, 5000));
        assert_eq!(app.drive_link(), DriveLink::Up);
        app.drive_mut().disconnected = true;
        exchange(&mut app, 2, &ppo3(START, 5000));
        assert_eq!(app.drive_link(), DriveLink::LostTemporarily);
        let later = 2 + LINK_LOST_PERMANENTLY_US / 1000;
        exchange(&mut app, later, &ppo3(START, 5000));
        assert_eq!(app.drive_link(), DriveLink::LostPermanently);
        app.drive_mut().disconnected = false;
        exchange(&mut app, later + 1, &ppo3(START, 5000));
        assert_eq!(app.drive_link(), DriveLink::Up);
    }

    /// A PROFIdrive or ABB Drives app on a 60.00 Hz drive (F0.10 = 6000), running forward at
    /// `reference`; returns the set frequency the drive got and the actual value read back.
    fn run_60_hz_drive(mode: OperationMode, rated_prm: u16, reference: u16) -> (u16, u16) {
        use crate::profile::control as pd;
        let mut prm = UserPrm::DEFAULT;
        prm.operation = mode;
        prm.rated_frequency = rated_prm;
        let mut drive = MockDrive::default();
        drive.set(crate::codes::named::MAX_FREQUENCY, 6000);
        let mut app = ProfidriveApp::new(drive);
        assert!(app.accept_user_prm(&prm.encode()));
        assert!(app.accept_cfg(Ppo::Ppo3.cfg()).is_some());
        exchange(&mut app, 1, &ppo3(pd::READY, 0));
        exchange(&mut app, 2, &ppo3(pd::READY | pd::ON, 0));
        exchange(&mut app, 3, &ppo3(pd::OPERATE, reference));
        let inputs = exchange(&mut app, 4, &ppo3(pd::OPERATE, reference));
        assert!(app.drive().running());
        (app.drive().get(SET_FREQUENCY), inputs[1])
    }

    #[test]
    fn seed_004_line_334_4000h_is_the_rated_frequency_read_from_a_60_hz_drive() {
        // The user parameter left at 0: the drive's F0.10 (60.00 Hz) is the rated frequency.
        assert_eq!(
            run_60_hz_drive(OperationMode::Profidrive, 0, 0x4000),
            (6000, 0x4000)
        );
        assert_eq!(
            run_60_hz_drive(OperationMode::Profidrive, 0, 0x2000),
            (3000, 0x2000)
        );
        // Given by the master: 50.00 Hz on the same drive.
        assert_eq!(
            run_60_hz_drive(OperationMode::Profidrive, 5000, 0x4000),
            (5000, 0x4000)
        );
    }

    #[test]
    fn seed_004_line_370_20000_is_the_rated_frequency_in_the_abb_drives_mode() {
        assert_eq!(
            run_60_hz_drive(OperationMode::AbbDrives, 0, 20_000),
            (6000, 20_000)
        );
        assert_eq!(
            run_60_hz_drive(OperationMode::AbbDrives, 0, 10_000),
            (3000, 10_000)
        );
        assert_eq!(
            run_60_hz_drive(OperationMode::AbbDrives, 5000, 20_000),
            (5000, 20_000)
        );
    }

    /// Until the drive has said its maximum frequency, no reference reaches it: never a
    /// silent 50 Hz.
    #[test]
    fn an_unread_rated_frequency_sends_no_reference() {
        use crate::profile::control as pd;
        let mut prm = UserPrm::DEFAULT;
        prm.operation = OperationMode::Profidrive;
        let mut app = app_with(prm, Ppo::Ppo3);
        // The drive does not answer the read of F0.10 (nor anything else).
        app.drive_mut().disconnected = true;
        for t in 1..4 {
            exchange(&mut app, t, &ppo3(pd::OPERATE, 0x4000));
        }
        assert_eq!(app.rated_reference(), 0);
        app.drive_mut().disconnected = false;
        exchange(&mut app, 10, &ppo3(pd::READY, 0x4000));
        assert_eq!(app.rated_reference(), 5000);
    }

    /// Outputs of PPO2 (PKW + 6 PZD) as words.
    fn ppo2(pkw: [u16; 4], pzd: [u16; 6]) -> Vec<u8> {
        pkw.iter()
            .chain(&pzd)
            .flat_map(|w| w.to_be_bytes())
            .collect()
    }

    #[test]
    fn profidrive_pkw_pzd_mapping_and_fault_buffer_through_ppo2() {
        use crate::pd_params::{RequestLabel, ResponseLabel};
        use crate::profile::control as pd;
        let mut prm = UserPrm::DEFAULT;
        prm.operation = OperationMode::Profidrive;
        let mut app = app_with(prm, Ppo::Ppo2);
        app.drive_mut().set(0xD104, 321);
        let pke = |label: u16, pnu: u16| label << 12 | pnu;
        // 915.3 = 1202 (PZD3 out writes 12.02, here FB.02); 916.3 = 2204 (PZD3 in reads D1.04).
        let run = pd::READY;
        let inputs = exchange(
            &mut app,
            1,
            &ppo2([pke(7, 915), 0x0300, 0, 1202], [run, 0, 0, 0, 0, 0]),
        );
        assert_eq!(
            ResponseLabel::from((inputs[0] >> 12) as u8),
            ResponseLabel::ArrayWord
        );
        let inputs = exchange(
            &mut app,
            2,
            &ppo2([pke(7, 916), 0x0300, 0, 2204], [run, 0, 777, 0, 0, 0]),
        );
        assert_eq!(
            ResponseLabel::from((inputs[0] >> 12) as u8),
            ResponseLabel::ArrayWord
        );
        let inputs = exchange(&mut app, 3, &ppo2([0; 4], [run, 0, 777, 0, 0, 0]));
        assert_eq!(app.drive().get(0xFB02), 777);
        assert_eq!(inputs[6], 321);
        // 929 tells the PPO type.
        let inputs = exchange(
            &mut app,
            4,
            &ppo2(
                [pke(u16::from(u8::from(RequestLabel::Read)), 929), 0, 0, 0],
                [run, 0, 777, 0, 0, 0],
            ),
        );
        assert_eq!(inputs[3], 2);
        // A drive fault lands in 945.1 and 952; the status word shows TRIPPED.
        app.drive_mut().fault = Some(12);
        let inputs = exchange(
            &mut app,
            5,
            &ppo2([pke(6, 945), 0x0100, 0, 0], [run, 0, 777, 0, 0, 0]),
        );
        assert_eq!(
            inputs[4] & crate::profile::status::TRIPPED,
            crate::profile::status::TRIPPED
        );
        let inputs = exchange(
            &mut app,
            6,
            &ppo2([pke(6, 945), 0x0100, 0, 0], [run, 0, 777, 0, 0, 0]),
        );
        // Seed 004 line 1522: 945 is DRIVECOM-coded (1000h, generic: seed 000 gives no
        // meaning to map), 947 has the drive's number (Fu.012).
        assert_eq!(inputs[3], crate::faults::DRIVECOM_GENERIC);
        assert_eq!(app.params().fault_numbers[0], 12);
        assert_eq!(app.params().fault_count, 1);
        // 948.1: seconds since that fault.
        app.service(Instant::from_millis(3005));
        assert_eq!(app.params().fault_times[0], 3);
        // 928 = 0: new PZD no longer taken.
        exchange(
            &mut app,
            7,
            &ppo2([pke(2, 928), 0, 0, 0], [run, 0, 777, 0, 0, 0]),
        );
        exchange(
            &mut app,
            8,
            &ppo2([pke(2, 928), 0, 0, 0], [run, 0, 999, 0, 0, 0]),
        );
        assert_eq!(app.drive().get(0xFB02), 777);
    }

    #[test]
    fn refused_configurations_and_parameters() {
        let mut app = ProfidriveApp::new(MockDrive::default());
        assert_eq!(app.accept_cfg(&[0xF3, 0xF3]), None);
        assert!(!app.accept_user_prm(&[0; 10]));
        let mut bad = UserPrm::DEFAULT.encode();
        bad[1] = 0x03;
        assert!(!app.accept_user_prm(&bad));
    }
}
