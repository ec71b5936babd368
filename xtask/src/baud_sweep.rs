//! `cargo xtask baud-sweep`: the autobaud regression.
//!
//! Every rate x clock offset x noise level x start phase, from power-up and after the master
//! changes its rate. Each case sends real telegrams through the transceiver model (fast mode) and
//! records the rate locked, the telegrams lost before the lock, the lock time in bit times, false
//! locks (a lock at the wrong rate) and corrupt deliveries (a telegram delivered as good that was
//! never sent). Writes `target/baud-sweep/sweep[-i-of-N].csv` and `.svg`, and ends with
//! `baud-sweep: cases=N first-telegram-locks=M false-locks=F corrupt-delivered=C`; it fails when F
//! or C is not 0 or any case does not lock.

use crate::{check_flags, flag_value, project_root};
use anyhow::{bail, Context, Result};
use dp_phy::bus::FaultInjector;
use dp_phy::testbench::{random_telegram, Kind, Testbench};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::{Baud, BaudState, BitTiming, Config, Tick};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scenario {
    PowerUp,
    /// The adapter is locked at `from`, then the master switches to the case's rate.
    RateChange {
        from: Baud,
    },
}

#[derive(Clone, Copy, Debug)]
struct Case {
    scenario: Scenario,
    baud: Baud,
    ppm: i32,
    /// Glitches (shorter than half a bit) per telegram time: 0, 1 or 3.
    noise: u32,
    /// Start phase in sample clocks.
    phase: u64,
    seed: u64,
}

#[derive(Clone, Debug, Default)]
struct Outcome {
    locked: Option<Baud>,
    lost_before_lock: usize,
    lock_time_bits: f64,
    false_lock: bool,
    corrupt: usize,
}

const TELEGRAMS: usize = 12;
const CHANGE_TELEGRAMS: usize = 40;

fn cases(quick: bool) -> Vec<Case> {
    let offsets: &[i32] = if quick {
        &[-5000, 0, 5000]
    } else {
        &[-5000, -2500, 0, 2500, 5000]
    };
    let noises: &[u32] = if quick { &[0, 1] } else { &[0, 1, 3] };
    let phases: &[u64] = if quick {
        &[0, 777]
    } else {
        &[0, 1, 2, 3, 777, 12_345]
    };
    let mut out = Vec::new();
    let mut seed = 0;
    for (i, &baud) in Baud::ALL.iter().enumerate() {
        // The rate the adapter was on before: a far one and a neighbour, in turn.
        let from = Baud::ALL[(i + 5 + (i % 2) * 4) % 10];
        for scenario in [Scenario::PowerUp, Scenario::RateChange { from }] {
            for &ppm in offsets {
                for &noise in noises {
                    for &phase in phases {
                        seed += 1;
                        out.push(Case {
                            scenario,
                            baud,
                            ppm,
                            noise,
                            phase,
                            seed,
                        });
                    }
                }
            }
        }
    }
    out
}

