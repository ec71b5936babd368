//! The adapter's drive: `profidrive::Drive` over a [`ModbusMaster`] that never waits.
//!
//! Contract:
//! - `exchange_pzd` only copies: the outputs into the out image, the in image (the last
//!   cycle's answer) into the inputs, and the link's state as its result. [`LinkedDrive::poll`]
//!   runs the cycles on its own. New outputs go first, as soon as the line is free, and
//!   carry only the words that changed: one word with a write (06h, 8 bytes on the line),
//!   more with an exchange (17h) that writes them and reads PZD 1..N in. The outputs are
//!   written whole again every [`REWRITE_US`] so that a value changed at the drive's side is
//!   overwritten, as cyclic process data does. While the drive holds the outputs, the in
//!   block is read (03h) once every [`READ_PERIOD_US`], not back to back: the line is free
//!   most of the time when new outputs come (README "Latency").
//! - The PZD mapping (the targets and sources of PZD2..N) lives in the drive's mapping
//!   registers. The link writes the ones that changed before the next cycle, and all of them
//!   again after the link failed (the drive may have restarted).
//! - Parameter transactions are submitted ([`Drive::submit`]) and queued: each gets a ticket,
//!   goes before the next cycle, and its answer waits for [`Drive::poll`] with that ticket (the
//!   last few answers are kept; one nobody asks for is forgotten). Nothing is replayed: a
//!   transaction reaches the drive once.
//! - No PZD configuration yet (before data exchange): the link reads the status word every
//!   [`KEEPALIVE_US`], so a lost drive shows before the master asks, and the drive's own
//!   communication alarm stays quiet.
//! - Link errors (no answer, CRC, noise) hold until the next transaction succeeds.
//! - The drive's fieldbus group 51 (`profidrive`'s [`FieldbusGroup`]) gets its transactions between the
//!   others; during data exchange at most one between two cycles, so a PZD cycle is never
//!   delayed by more than one short transaction.

use crate::{ModbusMaster, Op, Outcome, MAX_PZD_WORDS, STATUS_WORD_REGISTER};
use crate::{PZD_IN_MAP, PZD_OUT_BLOCK, PZD_OUT_MAP};
use embedded_hal_nb::serial::{Read, Write};
use heapless09::{Deque, Vec};
use profidrive::codes::FunctionCode;
use profidrive::drive::{Drive, DriveError, Submitted, Ticket, Transaction};
use profidrive::fieldbus_group::FieldbusGroup;

/// The status-word poll period while there is no PZD configuration.
pub const KEEPALIVE_US: u64 = 100_000;
/// The longest a cycle reads only: then the outputs are written again though unchanged.
pub const REWRITE_US: u64 = 10_000;
/// The shortest time from one read of the in block to the next while the drive holds the
/// outputs. A read under way when new outputs come holds them back by up to its length;
/// read back to back (every 150-300 µs), nearly every change waited for one, where reads
/// this far apart leave the line free four times in five. The price: the in block is up to
/// this much older when a data exchange takes it.
pub const READ_PERIOD_US: u64 = 500;
/// How much earlier than its own length a read of the in block keeps clear of the next
/// Data_Exchange's outputs: the DP cycle's jitter.
pub const READ_GUARD_US: u64 = 50;
/// How long a request or an answer keeps seed 000's TX or RX LED flashing.
pub const LED_ACTIVITY_US: u64 = 200_000;

/// Parameter transactions waiting for the link.
const QUEUE: usize = 6;
/// Answers kept until their caller polls for them.
const ANSWERS: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Job {
    Request(Ticket, Op),
    /// Writes mapping register: `(out, slot)`, slot 0 is PZD2.
    Map(bool, usize),
    /// A PZD cycle; `write`: the outputs it writes (of which the drive gets words
    /// `first..first + count`), `None` for a cycle that only reads.
    Cycle {
        words: usize,
        write: Option<[u16; MAX_PZD_WORDS]>,
        first: usize,
        count: usize,
    },
    KeepAlive,
    /// A transaction of the fieldbus group.
    Group(Transaction),
}

/// Counters for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkFigures {
    pub cycles: u32,
    pub requests: u32,
    pub mapping_writes: u32,
}

