//! A DP-V1 class-1 requester (MSAC1) on profirust's FDL station, for the tests.
//!
//! No open-source master speaks DP-V1 (profirust 0.6 and pyprofibus are DP-V0 only), so this
//! adds only the MSAC1 telegrams: it is an `FdlApplication` next to profirust's `DpMaster`
//! (`FdlActiveStation::poll_multi`), so the token, the bus timing, the slot time and the
//! retries stay profirust's. Per token visit it sends at most one telegram to SAP 51:
//!
//! ```text
//! request  SRD DSAP 51 SSAP 51  5F/5E slot index length [data]   -> SC
//! poll     SRD DSAP 51 SSAP 51  (no data)                         -> SC, or the response
//! ```
//! A PROFIdrive parameter exchange is a write of the request to index 47, polled until its
//! acknowledgement, then reads, each polled until its response, repeated while the answer is
//! B5h (state conflict: the slave is still busy), as seed 004 describes.
//!
//! FCB: profirust keeps the peripheral's frame count private, so this requester counts its
//! own for SAP 51 (first FCV=0 FCB=1, then alternating; a retry after a lost answer keeps
//! it). The slave takes a request as a repetition only for the same service (`dp_slave`'s
//! frame count), so Data_Exchange and MSAC1 never mistake one for the other's retry.

use dp_consts::dpv1::{self, Function};
use dp_slave::msac1::{Address, Request, Response, MAX_PDU_LEN};
use profirust::fdl::{
    DataTelegramHeader, FdlActiveStation, FdlApplication, FrameCountBit, FunctionCode, Telegram,
    TelegramTx, TelegramTxResponse,
};
use std::collections::VecDeque;

/// The slot and index of the PROFIdrive parameter channel (ABB's FPBA-01 shows slot 1).
pub const PARAMETER_CHANNEL: Address = Address {
    slot: 1,
    index: profidrive::pd_access::PARAMETER_REQUEST_INDEX,
};

/// One job for the requester.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Job {
    /// A PROFIdrive parameter request: written to index 47, then read back until the slave
    /// has the response.
    Parameter(Vec<u8>),
    /// One MSAC1 request as it is (for the negative responses).
    Raw(Vec<u8>),
}

/// A finished job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Done {
    pub job: Job,
    /// The last MSAC1 response (for a parameter job, the read that carried the answer, or
    /// the negative response that ended it).
    pub response: Vec<u8>,
    /// From the first request sent to the response received, in microseconds.
    pub roundtrip_us: u64,
    /// Reads answered B5h before the answer.
    pub busy_reads: u32,
    /// SAP 51 was not served (RS): DP-V1 is off.
    pub refused: bool,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Phase {
    /// `pdu` goes out next; `then` says what its response means.
    Request { pdu: Vec<u8>, write: bool },
    /// Polling for the response to the last request.
    Poll { write: bool },
}

struct Current {
    job: Job,
    phase: Phase,
    started_us: u64,
    busy_reads: u32,
}

pub struct Msac1Requester {
    slave: u8,
    fcb: FrameCountBit,
    /// The telegram waiting for its answer was sent with this FCB (a retry keeps it).
    awaiting: bool,
    retries: u8,
    queue: VecDeque<Job>,
    current: Option<Current>,
    pub done: Vec<Done>,
    /// Polls answered SC (the response was not there yet).
    pub empty_polls: u64,
    pub telegrams: u64,
}

impl Msac1Requester {
    pub fn new(slave: u8) -> Msac1Requester {
        Msac1Requester {
            slave,
            fcb: FrameCountBit::First,
            awaiting: false,
            retries: 0,
            queue: VecDeque::new(),
            current: None,
            done: Vec::new(),
            empty_polls: 0,
            telegrams: 0,
        }
    }

    pub fn push(&mut self, job: Job) {
        self.queue.push_back(job);
    }

    /// Nothing queued or under way.
    pub fn idle(&self) -> bool {
        self.queue.is_empty() && self.current.is_none()
    }

    fn start(&mut self, now_us: u64) {
        if self.current.is_some() {
            return;
        }
        let Some(job) = self.queue.pop_front() else {
            return;
        };
        let pdu = match &job {
            Job::Parameter(request) => {
                let mut out = [0u8; MAX_PDU_LEN];
                let write = Request::Write {
                    at: PARAMETER_CHANNEL,
                    data: request,
                };
                let n = write.emit(&mut out);
                out[..n].to_vec()
            }
            Job::Raw(pdu) => pdu.clone(),
        };
        let write = pdu.first() == Some(&u8::from(Function::Write));
        self.current = Some(Current {
            job,
            phase: Phase::Request { pdu, write },
            started_us: now_us,
            busy_reads: 0,
        });
    }

    fn finish(&mut self, now_us: u64, response: Vec<u8>, refused: bool) {
        if let Some(c) = self.current.take() {
            self.done.push(Done {
                job: c.job,
                response,
                roundtrip_us: now_us.saturating_sub(c.started_us),
                busy_reads: c.busy_reads,
                refused,
            });
        }
    }

