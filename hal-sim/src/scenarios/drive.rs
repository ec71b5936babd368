//! The drive scenarios (family "drive") of `cargo xtask qemu-test`: the profirust master drives the simulated
//! drive through the adapter (PZD and the parameter channel), in both profiles; the fail-safe
//! modes; the drive's fieldbus group 51; and the adapter's latency per PPO.
//!
//! Every check reads what the master received or what the drive simulator holds: nothing is
//! taken from the adapter's own account. The master's outputs and inputs are words here
//! (PKW first, then PZD), big-endian as on the bus.

use super::support::{Checks, Report, SWITCH_ADDRESS};
use crate::cosim::{CoSim, MasterSetup, Program};
use crate::firmware::Firmware;
use dp_consts::Baud;
use dp_link::{HostLed, Led};
use drive_link::LED_ACTIVITY_US;
use drive_sim::{DriveSim, LinkFault, ACCEL_TIME, DECEL_TIME, OUTPUT_CURRENT, SET_FREQUENCY};
use fdl::{RequestFunction, Sap};
use profidrive::codes::FunctionCode;
use profidrive::fieldbus_group::{self as fieldbus, index as fb};
use profidrive::pd_params::{Frame, RequestLabel, ResponseLabel};
use profidrive::pkw::{ReplyId, Request, Task};
use profidrive::ppo::Ppo;
use profidrive::prm::{FailSafeMode, OperationMode, UserPrm};
use profidrive::profile::{control as pd, status as pds};
use profidrive::words::{control, status};
use profirust::dp::DiagnosticFlags;
use std::io;

const BAUD: Baud = Baud::B1500000;
/// The vendor control word that runs the drive forward.
const START: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;
const TICKS_PER_US: u64 = (crate::cosim::CLOCK_HZ / 1_000_000) as u64;

fn setup(ppo: Ppo, prm: UserPrm) -> MasterSetup {
    let mut setup = MasterSetup::new(BAUD, SWITCH_ADDRESS);
    setup.config = ppo.cfg().to_vec();
    setup.user_prm = prm.encode().to_vec();
    setup
}

/// Starts the master with all-zero outputs under the scenario's control; true once it
/// exchanges data.
fn start<F: Firmware>(sim: &mut CoSim<F>, setup: MasterSetup) -> io::Result<bool> {
    sim.start_master(setup);
    if let Some(m) = sim.master.as_mut() {
        m.program = Program::Manual;
    }
    let end = sim.now + 500_000 * TICKS_PER_US;
    sim.run_until(end, |s| {
        s.master
            .as_mut()
            .is_some_and(|m| m.running() && m.cycles > 2)
    })
}

pub(crate) fn words(bytes: &[u8]) -> Vec<u16> {
    bytes
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect()
}

/// The master's outputs from now on.
fn put<F: Firmware>(sim: &mut CoSim<F>, out: &[u16]) {
    if let Some(m) = sim.master.as_mut() {
        m.outputs = out.iter().flat_map(|w| w.to_be_bytes()).collect();
    }
}

/// The inputs the master received last.
fn inputs<F: Firmware>(sim: &CoSim<F>) -> Vec<u16> {
    sim.master.as_ref().map_or(Vec::new(), |m| words(&m.inputs))
}

/// Runs until `done(inputs, drive)` holds after a data exchange cycle, or `limit_us` passed.
fn wait<F: Firmware>(
    sim: &mut CoSim<F>,
    limit_us: u64,
    mut done: impl FnMut(&[u16], &mut DriveSim) -> bool,
) -> io::Result<bool> {
    let end = sim.now + limit_us * TICKS_PER_US;
    let mut seen = u64::MAX;
    sim.run_until(end, |s| {
        let cycles = s.master.as_ref().map_or(0, |m| m.cycles);
        if cycles == seen {
            return false;
        }
        seen = cycles;
        let i = inputs(s);
        !i.is_empty() && done(&i, s.drive_now())
    })
}

/// Runs until the drive link's flags in the extended diagnosis the master read have `flag`
/// set, at most `limit_us`.
fn wait_diag<F: Firmware>(sim: &mut CoSim<F>, limit_us: u64, flag: u8) -> io::Result<Vec<u8>> {
    super::support::wait_ext_diag(sim, limit_us, |d| {
        super::support::link_flags(d).is_some_and(|f| f & flag != 0)
    })
}

/// Sends one parameter request (the PKW words) with the PZD words `pzd`, first clearing the
/// channel with an empty request; returns the reply words, or `None` if none came in 200 ms.
fn pkw<F: Firmware>(
    sim: &mut CoSim<F>,
    request: [u16; 4],
    pzd: &[u16],
) -> io::Result<Option<Vec<u16>>> {
    let mut out = vec![0u16; 4];
    out.extend_from_slice(pzd);
    put(sim, &out);
    wait(sim, 200_000, |i, _| i[..4] == [0, 0, 0, 0])?;
    out[..4].copy_from_slice(&request);
    put(sim, &out);
    let replied = wait(sim, 200_000, |i, _| i[0] != 0)?;
    Ok(replied.then(|| inputs(sim)[..4].to_vec()))
}

pub(crate) fn vendor_request(task: Task, code: u16, value: u16) -> [u16; 4] {
    let bytes = Request {
        task,
        code: FunctionCode(code),
        value,
    }
    .encode();
    let w = words(&bytes);
    [w[0], w[1], w[2], w[3]]
}

/// A vendor PKW reply: (reply ID, value).
pub(crate) fn vendor_reply(reply: &Option<Vec<u16>>) -> Option<(ReplyId, u16)> {
    reply
        .as_ref()
        .map(|r| (ReplyId::from((r[0] >> 12) as u8), r[3]))
}

