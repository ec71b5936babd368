//! The adapter's firmware: a thin RTIC shell around `crates/adapter`.
//!
//! ```text
//! UART (link) ─IRQ─► bytes ─► bbqueue ─► `link` task: COBS frames ─► postcard ToAdapter
//!    ▲                                          │ Adapter::on_message (fdl, dp-slave, app)
//!    └──────────── FromAdapter::Reply ◄─────────┘ + turnaround cycles
//! ```
//! The hardware task only moves bytes and wakes the software task; every protocol decision is
//! in the logic crates. Each message gets exactly one reply, so the queue holds one frame.
//!
//! The drive link (UART1 / USART2) is interrupt-driven too: its interrupt moves bytes between
//! the UART and two queues ([`drive_uart`]); the drive application's Modbus master runs in the
//! `link` task after each message, and never waits for the drive. Under hal-sim a Tick says
//! how many drive bytes have arrived; the task waits for them first, so the drive link runs
//! on simulated time and repeats run to run.
#![no_std]
#![no_main]

mod board;
mod drive_uart;

use defmt::error;

#[cfg(feature = "stm32f103")]
use defmt_rtt as _;
#[cfg(feature = "lm3s6965")]
use defmt_semihosting as _;

/// Bytes the link queue holds: two maximal frames.
const LINK_QUEUE_LEN: usize = 2 * dp_link::MAX_FRAME_LEN;

/// The drive application on the drive UART.
type DriveApp = adapter::DriveApp<drive_uart::DriveUart>;

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
    error!("panic: {}", defmt::Display2Format(info));
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
            use adapter::Adapter;
            use bbqueue::{BBBuffer, Consumer, Producer};
            use core::sync::atomic::{AtomicU32, Ordering};
            use defmt::{info, warn};
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
                link_rx: board::Uart,
                link_tx: Option<board::Uart>,
                producer: Producer<'static, { crate::LINK_QUEUE_LEN }>,
                consumer: Consumer<'static, { crate::LINK_QUEUE_LEN }>,
                wake: Sender<'static, (), 1>,
            }

            #[init]
            fn init(cx: init::Context) -> (Shared, Local) {
                let board = board::init(cx.core, cx.device);
                let (producer, consumer) = LINK_QUEUE.try_split().unwrap();
                let (wake, woken) = make_channel!((), 1);
                info!("boot: {}", board::NAME);
                info!("cycle counter: 1000 nops count {=u32} cycles", board::calibrate());
                let mut link_tx = board::link_tx();
                send(&mut link_tx, &FromAdapter::Ready);
                crate::selftest();
                link::spawn(woken).ok();
                (
                    Shared {},
                    Local {
                        link_rx: board.link,
                        link_tx: Some(link_tx),
                        producer,
                        consumer,
                        wake,
                    },
                )
            }

            #[idle]
            fn idle(_: idle::Context) -> ! {
                loop {
                    cortex_m::asm::wfi();
                }
            }

            /// Moves received bytes into the queue and wakes the link task.
            #[task(binds = $link_irq, priority = 2, local = [link_rx, producer, wake])]
            fn link_irq(cx: link_irq::Context) {
                let uart = cx.local.link_rx;
                uart.clear_rx_interrupt();
                let mut frame_ended = false;
                while let Some(byte) = uart.read_byte() {
                    if byte == 0 {
                        FRAME_END.store(board::timestamp(), Ordering::Relaxed);
                        frame_ended = true;
                    }
                    match cx.local.producer.grant_exact(1) {
                        Ok(mut grant) => {
                            grant[0] = byte;
                            grant.commit(1);
                        }
                        // Cannot happen in the lockstep protocol; dropped bytes fail the frame.
                        Err(_) => {}
                    }
                }
                // The link task runs on whole frames only, so its work after the frame's end
                // does not depend on how the bytes were split across interrupts: the cycle
                // count repeats run to run. A full channel means a wake-up is already pending.
                if frame_ended {
                    let _ = cx.local.wake.try_send(());
                }
            }

            /// The drive UART: above the link, so bytes queued to send leave at once.
            #[task(binds = $drive_irq, priority = 3)]
            fn drive_irq(_: drive_irq::Context) {
                board::drive_interrupt();
            }

            /// Decodes frames, runs the adapter, sends the replies.
            #[task(priority = 1, local = [consumer, link_tx, adapter: Option<Adapter<crate::DriveApp>> = None, deframer: Deframer = Deframer::new()])]
            async fn link(cx: link::Context, mut woken: Receiver<'static, (), 1>) {
                let tx = cx.local.link_tx.as_mut().unwrap();
                while woken.recv().await.is_ok() {
                    while let Ok(grant) = cx.local.consumer.read() {
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
                                    handle(cx.local.adapter, tx, &message);
                                    rest = r;
                                }
                            }
                        }
                        grant.release(len);
                    }
                }
            }

            fn handle(slot: &mut Option<Adapter<crate::DriveApp>>, tx: &mut board::Uart, message: &ToAdapter) {
                let start = FRAME_END.load(Ordering::Relaxed);
                if let ToAdapter::Tick { drive_rx_bytes, .. } = *message {
                    // The simulated drive's bytes were sent before this Tick; they may still
                    // be on their way through QEMU. The wait is not in the cycle count: on a
                    // board the bytes are there when the link's time says so.
                    while (crate::drive_uart::received().wrapping_sub(drive_rx_bytes) as i32) < 0 {}
                }
                let start = if matches!(message, ToAdapter::Tick { .. }) {
                    board::timestamp()
                } else {
                    start
                };
                if let ToAdapter::Boot { switch, nv, .. } = *message {
                    let app = adapter::drive_app(crate::drive_uart::DriveUart::new());
                    let adapter = Adapter::boot(switch, nv, app);
                    let a = adapter.addressing();
                    info!("adapter: switch {=u8}, address {=u8} from {}", switch, a.address, a.source);
                    *slot = Some(adapter);
                }
                let Some(adapter) = slot.as_mut() else {
                    warn!("link: message before Boot");
                    return;
                };
                let before = adapter.slave().state();
                let (response, status) = adapter.on_message(message);
                // The response is ready: the log line below is not part of the turnaround.
                let cycles = board::cycles_since(start);
                if adapter::link_state(before) != status.state {
                    info!("slave: {} -> {}", before, status.state);
                }
                let reply = FromAdapter::Reply {
                    seq: message.seq(),
                    response,
                    cycles,
                    status,
                };
                send(tx, &reply);
                // The drive link's turn, after the response is on its way.
                let (before, address) = (adapter.slave().state(), status.address);
                let status = adapter.after_message(message);
                if adapter::link_state(before) != status.state {
                    info!("slave: {} -> {}", before, status.state);
                }
                if status.address != address {
                    info!("slave: address {=u8} -> {=u8}, from the drive's 51.02", address, status.address);
                }
                send(tx, &FromAdapter::Done { seq: message.seq(), status });
            }

            fn send(tx: &mut board::Uart, message: &FromAdapter) {
                let mut frame = [0u8; dp_link::MAX_FRAME_LEN];
                match dp_link::encode(message, &mut frame) {
                    Ok(bytes) => bytes.iter().for_each(|b| tx.write_byte(*b)),
                    Err(_) => warn!("link: message does not fit a frame"),
                }
            }
        }
    };
}

#[cfg(feature = "lm3s6965")]
adapter_app!(UART0, UART1, GPIOA);
#[cfg(feature = "stm32f103")]
adapter_app!(USART1, USART2, EXTI0);
