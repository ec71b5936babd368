//! The scenarios of `cargo xtask qemu-test`: each powers the board up, drives the bus, and
//! checks what the device must do. A scenario fails on any failed check, and always when a
//! response started later than max TSDR, when the firmware saw a telegram that does not parse,
//! when the inputs did not carry the outputs back through the drive (the echo program), or
//! when two stations drove the line. The drive scenarios are in [`crate::drive_scenarios`].

use crate::cosim::{CoSim, Figures, MasterSetup, Program};
use crate::firmware::Firmware;
use dp_consts::Baud;
use dp_link::{Led, NvRecord, SlaveState};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, Sap};
use profirust::dp::DiagnosticFlags;
use std::io;

/// The station address the switch sets in most scenarios.
pub const SWITCH_ADDRESS: u8 = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Power-up, autodetect and data exchange at one rate.
    Autodetect(Baud),
    /// The master changes its rate mid-run; the adapter follows.
    RateChange { from: Baud, to: Baud },
    /// The master disappears: watchdog, fail-safe, then recovery.
    WatchdogFailSafe,
    /// A Set_Prm with a wrong Ident_Number, at a rate.
    PrmFault(Baud),
    /// A Chk_Cfg that is none of the PPOs, at a rate.
    CfgFault(Baud),
    /// Set_Slave_Add with the switch at 0, then a power cycle.
    SetSlaveAdd,
    /// Switch 99 restores the factory defaults.
    FactoryReset,
    /// A burst of line noise during data exchange.
    LineNoise,
    /// The drive through PZD and PKW in the vendor profile (seed 000), its faults, the link
    /// to it lost and back.
    DriveVendor,
    /// The same drive in the PROFIdrive profile (seed 004).
    DriveProfidrive,
    /// PLC stop and communication loss, in each fail-safe mode.
    FailSafeModes,
    /// The drive's fieldbus group 51: shown values, refresh, node address.
    FieldbusGroup,
    /// Adapter latency for PPO1-5 at 1.5 Mbit/s (figures for the report).
    Latency,
}

#[derive(Clone, Debug)]
pub struct Scenario {
    pub name: String,
    pub kind: Kind,
}

/// Every scenario, in the order they run.
pub fn all() -> Vec<Scenario> {
    let mut list: Vec<Scenario> = Baud::ALL
        .iter()
        .map(|b| Scenario {
            name: format!("autodetect-{}", b.to_string().replace('.', "_")),
            kind: Kind::Autodetect(*b),
        })
        .collect();
    let more = [
        (
            "rate-change",
            Kind::RateChange {
                from: Baud::B1500000,
                to: Baud::B93750,
            },
        ),
        ("watchdog-fail-safe", Kind::WatchdogFailSafe),
        ("prm-fault", Kind::PrmFault(Baud::B1500000)),
        ("cfg-fault", Kind::CfgFault(Baud::B1500000)),
        ("prm-fault-12M", Kind::PrmFault(Baud::B12000000)),
        ("cfg-fault-12M", Kind::CfgFault(Baud::B12000000)),
        ("set-slave-add", Kind::SetSlaveAdd),
        ("factory-reset", Kind::FactoryReset),
        ("line-noise", Kind::LineNoise),
        ("drive-vendor", Kind::DriveVendor),
        ("drive-profidrive", Kind::DriveProfidrive),
        ("fail-safe-modes", Kind::FailSafeModes),
        ("drive-fieldbus-group", Kind::FieldbusGroup),
        ("latency", Kind::Latency),
    ];
    list.extend(more.into_iter().map(|(name, kind)| Scenario {
        name: name.into(),
        kind,
    }));
    list
}

/// The result of one scenario.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub name: String,
    pub checks: Vec<(String, bool)>,
    pub figures: Figures,
    pub events: Vec<String>,
    pub leds: dp_link::Leds,
    /// Figures for the report (not compared with the golden files: they are measurements).
    pub report: Vec<String>,
}

impl Outcome {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|(_, ok)| *ok)
    }
}

struct Checks(Vec<(String, bool)>);

impl Checks {
    fn check(&mut self, what: impl Into<String>, ok: bool) {
        self.0.push((what.into(), ok));
    }
}

/// Sim-time limit for reaching a goal: generous, since a miss is a failure, not a hang.
fn limit_us(baud: Baud) -> u64 {
    match baud {
        Baud::B9600 | Baud::B19200 => 6_000_000,
        Baud::B45450 | Baud::B93750 => 3_000_000,
        _ => 1_500_000,
    }
}

/// Data exchange cycles that make a rate's run convincing without slowing the slow ones.
fn cycles_for(baud: Baud) -> u64 {
    if baud.bits_per_second() < 100_000 {
        10
    } else {
        50
    }
}

