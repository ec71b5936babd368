//! VCD waveform dump of the line and the transceiver's internal signals, for GTKWave.
//!
//! A [`Tracer`] samples a fixed set of signals once per clock and writes only changes, with the
//! time in picoseconds (the sample clock's period is rarely a whole number of nanoseconds). Tests
//! dump a waveform when they fail; runs can dump one on request.

use crate::transceiver::{BaudState, Transceiver};
use crate::Tick;
use std::io::{self, Write};
use vcd::{IdCode, TimescaleUnit, Value};

/// The signals of one transceiver and the line it sits on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Sample {
    line: bool,
    synced: bool,
    rx_active: bool,
    rx_bit: u8,
    measuring: bool,
    in_telegram: bool,
    driver_enable: bool,
    /// 0 searching, 1 trial, 2 locked.
    baud_state: u8,
    /// Index into `Baud::ALL` (15 while none).
    baud: u8,
    /// The lock a trial returns to if it fails (15: none).
    fallback: u8,
}

/// A signal: its index in `ids`, its width and how to read it from a sample.
type Field = (usize, u32, fn(&Sample) -> u32);

/// Writes a VCD file of one transceiver's signals.
pub struct Tracer<W: Write> {
    vcd: vcd::Writer<W>,
    ids: [IdCode; 10],
    last: Option<Sample>,
    clock_hz: u64,
}

impl<W: Write> Tracer<W> {
    /// Start a waveform with the transceiver's signals under module `scope`.
    pub fn new(out: W, clock_hz: u32, scope: &str) -> io::Result<Self> {
        let mut vcd = vcd::Writer::new(out);
        vcd.timescale(1, TimescaleUnit::PS)?;
        vcd.add_module(scope)?;
        let ids = [
            vcd.add_wire(1, "line")?,
            vcd.add_wire(1, "synced")?,
            vcd.add_wire(1, "rx_active")?,
            vcd.add_wire(4, "rx_bit")?,
            vcd.add_wire(1, "measuring")?,
            vcd.add_wire(1, "in_telegram")?,
            vcd.add_wire(1, "driver_enable")?,
            vcd.add_wire(2, "baud_state")?,
            vcd.add_wire(4, "baud")?,
            vcd.add_wire(4, "fallback")?,
        ];
        vcd.upscope()?;
        vcd.enddefinitions()?;
        Ok(Tracer {
            vcd,
            ids,
            last: None,
            clock_hz: clock_hz as u64,
        })
    }

    /// Record the signals at `now` (call once per clock, after the clock edge).
    pub fn sample(&mut self, now: Tick, line: bool, x: &Transceiver) -> io::Result<()> {
        let p = x.probe();
        let (state, baud) = match x.baud_state() {
            BaudState::Searching => (0, 15),
            BaudState::Trial(b) => (1, b.index() as u8),
            BaudState::Locked(b) => (2, b.index() as u8),
        };
        let s = Sample {
            line,
            synced: p.synced,
            rx_active: p.rx_active,
            rx_bit: p.rx_bit,
            measuring: p.measuring,
            in_telegram: p.in_telegram,
            driver_enable: p.driver_enable,
            baud_state: state,
            baud,
            fallback: p.fallback.map_or(15, |b| b.index() as u8),
        };
        if self.last == Some(s) {
            return Ok(());
        }
        let ps = (now as u128 * 1_000_000_000_000 / self.clock_hz as u128) as u64;
        self.vcd.timestamp(ps)?;
        let old = self.last;
        let changed = |f: fn(&Sample) -> u32| old.is_none_or(|o| f(&o) != f(&s));
        let fields: [Field; 10] = [
            (0, 1, |s| s.line as u32),
            (1, 1, |s| s.synced as u32),
            (2, 1, |s| s.rx_active as u32),
            (3, 4, |s| s.rx_bit as u32),
            (4, 1, |s| s.measuring as u32),
            (5, 1, |s| s.in_telegram as u32),
            (6, 1, |s| s.driver_enable as u32),
            (7, 2, |s| s.baud_state as u32),
            (8, 4, |s| s.baud as u32),
            (9, 4, |s| s.fallback as u32),
        ];
        for (i, width, f) in fields {
            if !changed(f) {
                continue;
            }
            let v = f(&s);
            if width == 1 {
                self.vcd.change_scalar(self.ids[i], v == 1)?;
            } else {
                let bits = (0..width).rev().map(|b| Value::from(v >> b & 1 == 1));
                self.vcd.change_vector(self.ids[i], bits)?;
            }
        }
        self.last = Some(s);
        Ok(())
    }

    /// Flush what is buffered.
    pub fn flush(&mut self) -> io::Result<()> {
        self.vcd.flush()
    }
}
