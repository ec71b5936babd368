//! The DP responder: the transceiver answers DP-V0 by itself, from buffers the firmware fills,
//! as an SPC3 / VPC3+ does.
//!
//! ```text
//!  delimiter ──good telegram──► decode ──► answer from buffers ──► transmitter (after min TSDR)
//!                                  │
//!                                  └──► hand over (Set_Prm, Chk_Cfg, Global_Control,
//!                                       Set_Slave_Add, new outputs) ──► link to the MCU
//!  link from the MCU ──► Regs / Inputs / Diag / Cfg buffers
//!  watchdog (restarted by the owner's requests) ──expired──► Wait_Prm, event to the MCU
//! ```
//!
//! | service | answered by | from | SPC3 / VPC3+ |
//! |---|---|---|---|
//! | Data_Exchange | responder | Inputs (DL; DH while a new diagnosis is unread; SC with no inputs); outputs to the MCU | D/N/U buffers, DX_OUT interrupt |
//! | Slave_Diag | responder | Diag (+ Master_Lock for another master) | diagnosis buffer |
//! | Get_Cfg | responder | Cfg | Read_Cfg buffer |
//! | Rd_Inp / Rd_Outp | responder | Inputs / the last outputs | Din / Dout buffers |
//! | FDL_Status | responder | its address | in the ASIC |
//! | Set_Prm, Chk_Cfg | responder (SC), then the firmware decides | | New_Prm_Data / New_Cfg_Data, User_*_Okay |
//! | Global_Control | responder (SC, or none for a broadcast), then the firmware | | Global_Control interrupt |
//! | Set_Slave_Add | responder (SC / RS / UE from its registers), then the firmware | | New_SSA_Data |
//! | other SAPs | responder (RS) | | SAP not activated |
//!
//! Contract. The answer to a request is the one the firmware's `dp_slave::Slave` gives to the
//! same request in the same state, bit for bit (the slave logic is the single source of what
//! an answer contains: the buffers are written from it). While a decision the firmware has not
//! yet reflected in its registers is on its way ([`Regs::seen`] is older than the event that
//! carried it), the answers that depend on it (Slave_Diag, Get_Cfg, Data_Exchange, Rd_Inp,
//! Rd_Outp, Set_Slave_Add) are "no resource" (RR), which changes nothing and is not stored as a
//! repetition's answer, so the master's retry gets the new answer; Set_Prm, Chk_Cfg and
//! Global_Control are acknowledged and handed over in order. A request with FCV set from the
//! station answered last, carrying the same FCB, for the same service (DSAP and SSAP), is a
//! repetition: it gets the stored answer and reaches the firmware no more (`dp_slave`'s frame
//! count says why the service counts). Each new Data_Exchange hands its outputs over exactly once.
//!
//! HDL style: the registers are [`ResponderQ`], [`next`] is the pure next-state function for
//! one input event, and [`Responder`] commits it. The decision is ready [`DECISION_CLOCKS`]
//! after the request's last stop bit (the header is decoded while the telegram arrives); the
//! frame is built by the same `fdl` emitter the firmware uses.

use crate::watchdog::Watchdog;
use crate::Tick;
use dp_consts::{diag, BROADCAST_ADDRESS, MAX_DATA_UNIT_LEN, MAX_TELEGRAM_LEN};
use dp_link::{FromAdapter, Regs, SlaveState};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, ResponseStatus, Sap};

/// Sample clocks from a request's last stop bit to the responder's decision.
pub const DECISION_CLOCKS: Tick = 2;

/// A buffer the firmware writes (or the responder fills from a request).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Buffer {
    len: u8,
    bytes: [u8; MAX_DATA_UNIT_LEN],
}

impl Buffer {
    pub const EMPTY: Buffer = Buffer {
        len: 0,
        bytes: [0; MAX_DATA_UNIT_LEN],
    };

    fn from(bytes: &[u8]) -> Buffer {
        let mut b = Buffer::EMPTY;
        let len = bytes.len().min(MAX_DATA_UNIT_LEN);
        b.bytes[..len].copy_from_slice(&bytes[..len]);
        b.len = len as u8;
        b
    }

