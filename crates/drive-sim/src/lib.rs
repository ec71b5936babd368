//! The simulated drive (crate `drive-sim`): the model, its Modbus RTU slave side and the line
//! to it on simulated time ([`line`]). The register map is the drive link's
//! (`drive_link::{CONTROL_WORD_REGISTER, PZD_*}`, `profidrive::fieldbus_group`) and the named
//! function codes are the application's (`profidrive::codes::named`): both sides read one
//! definition.
//!
//! The variable-frequency drive behind the adapter: seed 000's parameter groups, a speed
//! ramp, the vendor control word (obeyed only with the command source on the communication
//! module), faults and warnings a scenario injects, and faults of the link itself. It answers
//! Modbus RTU requests ([`DriveSim::modbus`]) and, for in-process tests, the adapter's
//! `profidrive::Drive` calls directly.
//!
//! Registers are function codes (seed 000): Fx.yy application parameters, D0.yy/D1.yy status
//! values, DE.yy fault record. Seed 000 does not name its communication registers or its ramp
//! times; this simulator uses (and documents here) the following:
//!
//! | register | meaning |
//! |---|---|
//! | 0x2000 | control word (seed 000's control-word bits), write |
//! | 0x2100 | status word (seed 000's status-word bits), read |
//! | F0.29 | set frequency, 0.01 Hz (seed 000: "通过 F029 给定运行频率") |
//! | F0.33, F0.34 | command source; 3 = extension communication module (seed 000) |
//! | F0.13, F0.14 | acceleration and deceleration time, 0.1 s from 0 to F0.10 |
//! | F0.10 | maximum frequency, 0.01 Hz (default 50.00 Hz) |
//! | D0.00 | output frequency, 0.01 Hz |
//! | D0.01 | set frequency, 0.01 Hz |
//! | D0.04 | output current, 0.01 A (proportional to frequency, a model) |
//! | DE.00 | the newest fault or warning record (bit 7 fault, bit 6 warning) |
//! | 0x2201..0x2209 | PZD2..PZD10 out mapping: the code each writes (0: none), volatile |
//! | 0x2301..0x2309 | PZD2..PZD10 in mapping: the code each reads (0: none), volatile |
//! | 0x2400.. | PZD in block: status word, then the mapped values (read) |
//! | 0x2500.. | PZD out block: control word, then the mapped values (write, not persisted) |
//! | 0x5101..0x5121, 0x5127 | fieldbus group 51.01-51.21 and 51.27 (seed 004, table 5; `profidrive::fieldbus_group`) |
//!
//! The fieldbus group is seed 004's: module type, node address (default 3), baud rate (kbit/s,
//! default 1500) and PPO type are written by the module and read-only at the panel
//! ([`DriveSim::set_at_panel`]); PZD3-10 OUT/IN (0-32767), DP mode (0 DP-V0, 1 DP-V1) and
//! FBA PAR REFRESH (0 DONE, 1 REFRESH) are set at the panel. 51.01 holds 1 for PROFIBUS DP.
//!
//! Functions: 03h read holding registers, 06h write single register, 17h read/write multiple
//! registers (the writes first, as the Modbus specification orders it).

use profidrive::codes::{CodeKind, FunctionCode};
use profidrive::drive::{DriveError, FaultRecord, ImmediateDrive};
use profidrive::fieldbus_group::{self as fieldbus, index as fb};
use profidrive::words::{control, rose, status};

pub mod line;

pub use drive_link::{CONTROL_WORD_REGISTER as CONTROL_WORD, STATUS_WORD_REGISTER as STATUS_WORD};
pub use profidrive::codes::named::*;

/// Seed 000's value of F0.33/F0.34 for "extension communication module".
pub const COMMAND_FROM_MODULE: u16 = 3;
/// AL.061: the drive's own alarm when the adapter stops talking to it.
pub const ALARM_COMMUNICATION_LOST: u8 = 61;
/// How long the adapter may stay silent before AL.061.
pub const COMMUNICATION_TIMEOUT_US: u64 = 500_000;
/// The quick stop ramps down this many times faster than the deceleration time.
const QUICK_STOP_FACTOR: u64 = 10;

/// Faults of the link to the drive, injected by a scenario.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LinkFault {
    #[default]
    None,
    /// The drive never answers.
    NoAnswer,
    /// Answers arrive with a bad CRC.
    CrcError,
    /// Noise on the line: answers arrive garbled.
    Noise,
    /// The cable is out.
    Disconnected,
}