    /// The answer to the telegram sent last: SC (`None`) or a response PDU.
    fn answered(&mut self, now_us: u64, pdu: Option<&[u8]>, refused: bool) {
        self.awaiting = false;
        self.retries = 0;
        self.fcb.cycle();
        let Some(current) = self.current.as_mut() else {
            return;
        };
        if refused {
            self.finish(now_us, Vec::new(), true);
            return;
        }
        match (&current.phase, pdu) {
            (Phase::Request { write, .. }, _) => {
                // Acknowledged (SC): poll for the response.
                current.phase = Phase::Poll { write: *write };
            }
            (Phase::Poll { .. }, None) => self.empty_polls += 1,
            (Phase::Poll { write }, Some(pdu)) => {
                let parameter = matches!(current.job, Job::Parameter(_));
                match Response::parse(pdu) {
                    // The parameter request was taken: read the response.
                    Some(Response::Write { .. }) if parameter && *write => {
                        current.phase = read_request();
                    }
                    Some(Response::Error {
                        write: false,
                        code1: dpv1::error::STATE_CONFLICT,
                        ..
                    }) if parameter => {
                        current.busy_reads += 1;
                        current.phase = read_request();
                    }
                    _ => self.finish(now_us, pdu.to_vec(), false),
                }
            }
        }
    }
}

fn read_request() -> Phase {
    let mut out = [0u8; MAX_PDU_LEN];
    let n = Request::Read {
        at: PARAMETER_CHANNEL,
        length: dpv1::MAX_DATA_LEN as u8,
    }
    .emit(&mut out);
    Phase::Request {
        pdu: out[..n].to_vec(),
        write: false,
    }
}

impl FdlApplication for Msac1Requester {
    fn transmit_telegram(
        &mut self,
        now: profirust::time::Instant,
        fdl: &FdlActiveStation,
        tx: TelegramTx,
        high_prio_only: bool,
    ) -> Option<TelegramTxResponse> {
        let now_us = now.total_micros() as u64;
        if high_prio_only {
            return None;
        }
        if self.awaiting {
            // No answer came within the slot time: the same telegram again, same FCB.
            if self.retries >= fdl.parameters().max_retry_limit {
                self.awaiting = false;
                self.retries = 0;
                self.fcb = FrameCountBit::First;
                self.finish(now_us, Vec::new(), false);
                return None;
            }
            self.retries += 1;
        } else {
            self.start(now_us);
        }
        let pdu = match &self.current.as_ref()?.phase {
            Phase::Request { pdu, .. } => pdu.clone(),
            Phase::Poll { .. } => Vec::new(),
        };
        self.awaiting = true;
        self.telegrams += 1;
        let sap = Some(dpv1::SAP);
        Some(tx.send_data_telegram(
            DataTelegramHeader {
                da: self.slave,
                sa: fdl.parameters().address,
                dsap: sap,
                ssap: sap,
                fc: FunctionCode::new_srd_low(self.fcb),
            },
            pdu.len(),
            |buf| buf.copy_from_slice(&pdu),
        ))
    }

    fn receive_reply(
        &mut self,
        now: profirust::time::Instant,
        _fdl: &FdlActiveStation,
        addr: u8,
        telegram: Telegram,
    ) {
        if addr != self.slave || !self.awaiting {
            return;
        }
        let now_us = now.total_micros() as u64;
        match telegram {
            Telegram::ShortConfirmation(_) => self.answered(now_us, None, false),
            Telegram::Data(t) => {
                let refused = t.pdu.is_empty();
                self.answered(now_us, (!refused).then_some(t.pdu), refused)
            }
            Telegram::Token(_) => {}
        }
    }

    fn handle_timeout(
        &mut self,
        _now: profirust::time::Instant,
        _fdl: &FdlActiveStation,
        _addr: u8,
    ) {
        // `transmit_telegram` sends the retry (still `awaiting`).
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_job_writes_index_47_then_reads_until_the_answer() {
        let mut r = Msac1Requester::new(8);
        r.push(Job::Parameter(vec![1, 1, 1, 1, 0x10, 0, 0x03, 0xC4, 0, 0]));
        r.start(0);
        let Some(Current {
            phase: Phase::Request { pdu, write: true },
            ..
        }) = &r.current
        else {
            panic!("a write first");
        };
        assert_eq!(pdu[..4], [0x5F, 1, 47, 10]);
        r.awaiting = true;
        r.answered(10, None, false); // SC
        r.answered(20, None, false); // poll: not yet
        r.answered(30, Some(&[0x5F, 1, 47, 10]), false); // the write's acknowledgement
        assert!(
            matches!(&r.current.as_ref().unwrap().phase, Phase::Request { pdu, write: false } if pdu[..4] == [0x5E, 1, 47, 240])
        );
        r.answered(40, None, false);
        r.answered(50, Some(&[0xDE, 0x80, 0xB5, 0]), false); // busy: read again
        r.answered(60, None, false);
        r.answered(70, Some(&[0x5E, 1, 47, 4, 1, 1, 1, 1]), false);
        assert_eq!(r.done.len(), 1);
        assert_eq!(r.done[0].busy_reads, 1);
        assert_eq!(r.done[0].roundtrip_us, 70);
        assert_eq!(r.done[0].response, [0x5E, 1, 47, 4, 1, 1, 1, 1]);
        assert_eq!(r.empty_polls, 1);
    }
}