/// Seed 000 in the vendor profile, PPO1: parameters, a run with the ramp, reverse, quick and
/// coast stop, another PZD mapping, a drive fault and its reset, the drive link lost and back.
pub fn vendor<F: Firmware>(sim: &mut CoSim<F>, c: &mut Checks, _: Baud) -> io::Result<Report> {
    let ok = start(sim, setup(Ppo::Ppo1, UserPrm::DEFAULT))?;
    c.check("PPO1, vendor profile: data exchange", ok);

    // PKW: ramps of 1.0 s (F0.13, F0.14 in 0.1 s), read back; then the error paths.
    let idle = [control::REMOTE, 0];
    let r = pkw(sim, vendor_request(Task::Write, ACCEL_TIME, 10), &idle)?;
    c.check(
        "PKW write F0.13 = 10: reply 1 with the value",
        vendor_reply(&r) == Some((ReplyId::Value, 10)),
    );
    let r = pkw(sim, vendor_request(Task::Write, DECEL_TIME, 10), &idle)?;
    c.check(
        "PKW write F0.14 = 10: reply 1",
        vendor_reply(&r) == Some((ReplyId::Value, 10)),
    );
    let held = sim.drive_now().read_register(ACCEL_TIME) == Ok(10)
        && sim.drive_now().read_register(DECEL_TIME) == Ok(10);
    c.check("the drive holds F0.13 = F0.14 = 10", held);
    let r = pkw(sim, vendor_request(Task::Read, ACCEL_TIME, 0), &idle)?;
    c.check(
        "PKW read F0.13: reply 1, 10",
        vendor_reply(&r) == Some((ReplyId::Value, 10)),
    );
    let r = pkw(sim, vendor_request(Task::Read, 0xF058, 0), &idle)?;
    c.check(
        "PKW read F0.58 (no such parameter): reply 7, 0x02 illegal address",
        vendor_reply(&r) == Some((ReplyId::Refused, 0x02)),
    );
    let r = pkw(sim, vendor_request(Task::Write, 0xD000, 1), &idle)?;
    c.check(
        "PKW write D0.00 (a status value): reply 7, 0x11 access restricted",
        vendor_reply(&r) == Some((ReplyId::Refused, 0x11)),
    );
    let r = pkw(sim, vendor_request(Task::Write, SET_FREQUENCY, 9000), &idle)?;
    c.check(
        "PKW write F0.29 above F0.10: reply 7, 0x03 invalid data",
        vendor_reply(&r) == Some((ReplyId::Refused, 0x03)),
    );
    let r = pkw(
        sim,
        vendor_request(Task::Unknown(5), SET_FREQUENCY, 0),
        &idle,
    )?;
    c.check(
        "PKW task 5: reply 7, 0x01 illegal operation",
        vendor_reply(&r) == Some((ReplyId::Refused, 0x01)),
    );

    // Run at 25.00 Hz: the ramp of 1.0 s to 50.00 Hz gets there in 0.5 s.
    let mut out = vec![0, 0, 0, 0, START, 2500];
    put(sim, &out);
    let accelerating = wait(sim, 100_000, |i, _| {
        i[4] & status::ACCELERATING != 0 && i[5] > 0
    })?;
    c.check(
        "run: status word accelerating, output frequency rising",
        accelerating,
    );
    let at_setpoint = wait(sim, 700_000, |i, d| {
        i[4] & status::AT_SETPOINT != 0 && i[5] == 2500 && d.output_frequency() == 2500
    })?;
    c.check(
        "run: at setpoint 25.00 Hz within the ramp time (PZD2 in = D0.00)",
        at_setpoint,
    );
    out[4] = START | control::REVERSE;
    put(sim, &out);
    let reversed = wait(sim, 1_500_000, |i, d| {
        i[4] & status::REVERSE != 0 && i[4] & status::AT_SETPOINT != 0 && d.reverse()
    })?;
    c.check("reverse: through zero to 25.00 Hz reverse", reversed);
    out[4] = START | control::QUICK_STOP;
    put(sim, &out);
    let t0 = sim.now_us();
    let stopped = wait(sim, 300_000, |i, _| {
        i[4] & status::ZERO_SPEED != 0 && i[5] == 0
    })?;
    let quick_ms = (sim.now_us() - t0) / 1000;
    // From 25.00 Hz at a tenth of the 1.0 s deceleration: 50 ms, plus the link's delay.
    c.check(
        format!("quick stop: zero speed in {quick_ms} ms (< 100)"),
        stopped && quick_ms < 100,
    );
    out[4] = START;
    put(sim, &out);
    wait(sim, 700_000, |i, _| i[4] & status::AT_SETPOINT != 0)?;
    out[4] = START | control::COAST_STOP;
    put(sim, &out);
    let t0 = sim.now_us();
    let coasted = wait(sim, 100_000, |i, _| i[5] == 0)?;
    c.check(
        format!("coast stop: output off at once ({} us)", sim.now_us() - t0),
        coasted && sim.now_us() - t0 < 5_000,
    );

    // A drive fault: status word, DE.00 through PKW, the diagnosis; the fault reset.
    out[4] = START;
    put(sim, &out);
    sim.drive_now().inject_fault(12);
    let faulted = wait(sim, 50_000, |i, _| i[4] & status::FAULT != 0)?;
    c.check("Fu.012: the status word shows the fault", faulted);
    let r = pkw(sim, vendor_request(Task::Read, 0xDE00, 0), &out[4..])?;
    c.check(
        "PKW read DE.00: 0x8C (Fu.012)",
        vendor_reply(&r) == Some((ReplyId::Value, 0x8C)),
    );
    let diag = wait_diag(sim, 50_000, profidrive::app::EXT_DIAG_DRIVE_FAULT)?;
    c.check(
        format!("the diagnosis shows the drive fault ({diag:02X?})"),
        super::support::link_flags(&diag)
            .is_some_and(|f| f & profidrive::app::EXT_DIAG_DRIVE_FAULT != 0),
    );
    out[4] = START | control::FAULT_RESET;
    put(sim, &out);
    let reset = wait(sim, 50_000, |i, d| {
        i[4] & status::FAULT == 0 && d.fault().is_none()
    })?;
    c.check("fault reset (control bit 15): fault cleared", reset);
    out[4] = START;
    put(sim, &out);

    // The drive link lost: PZD1 0xC022, the diagnosis, PKW refused with 0x22; and back.
    sim.drive_now().link_fault = LinkFault::Disconnected;
    let lost = wait(sim, 50_000, |i, _| i[4] == 0xC022)?;
    c.check("cable out: PZD1 = 0xC022 (no answer) within 50 ms", lost);
    let diag = wait_diag(sim, 50_000, profidrive::app::EXT_DIAG_LINK_LOST_TEMPORARILY)?;
    c.check(
        format!("the diagnosis: drive link lost ({diag:02X?})"),
        super::support::link_flags(&diag)
            .is_some_and(|f| f & profidrive::app::EXT_DIAG_LINK_LOST_TEMPORARILY != 0),
    );
    let end = sim.now + LED_ACTIVITY_US * TICKS_PER_US * 3 / 2;
    sim.run_until(end, |s| s.bridge.status.leds.rx == Led::Off)?;
    let leds = sim.bridge.status.leds;
    c.check(format!(
            "cable out: TX flashes, RX off within {} ms, Run blinks 2 Hz (tx {:?}, rx {:?}, run {:?})",
            LED_ACTIVITY_US / 1000,
            leds.tx, leds.rx, leds.run
        ),
        (leds.tx, leds.rx, leds.run) == (Led::Blink4Hz, Led::Off, Led::Blink2Hz),
    );
    c.check(
        format!(
            "cable out: the host LED blinks red, lost for now ({:?})",
            leds.host
        ),
        leds.host == HostLed::RedBlink,
    );
    let r = pkw(sim, vendor_request(Task::Read, ACCEL_TIME, 0), &out[4..])?;
    c.check(
        "PKW to a drive that does not answer: reply 7, 0x22",
        vendor_reply(&r) == Some((ReplyId::Refused, 0x22)),
    );
    sim.drive_now().link_fault = LinkFault::CrcError;
    let crc = wait(sim, 50_000, |i, _| i[4] == 0xC023)?;
    c.check("answers with a bad CRC: PZD1 = 0xC023", crc);
    sim.drive_now().link_fault = LinkFault::None;
    let back = wait(sim, 50_000, |i, _| {
        i[4] & 0xFF00 != 0xC000 && i[4] & status::RUNNING != 0
    })?;
    let leds = sim.bridge.status.leds;
    c.check(format!(
            "cable back: the status word again, the drive running; TX and RX flash, Run flashes 1 Hz (tx {:?}, rx {:?}, run {:?})",
            leds.tx, leds.rx, leds.run
        ),
        back && (leds.tx, leds.rx, leds.run) == (Led::Blink4Hz, Led::Blink4Hz, Led::Flash1Hz),
    );
    c.check(
        format!("cable back: the host LED green ({:?})", leds.host),
        leds.host == HostLed::Green,
    );
    // One answer after the adapter's 2 ms timeout: it costs that transaction (retried), and
    // the link is back on the next one; it is not read as the start of the next answer.
    sim.bridge.drive.late_once_us = Some(2_500);
    sim.run_for_us(50_000)?;
    let i = inputs(sim);
    c.check(
        format!(
            "one late drive answer: no lasting C0xx (PZD1 {:04X}, link error {:02X})",
            i[4], sim.bridge.status.drive_link_error
        ),
        i[4] & 0xFF00 != 0xC000 && sim.bridge.status.drive_link_error == 0,
    );

    // Another mapping through the user parameters: PZD2 in from D0.04 (output current).
    let mut prm = UserPrm::DEFAULT;
    prm.rd_pzd[0] = FunctionCode(OUTPUT_CURRENT);
    let ok = start(sim, setup(Ppo::Ppo1, prm))?;
    put(sim, &out);
    let remapped = ok
        && wait(sim, 700_000, |i, d| {
            i[5] != 0 && i[5] == d.output_frequency() / 10 && d.output_frequency() == 2500
        })?;
    c.check("RdPZD2 = D0.04: PZD2 in is the output current", remapped);

    // Issue 30: in the vendor mode the drive's group 51 shows the RdPZD/WrPZD mapping in force
    // (PZD3 out F0.13 = 113, PZD3 in D0.04 = 2104), and a 51.05 set at the panel is not taken:
    // the master's user parameters rule, and the group shows them again.
    let mut prm = UserPrm::DEFAULT;
    prm.wr_pzd[1] = FunctionCode(ACCEL_TIME);
    prm.rd_pzd[1] = FunctionCode(OUTPUT_CURRENT);
    let ok = start(sim, setup(Ppo::Ppo2, prm))?;
    let shown = ok
        && wait_drive(sim, 200_000, |d| {
            group(d, fb::PZD3_OUT) == 113 && group(d, fb::PZD3_OUT + 1) == 2104
        })?;
    c.check(
        "PPO2, WrPZD3 = F0.13, RdPZD3 = D0.04: the drive's 51.05 shows 113 and 51.06 2104",
        shown,
    );
    set_at_panel_and_refresh(sim, fb::PZD3_OUT, 114);
    let kept = wait_drive(sim, 1_500_000, |d| {
        group(d, fb::PAR_REFRESH) == fieldbus::DONE && group(d, fb::PZD3_OUT) == 113
    })?;
    c.check(
        "51.05 = 114 at the panel and a refresh: not taken, 51.05 shows 113 again",
        kept,
    );

    // Issue 30, the LEDs (README "Differences from the manuals"): a RdPZD code that is no drive
    // parameter (0x1234) is refused at Set_Prm, the DP way: Prm_Fault, no data exchange, Net
    // blinking (seed 000: DP communication wrong), Run off, error 2 Hz (seed 004: user
    // parameter data wrong), not seed 000's FAQ's Net on with Run 2 Hz.
    let mut prm = UserPrm::DEFAULT;
    prm.rd_pzd[0] = FunctionCode(0x1234);
    let exchanging = start(sim, setup(Ppo::Ppo1, prm))?;
    let end = sim.now + 500_000 * TICKS_PER_US;
    let shown = sim.run_until(end, |s| {
        let l = s.bridge.status.leds;
        (l.net, l.run, l.error) == (Led::Blink2Hz, Led::Off, Led::Blink2Hz)
    })?;
    let leds = sim.bridge.status.leds;
    c.check(
        format!(
            "RdPZD2 = 0x1234 (no drive parameter): Prm_Fault, Net 2 Hz, Run off, error 2 Hz (net {:?}, run {:?}, error {:?})",
            leds.net, leds.run, leds.error
        ),
        !exchanging && shown && super::support::diag_flags(sim).is_some_and(|f| f.contains(DiagnosticFlags::PARAMETER_FAULT)),
    );
    let ok = start(sim, setup(Ppo::Ppo1, UserPrm::DEFAULT))?;
    c.check("the default user parameters again: data exchange", ok);
    Ok(Vec::new())
}

