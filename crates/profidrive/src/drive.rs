//! The drive behind the adapter, as the application sees it, and the error and fault codes
//! of seed 000 that travel back to the master.
//!
//! Error values (seed 000, PKW reply 7 and "PZD1 返回值高字节为 0XC0"): 0x01 illegal
//! operation, 0x02 illegal address, 0x03 invalid data, 0x04 slave (drive) fault, 0x08 memory
//! fault, 0x11 access restricted, 0x21 bus noise, 0x22 no answer, 0x23 CRC error. The last
//! three are faults of the drive link itself.
//!
//! Parameter access is asynchronous: a channel submits a [`ParamRequest`] and polls it on
//! later services until the drive answered; a drive behind a link answers later, a drive that
//! answers at once ([`ImmediateDrive`]) completes it on the first poll. Nothing is replayed.

use crate::codes::FunctionCode;

/// An error from the drive or from the link to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveError {
    IllegalOperation = 0x01,
    IllegalAddress = 0x02,
    InvalidData = 0x03,
    DriveFault = 0x04,
    MemoryFault = 0x08,
    AccessRestricted = 0x11,
    BusNoise = 0x21,
    NoAnswer = 0x22,
    CrcError = 0x23,
}

impl DriveError {
    /// The value seed 000 sends for it (PKW VAL of reply 7, low byte of PZD1 0xC0xx).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// Whether the link failed (as opposed to the drive refusing the request).
    pub const fn is_link_fault(self) -> bool {
        matches!(
            self,
            DriveError::BusNoise | DriveError::NoAnswer | DriveError::CrcError
        )
    }
}

/// The high byte of PZD1 (status word) while the drive cannot be reached.
pub const PZD1_LINK_ERROR: u16 = 0xC000;

/// A drive that answers at once (the drive simulator, a test's mock, a blocking link): each
/// call returns its result. The application does not call these: [`Drive`] is implemented for
/// every immediate drive, each submitted request completing at once.
///
/// Registers are addressed by function code; the control and status words have their own
/// calls (the drive link knows where they live).
pub trait ImmediateDrive {
    fn read(&mut self, code: FunctionCode) -> Result<u16, DriveError>;
    /// Writes an application parameter. `persist`: the value goes to non-volatile memory
    /// (a parameter channel's write); PZD writes are run-time values and do not wear it.
    fn write(&mut self, code: FunctionCode, value: u16, persist: bool) -> Result<(), DriveError>;
    fn write_control(&mut self, control_word: u16) -> Result<(), DriveError>;
    fn read_status(&mut self) -> Result<u16, DriveError>;
}

/// One drive transaction of a parameter request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Transaction {
    Read(FunctionCode),
    /// A write to non-volatile memory.
    Write(FunctionCode, u16),
}

/// A transaction a drive took and will answer later.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ticket(pub u16);

/// What submitting a transaction gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Submitted {
    /// Answered at once: the value read, or the value written.
    Done(Result<u16, DriveError>),
    /// Taken: [`Drive::poll`] gives the answer once the drive gave it.
    Pending(Ticket),
}

/// What the adapter needs of a drive. Nothing here waits: parameter requests are submitted and
/// completed later ([`ParamRequest`]); the process data is exchanged with what the drive's own
/// cycle has.
pub trait Drive {
    /// One process-data cycle. `out[0]` is the control word and `out[i]` goes to
    /// `targets[i - 1]`; `inp[0]` gets the status word and `inp[i]` the value of
    /// `sources[i - 1]` (0 for none). On an error the words that could not be read keep their
    /// value, and the first error is returned.
    fn exchange_pzd(
        &mut self,
        out: &[u16],
        targets: &[Option<FunctionCode>],
        inp: &mut [u16],
        sources: &[Option<FunctionCode>],
    ) -> Result<(), DriveError>;

    /// Submits one transaction; never waits.
    fn submit(&mut self, transaction: Transaction) -> Submitted;

    /// The answer to a pending transaction, once (`None` while the drive has not answered).
    fn poll(&mut self, ticket: Ticket) -> Option<Result<u16, DriveError>>;
}

impl<T: ImmediateDrive> Drive for T {
    /// Register by register.
    fn exchange_pzd(
        &mut self,
        out: &[u16],
        targets: &[Option<FunctionCode>],
        inp: &mut [u16],
        sources: &[Option<FunctionCode>],
    ) -> Result<(), DriveError> {
        let mut first_error = None;
        let mut note = |r: Result<(), DriveError>| {
            if let Err(e) = r {
                first_error.get_or_insert(e);
            }
        };
        if let Some(cw) = out.first() {
            note(self.write_control(*cw));
        }
        for (target, value) in targets.iter().zip(out.iter().skip(1)) {
            if let Some(target) = target {
                note(self.write(*target, *value, false));
            }
        }
        if let Some(sw) = inp.first_mut() {
            match self.read_status() {
                Ok(v) => *sw = v,
                Err(e) => note(Err(e)),
            }
        }
        for (source, value) in sources.iter().zip(inp.iter_mut().skip(1)) {
            match source.map(|code| self.read(code)) {
                Some(Ok(v)) => *value = v,
                Some(Err(e)) => note(Err(e)),
                None => *value = 0,
            }
        }
        first_error.map_or(Ok(()), Err)
    }

