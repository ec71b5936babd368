//! Parameter writes through the path the firmware runs: `ProfidriveApp<LinkedDrive>` over the
//! drive simulator's Modbus side (a loopback UART, the drive answering each complete request).
//!
//! Both manuals warn that the drive's memory wears: a write of the value the drive already
//! holds must not reach its non-volatile memory, and a new value must be written exactly once
//! however long the master leaves the request in its outputs. Both parameter channels, seed
//! 000's PKW and seed 004's PROFIdrive channel.

use dp_slave::{Application, Instant};
use drive_link::{Config, LinkedDrive, ModbusMaster};
use drive_sim::{self, DriveSim, ACCEL_TIME};
use profidrive::codes::FunctionCode;
use profidrive::pd_params::{Frame, RequestLabel, ResponseLabel};
use profidrive::pkw::{self, ReplyId, Task};
use profidrive::ppo::Ppo;
use profidrive::prm::{OperationMode, UserPrm};
use profidrive::ProfidriveApp;
use std::collections::VecDeque;

/// Bytes between the adapter's drive UART and the drive.
#[derive(Default)]
struct Loopback {
    to_drive: Vec<u8>,
    from_drive: VecDeque<u8>,
}

impl embedded_hal_nb::serial::ErrorType for Loopback {
    type Error = embedded_hal_nb::serial::ErrorKind;
}

impl embedded_hal_nb::serial::Read<u8> for Loopback {
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        self.from_drive.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

impl embedded_hal_nb::serial::Write<u8> for Loopback {
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        self.to_drive.push(word);
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        Ok(())
    }
}

struct Rig {
    app: ProfidriveApp<LinkedDrive<Loopback>>,
    drive: DriveSim,
    now_us: u64,
}

impl Rig {
    /// In data exchange with PPO1 (PKW + 2 PZD) in `mode`.
    fn new(mode: OperationMode) -> Rig {
        let drive_link =
            LinkedDrive::new(ModbusMaster::new(Loopback::default(), Config::default()));
        let mut app = ProfidriveApp::new(drive_link);
        let mut prm = UserPrm::DEFAULT;
        prm.operation = mode;
        assert!(app.accept_user_prm(&prm.encode()));
        assert!(app.accept_cfg(Ppo::Ppo1.cfg()).is_some());
        Rig {
            app,
            drive: DriveSim::default(),
            now_us: 0,
        }
    }

    /// The adapter's cycle as the firmware runs it, then the drive answers what is complete.
    fn step(&mut self) {
        self.now_us += 200;
        self.drive.advance(200);
        let now = Instant::from_micros(self.now_us);
        self.app.service(now);
        self.app.drive_mut().poll(self.now_us);
        self.app.service(now);
        let uart = self.app.drive_mut().master_mut().uart_mut();
        if let Some(len) = drive_sim::request_len(&uart.to_drive) {
            if uart.to_drive.len() >= len {
                let request: Vec<u8> = uart.to_drive.drain(..len).collect();
                if let Some(answer) = self.drive.modbus(&request) {
                    let uart = self.app.drive_mut().master_mut().uart_mut();
                    uart.from_drive.extend(answer);
                }
            }
        }
    }

    /// The master's outputs: the PKW request and PZD1-2 (0: no command).
    fn outputs(&mut self, pkw: [u8; 8]) {
        let mut outputs = [0u8; 12];
        outputs[..8].copy_from_slice(&pkw);
        self.app
            .outputs(Instant::from_micros(self.now_us), &outputs);
    }

    fn pkw_in(&mut self) -> [u8; 8] {
        let mut inputs = [0u8; 12];
        self.app
            .inputs(Instant::from_micros(self.now_us), &mut inputs);
        inputs[..8].try_into().unwrap()
    }

    /// Leaves `request` in the outputs for `steps` cycles; returns the reply seen last.
    fn hold(&mut self, request: [u8; 8], steps: usize) -> [u8; 8] {
        for _ in 0..steps {
            self.outputs(request);
            self.step();
        }
        self.pkw_in()
    }
}

fn vendor_write(code: u16, value: u16) -> [u8; 8] {
    pkw::Request {
        task: Task::Write,
        code: FunctionCode(code),
        value,
    }
    .encode()
}

/// F0.13 is 1.13 = 113 = 0071h: PNU 0, IND 71h.
fn profidrive_write(value: u16) -> [u8; 8] {
    Frame {
        label: RequestLabel::WriteArrayWord.into(),
        pnu: 0,
        index: 0x71,
        value: u32::from(value),
    }
    .encode()
}

#[test]
fn a_pkw_write_of_the_value_the_drive_holds_writes_nothing_vendor() {
    let mut rig = Rig::new(OperationMode::Vendor);
    let held = rig.drive.read_register(ACCEL_TIME).unwrap();
    let writes = rig.drive.persistent_writes;
    let reply = rig.hold(vendor_write(ACCEL_TIME, held), 200);
    assert_eq!(
        ReplyId::from(reply[0] >> 4),
        ReplyId::Value,
        "the write is answered: {reply:02X?}"
    );
    assert_eq!(
        rig.drive.persistent_writes, writes,
        "no write of an unchanged value"
    );

    let reply = rig.hold(vendor_write(ACCEL_TIME, held + 7), 200);
    assert_eq!(ReplyId::from(reply[0] >> 4), ReplyId::Value, "{reply:02X?}");
    assert_eq!(rig.drive.read_register(ACCEL_TIME), Ok(held + 7));
    assert_eq!(
        rig.drive.persistent_writes,
        writes + 1,
        "a new value is written once, however long the request stays"
    );
}

#[test]
fn a_pkw_write_of_the_value_the_drive_holds_writes_nothing_profidrive() {
    let mut rig = Rig::new(OperationMode::Profidrive);
    let held = rig.drive.read_register(ACCEL_TIME).unwrap();
    let writes = rig.drive.persistent_writes;
    let reply = Frame::decode(&rig.hold(profidrive_write(held), 200));
    assert_eq!(
        (reply.response_label(), reply.value),
        (ResponseLabel::ArrayWord, u32::from(held))
    );
    assert_eq!(
        rig.drive.persistent_writes, writes,
        "no write of an unchanged value"
    );

    let reply = Frame::decode(&rig.hold(profidrive_write(held + 7), 200));
    assert_eq!(
        (reply.response_label(), reply.value),
        (ResponseLabel::ArrayWord, u32::from(held + 7))
    );
    assert_eq!(rig.drive.read_register(ACCEL_TIME), Ok(held + 7));
    assert_eq!(rig.drive.persistent_writes, writes + 1);
}
