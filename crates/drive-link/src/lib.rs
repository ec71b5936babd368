//! The link from the adapter to the drive: a Modbus RTU master on a UART (seed 000: the card
//! accesses the drive actively, the drive answers; 0x21 bus noise, 0x22 no answer and 0x23
//! CRC error are this link's errors).
//!
//! [`ModbusMaster`] runs one transaction at a time and never blocks: `start` queues a request,
//! `poll(now_us)` moves bytes between it and the UART (embedded-hal-nb's serial traits, so the
//! firmware's interrupt-fed UART and embedded-hal-mock both fit) and finishes the transaction
//! when the answer is complete, refused, garbled or late. Late and garbled answers are retried.
//! Frames are built and checked here (functions 03h read, 06h write, 17h read/write), with
//! the `crc` crate's table-driven CRC-16; rmodbus names the drive's exception codes.
//!
//! [`LinkedDrive`] is the adapter's drive: `profidrive::Drive` over the master without ever
//! waiting. It runs its own PZD cycles (new outputs at once, the in block read at a steady
//! pace), so a Data_Exchange only copies process images; parameter transactions are submitted
//! (`Drive::submit`), run between cycles and answered on a later poll, as are the transactions
//! of the drive's fieldbus group 51 (`profidrive::fieldbus_group`).
//! `BlockingDrive` (feature `testing`) is an immediate drive over the same master, for host
//! tests that may wait for each answer; the product never waits.

#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

#[cfg(any(test, feature = "testing"))]
mod blocking;
mod linked;
#[cfg(any(test, feature = "testing"))]
pub use blocking::BlockingDrive;
pub use linked::{
    LinkFigures, LinkedDrive, KEEPALIVE_US, LED_ACTIVITY_US, READ_PERIOD_US, REWRITE_US,
};

use embedded_hal_nb::serial::{Error as _, ErrorKind as UartError, Read, Write};
use heapless09::Vec;
use profidrive::drive::DriveError;
use rmodbus::ErrorKind;

/// The drive's Modbus address.
pub const DRIVE_ADDRESS: u8 = 1;
/// The drive's control-word and status-word registers.
pub const CONTROL_WORD_REGISTER: u16 = 0x2000;
pub const STATUS_WORD_REGISTER: u16 = 0x2100;

/// The most process data words a PPO carries (the application's figure).
pub use profidrive::ppo::MAX_PZD_WORDS;

/// The drive's process-data registers (the simulator documents them): PZD n (2..=10) out is
/// written to the code held in `PZD_OUT_MAP + n - 1`, PZD n in is read from the code held in
/// `PZD_IN_MAP + n - 1` (0: none). The block at `PZD_OUT_BLOCK` takes PZD 1..=N out (PZD1 is
/// the control word); the block at `PZD_IN_BLOCK` gives PZD 1..=N in (PZD1 is the status word).
pub const PZD_OUT_MAP: u16 = 0x2200;
pub const PZD_IN_MAP: u16 = 0x2300;
pub const PZD_IN_BLOCK: u16 = 0x2400;
pub const PZD_OUT_BLOCK: u16 = 0x2500;

/// Modbus function 17h, read/write multiple registers: one transaction per PZD cycle.
pub const READ_WRITE_MULTIPLE: u8 = 0x17;

/// What a transaction does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Op {
    Read(u16),
    Write(u16, u16),
    /// A PZD cycle: `out[first..first + count]` to the out block (the words that changed,
    /// all of them on a rewrite), then `words` registers of the in block.
    Exchange {
        words: u8,
        first: u8,
        count: u8,
        out: [u16; MAX_PZD_WORDS],
    },
    /// A PZD cycle whose outputs the drive already holds: `words` registers of the in block
    /// (03h, 25 bytes on the line for PPO4 against 42 for the exchange).
    ReadInputs {
        words: u8,
    },
}

/// How a transaction ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    Value(u16),
    Written,
    /// The in block of an exchange (`words` of them valid).
    Values([u16; MAX_PZD_WORDS]),
    Failed(DriveError),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// From the request's last byte sent to the answer's last byte received.
    pub timeout_us: u64,
    /// Further attempts after a late or garbled answer.
    pub retries: u8,
}

impl Config {
    /// The drive answers within 100 µs on its board-to-board link; 2 ms is generous, and
    /// three attempts find a lost drive in about 6 ms.
    pub const DEFAULT: Config = Config {
        timeout_us: 2_000,
        retries: 2,
    };
}

impl Default for Config {
    fn default() -> Self {
        Config::DEFAULT
    }
}

