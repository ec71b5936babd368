//! `cargo xtask qemu-test`: the real firmware image under QEMU against hal-sim, scenario by
//! scenario.
//!
//! On a fresh machine it first installs what it lacks: the `thumbv7m-none-eabi` target
//! through rustup, and `qemu-system-arm` through apt-get when run as root (otherwise it
//! names the command). It builds both board images, reports their flash and RAM, then runs
//! each scenario in its own QEMU, decodes the firmware's defmt log in-process, and compares
//! the scenario's events and log with `ci/expected/qemu-test/<name>.txt` (`--overwrite`
//! regenerates them). The last line is `qemu-test: N passed, M failed`.

use crate::{check_flags, flag_value, project_root};
use anyhow::{anyhow, bail, Context, Result};
use hal_sim::firmware::Qemu;
use hal_sim::scenarios::{self, Outcome};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const TARGET: &str = "thumbv7m-none-eabi";

/// The failure-path self-tests: an image feature, and the ERROR line its log must end with.
const SELFTESTS: [(&str, &str); 3] = [
    ("selftest-panic", "selftest: a panic on purpose"),
    ("selftest-hardfault", "HardFault"),
    // A stuck bit 256 bytes into RAM (seed 000 line 685).
    (
        "selftest-ramfault",
        "RAM test: the word at 0x20000100 failed",
    ),
];

/// One firmware image: the board, its feature, its limits.
pub(crate) struct Image {
    board: &'static str,
    features: &'static [&'static str],
    flash_limit: u64,
    ram_limit: u64,
}

pub(crate) const IMAGES: [Image; 2] = [
    Image {
        board: board::LM3S6965_QEMU.name,
        features: &[],
        flash_limit: board::LM3S6965_QEMU.flash_bytes as u64,
        ram_limit: board::LM3S6965_QEMU.ram_bytes as u64,
    },
    Image {
        board: board::STM32F103.name,
        features: &["--no-default-features", "--features", "stm32f103"],
        // The chip has 64 KiB; the image keeps to 48 KiB (40 KiB before DP-V1, which took
        // 5.3 KiB of it), so that what follows has a quarter of the chip.
        flash_limit: PRODUCTION_FLASH_BUDGET,
        ram_limit: board::STM32F103.ram_bytes as u64,
    },
];

/// The flash the production image may take (of the STM32F103C8's 64 KiB).
const PRODUCTION_FLASH_BUDGET: u64 = 48 * 1024;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--overwrite"], &["--only"])?;
    let overwrite = args.iter().any(|a| a == "--overwrite");
    let only = flag_value(args, "--only")?;

    ensure_target()?;
    let qemu = ensure_qemu()?;
    let mut failures = 0usize;
    let mut elf_for_qemu = None;
    println!("firmware images:");
    for image in &IMAGES {
        let elf = build(image)?;
        let (flash, ram) = image_size(&elf)?;
        let fits = flash <= image.flash_limit && ram <= image.ram_limit;
        println!(
            "  {:<10} flash {:>6} B of {:>6} B, RAM {:>6} B of {:>6} B (static; the stack takes the rest){}",
            image.board,
            flash,
            image.flash_limit,
            ram,
            image.ram_limit,
            if fits { "" } else { "  DOES NOT FIT" }
        );
        if !fits {
            failures += 1;
        }
        if image.board == "lm3s6965" {
            elf_for_qemu = Some(elf);
        }
    }
    let elf = elf_for_qemu.expect("the QEMU image is in IMAGES");
    let elf_bytes = std::fs::read(&elf)?;
    let table = defmt_decoder::Table::parse(&elf_bytes)?
        .ok_or_else(|| anyhow!("no defmt table in {}", elf.display()))?;
    println!("failure paths:");
    for (feature, want) in SELFTESTS {
        match selftest(&qemu, feature, want) {
            Ok(line) => println!("  {feature:<19} ok: {line}"),
            Err(e) => {
                println!("  {feature:<19} FAILED: {e:#}");
                failures += 1;
            }
        }
    }

    let expected_dir = project_root().join("ci/expected/qemu-test");
    let scenarios: Vec<&str> = scenarios::names()
        .into_iter()
        .filter(|name| only.is_none_or(|o| *name == o))
        .collect();
    if scenarios.is_empty() {
        bail!("no scenario named {:?}", only.unwrap_or_default());
    }
    let started = Instant::now();
    let mut rows = Vec::new();
    for (i, s) in scenarios.iter().enumerate() {
        let t0 = Instant::now();
        let result = run_one(&qemu, &elf, &table, s, &expected_dir, overwrite);
        let (ok, detail, outcome) = match result {
            Ok((outcome, golden)) => {
                let mut problems: Vec<String> = outcome
                    .checks
                    .iter()
                    .filter(|(_, ok)| !ok)
                    .map(|(what, _)| format!("check failed: {what}"))
                    .collect();
                problems.extend(golden);
                problems.extend(over_budget(&outcome.figures));
                (problems.is_empty(), problems, Some(outcome))
            }
            Err(e) => (false, vec![format!("error: {e:#}")], None),
        };
        println!(
            "[{:>2}/{}] {:<24} {} ({:.1} s)",
            i + 1,
            scenarios.len(),
            s,
            if ok { "ok" } else { "FAILED" },
            t0.elapsed().as_secs_f64()
        );
        for d in &detail {
            println!("        {d}");
        }
        if !ok {
            failures += 1;
        }
        rows.push((s.to_string(), ok, outcome));
    }
    print_table(&rows);
    for (_, _, outcome) in &rows {
        for line in outcome.iter().flat_map(|o| &o.report) {
            println!("{line}");
        }
    }
    let passed = rows.iter().filter(|(_, ok, _)| *ok).count();
    println!(
        "scenarios ran in {:.1} s after the build; waveform-free run, logs in ci/expected/qemu-test/",
        started.elapsed().as_secs_f64()
    );
    println!("qemu-test: {passed} passed, {failures} failed");
    if failures > 0 {
        std::process::exit(1);
    }
    Ok(())
}

