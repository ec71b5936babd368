//! An immediate drive over the Modbus master, for host tests (feature `testing`): each call
//! waits for its answer with a clock the test gives. The product never waits (`LinkedDrive`).

use crate::{ModbusMaster, Op, Outcome, CONTROL_WORD_REGISTER, STATUS_WORD_REGISTER};
use embedded_hal_nb::serial::{Read, Write};
use profidrive::codes::FunctionCode;
use profidrive::drive::{DriveError, ImmediateDrive};

/// `profidrive::Drive` over the master, waiting for each answer with `now` as the clock.
pub struct BlockingDrive<U, C> {
    pub master: ModbusMaster<U>,
    now_us: C,
}

impl<U: Read<u8> + Write<u8>, C: FnMut() -> u64> BlockingDrive<U, C> {
    pub fn new(master: ModbusMaster<U>, now_us: C) -> BlockingDrive<U, C> {
        BlockingDrive { master, now_us }
    }

    fn run(&mut self, op: Op) -> Result<Outcome, DriveError> {
        if self.master.start(op).is_err() {
            return Err(DriveError::DriveFault);
        }
        loop {
            let now = (self.now_us)();
            if let Some(outcome) = self.master.poll(now) {
                return match outcome {
                    Outcome::Failed(e) => Err(e),
                    other => Ok(other),
                };
            }
        }
    }
}

impl<U: Read<u8> + Write<u8>, C: FnMut() -> u64> ImmediateDrive for BlockingDrive<U, C> {
    fn read(&mut self, code: FunctionCode) -> Result<u16, DriveError> {
        match self.run(Op::Read(code.0))? {
            Outcome::Value(v) => Ok(v),
            _ => Err(DriveError::BusNoise),
        }
    }

    fn write(&mut self, code: FunctionCode, value: u16, _persist: bool) -> Result<(), DriveError> {
        // Modbus has one write; the drive decides what is non-volatile (its parameters are,
        // its control word is not). The adapter avoids rewriting unchanged values itself.
        self.run(Op::Write(code.0, value)).map(|_| ())
    }

    fn write_control(&mut self, control_word: u16) -> Result<(), DriveError> {
        self.run(Op::Write(CONTROL_WORD_REGISTER, control_word))
            .map(|_| ())
    }

    fn read_status(&mut self) -> Result<u16, DriveError> {
        match self.run(Op::Read(STATUS_WORD_REGISTER))? {
            Outcome::Value(v) => Ok(v),
            _ => Err(DriveError::BusNoise),
        }
    }
}
