//! A bench of one sending station (a master's transmitter), the adapter's transceiver and the
//! line between them, run strictly (one `tick` per clock) or fast (skipping quiet spans).
//!
//! Tests, the baud sweep and the benchmark all drive the model through it, so the way telegrams
//! are sent, faults applied and deliveries recorded is written once. A run records every delivered
//! telegram with its status, every change of the baud state, and can dump a VCD waveform.

use crate::bus::{Bus, FaultInjector, Outgoing, TxStation};
use crate::delimiter::Status;
use crate::trace::Tracer;
use crate::transceiver::{BaudState, Config, Transceiver};
use crate::{BitTiming, Tick};
use std::io::Write;

/// One telegram as the adapter delivered it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Delivered {
    pub bytes: Vec<u8>,
    pub status: Status,
    pub end: Tick,
}

/// Master transmitter + line + adapter transceiver.
pub struct Testbench {
    pub master: TxStation,
    pub adapter: Transceiver,
    pub bus: Bus,
    pub delivered: Vec<Delivered>,
    /// Every change of the adapter's baud state, with its tick.
    pub baud_log: Vec<(Tick, BaudState)>,
    /// Every telegram handed to the master's transmitter, with the tick it was handed over.
    pub sent: Vec<(Tick, Outgoing)>,
    tracer: Option<Tracer<Box<dyn Write>>>,
    observer: Option<Observer>,
}

/// Told every clock of a strict run: the line the adapter saw, the adapter after the clock, and
/// its outputs of the clock.
pub type Observer = Box<dyn FnMut(bool, &Transceiver, crate::TickOut)>;

impl Testbench {
    pub fn new(cfg: Config, master: BitTiming, faults: FaultInjector) -> Self {
        Testbench {
            master: TxStation::new(master),
            adapter: Transceiver::new(cfg),
            bus: Bus::new(faults),
            delivered: Vec::new(),
            baud_log: Vec::new(),
            sent: Vec::new(),
            tracer: None,
            observer: None,
        }
    }

    /// Dump a waveform of the adapter to `out` (strict mode only samples every clock).
    pub fn trace_to(&mut self, out: Box<dyn Write>) -> std::io::Result<()> {
        self.tracer = Some(Tracer::new(out, self.adapter.config().clock_hz, "adapter")?);
        Ok(())
    }

    /// Tell `observer` every clock from now on; the bench runs strict from then on (fast
    /// mode's skips have no clocks to tell).
    pub fn observe(&mut self, observer: Observer) {
        self.observer = Some(observer);
    }

    pub fn now(&self) -> Tick {
        self.adapter.now()
    }

    /// Queue a telegram at the master after `idle_bits` of its bit times.
    pub fn send(&mut self, idle_bits: u32, bytes: &[u8]) {
        self.master.push(idle_bits, bytes);
    }

    /// Queue a telegram with transmitter faults.
    pub fn send_outgoing(&mut self, o: Outgoing) {
        self.master.queue.push_back(o);
    }

    /// Replace the master's bit timing (it changes its rate); only while it is idle.
    pub fn set_master_timing(&mut self, timing: BitTiming) {
        assert!(!self.master.tx.busy(), "the master is sending");
        let queue = std::mem::take(&mut self.master.queue);
        let started = self.master.started;
        self.master = TxStation::new(timing);
        self.master.queue = queue;
        self.master.started = started;
    }

    /// One clock, every block ticked.
    #[inline]
    pub fn step_strict(&mut self) {
        let now = self.adapter.now();
        if !self.master.tx.busy() {
            if let Some(o) = self.master.queue.front() {
                self.sent.push((now, o.clone()));
            }
        }
        let line = self
            .bus
            .resolve(now, [self.master.drive(), self.adapter.drive()]);
        let out = self.adapter.tick(line);
        self.master.tick();
        self.record(out);
        if let Some(t) = &mut self.tracer {
            t.sample(now, line, &self.adapter).expect("waveform write");
        }
        if let Some(observe) = &mut self.observer {
            observe(line, &self.adapter, out);
        }
    }

    /// As many clocks as can be skipped at once, or one strict clock.
    #[inline]
    pub fn step_fast(&mut self, limit: Tick) {
        let now = self.adapter.now();
        let quiet = self
            .master
            .quiet_for()
            .min(self.bus.faults.quiet_for(now))
            .min(limit);
        if quiet == 0 || self.tracer.is_some() || self.observer.is_some() {
            return self.step_strict();
        }
        let line = self
            .bus
            .resolve(now, [self.master.drive(), self.adapter.drive()]);
        let (ticks, out) = self.adapter.advance(line, quiet);
        if ticks == 1 {
            self.master.tick();
        } else {
            self.master.skip(ticks);
        }
        self.record(out);
    }

