//! `cargo xtask dp-cycle [--slaves N] [--cycles N] [--hsa N]`: ten adapters on one simulated line with
//! one profirust master, at 1.5 and 12 Mbit/s, PPO1-5; the master's median cycle against the
//! line's floor, and where the cycle's bit times went (a benchmark that prints figures, not a
//! timed test).

use crate::{check_flags, flag_value};
use anyhow::{Context, Result};
use dp_consts::Baud;
use hal_sim::dp_cycle;
use profidrive::ppo::Ppo;

const PPOS: [Ppo; 5] = [Ppo::Ppo1, Ppo::Ppo2, Ppo::Ppo3, Ppo::Ppo4, Ppo::Ppo5];
const RATES: [Baud; 2] = [Baud::B1500000, Baud::B12000000];

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--slaves", "--cycles", "--hsa"])?;
    let slaves: usize = flag_value(args, "--slaves")?
        .map_or(Ok(10), str::parse)
        .context("--slaves takes a number")?;
    let cycles: usize = flag_value(args, "--cycles")?
        .map_or(Ok(50), str::parse)
        .context("--cycles takes a number")?;
    let hsa: u8 = flag_value(args, "--hsa")?
        .map_or(Ok(dp_cycle::default_hsa(slaves)), str::parse)
        .context("--hsa takes a station address")?;
    println!(
        "one profirust master at address {}, {slaves} adapters from address {}, HSA {hsa} (--hsa)",
        dp_cycle::MASTER_ADDRESS,
        dp_cycle::FIRST_ADDRESS
    );
    let mut runs = Vec::new();
    for baud in RATES {
        for ppo in PPOS {
            let r = dp_cycle::run(baud, ppo, slaves, cycles, hsa)?;
            println!(
                "dp-cycle: rate={} ppo=PPO{} slaves={} cycle_us={:.1} floor_us={:.1} ratio={:.3}",
                baud,
                ppo.number(),
                r.slaves,
                r.cycle_us,
                r.floor_us,
                r.ratio()
            );
            runs.push(r);
        }
    }
    for baud in RATES {
        println!("breakdown at {baud} (bit times, the mean of {cycles} cycles):");
        println!(
            "  {:<5} {:>7} {:>7} {:>9} {:>10} {:>5} {:>5} {:>7} {:>6} {:>7} {:>8}",
            "ppo",
            "cycle",
            "floor",
            "requests",
            "responses",
            "tsyn",
            "tsdr",
            "tsdr %",
            "gap",
            "master",
            "without"
        );
        for r in runs.iter().filter(|r| r.baud == baud) {
            let b = r.breakdown;
            let cycle_bits = r.mean_cycle_bits as f64;
            let floor = dp_cycle::floor_bits(r.ppo, r.slaves);
            println!(
                "  PPO{:<2} {:>7.0} {:>7} {:>9} {:>10} {:>5} {:>5} {:>6.1}% {:>6} {:>7} {:>8.3}",
                r.ppo.number(),
                cycle_bits,
                floor,
                b.request_bits,
                b.response_bits,
                b.tsyn_bits,
                b.tsdr_bits,
                100.0 * b.tsdr_bits as f64 / cycle_bits,
                b.gap_bits,
                b.master_bits,
                (cycle_bits - (b.gap_bits + b.master_bits) as f64) / floor as f64,
            );
        }
        let worst = runs
            .iter()
            .filter(|r| r.baud == baud)
            .map(|r| r.worst_tsdr_bits)
            .max()
            .unwrap_or(0);
        println!(
            "  tsdr: the adapters' part, at most {worst} bit times an answer (min TSDR 11); tsyn: \
             the 33 idle bit times before each request; gap: profirust's GAP poll (one FDL_Status \
             a token rotation, HSA just above the last adapter) and the slot time it waits where \
             nobody answers; master: its token, Global_Control, its idle beyond TSYN; without: \
             the ratio without the master's parts"
        );
    }
    Ok(())
}
