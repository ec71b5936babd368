//! The transceiver's DP responder against the firmware's own answers.
//!
//! Two slaves see the same requests in the same order: the reference is `dp_slave::Slave`
//! answering each request itself (what the firmware computed before the responder existed);
//! the other is the product's path: the responder answers from the buffers that the adapter
//! (the firmware's logic, `adapter::Adapter`) wrote after each event it was handed. Every
//! answer must be the same bytes. The link is ideal here (events and writes arrive at once);
//! the last test shows what a slow link changes (RR while a decision is on its way).

use adapter::{Adapter, Out};
use dp_consts::Baud;
use dp_link::ToAdapter;
use dp_phy::responder::{Input, Responder, DECISION_CLOCKS};
use dp_phy::station::StationRx;
use dp_phy::testbench::Testbench;
use dp_phy::{BitTiming, Tick};
use dp_slave::testing::EchoApp;
use dp_slave::{Config, Instant, Slave};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, Sap};

const CLOCK_HZ: u32 = 48_000_000;
const MASTER: u8 = 2;
const OTHER_MASTER: u8 = 3;
const PPO1: &[u8] = &[0xF3, 0xF1];
const PPO3: &[u8] = &[0xF1];

/// The application on both sides: the test's EchoApp for everything but the inputs, which are
/// the drive's values the test sets (`Plant::inputs`), not a function of the outputs just
/// received. A Data_Exchange answered from a buffer carries the inputs the firmware wrote
/// before the request arrived, as on an SPC3/VPC3+; an application that computed its inputs
/// from the same request's outputs would see them one cycle later.
#[derive(Clone, Debug, Default)]
struct Plant {
    echo: EchoApp,
    inputs: Vec<u8>,
    /// Set_Prm carries DPV1_Status_1-3.
    dpv1: bool,
}

impl dp_slave::Application for Plant {
    fn accept_user_prm(&mut self, user_prm: &[u8]) -> bool {
        self.echo.accept_user_prm(user_prm)
    }
    fn accept_cfg(&mut self, cfg: &[u8]) -> Option<dp_slave::IoSizes> {
        self.echo.accept_cfg(cfg)
    }
    fn default_cfg(&self) -> &[u8] {
        self.echo.default_cfg()
    }
    fn outputs(&mut self, now: Instant, outputs: &[u8]) {
        self.echo.outputs(now, outputs)
    }
    fn inputs(&mut self, _: Instant, inputs: &mut [u8]) {
        for (i, byte) in inputs.iter_mut().enumerate() {
            *byte = self.inputs.get(i).copied().unwrap_or(0);
        }
    }
    fn fail_safe(&mut self, now: Instant, reason: dp_slave::FailSafeReason) {
        self.echo.fail_safe(now, reason)
    }
    fn ext_diag(&mut self, buffer: &mut [u8]) -> usize {
        self.echo.ext_diag(buffer)
    }
    fn diag_changed(&mut self) -> bool {
        self.echo.diag_changed()
    }
    fn static_diag(&self) -> bool {
        self.echo.static_diag()
    }
    fn store_address(&mut self, address: u8, no_add_chg: bool) {
        self.echo.store_address(address, no_add_chg)
    }
    fn msac1(&mut self, now: Instant, request: &dp_slave::msac1::Request, out: &mut [u8]) -> usize {
        self.echo.msac1(now, request, out)
    }
}

impl adapter::Background for Plant {
    fn dpv1_mode(&self) -> bool {
        self.dpv1
    }
}

fn app() -> Plant {
    Plant {
        echo: EchoApp {
            accepted_cfgs: &[PPO1, PPO3],
            default_cfg: PPO1,
            ..EchoApp::default()
        },
        inputs: (0x40..0x40 + 12).collect(),
        dpv1: false,
    }
}

/// The reference slave and the product's path, fed the same requests.
struct Pair {
    reference: Slave<Plant>,
    adapter: Adapter<Plant>,
    responder: Responder,
    now_us: u64,
    /// Events handed to the adapter, and outputs among them.
    forwarded: Vec<Vec<u8>>,
    /// When false, events wait in `queue` (a slow link).
    deliver: bool,
    queue: Vec<ToAdapterOwned>,
}

#[derive(Clone, Debug)]
enum ToAdapterOwned {
    Telegram(u32, Vec<u8>),
    Watchdog(u32),
}

