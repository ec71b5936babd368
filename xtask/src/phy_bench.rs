//! `cargo xtask phy-bench`: how fast the transceiver model runs.
//!
//! Workload: for each of the ten rates, from power-up, 200 SD2 telegrams of 20 bytes, each after
//! 33 idle bits, through the receiver with autodetect, every delivered byte checked (about 482
//! million ticks of the 48 MHz clock, 10.05 s of bus time). Strict mode calls `tick()` once per
//! clock; fast mode skips quiet spans. Both must deliver every telegram. The RTL row runs the
//! gateware's receive path (`gateware/rtl/transceiver.v`, Verilated as rtl-check builds it) on
//! the same line, recorded once from a strict run, and compares every clock and delivery with
//! the model's (a case that differs is an error); its time is the harness's, stimulus file and
//! outputs included. Figures are medians of `--runs` runs (default 3; `--only
//! strict|fast|rtl` runs one mode); the last line is
//! `phy-bench: ticks=N errors=E strict_s=X fast_s=Y rtl_s=Z`.

use crate::{check_flags, flag_value, median, project_root, qemu_test::ensure_debian_tool};
use anyhow::{bail, Context, Result};
use dp_phy::bus::FaultInjector;
use dp_phy::testbench::{random_telegram, Kind, Testbench};
use dp_phy::{Baud, BitTiming, Config};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rtl_check::{blocks, first_event_mismatch, first_mismatch, verilator, Block, Case};
use std::path::PathBuf;
use std::time::Instant;

const TELEGRAMS_PER_RATE: usize = 200;
/// 20 bytes on the wire: SD2 LE LEr SD2 DA SA FC, 11 data bytes, FCS ED.
const DATA_BYTES: usize = 11;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--runs", "--only"])?;
    let (modes, with_rtl): (&[bool], bool) = match flag_value(args, "--only")? {
        None => (&[false, true], true),
        Some("strict") => (&[false], false),
        Some("fast") => (&[true], false),
        Some("rtl") => (&[], true),
        Some(other) => bail!("--only takes strict, fast or rtl, not {other}"),
    };
    let runs: usize = flag_value(args, "--runs")?.map_or(Ok(3), str::parse)?;
    if runs == 0 {
        bail!("--runs must be at least 1");
    }
    let mut strict_s = Vec::new();
    let mut fast_s = Vec::new();
    let mut rtl_s = Vec::new();
    let mut ticks = 0;
    let mut errors = 0;
    let rtl = if with_rtl {
        Some(RtlBench::new()?)
    } else {
        None
    };
    for run in 1..=runs {
        if let Some(rtl) = &rtl {
            let start = Instant::now();
            let (t, e) = rtl.run()?;
            let secs = start.elapsed().as_secs_f64();
            println!(
                "run {run}/{runs} rtl   : {t} ticks in {secs:.3} s ({:.1} M ticks/s), {e} cases differ from the model",
                t as f64 / secs / 1e6
            );
            ticks = t;
            errors += e;
            rtl_s.push(secs);
        }
        for &fast in modes {
            let start = Instant::now();
            let (t, e) = workload(fast);
            let secs = start.elapsed().as_secs_f64();
            println!(
                "run {run}/{runs} {:6}: {t} ticks in {secs:.3} s ({:.1} M ticks/s), {e} errors",
                if fast { "fast" } else { "strict" },
                t as f64 / secs / 1e6
            );
            ticks = t;
            errors += e;
            if fast {
                fast_s.push(secs);
            } else {
                strict_s.push(secs);
            }
        }
    }
    if strict_s.is_empty() || fast_s.is_empty() {
        let secs = median(if !rtl_s.is_empty() {
            &mut rtl_s
        } else if fast_s.is_empty() {
            &mut strict_s
        } else {
            &mut fast_s
        });
        println!("phy-bench: ticks={ticks} errors={errors} seconds={secs:.4}");
        return if errors > 0 {
            bail!("{errors} telegrams were not delivered exactly")
        } else {
            Ok(())
        };
    }
    let strict = median(&mut strict_s);
    let fast = median(&mut fast_s);
    let rtl = median(&mut rtl_s);
    println!(
        "median: strict {:.1} M ticks/s, fast {:.0} M ticks/s, rtl {:.2} M ticks/s; fast/strict = {:.0}x, strict/rtl = {:.1}x, fast/rtl = {:.0}x",
        ticks as f64 / strict / 1e6,
        ticks as f64 / fast / 1e6,
        ticks as f64 / rtl / 1e6,
        strict / fast,
        rtl / strict,
        rtl / fast
    );
    println!(
        "phy-bench: ticks={ticks} errors={errors} strict_s={strict:.3} fast_s={fast:.4} rtl_s={rtl:.2}"
    );
    if errors > 0 {
        bail!("{errors} telegrams were not delivered exactly");
    }
    Ok(())
}

