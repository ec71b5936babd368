//! The firmware behind the transceiver: the real image under QEMU, or the same logic crate
//! run in-process for fast host tests of the simulator itself.
//!
//! Both speak the link protocol of `dp-link`: the simulator hands over one event
//! ([`ToAdapter`]) and collects what the firmware writes while it handles it ([`Handled`]):
//! the product's writes for the transceiver, each with the instructions the firmware had run
//! when it sent it (the simulation-only `Done` mark), so that the caller places
//! them in board time. The QEMU side is a Unix socket that QEMU's first serial port (the
//! link UART) connects to; QEMU's stdout carries only the defmt stream (semihosting), collected
//! for the caller to decode.
//!
//! Every message is announced on the simulation's pipe ([`dp_link::sim::Next`], a FIFO that
//! the firmware reads over semihosting while it idles): the simulation's own messages go there
//! whole, the product's go on the link UART after their announcement. The firmware's replies
//! (`Done`, the stack's peak) come back on a second FIFO, the product's writes on the link
//! UART, `Done` saying how many. A byte on the link UART costs QEMU a main-loop turn on its
//! way in and a socket write on its way out, a message on the pipe one host read or write.
//!
//! The drive UART is a second byte stream (QEMU's UART1 on a second socket). The caller reads
//! exactly the bytes [`Handled::drive_tx_bytes`] says were sent, and writes the drive's answers
//! before the `DriveBytes` message that tells the firmware how many have arrived: the lockstep
//! that keeps the drive link on simulated time.

use dp_link::sim::{Next, SimFromAdapter, SimToAdapter};
use dp_link::{FromAdapter, NvContents, NvRecord, Regs, Status, ToAdapter, MAX_FRAME_LEN};
use nv_store::{MemFlash, Store};
use std::fs::File;
use std::io::{self, Read, Write as _};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// A product write from the firmware to the transceiver, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Write {
    Regs(Regs),
    Inputs(Vec<u8>),
    Diag { new: bool, bytes: Vec<u8> },
    Cfg(Vec<u8>),
    Msac1 { request: u32, bytes: Vec<u8> },
    Status(Status),
}

impl Write {
    /// Owns a product message; `None` for Ready.
    pub fn from_message(message: &FromAdapter) -> Option<Write> {
        Some(match *message {
            FromAdapter::Regs(r) => Write::Regs(r),
            FromAdapter::Inputs(b) => Write::Inputs(b.to_vec()),
            FromAdapter::Diag { new, bytes } => Write::Diag {
                new,
                bytes: bytes.to_vec(),
            },
            FromAdapter::Cfg(b) => Write::Cfg(b.to_vec()),
            FromAdapter::Msac1 { request, bytes } => Write::Msac1 {
                request,
                bytes: bytes.to_vec(),
            },
            FromAdapter::Status(s) => Write::Status(s),
            FromAdapter::Ready => return None,
        })
    }

    pub fn as_message(&self) -> FromAdapter<'_> {
        match self {
            Write::Regs(r) => FromAdapter::Regs(*r),
            Write::Inputs(b) => FromAdapter::Inputs(b),
            Write::Diag { new, bytes } => FromAdapter::Diag { new: *new, bytes },
            Write::Cfg(b) => FromAdapter::Cfg(b),
            Write::Msac1 { request, bytes } => FromAdapter::Msac1 {
                request: *request,
                bytes,
            },
            Write::Status(s) => FromAdapter::Status(*s),
        }
    }

    /// Its bytes on the link (COBS frame included).
    pub fn encoded_len(&self) -> usize {
        let mut frame = [0u8; MAX_FRAME_LEN];
        dp_link::encode(&self.as_message(), &mut frame).map_or(MAX_FRAME_LEN, |f| f.len())
    }
}

/// What the firmware did with one event.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Handled {
    /// The writes in order, each with the instructions run when it was sent.
    pub writes: Vec<(u32, Write)>,
    /// How many of them carry the event's decision (the rest follow the drive cycle).
    pub decision_writes: usize,
    /// Instructions until the decision's writes were sent.
    pub decision_instructions: u32,
    /// Instructions until the event was handled.
    pub instructions: u32,
    /// Bytes sent to the drive UART since power-up.
    pub drive_tx_bytes: u32,
    /// Instructions run when the bytes for the drive were handed to its UART, where that was
    /// before the end (0: at the end, after `instructions`).
    pub drive_instructions: u32,
    /// Steps of the drive application's cycle remain: the MCU runs the next one
    /// ([`SimToAdapter::Continue`]) when no event waits.
    pub cycle_pending: bool,
    /// After a [`SimToAdapter::Continue`]: the steps that ran before the last one under its
    /// grant, and their instructions together (they wrote nothing); the fields above are the
    /// last step's.
    pub earlier_steps: u32,
    pub earlier_instructions: u32,
}

