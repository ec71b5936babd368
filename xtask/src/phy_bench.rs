//! `cargo xtask phy-bench`: how fast the transceiver model runs.
//!
//! Workload: for each of the ten rates, from power-up, 200 SD2 telegrams of 20 bytes, each after
//! 33 idle bits, through the receiver with autodetect, every delivered byte checked (about 482
//! million ticks of the 48 MHz clock, 10.05 s of bus time). Strict mode calls `tick()` once per
//! clock; fast mode skips quiet spans. Both must deliver every telegram. Figures are medians of
//! `--runs` runs (default 3; `--only strict|fast` runs one mode); the last line is
//! `phy-bench: ticks=N errors=E strict_s=X fast_s=Y`.

use crate::{check_flags, flag_value, median};
use anyhow::{bail, Result};
use dp_phy::bus::FaultInjector;
use dp_phy::testbench::{random_telegram, Kind, Testbench};
use dp_phy::{Baud, BitTiming, Config};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

const TELEGRAMS_PER_RATE: usize = 200;
/// 20 bytes on the wire: SD2 LE LEr SD2 DA SA FC, 11 data bytes, FCS ED.
const DATA_BYTES: usize = 11;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--runs", "--only"])?;
    let modes: &[bool] = match flag_value(args, "--only")? {
        None => &[false, true],
        Some("strict") => &[false],
        Some("fast") => &[true],
        Some(other) => bail!("--only takes strict or fast, not {other}"),
    };
    let runs: usize = flag_value(args, "--runs")?.map_or(Ok(3), str::parse)?;
    if runs == 0 {
        bail!("--runs must be at least 1");
    }
    let mut strict_s = Vec::new();
    let mut fast_s = Vec::new();
    let mut ticks = 0;
    let mut errors = 0;
    for run in 1..=runs {
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
        let secs = median(if fast_s.is_empty() {
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
    println!(
        "median: strict {:.1} M ticks/s, fast {:.0} M ticks/s, fast/strict = {:.0}x",
        ticks as f64 / strict / 1e6,
        ticks as f64 / fast / 1e6,
        strict / fast
    );
    println!("phy-bench: ticks={ticks} errors={errors} strict_s={strict:.3} fast_s={fast:.4}");
    if errors > 0 {
        bail!("{errors} telegrams were not delivered exactly");
    }
    Ok(())
}

/// The whole workload once; returns (ticks simulated, telegrams not delivered exactly).
fn workload(fast: bool) -> (u64, u64) {
    let mut ticks = 0;
    let mut errors = 0;
    for baud in Baud::ALL {
        let mut rng = ChaCha8Rng::seed_from_u64(baud.index() as u64);
        let timing = BitTiming::new(dp_phy::timing::DEFAULT_CLOCK_HZ, baud, 0);
        let mut tb = Testbench::new(Config::default(), timing, FaultInjector::none());
        let mut sent = Vec::with_capacity(TELEGRAMS_PER_RATE);
        for _ in 0..TELEGRAMS_PER_RATE {
            let t = random_telegram(&mut rng, Kind::Sd2, DATA_BYTES);
            tb.send(33, &t);
            sent.push(t);
        }
        tb.run_out(0, fast);
        // The last telegram is delivered at the last vote of its last stop bit.
        let end = tb.now() + timing.clocks_for(1, 1);
        tb.run_until(end, fast);
        ticks += tb.now();
        let good = tb.good();
        errors += sent.len().abs_diff(good.len()) as u64;
        errors += sent.iter().zip(&good).filter(|(a, b)| a != b).count() as u64;
    }
    (ticks, errors)
}