/// 51.`index` as the drive holds it (u16::MAX where it cannot be read).
fn group(d: &DriveSim, index: u8) -> u16 {
    d.read_register(fieldbus::code(index).0).unwrap_or(u16::MAX)
}

/// `value` set at the drive's panel in 51.`index`, then the refresh (51.27) that hands the
/// group to the adapter.
fn set_at_panel_and_refresh<F: Firmware>(sim: &mut CoSim<F>, index: u8, value: u16) {
    let _ = sim.drive_now().set_at_panel(fieldbus::code(index).0, value);
    let _ = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::PAR_REFRESH).0, fieldbus::REFRESH);
}

/// A PROFIdrive PKW request (seed 004's parameter channel).
pub(crate) fn pd_request(label: RequestLabel, pnu: u16, index: u8, value: u32) -> [u16; 4] {
    let w = words(
        &Frame {
            label: label.into(),
            pnu,
            index,
            value,
        }
        .encode(),
    );
    [w[0], w[1], w[2], w[3]]
}

/// A PROFIdrive PKW reply: (response label, value or error number).
pub(crate) fn pd_reply(reply: &Option<Vec<u16>>) -> Option<(ResponseLabel, u32)> {
    reply.as_ref().map(|r| {
        let frame = Frame::decode(
            &r.iter()
                .flat_map(|w| w.to_be_bytes())
                .collect::<Vec<_>>()
                .try_into()
                .unwrap(),
        );
        (frame.response_label(), frame.value)
    })
}