/// Something that handles link events.
pub trait Firmware {
    fn exchange(&mut self, message: &ToAdapter) -> io::Result<Handled>;

    /// Power cycle: the firmware starts from reset (it then expects a Boot). Its storage stays.
    fn restart(&mut self) -> io::Result<()>;

    /// The non-volatile storage's pages as the firmware left them (empty: it keeps none).
    fn storage(&mut self) -> io::Result<Vec<u8>> {
        Ok(Vec::new())
    }

    /// Puts `image` in the storage's pages, before the first Boot.
    fn set_storage(&mut self, _image: Vec<u8>) -> io::Result<()> {
        Ok(())
    }

    /// Bytes from the drive into the firmware's drive UART.
    fn drive_send(&mut self, bytes: &[u8]) -> io::Result<()>;

    /// Exactly `n` bytes the firmware wrote to its drive UART, in order.
    fn drive_receive(&mut self, n: usize) -> io::Result<Vec<u8>>;

    /// The deepest the firmware's stack has been since power-up and the room it has, in
    /// bytes, where there is a stack to measure (not in-process).
    fn stack_peak(&mut self) -> io::Result<Option<StackPeak>> {
        Ok(None)
    }
}

/// A stack measurement: bytes used at the deepest, of the room above the statics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StackPeak {
    pub used_bytes: u32,
    pub room_bytes: u32,
}

/// The in-process drive UART: bytes in both directions, and a count of those sent.
#[derive(Debug, Default)]
pub struct MemoryUart {
    rx: std::collections::VecDeque<u8>,
    tx: std::collections::VecDeque<u8>,
    sent: u32,
}

impl embedded_hal_nb::serial::ErrorType for MemoryUart {
    type Error = embedded_hal_nb::serial::ErrorKind;
}

impl embedded_hal_nb::serial::Read<u8> for MemoryUart {
    fn read(&mut self) -> nb::Result<u8, Self::Error> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

impl embedded_hal_nb::serial::Write<u8> for MemoryUart {
    fn write(&mut self, word: u8) -> nb::Result<(), Self::Error> {
        self.tx.push_back(word);
        self.sent = self.sent.wrapping_add(1);
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), Self::Error> {
        Ok(())
    }
}

impl adapter::CountsSent for MemoryUart {
    fn bytes_sent(&self) -> u32 {
        self.sent
    }
}

/// The adapter crate in-process: the firmware's logic without the RTIC shell (cycles are 0),
/// its storage in memory, written as the firmware's `nv` module writes it.
pub struct InProcess {
    adapter: Option<adapter::Adapter<adapter::DriveApp<MemoryUart>>>,
    storage: MemFlash,
}

impl Default for InProcess {
    fn default() -> InProcess {
        InProcess {
            adapter: None,
            storage: MemFlash::erased(NV_STORAGE_PAGES),
        }
    }
}

/// The storage's pages (the board's, crates/board).
const NV_STORAGE_PAGES: usize = board::NV_STORAGE_PAGES as usize;

/// The storage over `flash`, as the firmware opens it.
pub fn nv_store(flash: MemFlash) -> Store<MemFlash> {
    Store::new(flash, 0..board::NV_STORAGE_BYTES)
}

/// What a storage image holds (an empty image: nothing).
pub fn nv_contents(image: &[u8]) -> NvContents {
    if image.is_empty() {
        return NvContents::default();
    }
    nv_store(MemFlash {
        bytes: image.to_vec(),
    })
    .load()
}

/// A storage image holding `address` (or nothing), as a board's storage would.
pub fn nv_image(address: Option<NvRecord>) -> Vec<u8> {
    let mut store = nv_store(MemFlash::erased(NV_STORAGE_PAGES));
    if let Some(record) = address {
        store
            .write_address(record)
            .expect("an empty storage takes a record");
    }
    store.into_flash().bytes
}

/// The file of the storage's pages in QEMU's working directory (the firmware's `nv` module
/// opens it by this name).
pub const NV_STORAGE_FILE: &str = "nv-storage.bin";

impl InProcess {
    pub fn new() -> InProcess {
        InProcess::default()
    }