/// The simulated drive.
#[derive(Clone, Debug)]
pub struct DriveSim {
    /// F0.00 .. FF.55: 16 groups of 56.
    application: [[u16; 56]; 16],
    control_word: u16,
    /// Output frequency in 0.01 Hz x 1000 (sub-step precision for the ramp).
    output_milli: u64,
    reverse: bool,
    fault: Option<u8>,
    warning: Option<u8>,
    /// The last time the adapter talked to the drive.
    last_contact_us: u64,
    now_us: u64,
    pub link_fault: LinkFault,
    /// The PZD2..PZD10 mapping registers (out, in).
    pzd_out_map: [u16; 9],
    pzd_in_map: [u16; 9],
    /// Group 51, by index (0 unused).
    fieldbus: [u16; fieldbus::LAST_INDEX as usize + 1],
    /// Writes to non-volatile memory.
    pub persistent_writes: u32,
    pub fault_resets: u32,
}

impl Default for DriveSim {
    fn default() -> Self {
        let mut application = [[0u16; 56]; 16];
        application[0][10] = 5000; // F0.10 maximum frequency, 50.00 Hz
        application[0][13] = 50; // F0.13 acceleration 5.0 s
        application[0][14] = 50; // F0.14 deceleration 5.0 s
        application[0][33] = COMMAND_FROM_MODULE;
        application[0][34] = COMMAND_FROM_MODULE;
        DriveSim {
            application,
            control_word: 0,
            output_milli: 0,
            reverse: false,
            fault: None,
            warning: None,
            last_contact_us: 0,
            now_us: 0,
            link_fault: LinkFault::None,
            pzd_out_map: [0; 9],
            pzd_in_map: [0; 9],
            fieldbus: {
                let mut group = [0; fieldbus::LAST_INDEX as usize + 1];
                group[usize::from(fb::NODE_ADDRESS)] = 3;
                group[usize::from(fb::BAUD_RATE)] = 1500;
                group[usize::from(fb::PPO_TYPE)] = 1;
                group
            },
            persistent_writes: 0,
            fault_resets: 0,
        }
    }
}

fn application_slot(code: u16) -> Option<(usize, usize)> {
    let code = FunctionCode(code);
    match code.kind() {
        Some(CodeKind::Application) => {
            Some((usize::from(code.group() - 0xF0), usize::from(code.index()?)))
        }
        _ => None,
    }
}

impl DriveSim {
    fn param(&self, code: u16) -> u16 {
        application_slot(code).map_or(0, |(g, i)| self.application[g][i])
    }

    /// Injects a fault Fu.`code`: the drive trips and coasts.
    pub fn inject_fault(&mut self, code: u8) {
        self.fault = Some(code & 0x3F);
        self.output_milli = 0;
    }

    /// Clears the fault, as a reset at the drive's panel does.
    pub fn clear_fault(&mut self) {
        self.fault = None;
    }

    /// Injects (or clears) a warning AL.`code`.
    pub fn set_warning(&mut self, code: Option<u8>) {
        self.warning = code.map(|c| c & 0x3F);
    }

    pub fn fault(&self) -> Option<u8> {
        self.fault
    }

    pub fn warning(&self) -> Option<u8> {
        self.warning
    }

    /// Output frequency, 0.01 Hz.
    pub fn output_frequency(&self) -> u16 {
        (self.output_milli / 1000) as u16
    }

    pub fn reverse(&self) -> bool {
        self.reverse
    }

    /// The drive's own time (what `advance` has let pass).
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    pub fn control_word(&self) -> u16 {
        self.control_word
    }

    fn obeys_bus(&self) -> bool {
        self.param(COMMAND_SOURCE) == COMMAND_FROM_MODULE
    }

    fn run_commanded(&self) -> bool {
        let cw = self.control_word;
        let needed = control::RUN_ENABLE | control::START_ENABLE | control::RUN;
        self.obeys_bus()
            && self.fault.is_none()
            && cw & needed == needed
            && cw & (control::QUICK_STOP | control::COAST_STOP) == 0
    }

