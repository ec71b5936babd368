//! `cargo xtask flash`: the production image onto a board, through a debug probe, with probe-rs.
//!
//! xtask builds the release image and runs this binary with `--elf PATH`. It attaches to the
//! chip (STM32F103CB from probe-rs's built-in targets unless `--chip` says otherwise), prints
//! the flash plan (sectors erased, pages programmed, bytes verified), flashes, verifies and
//! resets the board; with `--log` it then streams the firmware's defmt log over RTT, decoded
//! with defmt-decoder as qemu-test decodes QEMU's. `--dry-run` runs the same plan against
//! probe-rs's own fake probe, as probe-rs's command line does for its dry run: the ELF is
//! loaded into the chip's memory map and the plan checked, nothing is written. The last line is
//! `flash: chip=<chip> image=<bytes> sectors=<n> <dry-run ok|flashed>`.
//!
//! With no probe attached it fails at once, naming what to connect and the udev rule a Linux
//! user lacks; it never waits for a probe.

use anyhow::{anyhow, bail, Context, Result};
use probe_rs::config::FlashProperties;
use probe_rs::flashing::{self, DownloadOptions, FlashLoader};
use probe_rs::integration::FakeProbe;
use probe_rs::probe::list::Lister;
use probe_rs::probe::DebugProbeSelector;
use probe_rs::rtt::Rtt;
use probe_rs::{Permissions, Session, SessionConfig};
use std::path::PathBuf;
use std::time::Duration;

/// What to do, from the command line.
struct Options {
    elf: PathBuf,
    chip: String,
    probe: Option<DebugProbeSelector>,
    dry_run: bool,
    log: bool,
}

const USAGE: &str = "usage: dp-adapter-flash --elf PATH [--chip NAME] [--probe VID:PID[:SERIAL]] \
                     [--dry-run] [--log]";

/// What a user without a probe needs to know.
const NO_PROBE: &str = "no debug probe found. Connect an ST-LINK/V2 (or any probe probe-rs \
supports: CMSIS-DAP v2, J-Link) to the board's SWD header (SWDIO, SWCLK, GND, 3V3) and to USB. \
On Linux a probe that is plugged in but not listed lacks the udev rule: install \
https://probe.rs/files/69-probe-rs.rules as /etc/udev/rules.d/69-probe-rs.rules, run \
`sudo udevadm control --reload && sudo udevadm trigger`, and replug it. With several probes, \
pick one with --probe VID:PID[:SERIAL] (ST-LINK/V2 is 0483:3748). `cargo xtask flash --dry-run` \
checks the image and the plan without a probe.";

fn main() {
    if let Err(e) = run(&std::env::args().skip(1).collect::<Vec<_>>()) {
        eprintln!("flash: {e:#}");
        std::process::exit(1);
    }
}

fn parse(args: &[String]) -> Result<Options> {
    let mut options = Options {
        elf: PathBuf::new(),
        chip: board::PRODUCTION.chip.to_string(),
        probe: None,
        dry_run: false,
        log: false,
    };
    let mut args = args.iter();
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .cloned()
                .ok_or_else(|| anyhow!("{arg} needs a value ({USAGE})"))
        };
        match arg.as_str() {
            "--elf" => options.elf = value()?.into(),
            "--chip" => options.chip = value()?,
            "--probe" => {
                let text = value()?;
                options.probe = Some(
                    text.parse()
                        .map_err(|e| anyhow!("--probe {text}: {e} (VID:PID[:SERIAL], hex)"))?,
                );
            }
            "--dry-run" => options.dry_run = true,
            "--log" => options.log = true,
            other => bail!("unknown option `{other}` ({USAGE})"),
        }
    }
    if options.elf.as_os_str().is_empty() {
        bail!("--elf is required ({USAGE})");
    }
    if options.dry_run && options.log {
        bail!("--log needs a board: a dry run starts no firmware");
    }
    Ok(options)
}

fn run(args: &[String]) -> Result<()> {
    let options = parse(args)?;
    let image = std::fs::read(&options.elf)
        .with_context(|| format!("reading {}", options.elf.display()))?;
    // probe-rs's fake probe prints every register access of its mocked core on stdout; the
    // dry run's reader wants the plan, so those lines go to /dev/null while it is attached.
    let quiet = options.dry_run.then(QuietStdout::new).transpose()?;
    let mut session = attach(&options)?;
    let loader = flashing::build_loader(&mut session, &options.elf, elf_format(), None)
        .with_context(|| format!("loading {} for {}", options.elf.display(), options.chip))?;
    let plan = Plan::of(&session, &loader)?;

    let mut download = DownloadOptions::default();
    download.dry_run = options.dry_run;
    download.verify = true;
    let committed = loader.commit(&mut session, download);
    if options.dry_run {
        drop(session);
        drop(quiet);
        plan.print(&options.chip);
        committed.context("the flash plan (dry run)")?;
        println!(
            "flash: chip={} image={} sectors={} dry-run ok",
            options.chip,
            plan.image_bytes,
            plan.sectors.len()
        );
        return Ok(());
    }
    plan.print(&options.chip);
    committed.context("flashing (erase, program, verify)")?;
    session
        .core(0)?
        .reset()
        .context("resetting the board after flashing")?;
    println!(
        "flash: chip={} image={} sectors={} flashed",
        options.chip,
        plan.image_bytes,
        plan.sectors.len()
    );
    if options.log {
        stream_log(&mut session, &image)?;
    }
    Ok(())
}

