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

use crate::drive::{Drive, DriveError, PZD1_LINK_ERROR};
use crate::pkw::{PkwServer, PKW_BYTES};
use crate::ppo::{Ppo, MAX_PZD_WORDS};
use crate::prm::{ControlZeroMode, FailSafeMode, OperationMode, UserPrm};
use crate::words::control;
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

/// How long the drive may stay silent before the loss counts as permanent (seed 004's
/// extended diagnosis: "communication temporarily / permanently lost").
pub const LINK_LOST_PERMANENTLY_US: u64 = 1_000_000;

/// Seed 004's extended diagnosis: one header byte (its length, 2) and one byte of flags.
pub const EXT_DIAG_LEN: u8 = 2;
pub const EXT_DIAG_LINK_LOST_TEMPORARILY: u8 = 0x01;
pub const EXT_DIAG_LINK_LOST_PERMANENTLY: u8 = 0x02;

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
    link_lost_since: Option<Instant>,
    ext_diag_flags: u8,
    diag_changed: bool,
}

impl<D: Drive> ProfidriveApp<D> {
    pub fn new(drive: D) -> ProfidriveApp<D> {
        ProfidriveApp {
            drive,
            prm: UserPrm::DEFAULT,
            ppo: None,
            pzd_out: [0; MAX_PZD_WORDS],
            pzd_applied: [0; MAX_PZD_WORDS],
            pzd_in: [0; MAX_PZD_WORDS],
            pkw: PkwServer::default(),
            fail_safe: Some(FailSafeCause::LeftDataExchange),
            last_outputs_at: None,
            link_error: None,
            link_lost_since: None,
            ext_diag_flags: 0,
            diag_changed: false,
        }
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

    pub fn fail_safe(&self) -> Option<FailSafeCause> {
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
                    OperationMode::Profidrive => pzd[0] & !0x0001,
                };
                pzd
            }
        }
    }

    /// The drive's I/O for the current process images, the PKW request and the cut-off.
    pub fn service(&mut self, now: Instant) {
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
        let result = self.exchange_with_drive(&apply, words);
        self.pzd_applied = apply;
        if self.ppo.is_some_and(Ppo::has_pkw) {
            self.pkw.service(&mut self.drive);
        }
        self.note_link(now, result.err());
    }

    fn exchange_with_drive(&mut self, apply: &[u16; MAX_PZD_WORDS], words: usize) -> Result<(), DriveError> {
        let mut first_error = None;
        let mut note = |r: Result<(), DriveError>| {
            if let Err(e) = r {
                first_error.get_or_insert(e);
            }
        };
        note(self.drive.write_control(apply[0]));
        for i in 1..words {
            note(self.drive.write(self.prm.wr_pzd[i - 1], apply[i], false));
        }
        match self.drive.read_status() {
            Ok(sw) => self.pzd_in[0] = sw,
            Err(e) => note(Err(e)),
        }
        for i in 1..words {
            match self.drive.read(self.prm.rd_pzd[i - 1]) {
                Ok(v) => self.pzd_in[i] = v,
                Err(e) => note(Err(e)),
            }
        }
        match first_error {
            Some(e) => {
                self.pzd_in[0] = PZD1_LINK_ERROR | u16::from(e.code());
                Err(e)
            }
            None => Ok(()),
        }
    }

    fn note_link(&mut self, now: Instant, error: Option<DriveError>) {
        self.link_error = error;
        match error {
            Some(_) => {
                self.link_lost_since.get_or_insert(now);
            }
            None => self.link_lost_since = None,
        }
        let flags = match self.link_lost_since {
            None => 0,
            Some(since) if now.micros() - since.micros() >= LINK_LOST_PERMANENTLY_US => {
                EXT_DIAG_LINK_LOST_PERMANENTLY
            }
            Some(_) => EXT_DIAG_LINK_LOST_TEMPORARILY,
        };
        if flags != self.ext_diag_flags {
            self.ext_diag_flags = flags;
            self.diag_changed = true;
        }
    }
}

impl<D: Drive> Application for ProfidriveApp<D> {
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
        match UserPrm::parse(user_prm) {
            Ok(prm) => {
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

    fn outputs(&mut self, now: Instant, outputs: &[u8]) {
        let Some(ppo) = self.ppo else { return };
        if outputs.iter().all(|b| *b == 0) && self.prm.control_zero == ControlZeroMode::IgnoreFrame {
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
        for (word, bytes) in self.pzd_out.iter_mut().zip(pzd.chunks_exact(2)) {
            *word = u16::from_be_bytes([bytes[0], bytes[1]]);
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
        if self.ext_diag_flags == 0 || buffer.len() < 2 {
            return 0;
        }
        buffer[0] = EXT_DIAG_LEN;
        buffer[1] = self.ext_diag_flags;
        2
    }

    fn diag_changed(&mut self) -> bool {
        core::mem::take(&mut self.diag_changed)
    }

    fn store_address(&mut self, _address: u8, _no_add_chg: bool) {
        // The adapter persists the address; the drive application has nothing to keep.
    }
}
