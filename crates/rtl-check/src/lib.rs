//! rtl-check: the gateware's blocks (`gateware/rtl`) against their Rust twins in dp-phy, the
//! reference, clock for clock.
//!
//! Contract:
//! - A [`Block`] names its Verilog, its top module, its Verilator harness
//!   (`gateware/sim/<top>_check.cpp`) and the output bits it compares. [`verilator::build`]
//!   Verilates it with its parameters; the harness reads a stimulus file and writes its
//!   outputs, run-length coded, one value a clock ([`Trace`]).
//! - Each [`Case`] carries its stimulus and what the Rust model gave on the same stimulus, in
//!   strict mode (every clock ticked). The harness only clocks the RTL: the model is the judge.
//! - [`first_mismatch`] names the first clock and signal at which the two differ, with both
//!   values; [`write_vcd`] writes both sides into one VCD file. A block that delivers more than
//!   bits a clock (a telegram and its bytes) writes [`Event`]s too, compared one by one
//!   ([`first_event_mismatch`]).
//! - Nothing here knows a block's insides but [`blocks`], which builds stimuli and runs the
//!   model; a new block is a module there, a harness and a row in [`blocks::ALL`].

pub mod blocks;
pub mod verilator;

use std::io::{self, Write};
use std::path::Path;

/// One value a clock, run-length coded: (outputs, clocks) with the outputs' bits as the
/// block's [`Block::signals`] name them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Trace {
    pub runs: Vec<(u8, u32)>,
}

impl Trace {
    /// One more clock with `value`.
    pub fn push(&mut self, value: u8) {
        match self.runs.last_mut() {
            Some((v, n)) if *v == value && *n < u32::MAX => *n += 1,
            _ => self.runs.push((value, 1)),
        }
    }

    pub fn clocks(&self) -> u64 {
        self.runs.iter().map(|(_, n)| u64::from(*n)).sum()
    }

    /// The harness's output file: (u8 value, u32 count) records.
    pub fn parse(bytes: &[u8]) -> io::Result<Trace> {
        if !bytes.len().is_multiple_of(5) {
            return Err(io::Error::other(format!(
                "the harness wrote {} bytes, not whole (value, count) records",
                bytes.len()
            )));
        }
        let mut trace = Trace::default();
        for record in bytes.chunks_exact(5) {
            let count = u32::from_le_bytes([record[1], record[2], record[3], record[4]]);
            // Runs the harness split (it never does) join, as push would have.
            match trace.runs.last_mut() {
                Some((v, n)) if *v == record[0] => *n += count,
                _ => trace.runs.push((record[0], count)),
            }
        }
        Ok(trace)
    }
}

/// A block of the gateware and its harness.
#[derive(Clone, Debug)]
pub struct Block {
    /// The top module, which names the harness (`<top>_check.cpp`) and `V<top>`.
    pub top: &'static str,
    /// Its Verilog files in `gateware/rtl`, the top's first.
    pub rtl: &'static [&'static str],
    /// The output bits, bit 0 first.
    pub signals: &'static [&'static str],
    /// Verilog parameters (`-G`), which make a build of their own.
    pub params: Vec<(&'static str, i64)>,
    /// The dp-phy twin, for reports.
    pub twin: &'static str,
    /// Its harness writes events (a third file).
    pub events: bool,
}

impl Block {
    /// A name for this build: the top and its parameters.
    pub fn build_name(&self) -> String {
        let mut name = self.top.to_string();
        for (param, value) in &self.params {
            name.push_str(&format!("-{param}{value}"));
        }
        name
    }
}

/// One stimulus and the model's outputs on it.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    /// The harness's records.
    pub stimulus: Vec<u8>,
    pub model: Trace,
    /// What the model delivered beside its per-clock outputs.
    pub model_events: Vec<Event>,
}

/// A delivery at a clock, its payload as the block's harness lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Event {
    pub clock: u32,
    pub payload: Vec<u8>,
}

impl Event {
    /// The harness's events file: (u32 clock, u16 length, payload) records.
    pub fn parse_all(mut bytes: &[u8]) -> io::Result<Vec<Event>> {
        let mut events = Vec::new();
        while !bytes.is_empty() {
            let broken = || io::Error::other("the harness wrote a broken event record");
            let head = bytes.get(..6).ok_or_else(broken)?;
            let clock = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
            let len = usize::from(u16::from_le_bytes([head[4], head[5]]));
            let payload = bytes.get(6..6 + len).ok_or_else(broken)?.to_vec();
            events.push(Event { clock, payload });
            bytes = &bytes[6 + len..];
        }
        Ok(events)
    }
}

/// The first event at which `rtl` differs from `model`: its index and both sides (None where
/// one side has no more).
pub fn first_event_mismatch(
    model: &[Event],
    rtl: &[Event],
) -> Option<(usize, Option<Event>, Option<Event>)> {
    (0..model.len().max(rtl.len()))
        .find(|&i| model.get(i) != rtl.get(i))
        .map(|i| (i, model.get(i).cloned(), rtl.get(i).cloned()))
}

