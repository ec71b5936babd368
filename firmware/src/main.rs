//! The adapter's firmware: a thin RTIC shell around `crates/adapter`.
//!
//! ```text
//! UART (link) ─IRQ─► bytes ─► bbqueue ─► `link` task: COBS frames ─► postcard ToAdapter event
//!    ▲                                          │ Adapter::handle (fdl, dp-slave, app)
//!    └──── FromAdapter writes (registers, inputs, diagnosis, configuration, status)
//! ```
//! The transceiver answers the bus by itself from the buffers the firmware writes; the
//! firmware sees only the events that need its decision (Set_Prm, Chk_Cfg, Global_Control,
//! Set_Slave_Add, new outputs, the watchdog's expiry, its wake-up). The hardware task only
//! moves bytes and wakes the software task; every protocol decision is in the logic crates.
//!
//! The drive link (UART1 / USART2) is interrupt-driven too: its interrupt moves bytes between
//! the UART and two queues ([`drive_uart`]); the drive application's cycle (its Modbus master
//! included) runs in the `link` task a step at a time whenever no frame waits, so a decision
//! the transceiver waits for (new outputs above all) waits for one step, not a whole cycle;
//! it never waits for the drive. The drive interrupt wakes the task at an answer's end (the
//! line idle after it) for the drive link's turn. On the QEMU board (feature `sim`) hal-sim
//! says instead how many drive bytes have arrived (a simulation-only message); the task
//! waits for them first, so the drive link runs on simulated time and repeats run to run, and
//! it reports its instruction counts after each event, which hal-sim turns into board time.
#![no_std]
#![no_main]

mod board;
mod drive_uart;
mod nv;
mod ram_test;
#[cfg(feature = "sim")]
mod sim_pipe;

use defmt::error;
#[cfg(feature = "adapter-in-image")]
use static_cell::ConstStaticCell;
#[cfg(not(feature = "adapter-in-image"))]
use static_cell::StaticCell;

#[cfg(feature = "stm32f103")]
use defmt_rtt as _;
#[cfg(feature = "semihosting")]
use defmt_semihosting as _;

/// The firmware's version: `git describe` of the sources it was built from, which xtask
/// names (`cargo xtask dist` reads it back from the image, at the symbol `DP_ADAPTER_VERSION`;
/// PROFIdrive 964.2 carries its major and minor numbers).
const VERSION: &str = adapter::FIRMWARE_VERSION;

/// The version where a tool finds it in the image: NUL-padded, at a symbol of its own.
#[no_mangle]
#[used]
static DP_ADAPTER_VERSION: [u8; 64] = {
    let mut bytes = [0u8; 64];
    let version = VERSION.as_bytes();
    assert!(
        version.len() < bytes.len(),
        "the version does not fit its symbol"
    );
    let mut i = 0;
    while i < version.len() {
        bytes[i] = version[i];
        i += 1;
    }
    bytes
};

/// Bytes the link queue holds: the board's number of maximal frames.
const LINK_QUEUE_LEN: usize = board::BOARD.link_queue_frames as usize * dp_link::MAX_FRAME_LEN;

/// The drive application on the drive UART.
type DriveApp = adapter::DriveApp<drive_uart::DriveUart>;

/// The adapter's place, unpowered: built at the Boot into RAM (zeroed at reset, not part of the
/// image), once.
#[cfg(not(feature = "adapter-in-image"))]
#[inline(always)]
fn unpowered_adapter() -> &'static mut adapter::Adapter<DriveApp> {
    static ADAPTER: StaticCell<adapter::Adapter<DriveApp>> = StaticCell::new();
    ADAPTER
        .init_with(|| adapter::Adapter::unpowered(adapter::drive_app(drive_uart::DriveUart::new())))
}

/// The adapter's place, unpowered: the image holds it as initial data, which the reset copies
/// into RAM. Built at the Boot it would take a 1.6 KiB stack frame for a moment, which a board
/// with 8 KiB of RAM does not have (README "The production board under emulation"); the price
/// is its 5 KiB in flash.
#[cfg(feature = "adapter-in-image")]
fn unpowered_adapter() -> &'static mut adapter::Adapter<DriveApp> {
    static ADAPTER: ConstStaticCell<adapter::Adapter<DriveApp>> = ConstStaticCell::new(
        adapter::Adapter::unpowered(adapter::drive_app(drive_uart::DriveUart::new())),
    );
    ADAPTER.take()
}

