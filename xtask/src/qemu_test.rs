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
use hal_sim::firmware::{Firmware as _, Qemu};
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

/// One firmware image: its board (a row of `board::BOARDS`, whose name is its feature) and the
/// features it adds (a self-test).
pub(crate) struct Image {
    pub(crate) board: &'static board::Board,
    pub(crate) extra_feature: Option<&'static str>,
}

impl Image {
    /// The board's own image.
    pub(crate) const fn of(board: &'static board::Board) -> Image {
        Image {
            board,
            extra_feature: None,
        }
    }

    /// Its target directory's name: the board, or the self-test it was built for.
    fn name(&self) -> &'static str {
        self.extra_feature.unwrap_or(self.board.name)
    }

    /// The QEMU machine it runs on, if it runs under QEMU.
    pub(crate) fn machine(&self) -> Option<&'static str> {
        match self.board.runs {
            board::Runs::Qemu { machine } => Some(machine),
            board::Runs::Probe => None,
        }
    }
}

/// An image built: where its ELF is, its static RAM, and its defmt table where it runs under
/// QEMU (parsed once for all its runs).
struct Built {
    image: Image,
    elf: PathBuf,
    statics: u64,
    table: Option<defmt_decoder::Table>,
}

/// The defmt table of the image at `elf`.
pub(crate) fn defmt_table(elf: &Path) -> Result<defmt_decoder::Table> {
    defmt_decoder::Table::parse(&std::fs::read(elf)?)?
        .ok_or_else(|| anyhow!("no defmt table in {}", elf.display()))
}

