//! A profirust DP master on profirust's own simulated bus, against a [`Slave`]: the
//! independent-master proof used by this crate's tests and by the application crates'.
//! (Feature `harness`; std only.)
//!
//! profirust's `SimulatorPhy` panics when a station sends while another is sending, and when a
//! responder answers sooner than 11 bit times (min TSDR) or a requester leaves less than 33
//! (TSYN) after the last telegram, so every run also proves the slave's timing. The slave side
//! reads the bus byte by byte as profirust makes bytes visible, cuts complete telegrams with
//! fdl, and answers min TSDR after the request's last byte. After each telegram the
//! application's own work (its drive I/O) runs through the `service` hook.

extern crate std;

use crate::{Application, Config, Slave};
use profirust::dp::{DpMaster, Peripheral, PeripheralHandle, PeripheralOptions};
use profirust::fdl::{FdlActiveStation, ParametersBuilder};
use profirust::phy::{ProfibusPhy, SimulatorPhy};
use profirust::time::{Duration, Instant};
use profirust::Baudrate;
use std::vec;
use std::vec::Vec;

pub const MASTER: u8 = 2;
pub const SLAVE: u8 = 8;

/// What the master is told about the slave.
pub struct MasterOptions {
    pub ident_number: u16,
    pub user_prm: Vec<u8>,
    pub config: Vec<u8>,
}

pub struct Bus<A> {
    pub master_phy: SimulatorPhy,
    slave_phy: SimulatorPhy,
    pub fdl: FdlActiveStation,
    pub dp: DpMaster<'static>,
    pub handle: PeripheralHandle,
    pub slave: Slave<A>,
    /// The application's own work after each telegram (drive I/O), at the bus time.
    pub service: fn(&mut Slave<A>, crate::Instant),
    baud: Baudrate,
    step: Duration,
    /// The response and the earliest time it may go out.
    response: Option<(Instant, Vec<u8>)>,
    pub requests_seen: usize,
}

impl<A: Application> Bus<A> {
    pub fn new(baud: Baudrate, options: MasterOptions, config: Config, app: A) -> Bus<A> {
        let master_phy = SimulatorPhy::new(baud, "master");
        let slave_phy = master_phy.duplicate("slave");
        let mut dp = DpMaster::new(vec![]);
        let io = crate::cfg::io_sizes(&options.config).unwrap_or_default();
        let peripheral_options = PeripheralOptions {
            ident_number: options.ident_number,
            // profirust borrows these for the master's lifetime: leaked, a few bytes per test.
            user_parameters: Some(options.user_prm.leak()),
            config: Some(options.config.leak()),
            max_tsdr: 60,
            fail_safe: true,
            ..Default::default()
        };
        let handle = dp.add(
            Peripheral::new(
                SLAVE,
                peripheral_options,
                vec![0u8; io.inputs],
                vec![0u8; io.outputs],
            )
            .with_diag_buffer(vec![0u8; 32]),
        );
        let mut fdl = FdlActiveStation::new(
            ParametersBuilder::new(MASTER, baud)
                .highest_station_address(16)
                .watchdog_timeout(Duration::from_millis(200))
                .build_verified(&dp),
        );
        fdl.set_online();
        dp.enter_operate();
        // A step well under one character so that bytes are seen as soon as they are complete.
        let step = Duration::from_micros((baud.bits_to_time(1000).total_micros() / 1000).max(1));
        Bus {
            master_phy,
            slave_phy,
            fdl,
            dp,
            handle,
            slave: Slave::new(config, app),
            service: |_, _| {},
            baud,
            step,
            response: None,
            requests_seen: 0,
        }
    }

    pub fn now(&self) -> Instant {
        self.master_phy.bus_time()
    }

    pub fn slave_now(&self) -> crate::Instant {
        crate::Instant::from_micros(self.now().total_micros() as u64)
    }

    /// One time step: the master, then the slave.
    pub fn step(&mut self) {
        self.master_phy.advance_bus_time(self.step);
        let now = self.now();
        self.fdl.poll(now, &mut self.master_phy, &mut self.dp);
        self.poll_slave(now);
    }

    fn poll_slave(&mut self, now: Instant) {
        if self.slave_phy.poll_transmission(now) {
            return;
        }
        if let Some((due, bytes)) = &self.response {
            if now >= *due {
                let bytes = bytes.clone();
                self.slave_phy.transmit_data(now, |buf| {
                    buf[..bytes.len()].copy_from_slice(&bytes);
                    (bytes.len(), ())
                });
                self.response = None;
            }
            return;
        }
        let slave_now = self.slave_now();
        let slave = &mut self.slave;
        let mut out = [0u8; 256];
        let answer = self.slave_phy.receive_data(now, |pending| {
            match fdl::Repr::parse_bytes(pending) {
                Ok((_, len)) => {
                    let answer = slave.handle(slave_now, &pending[..len], &mut out);
                    (len, Some(answer))
                }
                Err(fdl::Error::Truncated) => (0, None),
                // Not a telegram start: drop a byte and look again next step.
                Err(_) => (1, None),
            }
        });
        if let Some(answer) = answer {
            self.requests_seen += 1;
            (self.service)(&mut self.slave, slave_now);
            if let Some(n) = answer {
                let tsdr = u32::from(self.slave.min_tsdr_bits());
                self.response = Some((now + self.baud.bits_to_time(tsdr), out[..n].to_vec()));
            }
        }
    }

    pub fn run_for(&mut self, duration: Duration) {
        let end = self.now() + duration;
        while self.now() < end {
            self.step();
        }
    }

    /// Steps until `done`; panics with the bus log after `limit`.
    pub fn run_until(&mut self, limit: Duration, mut done: impl FnMut(&mut Bus<A>) -> bool) {
        let end = self.now() + limit;
        while self.now() < end {
            self.step();
            if done(self) {
                return;
            }
        }
        self.master_phy.print_bus_log();
        panic!("not done within {} ms", limit.total_millis());
    }

    /// Steps until the master completes one more data exchange cycle.
    pub fn cycle(&mut self) {
        self.run_until(Duration::from_secs(2), |b| {
            b.dp.take_last_events().cycle_completed
        });
    }

    pub fn pi_q_mut(&mut self) -> &mut [u8] {
        self.dp.get_mut(self.handle).pi_q_mut()
    }

    pub fn pi_i(&mut self) -> Vec<u8> {
        self.dp.get_mut(self.handle).pi_i().to_vec()
    }

    pub fn running(&mut self) -> bool {
        self.dp.get_mut(self.handle).is_running()
    }
}
