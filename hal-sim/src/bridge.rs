//! The transceiver's side of the MCU link, on board time: one home for the DP responder, the
//! link's cost both ways, the MCU's queue, the wake-up timer, the board's storage, and the
//! drive line behind the MCU. The co-simulation and the serial-port adapter of `qemu-run` both
//! run the adapter through it.
//!
//! ```text
//!  telegram ─► responder ─► answer (to the transmitter, after min TSDR)
//!                 │ hand-over, watchdog, wake-up
//!                 ▼
//!  link to MCU: encoded bytes x byte time, one after another (an unsent outputs event is
//!               replaced by a newer one: the newest outputs are all the MCU needs)
//!                 ▼
//!  MCU: interrupt entry, then the firmware handles events one at a time (its counted
//!       instructions at the board's clock); drive answers interrupt it too. The drive
//!       application's cycle runs a step at a time when no event waits (`Continue`), so an
//!       event waits for one step, not a whole cycle. One `Continue` grants the firmware the
//!       steps that start before anything can reach the MCU (conservative lookahead): it runs
//!       them back to back and reports them in one `Done`, one host round trip for them all
//!                 ▼
//!  link from MCU: each write leaves when the firmware sent it, takes its bytes x byte time,
//!                 and lands in the responder's buffers (or the LEDs, storage, timer)
//! ```
//! Every figure comes from [`board::PRODUCTION`]. Time is in nanoseconds of the bus clock;
//! events carry the transceiver's time in microseconds.

use crate::firmware::{Firmware, Handled, Write};
use board::Board;
use dp_link::sim::{Grant, SimToAdapter};
use dp_link::{NvContents, NvWrite, Status, ToAdapter, MAX_FRAME_LEN};
use dp_phy::responder::{Input, Responder};
use dp_phy::Tick;
use drive_sim::line::DriveLine;
use drive_sim::DriveSim;
use std::collections::VecDeque;
use std::io;

/// An event for the MCU, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Event {
    Boot { seq: u32, switch: u8 },
    Telegram { seq: u32, baud: u8, bytes: Vec<u8> },
    Watchdog { seq: u32 },
    Timer { seq: u32 },
}

/// An event on its way to the MCU.
#[derive(Clone, Debug)]
struct InFlight {
    event: Event,
    /// When it happened (the event's time stamp).
    at_ns: u64,
    /// When its first byte left, and when its last arrived.
    start_ns: u64,
    arrived_ns: u64,
    outputs_only: bool,
}

/// Figures of the link and the MCU.
#[derive(Clone, Debug, Default)]
pub struct LinkFigures {
    pub events: u64,
    pub writes: u64,
    /// Outputs events replaced by newer ones before they were sent.
    pub outputs_replaced: u64,
    /// For each new Data_Exchange the MCU handled: from its outputs' arrival at the MCU to
    /// the last write of the firmware's decision in the transceiver, in ns.
    pub outputs_to_inputs_ns: Vec<u64>,
    /// Each new Data_Exchange's outputs on their way through the MCU, for the latency
    /// breakdown.
    pub outputs_events: Vec<OutputsEvent>,
    /// The longest time an event waited for the MCU (queue and link).
    pub worst_event_latency_ns: u64,
    /// New Data_Exchanges handed over, DP watchdog expiries, and Set_Prm received.
    pub data_exchanges: u64,
    pub watchdog_expiries: u64,
    pub set_prms: u64,
    /// Messages the firmware handled (each one host round trip under QEMU), and the steps of
    /// the drive application's cycle it ran: more than one a `Continue` under a grant.
    pub round_trips: u64,
    pub continues: u64,
    pub cycle_steps: u64,
}

/// A new Data_Exchange's outputs from the bus into the firmware, in ns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputsEvent {
    /// The request telegram's end on the bus.
    pub telegram_end_ns: u64,
    /// Its event through the link and the MCU's interrupt entry.
    pub at_mcu_ns: u64,
    /// The MCU starts on it, after the step it was running.
    pub handled_ns: u64,
    /// The firmware's decision is written (the outputs are in its process image).
    pub decided_ns: u64,
}

impl LinkFigures {
    pub fn worst_outputs_to_inputs_ns(&self) -> Option<u64> {
        self.outputs_to_inputs_ns.iter().copied().max()
    }
}