/// The QEMU board's image: every scenario runs on it.
pub(crate) const QEMU_IMAGE: Image = Image::of(&board::LM3S6965_QEMU);
/// The production image, flashed by `cargo xtask flash` and bundled by `cargo xtask dist`.
pub(crate) const PRODUCTION_IMAGE: Image = Image::of(&board::PRODUCTION);
/// The drive scenario the production board's code runs under QEMU (with every `autodetect-`
/// scenario): the vendor profile, through USART2 to the drive.
const STM32_QEMU_DRIVE_SCENARIO: &str = "drive-vendor";

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--overwrite"], &["--only"])?;
    let overwrite = args.iter().any(|a| a == "--overwrite");
    let only = flag_value(args, "--only")?;

    ensure_target()?;
    let qemu = ensure_qemu()?;
    let mut failures = 0usize;
    let version = crate::dist::firmware_version();
    println!("firmware images ({version}):");
    let mut built = Vec::new();
    for board in &board::BOARDS {
        let image = Image::of(board);
        let elf = build(&image)?;
        let (flash, ram) = image_size(&elf)?;
        let (flash_limit, ram_limit) = (board.flash_budget as u64, board.memory.ram_bytes as u64);
        let fits = flash <= flash_limit && ram <= ram_limit;
        println!(
            "  {:<14} flash {:>6} B of {:>6} B, RAM {:>6} B of {:>6} B (static; the stack takes the rest){}",
            board.name,
            flash,
            flash_limit,
            ram,
            ram_limit,
            if fits { "" } else { "  DOES NOT FIT" }
        );
        if !fits {
            failures += 1;
        }
        // Parsed once per image, for every run of it.
        let table = image.machine().map(|_| defmt_table(&elf)).transpose()?;
        built.push(Built {
            image,
            elf,
            statics: ram,
            table,
        });
    }
    println!("failure paths and boots:");
    for (feature, want) in SELFTESTS {
        match selftest(&qemu, feature, want) {
            Ok(line) => println!("  {feature:<19} ok: {line}"),
            Err(e) => {
                println!("  {feature:<19} FAILED: {e:#}");
                failures += 1;
            }
        }
    }
    // Every QEMU board but the main one boots before its scenarios: its clock start-up, its link
    // UART both ways and its cycle counter, with no Boot (which builds the adapter).
    for b in built.iter().filter(|b| b.image.board != QEMU_IMAGE.board) {
        let Some(table) = &b.table else { continue };
        let name = b.image.board.name;
        match smoke(&qemu, &b.image, &b.elf, table, version) {
            Ok((line, true)) => println!("  {name:<19} ok: {line}"),
            Ok((line, false)) => {
                println!("  {name:<19} DOES NOT FIT: {line}");
                failures += 1;
            }
            Err(e) => {
                println!("  {name:<19} FAILED: {e:#}");
                failures += 1;
            }
        }
    }

    // Every scenario on the QEMU board; the autodetect ones and one drive scenario on the
    // production board's code too, named `<board>/<scenario>`, with goldens in a folder of the
    // board's name.
    let expected_dir = project_root().join("ci/expected/qemu-test");
    let mut runs: Vec<(String, &Built, &str, PathBuf)> = Vec::new();
    for b in &built {
        if b.table.is_none() {
            continue;
        }
        let image = &b.image;
        let main = image.board == QEMU_IMAGE.board;
        for name in scenarios::names() {
            if !(main || name.starts_with("autodetect-") || name == STM32_QEMU_DRIVE_SCENARIO) {
                continue;
            }
            let (row, dir) = if main {
                (name.to_string(), expected_dir.clone())
            } else {
                (
                    format!("{}/{name}", image.board.name),
                    expected_dir.join(image.board.name),
                )
            };
            if only.is_none_or(|o| row == o) {
                runs.push((row, b, name, dir));
            }
        }
    }
    if runs.is_empty() {
        bail!("no scenario named {:?}", only.unwrap_or_default());
    }
    let started = Instant::now();
    let mut rows: Vec<Row> = Vec::new();
    for (i, (row, b, name, dir)) in runs.iter().enumerate() {
        let image = &b.image;
        let t0 = Instant::now();
        let result = run_one(&qemu, b, name, dir, version, overwrite);
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
                // A stack that reached the statics may have overwritten them: nothing after
                // it can be trusted.
                if let Some(p) = outcome
                    .figures
                    .stack_peak
                    .filter(|p| p.used_bytes >= p.room_bytes)
                {
                    problems.push(format!(
                        "the stack ran into the statics: {} of the {} B above them",
                        p.used_bytes, p.room_bytes
                    ));
                }
                (problems.is_empty(), problems, Some(outcome))
            }
            Err(e) => (false, vec![format!("error: {e:#}")], None),
        };
        let pace = outcome
            .as_ref()
            .map(|o| round_trip_pace(&o.figures))
            .unwrap_or_default();
        println!(
            "[{:>2}/{}] {:<32} {} ({:.1} s{pace})",
            i + 1,
            runs.len(),
            row,
            if ok { "ok" } else { "FAILED" },
            t0.elapsed().as_secs_f64()
        );
        for d in &detail {
            println!("        {d}");
        }
        if !ok {
            failures += 1;
        }
        rows.push(Row {
            name: row.clone(),
            board: image.board,
            ok,
            outcome,
        });
    }
    print_table(&rows);
    failures += check_ram(&rows, &built);
    for Row { outcome, .. } in &rows {
        for line in outcome.iter().flat_map(|o| &o.report) {
            println!("{line}");
        }
    }
    let passed = rows.iter().filter(|r| r.ok).count();
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