impl Pair {
    fn new(switch: u8) -> Pair {
        Pair::with(switch, false)
    }

    /// `dpv1`: Set_Prm carries DPV1_Status_1-3 on both sides.
    fn with(switch: u8, dpv1: bool) -> Pair {
        let app = Plant { dpv1, ..app() };
        let adapter = Adapter::boot(switch, Default::default(), app.clone());
        let a = adapter.addressing();
        let reference = Slave::new(
            Config {
                address: a.address,
                ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
                no_add_chg: a.no_add_chg,
                dpv1_status_bytes: dpv1,
            },
            app,
        );
        let mut responder = Responder::new(CLOCK_HZ);
        let seq = responder.next_event();
        let mut pair = Pair {
            reference,
            adapter,
            responder,
            now_us: 0,
            forwarded: Vec::new(),
            deliver: true,
            queue: Vec::new(),
        };
        pair.handle(&ToAdapter::Boot {
            seq,
            now_us: 0,
            switch,
        });
        pair
    }

    fn ticks(&self) -> Tick {
        self.now_us * Tick::from(CLOCK_HZ / 1_000_000)
    }

    /// The adapter handles an event; its writes go to the responder.
    fn handle(&mut self, message: &ToAdapter) {
        let now = self.ticks();
        let responder = &mut self.responder;
        self.adapter.handle(message, &mut |out| {
            if let Out::Write(write) = out {
                responder.step(&Input::Write { now, write: &write });
            }
        });
    }

    fn deliver_queue(&mut self) {
        for event in std::mem::take(&mut self.queue) {
            match event {
                ToAdapterOwned::Telegram(seq, bytes) => self.handle(&ToAdapter::Telegram {
                    seq,
                    now_us: self.now_us,
                    baud: 6,
                    bytes: &bytes,
                }),
                ToAdapterOwned::Watchdog(seq) => self.handle(&ToAdapter::WatchdogExpired {
                    seq,
                    now_us: self.now_us,
                }),
            }
        }
    }

    /// `bytes` to both at `now_us` (+1 ms each call); returns both answers.
    fn both(&mut self, bytes: &[u8]) -> (Option<Vec<u8>>, Option<Vec<u8>>) {
        self.now_us += 1000;
        self.answers(bytes)
    }

    /// `bytes` to both at `now_us`; returns both answers.
    fn answers(&mut self, bytes: &[u8]) -> (Option<Vec<u8>>, Option<Vec<u8>>) {
        let mut buf = [0u8; 256];
        let reference = self
            .reference
            .handle(Instant::from_micros(self.now_us), bytes, &mut buf)
            .map(|n| buf[..n].to_vec());
        let out = self.responder.step(&Input::Clock { now: self.ticks() });
        if let Some(seq) = out.watchdog_expired {
            self.queue.push(ToAdapterOwned::Watchdog(seq));
        }
        let out = self.responder.step(&Input::Telegram {
            now: self.ticks(),
            bytes,
        });
        let answer = out.response().map(<[u8]>::to_vec);
        if let Some(seq) = out.forward {
            self.forwarded.push(bytes.to_vec());
            self.queue
                .push(ToAdapterOwned::Telegram(seq, bytes.to_vec()));
        }
        if self.deliver {
            self.deliver_queue();
        }
        (reference, answer)
    }

    /// Sends `bytes` to both and asserts the same answer; returns it.
    fn same(&mut self, what: &str, bytes: &[u8]) -> Option<Vec<u8>> {
        let (reference, answer) = self.both(bytes);
        assert_eq!(answer, reference, "{what}: responder vs firmware");
        answer
    }

    /// The drive's values change: both applications see them, and the adapter writes them on
    /// its next event (a wake-up here), as the firmware does after its drive cycle.
    fn set_inputs(&mut self, inputs: &[u8]) {
        self.reference.app_mut().inputs = inputs.to_vec();
        self.adapter.app_mut().inputs = inputs.to_vec();
        let seq = self.responder.next_event();
        self.handle(&ToAdapter::Timer {
            seq,
            now_us: self.now_us,
        });
    }

    /// Time passes: the reference polls its watchdog, the responder its own.
    fn wait_ms(&mut self, ms: u64) {
        self.now_us += ms * 1000;
        self.reference.poll(Instant::from_micros(self.now_us));
        let out = self.responder.step(&Input::Clock { now: self.ticks() });
        if let Some(seq) = out.watchdog_expired {
            self.queue.push(ToAdapterOwned::Watchdog(seq));
        }
        if self.deliver {
            self.deliver_queue();
        }
    }
}