impl LinkFigures {
    /// Nothing counted yet.
    pub const fn new() -> LinkFigures {
        LinkFigures {
            cycles: 0,
            requests: 0,
            mapping_writes: 0,
        }
    }
}

impl Default for LinkFigures {
    fn default() -> Self {
        Self::new()
    }
}

pub struct LinkedDrive<U> {
    master: ModbusMaster<U>,
    /// PZD words of the current configuration (0: none).
    words: usize,
    out: [u16; MAX_PZD_WORDS],
    /// Function codes of PZD2..PZD10 out and in (0: none).
    targets: [u16; MAX_PZD_WORDS - 1],
    sources: [u16; MAX_PZD_WORDS - 1],
    /// What the drive's mapping registers hold, where known.
    drive_targets: [Option<u16>; MAX_PZD_WORDS - 1],
    drive_sources: [Option<u16>; MAX_PZD_WORDS - 1],
    /// The last cycle's answer, for `in_words` words.
    inp: [u16; MAX_PZD_WORDS],
    in_words: usize,
    link_error: Option<DriveError>,
    job: Option<Job>,
    requests: Deque<(Ticket, Op), QUEUE>,
    answers: Vec<(Ticket, Op, Result<Outcome, DriveError>), ANSWERS>,
    next_ticket: u16,
    next_keepalive_us: u64,
    group: FieldbusGroup,
    /// The last transaction was a cycle: the group may have the next one.
    cycle_ran: bool,
    /// The outputs the drive holds (the last written), and when they were last written
    /// whole.
    drive_out: Option<[u16; MAX_PZD_WORDS]>,
    written_at_us: u64,
    /// When the in block was last read by a cycle that only reads.
    read_at_us: Option<u64>,
    /// When a request last went out, and when the drive last answered (any valid frame).
    last_request_us: Option<u64>,
    last_answer_us: Option<u64>,
    /// The transaction under way was prepared and not yet sent.
    unsent: bool,
    /// When the last Data_Exchange's outputs came, and the DP cycle before it (0 while
    /// unknown): a read of the in block is not started where it would still be under way when
    /// the next come. The durations are u32 (71 minutes) for the 8 KiB board's RAM.
    data_exchange_us: Option<u64>,
    dp_cycle_us: u32,
    /// How long the last read of the in block took, from its request to its answer.
    read_len_us: u32,
    pub figures: LinkFigures,
}

impl<U: Read<u8> + Write<u8>> LinkedDrive<U> {
    // Always inlined: the firmware builds the adapter once, at boot, and inlined the
    // constructors write it in place instead of into temporaries copied up a level (the boot
    // frame is 0.45 KiB smaller, on the production board's 20 KiB).
    #[inline(always)]
    pub const fn new(master: ModbusMaster<U>) -> LinkedDrive<U> {
        LinkedDrive {
            master,
            words: 0,
            out: [0; MAX_PZD_WORDS],
            targets: [0; MAX_PZD_WORDS - 1],
            sources: [0; MAX_PZD_WORDS - 1],
            drive_targets: [None; MAX_PZD_WORDS - 1],
            drive_sources: [None; MAX_PZD_WORDS - 1],
            inp: [0; MAX_PZD_WORDS],
            in_words: 0,
            link_error: None,
            job: None,
            requests: Deque::new(),
            answers: Vec::new(),
            next_ticket: 0,
            next_keepalive_us: 0,
            group: FieldbusGroup::new(),
            cycle_ran: false,
            drive_out: None,
            written_at_us: 0,
            read_at_us: None,
            last_request_us: None,
            last_answer_us: None,
            unsent: false,
            data_exchange_us: None,
            dp_cycle_us: 0,
            read_len_us: 0,
            figures: LinkFigures::new(),
        }
    }

    pub fn master(&self) -> &ModbusMaster<U> {
        &self.master
    }

    pub fn master_mut(&mut self) -> &mut ModbusMaster<U> {
        &mut self.master
    }

    /// The drive's fieldbus group 51.
    pub fn fieldbus(&self) -> &FieldbusGroup {
        &self.group
    }

    pub fn fieldbus_mut(&mut self) -> &mut FieldbusGroup {
        &mut self.group
    }