    fn uart(&mut self) -> io::Result<&mut MemoryUart> {
        let adapter = self
            .adapter
            .as_mut()
            .ok_or_else(|| io::Error::other("drive bytes before Boot"))?;
        Ok(adapter.app_mut().drive_mut().master_mut().uart_mut())
    }
}

impl Firmware for InProcess {
    fn exchange(&mut self, message: &ToAdapter) -> io::Result<Handled> {
        if let ToAdapter::Boot { switch, .. } = *message {
            let app = adapter::drive_app(MemoryUart::default());
            let contents = nv_store(self.storage.clone()).load();
            self.adapter = Some(adapter::Adapter::boot(switch, contents, app));
        }
        let adapter = self
            .adapter
            .as_mut()
            .ok_or_else(|| io::Error::other("message before Boot"))?;
        let mut handled = Handled::default();
        // Cells: a grant's steps look at the writes between steps, while the closure adds them.
        let writes = std::cell::RefCell::new(Vec::new());
        let decision_writes = std::cell::Cell::new(0);
        let mut out = |out: adapter::Out| match out {
            adapter::Out::Write(write) => writes
                .borrow_mut()
                .extend(Write::from_message(&write).map(|w| (0, w))),
            adapter::Out::DecisionWritten => decision_writes.set(writes.borrow().len()),
            adapter::Out::DriveQueued => {}
        };
        match message {
            // As the firmware runs a grant's steps, each one 0 instructions.
            ToAdapter::Sim(SimToAdapter::Continue(grant)) => loop {
                let drive_before = adapter::Background::drive_tx_bytes(adapter.app());
                adapter.cycle_step(&mut out);
                let wrote = !writes.borrow().is_empty()
                    || adapter::Background::drive_tx_bytes(adapter.app()) != drive_before;
                if !adapter.cycle_pending() || !grant.allows_another(0, wrote) {
                    break;
                }
                handled.earlier_steps += 1;
            },
            ToAdapter::Sim(SimToAdapter::DriveBytes { now_us, .. }) => {
                adapter.drive_answer(*now_us);
            }
            _ => {
                adapter.decide(message, &mut out);
            }
        }
        handled.writes = writes.into_inner();
        let nv_write = handled.writes.iter().rev().find_map(|(_, w)| match w {
            Write::Status(status) => status.nv_write,
            _ => None,
        });
        if let Some(write) = nv_write {
            let mut store = nv_store(self.storage.clone());
            store
                .carry_out(write, adapter.nv_params())
                .map_err(|e| io::Error::other(format!("storage: {e:?}")))?;
            self.storage = store.into_flash();
        }
        handled.decision_writes = decision_writes.get();
        handled.cycle_pending = adapter.cycle_pending();
        handled.drive_tx_bytes = adapter::Background::drive_tx_bytes(adapter.app());
        Ok(handled)
    }

    fn restart(&mut self) -> io::Result<()> {
        self.adapter = None;
        Ok(())
    }

    fn storage(&mut self) -> io::Result<Vec<u8>> {
        Ok(self.storage.bytes.clone())
    }

    fn set_storage(&mut self, image: Vec<u8>) -> io::Result<()> {
        self.storage = if image.is_empty() {
            MemFlash::erased(NV_STORAGE_PAGES)
        } else {
            MemFlash { bytes: image }
        };
        Ok(())
    }

    fn drive_send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.uart()?.rx.extend(bytes);
        Ok(())
    }

    fn drive_receive(&mut self, n: usize) -> io::Result<Vec<u8>> {
        let uart = self.uart()?;
        if uart.tx.len() < n {
            return Err(io::Error::other(format!(
                "{n} drive bytes announced, {} written",
                uart.tx.len()
            )));
        }
        Ok(uart.tx.drain(..n).collect())
    }
}

/// QEMU's instruction counting: one instruction a count, time never waits for the host.
const ICOUNT: &str = "shift=7,align=off,sleep=off";
/// The same, but QEMU sleeps while the guest waits for an interrupt.
const ICOUNT_REALTIME: &str = "shift=7,align=off,sleep=on";