/// The transceiver's MCU side.
pub struct Bridge<F: Firmware> {
    pub firmware: F,
    pub responder: Responder,
    pub board: Board,
    /// The board's address switch.
    pub switch: u8,
    /// The adapter's last status.
    pub status: Status,
    /// The drive link and the drive behind the adapter.
    pub drive: DriveLine,
    pub figures: LinkFigures,
    /// What happened, in order: state and LED changes, storage writes.
    pub events: Vec<String>,
    clock_hz: u32,
    to_mcu: VecDeque<InFlight>,
    to_mcu_free_ns: u64,
    from_mcu: VecDeque<(u64, Write)>,
    from_mcu_free_ns: u64,
    mcu_free_ns: u64,
    /// Steps of the drive application's cycle remain: the MCU runs the next when it is free
    /// and no event waits.
    cycle_pending: bool,
    /// The wake-up time a Timer event was sent for.
    timer_sent_for: Option<u64>,
    /// When the last status landed: a wake-up it asks for at an earlier time is due then
    /// (the transceiver cannot send an event before it knows of it).
    status_landed_ns: u64,
    /// Wall-clock mode (`qemu-run` on a port): the firmware in QEMU cannot run ahead of the
    /// wall clock, so the MCU starts nothing before the time of the poll that runs it.
    pub realtime: bool,
    /// The time of the current poll, in wall-clock mode.
    floor_ns: u64,
    /// The bus's time at the current poll: a telegram not yet handed over ends no earlier.
    poll_ns: u64,
    /// The last step of a grant that ran more than one: it starts when the MCU is next free
    /// (after the earlier steps), and is placed in time then, as if it ran then.
    granted_last_step: Option<Handled>,
    /// The shortest timer or watchdog event on the link, and the shortest telegram event.
    min_event_len: usize,
    min_telegram_event_len: usize,
}

impl<F: Firmware> Bridge<F> {
    /// The board around `firmware`, not yet powered (see [`Bridge::boot`]).
    pub fn new(firmware: F, clock_hz: u32, switch: u8) -> Bridge<F> {
        Bridge {
            firmware,
            responder: Responder::new(clock_hz),
            board: board::PRODUCTION,
            switch,
            status: Status::POWER_ON,
            drive: DriveLine::default(),
            figures: LinkFigures::default(),
            events: Vec::new(),
            clock_hz,
            to_mcu: VecDeque::new(),
            to_mcu_free_ns: 0,
            from_mcu: VecDeque::new(),
            from_mcu_free_ns: 0,
            mcu_free_ns: 0,
            cycle_pending: false,
            timer_sent_for: None,
            status_landed_ns: 0,
            realtime: false,
            floor_ns: 0,
            poll_ns: 0,
            granted_last_step: None,
            min_event_len: encoded_len(&Event::Timer { seq: 0 }, 0),
            min_telegram_event_len: encoded_len(
                &Event::Telegram {
                    seq: 0,
                    baud: 0,
                    bytes: vec![0; SHORTEST_REQUEST_LEN],
                },
                0,
            ),
        }
    }

    fn ticks(&self, ns: u64) -> Tick {
        ns * u64::from(self.clock_hz / 1_000_000) / 1000
    }

    /// Power-up at `now_ns`: the transceiver tells the MCU the switch and the storage.
    pub fn boot(&mut self, now_ns: u64) {
        let stored = self.stored().ok().and_then(|c| c.address);
        self.events.push(format!(
            "power-up: switch {:02}, storage {:?}",
            self.switch, stored
        ));
        let seq = self.responder.next_event();
        self.send(
            now_ns,
            Event::Boot {
                seq,
                switch: self.switch,
            },
            false,
        );
    }

    /// What the MCU's storage holds now.
    pub fn stored(&mut self) -> io::Result<NvContents> {
        Ok(crate::firmware::nv_contents(&self.firmware.storage()?))
    }

