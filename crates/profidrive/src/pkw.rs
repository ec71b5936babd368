//! The vendor profile's parameter channel (seed 000, "PKW交互格式" and its frame examples).
//!
//! ```text
//! byte   0          1      2      3 4 5      6      7
//!        ID<<4      FID_H  FID_L  reserved   VAL_H  VAL_L
//! ```
//! Task IDs (master to slave): 0 none, 1 read, 2 write. Reply IDs: 0 none, 1 value (to a read
//! and to a write), 7 refused with the error in VAL. The manual's frame examples, decoded this
//! way, agree byte for byte (tests below); its typesetting scatters the D1.00 example over two
//! lines, read here as `10 D1 00 00 00 00 00 00`.
//!
//! [`PkwServer`] (for both profiles) executes a write once: the same request repeated keeps its
//! answer, and only a changed request starts a new one (the drive's memory wears). A read left
//! in the outputs is executed again every [`READ_REFRESH_US`], so a PLC that polls a value this
//! way sees it change (neither manual freezes it: seed 000 lines 238-355, seed 004 lines
//! 851-864); the master sees the previous answer until the new one is there. A request that needs the drive is
//! a [`ParamRequest`], submitted and polled on later services until the drive answered; a
//! write of the value the drive already holds does not write (the drive's non-volatile memory
//! wears).

use crate::codes::{CodeKind, FunctionCode};
use crate::drive::{Access, Drive, DriveError, ParamRequest};

pub const PKW_BYTES: usize = 8;

/// How often a read left in the outputs is read again: the period at which held outputs are
/// written again, so that the drive link keeps its PZD cycle (a read on every turn would halve
/// it).
pub const READ_REFRESH_US: u64 = 10_000;

dp_consts::code_point! {
    /// The task a request asks for (its ID, the high nibble of byte 0).
    pub enum Task {
        None = 0,
        Read = 1,
        Write = 2,
    }
}

/// A decoded request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Request {
    pub task: Task,
    pub code: FunctionCode,
    pub value: u16,
}

impl Request {
    pub fn decode(bytes: &[u8; PKW_BYTES]) -> Request {
        Request {
            task: Task::from(bytes[0] >> 4),
            code: FunctionCode(u16::from_be_bytes([bytes[1], bytes[2]])),
            value: u16::from_be_bytes([bytes[6], bytes[7]]),
        }
    }

    pub fn encode(&self) -> [u8; PKW_BYTES] {
        frame(u8::from(self.task) & 0x0F, self.code, self.value)
    }
}

/// A reply: ID 0 (nothing), 1 (the value) or 7 (refused, the error in the value).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reply {
    None,
    Value {
        code: FunctionCode,
        value: u16,
    },
    Refused {
        code: FunctionCode,
        error: DriveError,
    },
}

dp_consts::code_point! {
    /// A reply's ID (the high nibble of byte 0).
    pub enum ReplyId {
        None = 0,
        Value = 1,
        Refused = 7,
    }
}

fn frame(id: u8, code: FunctionCode, value: u16) -> [u8; PKW_BYTES] {
    let [fid_h, fid_l] = code.0.to_be_bytes();
    let [val_h, val_l] = value.to_be_bytes();
    [id << 4, fid_h, fid_l, 0, 0, 0, val_h, val_l]
}

impl Reply {
    pub fn encode(&self) -> [u8; PKW_BYTES] {
        match *self {
            Reply::None => [0; PKW_BYTES],
            Reply::Value { code, value } => frame(ReplyId::Value.into(), code, value),
            Reply::Refused { code, error } => {
                frame(ReplyId::Refused.into(), code, u16::from(error.code()))
            }
        }
    }
}

/// What a request of either parameter channel needs: its reply now, or the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Planned<R> {
    Reply(R),
    Drive(Access),
}

/// What a vendor request needs: refused or empty at once, or a drive access.
pub fn plan(request: &Request) -> Planned<Reply> {
    let code = request.code;
    let refused = |error| Planned::Reply(Reply::Refused { code, error });
    match request.task {
        Task::None => Planned::Reply(Reply::None),
        Task::Unknown(_) => refused(DriveError::IllegalOperation),
        Task::Read => match code.kind() {
            None => refused(DriveError::IllegalAddress),
            Some(_) => Planned::Drive(Access::Read(code)),
        },
        Task::Write => match code.kind() {
            None => refused(DriveError::IllegalAddress),
            Some(CodeKind::Status | CodeKind::FaultRecord) => refused(DriveError::AccessRestricted),
            Some(CodeKind::Application) => Planned::Drive(Access::Write(code, request.value)),
        },
    }
}

/// The reply to a vendor request once the drive answered.
pub fn reply(request: &Request, result: Result<u16, DriveError>) -> Reply {
    match result {
        Ok(value) => Reply::Value {
            code: request.code,
            value,
        },
        Err(error) => Reply::Refused {
            code: request.code,
            error,
        },
    }
}