    /// Lets `dt_us` pass: the ramp moves, the communication watchdog runs.
    pub fn advance(&mut self, dt_us: u64) {
        self.now_us += dt_us;
        if self.obeys_bus() && self.now_us - self.last_contact_us > COMMUNICATION_TIMEOUT_US {
            self.warning = Some(ALARM_COMMUNICATION_LOST);
        }
        let cw = self.control_word;
        if self.obeys_bus() && cw & control::COAST_STOP != 0 {
            self.output_milli = 0;
            return;
        }
        let max = u64::from(self.param(MAX_FREQUENCY).max(1));
        let target = if self.run_commanded() && cw & control::RAMP_INPUT_ZERO == 0 {
            u64::from(self.param(SET_FREQUENCY).min(self.param(MAX_FREQUENCY))) * 1000
        } else {
            0
        };
        // The direction changes only through zero.
        let want_reverse = cw & control::REVERSE != 0 && self.run_commanded();
        let target = if want_reverse != self.reverse && self.output_milli > 0 {
            0
        } else {
            target
        };
        if self.output_milli == 0 {
            self.reverse = want_reverse;
        }
        if cw & control::RAMP_HOLD != 0 && self.run_commanded() {
            return;
        }
        // Ramp time is from 0 to the maximum frequency, in 0.1 s.
        let accel = u64::from(self.param(ACCEL_TIME).max(1)) * 100_000;
        let mut decel = u64::from(self.param(DECEL_TIME).max(1)) * 100_000;
        if cw & control::QUICK_STOP != 0 {
            decel /= QUICK_STOP_FACTOR;
        }
        let (ramp_us, up) = if target > self.output_milli {
            (accel, true)
        } else {
            (decel, false)
        };
        let step = max * 1000 * dt_us / ramp_us;
        self.output_milli = if up {
            (self.output_milli + step).min(target)
        } else {
            self.output_milli.saturating_sub(step).max(target)
        };
    }

    fn status_word(&self) -> u16 {
        let cw = self.control_word;
        let mut sw = 0;
        if self.fault.is_none() {
            sw |= status::READY;
        }
        if cw & control::RUN_ENABLE != 0 {
            sw |= status::RUN_ENABLED;
        }
        if cw & control::START_ENABLE != 0 {
            sw |= status::START_ENABLED;
        }
        if self.run_commanded() || self.output_milli > 0 {
            sw |= status::RUNNING;
        }
        if self.reverse {
            sw |= status::REVERSE;
        }
        let target = if self.run_commanded() {
            u64::from(self.param(SET_FREQUENCY)) * 1000
        } else {
            0
        };
        match self.output_milli.cmp(&target) {
            core::cmp::Ordering::Less => sw |= status::ACCELERATING,
            core::cmp::Ordering::Greater => sw |= status::DECELERATING,
            core::cmp::Ordering::Equal if self.run_commanded() => sw |= status::AT_SETPOINT,
            core::cmp::Ordering::Equal => {}
        }
        if self.output_milli == 0 {
            sw |= status::ZERO_SPEED;
        }
        if self.obeys_bus() {
            sw |= status::COMMAND_FROM_BUS | status::REFERENCE_FROM_BUS;
        }
        if self.warning.is_some() {
            sw |= status::WARNING;
        }
        if self.fault.is_some() {
            sw |= status::FAULT;
        }
        sw
    }

    fn contact(&mut self) -> Result<(), DriveError> {
        match self.link_fault {
            LinkFault::None => {}
            LinkFault::NoAnswer | LinkFault::Disconnected => return Err(DriveError::NoAnswer),
            LinkFault::CrcError => return Err(DriveError::CrcError),
            LinkFault::Noise => return Err(DriveError::BusNoise),
        }
        self.note_contact();
        Ok(())
    }

    /// The adapter reached the drive: the communication watchdog restarts, AL.061 clears.
    fn note_contact(&mut self) {
        self.last_contact_us = self.now_us;
        if self.warning == Some(ALARM_COMMUNICATION_LOST) {
            self.warning = None;
        }
    }

    /// A register read, as the Modbus slave serves it.
    pub fn read_register(&self, register: u16) -> Result<u16, DriveError> {
        if let Some(slot) = map_slot(register, PZD_OUT_MAP) {
            return Ok(self.pzd_out_map[slot]);
        }
        if let Some(slot) = map_slot(register, PZD_IN_MAP) {
            return Ok(self.pzd_in_map[slot]);
        }
        if let Some(i) = fieldbus::index_of(FunctionCode(register)) {
            return Ok(self.fieldbus[usize::from(i)]);
        }
        if register == PZD_IN_BLOCK {
            return Ok(self.status_word());
        }
        if let Some(slot) = map_slot(register, PZD_IN_BLOCK) {
            return match self.pzd_in_map[slot] {
                0 => Ok(0),
                code => self.read_register(code),
            };
        }
        Ok(match register {
            STATUS_WORD => self.status_word(),
            CONTROL_WORD => self.control_word,
            OUTPUT_FREQUENCY => self.output_frequency(),
            SET_FREQUENCY_STATUS => self.param(SET_FREQUENCY),
            OUTPUT_CURRENT => self.output_frequency() / 10,
            FAULT_RECORD => u16::from(match (self.fault, self.warning) {
                (Some(f), _) => FaultRecord::Fault(f).to_byte(),
                (None, Some(w)) => FaultRecord::Warning(w).to_byte(),
                (None, None) => 0,
            }),
            other => match FunctionCode(other).kind() {
                Some(CodeKind::Application) => self.param(other),
                Some(CodeKind::Status | CodeKind::FaultRecord) => 0,
                None => return Err(DriveError::IllegalAddress),
            },
        })
    }

