//! A small drive for host tests: registers by function code, the vendor control word obeyed
//! at once (no ramp), faults and link errors on request. The full drive simulator, with ramps
//! and the seed's parameter groups, is crates/drive-sim.

pub use crate::codes::named::{FAULT_RECORD, OUTPUT_FREQUENCY, SET_FREQUENCY};
use crate::codes::FunctionCode;
use crate::drive::{DriveError, FaultRecord, ImmediateDrive};
use crate::words::{control, rose, status};

#[derive(Clone, Debug)]
pub struct MockDrive {
    registers: heapless::LinearMap<u16, u16, 64>,
    pub control_word: u16,
    /// Writes that went to non-volatile memory.
    pub persistent_writes: u32,
    /// The next call fails with this.
    pub fail_next: Option<DriveError>,
    /// Every call fails with NoAnswer (the cable is out).
    pub disconnected: bool,
    /// An active fault (Fu.xxx), cleared by a fault reset.
    pub fault: Option<u8>,
    /// Fault resets seen (rising edges of control bit 15).
    pub fault_resets: u32,
    /// An active warning (AL.xxx): the status word's warning bit, and the fault record when
    /// there is no fault.
    pub warning: Option<u8>,
}

/// A 50.00 Hz drive (F0.10, its maximum frequency, as the drive simulator's default).
impl Default for MockDrive {
    fn default() -> Self {
        let mut drive = MockDrive {
            registers: heapless::LinearMap::new(),
            control_word: 0,
            persistent_writes: 0,
            fail_next: None,
            disconnected: false,
            fault: None,
            fault_resets: 0,
            warning: None,
        };
        drive.set(crate::codes::named::MAX_FREQUENCY, 5000);
        drive
    }
}

impl MockDrive {
    pub fn set(&mut self, code: u16, value: u16) {
        let _ = self.registers.insert(code, value);
    }

    pub fn get(&self, code: u16) -> u16 {
        self.registers.get(&code).copied().unwrap_or(0)
    }

    fn check(&mut self) -> Result<(), DriveError> {
        if self.disconnected {
            return Err(DriveError::NoAnswer);
        }
        match self.fail_next.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    pub fn running(&self) -> bool {
        let cw = self.control_word;
        let needed = control::RUN_ENABLE | control::START_ENABLE | control::RUN;
        self.fault.is_none()
            && cw & needed == needed
            && cw & (control::QUICK_STOP | control::COAST_STOP) == 0
    }
}

impl ImmediateDrive for MockDrive {
    fn read(&mut self, code: FunctionCode) -> Result<u16, DriveError> {
        self.check()?;
        Ok(match code.0 {
            OUTPUT_FREQUENCY if self.running() => self.get(SET_FREQUENCY),
            OUTPUT_FREQUENCY => 0,
            FAULT_RECORD => match (self.fault, self.warning) {
                (Some(f), _) => u16::from(FaultRecord::Fault(f).to_byte()),
                (None, Some(w)) => u16::from(FaultRecord::Warning(w).to_byte()),
                (None, None) => 0,
            },
            other => self.get(other),
        })
    }

    fn write(&mut self, code: FunctionCode, value: u16, persist: bool) -> Result<(), DriveError> {
        self.check()?;
        self.set(code.0, value);
        if persist {
            self.persistent_writes += 1;
        }
        Ok(())
    }

    fn write_control(&mut self, control_word: u16) -> Result<(), DriveError> {
        self.check()?;
        if rose(self.control_word, control_word, control::FAULT_RESET) {
            self.fault_resets += 1;
            self.fault = None;
        }
        self.control_word = control_word;
        Ok(())
    }

    fn read_status(&mut self) -> Result<u16, DriveError> {
        self.check()?;
        let cw = self.control_word;
        let mut sw = status::READY | status::COMMAND_FROM_BUS | status::REFERENCE_FROM_BUS;
        if cw & control::RUN_ENABLE != 0 {
            sw |= status::RUN_ENABLED;
        }
        if cw & control::START_ENABLE != 0 {
            sw |= status::START_ENABLED;
        }
        if self.running() {
            sw |= status::RUNNING | status::AT_SETPOINT;
            if cw & control::REVERSE != 0 {
                sw |= status::REVERSE;
            }
        } else {
            sw |= status::ZERO_SPEED;
        }
        if self.fault.is_some() {
            sw |= status::FAULT;
            sw &= !status::READY;
        }
        if self.warning.is_some() {
            sw |= status::WARNING;
        }
        Ok(sw)
    }
}