/// The parameter channel over data exchange cycles.
#[derive(Clone, Debug)]
pub struct PkwServer {
    /// The request the current reply answers.
    answered: Option<[u8; PKW_BYTES]>,
    /// A request received and not yet answered.
    pending: Option<[u8; PKW_BYTES]>,
    /// The read answered last, and when: it is read again after [`READ_REFRESH_US`].
    refresh: Option<([u8; PKW_BYTES], u64)>,
    /// The drive access of the pending request, under way.
    in_flight: Option<([u8; PKW_BYTES], ParamRequest)>,
    reply: [u8; PKW_BYTES],
}

impl PkwServer {
    /// No request yet.
    pub const fn new() -> PkwServer {
        PkwServer {
            answered: None,
            pending: None,
            refresh: None,
            in_flight: None,
            reply: [0; PKW_BYTES],
        }
    }
}

impl Default for PkwServer {
    fn default() -> Self {
        Self::new()
    }
}

impl PkwServer {
    /// A request as it arrived in the outputs.
    pub fn received(&mut self, bytes: [u8; PKW_BYTES]) {
        if self.answered != Some(bytes) {
            self.pending = Some(bytes);
            self.refresh = None;
        }
    }

    /// Moves a pending request of the vendor profile on, if any, at `now_us`.
    pub fn service(&mut self, drive: &mut impl Drive, now_us: u64) {
        self.service_with(
            drive,
            now_us,
            |bytes| match plan(&Request::decode(bytes)) {
                Planned::Reply(r) => Planned::Reply(r.encode()),
                Planned::Drive(access) => Planned::Drive(access),
            },
            |bytes, result| reply(&Request::decode(bytes), result).encode(),
            |bytes| Request::decode(bytes).task == Task::Read,
        );
    }

    /// Moves a pending request on with the profile's `plan` (its reply now, or a drive access;
    /// called on every service while the access is under way, so it must not act) and
    /// `finish` (the reply once the drive answered). Until then the master keeps seeing the
    /// previous reply. `reads`: the request only reads, and is executed again while it stays.
    pub fn service_with<D: Drive>(
        &mut self,
        drive: &mut D,
        now_us: u64,
        mut plan: impl FnMut(&[u8; PKW_BYTES]) -> Planned<[u8; PKW_BYTES]>,
        finish: impl FnOnce(&[u8; PKW_BYTES], Result<u16, DriveError>) -> [u8; PKW_BYTES],
        reads: impl FnOnce(&[u8; PKW_BYTES]) -> bool,
    ) {
        if let Some((bytes, at)) = self.refresh {
            if self.pending.is_none() && now_us.saturating_sub(at) >= READ_REFRESH_US {
                self.pending = Some(bytes);
            }
        }
        let Some(bytes) = self.pending else {
            return;
        };
        let reply = match plan(&bytes) {
            Planned::Reply(reply) => reply,
            Planned::Drive(access) => {
                let current = self
                    .in_flight
                    .as_ref()
                    .is_some_and(|(b, r)| *b == bytes && r.access() == access);
                if !current {
                    // A new request: one that was under way is abandoned (the drive link
                    // finishes its transaction and forgets the answer).
                    self.in_flight = Some((bytes, ParamRequest::new(access)));
                }
                let Some((_, request)) = self.in_flight.as_mut() else {
                    return;
                };
                let Some(result) = request.poll(drive) else {
                    return;
                };
                self.in_flight = None;
                finish(&bytes, result)
            }
        };
        self.reply = reply;
        self.answered = Some(bytes);
        self.pending = None;
        // A read is read again while it stays (see `received`).
        self.refresh = reads(&bytes).then_some((bytes, now_us));
    }

    /// The reply to put into the inputs.
    pub fn reply(&self) -> [u8; PKW_BYTES] {
        self.reply
    }

