//! The scenarios of the transceiver and the DP slave on the bus (family "bus").

use super::support::*;
use crate::cosim::{CoSim, MasterSetup};
use crate::firmware::Firmware;
use dp_consts::Baud;
use dp_link::{Led, NvRecord, SlaveState};
use fdl::{RequestFunction, Sap};
use profirust::dp::DiagnosticFlags;
use std::io;

/// Power-up, autodetect and data exchange at `baud`; then every DP-V0 service profirust
/// does not send, from a commissioning tool.
pub fn autodetect<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
    let ok = exchange(sim, cycles_for(baud), limit_us(baud))?;
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
    let master = sim.take_master();
    probe_services(sim, c, baud)?;
    sim.master = master;
    Ok(Vec::new())
}

/// The master changes from 1.5 Mbit/s to `to` mid-run; the adapter follows on the new
/// master's first telegram (issue 17), not when its baud watchdog expires.
pub fn rate_change<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    to: Baud,
) -> io::Result<Report> {
    let from = Baud::B1500000;
    sim.start_master(MasterSetup::new(from, SWITCH_ADDRESS));
    let ok = exchange(sim, 20, limit_us(from))?;
    c.check(format!("data exchange at {from}"), ok);
    // The table's "lost" column is the new master's telegrams before the relock.
    sim.figures.lost_before_lock = None;
    let expiries = sim.adapter.stats().watchdog_expiries;
    sim.start_master(MasterSetup::new(to, SWITCH_ADDRESS));
    let ok = exchange(sim, cycles_for(to), limit_us(to))?;
    c.check(format!("data exchange again at {to}"), ok);
    c.check(
        format!("transceiver followed to {to}"),
        sim.figures.locked == Some(to),
    );
    let stats = sim.adapter.stats();
    c.check(
        format!(
            "relocked on the first telegram at {to}, not by the baud watchdog (lost {:?}, relocks {}, watchdog expiries {})",
            sim.figures.lost_before_lock,
            stats.relocks,
            stats.watchdog_expiries - expiries
        ),
        sim.figures.lost_before_lock == Some(0)
            && stats.relocks >= 1
            && stats.watchdog_expiries == expiries,
    );
    Ok(Vec::new())
}

/// The master disappears: watchdog, fail-safe, then recovery.
pub fn watchdog<F: Firmware>(sim: &mut CoSim<F>, c: &mut Checks, baud: Baud) -> io::Result<Report> {
    sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
    let ok = exchange(sim, 20, limit_us(baud))?;
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
        sim.bridge.status.leds.net == Led::Blink2Hz && sim.bridge.status.leds.offline == Led::On,
    );
    sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
    let ok = exchange(sim, 20, limit_us(baud))?;
    c.check("data exchange after the master returned", ok);
    Ok(Vec::new())
}

/// A Set_Prm with a wrong Ident_Number: Prm_Fault, no data exchange.
pub fn prm_fault<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    let mut setup = MasterSetup::new(baud, SWITCH_ADDRESS);
    setup.ident_number ^= 0x0001;
    refused(
        sim,
        c,
        setup,
        ("Prm_Fault", DiagnosticFlags::PARAMETER_FAULT),
        Led::Blink2Hz,
    )?;
    Ok(Vec::new())
}

/// A Chk_Cfg that is none of the PPOs: Cfg_Fault, no data exchange.
pub fn cfg_fault<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    let mut setup = MasterSetup::new(baud, SWITCH_ADDRESS);
    setup.config = vec![0xF5, 0xF1];
    refused(
        sim,
        c,
        setup,
        ("Cfg_Fault", DiagnosticFlags::CONFIGURATION_FAULT),
        Led::Blink1Hz,
    )?;
    Ok(Vec::new())
}

/// Set_Slave_Add with the switch at 0, then a power cycle.
pub fn set_slave_add<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    c.check(
        "switch 0, empty storage: address 126",
        sim.bridge.status.address == 126,
    );
    let answer = set_slave_add_request(sim, baud, 126, 42)?;
    c.check(
        "Set_Slave_Add acknowledged (SC)",
        answer.as_deref() == Some(&[dp_consts::SC][..]),
    );
    // The firmware decides after the transceiver's answer, and writes the storage.
    sim.run_for_us(1_000)?;
    c.check(
        "storage holds address 42",
        sim.bridge.stored()?.address
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
    let ok = exchange(sim, 20, limit_us(baud))?;
    c.check("data exchange at address 42", ok);
    Ok(Vec::new())
}

/// A commissioning tool (station 1) asks the slave at `at` to take `address` (its ident
/// number, changes allowed later); the answer read back from the line, if any.
pub(crate) fn set_slave_add_request<F: Firmware>(
    sim: &mut CoSim<F>,
    baud: Baud,
    at: u8,
    address: u8,
) -> io::Result<Option<Vec<u8>>> {
    let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
    let payload = [address, hi, lo, 0];
    let bytes = service_request(
        at,
        1,
        Sap::SET_SLAVE_ADD,
        RequestFunction::SrdLow,
        true,
        &payload,
    );
    let mut tool = MasterSetup::new(baud, at);
    tool.address = 1;
    sim.tool_request(tool, &bytes, 300)
}

/// Switch 99 restores the factory defaults.
pub fn factory_reset<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    c.check("switch 99: address 126", sim.bridge.status.address == 126);
    c.check(
        "storage reset to the factory defaults",
        sim.bridge.stored()?.address == Some(adapter::FACTORY_DEFAULTS),
    );
    sim.start_master(MasterSetup::new(baud, 126));
    let ok = exchange(sim, 20, limit_us(baud))?;
    c.check("data exchange at address 126", ok);
    sim.stop_master();
    sim.bridge.switch = 0;
    sim.power_cycle()?;
    c.check(
        "switch 0 after the reset: address 126 from storage",
        sim.bridge.status.address == 126,
    );
    Ok(Vec::new())
}

/// A burst of line noise during data exchange.
pub fn line_noise<F: Firmware>(
    sim: &mut CoSim<F>,
    c: &mut Checks,
    baud: Baud,
) -> io::Result<Report> {
    sim.start_master(MasterSetup::new(baud, SWITCH_ADDRESS));
    let ok = exchange(sim, 20, limit_us(baud))?;
    c.check("data exchange before the noise", ok);
    let from = sim.now;
    let to = from + 20_000 * 48;
    // Glitches up to 2 bit times long, 2000 of them over 20 ms. Now and then they make a start
    // delimiter at another rate, and whether they do moves with the bus timing, which varies
    // by a few clocks run to run: such a trial is counted, not logged, and it must fail back.
    sim.bus.faults.glitches(0x5EED, from, to, 2000, 64);
    sim.log_failed_trials = false;
    sim.run_until(to, |_| false)?;
    c.check(
        "the noise broke telegrams",
        sim.figures.bad_telegrams > 0 || sim.master.as_ref().is_some_and(|m| m.phy.char_errors > 0),
    );
    let ok = exchange(sim, 50, limit_us(baud))?;
    sim.log_failed_trials = true;
    c.check("data exchange recovered", ok);
    c.check(
        format!("the noise did not move the lock from {baud}"),
        sim.adapter.stats().relocks == 0 && sim.figures.locked == Some(baud),
    );
    c.check(
        "every trial the noise drew failed back to the lock",
        sim.adapter.stats().relock_trials_failed == sim.figures.trials_failed_back,
    );
    Ok(vec![format!(
        "line-noise: trials drawn by the noise, failed back to {baud}: {}",
        sim.figures.trials_failed_back
    )])
}