/// Starts `image` under QEMU and checks what it can do before a Boot: it logs its boot line and a
/// calibrated cycle counter (100 `nop`s count 95 to 110), says Ready over its link UART, and
/// answers a stack measurement over it, which takes a frame in through the UART's interrupt.
/// Returns what it saw, and whether the stack kept clear of the statics.
fn smoke(
    qemu: &Path,
    image: &Image,
    elf: &Path,
    table: &defmt_decoder::Table,
    version: &str,
) -> Result<(String, bool)> {
    let machine = image
        .machine()
        .context("the image does not run under QEMU")?;
    let mut firmware = Qemu::start(qemu, elf, machine).context("starting QEMU (Ready)")?;
    let peak = firmware
        .stack_peak()
        .context("the stack measurement over the link")?;
    let streams = firmware.stop();
    let lines = decode(table, streams.last().map_or(&[][..], |s| s.as_slice()))?;
    let boot = format!("boot: {}, firmware {version}", image.board.description);
    if !lines.iter().any(|(_, m)| *m == boot) {
        bail!("no boot line {boot:?} in {lines:?}");
    }
    let counted = lines
        .iter()
        .find_map(|(_, m)| calibration(m))
        .context("no cycle counter line")?;
    if !CALIBRATED.contains(&counted) {
        bail!("100 nops counted {counted} cycles");
    }
    let peak = peak.context("no stack measurement")?;
    let fits = peak.used_bytes < peak.room_bytes;
    Ok((
        format!(
            "booted: Ready and a stack measurement over its link UART, 100 nops count {counted} \
             cycles; the stack reached {} of the {} B above the statics{}",
            peak.used_bytes,
            peak.room_bytes,
            if fits {
                ""
            } else {
                " (all of it: it ran into them before any Boot)"
            }
        ),
        fits,
    ))
}

/// Where a scenario's wall time goes: the host round trips to the firmware per simulated second
/// (each one a message through QEMU's UART both ways), and the cycle steps each `Continue` ran.
fn round_trip_pace(f: &hal_sim::cosim::Figures) -> String {
    let simulated_s = f.simulated_us as f64 / 1e6;
    format!(
        ", {:.1} simulated s, {:.0} round trips per simulated s, {:.1} cycle steps per Continue",
        simulated_s,
        f.round_trips as f64 / simulated_s.max(1e-6),
        f.cycle_steps as f64 / (f.continues as f64).max(1.0),
    )
}

/// A scenario run on a board: its table row.
struct Row {
    name: String,
    board: &'static board::Board,
    ok: bool,
    outcome: Option<Outcome>,
}

/// What 100 `nop`s may count on a calibrated cycle counter: 100, give or take the reads.
const CALIBRATED: std::ops::RangeInclusive<u32> = 95..=110;
const CALIBRATION_LINE: &str = "cycle counter: 100 nops count ";

/// The count of a calibration line of the firmware's log.
fn calibration(message: &str) -> Option<u32> {
    let rest = message.strip_prefix(CALIBRATION_LINE)?;
    rest.strip_suffix(" cycles")?.parse().ok()
}

/// `message` for a golden: a calibration within [`CALIBRATED`] as the range, any other as is
/// (so that it fails the comparison).
fn golden_calibration(message: &str) -> String {
    match calibration(message) {
        Some(n) if CALIBRATED.contains(&n) => format!(
            "{CALIBRATION_LINE}{}-{} cycles",
            CALIBRATED.start(),
            CALIBRATED.end()
        ),
        _ => message.to_string(),
    }
}

/// The deepest stack the scenarios on `board` measured, and in which.
fn stack_peak<'a>(rows: &'a [Row], board: &board::Board) -> Option<(u64, &'a str)> {
    rows.iter()
        .filter(|r| r.board == board)
        .filter_map(|r| {
            Some((
                u64::from(r.outcome.as_ref()?.figures.stack_peak?.used_bytes),
                r.name.as_str(),
            ))
        })
        .max_by_key(|(peak, _)| *peak)
}

/// Statics and the deepest stack measured, against each board's RAM: one line a board, and
/// the number that do not fit. A board under QEMU is held to its own scenarios' stack (none
/// ran on it, as with `--only`: not measured, said so); the production board, which runs
/// none, to the QEMU board's (the same code but for the board module).
fn check_ram(rows: &[Row], built: &[Built]) -> usize {
    let mut over = 0;
    for Built { image, statics, .. } in built {
        let own = stack_peak(rows, image.board);
        let stand_in = match image.machine() {
            Some(_) => None,
            None => stack_peak(rows, QEMU_IMAGE.board),
        };
        let Some((peak, at)) = own.or(stand_in) else {
            println!(
                "ram: board={} statics={statics} stack not measured (no scenario ran on it)",
                image.board.name
            );
            continue;
        };
        let has = u64::from(image.board.memory.ram_bytes);
        let need = statics + peak;
        let fits = need <= has;
        println!(
            "ram: board={} statics={statics} stack_peak={peak} needs={need} has={has}{} (stack measured {}, deepest in {at})",
            image.board.name,
            if fits { "" } else { " DOES NOT FIT" },
            if own.is_some() { "on this board" } else { "on the QEMU board" },
        );
        if !fits {
            over += 1;
        }
    }
    over
}