    /// A register write, as the Modbus slave serves it.
    pub fn write_register(
        &mut self,
        register: u16,
        value: u16,
        persist: bool,
    ) -> Result<(), DriveError> {
        if let Some(slot) = map_slot(register, PZD_OUT_MAP) {
            self.pzd_out_map[slot] = mapped_code(value)?;
            return Ok(());
        }
        if let Some(slot) = map_slot(register, PZD_IN_MAP) {
            self.pzd_in_map[slot] = mapped_code(value)?;
            return Ok(());
        }
        if let Some(i) = fieldbus::index_of(FunctionCode(register)) {
            if !fieldbus_value_valid(i, value) {
                return Err(DriveError::InvalidData);
            }
            self.fieldbus[usize::from(i)] = value;
            if persist {
                self.persistent_writes += 1;
            }
            return Ok(());
        }
        if register == PZD_OUT_BLOCK {
            return self.write_register(CONTROL_WORD, value, false);
        }
        if let Some(slot) = map_slot(register, PZD_OUT_BLOCK) {
            return match self.pzd_out_map[slot] {
                0 => Ok(()),
                code => self.write_register(code, value, false),
            };
        }
        if register == CONTROL_WORD {
            if rose(self.control_word, value, control::FAULT_RESET) {
                self.fault_resets += 1;
                self.fault = None;
            }
            self.control_word = value;
            return Ok(());
        }
        let Some((g, i)) = application_slot(register) else {
            return Err(match FunctionCode(register).kind() {
                Some(_) => DriveError::AccessRestricted,
                None => DriveError::IllegalAddress,
            });
        };
        if register == SET_FREQUENCY && value > self.param(MAX_FREQUENCY) {
            return Err(DriveError::InvalidData);
        }
        if matches!(register, COMMAND_SOURCE | COMMAND_SOURCE_2) && value > 3 {
            return Err(DriveError::InvalidData);
        }
        self.application[g][i] = value;
        if persist {
            self.persistent_writes += 1;
        }
        Ok(())
    }
}

impl ImmediateDrive for DriveSim {
    fn read(&mut self, code: FunctionCode) -> Result<u16, DriveError> {
        self.contact()?;
        self.read_register(code.0)
    }

    fn write(&mut self, code: FunctionCode, value: u16, persist: bool) -> Result<(), DriveError> {
        self.contact()?;
        self.write_register(code.0, value, persist)
    }

    fn write_control(&mut self, control_word: u16) -> Result<(), DriveError> {
        self.contact()?;
        self.write_register(CONTROL_WORD, control_word, false)
    }

    fn read_status(&mut self) -> Result<u16, DriveError> {
        self.contact()?;
        self.read_register(STATUS_WORD)
    }
}

impl DriveSim {
    /// A parameter set at the drive's own panel (a commissioning engineer, not the adapter):
    /// the values the module reports (51.01, 51.03, 51.04) and status values are read-only.
    pub fn set_at_panel(&mut self, register: u16, value: u16) -> Result<(), DriveError> {
        let read_only = matches!(
            fieldbus::index_of(FunctionCode(register)),
            Some(fb::MODULE_TYPE | fb::BAUD_RATE | fb::PPO_TYPE)
        );
        if read_only {
            return Err(DriveError::AccessRestricted);
        }
        if fieldbus::index_of(FunctionCode(register)).is_none() && !is_parameter(register) {
            return Err(match FunctionCode(register).kind() {
                Some(_) => DriveError::AccessRestricted,
                None => DriveError::IllegalAddress,
            });
        }
        self.write_register(register, value, true)
    }
}

/// The range of each fieldbus parameter (seed 004, table 5).
fn fieldbus_value_valid(index: u8, value: u16) -> bool {
    match index {
        fb::NODE_ADDRESS => value <= u16::from(dp_consts::MAX_STATION_ADDRESS),
        fb::BAUD_RATE => dp_consts::Baud::ALL
            .iter()
            .any(|b| fieldbus::baud_rate_kbit(*b) == value),
        fb::PPO_TYPE => (1..=6).contains(&value),
        fb::PZD3_OUT..=fb::PZD10_IN => value <= 32767,
        fb::DP_MODE | fb::PAR_REFRESH => value <= 1,
        _ => true,
    }
}

/// PZD2..PZD10's slot (0..=8) in a mapping register set or block starting at `base`.
fn map_slot(register: u16, base: u16) -> Option<usize> {
    let n = register.checked_sub(base)?;
    (1..=9).contains(&n).then(|| usize::from(n - 1))
}

