//! The DP-V1 scenarios (family "dpv1") of `cargo xtask qemu-test`: PROFIdrive parameter access
//! over MSAC1 (seed 004, "DP-V1 通讯"), with cyclic data flowing through the drive throughout.
//!
//! The drive's 51.21 DP MODE is set to DP-V1 at its panel and taken with a refresh (51.27);
//! the master then parameterises the adapter with DPV1_Status_1-3 (DPV1_Enable) and reaches
//! data exchange with PPO3 or PPO4, which have no PKW: the parameters are reached only over
//! DP-V1. Every request goes through `msac1_master` (profirust's FDL station), and every
//! check reads what the master received or what the drive simulator holds.

use super::support::{diag_flags, link_flags, wait_ext_diag, Checks, Report, SWITCH_ADDRESS};
use crate::cosim::{echo_user_prm, CoSim, MasterSetup, Program};
use crate::firmware::Firmware;
use crate::msac1_master::{Done, Job, Msac1Requester};
use dp_consts::dpv1::{self, error};
use dp_consts::Baud;
use drive_sim::LinkFault;
use profidrive::fieldbus_group::{self as fieldbus, index as fb};
use profidrive::pd_access::{
    build_request, Attribute, Format, ParamAddress, ParamResponsePdu, RequestId, Values, MAX_LEN,
};
use profidrive::ppo::Ppo;
use profirust::dp::DiagnosticFlags;
use std::io;

const TICKS_PER_US: u64 = (crate::cosim::CLOCK_HZ / 1_000_000) as u64;

pub(crate) fn value(number: u16, subindex: u16) -> ParamAddress {
    ParamAddress::value(number, subindex, 0)
}

/// Drive parameter xx.yy as seed 004 addresses it: xxyy's high byte and low byte.
pub(crate) fn drive(xxyy: u16) -> ParamAddress {
    value(xxyy >> 8, xxyy & 0xFF)
}

/// What one exchange gave: the PROFIdrive response, and the exchange itself.
pub(crate) struct Exchange {
    pub(crate) done: Option<Done>,
}

impl Exchange {
    /// The parameter response (the read's data after its MSAC1 header).
    pub(crate) fn response(&self) -> Option<ParamResponsePdu<'_>> {
        let done = self.done.as_ref()?;
        (done.response.first() == Some(&u8::from(dpv1::Function::Read)))
            .then(|| ParamResponsePdu::parse(&done.response[4..]))
            .flatten()
    }

    /// The words of parameter `i`'s block.
    pub(crate) fn words(&self, i: usize) -> Option<Vec<u32>> {
        let r = self.response()?;
        let v = r.values(i)?;
        (v.format == Format::Word)
            .then(|| (0..usize::from(v.count)).filter_map(|k| v.get(k)).collect())
    }

    /// The error number of parameter `i`, if it failed.
    pub(crate) fn error(&self, i: usize) -> Option<u32> {
        let v = self.response()?.values(i)?;
        (v.format == Format::Error).then(|| v.get(0)).flatten()
    }
}

/// Runs one job to its end (at most 300 ms of bus time).
pub(crate) fn run_job<F: Firmware>(sim: &mut CoSim<F>, job: Job) -> io::Result<Exchange> {
    let before = sim
        .master
        .as_ref()
        .and_then(|m| m.msac1.as_ref())
        .map_or(0, |r| r.done.len());
    if let Some(r) = sim.master.as_mut().and_then(|m| m.msac1.as_mut()) {
        r.push(job);
    }
    let end = sim.now + 300_000 * TICKS_PER_US;
    sim.run_until(end, |s| {
        s.master
            .as_ref()
            .and_then(|m| m.msac1.as_ref())
            .is_some_and(|r| r.done.len() > before)
    })?;
    let done = sim
        .master
        .as_ref()
        .and_then(|m| m.msac1.as_ref())
        .and_then(|r| r.done.get(before).cloned());
    Ok(Exchange { done })
}

/// A PROFIdrive parameter request, reference `reference`.
pub(crate) fn request<F: Firmware>(
    sim: &mut CoSim<F>,
    reference: u8,
    id: RequestId,
    addresses: &[ParamAddress],
    values: &[Values],
) -> io::Result<Exchange> {
    let mut out = [0u8; MAX_LEN];
    let n = build_request(&mut out, reference, id, 1, addresses, values)
        .expect("the scenario's requests fit");
    run_job(sim, Job::Parameter(out[..n].to_vec()))
}

fn word_values(v: &[u8; 2]) -> Values<'_> {
    Values::word(v)
}