/// A request from `sa` to `da`, framed by fdl.
fn request(da: u8, sa: u8, sap: Option<Sap>, fcb: bool, fcv: bool, payload: &[u8]) -> Vec<u8> {
    let repr = Repr::Data(DataRepr {
        da,
        sa,
        dsap: sap,
        ssap: sap.map(|_| Sap::MASTER_MS0),
        fc: FrameControl::Request {
            fcb,
            fcv,
            function: if sap.is_none() {
                RequestFunction::SrdHigh
            } else {
                RequestFunction::SrdLow
            },
        },
        payload,
    });
    let mut bytes = vec![0; repr.buffer_len()];
    repr.emit(&mut bytes).unwrap();
    bytes
}

fn fdl_status(da: u8) -> Vec<u8> {
    let repr = Repr::Data(DataRepr {
        da,
        sa: MASTER,
        dsap: None,
        ssap: None,
        fc: FrameControl::Request {
            fcb: false,
            fcv: false,
            function: RequestFunction::FdlStatus,
        },
        payload: &[],
    });
    let mut bytes = vec![0; repr.buffer_len()];
    repr.emit(&mut bytes).unwrap();
    bytes
}

/// Station status: Lock_Req, WD_On, Freeze_Req, Sync_Req; WD 10 x 10 x 10 ms.
fn set_prm_payload(status: u8, ident: u16) -> Vec<u8> {
    let [hi, lo] = ident.to_be_bytes();
    vec![status, 10, 10, 11, hi, lo, 0x01]
}

const LOCK_WD_FREEZE_SYNC: u8 = 0x80 | 0x08 | 0x10 | 0x20;

/// A master's requests, each with its own FCB toggling.
struct Requests {
    sa: u8,
    fcb: bool,
    first: bool,
}

impl Requests {
    fn new(sa: u8) -> Requests {
        Requests {
            sa,
            fcb: true,
            first: true,
        }
    }

    fn next(&mut self, da: u8, sap: Option<Sap>, payload: &[u8]) -> Vec<u8> {
        let t = request(da, self.sa, sap, self.fcb, !self.first, payload);
        self.first = false;
        self.fcb = !self.fcb;
        t
    }

    /// The last request again, as a master repeats it after a lost response.
    fn repeat(&mut self, da: u8, sap: Option<Sap>, payload: &[u8]) -> Vec<u8> {
        self.fcb = !self.fcb;
        self.next(da, sap, payload)
    }
}

