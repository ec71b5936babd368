//! The PROFIdrive fault buffer (seed 004's 945, 947, 948, 952): a new drive fault goes in at
//! sub-index 1, the older ones move on by 8 (sub-indices 9, 17, .., 41), and 948 counts the
//! seconds since each. When the fault is reset, sub-index 1 goes back to 0 ("0: no fault",
//! seed 004 line 972) and the fault moves on to the history. The drive's warnings (AL.xxx) go
//! the same way into 953-957, the current alarm and the four before it (table 22). Numbers are
//! read from the drive's fault record (DE.00) with a [`ParamRequest`]: the buffer never waits
//! for the drive.

use crate::codes::{named, FunctionCode};
use crate::drive::{Access, Drive, DriveError, FaultRecord, ParamRequest};
use crate::pd_params::{Parameters, FAULT_SUBINDICES};
use dp_slave::Instant;

/// DRIVECOM's code for a fault of serial interface 1 (communication, 75xxh).
pub const DRIVECOM_SERIAL_INTERFACE: u16 = 0x7510;
/// DRIVECOM's generic error (1000h): the code of every drive fault. Seed 004 line 1522 asks for
/// DRIVECOM codes in 945, but seed 000 gives the drive's faults only as numbers (Fu.xxx), with
/// no meaning to map to a specific code; the number is in 947.
pub const DRIVECOM_GENERIC: u16 = 0x1000;

/// The buffer's state beside the parameters it fills.
#[derive(Clone, Debug)]
pub struct FaultBuffer {
    /// When each fault of the buffer happened.
    at: [Option<Instant>; FAULT_SUBINDICES.len()],
    /// A drive fault seen at this time and not yet in the buffer.
    due: Option<Instant>,
    /// The read of the drive's fault record for it, under way.
    read: Option<ParamRequest>,
    /// The fault was reset: sub-index 1 goes back to 0.
    reset_due: bool,
    /// A warning came (its number still to read), or went.
    warning_due: bool,
    warning_read: Option<ParamRequest>,
    warning_gone: bool,
}

impl FaultBuffer {
    /// No fault yet.
    pub const fn new() -> FaultBuffer {
        FaultBuffer {
            at: [None; FAULT_SUBINDICES.len()],
            due: None,
            read: None,
            reset_due: false,
            warning_due: false,
            warning_read: None,
            warning_gone: false,
        }
    }
}

impl Default for FaultBuffer {
    fn default() -> Self {
        Self::new()
    }
}

/// The alarms 953-957 hold (seed 004 table 22: 958-960 "不支持").
pub const ALARMS: usize = 5;

/// The drive's fault record (DE.00), read with `read` (started on the first call); `None`
/// until the drive answered.
fn poll_record(
    read: &mut Option<ParamRequest>,
    drive: &mut impl Drive,
) -> Option<Result<FaultRecord, DriveError>> {
    let request = read.get_or_insert(ParamRequest::new(Access::Read(FunctionCode(
        named::FAULT_RECORD,
    ))));
    let result = request.poll(drive)?;
    *read = None;
    Some(result.map(|r| FaultRecord::from_byte(r as u8)))
}

/// 953-957 one place on (957 is dropped). Element by element: an overlapping copy links a
/// memmove into the production board's flash.
fn shift_alarms(params: &mut Parameters) {
    for i in (1..ALARMS).rev() {
        params.alarms[i] = params.alarms[i - 1];
    }
}

impl FaultBuffer {
    /// The drive's status word went from `was_faulted` to `faulted` at `now`.
    pub fn observe(&mut self, now: Instant, was_faulted: bool, faulted: bool) {
        if !was_faulted && faulted {
            self.due = Some(now);
        }
        if was_faulted && !faulted {
            self.reset_due = true;
        }
    }

    /// The drive's status word went from `was_warning` to `warning`.
    pub fn observe_warning(&mut self, was_warning: bool, warning: bool) {
        if !was_warning && warning {
            self.warning_due = true;
        }
        if was_warning && !warning {
            self.warning_gone = true;
        }
    }