    pub fn as_slice(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The first `len` bytes, zero-padded past what was written.
    fn padded(&self, len: usize) -> &[u8] {
        &self.bytes[..len.min(MAX_DATA_UNIT_LEN)]
    }
}

/// The response stored for a repetition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Last {
    requester: u8,
    fcb: bool,
    service: (Option<Sap>, Option<Sap>),
    len: u8,
    telegram: [u8; MAX_TELEGRAM_LEN],
}

/// The responder's registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResponderQ {
    pub regs: Regs,
    pub inputs: Buffer,
    pub diag: Buffer,
    pub cfg: Buffer,
    /// The outputs of the last Data_Exchange (Rd_Outp).
    pub outputs: Buffer,
    /// A new diagnosis is unread: Data_Exchange answers DH.
    pub diag_high: bool,
    last: Option<Last>,
    /// The sequence number of the last event handed to the MCU.
    pub sent: u32,
    /// The event the MCU's registers must have seen before the answers that depend on its
    /// decision are given again.
    pub decision: Option<u32>,
    /// The DP watchdog (restarted by the owner's requests).
    pub watchdog: Watchdog,
    /// MSAC1 (SAP 51): the event of the request whose response is awaited, and the response
    /// once the MCU wrote it (the next poll takes it).
    pub msac1_for: Option<u32>,
    pub msac1: Option<Buffer>,
}

/// The registers at power-up: Wait_Prm at address 126 until the firmware writes its own.
pub const RESPONDER_RESET: ResponderQ = ResponderQ {
    regs: Regs {
        seen: 0,
        address: dp_consts::MAX_STATION_ADDRESS,
        state: SlaveState::PowerOn,
        owner: None,
        locked: false,
        no_add_chg: true,
        ident_number: 0,
        watchdog_us: None,
        min_tsdr_bits: dp_consts::MIN_TSDR_BITS,
        inputs_len: 0,
        outputs_len: 0,
        dpv1: false,
    },
    inputs: Buffer::EMPTY,
    diag: Buffer::EMPTY,
    cfg: Buffer::EMPTY,
    outputs: Buffer::EMPTY,
    diag_high: false,
    last: None,
    sent: 0,
    // Nothing is answered but FDL_Status until the firmware's first registers arrive.
    decision: Some(1),
    watchdog: Watchdog::STOPPED,
    msac1_for: None,
    msac1: None,
};

/// One input event.
#[derive(Clone, Copy, Debug)]
pub enum Input<'a> {
    /// A good telegram whose last stop bit ended at `now`.
    Telegram { now: Tick, bytes: &'a [u8] },
    /// A write from the MCU, complete at `now`.
    Write {
        now: Tick,
        write: &'a FromAdapter<'a>,
    },
    /// The clock reached `now` (the watchdog).
    Clock { now: Tick },
}

/// What one event produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output {
    /// The response telegram's length in [`Output::telegram`], 0 for none.
    pub response_len: usize,
    pub telegram: [u8; MAX_TELEGRAM_LEN],
    /// Hand the request to the MCU as event `seq`.
    pub forward: Option<u32>,
    /// The request is a Data_Exchange whose outputs the MCU needs only in their newest
    /// version: a link may replace it with a newer one still waiting to be sent.
    pub outputs_only: bool,
    /// The watchdog expired: tell the MCU as event `seq`.
    pub watchdog_expired: Option<u32>,
}

impl Output {
    const NONE: Output = Output {
        response_len: 0,
        telegram: [0; MAX_TELEGRAM_LEN],
        forward: None,
        outputs_only: false,
        watchdog_expired: None,
    };

    pub fn response(&self) -> Option<&[u8]> {
        (self.response_len > 0).then(|| &self.telegram[..self.response_len])
    }
}

/// Whether event `seen` is at or after event `event` (sequence numbers wrap).
fn has_seen(seen: u32, event: u32) -> bool {
    (seen.wrapping_sub(event) as i32) >= 0
}

/// What the responder answers, before framing. The payload is held by value, as the block's
/// output register would: one lives on the stack per request.
#[allow(clippy::large_enum_variant)]
enum Answer {
    ShortAck,
    Data(ResponseStatus, Buffer),
    /// Status only (RS, UE, RR), no data.
    Status(ResponseStatus),
}

const RR: Answer = Answer::Status(ResponseStatus::NoResources);
const RS: Answer = Answer::Status(ResponseStatus::SapNotActivated);
const UE: Answer = Answer::Status(ResponseStatus::UserError);

