//! `cargo xtask rtl-check [--quick] [--only BUILD] [--jobs N] [--shard i/N]`: the gateware's
//! blocks against their Rust twins in dp-phy, clock for clock (crates/rtl-check); `--only` runs
//! the builds whose name holds BUILD (`autobaud-Oversampled1`, `char_reader`), for work on one
//! block. A block's cases run N harnesses at once (`--jobs`, by default one a core), each in a
//! work directory of its own; `--shard i/N` runs the i-th of N shares of every block's cases
//! (by position: the GitHub workflow's matrix, or a full run split over sessions), and the
//! model makes only those.
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
use dp_phy::sweep::Shard;
use rayon::prelude::*;
use rtl_check::{blocks, first_event_mismatch, first_mismatch, verilator, write_vcd, Block, Case};
use std::path::Path;

/// A build's cases, made when it runs.
type CaseList = Box<dyn FnOnce() -> Vec<Case>>;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--quick"], &["--only", "--jobs", "--shard"])?;
    let quick = args.iter().any(|a| a == "--quick");
    let only = flag_value(args, "--only")?;
    let jobs = match flag_value(args, "--jobs")? {
        Some(n) => match n.parse::<usize>() {
            Ok(n) if n > 0 => n,
            _ => bail!("--jobs needs a number of harnesses at once, 1 or more, not `{n}`"),
        },
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let shard = match flag_value(args, "--shard")? {
        None => Shard::ALL,
        Some(s) => s.parse().map_err(anyhow::Error::msg)?,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .context("starting the harnesses' threads")?;
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
    // Each build with its cases, made only for the builds that run (the top's full set is
    // minutes of the model in strict mode): a shard takes every block's cases by position.
    let sharded = move |cases: Vec<Case>| -> Vec<Case> {
        cases
            .into_iter()
            .enumerate()
            .filter(|(k, _)| shard.holds(*k))
            .map(|(_, c)| c)
            .collect()
    };
    let mut runs: Vec<(Block, CaseList)> = vec![
        (
            blocks::line_sync(0),
            Box::new(move || sharded(blocks::line_sync_cases(0, quick))),
        ),
        (
            blocks::line_sync(3),
            Box::new(move || sharded(blocks::line_sync_cases(3, quick))),
        ),
        (
            blocks::char_reader(run_time),
            Box::new(move || sharded(blocks::char_reader_cases(&reader_rates, run_time, quick))),
        ),
        (
            blocks::autobaud(false),
            Box::new(move || sharded(blocks::autobaud_cases(quick, false))),
        ),
        (
            blocks::autobaud(true),
            Box::new(move || sharded(blocks::autobaud_cases(quick, true))),
        ),
        (
            blocks::edge_rx(),
            Box::new(move || sharded(blocks::edge_rx_cases(quick))),
        ),
        (
            blocks::rate_idle(),
            Box::new(move || sharded(blocks::rate_idle_cases(quick))),
        ),
        (
            blocks::delimiter(),
            Box::new(move || sharded(blocks::delimiter_cases(quick))),
        ),
        (
            blocks::uart_tx(false),
            Box::new(move || sharded(blocks::uart_tx_cases(quick))),
        ),
        (
            blocks::transceiver(),
            Box::new(move || blocks::transceiver_cases(quick, shard)),
        ),
        (
            blocks::transceiver_near_wrap(),
            Box::new(move || sharded(blocks::near_wrap_cases(quick))),
        ),
    ];
    for width in [blocks::baud_watchdog_width(), blocks::dp_watchdog_width()] {
        runs.push((
            blocks::watchdog(width),
            Box::new(move || sharded(blocks::watchdog_cases(width, quick))),
        ));
    }
    for baud in own_width_rates {
        let width = blocks::width_of(baud);
        if width != run_time {
            runs.push((
                blocks::char_reader(width),
                Box::new(move || sharded(blocks::char_reader_cases(&[baud], width, quick))),
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
    for (block, make_cases) in runs {
        let binary = build(&block, &gateware, &out)?;
        let block_cases = make_cases();
        let block_mismatches = run_cases(&pool, &block, &binary, &block_cases, &out)?;
        let block_clocks: u64 = block_cases.iter().map(|c| c.model.clocks()).sum();
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
    if shard != Shard::ALL {
        println!("rtl-check: shard {shard} of every block's cases (by position)");
    }
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

/// Runs `block`'s harness on each of `cases` on `pool`'s threads (each in a work directory of
/// its own under `out`: the harness reads its stimulus from a file), and compares each with the
/// model; prints each mismatch as it is found, with its VCD. Returns the mismatches.
fn run_cases(
    pool: &rayon::ThreadPool,
    block: &Block,
    binary: &Path,
    cases: &[Case],
    out: &Path,
) -> Result<usize> {
    let reports = pool.install(|| {
        // One case a task: a case is seconds to minutes of a harness, and a run of them that a
        // thread had begun in sequence could not be shared (rayon's default splitting).
        cases
            .par_iter()
            .with_max_len(1)
            .map(|case| {
                let worker = rayon::current_thread_index().unwrap_or(0);
                let work = out.join(format!("work-{worker}"));
                let report = compare_case(block, binary, case, out, &work)?;
                if let Some(line) = &report {
                    println!("{line}");
                }
                Ok(report)
            })
            .collect::<Result<Vec<_>>>()
    })?;
    Ok(reports.iter().flatten().count())
}

/// One case: the harness's outputs against the model's, clock for clock, then (where those
/// agree) delivery by delivery. Returns the mismatch's report line, its VCD written.
fn compare_case(
    block: &Block,
    binary: &Path,
    case: &Case,
    out: &Path,
    work: &Path,
) -> Result<Option<String>> {
    let (rtl, rtl_events) = verilator::run(block, binary, case, work)?;
    if let Some(m) = first_mismatch(&case.model, &rtl, block.signals) {
        let vcd = out.join(format!("{}.vcd", case.name));
        write_vcd(
            &vcd,
            block.signals,
            &case.model,
            &rtl,
            u64::from(dp_phy::timing::DEFAULT_CLOCK_HZ),
        )?;
        return Ok(Some(format!(
            "  MISMATCH {} ({} against {}): {m}; both sides in {}",
            case.name,
            block.build_name(),
            block.twin,
            vcd.display()
        )));
    }
    Ok(
        first_event_mismatch(&case.model_events, &rtl_events).map(|(i, model, rtl)| {
            format!(
                "  MISMATCH {} ({} against {}): delivery {i}: model {model:02X?} rtl {rtl:02X?}",
                case.name,
                block.build_name(),
                block.twin
            )
        }),
    )
}

fn build(block: &Block, gateware: &Path, out: &Path) -> Result<std::path::PathBuf> {
    verilator::build(block, gateware, out)
        .with_context(|| format!("building {}", block.build_name()))
}
