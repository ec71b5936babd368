//! `qemu-run --port pty --check SECONDS`: an independent DP master (profirust, PPO1, a 300 ms
//! watchdog) on the pty's other end, polling as fast as it can in real time, with a burst of
//! random bytes written between its telegrams every so often. It reports the cycles, how often
//! the slave left data exchange (a watchdog expiry or a reparameterisation), and whether the
//! inputs followed the outputs (the echo through the drive); it fails the run if the slave
//! left data exchange once it was there, or never got there.

use anyhow::{bail, Result};
use profidrive::ppo::Ppo;
use profirust::dp::{DpMaster, Peripheral, PeripheralOptions};
use profirust::fdl::{FdlActiveStation, ParametersBuilder};
use profirust::phy::ProfibusPhy;
use rand::{Rng, SeedableRng};
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// profirust's PHY on a pty: writes go out at once, reads take what has arrived.
struct PtyPhy {
    port: TTYPort,
    received: Vec<u8>,
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
                self.received.extend_from_slice(&buffer);
            }
        }
        let (used, result) = f(&self.received);
        self.received.drain(..used.min(self.received.len()));
        result
    }
}

/// The check's figures.
pub struct CheckReport {
    pub cycles: u64,
    pub left_data_exchange: u64,
    pub bursts: u64,
    pub inputs_seen_changing: bool,
}

/// Runs the master on `port` (the pty's slave end) against the adapter at `address` for
/// `seconds`; `stop` is polled so that the caller can end it.
pub fn run(port: TTYPort, address: u8, seconds: f64) -> Result<CheckReport> {
    let mut phy = PtyPhy {
        port,
        received: Vec::new(),
    };
    let mut dp = DpMaster::new(vec![]);
    let ppo = Ppo::Ppo1;
    let user_prm: &'static [u8] = hal_sim::cosim::echo_user_prm().encode().to_vec().leak();
    let handle = dp.add(Peripheral::new(
        address,
        PeripheralOptions {
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            user_parameters: Some(user_prm),
            config: Some(ppo.cfg()),
            fail_safe: true,
            ..Default::default()
        },
        vec![0u8; 12],
        vec![0u8; 12],
    ));
    let mut fdl = FdlActiveStation::new(
        // A pty has no bit timing: profirust's timing at 187.5 kbit/s, with a slot time of 1000
        // bits (5.3 ms) for the host's latency, as a PC master allows for a USB converter.
        ParametersBuilder::new(2, profirust::Baudrate::B187500)
            .highest_station_address(3)
            .slot_bits(1000)
            .watchdog_timeout(profirust::time::Duration::from_millis(300))
            .build_verified(&dp),
    );
    fdl.set_online();
    dp.enter_operate();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5EED);
    let start = Instant::now();
    let (mut cycles, mut left, mut bursts) = (0u64, 0u64, 0u64);
    let mut running = false;
    let mut first_inputs: Option<Vec<u8>> = None;
    let mut inputs_changed = false;
    while start.elapsed().as_secs_f64() < seconds {
        let now = profirust::time::Instant::from_micros(start.elapsed().as_micros() as i64);
        fdl.poll(now, &mut phy, &mut dp);
        let events = dp.take_last_events();
        let peripheral = dp.get_mut(handle);
        let now_running = peripheral.is_running();
        if running && !now_running {
            left += 1;
        }
        running = now_running;
        if events.cycle_completed && now_running {
            cycles += 1;
            // The echo program's outputs: run, PZD2 a set frequency that steps.
            let mut outputs = [0u8; 12];
            let cw = hal_sim::cosim::ECHO_CONTROL_WORD.to_be_bytes();
            outputs[8..10].copy_from_slice(&cw);
            let f = ((cycles / 50) % 49 + 1) as u16 * 100;
            outputs[10..12].copy_from_slice(&f.to_be_bytes());
            peripheral.pi_q_mut().copy_from_slice(&outputs);
            let inputs = peripheral.pi_i().to_vec();
            match &first_inputs {
                None => first_inputs = Some(inputs),
                Some(first) => inputs_changed |= *first != inputs,
            }
            // Every 100th cycle, a burst of junk between two telegrams (at most 100 bursts).
            if cycles % 100 == 0 && bursts < 100 {
                let len = rng.gen_range(1..64);
                let junk: Vec<u8> = (0..len).map(|_| rng.gen()).collect();
                let _ = phy.port.write_all(&junk);
                bursts += 1;
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
        inputs_seen_changing: inputs_changed,
    })
}