    /// Seed 000's TX and RX LEDs at `now_us`: the adapter accessed the drive, the drive
    /// answered, within [`LED_ACTIVITY_US`].
    pub fn activity(&self, now_us: u64) -> (bool, bool) {
        let recent =
            |at: Option<u64>| at.is_some_and(|t| now_us.saturating_sub(t) < LED_ACTIVITY_US);
        (recent(self.last_request_us), recent(self.last_answer_us))
    }

    /// The link's error, while it lasts.
    pub fn link_error(&self) -> Option<DriveError> {
        self.link_error
    }

    /// A Data_Exchange's outputs came at `now_us` (every one, changed or not): the DP cycle
    /// the reads of the in block keep clear of.
    pub fn data_exchange(&mut self, now_us: u64) {
        if let Some(last) = self.data_exchange_us {
            self.dp_cycle_us = u32::try_from(now_us.saturating_sub(last)).unwrap_or(u32::MAX);
        }
        self.data_exchange_us = Some(now_us);
    }

    /// When the next read of the in block may start: [`READ_PERIOD_US`] after the last one,
    /// but never where it would still be under way when the next Data_Exchange's outputs
    /// come (it would hold them back by up to its length): those reads go right after the
    /// outputs instead ([`LinkedDrive::read_after_outputs`]), or as long again after their
    /// expected time where they do not come.
    fn next_read_us(&self) -> u64 {
        let periodic = self.read_at_us.map_or(0, |at| at + READ_PERIOD_US);
        match self.before_next_outputs() {
            Some((from, to)) if (from..to).contains(&periodic) => to + (to - from),
            _ => periodic,
        }
    }

    /// The span before the next Data_Exchange's outputs in which a read of the in block
    /// would still be under way when they come: none without a DP cycle to keep clear of
    /// (none seen yet, or too short for a read: then reads go every [`READ_PERIOD_US`]).
    fn before_next_outputs(&self) -> Option<(u64, u64)> {
        let last = self.data_exchange_us?;
        let cycle = u64::from(self.dp_cycle_us);
        let span = u64::from(self.read_len_us) + READ_GUARD_US;
        if cycle <= span {
            return None;
        }
        let next = last + cycle;
        Some((next - span, next))
    }

    /// Right after a Data_Exchange's outputs were decided (and theirs went out): a read of the
    /// in block that is due goes now, where the DP cycle leaves it the time (one held back
    /// from the span before these outputs is due by now). Returns whether it started.
    pub fn read_after_outputs(&mut self, now_us: u64) -> bool {
        let due = self
            .read_at_us
            .is_none_or(|at| at + READ_PERIOD_US <= now_us);
        if self.job.is_some() || self.words == 0 || !due || self.before_next_outputs().is_none() {
            return false;
        }
        self.start_next(now_us);
        self.job.is_some()
    }

    /// When `poll` must run next even if no byte arrives: an answer's deadline, or the next
    /// keep-alive. `None`: only arriving bytes (or new work) move the link.
    pub fn poll_at(&self) -> Option<u64> {
        match self.job {
            Some(_) => self.master.deadline(),
            // A request waits for the free line: at once.
            None if !self.requests.is_empty() => Some(0),
            None if self.words == 0 => Some(
                self.group
                    .poll_at()
                    .map_or(self.next_keepalive_us, |at| at.min(self.next_keepalive_us)),
            ),
            // Data exchange, the line free: the next read of the in block (new outputs come
            // with a turn of their own).
            None => Some(self.next_read_us()),
        }
    }

    /// No transaction is under way: the line is free for the next.
    pub fn is_free(&self) -> bool {
        self.job.is_none()
    }

    /// New outputs for the out image, ahead of the next `exchange_pzd` (which brings the
    /// mapping and takes the in image): only while the configuration's size is the same, so
    /// that a new configuration still starts with its mapping.
    pub fn set_outputs(&mut self, out: &[u16]) {
        if out.len() == self.words {
            self.out[..out.len()].copy_from_slice(out);
        }
    }

    /// Moves the link on at `now_us`: finishes the transaction under way if its answer is
    /// complete or late, and starts the next one.
    pub fn poll(&mut self, now_us: u64) {
        if self.poll_answer(now_us) {
            self.start_next(now_us);
        }
    }