/// The simulation's pipe, two FIFOs in QEMU's working directory (the firmware's `sim_pipe`
/// opens them by these names): hal-sim's announcements, and the firmware's replies.
pub const SIM_PIPE_NEXT: &str = "sim-next.fifo";
pub const SIM_PIPE_REPLIES: &str = "sim-replies.fifo";

/// How often a wait for a reply looks whether QEMU is still there: the replies' FIFO stays open
/// here (for reading and writing, so that neither side's open waits), so QEMU's end closing
/// never ends the wait.
const LIVENESS_POLL: Duration = Duration::from_millis(100);

/// How long a reply may take in wall time before the run is declared hung.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(20);

/// The firmware image running in `qemu-system-arm`; killed when dropped.
pub struct Qemu {
    qemu: PathBuf,
    elf: PathBuf,
    /// The QEMU machine, for a restart.
    machine: String,
    /// `-icount`'s value, for a restart.
    icount: String,
    /// defmt bytes of earlier power cycles, each run's stream decoded on its own.
    earlier_runs: Vec<Vec<u8>>,
    child: Child,
    link: UnixStream,
    drive: UnixStream,
    /// The simulation's pipe, and the directory that holds it (QEMU's working directory),
    /// removed when dropped; the bytes of replies read past the last frame.
    next: File,
    replies: File,
    replies_pending: Vec<u8>,
    _pipe_dir: tempfile::TempDir,
    pending: Vec<u8>,
    defmt: Arc<Mutex<Vec<u8>>>,
    stdout_reader: Option<JoinHandle<()>>,
}