/// Builds the QEMU image with a self-test `feature`, runs it, and checks that QEMU exits with a
/// failure code after the firmware logged `want` at ERROR level. Returns what it saw.
fn selftest(qemu: &Path, feature: &'static str, want: &str) -> Result<String> {
    let image = Image {
        board: feature,
        features: &[],
        flash_limit: 0,
        ram_limit: 0,
    };
    let elf = build_with(&image, &["--features", feature])?;
    let table = defmt_decoder::Table::parse(&std::fs::read(&elf)?)?
        .ok_or_else(|| anyhow!("no defmt table in {}", elf.display()))?;
    let mut firmware = Qemu::start(qemu, &elf).context("starting QEMU")?;
    let status = firmware
        .wait_exit(std::time::Duration::from_secs(20))?
        .ok_or_else(|| anyhow!("QEMU did not exit"))?;
    let streams = firmware.stop();
    let lines = decode(&table, streams.last().map_or(&[][..], |s| s.as_slice()))?;
    let last_error = lines
        .iter()
        .rev()
        .find(|(level, _)| level == "ERROR")
        .map(|(_, m)| m.clone());
    match (status.code(), last_error) {
        (Some(code), Some(line)) if code != 0 && line.contains(want) => {
            Ok(format!("QEMU exit code {code}, ERROR {line:?}"))
        }
        (code, line) => {
            bail!("QEMU exit code {code:?}, last ERROR line {line:?}, expected {want:?}")
        }
    }
}

/// Runs one scenario in its own QEMU; returns the outcome and any golden-file problems.
fn run_one(
    qemu: &Path,
    elf: &Path,
    table: &defmt_decoder::Table,
    name: &str,
    expected_dir: &Path,
    overwrite: bool,
) -> Result<(Outcome, Vec<String>)> {
    let firmware = Qemu::start(qemu, elf).context("starting QEMU")?;
    let (outcome, firmware) = scenarios::run(name, firmware)?;
    let streams = firmware.stop();
    let mut text = String::new();
    for line in &outcome.events {
        text.push_str(line);
        text.push('\n');
    }
    let mut problems = Vec::new();
    for (run, bytes) in streams.iter().enumerate() {
        text.push_str(&format!("--- firmware log, power-up {} ---\n", run + 1));
        for (level, message) in decode(table, bytes)? {
            if level == "ERROR" {
                problems.push(format!("firmware error: {message}"));
            }
            text.push_str(&format!("{level:<5} {message}\n"));
        }
    }
    let path = expected_dir.join(format!("{name}.txt"));
    if overwrite {
        std::fs::create_dir_all(expected_dir)?;
        std::fs::write(&path, &text)?;
    } else {
        match std::fs::read_to_string(&path) {
            Ok(want) if want == text => {}
            Ok(want) => problems.push(format!(
                "differs from {}:\n{}",
                path.display(),
                diff(&want, &text)
            )),
            Err(_) => problems.push(format!(
                "no expected file {} (run `cargo xtask qemu-test --overwrite` and review it)",
                path.display()
            )),
        }
    }
    Ok((outcome, problems))
}