/// Builds the QEMU image with a self-test `feature`, runs it, and checks that QEMU exits with a
/// failure code after the firmware logged `want` at ERROR level. Returns what it saw.
fn selftest(qemu: &Path, feature: &'static str, want: &str) -> Result<String> {
    let image = Image {
        extra_feature: Some(feature),
        ..QEMU_IMAGE
    };
    let elf = build(&image)?;
    let table = defmt_table(&elf)?;
    let machine = image.machine().expect("the QEMU board runs under QEMU");
    let mut firmware = Qemu::start(qemu, &elf, machine).context("starting QEMU")?;
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
    b: &Built,
    name: &str,
    expected_dir: &Path,
    version: &str,
    overwrite: bool,
) -> Result<(Outcome, Vec<String>)> {
    let table = b
        .table
        .as_ref()
        .context("the image does not run under QEMU")?;
    let machine = b
        .image
        .machine()
        .context("the image does not run under QEMU")?;
    let firmware = Qemu::start(qemu, &b.elf, machine).context("starting QEMU")?;
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
            // The version changes with every commit; the golden holds its place. The cycle
            // counter's calibration is held to its range: a SysTick's count moves by one as
            // its phase falls against the `nop`s.
            let message = golden_calibration(&message.replace(version, "<version>"));
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
    Ok(defmt_lines::lines(&mut *decoder)?
        .into_iter()
        .map(|line| (line.level, line.message))
        .collect())
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

fn print_table(rows: &[Row]) {
    println!();
    println!(
        "{:<32} {:<6} {:>7} {:>5} {:>9} {:>6} {:>8} {:>8} {:>8} {:>6}  leds (net run tx rx error online offline host)",
        "scenario", "result", "locked", "lost", "tsdr bits", "max", "mcu us", "med us", "cycle us", "stack"
    );
    let us = |ns: Option<u64>| ns.map_or("-".into(), |ns| format!("{:.1}", ns as f64 / 1000.0));
    for Row {
        name, ok, outcome, ..
    } in rows
    {
        let Some(o) = outcome else {
            println!("{name:<32} {:<6}", if *ok { "ok" } else { "FAILED" });
            continue;
        };
        let f = &o.figures;
        let baud = f.locked;
        let l = o.leds;
        println!(
            "{:<32} {:<6} {:>7} {:>5} {:>9} {:>6} {:>8} {:>8} {:>8} {:>6}  {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
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
            f.stack_peak.map_or("-".into(), |p| p.used_bytes.to_string()),
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
         worst (a scenario over it fails); stack: the firmware's deepest stack in bytes since \
         its last power-up.",
        b.chip,
        b.mcu_clock_hz / 1_000_000,
        b.cycles_per_instruction_pct,
        b.link.bit_rate
    );
    // Per rate, over every scenario and every service at that rate.
    let mut worst: std::collections::BTreeMap<dp_consts::Baud, u64> = Default::default();
    for f in rows
        .iter()
        .filter_map(|r| r.outcome.as_ref())
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

pub(crate) fn find_in_path(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|dir| dir.join(program))
            .find(|p| p.is_file())
    })
}

pub(crate) fn ensure_qemu() -> Result<PathBuf> {
    ensure_debian_tool("qemu-system-arm", "qemu-system-arm")
}