impl Qemu {
    /// The CPU time QEMU has used (user and system), from `/proc` (Linux, whose clock ticks
    /// there are always 1/100 s).
    pub fn cpu_seconds(&self) -> Option<f64> {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id())).ok()?;
        // The fields after the command's closing parenthesis; utime and stime are the 14th
        // and 15th of the line, the 12th and 13th after it.
        let rest = &stat[stat.rfind(')')? + 1..];
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let ticks: u64 =
            fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
        Some(ticks as f64 / 100.0)
    }

    /// Starts QEMU with `elf` on `machine` (a board's `Runs::Qemu`), its first serial port (the
    /// link) and its second (the drive link) connected to fresh Unix sockets, `-icount
    /// shift=7` so that the firmware's cycle counts repeat run to run.
    pub fn start(qemu: &Path, elf: &Path, machine: &str) -> io::Result<Qemu> {
        Qemu::start_with(qemu, elf, machine, ICOUNT, Vec::new())
    }

    /// As [`Qemu::start`], for a run on the wall clock (`qemu-run`): QEMU sleeps while the
    /// firmware waits for an interrupt instead of spinning (66 % of a core idle, 7 % with
    /// this), and the counts still come from `-icount`.
    pub fn start_realtime(qemu: &Path, elf: &Path, machine: &str) -> io::Result<Qemu> {
        Qemu::start_with(qemu, elf, machine, ICOUNT_REALTIME, Vec::new())
    }

    /// `storage`: the storage's pages, in place before the firmware runs (empty: erased).
    fn start_with(
        qemu: &Path,
        elf: &Path,
        machine: &str,
        icount: &str,
        storage: Vec<u8>,
    ) -> io::Result<Qemu> {
        let pipe_dir = tempfile::Builder::new().prefix("hal-sim-").tempdir()?;
        // Unix sockets for the UARTs: QEMU writes a UART's bytes one at a time, and a byte
        // through the loopback's TCP stack cost several times as much.
        let link_path = pipe_dir.path().join("link.sock");
        let drive_path = pipe_dir.path().join("drive.sock");
        let listener = UnixListener::bind(&link_path)?;
        let drive_listener = UnixListener::bind(&drive_path)?;
        let fifo = |name: &str| -> io::Result<File> {
            let path = pipe_dir.path().join(name);
            nix::unistd::mkfifo(&path, nix::sys::stat::Mode::S_IRWXU).map_err(io::Error::from)?;
            // Read and write: opening a FIFO for one end alone waits for the other, and with
            // both ends held here the firmware's open never waits either.
            std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(&path)
        };
        write_storage(pipe_dir.path(), storage)?;
        let next = fifo(SIM_PIPE_NEXT)?;
        let replies = fifo(SIM_PIPE_REPLIES)?;
        // The image by its full path: QEMU runs in the pipe's directory.
        let elf = std::path::absolute(elf)?;
        let mut child = Command::new(qemu)
            .args([
                "-machine",
                machine,
                "-cpu",
                "cortex-m3",
                "-display",
                "none",
                "-monitor",
                "none",
                "-chardev",
                &format!("socket,id=link,path={}", link_path.display()),
                "-serial",
                "chardev:link",
                // UART1: the drive link.
                "-chardev",
                &format!("socket,id=drive,path={}", drive_path.display()),
                "-serial",
                "chardev:drive",
                "-semihosting-config",
                "enable=on,target=native",
                "-icount",
                &std::env::var("HALSIM_ICOUNT").unwrap_or_else(|_| icount.into()),
                "-kernel",
            ])
            .arg(&elf)
            .current_dir(pipe_dir.path())
            // More QEMU arguments, for a profile: `-d in_asm,exec,nochain -D /tmp/qemu.log`
            // logs every translated block and each run of one, enough to count instructions
            // per function (a full path: QEMU runs in the pipe's directory, removed after).
            .args(
                std::env::var("HALSIM_QEMU_EXTRA")
                    .map(|v| v.split_whitespace().map(String::from).collect::<Vec<_>>())
                    .unwrap_or_default(),
            )
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let link = accept(&listener, &mut child, "link")?;
        let drive = accept(&drive_listener, &mut child, "drive")?;
        for stream in [&link, &drive] {
            stream.set_nonblocking(false)?;
            stream.set_read_timeout(Some(REPLY_TIMEOUT))?;
        }
        let defmt = Arc::new(Mutex::new(Vec::new()));
        let mut stdout = child.stdout.take().expect("piped stdout");
        let sink = defmt.clone();
        let stdout_reader = std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = stdout.read(&mut buf) {
                if n == 0 {
                    break;
                }
                sink.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        });
        let mut qemu = Qemu {
            qemu: qemu.to_path_buf(),
            elf: elf.to_path_buf(),
            machine: machine.to_string(),
            icount: icount.to_string(),
            earlier_runs: Vec::new(),
            child,
            link,
            drive,
            next,
            replies,
            replies_pending: Vec::new(),
            _pipe_dir: pipe_dir,
            pending: Vec::new(),
            defmt,
            stdout_reader: Some(stdout_reader),
        };
        qemu.wait_ready()?;
        Ok(qemu)
    }

    /// The raw defmt bytes QEMU printed so far.
    pub fn defmt_bytes(&self) -> Vec<u8> {
        self.defmt.lock().unwrap().clone()
    }

    /// Whether QEMU has exited, and how.
    pub fn exit_status(&mut self) -> io::Result<Option<std::process::ExitStatus>> {
        self.child.try_wait()
    }

    /// Waits up to `timeout` (wall time) for QEMU to exit on its own.
    pub fn wait_exit(&mut self, timeout: Duration) -> io::Result<Option<std::process::ExitStatus>> {
        let start = std::time::Instant::now();
        loop {
            if let Some(status) = self.child.try_wait()? {
                return Ok(Some(status));
            }
            if start.elapsed() > timeout {
                return Ok(None);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Stops QEMU and returns the defmt stream of every run since the first start, one per
    /// power cycle.
    pub fn stop(mut self) -> Vec<Vec<u8>> {
        self.kill_and_collect();
        std::mem::take(&mut self.earlier_runs)
    }

    fn kill_and_collect(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(reader) = self.stdout_reader.take() {
            let _ = reader.join();
        }
        let bytes = std::mem::take(&mut *self.defmt.lock().unwrap());
        self.earlier_runs.push(bytes);
    }

    /// Waits for the firmware's Ready: its link is up.
    fn wait_ready(&mut self) -> io::Result<()> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        match self.read_message(&mut frame)? {
            Some(FromAdapter::Ready) => Ok(()),
            _ => Err(io::Error::other("a message before Ready")),
        }
    }

    /// The next message, decoded into `frame`'s copy (`None`: a frame that did not decode).
    fn read_message<'f>(
        &mut self,
        frame: &'f mut [u8; MAX_FRAME_LEN],
    ) -> io::Result<Option<FromAdapter<'f>>> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        loop {
            // One whole frame (up to its zero) out of what arrived, if there is one.
            if let Some(end) = self.pending.iter().position(|b| *b == 0) {
                let len = end + 1;
                if len > MAX_FRAME_LEN {
                    self.pending.drain(..len);
                    return Ok(None);
                }
                frame[..len].copy_from_slice(&self.pending[..len]);
                self.pending.drain(..len);
                // Decoded in place: the message borrows the caller's frame.
                return Ok(postcard::from_bytes_cobs::<FromAdapter>(&mut frame[..len]).ok());
            }
            let n = self.link.read(&mut buf).map_err(|e| {
                io::Error::new(
                    e.kind(),
                    format!(
                        "no message from the firmware within {} s ({e}); {} bytes of a frame had arrived",
                        REPLY_TIMEOUT.as_secs(),
                        self.pending.len()
                    ),
                )
            })?;
            if n == 0 {
                return Err(io::Error::other(
                    "QEMU closed the link (the firmware exited)",
                ));
            }
            self.pending.extend_from_slice(&buf[..n]);
        }
    }
}