    /// Forgets everything: a new configuration starts afresh.
    pub fn reset(&mut self) {
        *self = PkwServer::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::MockDrive;

    /// One request through the server, to a drive that answers at once.
    fn run(drive: &mut MockDrive, request: [u8; 8]) -> [u8; 8] {
        let mut server = PkwServer::default();
        server.received(request);
        server.service(drive, 0);
        server.reply()
    }

    #[test]
    fn seed_000_read_f0_29() {
        // "访问变频器应用参数 F029": request 10 F0 29 00 00 00 00 16 (VAL is not read),
        // reply 10 F0 29 00 00 00 00 25.
        let mut drive = MockDrive::default();
        drive.set(0xF029, 0x25);
        let reply = run(&mut drive, [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0x16]);
        assert_eq!(reply, [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0x25]);
    }

    #[test]
    fn seed_000_write_f0_29() {
        // "修改变频器应用参数 F029": request 20 F0 29 00 00 00 00 16, reply 10 F0 29 .. 16.
        let mut drive = MockDrive::default();
        let reply = run(&mut drive, [0x20, 0xF0, 0x29, 0, 0, 0, 0, 0x16]);
        assert_eq!(reply, [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0x16]);
        assert_eq!(drive.get(0xF029), 0x16);
        assert_eq!(drive.persistent_writes, 1);
    }

    #[test]
    fn seed_000_read_d1_00() {
        // "访问变频器状态参数 D100": reply value 02.
        let mut drive = MockDrive::default();
        drive.set(0xD100, 0x02);
        let reply = run(&mut drive, [0x10, 0xD1, 0x00, 0, 0, 0, 0, 0]);
        assert_eq!(reply, [0x10, 0xD1, 0x00, 0, 0, 0, 0, 0x02]);
    }

    #[test]
    fn seed_000_refused_f0_58() {
        // "访问变频器应用参数异常回答": request 10 F0 58 .., reply 70 F0 58 00 00 00 00 02.
        let mut drive = MockDrive::default();
        let reply = run(&mut drive, [0x10, 0xF0, 0x58, 0, 0, 0, 0, 0]);
        assert_eq!(reply, [0x70, 0xF0, 0x58, 0, 0, 0, 0, 0x02]);
    }

    #[test]
    fn every_error_path() {
        let mut drive = MockDrive::default();
        // Task 3: not an operation of this profile.
        assert_eq!(run(&mut drive, [0x30, 0xF0, 0x29, 0, 0, 0, 0, 0])[7], 0x01);
        // Writing a status value: access restricted.
        assert_eq!(
            run(&mut drive, [0x20, 0xD1, 0x00, 0, 0, 0, 0, 1])[..],
            [0x70, 0xD1, 0x00, 0, 0, 0, 0, 0x11]
        );
        // Whatever the drive or its link reports comes back as reply 7 with its value.
        for error in [
            DriveError::InvalidData,
            DriveError::DriveFault,
            DriveError::MemoryFault,
            DriveError::BusNoise,
            DriveError::NoAnswer,
            DriveError::CrcError,
        ] {
            drive.fail_next = Some(error);
            let reply = run(&mut drive, [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0]);
            assert_eq!(
                reply,
                [0x70, 0xF0, 0x29, 0, 0, 0, 0, error.code()],
                "{error:?}"
            );
        }
        // Task 0: no reply.
        assert_eq!(run(&mut drive, [0; 8]), [0; 8]);
    }

    #[test]
    fn a_repeated_request_is_executed_once_and_keeps_its_answer() {
        let mut drive = MockDrive::default();
        let mut server = PkwServer::default();
        let write = [0x20, 0xF0, 0x29, 0, 0, 0, 0, 0x30];
        for _ in 0..5 {
            server.received(write);
            server.service(&mut drive, 0);
            assert_eq!(server.reply(), [0x10, 0xF0, 0x29, 0, 0, 0, 0, 0x30]);
        }
        assert_eq!(drive.persistent_writes, 1);
        // The same value written by a new request (another parameter in between) does not
        // write the memory again.
        server.received([0x10, 0xF0, 0x29, 0, 0, 0, 0, 0]);
        server.service(&mut drive, 0);
        server.received(write);
        server.service(&mut drive, 0);
        assert_eq!(drive.persistent_writes, 1);
        // A new value does.
        server.received([0x20, 0xF0, 0x29, 0, 0, 0, 0, 0x31]);
        server.service(&mut drive, 0);
        assert_eq!(drive.persistent_writes, 2);
    }

    /// Issue 18: seed 000 (lines 238-355) and seed 004 (lines 851-864) describe a read as
    /// answering the parameter's value; a read left in the outputs follows the value, while a
    /// write left there stays written once.
    #[test]
    fn seed_000_lines_238_355_a_read_left_in_place_follows_the_value() {
        let mut drive = MockDrive::default();
        let mut server = PkwServer::default();
        let read = [0x10, 0xF0, 0x13, 0, 0, 0, 0, 0];
        drive.set(0xF013, 100);
        server.received(read);
        server.service(&mut drive, 0);
        assert_eq!(server.reply()[6..], [0, 100]);
        drive.set(0xF013, 250);
        server.received(read);
        server.service(&mut drive, READ_REFRESH_US - 1);
        assert_eq!(
            server.reply()[6..],
            [0, 100],
            "read again after the refresh period"
        );
        server.received(read);
        server.service(&mut drive, READ_REFRESH_US);
        assert_eq!(
            server.reply()[6..],
            [0, 250],
            "not frozen at the first value"
        );
        let write = [0x20, 0xF0, 0x29, 0, 0, 0, 0, 0x30];
        for _ in 0..3 {
            server.received(write);
            server.service(&mut drive, 0);
        }
        assert_eq!(drive.persistent_writes, 1, "a write stays once");
    }
}