    /// The answer half of [`LinkedDrive::poll`]: finishes the transaction under way if its
    /// answer is in or its time is up. Returns whether the link is free for the next; a caller
    /// that must not hold the CPU long runs [`LinkedDrive::start_next`] apart.
    pub fn poll_answer(&mut self, now_us: u64) -> bool {
        if let Some(job) = self.job {
            match self.master.poll(now_us) {
                Some(outcome) => {
                    self.job = None;
                    self.finish(job, outcome, now_us);
                }
                None => return false,
            }
        }
        true
    }

    /// Moves the transaction's bytes only (see [`ModbusMaster::pump`]): the step before
    /// [`LinkedDrive::poll_answer`], so that neither holds the MCU long.
    pub fn pump(&mut self) {
        if self.job.is_some() {
            self.master.pump();
        }
    }

    /// The request half of [`LinkedDrive::poll`]: starts the next transaction, if the link is
    /// free and one is due, and sends it ([`LinkedDrive::prepare_next`], then
    /// [`LinkedDrive::send`]).
    pub fn start_next(&mut self, now_us: u64) {
        self.prepare_next(now_us);
        self.send(now_us);
    }

    /// The outputs' own turn: starts and sends the next transaction as [`LinkedDrive::start_next`]
    /// does, but not a read of the in block, which waits for its time (see
    /// [`LinkedDrive::poll_at`]) rather than hold up the decision on new outputs.
    pub fn start_for_outputs(&mut self, now_us: u64) {
        if self.job.is_some() {
            return;
        }
        if let Some(job) = self.next_job(now_us, false) {
            self.start(job, now_us);
            self.send(now_us);
        }
    }

    /// The next transaction's request, built but not sent, if the link is free and one is due:
    /// a caller that must keep each piece of work short sends it in its next.
    pub fn prepare_next(&mut self, now_us: u64) {
        if self.job.is_some() {
            return;
        }
        if let Some(job) = self.next_job(now_us, true) {
            self.start(job, now_us);
        }
    }

    fn start(&mut self, job: Job, now_us: u64) {
        let op = self.op(job);
        if self.master.start(op).is_err() {
            return;
        }
        self.job = Some(job);
        self.unsent = true;
        self.last_request_us = Some(now_us);
    }

    /// Sends the request [`LinkedDrive::prepare_next`] built, if one waits. One that is
    /// answered at once is finished here; the next one waits for the next poll, so a call
    /// never runs more than two transactions.
    pub fn send(&mut self, now_us: u64) {
        let Some(job) = self.job.filter(|_| core::mem::take(&mut self.unsent)) else {
            return;
        };
        if let Some(outcome) = self.master.poll(now_us) {
            self.job = None;
            self.finish(job, outcome, now_us);
        }
    }

    /// The next transaction, in this order: the mapping (what the out block means), new
    /// outputs, a parameter request (first of all while the link fails), the fieldbus group
    /// (one between two cycles), a read of the in block when one is due.
    fn next_job(&mut self, now_us: u64, reads: bool) -> Option<Job> {
        // While the link fails, a request first: it gets its answer or its error in its own
        // time, where the mapping and the outputs would take every turn trying again.
        let link_down = self.link_error.is_some_and(DriveError::is_link_fault);
        if link_down {
            if let Some((ticket, op)) = self.requests.pop_front() {
                return Some(Job::Request(ticket, op));
            }
        }
        let slots = self.words.saturating_sub(1);
        for slot in 0..slots {
            if self.drive_targets[slot] != Some(self.targets[slot]) {
                return Some(Job::Map(true, slot));
            }
            if self.drive_sources[slot] != Some(self.sources[slot]) {
                return Some(Job::Map(false, slot));
            }
        }
        if let Some(job) = self.output_write() {
            self.cycle_ran = true;
            return Some(job);
        }
        if let Some((ticket, op)) = self.requests.pop_front() {
            return Some(Job::Request(ticket, op));
        }
        if self.words == 0 || self.cycle_ran {
            if let Some(transaction) = self.group.next_transaction(now_us) {
                self.cycle_ran = false;
                return Some(Job::Group(transaction));
            }
        }
        if self.words > 0 {
            if !reads || now_us < self.next_read_us() {
                return None;
            }
            self.cycle_ran = true;
            self.read_at_us = Some(now_us);
            // A read, or where a rewrite is due, the outputs whole with it (17h): in the
            // read's place, so that it holds back no new outputs that a read would not.
            let rewrite = now_us.saturating_sub(self.written_at_us) >= REWRITE_US;
            return Some(Job::Cycle {
                words: self.words,
                write: rewrite.then_some(self.out),
                first: 0,
                count: if rewrite { self.words } else { 0 },
            });
        }
        if now_us >= self.next_keepalive_us {
            self.next_keepalive_us = now_us + KEEPALIVE_US;
            return Some(Job::KeepAlive);
        }
        None
    }

