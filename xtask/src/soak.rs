//! `cargo xtask soak [--seed S] [--minutes M] [--events N] [--in-process] [--trace-from K]
//! [--broken fail-safe]`: the soak campaign (hal-sim's `soak`) on the real firmware image
//! under QEMU, or on the firmware's logic in-process with `--in-process`.
//!
//! Contract:
//! - It runs events of seed S's schedule until N have run or M minutes of wall time have
//!   passed (whichever comes first; with neither, 300 events).
//! - Its last line is `soak: seed=S events=N simulated_s=T invariants_checked=C violations=V`;
//!   it exits non-zero on a violation, after printing the seed, the event index, the last
//!   events and a command that replays that run up to the event that failed (the same events;
//!   in-process the same clocks too, under QEMU within a few clocks), with a waveform of that
//!   event (`--trace-from`) and the firmware's log, both under `target/soak/seed-S/`.
//! - `--broken fail-safe` builds the image with the fail-safe counted but never applied
//!   (firmware feature `broken-fail-safe`): the proof that the campaign finds a defect.
//! - A firmware that logged an ERROR line (a panic, a HardFault, a failed self-test) is a
//!   violation too, found once the run's log is decoded.

use crate::qemu_test::{self, Image, QEMU_IMAGE};
use crate::{check_flags, flag_value, project_root};
use anyhow::{bail, Context, Result};
use hal_sim::firmware::{Firmware, InProcess, Qemu};
use hal_sim::soak::{self, Options, Summary};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Events run when neither `--events` nor `--minutes` is given.
const DEFAULT_EVENTS: u64 = 300;

/// The deliberately broken builds: `--broken NAME` and the firmware feature it builds with.
const BROKEN_BUILDS: [(&str, &str); 1] = [("fail-safe", "broken-fail-safe")];

pub fn run(args: &[String]) -> Result<()> {
    check_flags(
        args,
        &["--in-process"],
        &[
            "--seed",
            "--minutes",
            "--events",
            "--trace-from",
            "--broken",
        ],
    )?;
    let number = |name: &str| -> Result<Option<u64>> {
        flag_value(args, name)?
            .map(|v| {
                v.parse()
                    .with_context(|| format!("{name} takes a number, not {v:?}"))
            })
            .transpose()
    };
    let seed = number("--seed")?.unwrap_or(1);
    let minutes = number("--minutes")?;
    let events = number("--events")?;
    let trace_from = number("--trace-from")?;
    let in_process = args.iter().any(|a| a == "--in-process");
    let broken = match flag_value(args, "--broken")? {
        None => None,
        Some(name) => match BROKEN_BUILDS.iter().find(|(n, _)| *n == name) {
            Some(&(_, feature)) => Some((name, feature)),
            None => bail!("no broken build named {name:?} (known: fail-safe)"),
        },
    };
    if in_process && broken.is_some() {
        bail!("--broken builds a firmware image: it runs under QEMU, not with --in-process");
    }
    let out_dir = project_root().join(format!("target/soak/seed-{seed}"));
    std::fs::create_dir_all(&out_dir)?;
    let options = Options {
        seed,
        events: events.unwrap_or(if minutes.is_some() {
            u64::MAX
        } else {
            DEFAULT_EVENTS
        }),
        deadline: minutes.map(|m| Instant::now() + Duration::from_secs(60 * m)),
        trace_from: trace_from.map(|k| (k, out_dir.join(format!("event-{k}.vcd")))),
    };
    let started = Instant::now();
    let summary = if in_process {
        soak::run(InProcess::new(), &options)?.0
    } else {
        under_qemu(&options, broken.map(|(_, f)| f), &out_dir)?
    };
    let rerun = reproduction(&summary, in_process, broken.map(|(n, _)| n));
    report(&summary, &rerun, &out_dir, started.elapsed());
    if summary.violations() > 0 {
        std::process::exit(1);
    }
    Ok(())
}