/// Seed 004's PROFIdrive profile on the same drive, PPO1: the state machine to Operation,
/// speed reference and actual value scaled to 0x4000, reverse by a negative reference, OFF3
/// quick stop and OFF2 coast stop, drive parameters and PROFIdrive parameters through the
/// parameter channel with their error numbers, a fault in 945 and its acknowledgement.
pub fn profidrive<F: Firmware>(sim: &mut CoSim<F>, c: &mut Checks, _: Baud) -> io::Result<Report> {
    let prm = UserPrm {
        operation: OperationMode::Profidrive,
        ..UserPrm::DEFAULT
    };
    let ok = start(sim, setup(Ppo::Ppo1, prm))?;
    c.check("PPO1, PROFIdrive profile: data exchange", ok);
    let mut out = vec![0, 0, 0, 0, pd::READY, 0x2000];
    put(sim, &out);
    let ready = wait(sim, 100_000, |i, _| i[4] & pds::RDY_ON != 0)?;
    c.check("READY (0x047E): status word ready to switch on", ready);
    // Drive parameters 113/114 (F0.13/F0.14): ramps of 1.0 s.
    for pnu_number in [113u16, 114] {
        let r = pkw(
            sim,
            pd_request(
                RequestLabel::WriteWord,
                pnu_number >> 8,
                pnu_number as u8,
                10,
            ),
            &out[4..],
        )?;
        c.check(
            format!("PKW write drive parameter {pnu_number} = 10: accepted"),
            // Seed 004's request table: a word written with label 2 is answered label 1.
            pd_reply(&r).is_some_and(|(l, v)| l == ResponseLabel::Word && v == 10),
        );
    }
    let r = pkw(sim, pd_request(RequestLabel::Read, 918, 0, 0), &out[4..])?;
    c.check(
        "PKW read 918 (node address): 8",
        pd_reply(&r) == Some((ResponseLabel::Word, u32::from(SWITCH_ADDRESS))),
    );
    let r = pkw(sim, pd_request(RequestLabel::Read, 999, 0, 0), &out[4..])?;
    c.check(
        "PKW read 999 (no such parameter): error 0",
        pd_reply(&r) == Some((ResponseLabel::Error, 0)),
    );
    let r = pkw(
        sim,
        pd_request(RequestLabel::WriteWord, 2100 >> 8, 2100u16 as u8, 5),
        &out[4..],
    )?;
    c.check(
        "PKW write drive parameter 2100 (D0.00, a status value): error 1, read only",
        pd_reply(&r) == Some((ResponseLabel::Error, 1)),
    );
    sim.drive_now().link_fault = LinkFault::NoAnswer;
    let r = pkw(sim, pd_request(RequestLabel::Read, 0, 113, 0), &out[4..])?;
    c.check(
        "PKW read 113 from a drive that does not answer: error 111, timeout",
        pd_reply(&r) == Some((ResponseLabel::Error, 111)),
    );
    // The lost link the PROFIdrive way (issue 18): TRIPPED, not C0xxh; 945[1] = 7510h.
    let tripped = wait(sim, 100_000, |i, _| {
        i[4] & pds::TRIPPED != 0 && i[4] & 0xFF00 != profidrive::drive::PZD1_LINK_ERROR
    })?;
    let r = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 945, 1, 0),
        &out[4..],
    )?;
    c.check(
        "the drive link lost in the PROFIdrive mode: status word TRIPPED (no C0xxh), 945[1] = 7510h",
        tripped && pd_reply(&r) == Some((ResponseLabel::ArrayWord, 0x7510)),
    );
    // Latched (issue 30): TRIPPED holds with the link back until a RESET, which moves 945's
    // entry to the history; then SWITCH-ON INHIBIT until ON goes 0 -> 1.
    sim.drive_now().link_fault = LinkFault::None;
    let cleared_by_itself = wait(sim, 100_000, |i, _| i[4] & pds::TRIPPED == 0)?;
    let r = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 945, 1, 0),
        &out[4..],
    )?;
    c.check(
        "the link back: TRIPPED holds, 945[1] still 7510h, until a RESET",
        !cleared_by_itself && pd_reply(&r) == Some((ResponseLabel::ArrayWord, 0x7510)),
    );
    // RESET with ON still 1: SWITCH-ON INHIBIT holds while ON stays 1.
    out[4] = pd::OPERATE | pd::RESET;
    put(sim, &out);
    let inhibited = wait(sim, 100_000, |i, _| {
        i[4] & pds::TRIPPED == 0 && i[4] & pds::SWC_ON_INHIB != 0
    })?;
    out[4] = pd::OPERATE;
    put(sim, &out);
    let r1 = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 945, 1, 0),
        &out[4..],
    )?;
    let r9 = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 945, 9, 0),
        &out[4..],
    )?;
    let still_inhibited = wait(sim, 20_000, |i, _| i[4] & pds::SWC_ON_INHIB != 0)?;
    c.check(
        "RESET: TRIPPED clears to SWITCH-ON INHIBIT (held while ON stays 1), 945[1] = 0 and 945[9] = 7510h (the history)",
        inhibited
            && still_inhibited
            && pd_reply(&r1) == Some((ResponseLabel::ArrayWord, 0))
            && pd_reply(&r9) == Some((ResponseLabel::ArrayWord, 0x7510)),
    );
    // ON 0 -> 1.
    out[4] = pd::READY;
    put(sim, &out);
    wait(sim, 50_000, |i, _| i[4] & pds::RDY_ON != 0)?;
    out[4] = pd::OPERATE;
    put(sim, &out);
    let running = wait(sim, 800_000, |i, d| {
        i[4] & pds::AT_SETPOINT != 0 && i[5] == 0x2000 && d.output_frequency() == 2500
    })?;
    c.check(
        "OPERATE, reference 0x2000: the drive at 25.00 Hz, actual 0x2000, at setpoint",
        running,
    );
    out[5] = 0xE000; // -0x2000
    put(sim, &out);
    let reversed = wait(sim, 1_500_000, |i, d| i[5] == 0xE000 && d.reverse())?;
    c.check(
        "reference -0x2000: reverse at 25.00 Hz, actual -0x2000",
        reversed,
    );
    out[4] = pd::OPERATE & !pd::NO_OFF3;
    put(sim, &out);
    let t0 = sim.now_us();
    let off3 = wait(sim, 300_000, |i, d| i[5] == 0 && d.output_frequency() == 0)?;
    c.check(
        format!(
            "OFF3 (quick stop): zero speed in {} ms",
            (sim.now_us() - t0) / 1000
        ),
        off3 && sim.now_us() - t0 < 100_000,
    );
    out = vec![0, 0, 0, 0, pd::READY, 0x2000];
    put(sim, &out);
    wait(sim, 50_000, |i, _| i[4] & pds::RDY_ON != 0)?;
    out[4] = pd::OPERATE;
    out[5] = 0x2000;
    put(sim, &out);
    wait(sim, 800_000, |i, _| i[4] & pds::AT_SETPOINT != 0)?;
    out[4] = pd::OPERATE & !pd::NO_OFF2;
    put(sim, &out);
    let off2 = wait(sim, 20_000, |_, d| d.output_frequency() == 0)?;
    c.check("OFF2 (coast stop): output off at once", off2);
    out[4] = pd::READY;
    put(sim, &out);
    wait(sim, 50_000, |i, _| i[4] & pds::RDY_ON != 0)?;
    out[4] = pd::OPERATE;
    put(sim, &out);
    sim.drive_now().inject_fault(12);
    let tripped = wait(sim, 50_000, |i, _| i[4] & pds::TRIPPED != 0)?;
    c.check("Fu.012: status word bit 3 (fault)", tripped);
    let r = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 945, 1, 0),
        &out[4..],
    )?;
    let number = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 947, 1, 0),
        &out[4..],
    )?;
    c.check(
        "PKW read 945[1] (fault code): 1000h, DRIVECOM generic; 947[1] (fault number): 12",
        pd_reply(&r) == Some((ResponseLabel::ArrayWord, 0x1000))
            && pd_reply(&number) == Some((ResponseLabel::ArrayWord, 12)),
    );
    let diag = wait_diag(sim, 50_000, profidrive::app::EXT_DIAG_DRIVE_FAULT)?;
    c.check(
        format!("the diagnosis shows the drive fault ({diag:02X?})"),
        super::support::link_flags(&diag)
            .is_some_and(|f| f & profidrive::app::EXT_DIAG_DRIVE_FAULT != 0),
    );
    out[4] = pd::READY | pd::RESET;
    put(sim, &out);
    let acknowledged = wait(sim, 50_000, |i, d| {
        i[4] & pds::TRIPPED == 0 && d.fault().is_none()
    })?;
    c.check("fault acknowledge (bit 7): fault cleared", acknowledged);
    // Seed 004 line 334 on a 60.00 Hz drive (issue 18): 4000h is the rated frequency, read
    // from the drive's F0.10 at the next parameterisation (the user parameter left at 0).
    let set = sim
        .drive_now()
        .write_register(profidrive::codes::named::MAX_FREQUENCY, 6000, true);
    let ok = start(sim, setup(Ppo::Ppo1, prm))?;
    c.check(
        "F0.10 = 60.00 Hz, parameterised again: data exchange",
        set.is_ok() && ok,
    );
    out = vec![0, 0, 0, 0, pd::READY, 0x4000];
    put(sim, &out);
    wait(sim, 100_000, |i, _| i[4] & pds::RDY_ON != 0)?;
    out[4] = pd::OPERATE;
    put(sim, &out);
    let rated = wait(sim, 2_000_000, |i, d| {
        i[4] & pds::AT_SETPOINT != 0 && i[5] == 0x4000 && d.output_frequency() == 6000
    })?;
    c.check(
        "a 60.00 Hz drive, reference 0x4000: the drive at 60.00 Hz, actual 0x4000",
        rated,
    );
    Ok(Vec::new())
}