/// Runs until the master completed `cycles` more data exchange cycles.
fn exchange<F: Firmware>(sim: &mut CoSim<F>, cycles: u64, limit_us: u64) -> io::Result<bool> {
    let start = sim.master.as_ref().map_or(0, |m| m.cycles);
    let end = sim.now + limit_us * 48;
    sim.run_until(end, |s| {
        s.master
            .as_ref()
            .is_some_and(|m| m.cycles >= start + cycles)
    })
}

fn diag_flags<F: Firmware>(sim: &mut CoSim<F>) -> Option<DiagnosticFlags> {
    let master = sim.master.as_mut()?;
    let peripheral = master.dp.get_mut(master.handle);
    peripheral.last_diagnostics().map(|d| d.flags)
}

/// The extended diagnosis the master read last (header byte, then the adapter's flags).
pub(crate) fn ext_diag<F: Firmware>(sim: &mut CoSim<F>) -> Vec<u8> {
    let Some(master) = sim.master.as_mut() else {
        return Vec::new();
    };
    let peripheral = master.dp.get_mut(master.handle);
    peripheral
        .last_diagnostics()
        .and_then(|d| d.extended_diagnostics.raw_diag_buffer().map(<[u8]>::to_vec))
        .unwrap_or_default()
}

/// The DP-V0 services profirust does not send, each from a commissioning tool (station 3, a
/// second master) after data exchange at `baud`: each must be answered, and as the slave
/// decides in that state (the responder's answers against the firmware's are proven bit for
/// bit by dp-phy's tests; here they are timed on the wire with every other answer).
fn probe_services<F: Firmware>(sim: &mut CoSim<F>, c: &mut Checks, baud: Baud) -> io::Result<()> {
    use fdl::ResponseStatus as S;
    // Let the last exchange finish on the line (the master's request, the adapter's answer).
    sim.run_for_us(300 * 1_000_000 / u64::from(baud.bits_per_second()) + 100)?;
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
fn refused<F: Firmware>(
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
    sim.stop_master();
    sim.run_for_us(20_000)?;
    c.check(
        format!("error LED {error_led:?}"),
        sim.bridge.status.leds.error == error_led,
    );
    Ok(())
}

/// Runs one scenario on a freshly powered board.
pub fn run<F: Firmware>(scenario: &Scenario, firmware: F) -> io::Result<(Outcome, F)> {
    let (switch, nv) = match scenario.kind {
        Kind::SetSlaveAdd => (0, None),
        Kind::FactoryReset => (
            99,
            Some(NvRecord {
                address: 42,
                no_add_chg: true,
            }),
        ),
        _ => (SWITCH_ADDRESS, None),
    };
    let mut sim = CoSim::new(firmware, switch, nv)?;
    let mut c = Checks(Vec::new());
    let mut report = Vec::new();
    match scenario.kind {
        Kind::Autodetect(baud) => {
            sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, cycles_for(baud), limit_us(baud))?;
            c.check(
                format!("{} data exchange cycles at {baud}", cycles_for(baud)),
                ok,
            );
            c.check(
                format!("transceiver locked at {baud}"),
                sim.figures.locked == Some(baud),
            );
            // The master steps aside for the tool and comes back for the run's echo check
            // (nothing runs after this).
            let master = sim.master.take();
            probe_services(&mut sim, &mut c, baud)?;
            sim.master = master;
        }
        Kind::RateChange { from, to } => {
            sim.start_master(MasterSetup::new(from, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, 20, limit_us(from))?;
            c.check(format!("data exchange at {from}"), ok);
            sim.start_master(MasterSetup::new(to, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, cycles_for(to), limit_us(to))?;
            c.check(format!("data exchange again at {to}"), ok);
            c.check(
                format!("transceiver followed to {to}"),
                sim.figures.locked == Some(to),
            );
        }
        Kind::WatchdogFailSafe => {
            let baud = Baud::B1500000;
            sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, 20, limit_us(baud))?;
            c.check("data exchange", ok);
            let fail_safes = sim.bridge.status.fail_safes;
            sim.stop_master();
            // The master's watchdog is 200 ms; wait past it.
            sim.run_for_us(300_000)?;
            c.check(
                "watchdog expired: Wait_Prm",
                sim.bridge.status.state == SlaveState::WaitPrm,
            );
            c.check(
                "outputs went to fail-safe",
                sim.bridge.status.fail_safes > fail_safes,
            );
            c.check(
                "Net LED blinks, offline LED on",
                sim.bridge.status.leds.net == Led::Blink2Hz
                    && sim.bridge.status.leds.offline == Led::On,
            );
            sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, 20, limit_us(baud))?;
            c.check("data exchange after the master returned", ok);
        }
        Kind::PrmFault(baud) => {
            let mut setup = MasterSetup::new(baud, SWITCH_ADDRESS);
            setup.ident_number ^= 0x0001;
            refused(
                &mut sim,
                &mut c,
                setup,
                ("Prm_Fault", DiagnosticFlags::PARAMETER_FAULT),
                Led::Blink2Hz,
            )?;
        }
        Kind::CfgFault(baud) => {
            let mut setup = MasterSetup::new(baud, SWITCH_ADDRESS);
            setup.config = vec![0xF5, 0xF1];
            refused(
                &mut sim,
                &mut c,
                setup,
                ("Cfg_Fault", DiagnosticFlags::CONFIGURATION_FAULT),
                Led::Blink1Hz,
            )?;
        }
        Kind::SetSlaveAdd => {
            let baud = Baud::B1500000;
            c.check(
                "switch 0, empty storage: address 126",
                sim.bridge.status.address == 126,
            );
            let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
            let payload = [42, hi, lo, 0];
            let request = Repr::Data(DataRepr {
                da: 126,
                sa: 1,
                dsap: Some(Sap::SET_SLAVE_ADD),
                ssap: Some(Sap::MASTER_MS0),
                fc: FrameControl::Request {
                    fcb: true,
                    fcv: false,
                    function: RequestFunction::SrdLow,
                },
                payload: &payload,
            });
            let mut bytes = vec![0u8; request.buffer_len()];
            request.emit(&mut bytes).expect("a valid request");
            let mut tool = MasterSetup::new(baud, 126);
            tool.address = 1;
            let answer = sim.tool_request(tool, &bytes, 300)?;
            c.check(
                "Set_Slave_Add acknowledged (SC)",
                answer.as_deref() == Some(&[dp_consts::SC][..]),
            );
            // The firmware decides after the transceiver's answer, and writes the storage.
            sim.run_for_us(1_000)?;
            c.check(
                "storage holds address 42",
                sim.bridge.nv
                    == Some(NvRecord {
                        address: 42,
                        no_add_chg: false,
                    }),
            );
            sim.power_cycle()?;
            c.check(
                "after a power cycle: address 42",
                sim.bridge.status.address == 42,
            );
            sim.start_master(MasterSetup::new(baud, 42));
            let ok = exchange(&mut sim, 20, limit_us(baud))?;
            c.check("data exchange at address 42", ok);
        }
        Kind::FactoryReset => {
            let baud = Baud::B1500000;
            c.check("switch 99: address 126", sim.bridge.status.address == 126);
            c.check(
                "storage reset to the factory defaults",
                sim.bridge.nv == Some(adapter::FACTORY_DEFAULTS),
            );
            sim.start_master(MasterSetup::new(baud, 126));
            let ok = exchange(&mut sim, 20, limit_us(baud))?;
            c.check("data exchange at address 126", ok);
            sim.stop_master();
            sim.bridge.switch = 0;
            sim.power_cycle()?;
            c.check(
                "switch 0 after the reset: address 126 from storage",
                sim.bridge.status.address == 126,
            );
        }
        Kind::LineNoise => {
            let baud = Baud::B1500000;
            sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
            let ok = exchange(&mut sim, 20, limit_us(baud))?;
            c.check("data exchange before the noise", ok);
            let from = sim.now;
            let to = from + 20_000 * 48;
            // Glitches up to 2 bit times long, 2000 of them over 20 ms.
            sim.bus.faults.glitches(0x5EED, from, to, 2000, 64);
            sim.run_until(to, |_| false)?;
            c.check(
                "the noise broke telegrams",
                sim.figures.bad_telegrams > 0
                    || sim.master.as_ref().is_some_and(|m| m.phy.char_errors > 0),
            );
            let ok = exchange(&mut sim, 50, limit_us(baud))?;
            c.check("data exchange recovered", ok);
        }
        Kind::DriveVendor => crate::drive_scenarios::vendor(&mut sim, &mut c.0)?,
        Kind::DriveProfidrive => crate::drive_scenarios::profidrive(&mut sim, &mut c.0)?,
        Kind::FailSafeModes => crate::drive_scenarios::fail_safe_modes(&mut sim, &mut c.0)?,
        Kind::FieldbusGroup => crate::drive_scenarios::fieldbus_group(&mut sim, &mut c.0)?,
        Kind::Latency => report = crate::drive_scenarios::latency(&mut sim, &mut c.0)?,
    }
    let figures = sim.figures();
    c.check(
        "no response later than max TSDR",
        figures.late_responses == 0,
    );
    c.check(
        "the firmware never got a malformed telegram",
        sim.bridge.status.malformed_telegrams == 0,
    );
    if let Some(m) = sim
        .master
        .as_ref()
        .filter(|m| m.program == Program::EchoThroughDrive)
    {
        c.check(
            "inputs carried PZD2 back through the drive, never a value not sent",
            (m.cycles < 20 || m.inputs_checked > 0) && m.inputs_wrong == 0,
        );
    }
    c.check("no collision on the line", sim.bus.collisions == 0);
    let mut figures = figures;
    figures.collisions = sim.bus.collisions;
    let outcome = Outcome {
        name: scenario.name.clone(),
        checks: c.0,
        figures,
        events: sim.events().to_vec(),
        leds: sim.bridge.status.leds,
        report,
    };
    Ok((outcome, sim.bridge.firmware))
}
