//! The Modbus master against a scripted UART (embedded-hal-mock: every byte written and read
//! is checked) and against the drive simulator (crates/drive-sim) over a loopback UART.

use drive_link::{BlockingDrive, Config, ModbusMaster, Op, Outcome};
use drive_sim::{self, with_crc, DriveSim, LinkFault};
use embedded_hal_mock::eh1::serial::{Mock, Transaction};
use profidrive::drive::{DriveError, ImmediateDrive};
use std::collections::VecDeque;

fn would_block() -> Transaction<u8> {
    Transaction::read_error(nb::Error::WouldBlock)
}

#[test]
fn read_frame_and_answer() {
    // Read F0.29 (one holding register at F029h) from drive 1; the drive answers 2500.
    let request = with_crc(vec![0x01, 0x03, 0xF0, 0x29, 0x00, 0x01]);
    let answer = with_crc(vec![0x01, 0x03, 0x02, 0x09, 0xC4]);
    let mut uart = Mock::new(&[
        // The master first discards stale bytes (a late answer): none here.
        would_block(),
        Transaction::write_many(request),
        Transaction::read_many(answer),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), Config::default());
    master.start(Op::Read(0xF029)).unwrap();
    assert_eq!(master.poll(0), Some(Outcome::Value(2500)));
    assert!(!master.busy());
    uart.done();
}

#[test]
fn write_frame_and_echo() {
    let request = with_crc(vec![0x01, 0x06, 0x20, 0x00, 0x00, 0x16]);
    let mut uart = Mock::new(&[
        // The master first discards stale bytes (a late answer): none here.
        would_block(),
        Transaction::write_many(request.clone()),
        would_block(),
        Transaction::read_many(request),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), Config::default());
    master.start(Op::Write(0x2000, 0x16)).unwrap();
    // Nothing yet: the answer has not arrived.
    assert_eq!(master.poll(0), None);
    assert_eq!(master.poll(1000), Some(Outcome::Written));
    uart.done();
}

#[test]
fn exceptions_map_to_seed_000_errors() {
    for (code, error) in [
        (0x01, DriveError::IllegalOperation),
        (0x02, DriveError::IllegalAddress),
        (0x03, DriveError::InvalidData),
        (0x04, DriveError::DriveFault),
    ] {
        let request = with_crc(vec![0x01, 0x03, 0xF0, 0x58, 0x00, 0x01]);
        let answer = with_crc(vec![0x01, 0x83, code]);
        let mut uart = Mock::new(&[
            // The master first discards stale bytes (a late answer): none here.
            would_block(),
            Transaction::write_many(request),
            Transaction::read_many(answer),
        ]);
        let mut master = ModbusMaster::new(uart.clone(), Config::default());
        master.start(Op::Read(0xF058)).unwrap();
        assert_eq!(
            master.poll(0),
            Some(Outcome::Failed(error)),
            "exception {code}"
        );
        uart.done();
    }
}

#[test]
fn a_crc_error_is_retried_and_the_retry_succeeds() {
    let request = with_crc(vec![0x01, 0x03, 0xD0, 0x00, 0x00, 0x01]);
    let mut bad = with_crc(vec![0x01, 0x03, 0x02, 0x00, 0x64]);
    bad[6] ^= 0xFF;
    let good = with_crc(vec![0x01, 0x03, 0x02, 0x00, 0x64]);
    let mut uart = Mock::new(&[
        // The master first discards stale bytes (a late answer): none here.
        would_block(),
        Transaction::write_many(request.clone()),
        Transaction::read_many(bad),
        // The master first discards stale bytes (a late answer): none here.
        would_block(),
        Transaction::write_many(request),
        Transaction::read_many(good),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), Config::default());
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), None, "retrying");
    assert_eq!(master.poll(10), Some(Outcome::Value(100)));
    assert_eq!((master.stats.crc_errors, master.stats.retries), (1, 1));
    uart.done();
}