    /// The warning half of the service: 953 the current alarm (0: none), 954-957 the ones
    /// before it. Whether the alarms changed.
    pub fn service_warnings(&mut self, drive: &mut impl Drive, params: &mut Parameters) -> bool {
        if self.warning_due {
            let Some(record) = poll_record(&mut self.warning_read, drive) else {
                return false;
            };
            self.warning_due = false;
            if let Ok(FaultRecord::Warning(n)) = record {
                // The one before it moves on only if it is still current: a warning that went
                // is at 954 already, and 953's 0 is no alarm to keep (table 22: no zeros in the
                // history).
                if params.alarms[0] != 0 {
                    shift_alarms(params);
                }
                params.alarms[0] = u16::from(n);
                return true;
            }
        }
        if core::mem::take(&mut self.warning_gone) && params.alarms[0] != 0 {
            shift_alarms(params);
            params.alarms[0] = 0;
            return true;
        }
        false
    }

    /// Moves a due fault on as far as the drive's answer allows; whether the buffer changed
    /// (a new diagnosis).
    pub fn service(&mut self, drive: &mut impl Drive, params: &mut Parameters) -> bool {
        let Some(at) = self.due else {
            if core::mem::take(&mut self.reset_due) && params.fault_codes[0] != 0 {
                // Reset: the fault goes to the history, sub-index 1 reads 0 (no fault).
                self.shift(params);
                params.fault_codes[0] = 0;
                params.fault_numbers[0] = 0;
                return true;
            }
            return false;
        };
        let Some(record) = poll_record(&mut self.read, drive) else {
            return false;
        };
        self.due = None;
        let number = match record {
            Ok(FaultRecord::Fault(n)) => u16::from(n),
            _ => 0,
        };
        self.push(at, DRIVECOM_GENERIC, number, params);
        true
    }

    /// The drive link was lost at `at` (a link fault, `link_error` its seed 000 value): it
    /// goes into the buffer as a fault of its own, so that a PLC in the PROFIdrive profile
    /// finds the cause (issue 18, seed 004 lines 725-745): 945 the DRIVECOM code 7510h
    /// (communication, serial interface 1: the drive link is one), 947 the link's error value
    /// (21h noise, 22h no answer, 23h CRC).
    pub fn link_lost(&mut self, at: Instant, link_error: u8, params: &mut Parameters) {
        self.push(at, DRIVECOM_SERIAL_INTERFACE, u16::from(link_error), params);
    }

    /// The master reset the lost drive link's fault (the link is back): it moves to the
    /// history and sub-index 1 reads 0, as a drive fault's reset does (seed 004 line 972).
    /// Whether the buffer changed.
    pub fn link_fault_reset(&mut self, params: &mut Parameters) -> bool {
        if params.fault_codes[0] != DRIVECOM_SERIAL_INTERFACE {
            return false;
        }
        self.shift(params);
        params.fault_codes[0] = 0;
        params.fault_numbers[0] = 0;
        true
    }

    /// A new fault at sub-index 1; a fault still there (not reset) moves on first.
    fn push(&mut self, at: Instant, code: u16, number: u16, params: &mut Parameters) {
        if params.fault_codes[0] != 0 {
            self.shift(params);
        }
        params.fault_codes[0] = code;
        params.fault_numbers[0] = number;
        params.fault_count = params.fault_count.saturating_add(1);
        self.at[0] = Some(at);
    }

    /// The buffer one place on: sub-index 1 to 9, .., 33 to 41 (41 is dropped).
    fn shift(&mut self, params: &mut Parameters) {
        for slot in (1..FAULT_SUBINDICES.len()).rev() {
            let (to, from) = (
                usize::from(FAULT_SUBINDICES[slot]) - 1,
                usize::from(FAULT_SUBINDICES[slot - 1]) - 1,
            );
            params.fault_codes[to] = params.fault_codes[from];
            params.fault_numbers[to] = params.fault_numbers[from];
        }
        // A new array, not `copy_within`: an overlapping copy links a 1.5 KiB memmove into
        // the production board's flash.
        let older = self.at;
        self.at = core::array::from_fn(|i| if i == 0 { None } else { older[i - 1] });
    }

    /// 948: the seconds since each fault, at `now`.
    pub fn update_times(&self, now: Instant, params: &mut Parameters) {
        for (at, sub) in self.at.iter().zip(FAULT_SUBINDICES) {
            params.fault_times[usize::from(sub) - 1] = match at {
                Some(at) => {
                    // 948 counts to 65535 s. In 32 bits (1_000_000 = 64 x 15_625): a 64-bit
                    // division is a kilobyte of the production board's flash.
                    let micros = (now.micros() - at.micros()).min(u64::from(u16::MAX) * 1_000_000);
                    (((micros >> 6) as u32) / 15_625) as u16
                }
                None => 0,
            };
        }
    }
}