/// The link's UART rate: 2.25 Mbit/s, the fastest exact rate of the production board's
/// USART2 (36 MHz / 16), 8E1 (11 bits per character) as Modbus RTU asks.
pub const LINK_BAUD: u32 = 2_250_000;
pub const BITS_PER_CHARACTER: u32 = 11;

/// Counters for reports and diagnosis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub transactions: u32,
    pub retries: u32,
    pub timeouts: u32,
    pub crc_errors: u32,
    pub garbled: u32,
    /// Bytes of late answers discarded before a transaction.
    pub stale_bytes: u32,
}

impl Stats {
    pub const ZERO: Stats = Stats {
        transactions: 0,
        retries: 0,
        timeouts: 0,
        crc_errors: 0,
        garbled: 0,
        stale_bytes: 0,
    };
}

/// The longest answer: an exchange of 10 words (25 bytes), with room.
const MAX_ANSWER_LEN: usize = 32;

struct Pending {
    op: Op,
    attempt: u8,
    /// When the request went out completely (the timeout runs from then).
    sent_at: Option<u64>,
}

/// The Modbus RTU master.
pub struct ModbusMaster<U> {
    uart: U,
    config: Config,
    pending: Option<Pending>,
    tx: Vec<u8, 40>,
    tx_pos: usize,
    rx: Vec<u8, MAX_ANSWER_LEN>,
    /// The UART reported noise, parity or framing errors during this answer.
    noise: bool,
    pub stats: Stats,
}

/// The longest answer this master asks for: address, function, count, one register, CRC.
const READ_ANSWER_LEN: usize = 7;
const WRITE_ANSWER_LEN: usize = 8;
const EXCEPTION_LEN: usize = 5;

fn drive_error(kind: ErrorKind) -> DriveError {
    match kind {
        ErrorKind::FrameCRCError => DriveError::CrcError,
        ErrorKind::IllegalFunction => DriveError::IllegalOperation,
        ErrorKind::IllegalDataAddress => DriveError::IllegalAddress,
        ErrorKind::IllegalDataValue => DriveError::InvalidData,
        ErrorKind::SlaveDeviceFailure => DriveError::DriveFault,
        ErrorKind::MemoryParityError => DriveError::MemoryFault,
        _ => DriveError::BusNoise,
    }
}

impl<U: Read<u8> + Write<u8>> ModbusMaster<U> {
    // Always inlined: the firmware builds the adapter once, at boot, and inlined the
    // constructors write it in place instead of into temporaries copied up a level (the boot
    // frame is 0.45 KiB smaller, on the production board's 20 KiB).
    #[inline(always)]
    pub const fn new(uart: U, config: Config) -> ModbusMaster<U> {
        ModbusMaster {
            uart,
            config,
            pending: None,
            tx: Vec::new(),
            tx_pos: 0,
            rx: Vec::new(),
            noise: false,
            stats: Stats::ZERO,
        }
    }

    pub fn uart(&self) -> &U {
        &self.uart
    }

    pub fn uart_mut(&mut self) -> &mut U {
        &mut self.uart
    }

    pub fn busy(&self) -> bool {
        self.pending.is_some()
    }

    /// When the answer to the request on the line is late, if one is awaited.
    pub fn deadline(&self) -> Option<u64> {
        let sent_at = self.pending.as_ref()?.sent_at?;
        Some(sent_at + self.config.timeout_us)
    }

    /// Queues a transaction; refused while one is under way.
    pub fn start(&mut self, op: Op) -> Result<(), Op> {
        if self.pending.is_some() {
            return Err(op);
        }
        self.stats.transactions += 1;
        match op {
            Op::Read(register) => short_request(READ_HOLDING, register, 1, &mut self.tx),
            Op::Write(register, value) => {
                short_request(WRITE_SINGLE, register, value, &mut self.tx)
            }
            Op::Exchange {
                words,
                first,
                count,
                out,
            } => {
                let (first, count) = (usize::from(first), usize::from(count));
                exchange_request(words, first, &out[first..first + count], &mut self.tx);
            }
            Op::ReadInputs { words } => {
                short_request(READ_HOLDING, PZD_IN_BLOCK, u16::from(words), &mut self.tx)
            }
        }
        self.pending = Some(Pending {
            op,
            attempt: 0,
            sent_at: None,
        });
        self.tx_pos = 0;
        self.discard_stale();
        Ok(())
    }