#[test]
fn uart_noise_makes_a_bad_answer_bus_noise() {
    let request = with_crc(vec![0x01, 0x03, 0xD0, 0x00, 0x00, 0x01]);
    let mut bad = with_crc(vec![0x01, 0x03, 0x02, 0x00, 0x64]);
    bad[3] ^= 0x10;
    let config = Config {
        timeout_us: 1000,
        retries: 0,
    };
    let mut uart = Mock::new(&[
        // The master first discards stale bytes (a late answer): none here.
        would_block(),
        Transaction::write_many(request),
        Transaction::read_error(nb::Error::Other(embedded_hal_nb::serial::ErrorKind::Noise)),
        Transaction::read_many(bad),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), Some(Outcome::Failed(DriveError::BusNoise)));
    uart.done();
}

#[test]
fn no_answer_times_out_after_the_retries() {
    let request = with_crc(vec![0x01, 0x03, 0xD0, 0x00, 0x00, 0x01]);
    let config = Config {
        timeout_us: 1000,
        retries: 2,
    };
    let mut script = Vec::new();
    for _ in 0..3 {
        // Each attempt first discards stale bytes (none), then sends and waits.
        script.push(would_block());
        script.push(Transaction::write_many(request.clone()));
        script.push(would_block());
        script.push(would_block());
    }
    let mut uart = Mock::new(&script);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    let mut now = 0;
    let outcome = loop {
        if let Some(o) = master.poll(now) {
            break o;
        }
        now += 1000;
    };
    assert_eq!(outcome, Outcome::Failed(DriveError::NoAnswer));
    assert_eq!((master.stats.timeouts, master.stats.retries), (3, 2));
    uart.done();
}

#[test]
fn a_retry_has_a_deadline_from_the_moment_it_goes() {
    let request = with_crc(vec![0x01, 0x03, 0xD0, 0x00, 0x00, 0x01]);
    let config = Config {
        timeout_us: 1000,
        retries: 1,
    };
    // Each attempt: stale bytes discarded (none), the request, a read with nothing yet; the
    // first one a read more, at its timeout.
    let mut uart = Mock::new(&[
        would_block(),
        Transaction::write_many(request.clone()),
        would_block(),
        would_block(),
        would_block(),
        Transaction::write_many(request),
        would_block(),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), None);
    assert_eq!(master.deadline(), Some(1000));
    // The first attempt times out at 1500 and goes again: its answer is late at 2500, and a
    // firmware that sleeps until the deadline must be told so.
    assert_eq!(master.poll(1500), None, "retrying");
    assert_eq!(master.deadline(), Some(2500));
    assert_eq!(master.stats.retries, 1);
    uart.done();
}

/// A UART wired to the drive simulator: a complete request frame gets the simulator's
/// answer, readable at once.
struct SimUart {
    drive: DriveSim,
    written: Vec<u8>,
    to_read: VecDeque<u8>,
    noisy_reported: bool,
    /// The function code of each request served.
    functions: Vec<u8>,
    /// Where set, the line's time: an answer is readable this long after its request was
    /// complete (the frames on the line and the drive's processing), else at once.
    line: Option<(std::rc::Rc<std::cell::Cell<u64>>, u64)>,
    answer_at_us: u64,
}

impl embedded_hal_nb::serial::ErrorType for SimUart {
    type Error = embedded_hal_nb::serial::ErrorKind;
}

impl embedded_hal_nb::serial::Write<u8> for SimUart {
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        self.written.push(word);
        if drive_sim::request_len(&self.written) == Some(self.written.len()) {
            let request = std::mem::take(&mut self.written);
            self.functions.push(request[1]);
            if let Some((clock, transaction_us)) = &self.line {
                self.answer_at_us = clock.get() + transaction_us;
            }
            if let Some(answer) = self.drive.modbus(&request) {
                self.to_read.extend(answer);
            }
        }
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        Ok(())
    }
}

impl embedded_hal_nb::serial::Read<u8> for SimUart {
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        // Noise on the line shows at the UART as a noise error beside the garbled bytes.
        if self.drive.link_fault == LinkFault::Noise
            && !self.to_read.is_empty()
            && !self.noisy_reported
        {
            self.noisy_reported = true;
            return Err(nb::Error::Other(embedded_hal_nb::serial::ErrorKind::Noise));
        }
        if let Some((clock, _)) = &self.line {
            if clock.get() < self.answer_at_us {
                return Err(nb::Error::WouldBlock);
            }
        }
        let byte = self.to_read.pop_front().ok_or(nb::Error::WouldBlock);
        if self.to_read.is_empty() {
            self.noisy_reported = false;
        }
        byte
    }
}

