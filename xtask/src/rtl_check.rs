//! `cargo xtask rtl-check [--quick] [--only BUILD]`: the gateware's blocks against their Rust
//! twins in dp-phy, clock for clock (crates/rtl-check); `--only` runs the builds whose name
//! holds BUILD (`autobaud-Oversampled1`, `char_reader`), for work on one block.
//!
//! First it proves that it can fail: the transmitter built one clock late (`LateByOne`) must
//! differ from the model at the first start bit's clock, on `tx`. Then every block ported so far
//! runs its cases; a mismatch prints the first differing clock, signal and both values and
//! writes `target/rtl/<case>.vcd` with both sides; where the outputs agree clock for clock, what
//! a block delivers besides (the delimiter's telegrams: status, length, end tick, bytes) is
//! compared delivery by delivery. Installs verilator through apt-get as root
//! where it is missing. The last line: `rtl-check: cases=N clocks=M mismatches=K`.

use crate::{check_flags, flag_value, project_root, qemu_test::ensure_debian_tool};
use anyhow::{bail, Context, Result};
use dp_consts::Baud;
use rtl_check::{blocks, first_event_mismatch, first_mismatch, verilator, write_vcd, Block, Case};
use std::path::Path;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--quick"], &["--only"])?;
    let quick = args.iter().any(|a| a == "--quick");
    let only = flag_value(args, "--only")?;
    ensure_debian_tool("verilator", "verilator")?;
    let root = project_root();
    let gateware = root.join("gateware");
    let out = root.join("target/rtl");
    std::fs::create_dir_all(&out)?;
    let _lock = lock_rtl_dir(&out)?;

    // The checker must be able to fail: a transmitter one clock late.
    let late = blocks::uart_tx(true);
    let binary = build(&late, &gateware, &out)?;
    let case = &blocks::uart_tx_cases(true)[9];
    let (rtl, _) = verilator::run(&late, &binary, case, &out.join("work"))?;
    // The case opens with 5 idle clocks, then the buffer's clock: the start bit is clock 6.
    match first_mismatch(&case.model, &rtl, late.signals) {
        Some(m) if m.clock == 6 && m.signal == "tx" => {
            println!("rtl-check: the checker finds a transmitter built one clock late: {m}")
        }
        other => bail!("a transmitter one clock late was not found where it must be: {other:?}"),
    }

    // The character reader as the receiver builds it (a rate chosen at run time) and as each
    // search channel does (its own rate, constant, its registers as narrow as that allows).
    let run_time = blocks::run_time_width();
    let (reader_rates, own_width_rates): (Vec<Baud>, Vec<Baud>) = if quick {
        (
            vec![Baud::B45450, Baud::B1500000, Baud::B12000000],
            vec![Baud::B12000000],
        )
    } else {
        (Baud::ALL.to_vec(), Baud::ALL.to_vec())
    };
    let mut runs: Vec<(Block, Vec<Case>)> = vec![
        (blocks::line_sync(0), blocks::line_sync_cases(0, quick)),
        (blocks::line_sync(3), blocks::line_sync_cases(3, quick)),
        (
            blocks::char_reader(run_time),
            blocks::char_reader_cases(&reader_rates, run_time, quick),
        ),
        (
            blocks::autobaud(false),
            blocks::autobaud_cases(quick, false),
        ),
        (blocks::autobaud(true), blocks::autobaud_cases(quick, true)),
        (blocks::edge_rx(), blocks::edge_rx_cases(quick)),
        (blocks::rate_idle(), blocks::rate_idle_cases(quick)),
        (blocks::delimiter(), blocks::delimiter_cases(quick)),
        (blocks::uart_tx(false), blocks::uart_tx_cases(quick)),
        (blocks::transceiver(), blocks::transceiver_cases(quick)),
        (
            blocks::transceiver_near_wrap(),
            blocks::near_wrap_cases(quick),
        ),
    ];
    for width in [blocks::baud_watchdog_width(), blocks::dp_watchdog_width()] {
        runs.push((
            blocks::watchdog(width),
            blocks::watchdog_cases(width, quick),
        ));
    }
    for baud in own_width_rates {
        let width = blocks::width_of(baud);
        if width != run_time {
            runs.push((
                blocks::char_reader(width),
                blocks::char_reader_cases(&[baud], width, quick),
            ));
        }
    }
    if let Some(only) = only {
        runs.retain(|(block, _)| block.build_name().contains(only));
        if runs.is_empty() {
            bail!("no build's name holds `{only}`");
        }
    }
    let (mut cases, mut clocks, mut mismatches) = (0usize, 0u64, 0usize);
    for (block, block_cases) in &runs {
        let binary = build(block, &gateware, &out)?;
        let mut block_clocks = 0;
        let mut block_mismatches = 0;
        for case in block_cases {
            let (rtl, rtl_events) = verilator::run(block, &binary, case, &out.join("work"))?;
            block_clocks += case.model.clocks();
            let mismatch = first_mismatch(&case.model, &rtl, block.signals);
            if mismatch.is_none() {
                if let Some((i, model, rtl)) = first_event_mismatch(&case.model_events, &rtl_events)
                {
                    block_mismatches += 1;
                    println!(
                        "  MISMATCH {} ({} against {}): delivery {i}: model {model:02X?} rtl {rtl:02X?}",
                        case.name,
                        block.build_name(),
                        block.twin
                    );
                }
            }
            if let Some(m) = mismatch {
                block_mismatches += 1;
                let vcd = out.join(format!("{}.vcd", case.name));
                write_vcd(
                    &vcd,
                    block.signals,
                    &case.model,
                    &rtl,
                    u64::from(dp_phy::timing::DEFAULT_CLOCK_HZ),
                )?;
                println!(
                    "  MISMATCH {} ({} against {}): {m}; both sides in {}",
                    case.name,
                    block.build_name(),
                    block.twin,
                    vcd.display()
                );
            }
        }
        println!(
            "  {:<24} against {:<32} cases {:>3}  clocks {:>11}  mismatches {}",
            block.build_name(),
            block.twin,
            block_cases.len(),
            block_clocks,
            block_mismatches
        );
        cases += block_cases.len();
        clocks += block_clocks;
        mismatches += block_mismatches;
    }
    let (done, left): (Vec<_>, Vec<_>) = blocks::TRANSCEIVER_BLOCKS
        .iter()
        .partition(|(_, ported)| *ported);
    println!(
        "rtl-check: blocks ported {} of {} ({}); not yet: {}",
        done.len(),
        blocks::TRANSCEIVER_BLOCKS.len(),
        done.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
        left.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
    );
    println!("rtl-check: cases={cases} clocks={clocks} mismatches={mismatches}");
    if mismatches > 0 {
        bail!("{mismatches} case(s) differ from the model");
    }
    Ok(())
}

/// Holds `out` (`target/rtl`) for this run: the Verilated builds and the stimulus file there are
/// shared, and a second run in the same checkout rewrote the stimulus under the first one's
/// harness (which then stopped: `stimulus ends inside a record`). The lock goes with the file.
pub(crate) fn lock_rtl_dir(out: &Path) -> Result<std::fs::File> {
    let path = out.join("lock");
    let lock =
        std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
    match lock.try_lock() {
        Ok(()) => Ok(lock),
        Err(std::fs::TryLockError::WouldBlock) => bail!(
            "another rtl-check or phy-bench is using {} in this checkout (its Verilated builds \
             and stimulus are shared): wait for it to finish",
            out.display()
        ),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("locking {}", path.display()))
        }
    }
}

fn build(block: &Block, gateware: &Path, out: &Path) -> Result<std::path::PathBuf> {
    verilator::build(block, gateware, out)
        .with_context(|| format!("building {}", block.build_name()))
}
