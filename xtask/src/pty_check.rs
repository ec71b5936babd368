//! `qemu-run --port pty --check SECONDS [--ppo N]`: an independent DP master (profirust, PPO1
//! or the PPO given, a 300 ms watchdog) on the pty's other end, polling as fast as it can in
//! real time, with 100 bursts of random bytes written between its telegrams, spread over the
//! run. It reports the cycles, how often the slave left data exchange (a watchdog expiry or a
//! reparameterisation), and whether the inputs followed the outputs through the drive the
//! whole time: the set frequency steps every 0.5 s, so the actual frequency (the inputs'
//! second PZD) must move in every 2-second window. It fails the run if the slave left data
//! exchange once it was there, never got there, or stopped following.

use anyhow::{bail, Result};
use profidrive::ppo::Ppo;
use profirust::phy::ProfibusPhy;
use rand::{Rng, SeedableRng};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// profirust's PHY on a pty: writes go out at once, reads take what has arrived.
struct PtyPhy {
    port: TTYPort,
    received: Vec<u8>,
    /// The last telegrams each way, with their times, for a report when the master leaves
    /// data exchange.
    trace: std::collections::VecDeque<(Instant, &'static str, Vec<u8>)>,
}

impl PtyPhy {
    fn record(&mut self, way: &'static str, bytes: &[u8]) {
        if self.trace.len() == 200 {
            self.trace.pop_front();
        }
        self.trace.push_back((Instant::now(), way, bytes.to_vec()));
    }
}

impl ProfibusPhy for PtyPhy {
    fn poll_transmission(&mut self, _now: profirust::time::Instant) -> bool {
        false
    }

    fn transmit_data<F, R>(&mut self, _now: profirust::time::Instant, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> (usize, R),
    {
        let mut buffer = [0u8; 256];
        let (len, result) = f(&mut buffer);
        if len > 0 {
            self.received.clear();
            self.record("tx", &buffer[..len]);
            let _ = self.port.write_all(&buffer[..len]);
            let _ = self.port.flush();
        }
        result
    }

    fn receive_data<F, R>(&mut self, _now: profirust::time::Instant, f: F) -> R
    where
        F: FnOnce(&[u8]) -> (usize, R),
    {
        if let Ok(n) = self.port.bytes_to_read() {
            let mut buffer = vec![0u8; n as usize];
            if n > 0 && self.port.read_exact(&mut buffer).is_ok() {
                self.record("rx", &buffer);
                self.received.extend_from_slice(&buffer);
            }
        }
        let (used, result) = f(&self.received);
        self.received.drain(..used.min(self.received.len()));
        result
    }
}

/// Bursts of junk the check writes, spread over the run.
pub const BURSTS: u64 = 100;
/// The window in which the actual frequency must move.
const FOLLOW_WINDOW: Duration = Duration::from_secs(2);

/// The check's figures.
pub struct CheckReport {
    pub cycles: u64,
    pub left_data_exchange: u64,
    pub bursts: u64,
    /// The junk bytes the bursts wrote, and the longest request the master sends in data
    /// exchange (what a burst may cost besides itself).
    pub junk_bytes: u64,
    pub data_exchange_request_len: u64,
    /// The actual frequency moved, and never stood still longer than the window.
    pub inputs_followed: bool,
    pub longest_still: Duration,
}

/// Runs the master on `port` (the pty's slave end) against the adapter at `address` for
/// `seconds`; `stop` is polled so that the caller can end it.
pub fn run(port: TTYPort, address: u8, seconds: f64, ppo: Ppo) -> Result<CheckReport> {
    let mut phy = PtyPhy {
        port,
        received: Vec::new(),
        trace: Default::default(),
    };
    let (mut dp, handle, mut fdl) = hal_sim::serial::pc_master(address, ppo);
    // The PZD follow the PKW where there is one: PZD1 the control or status word, PZD2 the
    // set or actual frequency.
    let pzd = if ppo.has_pkw() { 8 } else { 0 };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5EED);
    let start = Instant::now();
    let (mut cycles, mut left, mut bursts, mut junk_bytes) = (0u64, 0u64, 0u64, 0u64);
    let mut running = false;
    let mut dump_at = None;
    // When the actual frequency last moved, and the longest it stood still in data exchange.
    let (mut last_actual, mut moved_at) = (None::<u16>, Instant::now());
    let mut longest_still = Duration::ZERO;
    let mut inputs_changed = false;
    while start.elapsed().as_secs_f64() < seconds {
        let now = profirust::time::Instant::from_micros(start.elapsed().as_micros() as i64);
        fdl.poll(now, &mut phy, &mut dp);
        let events = dp.take_last_events();
        let peripheral = dp.get_mut(handle);
        let now_running = peripheral.is_running();
        if running && !now_running {
            left += 1;
            // What the master last saw, for the one run in eight that leaves (issue 16).
            let diag = peripheral
                .last_diagnostics()
                .map(|d| format!("{:?}, locked to {:?}", d.flags, d.master_address));
            eprintln!(
                "pty check: the master left data exchange at {:.1} s after {cycles} cycles and \
                 {bursts} bursts; its last diagnosis: {}",
                start.elapsed().as_secs_f64(),
                diag.as_deref().unwrap_or("none")
            );
            dump_at = Some(Instant::now() + Duration::from_millis(100));
        }
        if dump_at.is_some_and(|at| Instant::now() >= at) {
            dump_at = None;
            for (at, way, bytes) in &phy.trace {
                eprintln!("  {:>10} us {way} {bytes:02X?}", (*at - start).as_micros());
            }
        }
        if !running && now_running {
            moved_at = Instant::now();
        }
        running = now_running;
        if events.cycle_completed && now_running {
            cycles += 1;
            // The echo program's outputs: run, PZD2 a set frequency that steps every 0.5 s.
            let outputs = peripheral.pi_q_mut();
            let cw = hal_sim::cosim::ECHO_CONTROL_WORD.to_be_bytes();
            outputs[pzd..pzd + 2].copy_from_slice(&cw);
            let f = ((start.elapsed().as_millis() / 500) % 49 + 1) as u16 * 100;
            outputs[pzd + 2..pzd + 4].copy_from_slice(&f.to_be_bytes());
            let inputs = peripheral.pi_i();
            let actual = u16::from_be_bytes([inputs[pzd + 2], inputs[pzd + 3]]);
            if last_actual.is_some_and(|a| a != actual) {
                inputs_changed = true;
                moved_at = Instant::now();
            }
            last_actual = Some(actual);
            longest_still = longest_still.max(moved_at.elapsed());
            // A burst of junk between two telegrams, BURSTS of them spread over the run.
            let due = (start.elapsed().as_secs_f64() / seconds * (BURSTS + 1) as f64) as u64;
            if bursts < BURSTS && bursts < due {
                let len = rng.gen_range(1..64);
                let junk: Vec<u8> = (0..len).map(|_| rng.gen()).collect();
                phy.record("junk", &junk);
                let _ = phy.port.write_all(&junk);
                bursts += 1;
                junk_bytes += len as u64;
            }
        }
        std::thread::sleep(Duration::from_micros(100));
    }
    if cycles == 0 {
        bail!("the master never reached data exchange over the pty");
    }
    Ok(CheckReport {
        cycles,
        left_data_exchange: left,
        bursts,
        junk_bytes,
        data_exchange_request_len: hal_sim::dp_cycle::data_exchange_bytes(ppo).0 as u64,
        inputs_followed: inputs_changed && longest_still <= FOLLOW_WINDOW,
        longest_still,
    })
}