/// The master's timing at `baud`.
fn master_timing(baud: Baud) -> BitTiming {
    BitTiming::new(dp_phy::timing::DEFAULT_CLOCK_HZ, baud, 0)
}

/// One rate's share of the workload on `tb`; returns the telegrams sent.
fn drive(tb: &mut Testbench, baud: Baud, fast: bool) -> Vec<Vec<u8>> {
    let mut rng = ChaCha8Rng::seed_from_u64(baud.index() as u64);
    let mut sent = Vec::with_capacity(TELEGRAMS_PER_RATE);
    for _ in 0..TELEGRAMS_PER_RATE {
        let t = random_telegram(&mut rng, Kind::Sd2, DATA_BYTES);
        tb.send(33, &t);
        sent.push(t);
    }
    tb.run_out(0, fast);
    // The last telegram is delivered at the last vote of its last stop bit.
    let end = tb.now() + master_timing(baud).clocks_for(1, 1);
    tb.run_until(end, fast);
    sent
}

/// The whole workload once; returns (ticks simulated, telegrams not delivered exactly).
fn workload(fast: bool) -> (u64, u64) {
    let mut ticks = 0;
    let mut errors = 0;
    for baud in Baud::ALL {
        let mut tb = Testbench::new(
            Config::default(),
            master_timing(baud),
            FaultInjector::none(),
        );
        let sent = drive(&mut tb, baud, fast);
        ticks += tb.now();
        let good = tb.good();
        errors += sent.len().abs_diff(good.len()) as u64;
        errors += sent.iter().zip(&good).filter(|(a, b)| a != b).count() as u64;
    }
    (ticks, errors)
}

/// The Verilated receive path and the workload's line at every rate, recorded from strict runs
/// of the model with what it did at every clock.
struct RtlBench {
    block: Block,
    binary: PathBuf,
    work: PathBuf,
    cases: Vec<Case>,
    /// `target/rtl` held while the bench runs (rtl-check shares it).
    _lock: std::fs::File,
}

impl RtlBench {
    fn new() -> Result<RtlBench> {
        ensure_debian_tool("verilator", "verilator")?;
        let root = project_root();
        let out = root.join("target/rtl");
        std::fs::create_dir_all(&out)?;
        let lock = crate::rtl_check::lock_rtl_dir(&out)?;
        let block = blocks::transceiver();
        let binary = verilator::build(&block, &root.join("gateware"), &out)
            .context("building the transceiver's receive path")?;
        let cases = Baud::ALL
            .iter()
            .map(|&baud| {
                blocks::bench_case(format!("phy-bench-{baud}"), master_timing(baud), |tb| {
                    drive(tb, baud, false);
                })
            })
            .collect();
        Ok(RtlBench {
            block,
            binary,
            work: out.join("phy-bench"),
            cases,
            _lock: lock,
        })
    }

    /// The workload through the RTL; returns (ticks, cases that differ from the model).
    fn run(&self) -> Result<(u64, u64)> {
        let (mut ticks, mut differ) = (0, 0);
        for case in &self.cases {
            let (trace, events) = verilator::run(&self.block, &self.binary, case, &self.work)?;
            ticks += trace.clocks();
            if first_mismatch(&case.model, &trace, self.block.signals).is_some()
                || first_event_mismatch(&case.model_events, &events).is_some()
            {
                println!("  {}: the RTL differs from the model", case.name);
                differ += 1;
            }
        }
        Ok((ticks, differ))
    }
}