/// `program` on PATH, or Debian's `package` installed for it through apt-get when run as root
/// (else an error that says which command to run).
pub(crate) fn ensure_debian_tool(program: &str, package: &str) -> Result<PathBuf> {
    if let Some(path) = find_in_path(program) {
        return Ok(path);
    }
    apt_get_install(package, program)?;
    find_in_path(program).ok_or_else(|| anyhow!("{program} still not on PATH after apt-get"))
}

/// Debian's `package` (for `what`) installed through apt-get when run as root; else an error
/// that says which command to run.
pub(crate) fn apt_get_install(package: &str, what: &str) -> Result<()> {
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if uid.as_deref().ok() != Some("0") {
        bail!("{what} is not installed; install it with `sudo apt-get install -y {package}`");
    }
    println!("installing {what}: apt-get install -y --no-install-recommends {package}");
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
    apt(&["install", "-y", "-q", "--no-install-recommends", package])
}

/// Builds an image (release) in a target directory of its own name, with the version from
/// `git describe`; returns the ELF.
pub(crate) fn build(image: &Image) -> Result<PathBuf> {
    let status = firmware_cargo("build", image)
        .arg("--quiet")
        .status()
        .context("running cargo for the firmware")?;
    if !status.success() {
        bail!("the {} firmware did not build", image.name());
    }
    Ok(firmware_target_dir(image)
        .join(TARGET)
        .join("release/dp-adapter"))
}

/// `cargo clippy -- -D warnings` on every board's firmware (what `ci/run` lints), with the
/// environment the builds have, so that neither rebuilds the other's crates.
pub fn clippy_firmware(args: &[String]) -> Result<()> {
    check_flags(args, &[], &[])?;
    ensure_target()?;
    for board in &board::BOARDS {
        println!("clippy: firmware for {}", board.name);
        let status = firmware_cargo("clippy", &Image::of(board))
            .args(["--", "-D", "warnings"])
            .status()
            .context("running cargo clippy for the firmware")?;
        if !status.success() {
            bail!("clippy found problems in the {} firmware", board.name);
        }
    }
    Ok(())
}

fn firmware_target_dir(image: &Image) -> PathBuf {
    project_root().join("firmware/target").join(image.name())
}

/// `cargo <subcommand> --release` for `image`'s board and features in its target directory,
/// with the firmware's version and date.
fn firmware_cargo(subcommand: &str, image: &Image) -> Command {
    let mut features = image.board.name.to_string();
    if let Some(extra) = image.extra_feature {
        features = format!("{features},{extra}");
    }
    let mut cargo = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cargo
        .current_dir(project_root().join("firmware"))
        .args([
            subcommand,
            "--release",
            "--no-default-features",
            "--features",
        ])
        .arg(&features)
        .arg("--target-dir")
        .arg(firmware_target_dir(image))
        .env("DP_ADAPTER_VERSION", crate::dist::firmware_version())
        .env("DP_ADAPTER_DATE", crate::dist::firmware_date());
    cargo
}

/// Flash (code, read-only data, initial data) and static RAM (data, bss) of an image.
pub(crate) fn image_size(elf: &Path) -> Result<(u64, u64)> {
    use object::{Object, ObjectSection};
    let bytes = std::fs::read(elf)?;
    let file = object::File::parse(&*bytes)?;
    let size = |name: &str| file.section_by_name(name).map_or(0, |s| s.size());
    let data = size(".data");
    let flash = size(".vector_table") + size(".text") + size(".rodata") + data;
    let ram = data + size(".bss") + size(".uninit");
    Ok((flash, ram))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_golden_holds_a_calibration_in_range_as_the_range_and_any_other_as_it_is() {
        let line = |n: u32| format!("{CALIBRATION_LINE}{n} cycles");
        assert_eq!(
            golden_calibration(&line(101)),
            golden_calibration(&line(102))
        );
        assert_eq!(
            golden_calibration(&line(101)),
            "cycle counter: 100 nops count 95-110 cycles"
        );
        assert_eq!(golden_calibration(&line(140)), line(140));
        assert_eq!(golden_calibration("boot: x"), "boot: x");
    }
}
