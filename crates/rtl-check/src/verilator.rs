//! Verilating a block with its harness, and running the harness on a case.
//!
//! Contract: [`build`] runs `verilator --cc --exe --build` into a directory of the build's own
//! name (Verilator's make rebuilds only what changed), lint warnings fatal, and returns the
//! harness binary. [`run`] writes the case's stimulus, runs the binary and parses its outputs;
//! a harness that fails or writes a broken file is an error, never a pass.

use crate::{Block, Case, Event, Trace};
use std::io;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Verilates `block` from `gateware` (the repository's `gateware/`) under `out`; returns the
/// harness binary.
pub fn build(block: &Block, gateware: &Path, out: &Path) -> io::Result<PathBuf> {
    let mdir = out.join(block.build_name());
    let sim = gateware.join("sim");
    let mut cmd = Command::new("verilator");
    cmd.args(["--cc", "--exe", "--build", "-j", "2", "-O3", "-Wall"])
        .args(["--x-assign", "fast", "--x-initial", "fast", "--noassert"])
        .arg("--top-module")
        .arg(block.top)
        .arg("-CFLAGS")
        .arg(format!("-O2 -I{}{}", sim.display(), param_defines(block)))
        .arg("--Mdir")
        .arg(&mdir)
        .args(["-o", "check"]);
    // `include files sit beside the RTL.
    cmd.arg(format!("-I{}", gateware.join("rtl").display()));
    for (param, value) in &block.params {
        cmd.arg(format!("-G{param}={value}"));
    }
    for file in block.rtl {
        cmd.arg(gateware.join("rtl").join(file));
    }
    cmd.arg(sim.join(format!("{}_check.cpp", block.top)));
    let output = cmd.output()?;
    if !output.status.success() {
        return Err(io::Error::other(format!(
            "verilator did not build {}:\n{}{}",
            block.build_name(),
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        )));
    }
    Ok(mdir.join("check"))
}

/// The block's parameters for its harness too, as `PARAM_<name>` (widths it decodes).
fn param_defines(block: &Block) -> String {
    block
        .params
        .iter()
        .map(|(param, value)| format!(" -DPARAM_{param}={value}"))
        .collect()
}

/// Runs `binary` on `case`'s stimulus in `work`; returns what the RTL put out, per clock and
/// (a block with events) its events.
pub fn run(
    block: &Block,
    binary: &Path,
    case: &Case,
    work: &Path,
) -> io::Result<(Trace, Vec<Event>)> {
    std::fs::create_dir_all(work)?;
    let stimulus = work.join("stimulus.bin");
    let outputs = work.join("outputs.bin");
    let events = work.join("events.bin");
    std::fs::write(&stimulus, &case.stimulus)?;
    let mut cmd = Command::new(binary);
    cmd.arg(&stimulus).arg(&outputs);
    if block.events {
        cmd.arg(&events);
    }
    let output = cmd.output()?;
    if !output.status.success() {
        return Err(io::Error::other(format!(
            "the harness failed on {}: {}",
            case.name,
            String::from_utf8_lossy(&output.stderr)
        )));
    }
    let trace = Trace::parse(&std::fs::read(&outputs)?)?;
    let events = if block.events {
        Event::parse_all(&std::fs::read(&events)?)?
    } else {
        Vec::new()
    };
    Ok((trace, events))
}