    /// The outputs the drive does not hold yet, as a cycle that writes the words from the
    /// first that differs to the last (all of them where the drive's are unknown).
    fn output_write(&self) -> Option<Job> {
        let words = self.words;
        if words == 0 {
            return None;
        }
        let out = self.out;
        let (first, count) = match self.drive_out {
            Some(held) => {
                let differs = |i: &usize| held[*i] != out[*i];
                let first = (0..words).find(differs)?;
                let last = (0..words).rev().find(differs)?;
                (first, last + 1 - first)
            }
            None => (0, words),
        };
        Some(Job::Cycle {
            words,
            write: Some(out),
            first,
            count,
        })
    }

    fn op(&self, job: Job) -> Op {
        match job {
            Job::Request(_, op) => op,
            Job::Map(true, slot) => Op::Write(PZD_OUT_MAP + 1 + slot as u16, self.targets[slot]),
            Job::Map(false, slot) => Op::Write(PZD_IN_MAP + 1 + slot as u16, self.sources[slot]),
            // One word: the shortest frame there is; the next read brings the in block.
            Job::Cycle {
                write: Some(out),
                first,
                count: 1,
                ..
            } => Op::Write(PZD_OUT_BLOCK + first as u16, out[first]),
            Job::Cycle {
                words,
                write: Some(out),
                first,
                count,
            } => Op::Exchange {
                words: words as u8,
                first: first as u8,
                count: count as u8,
                out,
            },
            Job::Cycle {
                words, write: None, ..
            } => Op::ReadInputs { words: words as u8 },
            Job::KeepAlive => Op::Read(STATUS_WORD_REGISTER),
            Job::Group(transaction) => op_of(transaction),
        }
    }

    /// Takes answer `at` out, the last in its place. Not heapless's `remove` or
    /// `swap_remove`: their possibly-overlapping copy links a 1.5 KiB memmove into the
    /// production board's flash; the order does not matter (answers are found by ticket).
    fn take_answer(&mut self, at: usize) -> (Ticket, Op, Result<Outcome, DriveError>) {
        let last = self.answers.pop().expect("an answer is there");
        match self.answers.get_mut(at) {
            Some(slot) => core::mem::replace(slot, last),
            None => last,
        }
    }