impl Qemu {
    /// Hands `message` to the firmware: the simulation's own on the pipe, the product's on the
    /// link UART after their announcement there.
    fn send(&mut self, message: &ToAdapter) -> io::Result<()> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let next = match *message {
            ToAdapter::Sim(sim) => Next::Sim(sim),
            _ => {
                let bytes = dp_link::encode(message, &mut frame)
                    .map_err(|_| io::Error::other("message does not fit a frame"))?;
                self.link.write_all(bytes)?;
                Next::OnLink
            }
        };
        let bytes = dp_link::encode(&next, &mut frame)
            .map_err(|_| io::Error::other("announcement does not fit a frame"))?;
        // One write: a FIFO keeps a write of up to PIPE_BUF bytes whole.
        self.next.write_all(bytes)
    }

    /// The firmware's next reply on the pipe, waiting up to [`REPLY_TIMEOUT`] and failing at
    /// once if QEMU exits.
    fn reply(&mut self) -> io::Result<SimFromAdapter> {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        use std::os::fd::AsFd as _;
        let start = std::time::Instant::now();
        loop {
            if let Some(end) = self.replies_pending.iter().position(|b| *b == 0) {
                let mut frame: Vec<u8> = self.replies_pending.drain(..=end).collect();
                return dp_link::decode::<SimFromAdapter>(&mut frame)
                    .map_err(|_| io::Error::other("a reply on the pipe that does not decode"));
            }
            let mut fds = [PollFd::new(self.replies.as_fd(), PollFlags::POLLIN)];
            let timeout = PollTimeout::try_from(LIVENESS_POLL).expect("a short timeout");
            if poll(&mut fds, timeout).map_err(io::Error::from)? == 0 {
                if let Some(status) = self.child.try_wait()? {
                    // QEMU's own words (an abort names its cause there).
                    let mut err = String::new();
                    if let Some(mut e) = self.child.stderr.take() {
                        let _ = e.read_to_string(&mut err);
                    }
                    return Err(io::Error::other(format!(
                        "QEMU exited ({status}) before the firmware replied: {}",
                        err.trim()
                    )));
                }
                if start.elapsed() > REPLY_TIMEOUT {
                    return Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        format!(
                            "no reply from the firmware within {} s; {} bytes of one had arrived",
                            REPLY_TIMEOUT.as_secs(),
                            self.replies_pending.len()
                        ),
                    ));
                }
                continue;
            }
            let mut buf = [0u8; 64];
            let n = self.replies.read(&mut buf)?;
            self.replies_pending.extend_from_slice(&buf[..n]);
        }
    }
}

