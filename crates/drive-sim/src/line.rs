//! The drive link on simulated time: the UART line between the adapter's drive UART and the
//! drive simulator's Modbus slave.
//!
//! Contract: bytes the firmware wrote (as a reply's status counts them) go on the line at the
//! reply's time, or when the line is free again after the last frame and the 3.5-character
//! silence Modbus RTU asks for. A complete request reaches the drive at its last bit; the
//! drive answers [`PROCESSING_US`] later, and the answer reaches the firmware at its own
//! last bit: the caller then writes it to the firmware's drive UART and tells the firmware at
//! that time. Every duration is 11 bits per character at `drive_link::LINK_BAUD`.

use crate::{request_len, DriveSim};
use std::collections::VecDeque;

/// From a request's last bit to the drive's answer starting.
pub const PROCESSING_US: u64 = 10;

/// How long `chars` characters take on the drive link, rounded up to a microsecond.
pub fn chars_us(chars_x2: u64) -> u64 {
    let bits_x2 = chars_x2 * u64::from(drive_link::BITS_PER_CHARACTER);
    (bits_x2 * 1_000_000).div_ceil(2 * u64::from(drive_link::LINK_BAUD))
}

/// A frame of `len` bytes on the line.
pub fn frame_us(len: usize) -> u64 {
    chars_us(2 * len as u64)
}

/// The silence between frames: 3.5 characters.
pub fn gap_us() -> u64 {
    chars_us(7)
}

/// The registers of a block, big-endian as on the line.
fn block_words(bytes: &[u8]) -> Vec<u16> {
    bytes
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect()
}

/// An out block the drive applied: when, and the words (control word first).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Applied {
    pub at_us: u64,
    pub words: Vec<u16>,
    /// The request that carried it: its last byte handed to the adapter's UART, its first
    /// and last bits on the line, and the end of the answer before it (the line's last
    /// transaction), for the latency's breakdown.
    pub request: RequestTimes,
}

/// A request's way onto the line, in µs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RequestTimes {
    pub handed_us: u64,
    pub start_us: u64,
    pub end_us: u64,
    pub previous_answer_us: u64,
}

#[derive(Debug, Default)]
pub struct DriveLine {
    pub drive: DriveSim,
    request: Vec<u8>,
    line_free_us: u64,
    /// When the last answer was complete at the adapter.
    last_answer_us: u64,
    /// The out block as the requests on the line have written it (PZD1 first).
    out_block: Vec<u16>,
    deliveries: VecDeque<(u64, Vec<u8>)>,
    /// Bytes taken from the firmware and given to it.
    pub received: u32,
    pub delivered: u32,
    pub requests: u64,
    pub answers: u64,
    /// Each out block the drive applied whose words differ from the one before.
    pub applied: Vec<Applied>,
    /// Each in block the drive answered whose words differ from the one before, at the time
    /// the answer was complete at the adapter.
    pub answered: Vec<Applied>,
    /// The next answer comes this much later than the drive would send it (a scenario's
    /// late answer: one that arrives after the adapter's timeout).
    pub late_once_us: Option<u64>,
}

impl DriveLine {
    /// Lets the drive's time run up to `t_us`.
    pub fn advance_to(&mut self, t_us: u64) {
        let now = self.drive.now_us();
        if t_us > now {
            self.drive.advance(t_us - now);
        }
    }

    /// Bytes the firmware wrote, handed over at `t_us`.
    pub fn from_firmware(&mut self, t_us: u64, bytes: &[u8]) {
        self.received += bytes.len() as u32;
        for byte in bytes {
            self.request.push(*byte);
            if request_len(&self.request) == Some(self.request.len()) {
                let request = std::mem::take(&mut self.request);
                self.serve(t_us, &request);
            }
        }
    }

    fn serve(&mut self, t_us: u64, request: &[u8]) {
        self.requests += 1;
        let start = t_us.max(self.line_free_us);
        let end = start + frame_us(request.len());
        let times = RequestTimes {
            handed_us: t_us,
            start_us: start,
            end_us: end,
            previous_answer_us: self.last_answer_us,
        };
        self.line_free_us = end + gap_us();
        let at = end + PROCESSING_US;
        self.advance_to(at);
        let answer = self.drive.modbus(request);
        if self.note_out_block(request) {
            let words = self.out_block.clone();
            if self.applied.last().map(|a| &a.words) != Some(&words) {
                self.applied.push(Applied {
                    at_us: at,
                    words,
                    request: times,
                });
            }
        }
        if let Some(answer) = answer {
            self.answers += 1;
            let done = at + frame_us(answer.len()) + self.late_once_us.take().unwrap_or(0);
            // The in block comes with an exchange (17h) or a cycle that only reads (03h there).
            let reads_in_block = request.get(1) == Some(&drive_link::READ_WRITE_MULTIPLE)
                || (request.get(1) == Some(&0x03)
                    && request.get(2..4) == Some(&drive_link::PZD_IN_BLOCK.to_be_bytes()[..]));
            if reads_in_block && answer.get(1) == request.get(1) && answer.len() >= 5 {
                let words = block_words(&answer[3..answer.len() - 2]);
                if self.answered.last().map(|a| &a.words) != Some(&words) {
                    self.answered.push(Applied {
                        at_us: done,
                        words,
                        request: times,
                    });
                }
            }
            self.last_answer_us = done;
            self.line_free_us = done + gap_us();
            self.deliveries.push_back((done, answer));
        }
    }

    /// Takes the words `request` writes into the out block (a write of one register, 06h,
    /// or an exchange's writes, 17h) into the drive's out block as the line has carried it;
    /// returns whether there were any.
    fn note_out_block(&mut self, request: &[u8]) -> bool {
        let word = |at: usize| {
            request
                .get(at..at + 2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
        };
        let (first, values) = match (request.get(1).copied(), word(2), word(6)) {
            (Some(crate::WRITE_SINGLE), Some(register), _) if request.len() == 8 => {
                (register, vec![word(4).unwrap_or(0)])
            }
            (Some(drive_link::READ_WRITE_MULTIPLE), _, Some(register)) if request.len() >= 13 => {
                (register, block_words(&request[11..request.len() - 2]))
            }
            _ => return false,
        };
        let Some(at) = first.checked_sub(drive_link::PZD_OUT_BLOCK) else {
            return false;
        };
        let at = usize::from(at);
        if at >= drive_link::MAX_PZD_WORDS {
            return false;
        }
        let end = at + values.len();
        if self.out_block.len() < end {
            self.out_block.resize(end, 0);
        }
        self.out_block[at..end].copy_from_slice(&values);
        true
    }

    /// When the next answer is complete at the firmware.
    pub fn next_delivery_us(&self) -> Option<u64> {
        self.deliveries.front().map(|(at, _)| *at)
    }

    /// The next answer, if it is complete at `now_us`.
    pub fn take_delivery(&mut self, now_us: u64) -> Option<(u64, Vec<u8>)> {
        if self.next_delivery_us()? > now_us {
            return None;
        }
        let (at, bytes) = self.deliveries.pop_front()?;
        self.delivered += bytes.len() as u32;
        Some((at, bytes))
    }

    /// A power cycle of the adapter: its UART starts empty, the line is idle.
    pub fn adapter_restarted(&mut self) {
        self.request.clear();
        self.deliveries.clear();
        self.received = 0;
        self.delivered = 0;
    }
}