    fn submit(&mut self, transaction: Transaction) -> Submitted {
        Submitted::Done(match transaction {
            Transaction::Read(code) => self.read(code),
            Transaction::Write(code, value) => self.write(code, value, true).map(|()| value),
        })
    }

    fn poll(&mut self, _: Ticket) -> Option<Result<u16, DriveError>> {
        None
    }
}

/// What a parameter channel's request asks of the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Access {
    Read(FunctionCode),
    /// To non-volatile memory, and not at all when the drive already holds the value (its
    /// memory wears; both manuals warn).
    Write(FunctionCode, u16),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Step {
    Start,
    Reading(Ticket),
    Writing(Ticket),
    Done(Result<u16, DriveError>),
}

/// One parameter request to the drive, submitted and completed later: a read; or a write as
/// read, compare, write when different. Both parameter channels (and the fault record) hold
/// one per request; it never waits, and a write reaches the drive at most once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamRequest {
    access: Access,
    step: Step,
}

impl ParamRequest {
    pub const fn new(access: Access) -> ParamRequest {
        ParamRequest {
            access,
            step: Step::Start,
        }
    }

    pub fn access(&self) -> Access {
        self.access
    }

    /// Moves the request on as far as the drive's answers allow; its result once done (the
    /// value read, or the value the drive holds after the write), and on every later call.
    pub fn poll(&mut self, drive: &mut impl Drive) -> Option<Result<u16, DriveError>> {
        loop {
            self.step = match self.step {
                Step::Done(result) => return Some(result),
                Step::Start => {
                    let code = match self.access {
                        Access::Read(code) | Access::Write(code, _) => code,
                    };
                    self.after_read(drive.submit(Transaction::Read(code)), drive)
                }
                Step::Reading(ticket) => match drive.poll(ticket) {
                    None => return None,
                    Some(result) => self.after_read(Submitted::Done(result), drive),
                },
                Step::Writing(ticket) => match drive.poll(ticket) {
                    None => return None,
                    Some(result) => Step::Done(result),
                },
            };
        }
    }

    fn after_read(&self, read: Submitted, drive: &mut impl Drive) -> Step {
        match (read, self.access) {
            (Submitted::Pending(ticket), _) => Step::Reading(ticket),
            (Submitted::Done(result), Access::Read(_)) => Step::Done(result),
            (Submitted::Done(Ok(held)), Access::Write(_, value)) if held == value => {
                Step::Done(Ok(value))
            }
            // Different, or unreadable: write (the drive refuses what it must).
            (Submitted::Done(_), Access::Write(code, value)) => {
                match drive.submit(Transaction::Write(code, value)) {
                    Submitted::Pending(ticket) => Step::Writing(ticket),
                    Submitted::Done(result) => Step::Done(result),
                }
            }
        }
    }
}

/// A fault record entry (seed 000, DE.xx): bit 7 fault, bit 6 warning, bits 5-0 the number
/// after "Fu." or "AL." (0x8C is Fu.012, 0x64 is AL.036).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultRecord {
    Clear,
    /// Fu.xxx
    Fault(u8),
    /// AL.xxx
    Warning(u8),
}

impl FaultRecord {
    pub const fn from_byte(byte: u8) -> FaultRecord {
        let code = byte & 0x3F;
        if byte & 0x80 != 0 {
            FaultRecord::Fault(code)
        } else if byte & 0x40 != 0 {
            FaultRecord::Warning(code)
        } else {
            FaultRecord::Clear
        }
    }

    pub const fn to_byte(self) -> u8 {
        match self {
            FaultRecord::Clear => 0,
            FaultRecord::Fault(code) => 0x80 | (code & 0x3F),
            FaultRecord::Warning(code) => 0x40 | (code & 0x3F),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_000_fault_record_examples() {
        // "返回数据 0x8C(10001100)表示变频器故障代码为 Fu.012; 0x64(01100100) ... AL.036".
        assert_eq!(FaultRecord::from_byte(0x8C), FaultRecord::Fault(12));
        assert_eq!(FaultRecord::from_byte(0x64), FaultRecord::Warning(36));
        assert_eq!(FaultRecord::Fault(12).to_byte(), 0x8C);
        assert_eq!(FaultRecord::Warning(36).to_byte(), 0x64);
        assert_eq!(FaultRecord::from_byte(0), FaultRecord::Clear);
    }

    #[test]
    fn seed_000_error_values() {
        let table = [
            (DriveError::IllegalOperation, 0x01),
            (DriveError::IllegalAddress, 0x02),
            (DriveError::InvalidData, 0x03),
            (DriveError::DriveFault, 0x04),
            (DriveError::MemoryFault, 0x08),
            (DriveError::AccessRestricted, 0x11),
            (DriveError::BusNoise, 0x21),
            (DriveError::NoAnswer, 0x22),
            (DriveError::CrcError, 0x23),
        ];
        for (e, code) in table {
            assert_eq!(e.code(), code);
            assert_eq!(e.is_link_fault(), code >= 0x21);
        }
    }
}