    fn finish(&mut self, job: Job, outcome: Outcome, now_us: u64) {
        let result = match outcome {
            Outcome::Failed(e) => Err(e),
            other => Ok(other),
        };
        match result {
            Err(e) if e.is_link_fault() => {
                // The drive may have restarted: what it holds is unknown.
                self.link_error = Some(e);
                self.drive_targets = [None; MAX_PZD_WORDS - 1];
                self.drive_sources = [None; MAX_PZD_WORDS - 1];
                self.drive_out = None;
                self.group.link_lost();
            }
            // The drive answered: the link works, whatever it said.
            _ => {
                self.link_error = None;
                self.last_answer_us = Some(now_us);
            }
        }
        match job {
            Job::Request(ticket, op) => {
                self.figures.requests += 1;
                if self.answers.is_full() {
                    // The oldest answer nobody collected makes room.
                    let next = self.next_ticket;
                    let oldest = (0..self.answers.len())
                        .max_by_key(|&i| next.wrapping_sub(self.answers[i].0 .0))
                        .unwrap_or(0);
                    let _ = self.take_answer(oldest);
                }
                let _ = self.answers.push((ticket, op, result));
            }
            Job::Map(out, slot) => {
                self.figures.mapping_writes += 1;
                // The out block means other registers now: the outputs go to them at once.
                self.drive_out = None;
                let (held, wanted) = if out {
                    (&mut self.drive_targets, self.targets[slot])
                } else {
                    (&mut self.drive_sources, self.sources[slot])
                };
                // A refused code is not written again: the cycle then reports the drive's error.
                held[slot] = match result {
                    Err(e) if e.is_link_fault() => None,
                    _ => Some(wanted),
                };
            }
            Job::Cycle {
                words,
                write,
                count,
                ..
            } => {
                self.figures.cycles += 1;
                let mut written = || {
                    if write.is_some() {
                        self.drive_out = write;
                        if count == words {
                            self.written_at_us = now_us;
                        }
                    }
                };
                if write.is_none() {
                    if let Some(sent) = self.last_request_us {
                        let len = now_us.saturating_sub(sent);
                        self.read_len_us = u32::try_from(len).unwrap_or(u32::MAX);
                    }
                }
                match result {
                    Ok(Outcome::Values(values)) => {
                        written();
                        self.inp = values;
                        self.in_words = words;
                    }
                    Ok(Outcome::Written) => written(),
                    // The drive refused the cycle (a mapped register it does not have): the
                    // master sees the drive's error value in PZD1.
                    Err(e) if !e.is_link_fault() => self.link_error = Some(e),
                    _ => {}
                }
            }
            Job::KeepAlive => {}
            Job::Group(transaction) => self
                .group
                .finish(transaction, value(op_of(transaction), result)),
        }
    }
}

/// The Modbus transaction of a parameter transaction: the function code is the register.
fn op_of(transaction: Transaction) -> Op {
    match transaction {
        Transaction::Read(code) => Op::Read(code.0),
        Transaction::Write(code, value) => Op::Write(code.0, value),
    }
}

/// A transaction's answer: the value read, or the value written.
fn value(op: Op, result: Result<Outcome, DriveError>) -> Result<u16, DriveError> {
    match (op, result?) {
        (_, Outcome::Value(v)) => Ok(v),
        (Op::Write(_, v), Outcome::Written) => Ok(v),
        _ => Err(DriveError::BusNoise),
    }
}

impl<U: Read<u8> + Write<u8>> Drive for LinkedDrive<U> {
    fn submit(&mut self, transaction: Transaction) -> Submitted {
        // Only parameter channels submit, and their writes persist; the PZD cycle's run-time
        // writes go through the out block.
        let op = op_of(transaction);
        let ticket = Ticket(self.next_ticket);
        if self.requests.push_back((ticket, op)).is_err() {
            // More transactions at once than the parameter channels make: refuse, never wait.
            return Submitted::Done(Err(DriveError::DriveFault));
        }
        self.next_ticket = self.next_ticket.wrapping_add(1);
        Submitted::Pending(ticket)
    }

    fn poll(&mut self, ticket: Ticket) -> Option<Result<u16, DriveError>> {
        let at = self.answers.iter().position(|(t, _, _)| *t == ticket)?;
        let (_, op, result) = self.take_answer(at);
        Some(value(op, result))
    }

    fn exchange_pzd(
        &mut self,
        out: &[u16],
        targets: &[Option<FunctionCode>],
        inp: &mut [u16],
        sources: &[Option<FunctionCode>],
    ) -> Result<(), DriveError> {
        let words = out.len().min(MAX_PZD_WORDS);
        self.words = words;
        self.out[..words].copy_from_slice(&out[..words]);
        let code = |c: &Option<FunctionCode>| c.map_or(0, |c| c.0);
        for (held, wanted) in self.targets.iter_mut().zip(targets) {
            *held = code(wanted);
        }
        for (held, wanted) in self.sources.iter_mut().zip(sources) {
            *held = code(wanted);
        }
        if self.in_words == words && self.link_error.is_none() {
            let n = inp.len().min(words);
            inp[..n].copy_from_slice(&self.inp[..n]);
        }
        self.link_error.map_or(Ok(()), Err)
    }
}