    fn record(&mut self, out: crate::TickOut) {
        if out.telegram {
            let t = self.adapter.telegram();
            self.delivered.push(Delivered {
                bytes: t.bytes().to_vec(),
                status: t.status,
                end: t.end,
            });
        }
        if out.baud_changed {
            self.baud_log
                .push((self.adapter.now() - 1, self.adapter.baud_state()));
        }
    }

    /// Run until tick `until`, strictly or fast.
    pub fn run_until(&mut self, until: Tick, fast: bool) {
        while self.now() < until {
            if fast {
                self.step_fast(until - self.now());
            } else {
                self.step_strict();
            }
        }
    }

    /// Run until the master has sent everything and `tail_bits` of its bit times more passed.
    pub fn run_out(&mut self, tail_bits: u64, fast: bool) {
        while !self.master.done() {
            let next = self.now() + 1_000_000;
            while self.now() < next && !self.master.done() {
                if fast {
                    self.step_fast(next - self.now());
                } else {
                    self.step_strict();
                }
            }
        }
        let tail = self.master.tx.timing.clocks_for(tail_bits, 1);
        self.run_until(self.now() + tail, fast);
    }

    /// The good telegrams delivered, as byte strings.
    pub fn good(&self) -> Vec<Vec<u8>> {
        self.delivered
            .iter()
            .filter(|d| d.status == Status::Good)
            .map(|d| d.bytes.clone())
            .collect()
    }

    /// Flush the waveform, if one is being written.
    pub fn finish_trace(&mut self) -> std::io::Result<()> {
        match &mut self.tracer {
            Some(t) => t.flush(),
            None => Ok(()),
        }
    }
}

/// The kinds of telegram on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    Sd1,
    Sd2,
    Sd3,
    Sd4,
    Sc,
}

impl Kind {
    pub const ALL: [Kind; 5] = [Kind::Sd1, Kind::Sd2, Kind::Sd3, Kind::Sd4, Kind::Sc];
}

/// `count` random telegrams as the bus carries them from a master's polls: the first opens with
/// a start delimiter (SD1-SD4: an SC is no telegram start the search takes), the rest of any
/// kind, SD2 with 1..31 data bytes.
pub fn poll_sequence<R: rand::Rng>(rng: &mut R, count: usize) -> Vec<Vec<u8>> {
    (0..count)
        .map(|i| {
            let kind = if i == 0 {
                [Kind::Sd1, Kind::Sd2, Kind::Sd3, Kind::Sd4][rng.gen_range(0..4)]
            } else {
                Kind::ALL[rng.gen_range(0..5)]
            };
            let n = rng.gen_range(1..32);
            random_telegram(rng, kind, n)
        })
        .collect()
}

/// A well-formed telegram of `kind` with random addresses, function code and data (SD2: `len`
/// data bytes, 1..=246). Built byte by byte rather than by the `fdl` crate: the delimiter below
/// the responder must take whatever the line carries, including what `fdl` would never emit.
pub fn random_telegram<R: rand::Rng>(rng: &mut R, kind: Kind, len: usize) -> Vec<u8> {
    use dp_consts::{ED, SC, SD1, SD2, SD3, SD4};
    let (da, sa, fc) = (
        rng.gen_range(0..=127u8),
        rng.gen_range(0..=127u8),
        rng.gen::<u8>(),
    );
    let fcs = |body: &[u8]| body.iter().fold(0u8, |a, &x| a.wrapping_add(x));
    match kind {
        Kind::Sd1 => vec![SD1, da, sa, fc, fcs(&[da, sa, fc]), ED],
        Kind::Sd3 => {
            let mut t = vec![SD3, da, sa, fc];
            t.extend((0..8).map(|_| rng.gen::<u8>()));
            t.push(fcs(&t[1..]));
            t.push(ED);
            t
        }
        Kind::Sd2 => {
            let len = len.clamp(1, 246);
            let le = len as u8 + 3;
            let mut t = vec![SD2, le, le, SD2, da, sa, fc];
            t.extend((0..len).map(|_| rng.gen::<u8>()));
            t.push(fcs(&t[4..]));
            t.push(ED);
            t
        }
        Kind::Sd4 => vec![SD4, da, sa],
        Kind::Sc => vec![SC],
    }
}