#[test]
fn the_drive_simulator_over_modbus() {
    let uart = SimUart {
        drive: DriveSim::default(),
        written: Vec::new(),
        to_read: VecDeque::new(),
        noisy_reported: false,
        functions: Vec::new(),
        line: None,
        answer_at_us: 0,
    };
    let clock = std::cell::Cell::new(0u64);
    let mut drive = BlockingDrive::new(
        ModbusMaster::new(
            uart,
            Config {
                timeout_us: 100,
                retries: 1,
            },
        ),
        || {
            clock.set(clock.get() + 10);
            clock.get()
        },
    );
    let f0_29 = profidrive::codes::FunctionCode(0xF029);
    drive.write(f0_29, 2500, true).unwrap();
    assert_eq!(drive.read(f0_29), Ok(2500));
    drive
        .write_control(profidrive::words::control::RUN_ENABLE)
        .unwrap();
    assert_eq!(
        drive.master.uart_mut().drive.control_word(),
        profidrive::words::control::RUN_ENABLE
    );
    let sw = drive.read_status().unwrap();
    assert_eq!(
        sw & profidrive::words::status::RUN_ENABLED,
        profidrive::words::status::RUN_ENABLED
    );
    // Refusals and link faults come back as seed 000's errors.
    assert_eq!(
        drive.read(profidrive::codes::FunctionCode(0xF058)),
        Err(DriveError::IllegalAddress)
    );
    assert_eq!(
        drive.write(profidrive::codes::FunctionCode(0xD100), 1, true),
        Err(DriveError::IllegalAddress)
    );
    drive.master.uart_mut().drive.link_fault = LinkFault::NoAnswer;
    assert_eq!(drive.read(f0_29), Err(DriveError::NoAnswer));
    drive.master.uart_mut().drive.link_fault = LinkFault::CrcError;
    assert_eq!(drive.read(f0_29), Err(DriveError::CrcError));
    drive.master.uart_mut().drive.link_fault = LinkFault::Noise;
    assert_eq!(drive.read(f0_29), Err(DriveError::BusNoise));
    drive.master.uart_mut().drive.link_fault = LinkFault::None;
    assert_eq!(drive.read(f0_29), Ok(2500));
    let _ = drive_sim::MODBUS_ADDRESS;
}

fn sim_uart() -> SimUart {
    SimUart {
        drive: DriveSim::default(),
        written: Vec::new(),
        to_read: VecDeque::new(),
        noisy_reported: false,
        functions: Vec::new(),
        line: None,
        answer_at_us: 0,
    }
}

mod linked {
    use super::*;
    use dp_slave::{Application, Instant};
    use drive_link::{LinkedDrive, READ_PERIOD_US};
    use profidrive::pkw::{Request, Task};
    use profidrive::ppo::Ppo;
    use profidrive::prm::UserPrm;
    use profidrive::words::{control, status};
    use profidrive::ProfidriveApp;

    const START: u16 = control::RUN_ENABLE | control::START_ENABLE | control::RUN | control::REMOTE;

    type App = ProfidriveApp<LinkedDrive<SimUart>>;

    fn app(ppo: Ppo) -> App {
        let master = ModbusMaster::new(sim_uart(), Config::default());
        let mut app = ProfidriveApp::new(LinkedDrive::new(master));
        assert!(app.accept_user_prm(&UserPrm::DEFAULT.encode()));
        assert!(app.accept_cfg(ppo.cfg()).is_some());
        app
    }

    fn sim(app: &mut App) -> &mut DriveSim {
        &mut app.drive_mut().master_mut().uart_mut().drive
    }

    /// One data exchange with PPO1 outputs (PKW request, CW, PZD2), then `polls` turns of
    /// the link 100 µs apart; returns the inputs of a data exchange after them.
    fn exchange(
        app: &mut App,
        now: &mut u64,
        pkw: [u8; 8],
        cw: u16,
        pzd2: u16,
        polls: u32,
    ) -> Vec<u8> {
        let mut outputs = pkw.to_vec();
        outputs.extend_from_slice(&cw.to_be_bytes());
        outputs.extend_from_slice(&pzd2.to_be_bytes());
        app.outputs(Instant::from_micros(*now), &outputs);
        for _ in 0..polls {
            app.service(Instant::from_micros(*now));
            app.drive_mut().poll(*now);
            sim(app).advance(100);
            *now += 100;
        }
        let mut inputs = vec![0u8; 12];
        app.inputs(Instant::from_micros(*now), &mut inputs);
        inputs
    }