fn run_case(c: &Case) -> Outcome {
    let mut rng = ChaCha8Rng::seed_from_u64(c.seed);
    let target = BitTiming::new(DEFAULT_CLOCK_HZ, c.baud, c.ppm);
    let first_timing = match c.scenario {
        Scenario::PowerUp => target,
        Scenario::RateChange { from } => BitTiming::new(DEFAULT_CLOCK_HZ, from, -c.ppm),
    };
    let mut tb = Testbench::new(Config::default(), first_timing, FaultInjector::none());
    tb.run_until(c.phase, true);
    if let Scenario::RateChange { .. } = c.scenario {
        tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 4));
        tb.run_out(40, true);
        tb.set_master_timing(target);
    }
    // From here on, the telegrams at the case's rate.
    let from_tick = tb.now();
    let from_sent = tb.sent.len();
    let (count, idle) = match c.scenario {
        // A master polls as fast as it may; with more noise, more telegrams give the search its
        // chance (a glitch within TSYN before a telegram rightly costs that telegram).
        Scenario::PowerUp => (TELEGRAMS * (1 + c.noise as usize), 33),
        // A telegram every 10 ms, so the 200 ms baud watchdog lets go within the run.
        Scenario::RateChange { .. } => (CHANGE_TELEGRAMS, (c.baud.bits_per_second() / 100).max(33)),
    };
    let mut sent = Vec::new();
    for i in 0..count {
        let kind = if i == 0 {
            [Kind::Sd1, Kind::Sd2, Kind::Sd3, Kind::Sd4][rng.gen_range(0..4)]
        } else {
            Kind::ALL[rng.gen_range(0..5)]
        };
        let n = rng.gen_range(1..32);
        let t = random_telegram(&mut rng, kind, n);
        tb.send(if i == 0 { 40 } else { idle }, &t);
        sent.push(t);
    }
    if c.noise > 0 {
        let bits_per_telegram = idle as u64 + 40 * 11;
        let span = target.clocks_for(count as u64 * bits_per_telegram, 1);
        let mut f = FaultInjector::none();
        let max_len = (target.clocks_per_bit() / 2).saturating_sub(1).max(1);
        f.glitches(
            c.seed,
            from_tick,
            from_tick + span,
            count * c.noise as usize,
            max_len,
        );
        tb.bus.faults = f;
    }
    tb.run_out(40, true);

    let mut o = Outcome::default();
    let lock = tb
        .baud_log
        .iter()
        .filter(|(t, _)| *t >= from_tick)
        .find_map(|&(t, s)| match s {
            BaudState::Locked(b) => Some((t, b)),
            _ => None,
        });
    if let Some((t, b)) = lock {
        o.locked = Some(b);
        o.false_lock = b != c.baud;
        // A telegram's first start bit follows its hand-over by its idle bits.
        let starts: Vec<Tick> = tb.sent[from_sent..]
            .iter()
            .map(|(t, o)| t + target.clocks_for(o.idle_bits as u64, 1))
            .collect();
        // Telegrams handed to the master before the one that locked (whose start is the last
        // before the lock tick).
        o.lost_before_lock = starts.iter().filter(|&&s| s < t).count().saturating_sub(1);
        let first_start = starts.first().copied().unwrap_or(from_tick);
        o.lock_time_bits =
            (t - first_start) as f64 * c.baud.bits_per_second() as f64 / DEFAULT_CLOCK_HZ as f64;
    }
    let before: Vec<Vec<u8>> = tb.sent[..from_sent]
        .iter()
        .map(|(_, o)| o.bytes.clone())
        .collect();
    o.corrupt = tb
        .good()
        .iter()
        .filter(|g| !sent.contains(g) && !before.contains(g))
        .count();
    o
}

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--quick"], &["--shard"])?;
    let quick = args.iter().any(|a| a == "--quick");
    let (shard, shards) = match flag_value(args, "--shard")? {
        None => (1, 1),
        Some(s) => {
            let (i, n) = s.split_once('/').context("--shard takes i/N, e.g. 2/4")?;
            let (i, n): (usize, usize) = (i.parse()?, n.parse()?);
            if n == 0 || i == 0 || i > n {
                bail!("--shard {s}: i must be in 1..=N");
            }
            (i, n)
        }
    };
    let all = cases(quick);
    let mine: Vec<Case> = all
        .iter()
        .enumerate()
        .filter(|(k, _)| k % shards == shard - 1)
        .map(|(_, c)| *c)
        .collect();
    println!(
        "baud-sweep: {} of {} cases ({}shard {shard}/{shards})",
        mine.len(),
        all.len(),
        if quick { "quick, " } else { "" }
    );

    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(4);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut outcomes: Vec<(usize, Outcome)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|w| {
                let mine = &mine;
                let done = &done;
                s.spawn(move || {
                    let mut out = Vec::new();
                    for (k, c) in mine.iter().enumerate().filter(|(k, _)| k % workers == w) {
                        out.push((k, run_case(c)));
                        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        if n.is_multiple_of(20) || n == mine.len() {
                            println!("  {n}/{} cases", mine.len());
                        }
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    });
    outcomes.sort_by_key(|(k, _)| *k);

    let mut csv = String::from(
        "scenario,rate,ppm,noise,phase,locked_rate,first_telegram_lock,lost_before_lock,lock_time_bits,false_lock,corrupt_delivered\n",
    );
    let (mut first, mut false_locks, mut corrupt, mut unlocked) = (0, 0, 0, 0);
    for (k, o) in &outcomes {
        let c = &mine[*k];
        let scenario = match c.scenario {
            Scenario::PowerUp => "power-up".to_string(),
            Scenario::RateChange { from } => format!("change-from-{from}"),
        };
        let first_lock = o.locked == Some(c.baud) && o.lost_before_lock == 0;
        first += first_lock as usize;
        false_locks += o.false_lock as usize;
        corrupt += o.corrupt;
        if o.locked.is_none() {
            unlocked += 1;
            println!("  no lock: {c:?}");
        }
        if o.false_lock || o.corrupt > 0 {
            println!("  FAILED: {c:?} -> {o:?}");
        }
        writeln!(
            csv,
            "{scenario},{},{},{},{},{},{},{},{:.1},{},{}",
            c.baud,
            c.ppm,
            c.noise,
            c.phase,
            o.locked.map_or("none".into(), |b| b.to_string()),
            first_lock,
            o.lost_before_lock,
            o.lock_time_bits,
            o.false_lock,
            o.corrupt
        )?;
    }
    let dir = project_root().join("target/baud-sweep");
    std::fs::create_dir_all(&dir)?;
    let stem = if shards == 1 {
        "sweep".to_string()
    } else {
        format!("sweep-{shard}-of-{shards}")
    };
    let csv_path = dir.join(format!("{stem}.csv"));
    std::fs::write(&csv_path, csv)?;
    let svg_path = dir.join(format!("{stem}.svg"));
    plot(&svg_path, &mine, &outcomes)?;
    println!("wrote {} and {}", csv_path.display(), svg_path.display());
    println!(
        "baud-sweep: cases={} first-telegram-locks={first} false-locks={false_locks} corrupt-delivered={corrupt}",
        mine.len()
    );
    if false_locks > 0 || corrupt > 0 || unlocked > 0 {
        bail!("{false_locks} false locks, {corrupt} corrupt deliveries, {unlocked} cases without a lock");
    }
    Ok(())
}

/// A named line of (rate index, mean lock time in bits, mean telegrams lost).
type Series = (String, Vec<(f64, f64, f64)>);

/// Two panels: mean lock time (bit times) and mean telegrams lost before the lock, per rate, one
/// line per scenario and clock offset.
fn plot(path: &std::path::Path, cases: &[Case], outcomes: &[(usize, Outcome)]) -> Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (1200, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(600);
    let mut series: Vec<Series> = Vec::new();
    let mut offsets: Vec<i32> = cases.iter().map(|c| c.ppm).collect();
    offsets.sort();
    offsets.dedup();
    for change in [false, true] {
        for &ppm in &offsets {
            let mut pts = Vec::new();
            for baud in Baud::ALL {
                let sel: Vec<&Outcome> = outcomes
                    .iter()
                    .filter(|(k, _)| {
                        let c = &cases[*k];
                        c.baud == baud
                            && c.ppm == ppm
                            && matches!(c.scenario, Scenario::RateChange { .. }) == change
                    })
                    .map(|(_, o)| o)
                    .collect();
                if sel.is_empty() {
                    continue;
                }
                let n = sel.len() as f64;
                let time = sel.iter().map(|o| o.lock_time_bits).sum::<f64>() / n;
                let lost = sel.iter().map(|o| o.lost_before_lock as f64).sum::<f64>() / n;
                pts.push((baud.index() as f64, time.max(1.0), lost));
            }
            let name = format!(
                "{} {ppm:+} ppm",
                if change { "rate change" } else { "power-up" }
            );
            series.push((name, pts));
        }
    }
    let max_time = series
        .iter()
        .flat_map(|(_, p)| p.iter().map(|x| x.1))
        .fold(10.0, f64::max);
    let max_lost = series
        .iter()
        .flat_map(|(_, p)| p.iter().map(|x| x.2))
        .fold(1.0, f64::max);
    let label = |x: &f64| {
        Baud::ALL
            .get(*x as usize)
            .map_or(String::new(), |b| b.to_string())
    };
    let mut time_chart = ChartBuilder::on(&left)
        .caption("lock time (bit times, mean)", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5f64..9.5, (1.0f64..max_time * 2.0).log_scale())?;
    time_chart
        .configure_mesh()
        .x_labels(10)
        .x_label_formatter(&label)
        .draw()?;
    let mut lost_chart = ChartBuilder::on(&right)
        .caption("telegrams lost before lock (mean)", ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(-0.5f64..9.5, 0f64..max_lost * 1.2)?;
    lost_chart
        .configure_mesh()
        .x_labels(10)
        .x_label_formatter(&label)
        .draw()?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        time_chart
            .draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                color.stroke_width(2),
            ))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
        lost_chart.draw_series(LineSeries::new(
            pts.iter().map(|p| (p.0, p.2)),
            color.stroke_width(2),
        ))?;
    }
    time_chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}
