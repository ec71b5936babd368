//! What every scenario family uses: the checks, the master's data exchange, its view of the
//! diagnosis, the commissioning tool's probes.

use crate::cosim::{CoSim, MasterSetup};
use crate::firmware::Firmware;
use dp_consts::Baud;
use dp_link::{Led, SlaveState};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, Sap};
use profirust::dp::DiagnosticFlags;
use std::io;

/// The station address the switch sets in most scenarios.
pub const SWITCH_ADDRESS: u8 = 8;

/// A scenario's checks, in order: what, and whether it held.
#[derive(Clone, Debug, Default)]
pub struct Checks(pub Vec<(String, bool)>);

impl Checks {
    pub fn check(&mut self, what: impl Into<String>, ok: bool) {
        self.0.push((what.into(), ok));
    }
}

/// A tool's request from station `sa` to the service `dsap` of station `da` (its SSAP
/// MS0), as bytes on the line.
pub(crate) fn service_request(
    da: u8,
    sa: u8,
    dsap: Sap,
    function: RequestFunction,
    fcb: bool,
    payload: &[u8],
) -> Vec<u8> {
    let request = Repr::Data(DataRepr {
        da,
        sa,
        dsap: Some(dsap),
        ssap: Some(Sap::MASTER_MS0),
        fc: FrameControl::Request {
            fcb,
            fcv: false,
            function,
        },
        payload,
    });
    let mut bytes = vec![0u8; request.buffer_len()];
    request.emit(&mut bytes).expect("a valid request");
    bytes
}

/// Lines a scenario adds to the run's report (figures, not compared with golden files).
pub type Report = Vec<String>;

/// Sim-time limit for reaching a goal: generous, since a miss is a failure, not a hang.
pub fn limit_us(baud: Baud) -> u64 {
    match baud {
        Baud::B9600 | Baud::B19200 => 6_000_000,
        Baud::B45450 | Baud::B93750 => 3_000_000,
        _ => 1_500_000,
    }
}

/// Data exchange cycles that make a rate's run convincing without slowing the slow ones.
pub fn cycles_for(baud: Baud) -> u64 {
    if baud.bits_per_second() < 100_000 {
        10
    } else {
        50
    }
}

/// Runs until the master completed `cycles` more data exchange cycles.
pub fn exchange<F: Firmware>(sim: &mut CoSim<F>, cycles: u64, limit_us: u64) -> io::Result<bool> {
    let start = sim.master.as_ref().map_or(0, |m| m.cycles);
    let end = sim.now + limit_us * 48;
    sim.run_until(end, |s| {
        s.master
            .as_ref()
            .is_some_and(|m| m.cycles >= start + cycles)
    })
}

pub fn diag_flags<F: Firmware>(sim: &mut CoSim<F>) -> Option<DiagnosticFlags> {
    let master = sim.master.as_mut()?;
    let peripheral = master.dp.get_mut(master.handle);
    peripheral.last_diagnostics().map(|d| d.flags)
}

/// The extended diagnosis the master read last (header byte, then the adapter's flags).
pub fn ext_diag<F: Firmware>(sim: &mut CoSim<F>) -> Vec<u8> {
    let Some(master) = sim.master.as_mut() else {
        return Vec::new();
    };
    let peripheral = master.dp.get_mut(master.handle);
    peripheral
        .last_diagnostics()
        .and_then(|d| d.extended_diagnostics.raw_diag_buffer().map(<[u8]>::to_vec))
        .unwrap_or_default()
}

/// The drive link's flags in an extended diagnosis: after the header in DP-V0's form (header
/// 2), or closing DP-V1's status block (header 5, status type 81h, slot 0, specifier 0; seed
/// 004 lines 1098-1113). None for anything else.
pub fn link_flags(ext: &[u8]) -> Option<u8> {
    use profidrive::app::{DPV1_STATUS_BLOCK_LEN, DPV1_STATUS_TYPE, EXT_DIAG_LEN};
    match *ext {
        [EXT_DIAG_LEN, flags] => Some(flags),
        [DPV1_STATUS_BLOCK_LEN, DPV1_STATUS_TYPE, 0, 0, flags] => Some(flags),
        _ => None,
    }
}

/// Runs until the extended diagnosis the master read satisfies `done`, at most `limit_us`;
/// returns the last one read.
pub fn wait_ext_diag<F: Firmware>(
    sim: &mut CoSim<F>,
    limit_us: u64,
    done: impl Fn(&[u8]) -> bool,
) -> io::Result<Vec<u8>> {
    let end = sim.now_us() + limit_us;
    loop {
        let diag = ext_diag(sim);
        if done(&diag) || sim.now_us() >= end {
            return Ok(diag);
        }
        sim.run_for_us(1_000)?;
    }
}