    fn word(bytes: &[u8], at: usize) -> u16 {
        u16::from_be_bytes([bytes[at], bytes[at + 1]])
    }

    #[test]
    fn pzd_goes_through_the_mapped_block_and_pkw_is_answered_later() {
        let mut app = app(Ppo::Ppo1);
        let mut now = 1_000;
        let read_f029 = Request {
            task: Task::Read,
            code: profidrive::codes::FunctionCode(0xF029),
            value: 0,
        }
        .encode();
        // A data exchange only copies: nothing has reached the drive yet.
        exchange(&mut app, &mut now, [0; 8], START, 2500, 0);
        assert_eq!(sim(&mut app).control_word(), 0);
        exchange(&mut app, &mut now, [0; 8], START, 2500, 5);
        assert_eq!(sim(&mut app).control_word(), START);
        assert_eq!(sim(&mut app).read_register(0xF029), Ok(2500));
        let inputs = exchange(&mut app, &mut now, read_f029, START, 2500, 0);
        assert_eq!(
            word(&inputs, 0),
            0,
            "no PKW reply before the drive answered"
        );
        let inputs = exchange(&mut app, &mut now, read_f029, START, 2500, 2);
        // The PKW read was queued and answered on a later service: reply 1, F0.29's value.
        assert_eq!(
            &inputs[..8],
            &[0x10, 0xF0, 0x29, 0x00, 0x00, 0x00, 0x09, 0xC4]
        );
        assert_eq!(word(&inputs, 8) & status::RUNNING, status::RUNNING);
        // 1 s later, the output frequency (RdPZD2 = D0.00) follows the 5 s ramp to 25.00 Hz.
        let inputs = exchange(&mut app, &mut now, read_f029, START, 2500, 10_000);
        assert_eq!(word(&inputs, 10), 1000);
        // The mapping was written once; then the cycles: a read of the in block every
        // READ_PERIOD_US over the second (the outputs written whole again every REWRITE_US
        // with one of them); besides them the fieldbus group's load at link-up and the PKW
        // read left in the outputs, read again every 10 ms over the second it stayed.
        let figures = app.drive().figures;
        assert_eq!(figures.mapping_writes, 2);
        assert!((95..=102).contains(&figures.requests), "{figures:?}");
        assert_eq!(app.drive().fieldbus().figures.loads, 1);
        let paced = 1_000_000 / READ_PERIOD_US;
        let cycles = u64::from(figures.cycles);
        assert!(
            (paced * 95 / 100..=paced * 105 / 100).contains(&cycles),
            "{figures:?}, {paced} paced"
        );
    }

    #[test]
    fn held_outputs_are_only_read_and_rewritten_every_10_ms() {
        let mut app = app(Ppo::Ppo1);
        let mut now = 1_000;
        // 50 ms: the fieldbus group's load at link-up (a read between two cycles) is over.
        exchange(&mut app, &mut now, [0; 8], START, 2500, 500);
        let functions =
            |app: &mut App| std::mem::take(&mut app.drive_mut().master_mut().uart_mut().functions);
        functions(&mut app);
        // 5 ms of unchanged outputs: cycles read the in block (03h), one every
        // READ_PERIOD_US (the line free between them); at most one of them, the rewrite due
        // every REWRITE_US, writes the outputs whole with its read (17h).
        exchange(&mut app, &mut now, [0; 8], START, 2500, 50);
        let served = functions(&mut app);
        let reads = (5_000 / READ_PERIOD_US) as usize;
        let rewrites = served.iter().filter(|f| **f == 0x17).count();
        assert!(
            (reads..=reads + 1).contains(&served.len())
                && rewrites <= 1
                && served.iter().all(|f| *f == 0x03 || *f == 0x17),
            "{served:x?}"
        );
        // A change goes out at once, only the word that changed: a single write (06h).
        exchange(&mut app, &mut now, [0; 8], START, 2600, 1);
        assert_eq!(sim(&mut app).read_register(0xF029), Ok(2600));
        assert_eq!(functions(&mut app), [0x06]);
        // Two words changed: one exchange (17h) writes both and reads the in block.
        exchange(&mut app, &mut now, [0; 8], START & !control::RUN, 2700, 1);
        assert_eq!(sim(&mut app).read_register(0xF029), Ok(2700));
        assert_eq!(functions(&mut app), [0x17]);
        // A value changed at the drive's side is overwritten within 10 ms.
        sim(&mut app).write_register(0xF029, 1234, false).unwrap();
        exchange(&mut app, &mut now, [0; 8], START, 2600, 100);
        assert_eq!(sim(&mut app).read_register(0xF029), Ok(2600));
        let served = functions(&mut app);
        let exchanges = served.iter().filter(|f| **f == 0x17).count();
        assert!((1..=2).contains(&exchanges), "{served:x?}");
    }