/// The drive's fieldbus group 51 (seed 004, table 5) in the PROFIdrive profile, PPO2: what the
/// adapter shows there, a PZD3 mapping set at the drive's panel that takes effect on FBA PAR
/// REFRESH and not before, a 916 write that lands in the group, a node address the switch
/// overrules, and, with the switch at 0, a node address that moves the adapter without a
/// power cycle.
pub fn fieldbus_group<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    _: Baud,
) -> io::Result<Report> {
    let prm = UserPrm {
        operation: OperationMode::Profidrive,
        ..UserPrm::DEFAULT
    };
    let ok = start(sim, setup(Ppo::Ppo2, prm))?;
    c.check("PPO2, PROFIdrive profile: data exchange", ok);
    let mut out = vec![0, 0, 0, 0, pd::READY, 0x2000, 0, 0, 0, 0];
    put(sim, &out);
    let shown = wait(sim, 100_000, |_, d| {
        [1, 2, 3, 4, 21].map(|i| group(d, i)) == [fieldbus::MODULE_TYPE_PROFIBUS_DP, 8, 1500, 2, 0]
    })?;
    let d = sim.drive_now();
    c.check(
        format!(
            "51.01-51.04 show PROFIBUS DP, address 8, 1500 kbit/s, PPO2 (drive holds {:?})",
            [1, 2, 3, 4].map(|i| group(d, i))
        ),
        shown,
    );
    let refused = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::PPO_TYPE).0, 5);
    c.check(
        "51.04 is read-only at the drive's panel",
        refused == Err(profidrive::drive::DriveError::AccessRestricted),
    );

    // PZD3 OUT -> 113 (F0.13, acceleration time), PZD3 IN <- 2104 (D0.04, output current).
    let accel_before = sim.drive_now().read_register(ACCEL_TIME);
    let panel = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::PZD3_OUT).0, 113)
        .and_then(|()| {
            sim.drive_now()
                .set_at_panel(fieldbus::code(fb::PZD3_OUT + 1).0, 2104)
        });
    c.check("panel: 51.05 = 113, 51.06 = 2104", panel.is_ok());
    out[6] = 30;
    put(sim, &out);
    sim.run_for_us(100_000)?;
    c.check(
        "not in force before the refresh: F0.13 unchanged",
        sim.drive_now().read_register(ACCEL_TIME) == accel_before,
    );
    let t0 = sim.now_us();
    let _ = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::PAR_REFRESH).0, fieldbus::REFRESH);
    let refreshed = wait(sim, 1_000_000, |_, d| {
        d.read_register(ACCEL_TIME) == Ok(30) && group(d, fb::PAR_REFRESH) == fieldbus::DONE
    })?;
    c.check(
        format!(
            "51.27 REFRESH: PZD3 out reaches F0.13 and 51.27 is DONE in {} ms (poll {} ms)",
            (sim.now_us() - t0) / 1000,
            fieldbus::REFRESH_POLL_US / 1000
        ),
        refreshed,
    );
    let r915 = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 915, 3, 0),
        &out[4..],
    )?;
    let r916 = pkw(
        sim,
        pd_request(RequestLabel::ReadArray, 916, 3, 0),
        &out[4..],
    )?;
    c.check(
        "915[3] = 113 and 916[3] = 2104, as the drive set them",
        pd_reply(&r915) == Some((ResponseLabel::ArrayWord, 113))
            && pd_reply(&r916) == Some((ResponseLabel::ArrayWord, 2104)),
    );
    // A 916 write from the master lands in the drive's group: PZD4 IN <- 2100 (D0.00).
    let r = pkw(
        sim,
        pd_request(RequestLabel::WriteArrayWord, 916, 4, 2100),
        &out[4..],
    )?;
    let written = pd_reply(&r) == Some((ResponseLabel::ArrayWord, 2100))
        && wait(sim, 100_000, |_, d| group(d, fb::PZD3_OUT + 3) == 2100)?;
    c.check(
        "916[4] = 2100 written by the master: the drive's 51.08 follows",
        written,
    );
    out[4] = pd::OPERATE;
    put(sim, &out);
    // F0.13 is now 3.0 s from 0 to 50.00 Hz: 25.00 Hz in 1.5 s.
    let running = wait(sim, 2_500_000, |i, d| {
        let f = d.output_frequency();
        i[5] == 0x2000
            && f == 2500
            && i[6] == d.read_register(OUTPUT_CURRENT).unwrap_or(0)
            && i[7] == f
    })?;
    c.check(
        "running at 0x2000: PZD3 in is D0.04 (current), PZD4 in is D0.00 (frequency)",
        running,
    );

    // The switch sets the address: a 51.02 from the panel does not move the adapter.
    set_at_panel_and_refresh(sim, fb::NODE_ADDRESS, 20);
    let kept = wait(sim, 1_000_000, |_, d| {
        group(d, fb::PAR_REFRESH) == fieldbus::DONE && group(d, fb::NODE_ADDRESS) == 8
    })?;
    c.check(
        "switch at 8: 51.02 = 20 and a refresh leave the adapter at 8, and 51.02 shows 8 again",
        kept && sim.bridge.status.address == SWITCH_ADDRESS
            && sim.master.as_mut().is_some_and(|m| m.running()),
    );

    // The switch at 0: the address is the stored one until the drive sets another.
    sim.stop_master();
    sim.bridge.switch = 0;
    sim.power_cycle()?;
    let shown = wait_drive(sim, 100_000, |d| group(d, fb::NODE_ADDRESS) == 126)?;
    c.check(
        "switch 0, empty storage: address 126, and 51.02 shows it",
        shown && sim.bridge.status.address == 126,
    );
    set_at_panel_and_refresh(sim, fb::NODE_ADDRESS, 30);
    let t0 = sim.now_us();
    let moved = wait_drive(sim, 1_000_000, |d| {
        group(d, fb::PAR_REFRESH) == fieldbus::DONE
    })? && sim.bridge.status.address == 30;
    c.check(
        format!(
            "51.02 = 30 and a refresh: the adapter answers at 30 after {} ms, no power cycle",
            (sim.now_us() - t0) / 1000
        ),
        moved,
    );
    c.check(
        "the storage keeps address 30",
        sim.bridge
            .stored()?
            .address
            .is_some_and(|r| r.address == 30),
    );
    let mut at_30 = setup(Ppo::Ppo2, prm);
    at_30.slave_address = 30;
    let ok = start(sim, at_30)?;
    out[4] = pd::READY;
    out[6] = 40;
    put(sim, &out);
    let mapped = ok && wait(sim, 100_000, |_, d| d.read_register(ACCEL_TIME) == Ok(40))?;
    c.check(
        "data exchange at 30; the drive's PZD3 mapping read at power-up (PZD3 out -> F0.13)",
        mapped,
    );

    // Seed 004 lines 1490 and 1542-1552 (issue 18): 918 stores an address for the next
    // restart; 970-972 need the motor stopped; 972 restarts the module at the stored address.
    let r = pkw(
        sim,
        pd_request(RequestLabel::WriteWord, 918, 0, 40),
        &out[4..],
    )?;
    c.check(
        "PKW write 918 = 40 (switch at 0): accepted, the storage keeps 40, the adapter still at 30",
        pd_reply(&r) == Some((ResponseLabel::Word, 40))
            && sim
                .bridge
                .stored()?
                .address
                .is_some_and(|r| r.address == 40)
            && sim.bridge.status.address == 30,
    );
    out[4] = pd::OPERATE;
    out[5] = 0x1000;
    put(sim, &out);
    let running = wait(sim, 500_000, |_, d| d.output_frequency() > 0)?;
    let r = pkw(
        sim,
        pd_request(RequestLabel::WriteWord, 971, 0, 1),
        &out[4..],
    )?;
    c.check(
        "the motor running: PKW write 971 = 1 is error 17 (needs the motor stopped)",
        running && pd_reply(&r) == Some((ResponseLabel::Error, 17)),
    );
    out[4] = pd::READY;
    out[5] = 0;
    put(sim, &out);
    wait(sim, 1_000_000, |_, d| d.output_frequency() == 0)?;
    out[..4].copy_from_slice(&pd_request(RequestLabel::WriteWord, 972, 0, 1));
    put(sim, &out);
    let t0 = sim.now_us();
    let end = sim.now + 500_000 * TICKS_PER_US;
    let moved = sim.run_until(end, |s| s.bridge.status.address == 40)?;
    c.check(
        format!(
            "the motor stopped: 972 = 1 restarts the module at 40 after {} ms",
            (sim.now_us() - t0) / 1000
        ),
        moved,
    );
    let mut at_40 = setup(Ppo::Ppo2, prm);
    at_40.slave_address = 40;
    let ok = start(sim, at_40.clone())?;
    let r = pkw(sim, pd_request(RequestLabel::Read, 972, 0, 0), &out[4..])?;
    c.check(
        "data exchange at 40; 972 reads 0 again after the restart",
        ok && pd_reply(&r) == Some((ResponseLabel::Word, 0)),
    );

    // Seed 004 line 921 and 971 (issue 30 item 2): 971 keeps the settings in the storage,
    // and a power cycle brings them back.
    let write_928 = pkw(
        sim,
        pd_request(RequestLabel::WriteWord, 928, 0, 0),
        &out[4..],
    )?;
    let write_971 = pkw(
        sim,
        pd_request(RequestLabel::WriteWord, 971, 0, 1),
        &out[4..],
    )?;
    sim.run_for_us(1_000)?;
    let kept = sim.bridge.stored()?.params;
    c.check(
        "928 = 0, then 971 = 1 with the motor stopped: both accepted, the storage keeps 928 = 0",
        pd_reply(&write_928) == Some((ResponseLabel::Word, 0))
            && pd_reply(&write_971) == Some((ResponseLabel::Word, 1))
            && kept.is_some_and(|p| p.pzd_rights == 0),
    );
    sim.stop_master();
    sim.power_cycle()?;
    let ok = start(sim, at_40)?;
    let r = pkw(sim, pd_request(RequestLabel::Read, 928, 0, 0), &out[4..])?;
    c.check(
        "after a power cycle: data exchange at 40, and 928 reads 0, as 971 kept it",
        ok && pd_reply(&r) == Some((ResponseLabel::Word, 0)),
    );
    Ok(Vec::new())
}