/// The DP-V0 services profirust does not send, each from a commissioning tool (station 3, a
/// second master) after data exchange at `baud`: each must be answered, and as the slave
/// decides in that state (the responder's answers against the firmware's are proven bit for
/// bit by dp-phy's tests; here they are timed on the wire with every other answer).
pub fn probe_services<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<()> {
    use fdl::ResponseStatus as S;
    // Let the last exchange finish on the line (the master's request, the adapter's answer),
    // and its outputs go through the drive and back into the inputs (a few of the drive link's
    // reads of the in block, one every READ_PERIOD_US): Rd_Inp then reads the inputs of the
    // last set frequency, not a race with the drive link (the golden file records its answer).
    let reads_us = 4 * drive_link::READ_PERIOD_US;
    sim.run_for_us(300 * 1_000_000 / u64::from(baud.bits_per_second()) + 2_000 + reads_us)?;
    let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
    // (what, the service's SAP (none: FDL_Status), payload, the answer's status)
    type Probe<'a> = (&'a str, Option<Sap>, &'a [u8], Option<S>);
    let probes: [Probe; 6] = [
        ("FDL_Status", None, &[], Some(S::Ok)),
        ("Get_Cfg", Some(Sap::GET_CFG), &[], Some(S::DataLow)),
        ("Rd_Inp", Some(Sap::RD_INP), &[], Some(S::DataLow)),
        ("Rd_Outp", Some(Sap::RD_OUTP), &[], Some(S::DataLow)),
        (
            "Slave_Diag from another master",
            Some(Sap::SLAVE_DIAG),
            &[],
            Some(S::DataLow),
        ),
        (
            "Set_Slave_Add with the switch set",
            Some(Sap::SET_SLAVE_ADD),
            &[9, hi, lo, 0],
            Some(S::SapNotActivated),
        ),
    ];
    for (name, sap, payload, want) in probes {
        let function = if sap.is_none() {
            RequestFunction::FdlStatus
        } else {
            RequestFunction::SrdLow
        };
        let request = Repr::Data(DataRepr {
            da: SWITCH_ADDRESS,
            sa: 3,
            dsap: sap,
            ssap: sap.map(|_| Sap::MASTER_MS0),
            fc: FrameControl::Request {
                fcb: true,
                fcv: false,
                function,
            },
            payload,
        });
        let mut bytes = vec![0u8; request.buffer_len()];
        request.emit(&mut bytes).expect("a valid request");
        let mut tool = MasterSetup::new(baud, SWITCH_ADDRESS);
        tool.address = 3;
        let slot = u64::from(baud.default_slot_time_bits());
        let answer = sim.tool_request(tool, &bytes, slot)?;
        let status = answer.as_deref().and_then(|a| match Repr::parse_bytes(a) {
            Ok((Repr::Data(d), _)) => match d.fc {
                FrameControl::Response { status, .. } => Some(status),
                _ => None,
            },
            _ => None,
        });
        c.check(format!("{name} at {baud}: {want:?}"), status == want);
    }
    Ok(())
}

/// A master whose parameters or configuration the slave refuses: no data exchange, the
/// master reads the fault in the diagnosis, the error LED blinks at its rate.
pub fn refused<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    setup: MasterSetup,
    (fault, flag): (&str, DiagnosticFlags),
    error_led: Led,
) -> io::Result<()> {
    sim.start_master(setup);
    // Until the master has read the fault, then the master leaves and the bus settles: a
    // fixed time would cut the master's retries at a point that moves with QEMU's timing.
    let end = sim.now + 300_000 * 48;
    let read = sim.run_until(end, |s| diag_flags(s).is_some_and(|f| f.contains(flag)))?;
    c.check(format!("the master reads {fault}"), read);
    c.check(
        "no data exchange",
        sim.bridge.status.state != SlaveState::DataExch,
    );
    // The firmware's status says the slave went back to Wait_Prm (a Cfg_Fault's slave left
    // Wait_Cfg) before the master leaves: at 12 Mbit/s the master reads the fault within a few
    // hundred microseconds, so the two would otherwise land in either order.
    let end = sim.now + 50_000 * 48;
    sim.run_until(end, |s| s.bridge.status.state == SlaveState::WaitPrm)?;
    sim.stop_master();
    sim.run_for_us(20_000)?;
    c.check(
        format!("error LED {error_led:?}"),
        sim.bridge.status.leds.error == error_led,
    );
    Ok(())
}