    /// Forgets what was received so far, and the bytes already waiting in the UART: they
    /// belong to an answer that came after its transaction timed out, and read as the start of
    /// the next answer they would shift every answer after it.
    fn discard_stale(&mut self) {
        self.rx.clear();
        self.noise = false;
        // Bounded: a UART that reports an error on every read must not keep us here.
        for _ in 0..2 * MAX_ANSWER_LEN {
            match self.uart.read() {
                Ok(_) => self.stats.stale_bytes += 1,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => {}
            }
        }
    }

    /// Moves bytes only: the request into the UART, the answer out of it (without judging
    /// it). Returns whether the whole request is out. A caller that must keep each piece of
    /// work short pumps in one step and polls in the next.
    pub fn pump(&mut self) -> bool {
        if self.pending.is_none() {
            return false;
        }
        while self.tx_pos < self.tx.len() {
            match self.uart.write(self.tx[self.tx_pos]) {
                Ok(()) => self.tx_pos += 1,
                Err(_) => return false,
            }
        }
        // The answer's length is known from its function code on: judged once a byte then,
        // not again for every byte read (the drive link's longest step read them).
        let mut expected = self.expected_len();
        while self.rx.len() < self.rx.capacity() && self.rx.len() < expected {
            match self.uart.read() {
                Ok(byte) => {
                    let _ = self.rx.push(byte);
                    if self.rx.len() == 2 {
                        expected = self.expected_len();
                    }
                }
                Err(nb::Error::WouldBlock) => break,
                // Seed 000's 0x21, "bus noise": the UART saw the line disturbed.
                Err(nb::Error::Other(e)) => {
                    if matches!(
                        e.kind(),
                        UartError::Noise | UartError::Parity | UartError::FrameFormat
                    ) {
                        self.noise = true;
                    }
                }
            }
        }
        true
    }

    /// Moves bytes and finishes the transaction when it can; `now_us` runs the timeout.
    pub fn poll(&mut self, now_us: u64) -> Option<Outcome> {
        if !self.pump() {
            return None;
        }
        let pending = self.pending.as_mut()?;
        let sent_at = *pending.sent_at.get_or_insert(now_us);
        let result = if self.answer_complete() {
            let checked = self.check_answer();
            Some(match checked {
                Err(DriveError::CrcError) if self.noise => Err(DriveError::BusNoise),
                other => other,
            })
        } else if now_us.saturating_sub(sent_at) >= self.config.timeout_us {
            self.stats.timeouts += 1;
            Some(Err(DriveError::NoAnswer))
        } else {
            None
        }?;
        match result {
            Err(e) if e.is_link_fault() && self.retry() => {
                // The request goes again now, and its timeout runs from now: a caller that
                // sleeps until `deadline` must have one (with none, a drive that stopped
                // answering was never found out while no fieldbus event woke the firmware:
                // the soak's seed 7, event 113).
                if self.pump() {
                    if let Some(pending) = self.pending.as_mut() {
                        pending.sent_at = Some(now_us);
                    }
                }
                None
            }
            Err(e) => {
                self.pending = None;
                Some(Outcome::Failed(e))
            }
            Ok(outcome) => {
                self.pending = None;
                Some(outcome)
            }
        }
    }

    fn answer_complete(&self) -> bool {
        self.rx.len() >= self.expected_len()
    }

    /// The length of the answer to the transaction under way, from the function code received
    /// (an exception is shorter); none is complete without a transaction.
    fn expected_len(&self) -> usize {
        let Some(pending) = &self.pending else {
            return usize::MAX;
        };
        match (self.rx.get(1), pending.op) {
            (Some(function), _) if function & 0x80 != 0 => EXCEPTION_LEN,
            (_, Op::Read(_)) => READ_ANSWER_LEN,
            (_, Op::Write(..)) => WRITE_ANSWER_LEN,
            (_, Op::Exchange { words, .. } | Op::ReadInputs { words }) => {
                5 + 2 * usize::from(words)
            }
        }
    }