/// What a request asks of the MCU.
#[derive(Clone, Copy, PartialEq, Eq)]
enum HandOver {
    No,
    /// New outputs only: the newest is all the MCU needs.
    Outputs,
    /// An event the MCU acts on without changing what the responder answers.
    Event,
    /// A decision: the answers that depend on it wait for it.
    Decision,
    /// An MSAC1 request: the MCU writes its response, which the master's poll collects.
    Acyclic,
}

/// The pure next-state function. `clocks_per_us`: the sample clock, for the watchdog.
pub fn next(input: &Input, q: &ResponderQ, clocks_per_us: Tick) -> (Output, ResponderQ) {
    let mut d = *q;
    let mut out = Output::NONE;
    match *input {
        Input::Clock { now } => {
            if d.watchdog.expire(now) {
                d.sent = d.sent.wrapping_add(1);
                d.decision = Some(d.sent);
                out.watchdog_expired = Some(d.sent);
            }
        }
        Input::Write { now, write } => write_buffer(&mut d, now, write, clocks_per_us),
        Input::Telegram { now, bytes } => telegram(&mut d, &mut out, now, bytes, clocks_per_us),
    }
    (out, d)
}

/// The DP watchdog's clocks for `us` microseconds.
fn watchdog_clocks(us: u32, clocks_per_us: Tick) -> Tick {
    Tick::from(us) * clocks_per_us
}

fn pending(d: &ResponderQ) -> bool {
    d.decision.is_some_and(|k| !has_seen(d.regs.seen, k))
}

fn write_buffer(d: &mut ResponderQ, now: Tick, write: &FromAdapter, clocks_per_us: Tick) {
    match *write {
        FromAdapter::Regs(regs) => {
            if regs.address != d.regs.address {
                d.last = None;
            }
            d.regs = regs;
            if !pending(d) {
                d.decision = None;
                match (regs.owner, regs.watchdog_us) {
                    (Some(_), Some(us)) => d
                        .watchdog
                        .start_if_stopped(now, watchdog_clocks(us, clocks_per_us)),
                    _ => d.watchdog.stop(),
                }
            }
        }
        FromAdapter::Inputs(bytes) => d.inputs = Buffer::from(bytes),
        FromAdapter::Diag { new, bytes } => {
            d.diag = Buffer::from(bytes);
            d.diag_high |= new;
        }
        FromAdapter::Cfg(bytes) => d.cfg = Buffer::from(bytes),
        FromAdapter::Msac1 { request, bytes } if d.msac1_for == Some(request) => {
            d.msac1_for = None;
            d.msac1 = Some(Buffer::from(bytes));
        }
        _ => {}
    }
}

fn telegram(d: &mut ResponderQ, out: &mut Output, now: Tick, bytes: &[u8], clocks_per_us: Tick) {
    let Ok((Repr::Data(request), _)) = Repr::parse_bytes(bytes) else {
        return;
    };
    let FrameControl::Request { fcb, fcv, function } = request.fc else {
        return;
    };
    let broadcast = request.da == BROADCAST_ADDRESS;
    if request.da != d.regs.address && !broadcast {
        return;
    }
    let answers = !broadcast && function.expects_response();
    if function == RequestFunction::FdlStatus {
        if answers {
            let status = FrameControl::slave_response(ResponseStatus::Ok);
            frame(out, &request, status, &[]);
        }
        return;
    }
    if answers && !function.is_srd() {
        return;
    }
    if answers && fcv {
        if let Some(last) = d.last {
            if last.requester == request.sa
                && last.fcb == fcb
                && last.service == (request.dsap, request.ssap)
            {
                out.response_len = usize::from(last.len);
                out.telegram = last.telegram;
                return;
            }
        }
    }
    let service = match (request.dsap, request.ssap) {
        (None, _) => None,
        (Some(dsap), Some(_)) => Some(dsap),
        (Some(_), None) => return,
    };
    if broadcast && service != Some(Sap::GLOBAL_CONTROL) {
        return;
    }
    if d.regs.owner == Some(request.sa) {
        if let Some(us) = d.regs.watchdog_us {
            d.watchdog.start(now, watchdog_clocks(us, clocks_per_us));
        }
    }
    let (answer, hand_over) = decide(d, &request, service);
    if hand_over != HandOver::No {
        d.sent = d.sent.wrapping_add(1);
        out.forward = Some(d.sent);
        out.outputs_only = hand_over == HandOver::Outputs;
        if hand_over == HandOver::Decision {
            d.decision = Some(d.sent);
        }
        if hand_over == HandOver::Acyclic {
            d.msac1_for = Some(d.sent);
        }
    }
    if answers {
        answer_with(d, out, &request, fcb, answer);
    }
}