    /// A power cycle at `now_ns`: the MCU and the transceiver restart, the drive stays.
    pub fn power_cycle(&mut self, now_ns: u64) -> io::Result<()> {
        self.events.push("power cycle".into());
        self.firmware.restart()?;
        self.responder = Responder::new(self.clock_hz);
        self.to_mcu.clear();
        self.from_mcu.clear();
        self.to_mcu_free_ns = now_ns;
        self.from_mcu_free_ns = now_ns;
        self.mcu_free_ns = now_ns;
        self.cycle_pending = false;
        self.granted_last_step = None;
        self.timer_sent_for = None;
        self.drive.adapter_restarted();
        self.boot(now_ns);
        Ok(())
    }

    /// A good telegram whose last stop bit ended at `end_ns`, at rate index `baud`: the
    /// responder's answer, if any (to be sent after min TSDR), and its hand-over to the MCU.
    pub fn telegram(&mut self, end_ns: u64, baud: u8, bytes: &[u8]) -> Option<Vec<u8>> {
        let now = self.ticks(end_ns);
        let out = self.responder.step(&Input::Telegram { now, bytes });
        if let Some(seq) = out.forward {
            // New outputs are most of what is handed over: only the rest is looked into.
            if out.outputs_only {
                self.figures.data_exchanges += 1;
            } else if matches!(
                fdl::Repr::parse_bytes(bytes),
                Ok((fdl::Repr::Data(d), _)) if d.dsap == Some(fdl::Sap::SET_PRM)
            ) {
                self.figures.set_prms += 1;
            }
            let event = Event::Telegram {
                seq,
                baud,
                bytes: bytes.to_vec(),
            };
            self.send(end_ns, event, out.outputs_only);
        }
        out.response().map(<[u8]>::to_vec)
    }

    /// Sends `event` to the MCU; `outputs_only`: a newer one may replace it while unsent.
    fn send(&mut self, at_ns: u64, event: Event, outputs_only: bool) {
        self.figures.events += 1;
        let len = encoded_len(&event, at_ns);
        let transfer_ns = self.event_transfer_ns(len);
        if outputs_only {
            if let Some(last) = self.to_mcu.back_mut() {
                if last.outputs_only && last.start_ns > at_ns {
                    // Not on the wire yet: the newer outputs take its place.
                    last.event = event;
                    last.at_ns = at_ns;
                    last.arrived_ns = last.start_ns + transfer_ns;
                    self.to_mcu_free_ns = last.arrived_ns;
                    self.figures.outputs_replaced += 1;
                    return;
                }
            }
        }
        let start_ns = at_ns.max(self.to_mcu_free_ns);
        let arrived_ns = start_ns + transfer_ns;
        self.to_mcu_free_ns = arrived_ns;
        self.to_mcu.push_back(InFlight {
            event,
            at_ns,
            start_ns,
            arrived_ns,
            outputs_only,
        });
    }

    /// An event of `len` bytes on the link to the MCU, up to its interrupt: the frame and the
    /// idle line after it.
    fn event_transfer_ns(&self, len: usize) -> u64 {
        let link = self.board.link;
        link.transfer_ns(len + link.idle_bytes_after_frame as usize)
    }