/// Runs until `done(drive)` holds (checked every millisecond), at most `limit_us`.
fn wait_drive<F: Firmware>(
    sim: &mut CoSim<F>,
    limit_us: u64,
    mut done: impl FnMut(&DriveSim) -> bool,
) -> io::Result<bool> {
    let end = sim.now_us() + limit_us;
    loop {
        if done(sim.drive_now()) {
            return Ok(true);
        }
        if sim.now_us() >= end {
            return Ok(false);
        }
        sim.run_for_us(1_000)?;
    }
}

/// A Global_Control Clear_Data from the master's address, sent by the commissioning tool
/// (profirust 0.6 cannot send one): the PLC stopped.
pub(crate) fn plc_stop<F: Firmware>(sim: &mut CoSim<F>, setup: &MasterSetup) -> io::Result<()> {
    global_control(sim, setup, dp_consts::control_command::CLEAR_DATA)
}

/// A Global_Control with `command` to every group from the master's address, sent by the
/// commissioning tool (profirust 0.6 sends none).
pub(crate) fn global_control<F: Firmware>(
    sim: &mut CoSim<F>,
    setup: &MasterSetup,
    command: u8,
) -> io::Result<()> {
    let payload = [command, 0];
    let bytes = super::support::service_request(
        setup.slave_address,
        setup.address,
        Sap::GLOBAL_CONTROL,
        RequestFunction::SdnLow,
        false,
        &payload,
    );
    sim.tool_request(setup.clone(), &bytes, 100)?;
    Ok(())
}