impl Firmware for Qemu {
    fn exchange(&mut self, message: &ToAdapter) -> io::Result<Handled> {
        self.send(message)?;
        let context = |e: io::Error| io::Error::new(e.kind(), format!("event {message:?}: {e}"));
        let reply = self.reply().map_err(context)?;
        let SimFromAdapter::Done {
            link_frames,
            drive_instructions,
            earlier_steps,
            earlier_instructions,
            decision_instructions,
            decision_writes,
            instructions,
            drive_tx_bytes,
            cycle_pending,
        } = reply
        else {
            return Err(context(io::Error::other(format!(
                "{reply:?} instead of Done"
            ))));
        };
        let mut writes = Vec::with_capacity(link_frames as usize);
        for _ in 0..link_frames {
            let mut frame = [0u8; MAX_FRAME_LEN];
            match self.read_message(&mut frame).map_err(context)? {
                Some(FromAdapter::Ready) => {
                    return Err(io::Error::other("Ready again: the firmware restarted"))
                }
                Some(other) => writes.extend(Write::from_message(&other)),
                None => {
                    return Err(context(io::Error::other("a frame that does not decode")));
                }
            }
        }
        let decision_writes = (decision_writes as usize).min(writes.len());
        Ok(Handled {
            writes: writes
                .into_iter()
                .enumerate()
                .map(|(i, w)| {
                    let at = if i < decision_writes {
                        decision_instructions
                    } else {
                        instructions
                    };
                    (at, w)
                })
                .collect(),
            decision_writes,
            decision_instructions,
            instructions,
            drive_tx_bytes,
            drive_instructions,
            cycle_pending,
            earlier_steps: u32::from(earlier_steps),
            earlier_instructions,
        })
    }

    fn restart(&mut self) -> io::Result<()> {
        self.restart_process()
    }

    fn storage(&mut self) -> io::Result<Vec<u8>> {
        match std::fs::read(self._pipe_dir.path().join(NV_STORAGE_FILE)) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Vec::new()),
            other => other,
        }
    }

    fn set_storage(&mut self, image: Vec<u8>) -> io::Result<()> {
        write_storage(self._pipe_dir.path(), image)
    }

    fn stack_peak(&mut self) -> io::Result<Option<StackPeak>> {
        self.send(&ToAdapter::Sim(SimToAdapter::StackPeak))?;
        match self.reply()? {
            SimFromAdapter::StackPeak {
                used_bytes,
                room_bytes,
            } => Ok(Some(StackPeak {
                used_bytes,
                room_bytes,
            })),
            other => Err(io::Error::other(format!(
                "asked for the stack peak, got {other:?}"
            ))),
        }
    }

    fn drive_send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.drive.write_all(bytes)
    }

    fn drive_receive(&mut self, n: usize) -> io::Result<Vec<u8>> {
        let mut bytes = vec![0u8; n];
        self.drive
            .read_exact(&mut bytes)
            .map_err(|e| io::Error::new(e.kind(), format!("{n} bytes from the drive UART: {e}")))?;
        Ok(bytes)
    }
}

/// The storage's file in QEMU's directory: `image`, or erased pages where it is empty.
fn write_storage(dir: &Path, image: Vec<u8>) -> io::Result<()> {
    let image = if image.is_empty() {
        MemFlash::erased(NV_STORAGE_PAGES).bytes
    } else {
        image
    };
    std::fs::write(dir.join(NV_STORAGE_FILE), image)
}

/// The connection QEMU makes for one chardev, or why it never came.
fn accept(listener: &UnixListener, child: &mut Child, name: &str) -> io::Result<UnixStream> {
    listener.set_nonblocking(true)?;
    let start = std::time::Instant::now();
    loop {
        match listener.accept() {
            Ok((stream, _)) => return Ok(stream),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if let Some(status) = child.try_wait()? {
                    let mut err = String::new();
                    if let Some(mut e) = child.stderr.take() {
                        let _ = e.read_to_string(&mut err);
                    }
                    return Err(io::Error::other(format!("QEMU exited ({status}): {err}")));
                }
                if start.elapsed() > REPLY_TIMEOUT {
                    let _ = child.kill();
                    return Err(io::Error::other(format!(
                        "QEMU never connected to the {name} socket"
                    )));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e),
        }
    }
}

impl Qemu {
    fn restart_process(&mut self) -> io::Result<()> {
        self.kill_and_collect();
        // The storage outlives the power cycle: its file goes into the fresh directory before
        // the firmware starts.
        let storage = Firmware::storage(self)?;
        let earlier = std::mem::take(&mut self.earlier_runs);
        let fresh = Qemu::start_with(&self.qemu, &self.elf, &self.machine, &self.icount, storage)?;
        // Swap the fresh process in; the old (already dead) one is dropped with `fresh`.
        let old = std::mem::replace(self, fresh);
        drop(old);
        self.earlier_runs = earlier;
        Ok(())
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