    /// Data_Exchanges every `cycle_us` for 20 ms on a line whose transactions take 200 µs,
    /// the link polled every 10 µs in between (as its wake-ups and the drive's answers do);
    /// `beat`: the link is told of each (`data_exchange`, then `read_after_outputs`). Returns
    /// how many found a transaction under way (after the first four), and how many reads of
    /// the in block ran.
    fn exchanges_meeting_a_read(cycle_us: u64, beat: bool) -> (usize, u32) {
        let mut app = app(Ppo::Ppo1);
        let clock = std::rc::Rc::new(std::cell::Cell::new(0u64));
        app.drive_mut().master_mut().uart_mut().line = Some((clock.clone(), 200));
        let mut now = 1_000;
        // The mapping and the fieldbus group's load at link-up first.
        exchange(&mut app, &mut now, [0; 8], START, 2500, 500);
        let cycles_before = app.drive().figures.cycles;
        let mut met = 0;
        for n in 0..20_000 / 10 {
            let at = now + n * 10;
            clock.set(at);
            if n % (cycle_us / 10) == 0 {
                // The first ones teach the link the DP cycle and a read's length.
                let learnt = n / (cycle_us / 10) >= 4;
                met += usize::from(learnt && !app.drive().is_free());
                if beat {
                    app.drive_mut().data_exchange(at);
                    app.drive_mut().read_after_outputs(at);
                }
            }
            app.drive_mut().poll(at);
        }
        (met, app.drive().figures.cycles - cycles_before)
    }

    #[test]
    fn reads_of_the_in_block_keep_clear_of_the_next_outputs() {
        // A 630 µs DP cycle (PPO4 at 1.5 Mbit/s), reads every 500 µs: without the beat, reads
        // run into the outputs of a Data_Exchange now and then.
        let (met, reads) = exchanges_meeting_a_read(630, false);
        assert!(met >= 10 && reads >= 38, "{met} met, {reads} reads");
        // With it, none does once the DP cycle and a read's length are known, and the in
        // block is still read at least once a DP cycle.
        let (met, reads) = exchanges_meeting_a_read(630, true);
        assert!(
            met == 0 && reads >= 20_000 / 630,
            "{met} met, {reads} reads"
        );
        // A DP cycle too short to keep a read clear of (200 µs): reads every 500 µs as before.
        let (_, reads) = exchanges_meeting_a_read(200, true);
        assert!((38..=40).contains(&reads), "{reads} reads");
    }

    #[test]
    fn a_lost_drive_shows_in_pzd1_and_the_link_recovers_with_the_mapping() {
        let mut app = app(Ppo::Ppo1);
        let mut now = 1_000;
        exchange(&mut app, &mut now, [0; 8], START, 2500, 5);
        sim(&mut app).link_fault = LinkFault::Disconnected;
        // Three attempts of 2 ms each.
        let inputs = exchange(&mut app, &mut now, [0; 8], START, 2500, 70);
        assert_eq!(word(&inputs, 8), 0xC022);
        assert_eq!(app.link_error(), Some(DriveError::NoAnswer));
        // The drive comes back, having lost its volatile mapping (a restart).
        *sim(&mut app) = DriveSim::default();
        let inputs = exchange(&mut app, &mut now, [0; 8], START, 2600, 70);
        assert_ne!(word(&inputs, 8) & 0xC000, 0xC000);
        assert_eq!(sim(&mut app).read_register(0xF029), Ok(2600));
        assert_eq!(sim(&mut app).read_register(0x2301), Ok(0xD000));
    }
}