/// The answer to a service and what it asks of the MCU, from the registers (as `dp_slave`
/// decides it in the same state).
fn decide(d: &mut ResponderQ, request: &DataRepr, service: Option<Sap>) -> (Answer, HandOver) {
    let waiting = pending(d);
    let exchanging = d.regs.state == SlaveState::DataExch;
    let owner = d.regs.owner == Some(request.sa);
    let payload = request.payload;
    let inputs = |d: &ResponderQ| Buffer::from(d.inputs.padded(usize::from(d.regs.inputs_len)));
    match service {
        None if waiting => (RR, HandOver::No),
        None if !exchanging || !owner => (RS, HandOver::No),
        None => {
            let expected = usize::from(d.regs.outputs_len);
            let hand_over = if payload.is_empty() && expected > 0 {
                // Clear_Data by an empty telegram: the firmware goes fail-safe, the answer is
                // the same.
                HandOver::Event
            } else if payload.len() == expected {
                d.outputs = Buffer::from(payload);
                HandOver::Outputs
            } else {
                // Not our configuration: the firmware's slave leaves Data_Exch.
                return (RS, HandOver::Decision);
            };
            let status = if d.diag_high {
                ResponseStatus::DataHigh
            } else {
                ResponseStatus::DataLow
            };
            let answer = match d.regs.inputs_len {
                0 if !d.diag_high => Answer::ShortAck,
                _ => Answer::Data(status, inputs(d)),
            };
            (answer, hand_over)
        }
        Some(Sap::SLAVE_DIAG) if waiting => (RR, HandOver::No),
        Some(Sap::SLAVE_DIAG) => {
            if owner || d.regs.owner.is_none() {
                d.diag_high = false;
            }
            let mut diag = d.diag;
            if d.regs.locked && !owner && diag.len > 0 {
                diag.bytes[0] |= diag::ST1_MASTER_LOCK;
            }
            (Answer::Data(ResponseStatus::DataLow, diag), HandOver::No)
        }
        Some(Sap::SET_PRM) => (Answer::ShortAck, HandOver::Decision),
        Some(Sap::CHK_CFG) => {
            let for_us =
                owner && matches!(d.regs.state, SlaveState::WaitCfg | SlaveState::DataExch);
            if waiting || for_us {
                d.outputs = Buffer::EMPTY;
            }
            (Answer::ShortAck, HandOver::Decision)
        }
        Some(Sap::GLOBAL_CONTROL) if payload.len() < 2 => (UE, HandOver::No),
        // Clear, Sync and Freeze change what the firmware does with the outputs and which
        // inputs it writes, not the responder's registers.
        Some(Sap::GLOBAL_CONTROL) => (Answer::ShortAck, HandOver::Event),
        Some(Sap::GET_CFG) if waiting => (RR, HandOver::No),
        Some(Sap::GET_CFG) => (Answer::Data(ResponseStatus::DataLow, d.cfg), HandOver::No),
        Some(Sap::RD_INP | Sap::RD_OUTP) if waiting => (RR, HandOver::No),
        Some(Sap::RD_INP | Sap::RD_OUTP) if !exchanging => (RS, HandOver::No),
        Some(Sap::RD_INP) => (
            Answer::Data(ResponseStatus::DataLow, inputs(d)),
            HandOver::No,
        ),
        Some(Sap::RD_OUTP) => {
            let outputs = Buffer::from(d.outputs.padded(usize::from(d.regs.outputs_len)));
            (Answer::Data(ResponseStatus::DataLow, outputs), HandOver::No)
        }
        Some(Sap::SET_SLAVE_ADD) if waiting => (RR, HandOver::No),
        Some(Sap::SET_SLAVE_ADD) => set_slave_add(d, payload),
        Some(Sap::MSAC1) if waiting => (RR, HandOver::No),
        Some(Sap::MSAC1) if !(d.regs.dpv1 && exchanging && owner) => (RS, HandOver::No),
        // A poll: the response once the MCU wrote it, SC until then (`dp_slave`'s MSAC1).
        Some(Sap::MSAC1) if payload.is_empty() => match d.msac1.take() {
            Some(response) => (
                Answer::Data(ResponseStatus::DataLow, response),
                HandOver::No,
            ),
            None => (Answer::ShortAck, HandOver::No),
        },
        Some(Sap::MSAC1) => {
            d.msac1 = None;
            (Answer::ShortAck, HandOver::Acyclic)
        }
        Some(_) => (RS, HandOver::No),
    }
}