/// The defmt frames of one QEMU run, as (level, message).
pub(crate) fn decode(table: &defmt_decoder::Table, bytes: &[u8]) -> Result<Vec<(String, String)>> {
    let mut decoder = table.new_stream_decoder();
    decoder.received(bytes);
    let mut lines = Vec::new();
    loop {
        match decoder.decode() {
            Ok(frame) => {
                let level = frame
                    .level()
                    .map_or("PRINT".to_string(), |l| format!("{l:?}").to_uppercase());
                lines.push((level, frame.display_message().to_string()));
            }
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => {
                bail!("malformed defmt frame: something else wrote onto the defmt stream")
            }
        }
    }
    Ok(lines)
}

/// A line diff, small and dependency-free: the expected and actual lines around the first
/// difference.
fn diff(want: &str, got: &str) -> String {
    let w: Vec<&str> = want.lines().collect();
    let g: Vec<&str> = got.lines().collect();
    let first = w
        .iter()
        .zip(&g)
        .position(|(a, b)| a != b)
        .unwrap_or(w.len().min(g.len()));
    let mut out = String::new();
    for line in w.iter().skip(first).take(6) {
        out.push_str(&format!("          - {line}\n"));
    }
    for line in g.iter().skip(first).take(6) {
        out.push_str(&format!("          + {line}\n"));
    }
    out
}

/// Issue 12's budget: the firmware's part of a new Data_Exchange (its outputs arriving at the
/// MCU to its writes back in the transceiver, the link included) within one DP cycle.
fn over_budget(f: &hal_sim::cosim::Figures) -> Option<String> {
    let (worst, cycle) = (f.worst_outputs_to_inputs_ns?, f.median_dp_cycle_ns?);
    (worst > cycle).then(|| {
        format!(
            "budget: new outputs to the firmware's writes took up to {:.1} us, over the DP \
             cycle of {:.1} us",
            worst as f64 / 1000.0,
            cycle as f64 / 1000.0
        )
    })
}

fn print_table(rows: &[(String, bool, Option<Outcome>)]) {
    println!();
    println!(
        "{:<24} {:<6} {:>7} {:>5} {:>9} {:>6} {:>8} {:>8} {:>8}  leds (net run tx rx error online offline host)",
        "scenario", "result", "locked", "lost", "tsdr bits", "max", "mcu us", "med us", "cycle us"
    );
    let us = |ns: Option<u64>| ns.map_or("-".into(), |ns| format!("{:.1}", ns as f64 / 1000.0));
    for (name, ok, outcome) in rows {
        let Some(o) = outcome else {
            println!("{name:<24} {:<6}", if *ok { "ok" } else { "FAILED" });
            continue;
        };
        let f = &o.figures;
        let baud = f.locked;
        let l = o.leds;
        println!(
            "{:<24} {:<6} {:>7} {:>5} {:>9} {:>6} {:>8} {:>8} {:>8}  {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
            name,
            if *ok { "ok" } else { "FAILED" },
            baud.map_or("-".into(), |b| b.to_string()),
            f.lost_before_lock.map_or("-".into(), |n| n.to_string()),
            f.worst_tsdr_bits,
            f.worst_tsdr_baud
                .map_or("-".into(), |b| b.vpc3_max_tsdr_bits().to_string()),
            us(f.worst_outputs_to_inputs_ns),
            us(f.median_outputs_to_inputs_ns),
            us(f.median_dp_cycle_ns),
            l.net,
            l.run,
            l.tx,
            l.rx,
            l.error,
            l.online,
            l.offline,
            l.host,
        );
    }
    let b = board::PRODUCTION;
    println!(
        "tsdr bits: the worst request-to-response gap on the wire, answered by the transceiver; \
         max: the VPC3+ class's MaxTsdr at that rate; mcu us: from a new Data_Exchange's outputs \
         arriving at the MCU to the firmware's writes (inputs included) back in the transceiver, \
         worst and median, on the {} ({} MHz, {} instructions per 100 counted, link {} bit/s); \
         cycle us: the master's median Data_Exchange cycle to the adapter, the budget of the \
         worst (a scenario over it fails).",
        b.chip,
        b.mcu_clock_hz / 1_000_000,
        b.cycles_per_instruction_pct,
        b.link.bit_rate
    );
    // Per rate, over every scenario and every service at that rate.
    let mut worst: std::collections::BTreeMap<dp_consts::Baud, u64> = Default::default();
    for f in rows
        .iter()
        .filter_map(|(_, _, o)| o.as_ref())
        .map(|o| &o.figures)
    {
        for (baud, bits) in &f.worst_tsdr_by_rate {
            let w = worst.entry(*baud).or_default();
            *w = (*w).max(*bits);
        }
    }
    for (baud, bits) in worst {
        println!(
            "timing: rate={baud} worst_tsdr_bits={bits} max_tsdr_bits={}",
            baud.vpc3_max_tsdr_bits()
        );
    }
}

