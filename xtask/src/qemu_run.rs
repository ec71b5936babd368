//! `cargo xtask qemu-run`: the adapter interactively, the firmware in QEMU with the drive
//! simulator behind it and a live status line.
//!
//! - No `--port`: the simulated bus with the profirust master (1.5 Mbit/s, PPO1, the echo
//!   program), paced to the wall clock.
//! - `--port pty`: a pseudo-terminal is created and its name printed; any DP master software
//!   opens it. `--port /dev/ttyUSB0` (any device): a real port, e.g. a PLC behind a USB-RS485
//!   converter. On a port there is no bit timing: telegrams are delimited by start delimiter
//!   and length (`hal_sim::serial`); `--baud` sets the port's rate (default 19200).
//! - `--switch N`: the address switch (default 8); `--seconds N`: stop after N seconds of
//!   wall time (default: until Ctrl-C).

use crate::qemu_test::{build, ensure_qemu, ensure_target, IMAGES};
use crate::{check_flags, flag_value};
use anyhow::{bail, Context, Result};
use dp_consts::Baud;
use drive_sim::DriveSim;
use hal_sim::cosim::{CoSim, MasterSetup};
use hal_sim::firmware::Qemu;
use hal_sim::serial::SerialAdapter;
use serialport::SerialPort;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--port", "--baud", "--switch", "--seconds"])?;
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
    let elf = build(&IMAGES[0])?;
    let firmware = Qemu::start(&qemu, &elf).context("starting QEMU")?;
    let stop_at = seconds.map(Duration::from_secs_f64);
    match flag_value(args, "--port")? {
        None => simulated_bus(firmware, switch, stop_at),
        Some(port) => serial_port(firmware, switch, port, port_baud, stop_at),
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
            e => format!("error 0x{e:02X}"),
        }
    )
}

fn simulated_bus(firmware: Qemu, switch: u8, stop_at: Option<Duration>) -> Result<()> {
    let mut sim = CoSim::new(firmware, switch, None)?;
    let address = sim.bridge.status.address;
    sim.start_master(MasterSetup::new(Baud::B1500000, address));
    println!("qemu-run: the firmware in QEMU, a profirust master at 1.5M on the simulated bus, the drive simulator; Ctrl-C ends");
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
            print!(
                "\r[{:>7.1} s] {state:?} addr {addr} DX cycles {cycles} {drive}   ",
                sim_time.as_secs_f64()
            );
            std::io::stdout().flush()?;
        }
        if stop_at.is_some_and(|s| start.elapsed() >= s) {
            println!();
            return Ok(());
        }
    }
}

fn serial_port(
    firmware: Qemu,
    switch: u8,
    port: &str,
    baud: u32,
    stop_at: Option<Duration>,
) -> Result<()> {
    let dp_baud = Baud::ALL
        .into_iter()
        .find(|b| b.bits_per_second() == baud)
        .unwrap_or(Baud::B19200);
    let mut adapter = SerialAdapter::new(firmware, switch, dp_baud)?;
    // The pty's other end must stay open while we run.
    let mut _pty_other_end = None;
    let mut port: Box<dyn SerialPort> = if port == "pty" {
        let (master, slave) = serialport::TTYPort::pair().context("creating a pseudo-terminal")?;
        let name = slave.name().unwrap_or_default();
        println!(
            "qemu-run: the adapter (address {}) is on {name}: point the DP master at it",
            adapter.bridge.status.address
        );
        _pty_other_end = Some(slave);
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
    let start = Instant::now();
    let mut last_print = Instant::now();
    let mut buf = [0u8; 512];
    loop {
        let now_us = start.elapsed().as_micros() as u64;
        match port.read(&mut buf) {
            Ok(n) if n > 0 => {
                let answer = adapter.on_bytes(now_us, &buf[..n])?;
                if !answer.is_empty() {
                    port.write_all(&answer)?;
                }
            }
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) => return Err(e).context("reading the port"),
        }
        adapter.poll(start.elapsed().as_micros() as u64)?;
        if last_print.elapsed() >= Duration::from_millis(500) {
            last_print = Instant::now();
            let now = start.elapsed().as_micros() as u64;
            adapter.bridge.drive.advance_to(now);
            let s = adapter.bridge.status;
            print!(
                "\r[{:>7.1} s] {:?} addr {} telegrams {} responses {} {}   ",
                start.elapsed().as_secs_f64(),
                s.state,
                s.address,
                adapter.telegrams,
                adapter.responses,
                drive_line(&adapter.bridge.drive.drive, s.drive_link_error)
            );
            std::io::stdout().flush()?;
        }
        if stop_at.is_some_and(|s| start.elapsed() >= s) {
            println!();
            return Ok(());
        }
    }
}
