//! The contract between the DP slave and the application behind it (the drive adapter).
//!
//! The slave owns the protocol: states, FCB, lock, watchdog, diagnosis framing. The
//! application owns the meaning of the data: which configurations it accepts, whether user
//! parameters are valid, what the outputs do, what the inputs say, what fail-safe means, and
//! where the station address is stored. Every callback is short and never blocks: it runs
//! between a request and its response.

use crate::cfg::IoSizes;
use crate::msac1::{Request, Response};
use crate::Instant;

/// Why the application must go to its fail-safe state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FailSafeReason {
    /// The DP watchdog expired: the master stopped talking to us.
    WatchdogExpired,
    /// Global_Control with Clear_Data: the PLC is in STOP (or Clear).
    ClearData,
    /// Data exchange ended: new parameters, a configuration fault or an unlock.
    LeftDataExchange,
}

/// The drive application as the DP slave sees it.
pub trait Application {
    /// Checks the user parameter data of Set_Prm (the bytes after the 7 standard ones).
    /// `false` sets Prm_Fault.
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool;

    /// Checks a Chk_Cfg configuration; `None` sets Cfg_Fault.
    fn accept_cfg(&mut self, cfg: &[u8]) -> Option<IoSizes>;

    /// The configuration Get_Cfg reports before a Chk_Cfg was accepted.
    fn default_cfg(&self) -> &[u8];

    /// New outputs from the master (the first `IoSizes::outputs` bytes of Data_Exchange).
    fn outputs(&mut self, now: Instant, outputs: &[u8]);

    /// Fills the inputs to send to the master.
    fn inputs(&mut self, now: Instant, inputs: &mut [u8]);

    /// Go to the fail-safe state; outputs stop coming until data exchange resumes.
    fn fail_safe(&mut self, now: Instant, reason: FailSafeReason);

    /// Writes the extended diagnosis (after the 6 standard bytes); returns its length. An
    /// empty extended diagnosis clears Ext_Diag.
    fn ext_diag(&mut self, buffer: &mut [u8]) -> usize {
        let _ = buffer;
        0
    }

    /// Whether the extended diagnosis reports something (Station_Status_1's Ext_Diag), for an
    /// application whose extended diagnosis is always there (seed 004: "fixed to 2" bytes,
    /// with no flag set while all is well). By default, whenever there is one.
    fn ext_diag_reported(&self) -> bool {
        true
    }

    /// Whether the diagnosis changed since the master last read it: the slave then answers
    /// Data_Exchange with DH until it is read.
    fn diag_changed(&mut self) -> bool {
        false
    }

    /// Stat_Diag: the application cannot deliver valid inputs yet; the master keeps reading
    /// diagnosis instead of exchanging data.
    fn static_diag(&self) -> bool {
        false
    }

    /// Stores a new station address from Set_Slave_Add (non-volatile).
    fn store_address(&mut self, address: u8, no_add_chg: bool);

    /// A DP-V1 class-1 request (MSAC1 on SAP 51, DPV1_Enable in force): writes the response
    /// PDU into `out` (room for [`crate::msac1::MAX_PDU_LEN`]) and returns its length. It must
    /// not wait: what takes longer is answered later, on a read the master repeats (seed 004:
    /// B5h, state conflict). Without DP-V1 services: "feature not supported".
    fn msac1(&mut self, now: Instant, request: &Request, out: &mut [u8]) -> usize {
        let _ = now;
        let code = dp_consts::dpv1::error::APPLICATION_NOT_SUPPORTED;
        Response::error(request.is_write(), code).emit(out)
    }
}
