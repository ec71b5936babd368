//! `cargo xtask qemu-run`: the adapter interactively, the firmware in QEMU with the drive
//! simulator behind it and a live status line.
//!
//! - No `--port`: the simulated bus with the profirust master (1.5 Mbit/s, PPO1, the echo
//!   program), paced to the wall clock.
//! - `--port pty`: a pseudo-terminal is created and its name printed; any DP master software
//!   opens it. `--port /dev/ttyUSB0` (any device): a real port, e.g. a PLC behind a USB-RS485
//!   converter. On a port there is no bit timing: telegrams are delimited by start delimiter
//!   and length (`hal_sim::serial`); `--baud` sets the port's rate (default 19200).
//! - `--check N [--ppo P]` (with `--port pty`): an independent DP master (profirust, PPO1 or
//!   P) on the pty's other end for N seconds, with 100 bursts of random bytes between its
//!   telegrams; the run fails if the slave leaves data exchange once there, its watchdog
//!   expires, it is parameterised again, or its inputs stop following the outputs
//!   (`crate::pty_check`).
//! - `--switch N`: the address switch (default 8); `--seconds N`: stop after N seconds of
//!   wall time (default: until Ctrl-C or SIGTERM, which stop QEMU and print a summary, QEMU's
//!   CPU time included).
//! - `--pty-link PATH` (with `--port pty`): where the stable symlink to the pty goes (default
//!   `target/qemu-run.pty`), so that a master's configuration names one path from run to run.
//!   Only a symlink is ever replaced there, and it is removed at the end of the run.
//! - `--dpv1` (with `--port`): the simulated drive's 51.21 DP MODE = 1, set at its panel and
//!   taken with a refresh: the adapter expects a DP-V1 Set_Prm (the GSD DPA1D7A1.GSD from
//!   `cargo xtask gsd`) and serves MSAC1 on SAP 51 (the PROFIdrive parameter channel, index 47).
//! - `--log`: the firmware's defmt log, decoded (with the table of the image QEMU runs), a line
//!   as each comes, between the status lines.
//!
//! The status line rewrites itself on a terminal and prints a line each time otherwise (a log
//! file holds lines).

use crate::qemu_test::{build, ensure_qemu, ensure_target, QEMU_IMAGE};
use crate::{check_flags, flag_value};
use anyhow::{bail, Context, Result};
use dp_consts::Baud;
use drive_sim::DriveSim;
use hal_sim::cosim::{CoSim, MasterSetup};
use hal_sim::firmware::Qemu;
use hal_sim::serial::SerialAdapter;
use serialport::SerialPort;
use std::io::{IsTerminal, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Ctrl-C or SIGTERM was received: the loop ends, QEMU is stopped (on drop), a summary printed.
fn stop_flag() -> Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
        .context("installing the Ctrl-C / SIGTERM handler")?;
    Ok(stop)
}

/// One status line: rewritten in place on a terminal, a line of its own otherwise.
fn status(line: &str) -> Result<()> {
    let mut out = std::io::stdout();
    if out.is_terminal() {
        write!(out, "\r{line}   ")?;
    } else {
        writeln!(out, "{line}")?;
    }
    out.flush()?;
    Ok(())
}

/// The firmware's defmt log, printed as it comes (`--log`).
struct LiveLog {
    table: defmt_decoder::Table,
    /// The stream's bytes and lines printed so far (both start again after a power cycle).
    bytes: usize,
    lines: usize,
}

impl LiveLog {
    fn new(elf: &std::path::Path) -> Result<LiveLog> {
        let table = crate::qemu_test::defmt_table(elf)?;
        Ok(LiveLog {
            table,
            bytes: 0,
            lines: 0,
        })
    }

    /// Prints the lines that came since the last call. The stream is decoded whole each time
    /// (a frame may end in the next call's bytes); the log is a few lines a minute.
    fn print_new(&mut self, firmware: &Qemu) -> Result<()> {
        let bytes = firmware.defmt_bytes();
        if bytes.len() < self.bytes {
            self.lines = 0;
        }
        if bytes.len() == self.bytes {
            return Ok(());
        }
        self.bytes = bytes.len();
        let lines = crate::qemu_test::decode(&self.table, &bytes)?;
        let mut out = std::io::stdout();
        for (level, message) in lines.iter().skip(self.lines) {
            // On a terminal, over the status line; it is written again next time.
            let start = if out.is_terminal() { "\r" } else { "" };
            writeln!(out, "{start}firmware: {level:<5} {message}")?;
        }
        self.lines = lines.len();
        Ok(())
    }
}

