//! Project tasks, run as `cargo xtask <task>`.
//!
//! - `baud-sweep [--quick] [--shard i/N]`: the autobaud regression (rate x clock offset x noise x
//!   start phase, from power-up and after a rate change); CSV and SVG under `target/baud-sweep/`.
//! - `phy-bench [--runs N]`: the transceiver model's speed, strict and fast mode.
//! - `dp-cycle [--slaves N] [--cycles N]`: ten adapters on one line with one profirust master,
//!   at 1.5 and 12 Mbit/s for PPO1-5: the master's cycle against the line's floor.
//! - `gsd [--out PATH]`: the adapter's GSD file, from the constants the firmware uses.
//! - `qemu-run [--port pty|DEVICE] [--baud N] [--switch N] [--seconds N]`: the adapter
//!   interactively, on the simulated bus or on a serial port for an external master.
//! - `qemu-test [--only NAME] [--overwrite]`: the firmware under QEMU against hal-sim,
//!   scenario by scenario, with golden files in `ci/expected/qemu-test/`.
//! - `flash [--dry-run] [--log] [--probe VID:PID[:SERIAL]] [--chip NAME]`: the production
//!   image onto a board through a debug probe (probe-rs, in `flash/`).
//! - `dist`: the release bundle for a production line under `target/dist/<version>/`.
//! - `clippy-firmware`: clippy, warnings denied, on the firmware of every board in the table.
//! - `rtl-check [--quick]`: the gateware's blocks against the transceiver model, clock for
//!   clock, under Verilator.
//! - `gateware [--part P]`: the blocks synthesised for the production board's FPGA (an ECP5),
//!   the search and the transceiver's top placed and routed on it (yosys and nextpnr from
//!   PyPI); `--part iCE40HX8K-CT256` for the iCE40 HX8K, measured, not gated.
//! - `soak [--seed S] [--minutes M] [--events N] [--in-process] [--trace-from K] [--broken
//!   fail-safe]`: a seeded random schedule of everything the scenarios do, on the firmware
//!   under QEMU, with invariants checked as it runs.

mod baud_sweep;
mod dist;
mod dp_cycle;
mod flash;
mod gateware;
mod gsd;
mod phy_bench;
mod pty_check;
mod qemu_run;
mod qemu_test;
mod rtl_check;
mod soak;

use anyhow::{bail, Result};
use std::path::PathBuf;

fn main() {
    if let Err(e) = try_main() {
        eprintln!("xtask: {e:#}");
        std::process::exit(1);
    }
}

fn try_main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((task, rest)) = args.split_first() else {
        bail!(
            "usage: cargo xtask <qemu-test|qemu-run|flash|dist|clippy-firmware|baud-sweep|phy-bench|dp-cycle|gsd|rtl-check|gateware|soak> [options]"
        );
    };
    match task.as_str() {
        "baud-sweep" => baud_sweep::run(rest),
        "phy-bench" => phy_bench::run(rest),
        "dp-cycle" => dp_cycle::run(rest),
        "gsd" => gsd::run(rest),
        "qemu-test" => qemu_test::run(rest),
        "qemu-run" => qemu_run::run(rest),
        "flash" => flash::run(rest),
        "dist" => dist::run(rest),
        "clippy-firmware" => qemu_test::clippy_firmware(rest),
        "rtl-check" => rtl_check::run(rest),
        "gateware" => gateware::run(rest),
        "soak" => soak::run(rest),
        other => bail!(
            "unknown task `{other}`: qemu-test, qemu-run, flash, dist, clippy-firmware, \
             baud-sweep, phy-bench, dp-cycle, gsd, rtl-check, gateware or soak"
        ),
    }
}

/// The workspace root.
pub fn project_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace root")
        .to_path_buf()
}

/// The value after `--name`, if given.
pub fn flag_value<'a>(args: &'a [String], name: &str) -> Result<Option<&'a str>> {
    match args.iter().position(|a| a == name) {
        None => Ok(None),
        Some(i) => match args.get(i + 1) {
            Some(v) => Ok(Some(v)),
            None => bail!("{name} needs a value"),
        },
    }
}

/// Refuse options the task does not know, so a typo is not silently ignored.
pub fn check_flags(args: &[String], known: &[&str], with_value: &[&str]) -> Result<()> {
    let mut i = 0;
    while i < args.len() {
        let a = args[i].as_str();
        if with_value.contains(&a) {
            i += 2;
        } else if known.contains(&a) {
            i += 1;
        } else {
            bail!("unknown option `{a}`");
        }
    }
    Ok(())
}

/// The median of `xs` (which must not be empty).
pub fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(|a, b| a.total_cmp(b));
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        (xs[n / 2 - 1] + xs[n / 2]) / 2.0
    }
}