/// A code a mapping register may hold: 0 or a register the drive has.
fn mapped_code(value: u16) -> Result<u16, DriveError> {
    match value {
        0 | CONTROL_WORD | STATUS_WORD => Ok(value),
        _ if FunctionCode(value).kind().is_some() => Ok(value),
        _ => Err(DriveError::InvalidData),
    }
}

/// The drive's Modbus RTU slave address.
pub const MODBUS_ADDRESS: u8 = drive_link::DRIVE_ADDRESS;
const READ_HOLDING: u8 = 0x03;
const WRITE_SINGLE: u8 = 0x06;
use drive_link::{PZD_IN_BLOCK, PZD_IN_MAP, PZD_OUT_BLOCK, PZD_OUT_MAP, READ_WRITE_MULTIPLE};
const EXCEPTION: u8 = 0x80;
const CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_MODBUS);

/// Appends the Modbus CRC (low byte first).
pub fn with_crc(mut frame: Vec<u8>) -> Vec<u8> {
    let crc = CRC.checksum(&frame);
    frame.extend_from_slice(&crc.to_le_bytes());
    frame
}

/// The Modbus exception code for an error (illegal function 1, illegal address 2, illegal
/// value 3, device failure 4).
fn exception_code(e: DriveError) -> u8 {
    match e {
        DriveError::IllegalOperation => 0x01,
        DriveError::IllegalAddress | DriveError::AccessRestricted => 0x02,
        DriveError::InvalidData => 0x03,
        _ => 0x04,
    }
}