/// A UART to a drive that answers each complete request after a delay the test sets: bytes
/// become readable at their time on a clock the test moves.
struct DelayedUart {
    drive: DriveSim,
    written: Vec<u8>,
    /// (readable from, byte)
    pending: VecDeque<(u64, u8)>,
    now_us: u64,
    /// Delay of the next answer; afterwards `normal_delay_us`.
    next_delay_us: Option<u64>,
    normal_delay_us: u64,
}

impl embedded_hal_nb::serial::ErrorType for DelayedUart {
    type Error = embedded_hal_nb::serial::ErrorKind;
}

impl embedded_hal_nb::serial::Read<u8> for DelayedUart {
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        match self.pending.front() {
            Some(&(at, byte)) if at <= self.now_us => {
                self.pending.pop_front();
                Ok(byte)
            }
            _ => Err(nb::Error::WouldBlock),
        }
    }
}

impl embedded_hal_nb::serial::Write<u8> for DelayedUart {
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        self.written.push(word);
        if drive_sim::request_len(&self.written) == Some(self.written.len()) {
            let request = std::mem::take(&mut self.written);
            if let Some(answer) = self.drive.modbus(&request) {
                let delay = self.next_delay_us.take().unwrap_or(self.normal_delay_us);
                let at = self.now_us + delay;
                // Behind whatever is still on its way (the line is serial).
                let at = self.pending.back().map_or(at, |(t, _)| at.max(*t));
                self.pending.extend(answer.into_iter().map(|b| (at, b)));
            }
        }
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        Ok(())
    }
}

/// The transaction `i` of a run: reads of F0.29 (2500) and writes of F0.13 in turn (their
/// answers differ in length, as a link's transactions do), and what it must give.
fn transaction(i: usize) -> (Op, Outcome) {
    if i.is_multiple_of(2) {
        (Op::Read(0xF029), Outcome::Value(2500))
    } else {
        (Op::Write(0xF013, 50 + i as u16), Outcome::Written)
    }
}

/// Runs `count` transactions one after the other, polling every 100 µs; the answer to
/// transaction `late` comes after `late_us`. Returns each transaction's outcome.
fn reads_with_one_late_answer(count: usize, late: usize, late_us: u64) -> Vec<Option<Outcome>> {
    let mut drive = DriveSim::default();
    drive.write_register(0xF029, 2500, true).unwrap();
    let uart = DelayedUart {
        drive,
        written: Vec::new(),
        pending: VecDeque::new(),
        now_us: 0,
        next_delay_us: None,
        normal_delay_us: 100,
    };
    let mut master = ModbusMaster::new(uart, Config::default());
    let mut now = 0;
    let mut outcomes = Vec::new();
    for i in 0..count {
        if i == late {
            master.uart_mut().next_delay_us = Some(late_us);
        }
        master.start(transaction(i).0).unwrap();
        let mut outcome = None;
        for _ in 0..200 {
            now += 100;
            master.uart_mut().now_us = now;
            if let Some(o) = master.poll(now) {
                outcome = Some(o);
                break;
            }
        }
        outcomes.push(outcome);
    }
    outcomes
}

#[test]
fn answers_in_time_or_just_before_the_timeout_all_arrive() {
    for late_us in [100, 1_900] {
        let outcomes = reads_with_one_late_answer(40, 7, late_us);
        for (i, o) in outcomes.iter().enumerate() {
            assert_eq!(*o, Some(transaction(i).1), "{late_us} us, transaction {i}");
        }
    }
}

/// An answer that arrives after the timeout belongs to a transaction the master gave up on
/// (or retried): it must not be read as the next answer. Issue 16: one answer at 2.5 ms broke
/// every later transaction with a CRC error.
#[test]
fn a_late_answer_costs_at_most_its_own_transaction() {
    let outcomes = reads_with_one_late_answer(40, 7, 2_500);
    for (i, o) in outcomes.iter().enumerate().skip(8) {
        assert_eq!(*o, Some(transaction(i).1), "transaction {i}: {outcomes:?}");
    }
}