    fn check_answer(&mut self) -> Result<Outcome, DriveError> {
        let pending = self.pending.as_ref().expect("a transaction is under way");
        let counted = |stats: &mut Stats, e: DriveError| {
            match e {
                DriveError::CrcError => stats.crc_errors += 1,
                DriveError::BusNoise => stats.garbled += 1,
                _ => {}
            }
            e
        };
        let outcome = match pending.op {
            Op::Read(_) => {
                registers_answer(&self.rx, READ_HOLDING, 1).map(|values| Outcome::Value(values[0]))
            }
            // The echo must carry the register and the value written.
            Op::Write(register, value) => checked_body(&self.rx, WRITE_SINGLE).and_then(|body| {
                let [r0, r1] = register.to_be_bytes();
                let [v0, v1] = value.to_be_bytes();
                match body.get(2..) == Some(&[r0, r1, v0, v1][..]) {
                    true => Ok(Outcome::Written),
                    false => Err(DriveError::BusNoise),
                }
            }),
            Op::Exchange { words, .. } => {
                registers_answer(&self.rx, READ_WRITE_MULTIPLE, usize::from(words))
                    .map(Outcome::Values)
            }
            Op::ReadInputs { words } => {
                registers_answer(&self.rx, READ_HOLDING, usize::from(words)).map(Outcome::Values)
            }
        };
        outcome.map_err(|e| counted(&mut self.stats, e))
    }

    /// Sends the request again if attempts are left.
    fn retry(&mut self) -> bool {
        let Some(pending) = self.pending.as_mut() else {
            return false;
        };
        if pending.attempt >= self.config.retries {
            return false;
        }
        pending.attempt += 1;
        pending.sent_at = None;
        self.stats.retries += 1;
        self.tx_pos = 0;
        self.discard_stale();
        true
    }
}

// Framed here rather than by rmodbus (0.13): it has no 17h, and its CRC, bit by bit, and its
// parser took 1,400 of the MCU's instructions for each answer of the PZD cycle, where the
// `crc` crate's table and the checks below take a fifth of that.
const MODBUS_CRC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_MODBUS);

/// Modbus functions 03h, read holding registers, and 06h, write a single register.
const READ_HOLDING: u8 = 0x03;
const WRITE_SINGLE: u8 = 0x06;

/// The request of a read (`register`, `value` registers) or a write (`register`, `value`):
/// both are the address, the function, two words and the CRC.
fn short_request(function: u8, register: u16, value: u16, tx: &mut Vec<u8, 40>) {
    tx.clear();
    let _ = tx.extend_from_slice(&[DRIVE_ADDRESS, function]);
    let _ = tx.extend_from_slice(&register.to_be_bytes());
    let _ = tx.extend_from_slice(&value.to_be_bytes());
    let crc = MODBUS_CRC.checksum(tx);
    let _ = tx.extend_from_slice(&crc.to_le_bytes());
}

/// The answer's body (without its CRC) when the CRC holds and it is the drive's answer to
/// `function`; the drive's exception as its error.
fn checked_body(rx: &[u8], function: u8) -> Result<&[u8], DriveError> {
    let (body, crc) = rx.split_at(rx.len().saturating_sub(2));
    if body.len() < 3 || MODBUS_CRC.checksum(body).to_le_bytes() != crc {
        return Err(DriveError::CrcError);
    }
    if body[0] != DRIVE_ADDRESS {
        return Err(DriveError::BusNoise);
    }
    if body[1] == function | 0x80 {
        return Err(drive_error(ErrorKind::from_modbus_error(body[2])));
    }
    if body[1] != function {
        return Err(DriveError::BusNoise);
    }
    Ok(body)
}

/// The `words` registers an answer to `function` (03h, 17h) carries.
fn registers_answer(
    rx: &[u8],
    function: u8,
    words: usize,
) -> Result<[u16; MAX_PZD_WORDS], DriveError> {
    let body = checked_body(rx, function)?;
    if usize::from(body[2]) != 2 * words || body.len() != 3 + 2 * words {
        return Err(DriveError::BusNoise);
    }
    let mut values = [0u16; MAX_PZD_WORDS];
    for (value, bytes) in values.iter_mut().zip(body[3..].chunks_exact(2)) {
        *value = u16::from_be_bytes([bytes[0], bytes[1]]);
    }
    Ok(values)
}

/// The request of an exchange: write `out` to the out block from its word `first`, read
/// `words` from the in block.
fn exchange_request(words: u8, first: usize, out: &[u16], tx: &mut Vec<u8, 40>) {
    let count = out.len() as u16;
    tx.clear();
    let _ = tx.extend_from_slice(&[DRIVE_ADDRESS, READ_WRITE_MULTIPLE]);
    let write_at = PZD_OUT_BLOCK + first as u16;
    for field in [PZD_IN_BLOCK, u16::from(words), write_at, count] {
        let _ = tx.extend_from_slice(&field.to_be_bytes());
    }
    let _ = tx.push(2 * count as u8);
    for value in out {
        let _ = tx.extend_from_slice(&value.to_be_bytes());
    }
    let crc = MODBUS_CRC.checksum(tx);
    let _ = tx.extend_from_slice(&crc.to_le_bytes());
}
