//! dp-slave + profidrive + a mock drive against profirust, the independent DP master, in the
//! vendor profile: a start, a speed reference, a parameter read and write through PKW, a fault
//! and its reset, with PPO1 (PKW + 2 PZD) and PPO3 (2 PZD).

use dp_slave::harness::{Bus, MasterOptions, SLAVE};
use dp_slave::{Config, State};
use profidrive::ppo::Ppo;
use profidrive::prm::UserPrm;
use profidrive::testing::{MockDrive, SET_FREQUENCY};
use profidrive::words::{control, status};
use profidrive::ProfidriveApp;
use profirust::time::Duration;
use profirust::Baudrate;

const START: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

fn bus(ppo: Ppo) -> Bus<ProfidriveApp<MockDrive>> {
    bus_with(ppo, UserPrm::DEFAULT)
}

/// A master with `ppo` and `prm` in data exchange with the slave.
fn bus_with(ppo: Ppo, prm: UserPrm) -> Bus<ProfidriveApp<MockDrive>> {
    let mut bus = Bus::new(
        Baudrate::B1500000,
        MasterOptions {
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            user_prm: prm.encode().to_vec(),
            config: ppo.cfg().to_vec(),
        },
        Config {
            address: SLAVE,
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            no_add_chg: false,
            dpv1_status_bytes: false,
        },
        ProfidriveApp::new(MockDrive::default()),
    );
    bus.service = |slave, now| slave.app_mut().service(now);
    bus.run_until(Duration::from_secs(2), |b| b.running());
    assert_eq!(bus.slave.state(), State::DataExch);
    bus
}

fn words(bytes: &[u8]) -> Vec<u16> {
    bytes
        .chunks(2)
        .map(|w| u16::from_be_bytes([w[0], w[1]]))
        .collect()
}

/// Sets the outputs and runs until the inputs satisfy `done` (a few cycles at most).
fn until(
    bus: &mut Bus<ProfidriveApp<MockDrive>>,
    outputs: &[u16],
    done: impl Fn(&[u16]) -> bool,
) -> Vec<u16> {
    let bytes: Vec<u8> = outputs.iter().flat_map(|w| w.to_be_bytes()).collect();
    bus.pi_q_mut().copy_from_slice(&bytes);
    for _ in 0..10 {
        bus.cycle();
        let inputs = words(&bus.pi_i());
        if done(&inputs) {
            return inputs;
        }
    }
    panic!(
        "outputs {outputs:04X?}: inputs never satisfied the check: {:04X?}",
        words(&bus.pi_i())
    );
}

#[test]
fn ppo3_start_and_speed_reference() {
    let mut bus = bus(Ppo::Ppo3);
    let inputs = until(&mut bus, &[START, 2500], |i| {
        i[0] & status::RUNNING != 0 && i[1] == 2500
    });
    assert_eq!(inputs[0] & status::FAULT, 0);
    assert_eq!(bus.slave.app().drive().get(SET_FREQUENCY), 2500);
    // Stop: the output frequency falls to 0 and zero speed shows.
    until(&mut bus, &[START & !control::RUN, 2500], |i| {
        i[0] & status::ZERO_SPEED != 0 && i[1] == 0
    });
}

#[test]
fn ppo1_pkw_read_write_and_fault_reset() {
    let mut bus = bus(Ppo::Ppo1);
    bus.slave.app_mut().drive_mut().set(0xF105, 0x0123);
    // Read F1.05 through PKW (task 1) while running.
    let inputs = until(&mut bus, &[0x1000 | 0xF1, 0x0500, 0, 0, START, 1000], |i| {
        i[0] == 0x1000 | 0xF1 && i[1] == 0x0500 && i[4] & status::RUNNING != 0
    });
    assert_eq!(inputs[3], 0x0123);
    // Write F1.05 = 0x0456 (task 2): reply 1 with the value, and the drive holds it.
    until(
        &mut bus,
        &[0x2000 | 0xF1, 0x0500, 0, 0x0456, START, 1000],
        |i| i[0] >> 12 == 1 && i[3] == 0x0456,
    );
    assert_eq!(bus.slave.app().drive().get(0xF105), 0x0456);
    // The request stays in the outputs for many cycles: it was written once.
    for _ in 0..5 {
        bus.cycle();
    }
    assert_eq!(bus.slave.app().drive().persistent_writes, 1);
    // A refused write: D1.00 is a status value (reply 7, 0x11).
    until(&mut bus, &[0x2000 | 0xD1, 0x0000, 0, 1, START, 1000], |i| {
        i[0] >> 12 == 7 && i[3] == 0x11
    });
    // A drive fault shows in the status word; a 0 -> 1 of bit 15 resets it.
    bus.slave.app_mut().drive_mut().fault = Some(12);
    until(&mut bus, &[0, 0, 0, 0, START, 1000], |i| {
        i[4] & status::FAULT != 0
    });
    until(
        &mut bus,
        &[0, 0, 0, 0, START | control::FAULT_RESET, 1000],
        |i| i[4] & status::FAULT == 0,
    );
    assert_eq!(bus.slave.app().drive().fault_resets, 1);
}

#[test]
fn ppo1_in_the_profidrive_profile() {
    use profidrive::pd_params::ResponseLabel;
    use profidrive::prm::OperationMode;
    use profidrive::profile::{control as pd, status as pds};
    let mut prm = UserPrm::DEFAULT;
    prm.operation = OperationMode::Profidrive;
    let mut bus = bus_with(Ppo::Ppo1, prm);
    let (off, run) = (pd::READY, pd::OPERATE);
    // The start sequence of table 7, then half the rated speed.
    until(&mut bus, &[0, 0, 0, 0, off, 0], |i| i[4] & pds::RDY_ON != 0);
    until(&mut bus, &[0, 0, 0, 0, off | pd::ON, 0], |i| {
        i[4] & pds::RDY_RUN != 0
    });
    let inputs = until(&mut bus, &[0, 0, 0, 0, run, 0x2000], |i| {
        i[4] & pds::RDY_REF != 0 && i[5] == 0x2000
    });
    assert_eq!(inputs[4] & pds::AT_SETPOINT, pds::AT_SETPOINT);
    assert_eq!(bus.slave.app().drive().get(SET_FREQUENCY), 2500);
    // PKW: read 964 (the Ident_Number) with request label 1.
    let inputs = until(&mut bus, &[0x1000 | 964, 0, 0, 0, run, 0x2000], |i| {
        i[0] >> 12 == u16::from(u8::from(ResponseLabel::Word)) && i[0] & 0x7FF == 964
    });
    assert_eq!(inputs[3], dp_consts::ADAPTER_IDENT_NUMBER);
    // A fault trips, a 0 -> 1 of RESET clears it back to SWITCH-ON INHIBIT.
    bus.slave.app_mut().drive_mut().fault = Some(12);
    until(&mut bus, &[0, 0, 0, 0, run, 0x2000], |i| {
        i[4] & pds::TRIPPED != 0
    });
    until(&mut bus, &[0, 0, 0, 0, run | pd::RESET, 0x2000], |i| {
        i[4] & pds::SWC_ON_INHIB != 0
    });
}