#[test]
fn every_service_answers_as_the_firmware_would() {
    let mut p = Pair::new(8);
    let mut m = Requests::new(MASTER);
    let mut other = Requests::new(OTHER_MASTER);
    let ident = dp_consts::ADAPTER_IDENT_NUMBER;

    p.same("FDL_Status", &fdl_status(8));
    p.same(
        "Slave_Diag at power-up",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "Get_Cfg before Chk_Cfg",
        &m.next(8, Some(Sap::GET_CFG), &[]),
    );
    p.same("Data_Exchange before Set_Prm", &m.next(8, None, &[1; 12]));
    p.same("Rd_Inp before Set_Prm", &m.next(8, Some(Sap::RD_INP), &[]));
    p.same(
        "Rd_Outp before Set_Prm",
        &m.next(8, Some(Sap::RD_OUTP), &[]),
    );
    p.same(
        "Set_Prm, wrong ident",
        &m.next(8, Some(Sap::SET_PRM), &set_prm_payload(0x88, ident ^ 1)),
    );
    p.same(
        "Slave_Diag after Prm_Fault",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    let prm = set_prm_payload(LOCK_WD_FREEZE_SYNC, ident);
    p.same("Set_Prm", &m.next(8, Some(Sap::SET_PRM), &prm));
    p.same(
        "Slave_Diag in Wait_Cfg",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same("Chk_Cfg refused", &m.next(8, Some(Sap::CHK_CFG), &[0x13]));
    p.same(
        "Slave_Diag after Cfg_Fault",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same("Set_Prm again", &m.next(8, Some(Sap::SET_PRM), &prm));
    p.same("Chk_Cfg PPO1", &m.next(8, Some(Sap::CHK_CFG), PPO1));
    p.same(
        "Slave_Diag in Data_Exch",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same("Get_Cfg in Data_Exch", &m.next(8, Some(Sap::GET_CFG), &[]));
    let outputs: Vec<u8> = (1..=12).collect();
    p.same("Data_Exchange", &m.next(8, None, &outputs));
    p.set_inputs(&[0x11; 12]);
    p.same(
        "Data_Exchange repeated (same FCB)",
        &m.repeat(8, None, &outputs),
    );
    p.same("Data_Exchange with new inputs", &m.next(8, None, &outputs));
    p.same("Rd_Inp", &m.next(8, Some(Sap::RD_INP), &[]));
    p.same("Rd_Outp", &m.next(8, Some(Sap::RD_OUTP), &[]));
    p.same(
        "Slave_Diag from another master (Master_Lock)",
        &other.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "Set_Prm from another master while locked",
        &other.next(8, Some(Sap::SET_PRM), &prm),
    );
    p.same(
        "Data_Exchange from another master",
        &other.next(8, None, &outputs),
    );
    p.same(
        "Global_Control Freeze",
        &m.next(8, Some(Sap::GLOBAL_CONTROL), &[0x08, 0x00]),
    );
    p.set_inputs(&[0x22; 12]);
    p.same("Data_Exchange under Freeze", &m.next(8, None, &[7; 12]));
    p.same(
        "Global_Control too short",
        &m.next(8, Some(Sap::GLOBAL_CONTROL), &[0x08]),
    );
    p.same(
        "Global_Control Unfreeze",
        &m.next(8, Some(Sap::GLOBAL_CONTROL), &[0x04, 0x00]),
    );
    p.same("Data_Exchange after Unfreeze", &m.next(8, None, &[9; 12]));
    p.set_inputs(&[0x33; 12]);
    p.same(
        "Data_Exchange with the live inputs",
        &m.next(8, None, &[9; 12]),
    );
    p.same(
        "Clear_Data by an empty Data_Exchange",
        &m.next(8, None, &[]),
    );
    p.same(
        "Ext_User_Prm (not activated)",
        &m.next(8, Some(Sap(53)), &[1]),
    );
    p.same(
        "DP-V1 SAP 51 (not activated)",
        &m.next(8, Some(Sap(51)), &[0x5E, 0, 0, 4]),
    );
    p.same(
        "Set_Slave_Add with the switch set",
        &m.next(8, Some(Sap::SET_SLAVE_ADD), &[9, 0xD7, 0xA1, 0]),
    );
    p.same(
        "Data_Exchange of the wrong length",
        &m.next(8, None, &[1; 3]),
    );
    p.same(
        "Slave_Diag after it",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "for another station",
        &m.next(9, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "broadcast Global_Control",
        &request(
            127,
            MASTER,
            Some(Sap::GLOBAL_CONTROL),
            false,
            false,
            &[0, 0],
        ),
    );
}

#[test]
fn diagnosis_high_until_the_owner_reads_it() {
    let mut p = Pair::new(8);
    let mut m = Requests::new(MASTER);
    let prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
    p.same("Set_Prm", &m.next(8, Some(Sap::SET_PRM), &prm));
    p.same("Chk_Cfg", &m.next(8, Some(Sap::CHK_CFG), PPO3));
    // The application flags a new diagnosis with extended bytes; the adapter writes it on its
    // next event (a wake-up here), as the firmware does.
    for app in [p.reference.app_mut(), p.adapter.app_mut()] {
        app.echo
            .ext_diag
            .extend_from_slice(&[0x03, 0x01, 0x02])
            .unwrap();
        app.echo.diag_changed = true;
    }
    let seq = p.responder.next_event();
    p.handle(&ToAdapter::Timer {
        seq,
        now_us: p.now_us,
    });
    let dh = p.same(
        "Data_Exchange with new diagnosis",
        &m.next(8, None, &[1, 2, 3, 4]),
    );
    let dh = Repr::parse_bytes(dh.as_deref().unwrap()).unwrap().0;
    assert!(
        matches!(
            dh,
            Repr::Data(DataRepr {
                fc: FrameControl::Response {
                    status: fdl::ResponseStatus::DataHigh,
                    ..
                },
                ..
            })
        ),
        "{dh:?}"
    );
    p.same(
        "Slave_Diag with the extension",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "Data_Exchange after the read",
        &m.next(8, None, &[3, 4, 5, 6]),
    );
}

#[test]
fn the_watchdog_runs_in_the_transceiver() {
    let mut p = Pair::new(8);
    let mut m = Requests::new(MASTER);
    let prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
    p.same(
        "Set_Prm (1 s watchdog)",
        &m.next(8, Some(Sap::SET_PRM), &prm),
    );
    p.same("Chk_Cfg", &m.next(8, Some(Sap::CHK_CFG), PPO1));
    p.same("Data_Exchange", &m.next(8, None, &[5; 12]));
    p.wait_ms(900);
    p.same(
        "Data_Exchange within the watchdog",
        &m.next(8, None, &[6; 12]),
    );
    p.wait_ms(1100);
    assert_eq!(p.reference.state(), dp_slave::State::WaitPrm);
    assert_eq!(p.adapter.slave().state(), dp_slave::State::WaitPrm);
    assert_eq!(
        p.adapter.app().echo.fail_safes.len(),
        p.reference.app().echo.fail_safes.len(),
        "the firmware went fail-safe as the reference did"
    );
    p.same(
        "Slave_Diag after the expiry",
        &m.next(8, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same("Data_Exchange after the expiry", &m.next(8, None, &[7; 12]));
}

#[test]
fn set_slave_add_with_the_switch_at_zero() {
    let mut p = Pair::new(0);
    let mut m = Requests::new(MASTER);
    let [hi, lo] = dp_consts::ADAPTER_IDENT_NUMBER.to_be_bytes();
    p.same(
        "Set_Slave_Add, wrong ident",
        &m.next(126, Some(Sap::SET_SLAVE_ADD), &[42, hi, lo ^ 1, 0]),
    );
    p.same(
        "Set_Slave_Add to 126 (reserved)",
        &m.next(126, Some(Sap::SET_SLAVE_ADD), &[126, hi, lo, 0]),
    );
    p.same(
        "Set_Slave_Add, short",
        &m.next(126, Some(Sap::SET_SLAVE_ADD), &[42, hi]),
    );
    p.same(
        "Set_Slave_Add to 42",
        &m.next(126, Some(Sap::SET_SLAVE_ADD), &[42, hi, lo, 1]),
    );
    p.same(
        "at the new address",
        &m.next(42, Some(Sap::SLAVE_DIAG), &[]),
    );
    p.same(
        "Set_Slave_Add again (No_Add_Chg)",
        &m.next(42, Some(Sap::SET_SLAVE_ADD), &[43, hi, lo, 0]),
    );
}

#[test]
fn outputs_reach_the_firmware_once_per_new_data_exchange() {
    let mut p = Pair::new(8);
    let mut m = Requests::new(MASTER);
    let prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
    p.same("Set_Prm", &m.next(8, Some(Sap::SET_PRM), &prm));
    p.same("Chk_Cfg", &m.next(8, Some(Sap::CHK_CFG), PPO1));
    p.forwarded.clear();
    let before = p.adapter.app().echo.output_count;
    for i in 0..20u8 {
        let t = m.next(8, None, &[i; 12]);
        p.same("Data_Exchange", &t);
        p.set_inputs(&[i ^ 0xFF; 12]);
        if i % 3 == 0 {
            p.same("its repetition", &m.repeat(8, None, &[i; 12]));
        }
        p.same("Slave_Diag between", &m.next(8, Some(Sap::SLAVE_DIAG), &[]));
    }
    assert_eq!(
        p.forwarded.len(),
        20,
        "one hand-over per new Data_Exchange, none else"
    );
    assert_eq!(p.adapter.app().echo.output_count - before, 20);
    assert_eq!(p.adapter.app().echo.outputs, [19; 12]);
}

#[test]
fn a_decision_on_its_way_gets_no_resource_then_the_new_answer() {
    let mut p = Pair::new(8);
    let mut m = Requests::new(MASTER);
    let prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
    p.deliver = false;
    let (_, sc) = p.both(&m.next(8, Some(Sap::SET_PRM), &prm));
    assert_eq!(sc.as_deref(), Some(&[dp_consts::SC][..]));
    let (_, sc) = p.both(&m.next(8, Some(Sap::CHK_CFG), PPO1));
    assert_eq!(
        sc.as_deref(),
        Some(&[dp_consts::SC][..]),
        "Chk_Cfg acknowledged in order"
    );
    let diag = m.next(8, Some(Sap::SLAVE_DIAG), &[]);
    let (_, rr) = p.both(&diag);
    let rr = Repr::parse_bytes(rr.as_deref().unwrap()).unwrap().0;
    assert!(
        matches!(
            rr,
            Repr::Data(DataRepr {
                fc: FrameControl::Response {
                    status: fdl::ResponseStatus::NoResources,
                    ..
                },
                payload: [],
                ..
            })
        ),
        "{rr:?}"
    );
    // The firmware decides; the master retries with the same FCB (profirust does not toggle
    // it on a failed diagnosis) and gets the diagnosis of Data_Exch.
    p.deliver_queue();
    p.deliver = true;
    let retry = m.repeat(8, Some(Sap::SLAVE_DIAG), &[]);
    let (_, answer) = p.both(&retry);
    let mut reference = [0u8; 64];
    let mut fresh = Slave::new(
        Config {
            address: 8,
            ident_number: dp_consts::ADAPTER_IDENT_NUMBER,
            no_add_chg: true,
            dpv1_status_bytes: false,
        },
        app(),
    );
    let mut r = Requests::new(MASTER);
    let now = Instant::ZERO;
    let mut scratch = [0u8; 64];
    fresh.handle(now, &r.next(8, Some(Sap::SET_PRM), &prm), &mut scratch);
    fresh.handle(now, &r.next(8, Some(Sap::CHK_CFG), PPO1), &mut scratch);
    let n = fresh
        .handle(now, &r.next(8, Some(Sap::SLAVE_DIAG), &[]), &mut reference)
        .unwrap();
    assert_eq!(answer.as_deref(), Some(&reference[..n]));
}

/// The response on the line, at every rate: it starts min TSDR after the request (11 bit
/// times, plus the decision and the bit grid), and the master's receiver decodes the same bytes
/// the firmware would have sent.
#[test]
fn answers_start_at_min_tsdr_at_every_rate() {
    for baud in Baud::ALL {
        let timing = BitTiming::new(CLOCK_HZ, baud, 0);
        let mut p = Pair::new(8);
        let mut m = Requests::new(MASTER);
        let prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
        let requests = [
            m.next(8, Some(Sap::SLAVE_DIAG), &[]),
            m.next(8, Some(Sap::SET_PRM), &prm),
            m.next(8, Some(Sap::CHK_CFG), PPO1),
            m.next(8, Some(Sap::SLAVE_DIAG), &[]),
            m.next(8, Some(Sap::GET_CFG), &[]),
            m.next(8, None, &[0x5A; 12]),
        ];
        let mut tb = Testbench::new(
            dp_phy::Config {
                clock_hz: CLOCK_HZ,
                ..dp_phy::Config::default()
            },
            timing,
            dp_phy::bus::FaultInjector::none(),
        );
        let mut rx = StationRx::new(timing);
        for (i, t) in requests.iter().enumerate() {
            // Room for the longest answer (a diagnosis, 17 characters) before the next request.
            tb.send(if i == 0 { 400 } else { 11 + 11 * 20 + 40 }, t);
        }
        let mut heard: Vec<u8> = Vec::new();
        let mut expected: Vec<Vec<u8>> = Vec::new();
        let mut answers: Vec<(Tick, Tick, Vec<u8>)> = Vec::new();
        let mut request_end = None;
        let mut started = None;
        let mut last_driven = 0;
        let end = tb.now() + timing.clocks_for(6 * (300 + 30 * 11) + 400, 1);
        while tb.now() < end {
            let driving = tb.adapter.drive().is_some();
            let line = tb
                .bus
                .resolve(tb.now(), [tb.master.drive(), tb.adapter.drive()]);
            let delivered = tb.delivered.len();
            tb.step_strict();
            if driving {
                last_driven = tb.now();
                started.get_or_insert(tb.now() - 1);
            }
            // The master's receiver: its last character ends a filter delay after the line.
            if let Some(c) = rx.tick(line, false) {
                if started.is_some() {
                    heard.push(c.byte);
                }
            }
            if started.is_some() && tb.now() - last_driven > 2 * timing.clocks_per_bit() {
                let end_of_request: Tick = request_end.take().unwrap();
                answers.push((
                    end_of_request,
                    started.take().unwrap(),
                    std::mem::take(&mut heard),
                ));
            }
            if tb.delivered.len() > delivered {
                let d = tb.delivered.last().unwrap().clone();
                p.now_us = d.end / 48;
                let (reference, answer) = p.answers(&d.bytes);
                assert_eq!(answer, reference, "{baud}: content");
                expected.extend(answer.clone());
                if let Some(bytes) = answer {
                    assert!(tb.adapter.respond(&bytes, d.end + DECISION_CLOCKS));
                    request_end = Some(d.end);
                }
            }
        }
        assert_eq!(
            answers.len(),
            requests.len(),
            "{baud}: every request answered"
        );
        let on_the_line: Vec<Vec<u8>> = answers.iter().map(|a| a.2.clone()).collect();
        assert_eq!(
            on_the_line, expected,
            "{baud}: the master heard the firmware's answers"
        );
        for (request_end, start, bytes) in &answers {
            let tsdr = (start - request_end) as f64 / timing.clocks_per_bit() as f64;
            assert!(
                (11.0..=12.5).contains(&tsdr),
                "{baud}: TSDR {tsdr:.2} bit times for {bytes:02X?}"
            );
        }
    }
}

/// An MSAC1 request (SAP 51 on both sides) from `sa`.
fn msac1(sa: u8, fcb: bool, pdu: &[u8]) -> Vec<u8> {
    let repr = Repr::Data(DataRepr {
        da: 8,
        sa,
        dsap: Some(Sap::MSAC1),
        ssap: Some(Sap::MSAC1),
        fc: FrameControl::Request {
            fcb,
            fcv: true,
            function: RequestFunction::SrdLow,
        },
        payload: pdu,
    });
    let mut bytes = vec![0; repr.buffer_len()];
    repr.emit(&mut bytes).unwrap();
    bytes
}

/// DP-V1: the responder acknowledges an MSAC1 request with SC and hands it over; the master's
/// poll gets the response the firmware wrote, as `dp_slave` gives it. On a slow link the poll
/// gets SC until the response is there, and a response to an older request is not given.
#[test]
fn msac1_requests_are_answered_on_the_poll_as_the_firmware_would() {
    let mut p = Pair::with(8, true);
    let mut m = Requests::new(MASTER);
    let mut prm = set_prm_payload(0x88, dp_consts::ADAPTER_IDENT_NUMBER);
    prm.extend([0x80, 0, 0]);
    p.same("Set_Prm, DPV1_Enable", &m.next(8, Some(Sap::SET_PRM), &prm));
    p.same("Chk_Cfg", &m.next(8, Some(Sap::CHK_CFG), PPO3));
    p.same("Data_Exchange", &m.next(8, None, &[1, 2, 3, 4]));
    let write = [0x5F, 1, 47, 2, 0xAB, 0xCD];
    let read = [0x5E, 1, 47, 240];
    assert_eq!(
        p.same("write", &msac1(MASTER, true, &write)),
        Some(vec![0xE5])
    );
    let answer = p.same("poll", &msac1(MASTER, false, &[])).unwrap();
    assert!(
        answer.windows(4).any(|w| w == [0x5F, 1, 47, 2]),
        "{answer:02X?}"
    );
    p.same("poll, nothing left", &msac1(MASTER, true, &[]));
    p.same("read", &msac1(MASTER, false, &read));
    let data = p
        .same("poll for the read", &msac1(MASTER, true, &[]))
        .unwrap();
    assert!(
        data.windows(6).any(|w| w == [0x5E, 1, 47, 2, 0xAB, 0xCD]),
        "{data:02X?}"
    );
    p.same("Data_Exchange goes on", &m.next(8, None, &[5, 6, 7, 8]));
    // Another master's MSAC1 is not served (RS), as the firmware says.
    p.same("another master", &msac1(OTHER_MASTER, true, &read));

    // A slow link: the poll before the firmware's write gets SC, the one after it the data.
    p.deliver = false;
    let (_, ack) = p.both(&msac1(MASTER, false, &read));
    assert_eq!(ack, Some(vec![0xE5]));
    let (_, early) = p.both(&msac1(MASTER, true, &[]));
    assert_eq!(early, Some(vec![0xE5]), "not there yet");
    p.deliver_queue();
    let (_, late) = p.both(&msac1(MASTER, false, &[]));
    assert!(late
        .unwrap()
        .windows(6)
        .any(|w| w == [0x5E, 1, 47, 2, 0xAB, 0xCD]));
}