/// Each fail-safe mode (seed 004, extended Prm_Data byte 8), on a PLC stop (Global_Control
/// Clear) and on a communication loss (the DP watchdog): what the drive is told.
pub fn fail_safe_modes<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    _: Baud,
) -> io::Result<Report> {
    let fail_safe_pzd = {
        let mut pzd = [0u16; 10];
        pzd[0] = START;
        pzd[1] = 1234;
        pzd
    };
    for mode in [
        FailSafeMode::Stop,
        FailSafeMode::LastSpeed,
        FailSafeMode::UseFailSafeValues,
    ] {
        for cause in ["PLC stop", "communication loss"] {
            let prm = UserPrm {
                fail_safe: mode,
                fail_safe_pzd,
                ..UserPrm::DEFAULT
            };
            let setup = setup(Ppo::Ppo3, prm);
            let ok = start(sim, setup.clone())?;
            put(sim, &[START, 3000]);
            let running = ok
                && wait(sim, 100_000, |_, d| {
                    d.control_word() == START && d.read_register(SET_FREQUENCY) == Ok(3000)
                })?;
            c.check(
                format!("{mode:?}, {cause}: the drive runs at 30.00 Hz first"),
                running,
            );
            if cause == "PLC stop" {
                plc_stop(sim, &setup)?;
            } else {
                sim.stop_master();
                // The master's watchdog is 200 ms.
            }
            sim.run_for_us(if cause == "PLC stop" { 20_000 } else { 250_000 })?;
            let d = sim.drive_now();
            let (cw, f) = (
                d.control_word(),
                d.read_register(SET_FREQUENCY).unwrap_or(0),
            );
            let (want, ok) = match mode {
                FailSafeMode::Stop => ("run bit off", cw & control::RUN == 0),
                FailSafeMode::LastSpeed => ("run at 30.00 Hz", cw == START && f == 3000),
                FailSafeMode::UseFailSafeValues => (
                    "the fail-safe PZD: run at 12.34 Hz",
                    cw == START && f == 1234,
                ),
            };
            c.check(
                format!("{mode:?}, {cause}: the drive gets {want} (CW {cw:04X}, F0.29 {f})"),
                ok,
            );
        }
    }
    Ok(Vec::new())
}