    /// When something happens next, if anything is due.
    pub fn next_ns(&self) -> Option<u64> {
        let entry = self.board.irq_entry_ns();
        [
            self.from_mcu.front().map(|(at, _)| *at),
            self.responder
                .deadline()
                .map(|t| (t * 1000).div_ceil(u64::from(self.clock_hz / 1_000_000))),
            self.timer_due(),
            self.to_mcu
                .front()
                .map(|e| (e.arrived_ns + entry).max(self.mcu_free_ns)),
            self.drive
                .next_delivery_us()
                .map(|us| (us * 1000).max(self.mcu_free_ns)),
            self.cycle_pending.then_some(self.mcu_free_ns),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    fn timer_due(&self) -> Option<u64> {
        let at = self.status.wake_at_us?;
        (self.timer_sent_for != Some(at)).then_some((at * 1000).max(self.status_landed_ns))
    }

    /// Everything due at `now_ns`, in time order.
    pub fn poll(&mut self, now_ns: u64) -> io::Result<()> {
        while self.poll_one(now_ns)? {}
        Ok(())
    }

    /// Runs the one action due first at `now_ns`, if any; returns whether there was one. A
    /// caller that also serves a port can answer it between two actions (a QEMU round trip
    /// each) instead of after all of them.
    pub fn poll_one(&mut self, now_ns: u64) -> io::Result<bool> {
        if self.realtime {
            self.floor_ns = self.floor_ns.max(now_ns);
        }
        self.poll_ns = now_ns;
        match self.next_ns().filter(|t| *t <= now_ns) {
            Some(t) => self.step_at(t).map(|()| true),
            None => Ok(false),
        }
    }

    /// The action due at `t`.
    fn step_at(&mut self, t: u64) -> io::Result<()> {
        if self.from_mcu.front().is_some_and(|(at, _)| *at <= t) {
            let (at, write) = self.from_mcu.pop_front().expect("checked");
            return self.apply(at, &write);
        }
        let now = self.ticks(t);
        if self.responder.deadline().is_some_and(|d| d <= now) {
            let out = self.responder.step(&Input::Clock { now });
            if let Some(seq) = out.watchdog_expired {
                self.figures.watchdog_expiries += 1;
                self.send(t, Event::Watchdog { seq }, false);
            }
            return Ok(());
        }
        if self.timer_due().is_some_and(|at| at <= t) {
            self.timer_sent_for = self.status.wake_at_us;
            let seq = self.responder.next_event();
            self.send(t, Event::Timer { seq }, false);
            return Ok(());
        }
        let entry = self.board.irq_entry_ns();
        let link_ready = self
            .to_mcu
            .front()
            .map(|e| (e.arrived_ns + entry).max(self.mcu_free_ns));
        let drive_ready = self
            .drive
            .next_delivery_us()
            .map(|us| (us * 1000).max(self.mcu_free_ns));
        let preempts = link_ready.into_iter().chain(drive_ready).any(|r| r <= t);
        if preempts && self.granted_last_step.is_some() {
            // The grant let the firmware run a step that an event now ready would have held
            // back: the lookahead below is wrong, and the run with it.
            return Err(io::Error::other(format!(
                "the firmware ran a step of its cycle past an event ready at {t} ns: the \
                 lookahead granted too much"
            )));
        }
        match (link_ready, drive_ready) {
            (Some(l), d) if l <= t && d.is_none_or(|d| l <= d) => {
                let e = self.to_mcu.pop_front().expect("checked");
                self.handle_event(l.max(self.floor_ns), e)
            }
            (_, Some(d)) if d <= t => self.handle_drive_answer(d.max(self.floor_ns)),
            _ if self.cycle_pending && self.mcu_free_ns <= t => {
                self.continue_cycle(self.mcu_free_ns.max(self.floor_ns))
            }
            _ => Ok(()),
        }
    }

    /// No event waits: the MCU runs the next step of the drive application's cycle, and those
    /// after it that start before anything can reach it, in one exchange.
    fn continue_cycle(&mut self, start_ns: u64) -> io::Result<()> {
        if let Some(last) = self.granted_last_step.take() {
            self.take(start_ns, &last)?;
            return Ok(());
        }
        let horizon_ns = self.horizon_ns();
        let grant = if self.realtime {
            Grant::ONE_STEP
        } else {
            Grant {
                budget_instructions: self
                    .board
                    .instructions_taking_ns(horizon_ns.saturating_sub(start_ns)),
            }
        };
        let handled = self.exchange(&ToAdapter::Sim(SimToAdapter::Continue(grant)))?;
        self.figures.continues += 1;
        self.figures.cycle_steps += u64::from(handled.earlier_steps) + 1;
        if handled.earlier_steps == 0 {
            self.take(start_ns, &handled)?;
            return Ok(());
        }
        // The earlier steps wrote nothing: they only keep the MCU busy. The last one is placed
        // when the MCU is free after them, as a step run alone would be.
        let last_start_ns = start_ns
            + self
                .board
                .instructions_ns(u64::from(handled.earlier_instructions));
        if last_start_ns >= horizon_ns {
            return Err(io::Error::other(format!(
                "the firmware ran a step at {last_start_ns} ns, past its grant to {horizon_ns} ns"
            )));
        }
        self.mcu_free_ns = last_start_ns;
        self.granted_last_step = Some(handled);
        Ok(())
    }

    /// The earliest time anything can be ready for the MCU that would hold back a step of the
    /// cycle (an event on the link, a drive answer), from what is known at this poll. An event
    /// not yet on the link is created no earlier than: a telegram, this poll's bus time (one
    /// that is still arriving ends later) or, where it would replace outputs not yet sent,
    /// their start; a timer, its time; the watchdog, the responder's deadline; and either of
    /// them, when a status or registers write not yet landed moves that time. It then takes
    /// at least the shortest such event's bytes on the link, and the interrupt's entry. Every
    /// time it names is later than this poll's: whatever was due by then went first.
    fn horizon_ns(&self) -> u64 {
        let entry = self.board.irq_entry_ns();
        let queue_free = self.to_mcu_free_ns;
        let event = |created: u64, len: usize| {
            created.max(queue_free) + self.event_transfer_ns(len) + entry
        };
        let replaceable = self
            .to_mcu
            .back()
            .filter(|e| e.outputs_only && e.start_ns > self.poll_ns);
        let telegram = match replaceable {
            Some(e) => e.start_ns + self.event_transfer_ns(self.min_telegram_event_len) + entry,
            None => event(self.poll_ns, self.min_telegram_event_len),
        };
        [
            self.to_mcu.front().map(|e| e.arrived_ns + entry),
            self.drive.next_delivery_us().map(|us| us * 1000),
            Some(telegram),
            self.timer_due().map(|at| event(at, self.min_event_len)),
            self.responder.deadline().map(|t| {
                let at = (t * 1000).div_ceil(u64::from(self.clock_hz / 1_000_000));
                event(at, self.min_event_len)
            }),
            // Of the writes, only the status (its wake-up) and the registers (the watchdog)
            // move the time of an event.
            self.from_mcu
                .iter()
                .find(|(_, w)| matches!(w, Write::Status(_) | Write::Regs(_)))
                .map(|(at, _)| event(*at, self.min_event_len)),
        ]
        .into_iter()
        .flatten()
        .min()
        .expect("a telegram can always come")
    }

    /// One message to the firmware, counted.
    fn exchange(&mut self, message: &ToAdapter) -> io::Result<Handled> {
        self.figures.round_trips += 1;
        self.firmware.exchange(message)
    }

    /// The MCU handles `e` from `start_ns`.
    fn handle_event(&mut self, start_ns: u64, e: InFlight) -> io::Result<()> {
        // In wall-clock mode the MCU's time is when it runs: a firmware that is told an
        // earlier time would time its drive link against answers that come later.
        let now_us = if self.realtime { start_ns } else { e.at_ns } / 1000;
        let latency = start_ns - e.at_ns;
        self.figures.worst_event_latency_ns = self.figures.worst_event_latency_ns.max(latency);
        let handled = match &e.event {
            Event::Boot { seq, switch } => self.exchange(&ToAdapter::Boot {
                seq: *seq,
                now_us,
                switch: *switch,
            })?,
            Event::Telegram { seq, baud, bytes } => self.exchange(&ToAdapter::Telegram {
                seq: *seq,
                now_us,
                baud: *baud,
                bytes,
            })?,
            Event::Watchdog { seq } => {
                self.exchange(&ToAdapter::WatchdogExpired { seq: *seq, now_us })?
            }
            Event::Timer { seq } => self.exchange(&ToAdapter::Timer { seq: *seq, now_us })?,
        };
        let decided_ns = self.take(start_ns, &handled)?;
        if e.outputs_only {
            self.figures
                .outputs_to_inputs_ns
                .push(decided_ns - e.arrived_ns);
            self.figures.outputs_events.push(OutputsEvent {
                telegram_end_ns: e.at_ns,
                at_mcu_ns: e.arrived_ns + self.board.irq_entry_ns(),
                handled_ns: start_ns,
                decided_ns,
            });
        }
        Ok(())
    }

    /// The drive's answer interrupts the MCU at `start_ns`.
    fn handle_drive_answer(&mut self, start_ns: u64) -> io::Result<()> {
        let Some((at_us, bytes)) = self.drive.take_delivery(start_ns / 1000) else {
            return Ok(());
        };
        self.firmware.drive_send(&bytes)?;
        // The answer's own time, in both modes: the drive line computed it from when the
        // request went out, so the firmware times its drive link on one consistent clock even
        // when the host is late to hand the answer over.
        let now_us = at_us;
        let handled = self.exchange(&ToAdapter::Sim(SimToAdapter::DriveBytes {
            now_us,
            drive_rx_bytes: self.drive.delivered,
        }))?;
        self.take(start_ns, &handled)?;
        Ok(())
    }

    /// Puts the writes of an event handled from `start_ns` on the link, and the drive bytes
    /// on the drive line; returns when the decision was in the transceiver: its last write
    /// landed, or (nothing changed) the firmware had taken it.
    fn take(&mut self, start_ns: u64, handled: &Handled) -> io::Result<u64> {
        let link = self.board.link;
        // Time the MCU spent waiting for the link to take its writes.
        let mut blocked_ns = 0;
        let mut decided_ns = start_ns
            + self
                .board
                .instructions_ns(u64::from(handled.decision_instructions));
        // The MCU blocked on writes before the drive's bytes went to its UART.
        let mut blocked_before_drive_ns = 0;
        for (i, (instructions, write)) in handled.writes.iter().enumerate() {
            let sent = start_ns + self.board.instructions_ns(u64::from(*instructions)) + blocked_ns;
            let begin = sent.max(self.from_mcu_free_ns);
            let arrived = begin + link.transfer_ns(write.encoded_len());
            self.from_mcu_free_ns = arrived;
            blocked_ns += if link.dma_writes {
                // The frame before it must be out of the one buffer first.
                begin - sent
            } else {
                // The last byte's hand-over: one byte time before it has gone out.
                (arrived - link.transfer_ns(1)).saturating_sub(sent)
            };
            if i < handled.decision_writes {
                decided_ns = arrived;
            }
            if *instructions <= handled.drive_instructions {
                blocked_before_drive_ns = blocked_ns;
            }
            self.figures.writes += 1;
            self.from_mcu.push_back((arrived, write.clone()));
        }
        let done_ns =
            start_ns + self.board.instructions_ns(u64::from(handled.instructions)) + blocked_ns;
        self.mcu_free_ns = done_ns;
        self.cycle_pending = handled.cycle_pending;
        // The bytes the firmware wrote to its drive UART go on the drive line when it handed
        // them over: where it said, else when it is done.
        let sent = handled.drive_tx_bytes.wrapping_sub(self.drive.received);
        if sent > 0 {
            let handed_ns = match handled.drive_instructions {
                0 => done_ns,
                at => {
                    start_ns + self.board.instructions_ns(u64::from(at)) + blocked_before_drive_ns
                }
            };
            let bytes = self.firmware.drive_receive(sent as usize)?;
            self.drive.from_firmware(handed_ns / 1000, &bytes);
        }
        Ok(decided_ns)
    }

    /// A write lands at `at_ns`.
    fn apply(&mut self, at_ns: u64, write: &Write) -> io::Result<()> {
        let now = self.ticks(at_ns);
        self.responder.step(&Input::Write {
            now,
            write: &write.as_message(),
        });
        if let Write::Status(status) = write {
            self.status_landed_ns = at_ns;
            self.apply_status(*status);
        }
        Ok(())
    }

    fn apply_status(&mut self, new: Status) {
        let old = self.status;
        if new.drive_link_error != old.drive_link_error {
            self.events.push(match new.drive_link_error {
                0 => "drive link: working".into(),
                e => format!("drive link: error 0x{e:02X}"),
            });
        }
        if new.state != old.state {
            self.events
                .push(format!("slave: {:?} -> {:?}", old.state, new.state));
        }
        if new.address != old.address {
            self.events.push(format!("slave address: {}", new.address));
        }
        if new.leds != old.leds {
            let l = new.leds;
            self.events.push(format!(
                "leds: net {:?}, run {:?}, tx {:?}, rx {:?}, error {:?}, online {:?}, offline {:?}, host {:?}",
                l.net, l.run, l.tx, l.rx, l.error, l.online, l.offline, l.host
            ));
        }
        match new.nv_write {
            Some(NvWrite::Address(record)) | Some(NvWrite::FactoryDefaults(record)) => {
                self.events.push(format!(
                    "storage: address {}, no_add_chg {}",
                    record.address, record.no_add_chg
                ));
            }
            Some(NvWrite::Params) => self.events.push("storage: the settings (971)".into()),
            None => {}
        }
        if new.wake_at_us != old.wake_at_us {
            self.timer_sent_for = None;
        }
        self.status = new;
    }

    /// The drive as it is at `now_us`.
    pub fn drive_at(&mut self, now_us: u64) -> &mut DriveSim {
        self.drive.advance_to(now_us);
        &mut self.drive.drive
    }

    /// Whether the transceiver holds nothing for the MCU, the MCU nothing for it, and the
    /// drive application has no step of its cycle left.
    pub fn idle(&self) -> bool {
        self.to_mcu.is_empty() && self.from_mcu.is_empty() && !self.cycle_pending
    }
}

/// The shortest request the responder hands over: an SD1 telegram (SD1, DA, SA, FC, FCS, ED);
/// SD2 and SD3 are longer, and an SC or a token is never handed over.
const SHORTEST_REQUEST_LEN: usize = 6;

/// The bytes `event` takes on the link.
fn encoded_len(event: &Event, at_ns: u64) -> usize {
    let now_us = at_ns / 1000;
    let message = match event {
        Event::Boot { seq, switch } => ToAdapter::Boot {
            seq: *seq,
            now_us,
            switch: *switch,
        },
        Event::Telegram { seq, baud, bytes } => ToAdapter::Telegram {
            seq: *seq,
            now_us,
            baud: *baud,
            bytes,
        },
        Event::Watchdog { seq } => ToAdapter::WatchdogExpired { seq: *seq, now_us },
        Event::Timer { seq } => ToAdapter::Timer { seq: *seq, now_us },
    };
    let mut frame = [0u8; MAX_FRAME_LEN];
    dp_link::encode(&message, &mut frame).map_or(MAX_FRAME_LEN, |f| f.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A firmware that answers every message by `script`, with no drive bytes.
    struct Scripted<S>(S);

    impl<S: FnMut(&ToAdapter) -> Handled> Firmware for Scripted<S> {
        fn exchange(&mut self, message: &ToAdapter) -> io::Result<Handled> {
            Ok((self.0)(message))
        }
        fn restart(&mut self) -> io::Result<()> {
            Ok(())
        }
        fn drive_send(&mut self, _: &[u8]) -> io::Result<()> {
            Ok(())
        }
        fn drive_receive(&mut self, _: usize) -> io::Result<Vec<u8>> {
            Ok(Vec::new())
        }
    }

    /// Handles every event alike: `decision` instructions, then one write of `inputs` (the
    /// decision's), then `total` instructions in all.
    fn fixed(decision: u32, total: u32, inputs: Vec<u8>) -> impl Firmware {
        Scripted(move |_: &ToAdapter| Handled {
            writes: vec![(decision, Write::Inputs(inputs.clone()))],
            decision_writes: 1,
            decision_instructions: decision,
            instructions: total,
            drive_tx_bytes: 0,
            ..Handled::default()
        })
    }

    /// A cycle that always has steps left: each `Continue`'s grant goes to `grants`, and
    /// `earlier` steps of `step` instructions each run before the last.
    fn cycling(
        grants: std::rc::Rc<std::cell::RefCell<Vec<Grant>>>,
        earlier: u32,
        step: u32,
    ) -> impl Firmware {
        Scripted(move |message: &ToAdapter| {
            let earlier_steps = match *message {
                ToAdapter::Sim(SimToAdapter::Continue(grant)) => {
                    grants.borrow_mut().push(grant);
                    earlier
                }
                _ => 0,
            };
            Handled {
                instructions: step,
                cycle_pending: true,
                earlier_steps,
                earlier_instructions: earlier_steps * step,
                ..Handled::default()
            }
        })
    }

    /// A bridge whose MCU is free at 1 ms with steps of its cycle left and nothing on its way,
    /// and the grants its firmware gets.
    fn cycling_bridge(
        earlier: u32,
        step: u32,
    ) -> (
        Bridge<impl Firmware>,
        std::rc::Rc<std::cell::RefCell<Vec<Grant>>>,
    ) {
        let grants = std::rc::Rc::default();
        let firmware = cycling(std::rc::Rc::clone(&grants), earlier, step);
        let mut bridge = Bridge::new(firmware, 48_000_000, 5);
        bridge.mcu_free_ns = 1_000_000;
        bridge.to_mcu_free_ns = 1_000_000;
        bridge.cycle_pending = true;
        (bridge, grants)
    }

    #[test]
    fn a_grant_reaches_as_far_as_the_shortest_telegram_event_can_come() {
        let (mut bridge, grants) = cycling_bridge(0, 100);
        let board = bridge.board;
        bridge.poll(1_000_000).unwrap();
        // Nothing is pending: the next event is a telegram ending now at the earliest, an SD1
        // of six bytes whose event is 11 bytes of message, COBS's two and the idle character.
        let horizon_ns = board.link.transfer_ns(14) + board.irq_entry_ns();
        let budget = board.instructions_taking_ns(horizon_ns);
        assert_eq!(
            *grants.borrow(),
            [Grant {
                budget_instructions: budget
            }]
        );
        // A write of the status on its way shortens it: the wake-up it may ask for comes
        // after it lands, a timer event's 5 bytes and the idle character later.
        let landing = bridge.mcu_free_ns + 2_000;
        bridge
            .from_mcu
            .push_back((landing, Write::Status(Status::POWER_ON)));
        let start = bridge.mcu_free_ns;
        bridge.poll(start).unwrap();
        let horizon_ns = landing + board.link.transfer_ns(6) + board.irq_entry_ns();
        assert_eq!(
            grants.borrow()[1].budget_instructions,
            board.instructions_taking_ns(horizon_ns - start)
        );
    }

    #[test]
    fn the_last_step_of_a_grant_waits_for_the_mcu_and_a_step_past_the_grant_fails_the_run() {
        let (mut bridge, _) = cycling_bridge(3, 100);
        let board = bridge.board;
        bridge.poll(1_000_000).unwrap();
        // Three steps ran; the fourth is placed after them and taken when the MCU is free.
        assert_eq!(bridge.mcu_free_ns, 1_000_000 + board.instructions_ns(300));
        assert!(bridge.granted_last_step.is_some());
        bridge.poll(bridge.mcu_free_ns).unwrap();
        assert!(bridge.granted_last_step.is_none());
        assert_eq!(bridge.figures.cycle_steps, 4);
        // A firmware that ran past its grant is caught.
        let (mut bridge, _) = cycling_bridge(100, 1_000);
        let err = bridge.poll(1_000_000).unwrap_err();
        assert!(err.to_string().contains("past its grant"), "{err}");
    }

    #[test]
    fn the_board_charges_the_idle_character_and_a_write_waits_for_the_one_before() {
        let firmware = fixed(720, 1440, vec![0x55; 12]);
        let mut bridge = Bridge::new(firmware, 48_000_000, 5);
        let board = bridge.board;
        let link = board.link;
        assert!(link.dma_writes && link.idle_bytes_after_frame == 1);
        bridge.boot(0);
        let boot_len = encoded_len(&Event::Boot { seq: 1, switch: 5 }, 0);
        // The Boot reaches the MCU after its bytes and the idle character, plus the entry.
        let arrival = link.transfer_ns(boot_len + 1);
        assert_eq!(bridge.next_ns(), Some(arrival + board.irq_entry_ns()));
        let start = arrival + board.irq_entry_ns();
        bridge.poll(start).unwrap();
        // The write leaves after the decision's instructions and takes its bytes' time; by
        // DMA, the MCU goes on at once.
        let write_len = Write::Inputs(vec![0x55; 12]).encoded_len();
        let written = start + board.instructions_ns(720) + link.transfer_ns(write_len);
        assert_eq!(bridge.next_ns(), Some(written));
        assert_eq!(bridge.mcu_free_ns, start + board.instructions_ns(1440));
        bridge.poll(written).unwrap();
        assert!(bridge.idle());
        // Two writes at once: the second waits for the first to be out, and the MCU with it.
        let handled = Handled {
            writes: vec![
                (100, Write::Inputs(vec![1; 12])),
                (100, Write::Inputs(vec![2; 12])),
            ],
            decision_writes: 2,
            decision_instructions: 100,
            instructions: 200,
            drive_tx_bytes: 0,
            ..Handled::default()
        };
        let at = written + 1_000_000;
        bridge.take(at, &handled).unwrap();
        let first_out = at + board.instructions_ns(100) + link.transfer_ns(write_len);
        assert_eq!(
            bridge.mcu_free_ns,
            first_out + board.instructions_ns(200) - board.instructions_ns(100)
        );
    }
}
