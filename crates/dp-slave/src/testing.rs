//! A small application for tests, benchmarks and examples: it accepts any configuration that
//! sizes (or only the ones it was given), answers each output byte with its complement, and
//! records what the slave told it.

use crate::app::{Application, FailSafeReason};
use crate::cfg::{io_sizes, IoSizes};
use crate::msac1::{Request, Response};
use crate::Instant;

/// Inputs are the bitwise complement of the last outputs; records fail-safe and storage calls.
#[derive(Clone, Debug, Default)]
pub struct EchoApp {
    /// Configurations accepted; empty means any configuration [`io_sizes`] can size.
    pub accepted_cfgs: &'static [&'static [u8]],
    /// The configuration Get_Cfg reports before Chk_Cfg.
    pub default_cfg: &'static [u8],
    /// User parameters are refused when their first byte equals this.
    pub reject_user_prm_byte: Option<u8>,
    /// The last user parameters accepted.
    pub user_prm: heapless::Vec<u8, 64>,
    /// The last outputs handed over.
    pub outputs: heapless::Vec<u8, 244>,
    /// How many times outputs were handed over.
    pub output_count: u32,
    /// Every fail-safe request, oldest first (the first 16).
    pub fail_safes: heapless::Vec<FailSafeReason, 16>,
    /// Extended diagnosis to report.
    pub ext_diag: heapless::Vec<u8, 32>,
    /// Set to flag new diagnosis once.
    pub diag_changed: bool,
    /// The last address stored by Set_Slave_Add, with No_Add_Chg.
    pub stored_address: Option<(u8, bool)>,
    /// The data of the last MSAC1 write, which a read returns (an MSAC1 echo).
    pub record: heapless::Vec<u8, 240>,
}

impl Application for EchoApp {
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
        if self.reject_user_prm_byte.is_some()
            && user_prm.first() == self.reject_user_prm_byte.as_ref()
        {
            return false;
        }
        self.user_prm.clear();
        self.user_prm.extend_from_slice(user_prm).is_ok()
    }

    fn accept_cfg(&mut self, cfg: &[u8]) -> Option<IoSizes> {
        if !self.accepted_cfgs.is_empty() && !self.accepted_cfgs.contains(&cfg) {
            return None;
        }
        io_sizes(cfg).ok()
    }

    fn default_cfg(&self) -> &[u8] {
        self.default_cfg
    }

    fn outputs(&mut self, _now: Instant, outputs: &[u8]) {
        self.outputs.clear();
        // Cannot fail: outputs are at most 244 bytes (MAX_IO_LEN).
        let _ = self.outputs.extend_from_slice(outputs);
        self.output_count += 1;
    }

    fn inputs(&mut self, _now: Instant, inputs: &mut [u8]) {
        for (i, byte) in inputs.iter_mut().enumerate() {
            *byte = !self.outputs.get(i).copied().unwrap_or(0);
        }
    }

    fn fail_safe(&mut self, _now: Instant, reason: FailSafeReason) {
        self.outputs.clear();
        let _ = self.fail_safes.push(reason);
    }

    fn ext_diag(&mut self, buffer: &mut [u8]) -> usize {
        let len = self.ext_diag.len().min(buffer.len());
        buffer[..len].copy_from_slice(&self.ext_diag[..len]);
        len
    }

    fn diag_changed(&mut self) -> bool {
        core::mem::take(&mut self.diag_changed)
    }

    fn store_address(&mut self, address: u8, no_add_chg: bool) {
        self.stored_address = Some((address, no_add_chg));
    }

    /// An echo record: a write stores its data, a read returns it (B5h, state conflict,
    /// before any write).
    fn msac1(&mut self, _now: Instant, request: &Request, out: &mut [u8]) -> usize {
        let response = match *request {
            Request::Write { at, data } => {
                self.record.clear();
                let _ = self.record.extend_from_slice(data);
                Response::Write {
                    at,
                    length: data.len() as u8,
                }
            }
            Request::Read { .. } if self.record.is_empty() => {
                Response::error(false, dp_consts::dpv1::error::STATE_CONFLICT)
            }
            Request::Read { at, length } => Response::Read {
                at,
                data: &self.record[..self.record.len().min(usize::from(length))],
            },
        };
        response.emit(out)
    }
}