fn elf_format() -> Box<dyn flashing::ImageLoader> {
    flashing::image_format("elf")
        .expect("probe-rs's built-in formats include ELF")
        .create_loader(None)
}

/// A session on the chosen probe, the first one found, or probe-rs's fake probe for a dry run.
fn attach(options: &Options) -> Result<Session> {
    let chip = options.chip.as_str();
    if options.dry_run {
        return FakeProbe::with_mocked_core()
            .into_probe()
            .attach(chip, Permissions::default())
            .with_context(|| format!("attaching the fake probe to {chip}"));
    }
    let lister = Lister::new();
    if let Some(selector) = &options.probe {
        let probe = lister
            .open(selector.clone())
            .with_context(|| format!("opening the probe {selector}. {NO_PROBE}"))?;
        return probe
            .attach(chip, Permissions::default())
            .with_context(|| format!("attaching to {chip} through {selector}"));
    }
    if lister.list_all().is_empty() {
        bail!(NO_PROBE);
    }
    Session::auto_attach(chip, SessionConfig::default())
        .with_context(|| format!("attaching to {chip} (is the board powered?)"))
}

/// What flashing will do: the chip's sectors and pages the image touches.
struct Plan {
    algorithm: String,
    image_bytes: u64,
    blocks: usize,
    span: (u64, u64),
    sectors: Vec<(u64, u64)>,
    pages: Vec<(u64, u64)>,
}

impl Plan {
    fn of(session: &Session, loader: &FlashLoader) -> Result<Plan> {
        let blocks: Vec<(u64, u64)> = loader
            .data()
            .map(|(address, data)| (address, address + data.len() as u64))
            .collect();
        let (Some(first), Some(last)) = (blocks.first(), blocks.last()) else {
            bail!("the image holds nothing to flash");
        };
        let span = (first.0, last.1);
        let target = session.target();
        let algorithm = target
            .flash_algorithms
            .iter()
            .find(|a| a.flash_properties.address_range.contains(&span.0))
            .ok_or_else(|| anyhow!("{} has no flash algorithm at {:#010x}", target.name, span.0))?;
        let flash = &algorithm.flash_properties;
        if span.1 > flash.address_range.end {
            bail!(
                "the image ends at {:#010x}, past {}'s flash ({:#010x})",
                span.1,
                target.name,
                flash.address_range.end
            );
        }
        let (sectors, pages) = layout(&blocks, flash);
        Ok(Plan {
            algorithm: algorithm.name.clone(),
            image_bytes: blocks.iter().map(|b| b.1 - b.0).sum(),
            blocks: blocks.len(),
            span,
            sectors,
            pages,
        })
    }

    fn print(&self, chip: &str) {
        let total = |xs: &[(u64, u64)]| xs.iter().map(|x| x.1).sum::<u64>();
        println!("flash plan for {chip} (algorithm {}):", self.algorithm);
        println!(
            "  image:   {} bytes in {} block(s), {:#010x}..{:#010x}",
            self.image_bytes, self.blocks, self.span.0, self.span.1
        );
        println!(
            "  erase:   {} sector(s), {} bytes",
            self.sectors.len(),
            total(&self.sectors)
        );
        println!(
            "  program: {} page(s), {} bytes",
            self.pages.len(),
            total(&self.pages)
        );
        println!(
            "  verify:  read back {} bytes after programming",
            self.image_bytes
        );
    }
}

/// The sectors (erased) and pages (programmed) of `flash` that `blocks` (start, end) touch, as
/// (address, size).
type Spans = Vec<(u64, u64)>;
fn layout(blocks: &[(u64, u64)], flash: &FlashProperties) -> (Spans, Spans) {
    let touched = |start: u64, end: u64| blocks.iter().any(|b| b.0 < end && start < b.1);
    let range = flash.address_range.clone();
    let mut sectors = Vec::new();
    // Sector groups: each runs at its size from its address to the next group's.
    for (i, group) in flash.sectors.iter().enumerate() {
        let end = flash
            .sectors
            .get(i + 1)
            .map_or(range.end, |next| range.start + next.address);
        let mut at = range.start + group.address;
        while at < end {
            if touched(at, at + group.size) {
                sectors.push((at, group.size));
            }
            at += group.size;
        }
    }
    let page = u64::from(flash.page_size);
    let pages = (range.start..range.end)
        .step_by(page as usize)
        .filter(|at| touched(*at, at + page))
        .map(|at| (at, page))
        .collect();
    (sectors, pages)
}

/// Standard output sent to /dev/null until dropped (the fake probe's trace; see `run`). On
/// other systems than Unix the trace stays: the plan and the last line follow it all the same.
struct QuietStdout {
    #[cfg(unix)]
    saved: std::os::fd::OwnedFd,
}