/// QEMU must still run: if it died, say so instead of showing a frozen status. With `--log`,
/// the firmware's new log lines.
fn check_alive(firmware: &mut Qemu, log: &mut Option<LiveLog>) -> Result<()> {
    if let Some(log) = log {
        log.print_new(firmware)?;
    }
    if let Some(exit) = firmware.exit_status()? {
        bail!("QEMU exited ({exit}): the firmware stopped; its log is in the run's defmt stream");
    }
    Ok(())
}

pub fn run(args: &[String]) -> Result<()> {
    check_flags(
        args,
        &["--log", "--dpv1"],
        &[
            "--port",
            "--baud",
            "--switch",
            "--seconds",
            "--check",
            "--pty-link",
            "--ppo",
        ],
    )?;
    let ppo = match flag_value(args, "--ppo")? {
        None => profidrive::ppo::Ppo::Ppo1,
        Some(n) => {
            let n: u8 = n.parse().context("--ppo takes a PPO number, 1-6")?;
            profidrive::ppo::Ppo::ALL
                .into_iter()
                .find(|p| p.number() == n)
                .with_context(|| format!("--ppo {n}: no such PPO (1-6)"))?
        }
    };
    let pty_link = flag_value(args, "--pty-link")?.map(std::path::PathBuf::from);
    if pty_link.is_some() && flag_value(args, "--port")? != Some("pty") {
        bail!("--pty-link names a link to the pty: use it with --port pty");
    }
    let check: Option<f64> = flag_value(args, "--check")?
        .map(str::parse)
        .transpose()
        .context("--check takes seconds")?;
    if check.is_some() && flag_value(args, "--port")? != Some("pty") {
        bail!("--check runs a master on the pty: use it with --port pty");
    }
    if check.is_none() && flag_value(args, "--ppo")?.is_some() {
        bail!("--ppo is the check's master's PPO: use it with --check");
    }
    let dpv1 = args.iter().any(|a| a == "--dpv1");
    if dpv1 && (flag_value(args, "--port")?.is_none() || check.is_some()) {
        bail!(
            "--dpv1 is for a DP-V1 master of your own on --port (the simulated bus's master and \
             the check's are DP-V0)"
        );
    }
    let switch: u8 = flag_value(args, "--switch")?
        .unwrap_or("8")
        .parse()
        .context("--switch")?;
    if switch > 99 {
        bail!("--switch is two decimal digits, 0-99");
    }
    let seconds: Option<f64> = flag_value(args, "--seconds")?
        .map(str::parse)
        .transpose()
        .context("--seconds")?;
    let port_baud: u32 = flag_value(args, "--baud")?
        .unwrap_or("19200")
        .parse()
        .context("--baud")?;
    ensure_target()?;
    let qemu = ensure_qemu()?;
    println!("qemu-run: building the firmware (release, lm3s6965evb)...");
    let elf = build(&QEMU_IMAGE)?;
    let machine = QEMU_IMAGE
        .machine()
        .expect("the QEMU board runs under QEMU");
    let firmware = Qemu::start_realtime(&qemu, &elf, machine).context("starting QEMU")?;
    let log = if args.iter().any(|a| a == "--log") {
        Some(LiveLog::new(&elf)?)
    } else {
        None
    };
    let stop_at = seconds
        .or(check.map(|c| c + 2.0))
        .map(Duration::from_secs_f64);
    match flag_value(args, "--port")? {
        None => simulated_bus(firmware, switch, stop_at, log),
        Some(port) => {
            let link =
                pty_link.unwrap_or_else(|| crate::project_root().join("target/qemu-run.pty"));
            serial_port(
                firmware,
                switch,
                PortRun {
                    port,
                    baud: port_baud,
                    stop_at,
                    check: check.map(|s| (s, ppo)),
                    pty_link: &link,
                    log,
                    dpv1,
                },
            )
        }
    }
}

