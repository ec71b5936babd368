//! Telegram delimiter: cuts the character stream into whole telegrams and checks their frame.
//!
//! A telegram may only start on a line that was idle for TSYN (33 bit times) and must then come
//! without pause. From the start delimiter (and the SD2 length byte) it knows where the telegram
//! ends, so it delivers each one the moment its last stop bit ends, with a status:
//! good, or the first thing wrong with it (a character error, an idle gap inside, LE != LEr, a
//! length out of range, a bad FCS, a missing end delimiter). After any error nothing is taken as a
//! telegram start until the line has been idle for TSYN again.
//!
//! It is clocked by the receiver's character strobe and by an idle check on every clock; the
//! telegram buffer is its RAM, written one character at a time.

use crate::uart::{CharError, RxChar};
use crate::Tick;
use dp_consts::{
    ED, MAX_TELEGRAM_LEN, SC, SD1, SD2, SD2_MAX_LE, SD2_MIN_LE, SD3, SD3_DATA_LEN, SD4,
};

/// What a delivered telegram looks like.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Status {
    Good,
    /// A character inside had a parity, framing or break error.
    Char(CharError),
    /// The line went idle inside the telegram.
    Gap,
    /// The first byte is no start delimiter.
    BadDelimiter,
    /// SD2: LE and LEr differ, or the second SD2 is missing.
    LengthMismatch,
    /// SD2: LE outside 4..=249.
    BadLength,
    /// The frame check sequence is wrong.
    BadFcs,
    /// The last byte is not 0x16.
    NoEndDelimiter,
}

/// A telegram as the transceiver delivers it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RxTelegram {
    bytes: [u8; MAX_TELEGRAM_LEN],
    len: usize,
    pub status: Status,
    /// The tick at which its last stop bit ended.
    pub end: Tick,
}

impl RxTelegram {
    pub const fn empty() -> Self {
        RxTelegram {
            bytes: [0; MAX_TELEGRAM_LEN],
            len: 0,
            status: Status::Good,
            end: 0,
        }
    }

    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }

    pub fn is_good(&self) -> bool {
        self.status == Status::Good
    }
}

impl Default for RxTelegram {
    fn default() -> Self {
        Self::empty()
    }
}

/// Where the delimiter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// No telegram under way; the next character starts one if TSYN was met.
    Ready,
    /// A telegram of `expect` bytes (0: SD2 whose length is not known yet).
    Inside { expect: usize },
}

/// The delimiter with its telegram RAM.
#[derive(Clone, Debug)]
pub struct Delimiter {
    /// Idle clocks before a character that make TSYN.
    pub tsyn_clocks: Tick,
    /// Idle clocks inside a telegram that count as a gap.
    pub gap_clocks: Tick,
    phase: Phase,
    /// The telegram being assembled, then delivered.
    rx: RxTelegram,
}

impl Delimiter {
    pub fn new(tsyn_clocks: Tick, gap_clocks: Tick) -> Self {
        Delimiter {
            tsyn_clocks,
            gap_clocks,
            phase: Phase::Ready,
            rx: RxTelegram::empty(),
        }
    }

    /// Whether a telegram is being assembled.
    pub fn inside(&self) -> bool {
        matches!(self.phase, Phase::Inside { .. })
    }

    /// Drop a telegram under way (the rate changed).
    pub fn reset(&mut self) {
        self.phase = Phase::Ready;
    }

    /// The telegram delivered last.
    pub fn telegram(&self) -> &RxTelegram {
        &self.rx
    }

    /// A character arrived after `idle_before` idle clocks. Returns whether a telegram was
    /// delivered (read it with [`telegram`](Self::telegram)), and whether the character was
    /// refused as a telegram start for want of TSYN.
    pub fn on_char(&mut self, c: &RxChar, idle_before: Tick) -> Delivery {
        if let Phase::Inside { .. } = self.phase {
            if idle_before > self.gap_clocks {
                // Cannot happen with on_idle called every clock; kept for callers that skip.
                return self.deliver(Status::Gap, c.end);
            }
            return self.append(c);
        }
        if idle_before < self.tsyn_clocks {
            return Delivery::NotSynced;
        }
        self.rx.len = 0;
        self.phase = Phase::Inside { expect: 0 };
        if let Some(e) = c.error {
            return self.deliver(Status::Char(e), c.end);
        }
        let expect = match c.byte {
            SD1 => 6,
            SD2 => 0,
            SD3 => 6 + SD3_DATA_LEN,
            SD4 => 3,
            SC => 1,
            _ => {
                self.push(c.byte);
                return self.deliver(Status::BadDelimiter, c.end);
            }
        };
        self.phase = Phase::Inside { expect };
        self.append(c)
    }

    fn push(&mut self, byte: u8) {
        self.rx.bytes[self.rx.len] = byte;
        self.rx.len += 1;
    }