/// The highest address Set_Slave_Add may give (126 is reserved for commissioning).
const MAX_SETTABLE_ADDRESS: u8 = dp_consts::MAX_STATION_ADDRESS - 1;

/// Set_Slave_Add from the registers, as `dp_slave` decides it.
fn set_slave_add(d: &ResponderQ, payload: &[u8]) -> (Answer, HandOver) {
    let open = matches!(d.regs.state, SlaveState::PowerOn | SlaveState::WaitPrm)
        && d.regs.owner.is_none()
        && !d.regs.no_add_chg;
    if !open {
        return (RS, HandOver::No);
    }
    let [new_address, ident_hi, ident_lo, _, ..] = *payload else {
        return (UE, HandOver::No);
    };
    if new_address > MAX_SETTABLE_ADDRESS
        || u16::from_be_bytes([ident_hi, ident_lo]) != d.regs.ident_number
    {
        return (UE, HandOver::No);
    }
    (Answer::ShortAck, HandOver::Decision)
}

/// Frames `answer` into `out` and stores it for a repetition (not RR: the request was not
/// taken, and its retry must be taken).
fn answer_with(
    d: &mut ResponderQ,
    out: &mut Output,
    request: &DataRepr,
    fcb: bool,
    answer: Answer,
) {
    let no_resource = matches!(answer, Answer::Status(ResponseStatus::NoResources));
    match answer {
        Answer::ShortAck => {
            out.telegram[0] = dp_consts::SC;
            out.response_len = 1;
        }
        Answer::Data(status, payload) => frame(
            out,
            request,
            FrameControl::slave_response(status),
            payload.as_slice(),
        ),
        Answer::Status(status) => frame(out, request, FrameControl::slave_response(status), &[]),
    }
    d.last = (!no_resource).then_some(Last {
        requester: request.sa,
        fcb,
        service: (request.dsap, request.ssap),
        len: out.response_len as u8,
        telegram: out.telegram,
    });
}

/// The response to `request`: addresses and SAPs swapped.
fn frame(out: &mut Output, request: &DataRepr, fc: FrameControl, payload: &[u8]) {
    let repr = Repr::Data(DataRepr {
        da: request.sa,
        sa: request.da,
        dsap: request.ssap,
        ssap: request.dsap,
        fc,
        payload,
    });
    out.response_len = repr.emit(&mut out.telegram).unwrap_or(0);
}

/// The responder block: its registers, committed once per event.
#[derive(Clone, Debug)]
pub struct Responder {
    q: ResponderQ,
    clocks_per_us: Tick,
}

impl Responder {
    pub fn new(clock_hz: u32) -> Responder {
        Responder {
            q: RESPONDER_RESET,
            clocks_per_us: Tick::from(clock_hz / 1_000_000),
        }
    }

    pub fn q(&self) -> &ResponderQ {
        &self.q
    }

    /// One event; returns what it produced.
    pub fn step(&mut self, input: &Input) -> Output {
        let (out, q) = next(input, &self.q, self.clocks_per_us);
        self.q = q;
        out
    }

    /// Numbers an event the transceiver sends on its own (Boot, a wake-up): every event to
    /// the MCU is numbered from one counter, which [`Regs::seen`] refers to.
    pub fn next_event(&mut self) -> u32 {
        self.q.sent = self.q.sent.wrapping_add(1);
        self.q.sent
    }

    /// When the watchdog expires, if it runs.
    pub fn deadline(&self) -> Option<Tick> {
        self.q.watchdog.deadline
    }

    /// min TSDR for the transmitter, in bit times.
    pub fn min_tsdr_bits(&self) -> u8 {
        self.q.regs.min_tsdr_bits
    }
}