/// Links `path` to the pty `name`. Only a symlink (an earlier run's) is replaced: a file or a
/// directory there is the user's.
fn link_pty(name: &str, path: &std::path::Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => std::fs::remove_file(path)
            .with_context(|| format!("--pty-link: replacing the old link {}", path.display()))?,
        Ok(_) => bail!(
            "--pty-link: {} exists and is not a symlink; name another path",
            path.display()
        ),
        Err(_) => {}
    }
    std::os::unix::fs::symlink(name, path)
        .with_context(|| format!("--pty-link: linking {} to {name}", path.display()))
}

/// The link to the pty, removed when the run ends (the pty goes with it).
struct LinkedPty(std::path::PathBuf);

impl Drop for LinkedPty {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// The DP state for the status line. Power_On is the DP state machine's own: the slave stays in
/// it until its first request other than Set_Slave_Add, which is why it shows until a master
/// speaks.
fn state_name(state: dp_link::SlaveState) -> String {
    match state {
        dp_link::SlaveState::PowerOn => "PowerOn (no request yet)".to_string(),
        other => format!("{other:?}"),
    }
}

fn drive_line(drive: &DriveSim, link_error: u8) -> String {
    format!(
        "drive: CW {:04X} f {:>3}.{:02} Hz{} link {}",
        drive.control_word(),
        drive.output_frequency() / 100,
        drive.output_frequency() % 100,
        if drive.reverse() { " rev" } else { "" },
        match link_error {
            0 => "ok".to_string(),
            0x21 => "error 0x21 (noise on the drive line)".to_string(),
            0x22 => "error 0x22 (the drive does not answer)".to_string(),
            0x23 => "error 0x23 (CRC error from the drive)".to_string(),
            e => format!("error 0x{e:02X} (the drive refused)"),
        }
    )
}

fn simulated_bus(
    firmware: Qemu,
    switch: u8,
    stop_at: Option<Duration>,
    mut log: Option<LiveLog>,
) -> Result<()> {
    let mut sim = CoSim::new(firmware, switch, None)?;
    let address = sim.bridge.status.address;
    sim.start_master(MasterSetup::new(Baud::B1500000, address));
    println!("qemu-run: the firmware in QEMU, a profirust master at 1.5M on the simulated bus, the drive simulator; Ctrl-C ends");
    let stop = stop_flag()?;
    let start = Instant::now();
    let mut last_print = Instant::now();
    loop {
        sim.run_for_us(20_000)?;
        let sim_time = Duration::from_micros(sim.now_us());
        if let Some(ahead) = sim_time.checked_sub(start.elapsed()) {
            std::thread::sleep(ahead);
        }
        if last_print.elapsed() >= Duration::from_millis(500) {
            last_print = Instant::now();
            let cycles = sim.master.as_ref().map_or(0, |m| m.cycles);
            let (state, addr, err) = (
                sim.bridge.status.state,
                sim.bridge.status.address,
                sim.bridge.status.drive_link_error,
            );
            let drive = drive_line(sim.drive_now(), err);
            status(&format!(
                "[{:>7.1} s] {} addr {addr} DX cycles {cycles} {drive}",
                sim_time.as_secs_f64(),
                state_name(state)
            ))?;
            check_alive(&mut sim.bridge.firmware, &mut log)?;
        }
        if stop.load(Ordering::SeqCst) || stop_at.is_some_and(|s| start.elapsed() >= s) {
            let cycles = sim.master.as_ref().map_or(0, |m| m.cycles);
            println!(
                "\nqemu-run: {:.1} s of bus time, {cycles} data exchange cycles, state {:?}",
                sim_time.as_secs_f64(),
                sim.bridge.status.state
            );
            return Ok(());
        }
    }
}

/// Whether the check's thread ends within a second (it closes its end of the pty just before).
fn finishes_soon<T>(checker: &std::thread::JoinHandle<T>) -> bool {
    let until = Instant::now() + Duration::from_secs(1);
    while !checker.is_finished() {
        if Instant::now() >= until {
            return false;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    true
}

/// What a run on a port was asked for.
struct PortRun<'a> {
    port: &'a str,
    baud: u32,
    stop_at: Option<Duration>,
    check: Option<(f64, profidrive::ppo::Ppo)>,
    /// The drive's 51.21 DP MODE = 1: the adapter takes DP-V1 Set_Prm and serves MSAC1.
    dpv1: bool,
    pty_link: &'a std::path::Path,
    log: Option<LiveLog>,
}

fn serial_port(firmware: Qemu, switch: u8, run: PortRun) -> Result<()> {
    let PortRun {
        port,
        baud,
        stop_at,
        check,
        pty_link,
        mut log,
        dpv1,
    } = run;
    let dp_baud = Baud::ALL
        .into_iter()
        .find(|b| b.bits_per_second() == baud)
        .unwrap_or(Baud::B19200);
    let mut adapter = SerialAdapter::new(firmware, switch, dp_baud)?;
    if dpv1 {
        // As a user would at the drive's panel: 51.21 = 1, then a refresh (51.27).
        use profidrive::fieldbus_group::{self as fieldbus, index};
        let drive = &mut adapter.bridge.drive.drive;
        let _ = drive.set_at_panel(fieldbus::code(index::DP_MODE).0, fieldbus::DP_MODE_DPV1);
        let _ = drive.set_at_panel(fieldbus::code(index::PAR_REFRESH).0, fieldbus::REFRESH);
        println!(
            "qemu-run: the drive's 51.21 DP MODE = 1: configure the master with {} (DP-V1)",
            profidrive::gsd::FILE_NAME_DPV1
        );
    }
    // The pty's other end must stay open while we run (or the check's master holds it).
    let mut _pty_other_end = None;
    let mut _linked = None;
    let mut checker = None;
    let mut port: Box<dyn SerialPort> = if port == "pty" {
        let (master, slave) = serialport::TTYPort::pair().context("creating a pseudo-terminal")?;
        let name = slave.name().unwrap_or_default();
        link_pty(&name, pty_link)?;
        _linked = Some(LinkedPty(pty_link.to_path_buf()));
        println!(
            "qemu-run: the adapter (address {}) is on {name} (also {}): point the DP master at it",
            adapter.bridge.status.address,
            pty_link.display()
        );
        match check {
            Some((seconds, ppo)) => {
                let address = adapter.bridge.status.address;
                checker = Some(std::thread::spawn(move || {
                    crate::pty_check::run(slave, address, seconds, ppo)
                }));
            }
            None => _pty_other_end = Some(slave),
        }
        Box::new(master)
    } else {
        println!(
            "qemu-run: the adapter (address {}) is on {port} at {baud} bit/s",
            adapter.bridge.status.address
        );
        serialport::new(port, baud)
            .parity(serialport::Parity::Even)
            .open()
            .with_context(|| format!("opening {port}"))?
    };
    // Short: the loop also runs the firmware and the drive line, whose answers are due within
    // a few hundred microseconds.
    port.set_timeout(Duration::from_micros(200))?;
    println!("qemu-run: telegrams are delimited by start delimiter and length; Ctrl-C ends");
    let stop = stop_flag()?;
    let start = Instant::now();
    let mut link_errors = 0u64;
    let mut last_link_error = 0u8;
    // A reply is late if it left more than the GSD's MaxTsdr at the port's rate after the request was
    // read (the port's own latency comes on top, on both sides, and is not ours to count).
    let late_after = Duration::from_micros(
        u64::from(dp_baud.adapter_max_tsdr_bits()) * 1_000_000 / u64::from(baud.max(1)),
    );
    let mut late_replies = 0u64;
    let mut last_print = Instant::now();
    let mut buf = [0u8; 512];
    // Bytes from the port, answered at once (the transceiver answers from its buffers).
    let mut serve = |adapter: &mut SerialAdapter<Qemu>,
                     port: &mut Box<dyn SerialPort>,
                     bytes: &[u8]|
     -> Result<()> {
        let read_at = Instant::now();
        let answer = adapter.on_bytes(start.elapsed().as_micros() as u64, bytes)?;
        if !answer.is_empty() {
            port.write_all(&answer)?;
            if read_at.elapsed() > late_after {
                late_replies += 1;
            }
        }
        Ok(())
    };
    loop {
        match port.read(&mut buf) {
            Ok(n) if n > 0 => serve(&mut adapter, &mut port, &buf[..n])?,
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            // A signal (Ctrl-C, SIGTERM) interrupted the read: the stop flag says what next.
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            // The check's master closed its end as its run ended: the summary follows. Its
            // thread may close the pty a moment before it counts as finished, so wait for it.
            Err(_) if checker.as_ref().is_some_and(finishes_soon) => {}
            Err(e) => return Err(e).context("reading the port"),
        }
        // The firmware's work one QEMU round trip at a time, with the port served in between:
        // a request that arrives meanwhile is answered within one round trip, not after all
        // of them (two answers later than the master's slot time make it give the slave up).
        // Up to the time at the top of this pass only: work that falls due meanwhile waits for
        // the next pass, or a host slower than the bus for a while would never leave here.
        let due_us = start.elapsed().as_micros() as u64;
        while adapter.poll_one(due_us)? {
            let waiting = port.bytes_to_read().unwrap_or(0) as usize;
            if waiting > 0 {
                let n = port.read(&mut buf[..waiting.min(512)]).unwrap_or(0);
                serve(&mut adapter, &mut port, &buf[..n])?;
            }
        }
        if last_print.elapsed() >= Duration::from_millis(500) {
            last_print = Instant::now();
            let now = start.elapsed().as_micros() as u64;
            adapter.bridge.drive.advance_to(now);
            let s = adapter.bridge.status;
            if s.drive_link_error != 0 && s.drive_link_error != last_link_error {
                link_errors += 1;
            }
            last_link_error = s.drive_link_error;
            status(&format!(
                "[{:>7.1} s] {} addr {} telegrams {} responses {} {}",
                start.elapsed().as_secs_f64(),
                state_name(s.state),
                s.address,
                adapter.telegrams,
                adapter.responses,
                drive_line(&adapter.bridge.drive.drive, s.drive_link_error)
            ))?;
            check_alive(&mut adapter.bridge.firmware, &mut log)?;
        }
        let checked = checker.as_ref().is_some_and(|c| c.is_finished());
        if checked || stop.load(Ordering::SeqCst) || stop_at.is_some_and(|s| start.elapsed() >= s) {
            let f = &adapter.bridge.figures;
            println!(
                "\nqemu-run: seconds={:.1} requests={} responses={} data_exchange={} watchdog_expiries={} reparameterisations={} late_replies={} skipped_bytes={} drive_link_errors={}",
                start.elapsed().as_secs_f64(),
                adapter.telegrams,
                adapter.responses,
                f.data_exchanges,
                f.watchdog_expiries,
                f.set_prms.saturating_sub(1),
                late_replies,
                adapter.skipped_bytes,
                link_errors,
            );
            if let Some(cpu) = adapter.bridge.firmware.cpu_seconds() {
                let wall = start.elapsed().as_secs_f64();
                println!(
                    "qemu-run: qemu_cpu_seconds={cpu:.1} of {wall:.1} s ({:.0} % of one core)",
                    100.0 * cpu / wall
                );
            }
            if let Some(checker) = checker {
                let r = checker
                    .join()
                    .map_err(|_| anyhow::anyhow!("the check's master panicked"))??;
                // Bytes of the master's own telegrams skipped: each burst may cost at most the
                // telegram it hit.
                let lost = adapter.skipped_bytes.saturating_sub(r.junk_bytes);
                let lost_bound = r.bursts * r.data_exchange_request_len;
                println!(
                    "qemu-run check: cycles={} left_data_exchange={} bursts={} junk_bytes={} telegram_bytes_lost={} (at most {}) inputs_followed={} (longest still {} ms)",
                    r.cycles,
                    r.left_data_exchange,
                    r.bursts,
                    r.junk_bytes,
                    lost,
                    lost_bound,
                    r.inputs_followed,
                    r.longest_still.as_millis()
                );
                if r.left_data_exchange > 0
                    || f.watchdog_expiries > 0
                    || f.set_prms > 1
                    || r.bursts < crate::pty_check::BURSTS
                    || lost > lost_bound
                    || !r.inputs_followed
                {
                    bail!(
                        "the check failed: the slave left data exchange, its watchdog expired, it \
                         was parameterised again, a burst was not written or cost more than the \
                         telegram it hit, or its inputs stopped following the outputs"
                    );
                }
            }
            return Ok(());
        }
    }
}