pub(crate) fn ensure_target() -> Result<()> {
    let out = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .context("running rustup (the Rust toolchain installer)")?;
    if String::from_utf8_lossy(&out.stdout)
        .lines()
        .any(|l| l.trim() == TARGET)
    {
        return Ok(());
    }
    println!("installing the {TARGET} target: rustup target add {TARGET}");
    let status = Command::new("rustup")
        .args(["target", "add", TARGET])
        .status()?;
    if !status.success() {
        bail!("`rustup target add {TARGET}` failed");
    }
    Ok(())
}

fn find_in_path(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|dir| dir.join(program))
            .find(|p| p.is_file())
    })
}

pub(crate) fn ensure_qemu() -> Result<PathBuf> {
    if let Some(path) = find_in_path("qemu-system-arm") {
        return Ok(path);
    }
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if uid.as_deref().ok() != Some("0") {
        bail!("qemu-system-arm is not installed; install it with `sudo apt-get install -y qemu-system-arm`");
    }
    println!(
        "installing qemu-system-arm: apt-get install -y --no-install-recommends qemu-system-arm"
    );
    let apt = |args: &[&str]| -> Result<()> {
        let status = Command::new("apt-get")
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status()
            .context("running apt-get")?;
        if !status.success() {
            bail!("`apt-get {}` failed", args.join(" "));
        }
        Ok(())
    };
    apt(&["update", "-q"])?;
    apt(&[
        "install",
        "-y",
        "-q",
        "--no-install-recommends",
        "qemu-system-arm",
    ])?;
    find_in_path("qemu-system-arm")
        .ok_or_else(|| anyhow!("qemu-system-arm still not on PATH after apt-get"))
}

/// Builds one board's image in its own target directory; returns the ELF.
pub(crate) fn build(image: &Image) -> Result<PathBuf> {
    build_with(image, &[])
}

/// Builds `image` with `extra` cargo arguments, in a target directory named after the image.
fn build_with(image: &Image, extra: &[&str]) -> Result<PathBuf> {
    let firmware = project_root().join("firmware");
    let target_dir = firmware.join("target").join(image.board);
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(&firmware)
        .args(["build", "--release", "--quiet"])
        .args(image.features)
        .args(extra)
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .context("running cargo for the firmware")?;
    if !status.success() {
        bail!("the {} firmware did not build", image.board);
    }
    Ok(target_dir.join(TARGET).join("release/dp-adapter"))
}

/// Flash (code, read-only data, initial data) and static RAM (data, bss) of an image.
fn image_size(elf: &Path) -> Result<(u64, u64)> {
    use object::{Object, ObjectSection};
    let bytes = std::fs::read(elf)?;
    let file = object::File::parse(&*bytes)?;
    let size = |name: &str| file.section_by_name(name).map_or(0, |s| s.size());
    let data = size(".data");
    let flash = size(".vector_table") + size(".text") + size(".rodata") + data;
    let ram = data + size(".bss") + size(".uninit");
    Ok((flash, ram))
}