#[cfg(not(unix))]
impl QuietStdout {
    fn new() -> Result<QuietStdout> {
        Ok(QuietStdout {})
    }
}

#[cfg(unix)]
impl QuietStdout {
    fn new() -> Result<QuietStdout> {
        use std::io::Write;
        use std::os::fd::{AsFd, AsRawFd};
        std::io::stdout().flush()?;
        let saved = std::io::stdout().as_fd().try_clone_to_owned()?;
        let null = std::fs::File::options().write(true).open("/dev/null")?;
        // SAFETY: dup2 on two descriptors this process owns; it replaces fd 1 atomically.
        if unsafe { libc::dup2(null.as_raw_fd(), libc::STDOUT_FILENO) } < 0 {
            return Err(std::io::Error::last_os_error().into());
        }
        Ok(QuietStdout { saved })
    }
}

#[cfg(unix)]
impl Drop for QuietStdout {
    fn drop(&mut self) {
        use std::io::Write;
        use std::os::fd::AsRawFd;
        let _ = std::io::stdout().flush();
        // SAFETY: as in `new`: the saved descriptor goes back to fd 1.
        unsafe { libc::dup2(self.saved.as_raw_fd(), libc::STDOUT_FILENO) };
    }
}

/// Streams the firmware's defmt log from RTT up channel 0 until Ctrl-C or the probe goes away.
fn stream_log(session: &mut Session, elf: &[u8]) -> Result<()> {
    let table = defmt_decoder::Table::parse(elf)?
        .ok_or_else(|| anyhow!("the image holds no defmt table"))?;
    let mut decoder = table.new_stream_decoder();
    let mut core = session.core(0)?;
    // The firmware sets its RTT control block up at boot; give it a moment.
    let mut rtt = None;
    for _ in 0..50 {
        match Rtt::attach(&mut core) {
            Ok(found) => {
                rtt = Some(found);
                break;
            }
            Err(_) => std::thread::sleep(Duration::from_millis(20)),
        }
    }
    let mut rtt = rtt.ok_or_else(|| anyhow!("no RTT control block in the board's RAM"))?;
    let channel = rtt
        .up_channel(0)
        .ok_or_else(|| anyhow!("the firmware opened no RTT up channel"))?;
    println!("flash: defmt log over RTT (Ctrl-C ends it)");
    let mut buf = [0u8; 1024];
    loop {
        let n = channel.read(&mut core, &mut buf)?;
        if n == 0 {
            std::thread::sleep(Duration::from_millis(10));
            continue;
        }
        decoder.received(&buf[..n]);
        for line in defmt_lines::lines(&mut *decoder).context("RTT channel 0")? {
            println!("{:<5} {}", line.level, line.message);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The production chip's flash as probe-rs's built-in target describes it (1 KiB sectors and
    /// pages at 0x08000000), not as this crate would guess it.
    fn production_flash() -> FlashProperties {
        let target = probe_rs::config::Registry::from_builtin_families()
            .get_target_by_name(board::PRODUCTION.chip)
            .unwrap();
        target
            .flash_algorithms
            .iter()
            .find(|a| a.flash_properties.address_range.contains(&0x0800_0000))
            .unwrap()
            .flash_properties
            .clone()
    }

    #[test]
    fn an_image_erases_and_programs_the_sectors_it_touches() {
        let flash = production_flash();
        // 46,656 bytes from the start: 45 whole KiB and part of a 46th.
        let (sectors, pages) = layout(&[(0x0800_0000, 0x0800_B640)], &flash);
        assert_eq!(sectors.len(), 46);
        assert_eq!(sectors.last(), Some(&(0x0800_B400, 1024)));
        assert_eq!(pages.len(), 46);
        // Two blocks in one sector and one in the third: two sectors, the gap left alone.
        let (sectors, _) = layout(
            &[
                (0x0800_0000, 0x0800_0010),
                (0x0800_0100, 0x0800_0200),
                (0x0800_0800, 0x0800_0801),
            ],
            &flash,
        );
        assert_eq!(sectors, vec![(0x0800_0000, 1024), (0x0800_0800, 1024)]);
    }

    #[test]
    fn options_are_checked_before_anything_is_touched() {
        let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(parse(&args(&["--dry-run"])).is_err(), "no --elf");
        assert!(parse(&args(&["--elf", "x", "--dry-run", "--log"])).is_err());
        assert!(parse(&args(&["--elf", "x", "--probe", "not-a-probe"])).is_err());
        assert!(parse(&args(&["--elf", "x", "--speed", "1"])).is_err());
        let o = parse(&args(&[
            "--elf",
            "x",
            "--probe",
            "0483:3748:ABC",
            "--chip",
            "STM32F103C8",
        ]))
        .unwrap();
        assert_eq!(o.chip, "STM32F103C8");
        assert_eq!(o.probe.unwrap().to_string(), "0483:3748:ABC");
        assert_eq!(parse(&args(&["--elf", "x"])).unwrap().chip, "STM32F103CB");
    }
}