/// Builds the QEMU board's image (with `feature`, for a broken build) and runs the campaign
/// on it; returns the summary with the ERROR lines of the firmware's log, which it writes to
/// `out_dir/firmware.log`.
fn under_qemu(
    options: &Options,
    feature: Option<&'static str>,
    out_dir: &std::path::Path,
) -> Result<Summary> {
    qemu_test::ensure_target()?;
    let qemu = qemu_test::ensure_qemu()?;
    let image = Image {
        extra_feature: feature,
        ..QEMU_IMAGE
    };
    let elf = qemu_test::build(&image)?;
    let table = qemu_test::defmt_table(&elf)?;
    let machine = image.machine().expect("the QEMU board runs under QEMU");
    let firmware = Qemu::start(&qemu, &elf, machine).context("starting QEMU")?;
    let (mut summary, mut firmware) = soak::run(firmware, options)?;
    // The deepest stack of the run, as qemu-test holds each scenario to it.
    let stack = firmware.stack_peak().ok().flatten();
    let streams = firmware.stop();
    let mut log = String::new();
    for (run, bytes) in streams.iter().enumerate() {
        log.push_str(&format!("--- firmware log, power-up {} ---\n", run + 1));
        for (level, message) in qemu_test::decode(&table, bytes)? {
            if level == "ERROR" {
                summary
                    .firmware_errors
                    .push(format!("power-up {}: {message}", run + 1));
            }
            log.push_str(&format!("{level:<5} {message}\n"));
        }
    }
    std::fs::write(out_dir.join("firmware.log"), log)?;
    if let Some(p) = stack {
        println!(
            "soak: the firmware's stack reached {} of the {} B above its statics",
            p.used_bytes, p.room_bytes
        );
    }
    Ok(summary)
}

/// The command that replays `summary`'s run up to its violation, with a waveform of the
/// event that failed.
fn reproduction(summary: &Summary, in_process: bool, broken: Option<&str>) -> Option<String> {
    let mut command = match (&summary.violation, summary.firmware_errors.is_empty()) {
        (Some(v), _) => format!(
            "cargo xtask soak --seed {} --events {} --trace-from {}",
            summary.seed,
            v.event + 1,
            v.event
        ),
        // An ERROR in the log is found after the run, not at an event: the whole run again.
        (None, false) => format!(
            "cargo xtask soak --seed {} --events {}",
            summary.seed, summary.events
        ),
        (None, true) => return None,
    };
    if in_process {
        command.push_str(" --in-process");
    }
    if let Some(name) = broken {
        command.push_str(&format!(" --broken {name}"));
    }
    Some(command)
}

fn report(summary: &Summary, rerun: &Option<String>, out_dir: &std::path::Path, wall: Duration) {
    let kinds: Vec<String> = summary
        .kinds
        .iter()
        .map(|(kind, n)| format!("{kind} {n}"))
        .collect();
    println!("soak: events by kind: {}", kinds.join(", "));
    println!(
        "soak: {:.1} simulated s in {:.1} s of wall time",
        summary.simulated_us as f64 / 1e6,
        wall.as_secs_f64()
    );
    if let Some(v) = &summary.violation {
        println!(
            "soak: VIOLATION at seed {} event {}: {}",
            summary.seed, v.event, v.what
        );
        println!("soak: the last events of the schedule:");
        for line in &v.last_events {
            println!("    {line}");
        }
        println!("soak: the adapter's last events:");
        for line in &v.adapter_events {
            println!("    {line}");
        }
    }
    for e in &summary.firmware_errors {
        println!("soak: VIOLATION: the firmware logged an ERROR: {e}");
    }
    if let Some(command) = rerun {
        let dir: PathBuf = out_dir
            .strip_prefix(project_root())
            .unwrap_or(out_dir)
            .into();
        println!(
            "soak: replay it: {command}  (a waveform of the event and the firmware's log in {})",
            dir.display()
        );
    }
    println!("{}", summary.line());
}