/// The failure paths, proven by `cargo xtask qemu-test` on images built for it.
fn selftest() {
    #[cfg(feature = "selftest-panic")]
    panic!("selftest: a panic on purpose");
    // An undefined instruction: a UsageFault, escalated to HardFault (the fault handlers
    // are not enabled).
    #[cfg(feature = "selftest-hardfault")]
    cortex_m::asm::udf();
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // The message only where it is a plain string, and the location: formatting arguments
    // would link core::fmt, a tenth of the production board's flash.
    let message = info.message().as_str().unwrap_or("(formatted message)");
    match info.location() {
        Some(at) => error!(
            "panic: panicked at {=str}:{=u32}:{=u32}:\n{=str}",
            at.file(),
            at.line(),
            at.column(),
            message
        ),
        None => error!("panic: {=str}", message),
    }
    board::exit_failure()
}

#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    error!("HardFault");
    board::exit_failure()
}

macro_rules! adapter_app {
    ($link_irq:ident, $drive_irq:ident, $dispatcher:ident) => {
        #[rtic::app(device = crate::board::pac, dispatchers = [$dispatcher])]
        mod app {
            use crate::board;
            use adapter::{Adapter, Out};
            use bbqueue::{BBBuffer, Consumer, Producer};
            use core::sync::atomic::{AtomicU32, Ordering};
            use defmt::{error, info, warn};
            use dp_link::{Deframer, Fed, FromAdapter, ToAdapter};
            use rtic_sync::channel::{Receiver, Sender};
            use rtic_sync::make_channel;

            static LINK_QUEUE: BBBuffer<{ crate::LINK_QUEUE_LEN }> = BBBuffer::new();
            /// Timestamp of the last frame end seen by the hardware task.
            static FRAME_END: AtomicU32 = AtomicU32::new(0);

            #[shared]
            struct Shared {}

            #[local]
            struct Local {
                /// The adapter, from the Boot on (`crate::unpowered_adapter`, powered up).
                adapter: Option<&'static mut Adapter<crate::DriveApp>>,
                /// The drive link's ends of the drive UART's queues, until the Boot attaches them.
                drive_ends: Option<crate::drive_uart::LinkEnds>,
                /// The drive interrupt's ends.
                drive_queues: crate::drive_uart::InterruptEnds,
                link_rx: board::Uart,
                link_tx: Option<board::Uart>,
                producer: Producer<'static, { crate::LINK_QUEUE_LEN }>,
                consumer: Consumer<'static, { crate::LINK_QUEUE_LEN }>,
                wake: Sender<'static, (), 1>,
                /// The idle loop's, to hand over hal-sim's messages from its pipe (simulation
                /// only; a board's idle loop only sleeps).
                idle_wake: Sender<'static, (), 1>,
                /// The drive interrupt's, for an answer's end.
                drive_wake: Sender<'static, (), 1>,
            }

            #[init(local = [
                drive_rx: crate::drive_uart::ByteQueue = crate::drive_uart::ByteQueue::new(),
                drive_tx: crate::drive_uart::ByteQueue = crate::drive_uart::ByteQueue::new(),
            ])]
            fn init(cx: init::Context) -> (Shared, Local) {
                let (drive_ends, drive_queues) = crate::drive_uart::split(cx.local.drive_rx, cx.local.drive_tx);
                let board = board::init(cx.core, cx.device);
                let (producer, consumer) = LINK_QUEUE.try_split().unwrap();
                let (wake, woken) = make_channel!((), 1);
                info!("boot: {=str}, firmware {=str}", board::BOARD.description, crate::VERSION);
                info!("cycle counter: 100 nops count {=u32} cycles", board::calibrate());
                let mut link_tx = board::link_tx();
                #[cfg(feature = "sim")]
                crate::sim_pipe::open();
                send(&mut link_tx, &mut [0; dp_link::MAX_FRAME_LEN], &FromAdapter::Ready);
                if let Err(address) = crate::ram_test::result() {
                    // Seed 000 line 685: Run steady on, and the adapter does not start.
                    error!("RAM test: the word at {=u32:#010x} failed", address);
                    let status = FromAdapter::Status(adapter::ram_fault_status());
                    send(&mut link_tx, &mut [0; dp_link::MAX_FRAME_LEN], &status);
                    board::halt_ram_fault();
                }
                crate::selftest();
                link::spawn(woken).ok();
                (
                    Shared {},
                    Local {
                        adapter: None,
                        drive_ends: Some(drive_ends),
                        drive_queues,
                        link_rx: board.link,
                        link_tx: Some(link_tx),
                        producer,
                        consumer,
                        idle_wake: wake.clone(),
                        drive_wake: wake.clone(),
                        wake,
                    },
                )
            }

            /// Sleeps between interrupts. Under simulation it waits for hal-sim's next message
            /// on its pipe instead (`sim_pipe`), and hands the simulation's own to the link
            /// task.
            #[idle(local = [idle_wake])]
            fn idle(cx: idle::Context) -> ! {
                #[cfg(feature = "sim")]
                crate::sim_pipe::serve(cx.local.idle_wake);
                #[cfg(not(feature = "sim"))]
                {
                    let _unused_on_a_board = cx.local.idle_wake;
                    loop {
                        cortex_m::asm::wfi();
                    }
                }
            }

            /// Moves received bytes into the queue and wakes the link task.
            #[task(binds = $link_irq, priority = 2, local = [link_rx, producer, wake])]
            fn link_irq(cx: link_irq::Context) {
                let uart = cx.local.link_rx;
                uart.clear_rx_interrupt();
                let mut frame_ended = false;
                // One grant for all the bytes waiting, not one per byte: bbqueue's grant and
                // commit cost more than the byte's copy.
                loop {
                    let Ok(mut grant) = cx.local.producer.grant_max_remaining(crate::LINK_QUEUE_LEN) else {
                        // Four frames behind: the dropped bytes fail their frame, which the
                        // deframer drops; the transceiver's registers wait for a newer event.
                        while uart.read_byte().is_some() {}
                        break;
                    };
                    let mut n = 0;
                    while n < grant.len() {
                        let Some(byte) = uart.read_byte() else { break };
                        grant[n] = byte;
                        n += 1;
                        if byte == 0 {
                            FRAME_END.store(board::timestamp(), Ordering::Relaxed);
                            frame_ended = true;
                        }
                    }
                    let filled = n == grant.len();
                    grant.commit(n);
                    if !filled {
                        break;
                    }
                }
                // The link task runs on whole frames only, so its work after the frame's end
                // does not depend on how the bytes were split across interrupts: the cycle
                // count repeats run to run. A full channel means a wake-up is already pending.
                if frame_ended {
                    let _ = cx.local.wake.try_send(());
                }
            }

            /// The drive UART: above the link, so bytes queued to send leave at once. An
            /// answer's end (the line idle after it) wakes the link task for the drive link's
            /// turn; under simulation hal-sim's `DriveBytes` says so instead, in simulated time.
            #[task(binds = $drive_irq, priority = 3, local = [drive_wake, drive_queues])]
            fn drive_irq(cx: drive_irq::Context) {
                let answered = board::drive_interrupt(cx.local.drive_queues);
                #[cfg(not(feature = "sim"))]
                if answered {
                    crate::drive_uart::on_line_idle();
                    let _ = cx.local.drive_wake.try_send(());
                }
                #[cfg(feature = "sim")]
                let _ = (answered, cx.local.drive_wake);
            }

            /// Decodes frames, runs the adapter, sends the replies.
            #[task(priority = 1, local = [consumer, link_tx, adapter, drive_ends, deframer: Deframer = Deframer::new(), frame: [u8; dp_link::MAX_FRAME_LEN] = [0; dp_link::MAX_FRAME_LEN]])]
            async fn link(cx: link::Context, mut woken: Receiver<'static, (), 1>) {
                let tx = cx.local.link_tx.as_mut().unwrap();
                while woken.recv().await.is_ok() {
                    loop {
                        // Every frame first: the decisions the transceiver waits for.
                        if let Ok(grant) = cx.local.consumer.read() {
                            let len = grant.len();
                            let mut rest: &[u8] = &grant;
                            loop {
                                match cx.local.deframer.feed::<ToAdapter>(rest) {
                                    Fed::Pending => break,
                                    Fed::Dropped(r) => {
                                        warn!("link: dropped a frame");
                                        rest = r;
                                    }
                                    Fed::Message(message, r) => {
                                        handle(cx.local.adapter, cx.local.drive_ends, tx, cx.local.frame, &message);
                                        #[cfg(feature = "sim")]
                                        crate::sim_pipe::handled();
                                        rest = r;
                                    }
                                }
                            }
                            grant.release(len);
                            continue;
                        }
                        #[cfg(feature = "sim")]
                        if let Some(message) = crate::sim_pipe::take() {
                            handle(cx.local.adapter, cx.local.drive_ends, tx, cx.local.frame, &ToAdapter::Sim(message));
                            crate::sim_pipe::handled();
                            continue;
                        }
                        // The queue is empty: one step of the drive application's cycle, then
                        // look again, so that an event waits for one step, not a whole cycle.
                        if !cycle_step(cx.local.adapter, tx, cx.local.frame) {
                            break;
                        }
                    }
                }
            }

            /// One step of the drive application's cycle, if one is due. Under simulation
            /// hal-sim says when (`SimToAdapter::Continue`): only it knows whether an event
            /// reached the MCU during the last step.
            #[cfg(not(feature = "sim"))]
            fn cycle_step(
                slot: &mut Option<&'static mut Adapter<crate::DriveApp>>,
                tx: &mut board::Uart,
                frame: &mut [u8; dp_link::MAX_FRAME_LEN],
            ) -> bool {
                if crate::drive_uart::take_answered() {
                    if let Some(adapter) = slot.as_deref_mut() {
                        adapter.drive_answer(adapter.now_us());
                    }
                }
                let Some(adapter) = slot.as_deref_mut().filter(|a| a.cycle_pending()) else {
                    return false;
                };
                let before = (adapter.slave().state(), adapter.slave().address());
                adapter.cycle_step(&mut |out| {
                    if let Out::Write(write) = out {
                        send(tx, frame, &write);
                    }
                });
                crate::drive_uart::kick();
                crate::nv::carry_out(adapter);
                log_changes(before, adapter);
                true
            }

            #[cfg(feature = "sim")]
            fn cycle_step(
                _: &mut Option<&'static mut Adapter<crate::DriveApp>>,
                _: &mut board::Uart,
                _: &mut [u8; dp_link::MAX_FRAME_LEN],
            ) -> bool {
                false
            }

            /// The slave's state and address changes, after the work they describe (not part
            /// of the counts).
            fn log_changes(before: (dp_slave::State, u8), adapter: &Adapter<crate::DriveApp>) {
                let (state, address) = (adapter.slave().state(), adapter.slave().address());
                if before.0 != state {
                    info!("slave: {} -> {}", adapter::link_state(before.0), adapter::link_state(state));
                }
                if before.1 != address {
                    info!("slave: address {=u8} -> {=u8}", before.1, address);
                }
            }

            fn handle(
                slot: &mut Option<&'static mut Adapter<crate::DriveApp>>,
                drive_ends: &mut Option<crate::drive_uart::LinkEnds>,
                tx: &mut board::Uart,
                frame: &mut [u8; dp_link::MAX_FRAME_LEN],
                message: &ToAdapter,
            ) {
                // A measurement, answered alone: no event, so no counts and no `Done`.
                #[cfg(feature = "sim")]
                if let ToAdapter::Sim(dp_link::sim::SimToAdapter::StackPeak) = *message {
                    let (used_bytes, room_bytes) = crate::ram_test::stack_peak();
                    let peak = dp_link::sim::SimFromAdapter::StackPeak { used_bytes, room_bytes };
                    crate::sim_pipe::reply(frame, &peak);
                    return;
                }
                // Instructions are counted from the frame's end, for hal-sim's board time.
                #[cfg(feature = "sim")]
                #[allow(unused_mut)]
                let mut start = FRAME_END.load(Ordering::Relaxed);
                #[cfg(feature = "sim")]
                if let ToAdapter::Sim(dp_link::sim::SimToAdapter::DriveBytes { drive_rx_bytes, .. }) = *message {
                    // The simulated drive's bytes were sent before this message; they may
                    // still be on their way through QEMU. The wait is not counted: on a board
                    // the drive UART's interrupt starts this work when they are there.
                    while (crate::drive_uart::received().wrapping_sub(drive_rx_bytes) as i32) < 0 {}
                    start = board::timestamp();
                }
                // A step of the cycle is counted from here: on a board it follows the look at
                // the empty queue, with no frame to receive or decode.
                #[cfg(feature = "sim")]
                if let ToAdapter::Sim(dp_link::sim::SimToAdapter::Continue(_)) = *message {
                    start = board::timestamp();
                }
                if let ToAdapter::Boot { switch, .. } = *message {
                    boot(slot, drive_ends, switch);
                }
                let Some(adapter) = slot.as_deref_mut() else {
                    warn!("link: message before Boot");
                    return;
                };
                let before = (adapter.slave().state(), adapter.slave().address());
                // Cells: the steps of a grant read them between the writes the closure counts.
                #[cfg(feature = "sim")]
                let (start, writes) = (core::cell::Cell::new(start), core::cell::Cell::new(0u32));
                #[cfg(feature = "sim")]
                let mut decision = (0u32, 0u32);
                #[cfg(feature = "sim")]
                let drive_instructions = core::cell::Cell::new(0u32);
                let mut out = |out: Out| match out {
                    Out::Write(write) => {
                        send(tx, frame, &write);
                        #[cfg(feature = "sim")]
                        writes.set(writes.get() + 1);
                    }
                    Out::DecisionWritten => {
                        #[cfg(feature = "sim")]
                        {
                            decision = (board::cycles_since(start.get()), writes.get());
                        }
                    }
                    Out::DriveQueued => {
                        // The request leaves here: the drive interrupt runs at once and puts
                        // its first byte on the line (QEMU's UART then takes the rest at once,
                        // where the part takes one a character: not the request's start).
                        #[cfg(feature = "sim")]
                        {
                            drive_instructions.set(board::cycles_since(start.get()));
                        }
                        crate::drive_uart::kick();
                    }
                };
                // The steps of a grant that ran before the last one, and their instructions.
                #[cfg(feature = "sim")]
                let mut earlier = (0u8, 0u32);
                match message {
                    #[cfg(feature = "sim")]
                    ToAdapter::Sim(dp_link::sim::SimToAdapter::Continue(grant)) => loop {
                        let drive_before = adapter::Background::drive_tx_bytes(adapter.app());
                        adapter.cycle_step(&mut out);
                        // What the step queued for the drive goes out now, in one interrupt,
                        // its first byte at once (as for `Out::DriveQueued`).
                        let queued = adapter::Background::drive_tx_bytes(adapter.app()) != drive_before;
                        if queued {
                            drive_instructions.set(board::cycles_since(start.get()));
                        }
                        crate::drive_uart::kick();
                        let used = earlier.1.saturating_add(board::cycles_since(start.get()));
                        let wrote = writes.get() > 0 || queued;
                        // A u8 is plenty: a cycle has fewer steps, and a grant ends with it.
                        if !adapter.cycle_pending() || !grant.allows_another(used, wrote) || earlier.0 == u8::MAX {
                            break;
                        }
                        // This step's counts go with the earlier ones; the next is counted
                        // from its own start, as on a board after its look at the queue.
                        earlier = (earlier.0 + 1, used);
                        start.set(board::timestamp());
                    },
                    // The drive's answer is in its UART: the drive link's turn is next.
                    #[cfg(feature = "sim")]
                    ToAdapter::Sim(dp_link::sim::SimToAdapter::DriveBytes { now_us, .. }) => {
                        adapter.drive_answer(*now_us);
                    }
                    _ => {
                        adapter.decide(message, &mut out);
                        crate::drive_uart::kick();
                    }
                }
                crate::nv::carry_out(adapter);
                #[cfg(feature = "sim")]
                crate::sim_pipe::reply(frame, &dp_link::sim::SimFromAdapter::Done {
                    link_frames: writes.get(),
                    drive_instructions: drive_instructions.get(),
                    earlier_steps: earlier.0,
                    earlier_instructions: earlier.1,
                    decision_instructions: decision.0,
                    decision_writes: decision.1,
                    instructions: board::cycles_since(start.get()),
                    drive_tx_bytes: adapter::Background::drive_tx_bytes(adapter.app()),
                    cycle_pending: adapter.cycle_pending(),
                });
                log_changes(before, adapter);
            }

            /// Powers the adapter up, once: the transceiver sends one Boot per power-up. Never
            /// inlined: where the adapter is built at Boot that takes a 1.6 KiB frame for
            /// a moment, and inlined into the link task that frame would be taken at every
            /// dispatch (3.5 KiB then, against 0.5 KiB now), not only at boot.
            #[inline(never)]
            fn boot(
                slot: &mut Option<&'static mut Adapter<crate::DriveApp>>,
                drive_ends: &mut Option<crate::drive_uart::LinkEnds>,
                switch: u8,
            ) {
                if slot.is_some() {
                    warn!("link: a second Boot, ignored");
                    return;
                }
                let adapter = crate::unpowered_adapter();
                if let Some(ends) = drive_ends.take() {
                    adapter.app_mut().drive_mut().master_mut().uart_mut().attach(ends);
                }
                adapter.power_up(switch, crate::nv::load());
                let a = adapter.addressing();
                info!("adapter: switch {=u8}, address {=u8} from {}", switch, a.address, a.source);
                *slot = Some(adapter);
            }

            /// `frame` is the task's: a fresh zeroed frame per message cost more than encoding it.
            fn send(tx: &mut board::Uart, frame: &mut [u8; dp_link::MAX_FRAME_LEN], message: &FromAdapter) {
                if let FromAdapter::Status(status) = message {
                    crate::nv::note(status);
                }
                match dp_link::encode(message, frame) {
                    Ok(bytes) => tx.write_frame(bytes),
                    Err(_) => warn!("link: message does not fit a frame"),
                }
            }
        }
    };
}

/// Each board module instantiates the app on its interrupts: `crate::adapter_app!(link UART,
/// drive UART, a free interrupt for the software tasks)`.
pub(crate) use adapter_app;
