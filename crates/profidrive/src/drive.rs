//! The drive behind the adapter, as the application sees it, and the error and fault codes
//! of seed 000 that travel back to the master.
//!
//! Error values (seed 000, PKW reply 7 and "PZD1 返回值高字节为 0XC0"): 0x01 illegal
//! operation, 0x02 illegal address, 0x03 invalid data, 0x04 slave (drive) fault, 0x08 memory
//! fault, 0x11 access restricted, 0x21 bus noise, 0x22 no answer, 0x23 CRC error. The last
//! three are faults of the drive link itself (issue 6 puts a Modbus link under this trait).

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

/// What the adapter needs of a drive. Registers are addressed by function code; the control
/// and status words have their own calls (the drive link knows where they live).
///
/// A drive behind a slow link may answer later: it then says so through
/// [`Drive::take_deferred`], and the caller repeats the same calls on a later service until
/// they are answered. [`Drive::exchange_pzd`] never waits; a linked drive serves it from the
/// values of its own cycle.
pub trait Drive {
    fn read(&mut self, code: FunctionCode) -> Result<u16, DriveError>;
    /// Writes an application parameter. `persist`: the value goes to non-volatile memory
    /// (a PKW write); PZD writes are run-time values and do not wear the memory.
    fn write(&mut self, code: FunctionCode, value: u16, persist: bool) -> Result<(), DriveError>;
    fn write_control(&mut self, control_word: u16) -> Result<(), DriveError>;
    fn read_status(&mut self) -> Result<u16, DriveError>;

    /// One process-data cycle. `out[0]` is the control word and `out[i]` goes to
    /// `targets[i - 1]`; `inp[0]` gets the status word and `inp[i]` the value of
    /// `sources[i - 1]` (0 for none). On an error the words that could not be read keep their
    /// value, and the first error is returned. The default does it register by register.
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

    /// Whether the reads and writes since the last call were only queued: their results are
    /// not known yet, and the caller must make the same calls again later (the drive keeps
    /// the answers until the calls are repeated). A drive that answers at once never defers.
    fn take_deferred(&mut self) -> bool {
        false
    }
}

/// A parameter write from a parameter channel (either profile): to non-volatile memory, and
/// not at all when the drive already holds the value (its memory wears; both manuals warn).
pub fn write_if_changed(
    drive: &mut impl Drive,
    code: FunctionCode,
    value: u16,
) -> Result<(), DriveError> {
    if drive.read(code).is_ok_and(|v| v == value) {
        return Ok(());
    }
    drive.write(code, value, true)
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