/// Adapter latency per PPO at 1.5 Mbit/s, in simulated time: from a PZD output arriving at
/// the adapter (the end of the Data_Exchange request that first carries it) to the drive
/// applying it; and from a drive status change to the end of the first Data_Exchange
/// response that carries it. Each figure is the worst of 20 changes at varying phases.
pub fn latency<F: Firmware>(sim: &mut CoSim<F>, c: &mut Checks, _: Baud) -> io::Result<Report> {
    let mut report = Vec::new();
    for ppo in [Ppo::Ppo1, Ppo::Ppo2, Ppo::Ppo3, Ppo::Ppo4, Ppo::Ppo5] {
        let ok = start(sim, setup(ppo, UserPrm::DEFAULT))?;
        c.check(format!("PPO{}: data exchange", ppo.number()), ok);
        let pkw_words = if ppo.has_pkw() { 4 } else { 0 };
        let pzd_words = ppo.pzd_words();
        let mut out = vec![0u16; pkw_words + pzd_words];
        out[pkw_words] = control::REMOTE;
        put(sim, &out);
        wait(sim, 20_000, |_, _| false)?;
        sim.log_dx = true;
        let (mut to_drive, mut to_master, mut to_adapter) = (Vec::new(), Vec::new(), Vec::new());
        let mut parts = Vec::new();
        for n in 0..20u64 {
            // Outputs: a new set frequency in PZD2.
            let value = 100 + n as u16 * 10;
            out[pkw_words + 1] = value;
            put(sim, &out);
            let outputs_before = sim.dx.outputs.len();
            let applied_before = sim.bridge.drive.applied.len();
            wait(sim, 50_000, |_, d| {
                d.read_register(SET_FREQUENCY) == Ok(value)
            })?;
            let arrived = sim.dx.outputs[outputs_before..]
                .iter()
                .find(|(_, o)| words(o).get(pkw_words + 1) == Some(&value))
                .map(|(t, _)| *t);
            let applied = sim.bridge.drive.applied[applied_before..]
                .iter()
                .find(|a| a.words.get(1) == Some(&value))
                .cloned();
            let event = arrived.and_then(|a| {
                sim.bridge
                    .figures
                    .outputs_events
                    .iter()
                    .rev()
                    .copied()
                    .find(|e| e.telegram_end_ns / 1000 == a)
            });
            if let (Some(e), Some(applied)) = (event, &applied) {
                parts.push(OutToDrive::new(&e, applied));
            }
            match (arrived, applied.map(|a| a.at_us)) {
                (Some(a), Some(b)) if b >= a => to_drive.push(b - a),
                _ => c.check(
                    format!("PPO{}: output {value} traced to the drive", ppo.number()),
                    false,
                ),
            }
            // Inputs: a warning on and off flips the status word's bit 14.
            wait(sim, 1_000 + n * 137, |_, _| false)?;
            let warn = n % 2 == 0;
            let changed_at = sim.now_us();
            let inputs_before = sim.dx.inputs.len();
            let answered_before = sim.bridge.drive.answered.len();
            sim.drive_now().set_warning(warn.then_some(36));
            wait(sim, 50_000, |i, _| {
                (i[pkw_words] & status::WARNING != 0) == warn
            })?;
            let seen = sim.dx.inputs[inputs_before..]
                .iter()
                .find(|(_, i)| {
                    words(i)
                        .get(pkw_words)
                        .is_some_and(|sw| (sw & status::WARNING != 0) == warn)
                })
                .map(|(t, _)| *t);
            let at_adapter = sim.bridge.drive.answered[answered_before..]
                .iter()
                .find(|a| {
                    a.words
                        .first()
                        .is_some_and(|sw| (sw & status::WARNING != 0) == warn)
                })
                .map(|a| a.at_us);
            if let Some(t) = at_adapter {
                to_adapter.push(t - changed_at);
            }
            match seen {
                Some(t) => to_master.push(t - changed_at),
                None => c.check(
                    format!("PPO{}: status change traced to the master", ppo.number()),
                    false,
                ),
            }
            wait(sim, 500 + n * 71, |_, _| false)?;
        }
        sim.log_dx = false;
        sim.dx = Default::default();
        let worst = |v: &[u64]| worst_and_median(v).0;
        let median = |v: &mut Vec<u64>| worst_and_median(v).1;
        report.push(format!(
            "latency PPO{}: out->drive={} us, drive->in={} us",
            ppo.number(),
            worst(&to_drive),
            worst(&to_master)
        ));
        report.push(format!(
            "  (worst of {} changes each; medians {} us and {} us; drive->in up to the adapter's input image: worst {} us, median {} us, the rest is the master's poll; seed 000 states {} for its card, target a fifth: {} us)",
            to_drive.len(),
            median(&mut to_drive.clone()),
            median(&mut to_master.clone()),
            worst(&to_adapter),
            median(&mut to_adapter.clone()),
            SEED_000_LATENCY[ppo.number() as usize - 1].0,
            SEED_000_LATENCY[ppo.number() as usize - 1].1,
        ));
        report.push(format!(
            "  out->drive in parts, worst/median us: {}",
            OutToDrive::summary(&parts)
        ));
        c.check(
            format!("PPO{}: every change traced both ways", ppo.number()),
            to_drive.len() == 20 && to_master.len() == 20 && parts.len() == 20,
        );
        let (words, target) = SEED_000_LATENCY[ppo.number() as usize - 1];
        // The worst must be within a fifth of seed 000's figure.
        c.check(
            format!(
                "PPO{}: out->drive worst {} us within a fifth of seed 000's {words} ({target} us)",
                ppo.number(),
                worst(&to_drive)
            ),
            worst(&to_drive) <= target,
        );
        let verdict = |value: u64, bound: u64| if value <= bound { "met" } else { "OVER" };
        report.push(format!(
            "  target: worst {} us <= {target} ({}), median {} us <= {} ({})",
            worst(&to_drive),
            verdict(worst(&to_drive), target),
            median(&mut to_drive.clone()),
            target / 2,
            verdict(median(&mut to_drive.clone()), target / 2),
        ));
    }
    Ok(report)
}

/// One output change from the master to the drive, in its parts (µs): the event through the
/// link to the MCU's interrupt; the MCU finishing the step it was in; the firmware's decision
/// (up to the request's hand-over where the drive link was free); the drive link busy with a
/// transaction that started before (its answer's end); the firmware from then to the
/// request's last byte in its UART; the line's silence before the request; the request's
/// frame; the drive's processing.
#[derive(Clone, Copy, Debug)]
struct OutToDrive([u64; 8]);

impl OutToDrive {
    const NAMES: [&'static str; 8] = [
        "link",
        "mcu busy",
        "decision",
        "drive link busy",
        "firmware to request",
        "line silence",
        "frame",
        "drive",
    ];

    fn new(e: &crate::bridge::OutputsEvent, applied: &drive_sim::line::Applied) -> OutToDrive {
        let us = |ns: u64| ns / 1000;
        let r = applied.request;
        // The decision ends when its writes are out, or earlier where the request was handed
        // over within it (the drive link was free).
        let (handled, handed) = (us(e.handled_ns), r.handed_us.max(us(e.handled_ns)));
        let decided = us(e.decided_ns).clamp(handled, handed);
        let busy_until = r.previous_answer_us.clamp(decided, handed);
        OutToDrive([
            us(e.at_mcu_ns).saturating_sub(us(e.telegram_end_ns)),
            handled.saturating_sub(us(e.at_mcu_ns)),
            decided - handled,
            busy_until - decided,
            handed - busy_until,
            r.start_us - r.handed_us,
            r.end_us - r.start_us,
            applied.at_us - r.end_us,
        ])
    }

    /// Each part's worst and median over `changes`.
    fn summary(changes: &[OutToDrive]) -> String {
        (0..Self::NAMES.len())
            .map(|i| {
                let v: Vec<u64> = changes.iter().map(|c| c.0[i]).collect();
                let (worst, median) = worst_and_median(&v);
                format!("{} {worst}/{median}", Self::NAMES[i])
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The largest of `values` and their (upper) median; 0 for none.
fn worst_and_median(values: &[u64]) -> (u64, u64) {
    let mut sorted = values.to_vec();
    sorted.sort_unstable();
    let worst = sorted.last().copied().unwrap_or(0);
    (worst, sorted.get(sorted.len() / 2).copied().unwrap_or(0))
}

/// Seed 000's latency per PPO (its words) and a fifth of it in microseconds.
const SEED_000_LATENCY: [(&str, u64); 5] = [
    ("<= 3 ms", 600),
    ("<= 4 ms", 800),
    ("< 2 ms", 400),
    ("<= 2 ms", 400),
    ("<= 7 ms", 1400),
];