/// Where the two sides first differ.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// Clock from the start of the case (0: the first after reset).
    pub clock: u64,
    pub signal: &'static str,
    pub model: bool,
    pub rtl: bool,
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "clock {} signal {}: model {} rtl {}",
            self.clock,
            self.signal,
            u8::from(self.model),
            u8::from(self.rtl)
        )
    }
}

/// The first clock at which `rtl` differs from `model` in one of `signals`; a trace that ends
/// early differs at its end (`signal` "length", the shorter side 0).
pub fn first_mismatch(model: &Trace, rtl: &Trace, signals: &[&'static str]) -> Option<Mismatch> {
    let (mut m, mut r) = (model.runs.iter().copied(), rtl.runs.iter().copied());
    let (mut mr, mut rr) = (m.next(), r.next());
    let mut clock = 0u64;
    loop {
        match (mr, rr) {
            (None, None) => return None,
            (Some(_), None) | (None, Some(_)) => {
                return Some(Mismatch {
                    clock,
                    signal: "length",
                    model: mr.is_some(),
                    rtl: rr.is_some(),
                })
            }
            (Some((mv, mn)), Some((rv, rn))) => {
                if mv != rv {
                    let bit = (0..signals.len())
                        .find(|b| (mv ^ rv) >> b & 1 == 1)
                        .unwrap_or(0);
                    return Some(Mismatch {
                        clock,
                        signal: signals.get(bit).copied().unwrap_or("?"),
                        model: mv >> bit & 1 == 1,
                        rtl: rv >> bit & 1 == 1,
                    });
                }
                let step = mn.min(rn);
                clock += u64::from(step);
                mr = if mn > step {
                    Some((mv, mn - step))
                } else {
                    m.next()
                };
                rr = if rn > step {
                    Some((rv, rn - step))
                } else {
                    r.next()
                };
            }
        }
    }
}

/// Both sides' signals in one VCD file (`model.*` and `rtl.*`), time in picoseconds of the
/// sample clock `clock_hz`.
pub fn write_vcd(
    path: &Path,
    signals: &[&'static str],
    model: &Trace,
    rtl: &Trace,
    clock_hz: u64,
) -> io::Result<()> {
    let file = std::fs::File::create(path)?;
    let mut vcd = vcd::Writer::new(io::BufWriter::new(file));
    vcd.timescale(1, vcd::TimescaleUnit::PS)?;
    let mut ids = Vec::new();
    for side in ["model", "rtl"] {
        vcd.add_module(side)?;
        ids.push(
            signals
                .iter()
                .map(|s| vcd.add_wire(1, s))
                .collect::<io::Result<Vec<_>>>()?,
        );
        vcd.upscope()?;
    }
    vcd.enddefinitions()?;
    // Every change of either side, in time order.
    let mut changes: Vec<(u64, usize, u8)> = Vec::new();
    for (side, trace) in [model, rtl].into_iter().enumerate() {
        let mut clock = 0u64;
        for (value, n) in &trace.runs {
            changes.push((clock, side, *value));
            clock += u64::from(*n);
        }
    }
    changes.sort_by_key(|(clock, side, _)| (*clock, *side));
    let mut last = [None::<u8>; 2];
    let mut time = None;
    for (clock, side, value) in changes {
        let t = clock * 1_000_000_000_000 / clock_hz;
        if time != Some(t) {
            vcd.timestamp(t)?;
            time = Some(t);
        }
        for (bit, id) in ids[side].iter().enumerate() {
            let now = value >> bit & 1;
            if last[side].is_none_or(|l| l >> bit & 1 != now) {
                vcd.change_scalar(*id, now == 1)?;
            }
        }
        last[side] = Some(value);
    }
    vcd.writer().flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(values: &[u8]) -> Trace {
        let mut t = Trace::default();
        values.iter().for_each(|v| t.push(*v));
        t
    }

    #[test]
    fn the_first_differing_clock_and_bit_are_named() {
        let signals = ["tx", "de"];
        let model = trace(&[1, 1, 2, 2, 3, 3, 1]);
        assert_eq!(first_mismatch(&model, &model.clone(), &signals), None);
        let rtl = trace(&[1, 1, 2, 3, 3, 3, 1]);
        assert_eq!(
            first_mismatch(&model, &rtl, &signals),
            Some(Mismatch {
                clock: 3,
                signal: "tx",
                model: false,
                rtl: true
            })
        );
        let rtl = trace(&[1, 1, 2, 2, 1, 3, 1]);
        assert_eq!(
            first_mismatch(&model, &rtl, &signals),
            Some(Mismatch {
                clock: 4,
                signal: "de",
                model: true,
                rtl: false
            })
        );
        let short = trace(&[1, 1, 2]);
        assert_eq!(
            first_mismatch(&model, &short, &signals),
            Some(Mismatch {
                clock: 3,
                signal: "length",
                model: true,
                rtl: false
            })
        );
    }

    #[test]
    fn harness_records_parse_into_runs() {
        let bytes = [2, 3, 0, 0, 0, 2, 1, 0, 0, 0, 1, 0, 0, 1, 0];
        assert_eq!(Trace::parse(&bytes).unwrap().runs, [(2, 4), (1, 65536)]);
        assert!(Trace::parse(&bytes[..4]).is_err());
    }
}