/// `dpv1-profidrive`: PPO3 at 1.5 Mbit/s, PPO4 at 12 Mbit/s.
pub fn profidrive<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    let ppo = if baud == Baud::B12000000 {
        Ppo::Ppo4
    } else {
        Ppo::Ppo3
    };
    // 51.21 = 1 at the drive's panel, taken with a refresh.
    let group = |s: &mut CoSim<F>, i: u8| s.drive_now().read_register(fieldbus::code(i).0);
    let _ = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::DP_MODE).0, 1);
    let _ = sim
        .drive_now()
        .set_at_panel(fieldbus::code(fb::PAR_REFRESH).0, fieldbus::REFRESH);
    let end = sim.now + 2_000_000 * TICKS_PER_US;
    let refreshed = sim.run_until(end, |s| {
        group(s, fb::PAR_REFRESH) == Ok(fieldbus::DONE) && group(s, fb::DP_MODE) == Ok(1)
    })?;
    c.check(
        "51.21 DP MODE = 1 (DP-V1) taken with a refresh and shown back",
        refreshed,
    );

    let mut setup = MasterSetup::new(baud, SWITCH_ADDRESS);
    setup.config = ppo.cfg().to_vec();
    // Seed 004's DP-V1 Set_Prm: DPV1_Status_1-3 (DPV1_Enable), then the header byte onward.
    let mut user_prm = vec![dpv1::status1::DPV1_ENABLE, 0, 0];
    user_prm.extend_from_slice(&echo_user_prm().encode()[1..]);
    setup.user_prm = user_prm;
    sim.start_master(setup);
    if let Some(m) = sim.master.as_mut() {
        m.program = Program::EchoThroughDrive;
        m.echo_at = Some(0);
        m.msac1 = Some(Msac1Requester::new(SWITCH_ADDRESS));
    }
    let end = sim.now + 500_000 * TICKS_PER_US;
    let running = sim.run_until(end, |s| {
        s.master
            .as_mut()
            .is_some_and(|m| m.running() && m.cycles > 20)
    })?;
    c.check(
        format!("{ppo:?} with DPV1_Enable: data exchange, the inputs following the outputs"),
        running,
    );
    let cycles_before = sim.master.as_ref().map_or(0, |m| m.cycles);
    let late_before = sim.figures.late_responses;
    let mut expected_errors = 0u32;

    // 964: device identification (the Ident_Number); 945/947: the fault buffer.
    let x = request(sim, 1, RequestId::Read, &[value(964, 0)], &[])?;
    c.check(
        "read 964 (device identification): the Ident_Number",
        x.words(0) == Some(vec![u32::from(dp_consts::ADAPTER_IDENT_NUMBER)]),
    );
    sim.drive_now().inject_fault(12);
    sim.run_for_us(50_000)?;
    let x = request(
        sim,
        2,
        RequestId::Read,
        &[value(945, 1), value(947, 1)],
        &[],
    )?;
    c.check(
        "read 945 and 947, subindex 1 (fault buffer): 1000h (DRIVECOM generic) and Fu.012",
        x.words(0) == Some(vec![0x1000]) && x.words(1) == Some(vec![12]),
    );
    sim.drive_now().clear_fault();

    // Seed 004's examples: 1a (12.04), 1b (12.04-12.06), 2b (12.02 = 300, 12.03 = 500),
    // 3 (918), 4 (915 subindex 3 = 12.06), 5 (916 subindex 3 = 12.05).
    for (code, v) in [(0xFB04u16, 1204u16), (0xFB05, 1205), (0xFB06, 1206)] {
        let _ = sim.drive_now().set_at_panel(code, v);
    }
    let x = request(sim, 3, RequestId::Read, &[drive(1204)], &[])?;
    c.check("example 1a: read 12.04", x.words(0) == Some(vec![1204]));
    let x = request(
        sim,
        4,
        RequestId::Read,
        &[drive(1204), drive(1205), drive(1206)],
        &[],
    )?;
    c.check(
        "example 1b: read 12.04, 12.05, 12.06 in one request",
        (0..3).map(|i| x.words(i)).collect::<Vec<_>>()
            == [Some(vec![1204]), Some(vec![1205]), Some(vec![1206])],
    );
    let busy_reads = x.done.as_ref().map_or(0, |d| d.busy_reads);
    c.check(
        "the reads before the drive answered got B5h (state conflict) and were repeated",
        busy_reads > 0,
    );
    let (v300, v500) = (300u16.to_be_bytes(), 500u16.to_be_bytes());
    let writes_before = sim.drive_now().persistent_writes;
    let x = request(
        sim,
        5,
        RequestId::Change,
        &[drive(1202), drive(1203)],
        &[word_values(&v300), word_values(&v500)],
    )?;
    let d = sim.drive_now();
    c.check(
        "example 2b: 12.02 = 300 and 12.03 = 500, one request, positive (header only)",
        x.response().is_some_and(|r| r.id == 0x02 && r.count == 2)
            && d.read_register(0xFB02) == Ok(300)
            && d.read_register(0xFB03) == Ok(500)
            && d.persistent_writes == writes_before + 2,
    );
    let writes_before = sim.drive_now().persistent_writes;
    let x = request(
        sim,
        6,
        RequestId::Change,
        &[drive(1202)],
        &[word_values(&v300)],
    )?;
    c.check(
        "12.02 = 300 again: positive, and the drive's storage is not written",
        x.response().is_some_and(|r| r.id == 0x02)
            && sim.drive_now().persistent_writes == writes_before,
    );
    let x = request(sim, 7, RequestId::Read, &[value(918, 0)], &[])?;
    c.check(
        "example 3: read 918 (node address): 8",
        x.words(0) == Some(vec![u32::from(SWITCH_ADDRESS)]),
    );
    for (reference, number, v, what) in [
        (
            8,
            915u16,
            0x4B6u16,
            "example 4: 915 subindex 3 = 12.06 (PZD3 out)",
        ),
        (9, 916, 0x4B5, "example 5: 916 subindex 3 = 12.05 (PZD3 in)"),
    ] {
        let bytes = v.to_be_bytes();
        let x = request(
            sim,
            reference,
            RequestId::Change,
            &[ParamAddress {
                elements: 1,
                ..value(number, 3)
            }],
            &[word_values(&bytes)],
        )?;
        let back = request(
            sim,
            reference + 100,
            RequestId::Read,
            &[ParamAddress {
                elements: 1,
                ..value(number, 3)
            }],
            &[],
        )?;
        c.check(
            what,
            x.response().is_some_and(|r| r.id == 0x02) && back.words(0) == Some(vec![u32::from(v)]),
        );
    }
    // Three more drive parameters in one read, from two groups: 12.07, 12.08 and 16.01
    // (seed 000's FB.07, FB.08, FF.01), set at the drive's panel first.
    for (code, v) in [(0xFB07u16, 7u16), (0xFB08, 8), (0xFF01, 1601)] {
        let _ = sim.drive_now().set_at_panel(code, v);
    }
    let x = request(
        sim,
        10,
        RequestId::Read,
        &[drive(1207), drive(1208), drive(1601)],
        &[],
    )?;
    c.check(
        "a read of three drive parameters (12.07, 12.08, 16.01): what the drive holds",
        (0..3).map(|i| x.words(i)).collect::<Vec<_>>()
            == [Some(vec![7]), Some(vec![8]), Some(vec![1601])],
    );

    // The errors, each of its class.
    let mut raw = |sim: &mut CoSim<F>, pdu: Vec<u8>, want: [u8; 4], what: &str| -> io::Result<()> {
        let x = run_job(sim, Job::Raw(pdu))?;
        let got = x.done.map(|d| d.response);
        c.check(
            format!("{what}: {want:02X?}"),
            got.as_deref() == Some(&want[..]),
        );
        expected_errors += 1;
        Ok(())
    };
    raw(
        sim,
        vec![0x5F, 1, 48, 2, 1, 2],
        [0xDF, 0x80, error::INVALID_INDEX, 0],
        "write to index 48, invalid index",
    )?;
    raw(
        sim,
        vec![0x5E, 5, 47, 240],
        [0xDE, 0x80, error::INVALID_SLOT, 0],
        "read of slot 5, invalid slot",
    )?;
    raw(
        sim,
        vec![0x5F, 1, 47, 10, 1, 2, 3],
        [0xDF, 0x80, error::WRITE_LENGTH, 0],
        "a write whose length disagrees with its data, write length",
    )?;
    raw(
        sim,
        vec![0x5E, 1, 47, 240],
        [0xDE, 0x80, error::STATE_CONFLICT, 0],
        "a read with no request written, state conflict",
    )?;
    let x = request(sim, 11, RequestId::Read, &[value(999, 0)], &[])?;
    c.check(
        "read 999: error 00h, parameter number not allowed",
        x.error(0) == Some(0x00),
    );
    let two = 2u16.to_be_bytes();
    let x = request(
        sim,
        12,
        RequestId::Change,
        &[value(927, 0)],
        &[word_values(&two)],
    )?;
    c.check(
        "927 = 2: error 02h, value out of range",
        x.error(0) == Some(0x02),
    );
    let x = request(
        sim,
        13,
        RequestId::Read,
        &[ParamAddress {
            attribute: Attribute::Text,
            ..value(918, 0)
        }],
        &[],
    )?;
    c.check(
        "the text attribute of 918: error 0Fh, not supported",
        x.error(0) == Some(0x0F),
    );
    expected_errors += 3;

    // A request pending while the drive link is unplugged: answered with an error. The
    // inputs carry the link error meanwhile (PZD1 C0xxh), so the echo check pauses.
    let program = |s: &mut CoSim<F>, p| {
        if let Some(m) = s.master.as_mut() {
            m.program = p;
        }
    };
    program(sim, Program::Manual);
    sim.drive_now().link_fault = LinkFault::NoAnswer;
    let x = request(sim, 14, RequestId::Read, &[drive(1204)], &[])?;
    c.check(
        "12.04 read with the drive link unplugged: error 6Fh (timeout), not left hanging",
        x.error(0) == Some(0x6F),
    );
    expected_errors += 1;
    // Seed 004 lines 1098-1113: in DP-V1 mode Slave_Diag carries the status block, the
    // communication flags at its byte 10.
    let lost = profidrive::app::EXT_DIAG_LINK_LOST_TEMPORARILY;
    let diag = wait_ext_diag(sim, 50_000, |d| {
        link_flags(d).is_some_and(|f| f & lost != 0)
    })?;
    c.check(
        format!(
            "unplugged: Slave_Diag bytes 6-10 are the status block 05 81 00 00, the link lost at byte 10 ({diag:02X?})"
        ),
        diag.len() == 5 && diag[..4] == [0x05, 0x81, 0x00, 0x00] && diag[4] & lost != 0,
    );
    sim.drive_now().link_fault = LinkFault::None;
    // Back: the diagnosis no longer reports (no Ext_Diag; profirust keeps the last extended
    // diagnosis it read with Ext_Diag, so the block is read from the transceiver, which
    // answers Slave_Diag with it).
    let end = sim.now + 100_000 * TICKS_PER_US;
    let cleared = sim.run_until(end, |s| {
        s.bridge.responder.q().diag.as_slice().get(6..) == Some(&[0x05, 0x81, 0x00, 0x00, 0x00])
    })?;
    let diag = sim.bridge.responder.q().diag.as_slice().to_vec();
    c.check(
        format!("plugged back: Slave_Diag's status block has its flags clear ({diag:02X?})"),
        cleared,
    );
    let end = sim.now + 100_000 * TICKS_PER_US;
    let read = sim.run_until(end, |s| {
        diag_flags(s).is_some_and(|f| !f.contains(DiagnosticFlags::EXT_DIAG))
    })?;
    c.check(
        "plugged back: the master read a diagnosis without Ext_Diag",
        read,
    );
    sim.run_for_us(100_000)?;
    program(sim, Program::EchoThroughDrive);
    sim.run_for_us(100_000)?;

    let (cycles, wrong, checked, telegrams, done, empty_polls) = sim
        .master
        .as_ref()
        .map(|m| {
            let r = m.msac1.as_ref();
            (
                m.cycles,
                m.inputs_wrong,
                m.inputs_checked,
                r.map_or(0, |r| r.telegrams),
                r.map_or(Vec::new(), |r| r.done.clone()),
                r.map_or(0, |r| r.empty_polls),
            )
        })
        .unwrap_or_default();
    c.check(
        "cyclic data went on throughout: the inputs followed the outputs, none wrong",
        cycles > cycles_before + 100 && wrong == 0 && checked > 100,
    );
    c.check(
        "no answer later than the GSD's MaxTsdr while the requests were pending",
        sim.figures.late_responses == late_before,
    );
    let answered = done.iter().filter(|d| !d.response.is_empty()).count();
    let max_roundtrip = done
        .iter()
        .filter(|d| matches!(d.job, Job::Parameter(_)))
        .map(|d| d.roundtrip_us)
        .max()
        .unwrap_or(0);
    Ok(vec![
        format!(
            "dpv1: requests={} answered={answered} errors_as_expected={expected_errors} max_roundtrip_us={max_roundtrip}",
            done.len()
        ),
        format!("dpv1: msac1_telegrams={telegrams} polls_without_data={empty_polls}"),
    ])
}