impl DriveSim {
    /// Serves one Modbus RTU request frame (read holding registers 03h, write single register
    /// 06h); `None` when the drive stays silent (not addressed, a bad CRC, or a link fault).
    /// Register writes over Modbus go to non-volatile memory except the control word.
    pub fn modbus(&mut self, request: &[u8]) -> Option<Vec<u8>> {
        if matches!(
            self.link_fault,
            LinkFault::NoAnswer | LinkFault::Disconnected
        ) {
            return None;
        }
        let (body, crc) = request.split_at_checked(request.len().checked_sub(2)?)?;
        if body.len() < 2 || body[0] != MODBUS_ADDRESS || CRC.checksum(body).to_le_bytes() != crc {
            return None;
        }
        self.note_contact();
        let function = body[1];
        let word = |at: usize| {
            body.get(at..at + 2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
        };
        let answer = match (function, word(2), word(4), body.len()) {
            (READ_HOLDING, Some(first), Some(count @ 1..=16), 6) => {
                let mut frame = vec![MODBUS_ADDRESS, READ_HOLDING, (count * 2) as u8];
                let mut result = Ok(());
                for r in first..first.saturating_add(count) {
                    match self.read_register(r) {
                        Ok(v) => frame.extend_from_slice(&v.to_be_bytes()),
                        Err(e) => {
                            result = Err(e);
                            break;
                        }
                    }
                }
                result.map(|()| frame)
            }
            (WRITE_SINGLE, Some(register), Some(value), 6) => self
                .write_register(register, value, is_parameter(register))
                .map(|()| body.to_vec()),
            (READ_WRITE_MULTIPLE, Some(read_first), Some(read_count @ 1..=16), _) => {
                self.read_write_multiple(body, read_first, read_count)
            }
            (READ_HOLDING | WRITE_SINGLE | READ_WRITE_MULTIPLE, _, _, _) => {
                Err(DriveError::InvalidData)
            }
            _ => Err(DriveError::IllegalOperation),
        };
        let frame = match answer {
            Ok(frame) => frame,
            Err(e) => vec![MODBUS_ADDRESS, function | EXCEPTION, exception_code(e)],
        };
        let mut frame = with_crc(frame);
        match self.link_fault {
            LinkFault::CrcError => {
                let last = frame.len() - 1;
                frame[last] ^= 0xFF;
            }
            LinkFault::Noise => frame[1] ^= 0x5A,
            _ => {}
        }
        Some(frame)
    }
}

/// The length of the request frame that starts with `prefix`, once the prefix tells it
/// (a master's requests are delimited by their length, as the drive's UART sees them).
pub fn request_len(prefix: &[u8]) -> Option<usize> {
    match *prefix.get(1)? {
        READ_WRITE_MULTIPLE => prefix.get(10).map(|count| 13 + usize::from(*count)),
        _ => Some(8),
    }
}

/// Writes over Modbus go to non-volatile memory for the application parameters and the
/// fieldbus group only.
fn is_parameter(register: u16) -> bool {
    FunctionCode(register).kind() == Some(CodeKind::Application)
        || fieldbus::index_of(FunctionCode(register)).is_some()
}

impl DriveSim {
    /// 17h: the writes (run-time values), then the reads; the answer carries the reads.
    fn read_write_multiple(
        &mut self,
        body: &[u8],
        read_first: u16,
        read_count: u16,
    ) -> Result<Vec<u8>, DriveError> {
        let word = |at: usize| u16::from_be_bytes([body[at], body[at + 1]]);
        if body.len() < 11 {
            return Err(DriveError::InvalidData);
        }
        let (write_first, write_count, bytes) = (word(6), word(8), usize::from(body[10]));
        if !(1..=16).contains(&write_count)
            || bytes != 2 * usize::from(write_count)
            || body.len() != 11 + bytes
        {
            return Err(DriveError::InvalidData);
        }
        for i in 0..write_count {
            let value = word(11 + 2 * usize::from(i));
            self.write_register(write_first + i, value, false)?;
        }
        let mut frame = vec![MODBUS_ADDRESS, READ_WRITE_MULTIPLE, (read_count * 2) as u8];
        for r in read_first..read_first + read_count {
            frame.extend_from_slice(&self.read_register(r)?.to_be_bytes());
        }
        Ok(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dp_slave::{Application, Instant};
    use profidrive::ppo::Ppo;
    use profidrive::prm::{OperationMode, UserPrm};
    use profidrive::ProfidriveApp;

    const START: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

    #[test]
    fn the_ramp_follows_the_acceleration_and_deceleration_times() {
        let mut d = DriveSim::default();
        d.write_register(SET_FREQUENCY, 5000, false).unwrap();
        d.write_register(CONTROL_WORD, START, false).unwrap();
        // 5.0 s from 0 to 50.00 Hz: after 1 s, 10.00 Hz, accelerating.
        d.advance(1_000_000);
        assert_eq!(d.output_frequency(), 1000);
        assert_eq!(
            d.read_register(STATUS_WORD).unwrap() & status::ACCELERATING,
            status::ACCELERATING
        );
        d.advance(5_000_000);
        assert_eq!(d.output_frequency(), 5000);
        assert_eq!(
            d.read_register(STATUS_WORD).unwrap() & status::AT_SETPOINT,
            status::AT_SETPOINT
        );
        // Stop: down by the deceleration ramp; quick stop ten times faster.
        d.write_register(CONTROL_WORD, START & !control::RUN, false)
            .unwrap();
        d.advance(1_000_000);
        assert_eq!(d.output_frequency(), 4000);
        d.write_register(CONTROL_WORD, START | control::QUICK_STOP, false)
            .unwrap();
        d.advance(400_000);
        assert_eq!(d.output_frequency(), 0);
    }

    #[test]
    fn reverse_goes_through_zero_and_coast_stop_drops_at_once() {
        let mut d = DriveSim::default();
        d.write_register(SET_FREQUENCY, 2000, false).unwrap();
        d.write_register(CONTROL_WORD, START, false).unwrap();
        d.advance(3_000_000);
        assert_eq!((d.output_frequency(), d.reverse()), (2000, false));
        d.write_register(CONTROL_WORD, START | control::REVERSE, false)
            .unwrap();
        d.advance(2_000_000);
        assert_eq!(d.output_frequency(), 0);
        d.advance(3_000_000);
        assert_eq!((d.output_frequency(), d.reverse()), (2000, true));
        d.write_register(CONTROL_WORD, START | control::COAST_STOP, false)
            .unwrap();
        d.advance(1);
        assert_eq!(d.output_frequency(), 0);
    }

    #[test]
    fn only_the_communication_command_source_obeys_and_silence_raises_al_061() {
        let mut d = DriveSim::default();
        d.write_register(COMMAND_SOURCE, 0, false).unwrap();
        d.write_register(SET_FREQUENCY, 2000, false).unwrap();
        d.write_register(CONTROL_WORD, START, false).unwrap();
        d.advance(1_000_000);
        assert_eq!(d.output_frequency(), 0);
        d.write_register(COMMAND_SOURCE, COMMAND_FROM_MODULE, false)
            .unwrap();
        d.advance(1_000_000);
        assert_eq!(d.warning(), Some(ALARM_COMMUNICATION_LOST));
        // AL.061 shows in DE.00 as a warning record (bit 6), and contact clears it.
        assert_eq!(d.read_register(FAULT_RECORD).unwrap(), 0x40 | 61);
        ImmediateDrive::read_status(&mut d).unwrap();
        assert_eq!(d.warning(), None);
    }

    #[test]
    fn faults_warnings_and_reset() {
        let mut d = DriveSim::default();
        d.inject_fault(12);
        assert_eq!(d.read_register(FAULT_RECORD).unwrap(), 0x8C);
        assert_eq!(
            d.read_register(STATUS_WORD).unwrap() & status::FAULT,
            status::FAULT
        );
        d.write_register(CONTROL_WORD, control::FAULT_RESET, false)
            .unwrap();
        assert_eq!(d.fault(), None);
        d.set_warning(Some(36));
        assert_eq!(d.read_register(FAULT_RECORD).unwrap(), 0x64);
        assert_eq!(
            d.write_register(0xD100, 1, true),
            Err(DriveError::AccessRestricted)
        );
        assert_eq!(
            d.write_register(0xF058, 1, true),
            Err(DriveError::IllegalAddress)
        );
        assert_eq!(
            d.write_register(SET_FREQUENCY, 6000, true),
            Err(DriveError::InvalidData)
        );
        d.link_fault = LinkFault::Disconnected;
        assert_eq!(
            ImmediateDrive::read_status(&mut d),
            Err(DriveError::NoAnswer)
        );
        d.link_fault = LinkFault::CrcError;
        assert_eq!(
            ImmediateDrive::read_status(&mut d),
            Err(DriveError::CrcError)
        );
    }

    #[test]
    fn the_fieldbus_group_of_seed_004_table_5() {
        let mut d = DriveSim::default();
        // Defaults of table 5: address 3, 1500 kbit/s, PPO1, DP-V0, DONE.
        let read = |d: &DriveSim, i| d.read_register(fieldbus::code(i).0);
        assert_eq!(read(&d, fb::NODE_ADDRESS), Ok(3));
        assert_eq!(read(&d, fb::BAUD_RATE), Ok(1500));
        assert_eq!(read(&d, fb::PPO_TYPE), Ok(1));
        assert_eq!(read(&d, fb::DP_MODE), Ok(0));
        assert_eq!(read(&d, fb::PAR_REFRESH), Ok(fieldbus::DONE));
        // 51.22-51.26 are not in the table.
        assert_eq!(d.read_register(0x5122), Err(DriveError::IllegalAddress));
        // At the panel, what the module reports is read-only; the rest has table 5's ranges.
        for i in [fb::MODULE_TYPE, fb::BAUD_RATE, fb::PPO_TYPE] {
            assert_eq!(
                d.set_at_panel(fieldbus::code(i).0, 2),
                Err(DriveError::AccessRestricted)
            );
        }
        assert_eq!(d.set_at_panel(fieldbus::code(fb::PZD3_OUT).0, 1202), Ok(()));
        assert_eq!(
            d.set_at_panel(fieldbus::code(fb::PZD3_OUT).0, 32768),
            Err(DriveError::InvalidData)
        );
        assert_eq!(
            d.set_at_panel(fieldbus::code(fb::NODE_ADDRESS).0, 127),
            Err(DriveError::InvalidData)
        );
        assert_eq!(
            d.set_at_panel(OUTPUT_FREQUENCY, 1),
            Err(DriveError::AccessRestricted)
        );
        // The module writes them over Modbus, within their ranges; they are non-volatile.
        let writes = d.persistent_writes;
        let baud = with_crc(vec![1, 0x06, 0x51, 0x03, 0x2E, 0xE0]); // 12000
        assert_eq!(d.modbus(&baud), Some(baud.clone()));
        assert_eq!(read(&d, fb::BAUD_RATE), Ok(12000));
        assert_eq!(
            d.modbus(&with_crc(vec![1, 0x06, 0x51, 0x03, 0x2E, 0xE1])),
            Some(with_crc(vec![1, 0x86, 0x03]))
        );
        assert_eq!(d.persistent_writes, writes + 1);
    }

    #[test]
    fn modbus_frames_with_known_crcs() {
        // The classic "read one holding register at 0 from slave 1": 01 03 00 00 00 01 84 0A.
        assert_eq!(
            with_crc(vec![0x01, 0x03, 0x00, 0x00, 0x00, 0x01]),
            [0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A]
        );
        // Write 12345 to 10BCh at slave 1: 01 06 10 BC 30 39 98 FC (async-modbus's example).
        assert_eq!(
            with_crc(vec![0x01, 0x06, 0x10, 0xBC, 0x30, 0x39]),
            [0x01, 0x06, 0x10, 0xBC, 0x30, 0x39, 0x98, 0xFC]
        );
    }

    #[test]
    fn modbus_reads_writes_and_exceptions() {
        let mut d = DriveSim::default();
        // Write F0.29 = 25.00 Hz, echoed; read it back.
        let write = with_crc(vec![1, 0x06, 0xF0, 0x29, 0x09, 0xC4]);
        assert_eq!(d.modbus(&write), Some(write.clone()));
        assert_eq!(d.persistent_writes, 1);
        let read = with_crc(vec![1, 0x03, 0xF0, 0x29, 0x00, 0x01]);
        assert_eq!(
            d.modbus(&read),
            Some(with_crc(vec![1, 0x03, 2, 0x09, 0xC4]))
        );
        // Two registers: D0.00 output frequency (0, stopped) and D0.01 set frequency.
        let read_two = with_crc(vec![1, 0x03, 0xD0, 0x00, 0x00, 0x02]);
        assert_eq!(
            d.modbus(&read_two),
            Some(with_crc(vec![1, 0x03, 4, 0, 0, 0x09, 0xC4]))
        );
        // The address after F0.29 is 0xF02A, not F0.30: codes are decimal digits (exception 2).
        let across = with_crc(vec![1, 0x03, 0xF0, 0x29, 0x00, 0x02]);
        assert_eq!(d.modbus(&across), Some(with_crc(vec![1, 0x83, 0x02])));
        // The control word register is not non-volatile.
        d.modbus(&with_crc(vec![1, 0x06, 0x20, 0x00, 0x00, 0x16]));
        assert_eq!((d.control_word(), d.persistent_writes), (0x16, 1));
        // F0.58 does not exist: exception 2. A status value is not writable: exception 2.
        // Function 0x10 is not served: exception 1.
        assert_eq!(
            d.modbus(&with_crc(vec![1, 0x03, 0xF0, 0x58, 0, 1])),
            Some(with_crc(vec![1, 0x83, 0x02]))
        );
        assert_eq!(
            d.modbus(&with_crc(vec![1, 0x06, 0xD1, 0x00, 0, 1])),
            Some(with_crc(vec![1, 0x86, 0x02]))
        );
        assert_eq!(
            d.modbus(&with_crc(vec![1, 0x10, 0xF0, 0x29, 0, 1, 2, 0, 0])),
            Some(with_crc(vec![1, 0x90, 0x01]))
        );
        // Another slave, a bad CRC, a short frame: silence.
        assert_eq!(d.modbus(&with_crc(vec![2, 0x03, 0xF0, 0x29, 0, 1])), None);
        let mut bad = read.clone();
        bad[7] ^= 1;
        assert_eq!(d.modbus(&bad), None);
        assert_eq!(d.modbus(&[1]), None);
        // Link faults: no answer, a CRC error, noise.
        d.link_fault = LinkFault::NoAnswer;
        assert_eq!(d.modbus(&read), None);
        d.link_fault = LinkFault::CrcError;
        let answer = d.modbus(&read).unwrap();
        assert_ne!(
            CRC.checksum(&answer[..answer.len() - 2]).to_le_bytes(),
            answer[answer.len() - 2..]
        );
        d.link_fault = LinkFault::Noise;
        assert_ne!(d.modbus(&read).unwrap()[1], 0x03);
    }

    /// The adapter's application over this drive, both profiles: a start, a speed reference
    /// followed by the ramp, the status word.
    #[test]
    fn profidrive_app_runs_the_simulated_drive_in_both_profiles() {
        for operation in [OperationMode::Vendor, OperationMode::Profidrive] {
            let mut app = ProfidriveApp::new(DriveSim::default());
            let mut prm = UserPrm::DEFAULT;
            prm.operation = operation;
            assert!(app.accept_user_prm(&prm.encode()));
            app.accept_cfg(Ppo::Ppo3.cfg()).unwrap();
            use profidrive::profile::control as pd;
            let frames: Vec<[u16; 2]> = match operation {
                OperationMode::Vendor => vec![[START, 2500]],
                _ => vec![
                    [pd::READY, 0],
                    [pd::READY | pd::ON, 0],
                    [pd::OPERATE, 0x2000],
                ],
            };
            let mut t = 0;
            let mut inputs = [0u8; 4];
            let last = *frames.last().unwrap();
            for frame in frames.iter().chain(std::iter::repeat_n(&last, 300)) {
                let out: Vec<u8> = frame.iter().flat_map(|w| w.to_be_bytes()).collect();
                t += 10_000;
                app.drive_mut().advance(10_000);
                app.outputs(Instant::from_micros(t), &out);
                app.service(Instant::from_micros(t));
                app.inputs(Instant::from_micros(t), &mut inputs);
            }
            // 25.00 Hz reached by the ramp (2.5 s of the 3 s run).
            assert_eq!(app.drive().output_frequency(), 2500, "{operation:?}");
            let act = u16::from_be_bytes([inputs[2], inputs[3]]);
            match operation {
                OperationMode::Vendor => assert_eq!(act, 2500),
                _ => assert_eq!(act, 0x2000),
            }
        }
    }
}