/// A read of D0.00 from drive 1, its answer (100), and a master that retries once after 1 ms.
fn read_d000_one_retry() -> (Vec<u8>, Vec<u8>, Config) {
    let request = with_crc(vec![0x01, 0x03, 0xD0, 0x00, 0x00, 0x01]);
    let answer = with_crc(vec![0x01, 0x03, 0x02, 0x00, 0x64]);
    let config = Config {
        timeout_us: 1000,
        retries: 1,
    };
    (request, answer, config)
}

/// Issue 16: an answer whose first bytes arrive before the timeout and the rest after. The
/// master gives up on it at the timeout, discards the rest before it sends again, and reads the
/// retry's answer whole.
#[test]
fn an_answer_split_across_the_timeout_is_discarded_and_the_retry_succeeds() {
    let (request, answer, config) = read_d000_one_retry();
    let mut uart = Mock::new(&[
        would_block(),
        Transaction::write_many(request.clone()),
        // Three bytes in time, then silence until the timeout.
        Transaction::read_many(&answer[..3]),
        would_block(),
        would_block(),
        // The retry: the rest of the late answer is waiting, and is discarded.
        Transaction::read_many(&answer[3..]),
        would_block(),
        Transaction::write_many(request),
        Transaction::read_many(answer),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), None, "three bytes of seven");
    assert_eq!(master.poll(1000), None, "timed out, retrying");
    assert_eq!(master.poll(1100), Some(Outcome::Value(100)));
    assert_eq!(
        (
            master.stats.timeouts,
            master.stats.retries,
            master.stats.stale_bytes
        ),
        (1, 1, 4)
    );
    uart.done();
}

/// A burst of noise on the drive line: bytes and a framing error between transactions are
/// discarded before the next request; inside an answer it garbles that answer only, which is
/// sent for again.
#[test]
fn a_noise_burst_costs_at_most_the_answer_it_hit() {
    let (request, answer, config) = read_d000_one_retry();
    let mut garbled = answer.clone();
    garbled[2] ^= 0x5A;
    garbled[4] ^= 0xA5;
    let frame_error = || {
        Transaction::read_error(nb::Error::Other(
            embedded_hal_nb::serial::ErrorKind::FrameFormat,
        ))
    };
    let mut uart = Mock::new(&[
        // Before the first transaction: a burst, discarded.
        Transaction::read_many(vec![0xFF, 0x00, 0x13, 0xE7, 0x81]),
        frame_error(),
        Transaction::read_many(vec![0x3C, 0x01]),
        would_block(),
        Transaction::write_many(request.clone()),
        Transaction::read_many(answer.clone()),
        // The second transaction: the burst hits its answer.
        would_block(),
        Transaction::write_many(request.clone()),
        frame_error(),
        Transaction::read_many(garbled),
        // Sent for again.
        would_block(),
        Transaction::write_many(request),
        Transaction::read_many(answer),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), Some(Outcome::Value(100)));
    assert_eq!(master.stats.stale_bytes, 7);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(2000), None, "garbled, retrying");
    assert_eq!(master.poll(2100), Some(Outcome::Value(100)));
    assert_eq!(master.stats.retries, 1);
    uart.done();
}

/// An answer from another station (a second drive on the line, or a corrupted address with a
/// CRC that happens to fit) is not this drive's: it is not taken as the value, and the request
/// goes out again.
#[test]
fn an_answer_from_the_wrong_station_is_not_taken() {
    let (request, answer, config) = read_d000_one_retry();
    let foreign = with_crc(vec![0x02, 0x03, 0x02, 0x12, 0x34]);
    let mut uart = Mock::new(&[
        would_block(),
        Transaction::write_many(request.clone()),
        Transaction::read_many(foreign),
        would_block(),
        Transaction::write_many(request),
        Transaction::read_many(answer),
    ]);
    let mut master = ModbusMaster::new(uart.clone(), config);
    master.start(Op::Read(0xD000)).unwrap();
    assert_eq!(master.poll(0), None, "not ours: retrying");
    assert_eq!(master.poll(100), Some(Outcome::Value(100)));
    assert_eq!(master.stats.retries, 1);
    uart.done();
}
