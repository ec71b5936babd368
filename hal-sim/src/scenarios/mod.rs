//! The scenarios of `cargo xtask qemu-test`, in one catalog: each powers the board up, drives
//! the bus, and checks what the device must do. A scenario fails on any failed check, and
//! always when a response started later than the GSD's MaxTsdr, when the firmware saw a
//! telegram that does not parse, when the inputs did not carry the outputs back through the
//! drive (the echo program), or when two stations drove the line.
//!
//! Adding a scenario: write its function in the family's file (`bus.rs`, `drive.rs`: it takes
//! the co-simulation, the checks and the rate, and returns report lines), add one row to
//! [`catalog`], and record its golden file with `cargo xtask qemu-test --only NAME
//! --overwrite` (review it). qemu-test, `--only` and the in-process test read the catalog.

mod bus;
mod dpv1;
mod drive;
mod support;

pub(crate) use bus::set_slave_add_request;
pub(crate) use dpv1::{
    drive as drive_param, request as dpv1_request, run_job as dpv1_job, value as param,
};
pub(crate) use drive::{
    global_control, pd_reply, pd_request, plc_stop, vendor_reply, vendor_request, words,
};
pub(crate) use support::{limit_us, probe_services};
pub use support::{Checks, Report, SWITCH_ADDRESS};

use crate::cosim::{CoSim, Figures, Program};
use crate::firmware::Firmware;
use dp_consts::Baud;
use dp_link::NvRecord;
use std::io;

/// What a scenario exercises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// The transceiver and the DP slave on the bus.
    Bus,
    /// The drive behind the adapter.
    Drive,
    /// DP-V1: acyclic parameter access beside the cyclic data.
    Dpv1,
}

/// One row of the catalog.
pub struct Scenario<F: Firmware> {
    pub name: &'static str,
    pub family: Family,
    /// The rate the master runs at (for a rate change: the rate it changes to).
    pub rate: Baud,
    /// The board at power-up: the address switch and the storage.
    pub switch: u8,
    pub nv: Option<NvRecord>,
    /// What the scenario proves, for the reader of the catalog.
    pub proves: &'static str,
    pub run: fn(&mut CoSim<F>, &mut Checks, Baud) -> io::Result<Report>,
}

const FACTORY_RESET_STORAGE: Option<NvRecord> = Some(NvRecord {
    address: 42,
    no_add_chg: true,
});

/// Every scenario, in the order they run.
pub fn catalog<F: Firmware>() -> Vec<Scenario<F>> {
    use Baud::*;
    use Family::{Bus, Dpv1, Drive};
    let row = |name, family, rate, proves, run| Scenario {
        name,
        family,
        rate,
        switch: SWITCH_ADDRESS,
        nv: None,
        proves,
        run,
    };
    let autodetect = "power-up, autodetect and data exchange at this rate; every DP-V0 service";
    // One row per scenario (rustfmt would break the rows: the catalog reads as a table).
    #[rustfmt::skip]
    let rows = vec![
        row("autodetect-9_6k", Bus, B9600, autodetect, bus::autodetect),
        row("autodetect-19_2k", Bus, B19200, autodetect, bus::autodetect),
        row("autodetect-45_45k", Bus, B45450, autodetect, bus::autodetect),
        row("autodetect-93_75k", Bus, B93750, autodetect, bus::autodetect),
        row("autodetect-187_5k", Bus, B187500, autodetect, bus::autodetect),
        row("autodetect-500k", Bus, B500000, autodetect, bus::autodetect),
        row("autodetect-1_5M", Bus, B1500000, autodetect, bus::autodetect),
        row("autodetect-3M", Bus, B3000000, autodetect, bus::autodetect),
        row("autodetect-6M", Bus, B6000000, autodetect, bus::autodetect),
        row("autodetect-12M", Bus, B12000000, autodetect, bus::autodetect),
        row("rate-change", Bus, B93750, "the master changes rate mid-run: the adapter follows", bus::rate_change),
        row("watchdog-fail-safe", Bus, B1500000, "the master disappears: watchdog, fail-safe, recovery", bus::watchdog),
        row("prm-fault", Bus, B1500000, "a wrong Ident_Number: Prm_Fault", bus::prm_fault),
        row("cfg-fault", Bus, B1500000, "a configuration of no PPO: Cfg_Fault", bus::cfg_fault),
        row("prm-fault-12M", Bus, B12000000, "Prm_Fault at 12 Mbit/s", bus::prm_fault),
        row("cfg-fault-12M", Bus, B12000000, "Cfg_Fault at 12 Mbit/s", bus::cfg_fault),
        Scenario { switch: 0, ..row("set-slave-add", Bus, B1500000, "Set_Slave_Add with the switch at 0, kept over a power cycle", bus::set_slave_add) },
        Scenario { switch: 99, nv: FACTORY_RESET_STORAGE, ..row("factory-reset", Bus, B1500000, "switch 99 restores the factory defaults", bus::factory_reset) },
        row("line-noise", Bus, B1500000, "a burst of line noise: data exchange recovers", bus::line_noise),
        row("drive-vendor", Drive, B1500000, "seed 000's words, PKW, faults, link loss, a late answer (vendor profile)", drive::vendor),
        row("drive-profidrive", Drive, B1500000, "seed 004's state machine and parameter channel", drive::profidrive),
        row("fail-safe-modes", Drive, B1500000, "PLC stop and watchdog in each fail-safe mode", drive::fail_safe_modes),
        row("drive-fieldbus-group", Drive, B1500000, "the drive's group 51: shown values, refresh, node address", drive::fieldbus_group),
        row("latency", Drive, B1500000, "out->drive and drive->in per PPO (report)", drive::latency),
        row("dpv1-profidrive", Dpv1, B1500000, "PROFIdrive parameters over DP-V1 (MSAC1), PPO3: seed 004's examples and errors", dpv1::profidrive),
        row("dpv1-profidrive-12M", Dpv1, B12000000, "PROFIdrive parameters over DP-V1 at 12 Mbit/s, PPO4", dpv1::profidrive),
    ];
    rows
}

/// The scenario names, in the order they run.
pub fn names() -> Vec<&'static str> {
    catalog::<crate::firmware::InProcess>()
        .into_iter()
        .map(|s| s.name)
        .collect()
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

/// Runs the scenario `name` on a freshly powered board around `firmware`.
pub fn run<F: Firmware>(name: &str, firmware: F) -> io::Result<(Outcome, F)> {
    let Some(scenario) = catalog::<F>().into_iter().find(|s| s.name == name) else {
        return Err(io::Error::other(format!("no scenario named {name:?}")));
    };
    let mut sim = CoSim::new(firmware, scenario.switch, scenario.nv)?;
    let mut c = Checks::default();
    let report = (scenario.run)(&mut sim, &mut c, scenario.rate)?;
    let figures = sim.figures();
    c.check(
        "no response later than max TSDR",
        figures.late_responses == 0,
    );
    c.check(
        "no telegram delivered as good that the master did not send",
        figures.corrupt_delivered == 0,
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
    // The stack since the last power-up (a scenario with a power cycle measures its last run).
    figures.stack_peak = sim.bridge.firmware.stack_peak()?;
    let outcome = Outcome {
        name: scenario.name.to_string(),
        checks: c.0,
        figures,
        events: sim.events().to_vec(),
        leds: sim.bridge.status.leds,
        report,
    };
    Ok((outcome, sim.bridge.firmware))
}