    fn append(&mut self, c: &RxChar) -> Delivery {
        let Phase::Inside { mut expect } = self.phase else {
            unreachable!("append outside a telegram");
        };
        if let Some(e) = c.error {
            return self.deliver(Status::Char(e), c.end);
        }
        self.push(c.byte);
        let b = self.rx.bytes();
        if b[0] == SD2 {
            match b.len() {
                2 if !(SD2_MIN_LE..=SD2_MAX_LE).contains(&b[1]) => {
                    return self.deliver(Status::BadLength, c.end)
                }
                3 if b[2] != b[1] => return self.deliver(Status::LengthMismatch, c.end),
                3 => expect = b[1] as usize + 6,
                4 if b[3] != SD2 => return self.deliver(Status::LengthMismatch, c.end),
                _ => {}
            }
            self.phase = Phase::Inside { expect };
        }
        if b.len() < expect || expect == 0 {
            return Delivery::None;
        }
        let status = frame_status(b);
        self.deliver(status, c.end)
    }

    /// The line has been idle for `idle` clocks with no character: a gap inside a telegram ends it.
    #[inline(always)]
    pub fn on_idle(&mut self, idle: Tick, now: Tick) -> Delivery {
        if self.inside() && idle > self.gap_clocks {
            return self.deliver(Status::Gap, now);
        }
        Delivery::None
    }

    fn deliver(&mut self, status: Status, end: Tick) -> Delivery {
        self.rx.status = status;
        self.rx.end = end;
        self.phase = Phase::Ready;
        Delivery::Telegram
    }
}

/// What one strobe of the delimiter produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delivery {
    None,
    /// A telegram (good or not) is ready.
    Telegram,
    /// A character outside a telegram without TSYN before it: ignored.
    NotSynced,
}

/// FCS and end delimiter of a complete SD1/SD2/SD3 telegram (SD4 and SC have neither).
fn frame_status(b: &[u8]) -> Status {
    let (body, tail) = match b[0] {
        SD1 | SD3 => (&b[1..b.len() - 2], &b[b.len() - 2..]),
        SD2 => (&b[4..b.len() - 2], &b[b.len() - 2..]),
        _ => return Status::Good,
    };
    let fcs = body.iter().fold(0u8, |a, &x| a.wrapping_add(x));
    if tail[0] != fcs {
        Status::BadFcs
    } else if tail[1] != ED {
        Status::NoEndDelimiter
    } else {
        Status::Good
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(d: &mut Delimiter, bytes: &[u8], first_idle: Tick) -> Vec<(Vec<u8>, Status)> {
        let mut out = Vec::new();
        for (i, &byte) in bytes.iter().enumerate() {
            let c = RxChar {
                byte,
                error: None,
                start: 0,
                end: i as Tick,
            };
            if d.on_char(&c, if i == 0 { first_idle } else { 0 }) == Delivery::Telegram {
                out.push((d.telegram().bytes().to_vec(), d.telegram().status));
            }
        }
        out
    }

    // shared/PROTOCOL.md vectors.
    const GET_CFG_RESPONSE: [u8; 14] = [
        0x68, 0x08, 0x08, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3B, 0x00, 0x10, 0x10, 0xAA, 0x16,
    ];
    const SD3_DATA: [u8; 14] = [
        0xA2, 0x08, 0x02, 0x4D, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x73, 0x16,
    ];
    const SD1_FDL_STATUS: [u8; 6] = [0x10, 0x08, 0x02, 0x49, 0x53, 0x16];

    #[test]
    fn protocol_vectors_are_delimited_and_good() {
        for v in [
            &GET_CFG_RESPONSE[..],
            &SD3_DATA,
            &SD1_FDL_STATUS,
            &[0xDC, 0x02, 0x01],
            &[0xE5],
        ] {
            let mut d = Delimiter::new(100, 10);
            assert_eq!(feed(&mut d, v, 100), vec![(v.to_vec(), Status::Good)]);
        }
    }

    #[test]
    fn frame_errors_are_named() {
        let mut bad_fcs = GET_CFG_RESPONSE;
        bad_fcs[12] ^= 1;
        let mut bad_ed = SD1_FDL_STATUS;
        bad_ed[5] = 0x17;
        let mut bad_ler = GET_CFG_RESPONSE;
        bad_ler[2] = 0x09;
        let cases: [(&[u8], Status); 5] = [
            (&bad_fcs, Status::BadFcs),
            (&bad_ed, Status::NoEndDelimiter),
            (&bad_ler[..3], Status::LengthMismatch),
            (&[0x68, 0x03], Status::BadLength),
            (&[0x42], Status::BadDelimiter),
        ];
        for (bytes, status) in cases {
            let mut d = Delimiter::new(100, 10);
            let got = feed(&mut d, bytes, 100);
            assert_eq!(got.last().map(|t| t.1), Some(status), "{bytes:02x?}");
        }
    }

    #[test]
    fn no_start_without_tsyn() {
        let mut d = Delimiter::new(100, 10);
        assert!(feed(&mut d, &SD1_FDL_STATUS, 99).is_empty());
    }

    #[test]
    fn idle_inside_a_telegram_is_a_gap() {
        let mut d = Delimiter::new(100, 10);
        feed(&mut d, &SD1_FDL_STATUS[..3], 100);
        assert_eq!(d.on_idle(10, 50), Delivery::None);
        assert_eq!(d.on_idle(11, 51), Delivery::Telegram);
        assert_eq!(d.telegram().status, Status::Gap);
        assert_eq!(d.telegram().end, 51);
    }
}
