//! The link between the transceiver (the FPGA, or hal-sim's model of it) and the adapter's MCU.
//!
//! Every message is postcard-encoded and COBS-framed (a zero byte ends each frame), defined
//! once here for the firmware and the simulator. The link is event-driven, as the interface of
//! an SPC3/VPC3+ is: the transceiver answers every DP-V0 request by itself from buffers the
//! firmware filled ([`FromAdapter::Regs`], [`FromAdapter::Inputs`], [`FromAdapter::Diag`],
//! [`FromAdapter::Cfg`]), and hands the firmware only what needs its decision
//! ([`ToAdapter::Telegram`]: Set_Prm, Chk_Cfg, Global_Control, Set_Slave_Add and the outputs of
//! each new Data_Exchange), its watchdog's expiry, and the wake-up the firmware asked for.
//! Nothing waits for a reply.
//!
//! Events carry a sequence number; the firmware's [`Regs`] say which events it had seen when
//! it wrote them ([`Regs::seen`]). The transceiver answers the requests whose answer depends on
//! a decision still on its way (Slave_Diag, Get_Cfg, Data_Exchange, Rd_Inp, Rd_Outp,
//! Set_Slave_Add) with "no resource" (RR) until the firmware's registers have seen that
//! decision, as an SPC3 does while its user buffer is not free.
//!
//! Time on the link is the transceiver's clock in microseconds (`now_us`): the firmware has no
//! clock of its own for the protocol, so everything it times runs on bus time, in QEMU as on
//! the board.
//!
//! What only the simulation needs (how many drive bytes the simulated drive line has delivered,
//! the firmware's cycle counts) is in [`sim`], behind the `sim` feature: the production board's
//! build does not have it, so it can neither send nor accept it.
//!
//! [`encode`] never panics (it fails on a short buffer); [`Deframer`] never panics on any bytes
//! and drops a frame that is too long or does not decode.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

use serde::{Deserialize, Serialize};

pub mod cobs;

/// The largest encoded frame: a 255-byte telegram or buffer plus the fields around it, COBS
/// overhead and the terminating zero.
pub const MAX_FRAME_LEN: usize = 320;

/// What the non-volatile storage holds for the station address.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NvRecord {
    pub address: u8,
    /// Set_Slave_Add with No_Add_Chg: the address may not change again.
    pub no_add_chg: bool,
}

/// The PROFIdrive settings the storage keeps when 971 says so (seed 004 line 921): 927 PKW
/// rights, 928 PZD rights, 930 operating mode, 933-937 and 939-943 the selectors of control
/// and status word bits 11-15.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NvParams {
    pub pkw_rights: u16,
    pub pzd_rights: u16,
    pub operating_mode: u16,
    pub control_bit_selectors: [u16; 5],
    pub status_bit_selectors: [u16; 5],
}

/// What the storage holds at power-up: each record, if it was ever written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NvContents {
    pub address: Option<NvRecord>,
    pub params: Option<NvParams>,
}

/// A write the storage must carry out now ([`Status::nv_write`]). The settings travel no
/// further than the firmware, which reads them from the adapter: the link says only that they
/// were stored.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NvWrite {
    /// The station address record (Set_Slave_Add, 918).
    Address(NvRecord),
    /// The settings as they are now (971).
    Params,
    /// Switch 99 at power-up: the factory address record, and no settings (their defaults).
    FactoryDefaults(NvRecord),
}

/// Transceiver to MCU.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ToAdapter<'a> {
    /// Power-up, with the address switch (two decimal digits, 0-99) that the transceiver
    /// reads (hal-sim emulates it). The storage is the MCU's own (its flash).
    Boot { seq: u32, now_us: u64, switch: u8 },
    /// A request for the firmware's decision, already answered on the bus by the transceiver:
    /// its last stop bit ended at `now_us`, at rate index `baud` (`dp_consts::Baud::index`).
    Telegram {
        seq: u32,
        now_us: u64,
        baud: u8,
        #[serde(borrow, with = "serde_bytes")]
        bytes: &'a [u8],
    },
    /// The DP watchdog expired in the transceiver: it is back in Wait_Prm, and the firmware's
    /// slave must follow (fail-safe).
    WatchdogExpired { seq: u32, now_us: u64 },
    /// The wake-up the firmware asked for ([`Status::wake_at_us`]).
    Timer { seq: u32, now_us: u64 },
    /// Simulation only: on the simulation's pipe ([`sim::Next`]), never on the link UART.
    #[cfg(feature = "sim")]
    Sim(sim::SimToAdapter),
}

impl ToAdapter<'_> {
    /// The event's sequence number (0 for simulation messages, which are not events).
    pub fn seq(&self) -> u32 {
        match *self {
            ToAdapter::Boot { seq, .. }
            | ToAdapter::Telegram { seq, .. }
            | ToAdapter::WatchdogExpired { seq, .. }
            | ToAdapter::Timer { seq, .. } => seq,
            #[cfg(feature = "sim")]
            ToAdapter::Sim(_) => 0,
        }
    }

    /// The transceiver's time of the event (0 for [`sim::SimToAdapter::Continue`], which is
    /// not one: the step it runs keeps the last event's time).
    pub fn now_us(&self) -> u64 {
        match *self {
            ToAdapter::Boot { now_us, .. }
            | ToAdapter::Telegram { now_us, .. }
            | ToAdapter::WatchdogExpired { now_us, .. }
            | ToAdapter::Timer { now_us, .. } => now_us,
            #[cfg(feature = "sim")]
            ToAdapter::Sim(sim::SimToAdapter::DriveBytes { now_us, .. }) => now_us,
            #[cfg(feature = "sim")]
            ToAdapter::Sim(sim::SimToAdapter::Continue(_) | sim::SimToAdapter::StackPeak) => 0,
        }
    }
}

/// The DP slave's registers in the transceiver, as the firmware's slave has them.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Regs {
    /// The last event the firmware had handled when it wrote these.
    pub seen: u32,
    pub address: u8,
    pub state: SlaveState,
    /// The master that parameterised the slave.
    pub owner: Option<u8>,
    /// Lock_Req of that master is in force.
    pub locked: bool,
    /// Set_Slave_Add is refused (the switch rules, or No_Add_Chg).
    pub no_add_chg: bool,
    pub ident_number: u16,
    /// The DP watchdog from the last Set_Prm, if on.
    pub watchdog_us: Option<u32>,
    /// min TSDR to give the transmitter, in bit times.
    pub min_tsdr_bits: u8,
    /// Bytes of the accepted configuration.
    pub inputs_len: u8,
    pub outputs_len: u8,
    /// DPV1_Enable is in force: SAP 51 serves the owner in Data_Exch.
    pub dpv1: bool,
}

// Byte slices are serialized with `serde_bytes`: postcard then copies them in one go instead
// of element by element (a DX's inputs were a third of the link's encoding work). The bytes on
// the wire are the same: a varint length, then the bytes.

/// MCU to transceiver.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FromAdapter<'a> {
    /// The MCU's link is up: sent once after reset, before which the transceiver sends nothing
    /// (bytes that reach a UART before it is configured are lost).
    Ready,
    /// The slave's registers.
    Regs(Regs),
    /// The inputs a Data_Exchange or Rd_Inp answers with.
    Inputs(#[serde(borrow, with = "serde_bytes")] &'a [u8]),
    /// The diagnosis Slave_Diag answers with (as the owner reads it; the transceiver adds
    /// Master_Lock for another master). `new`: Data_Exchange answers DH until the owner reads it.
    Diag {
        new: bool,
        #[serde(borrow, with = "serde_bytes")]
        bytes: &'a [u8],
    },
    /// The configuration Get_Cfg answers with.
    Cfg(#[serde(borrow, with = "serde_bytes")] &'a [u8]),
    /// The response to the MSAC1 request handed over as event `request` (SAP 51): the
    /// master's next poll gets it.
    Msac1 {
        request: u32,
        #[serde(borrow, with = "serde_bytes")]
        bytes: &'a [u8],
    },
    /// LEDs, storage, the wake-up, and figures for observers.
    Status(Status),
}

/// The messages only the simulation has: the drive line's lockstep and the firmware's own
/// cycle counts, which hal-sim turns into board time.
#[cfg(feature = "sim")]
pub mod sim {
    use serde::{Deserialize, Serialize};

    #[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub enum SimToAdapter {
        /// The simulated drive has sent `drive_rx_bytes` bytes since power-up, all of which
        /// are in the MCU's drive UART when this is handled.
        DriveBytes { now_us: u64, drive_rx_bytes: u32 },
        /// No frame is waiting: run the next step of the drive application's cycle. On a
        /// board the firmware decides this itself (its link queue is empty); under simulation
        /// only hal-sim knows whether an event reached the MCU during the last step. It knows
        /// when the next one can at the earliest ([`Grant`]), so the firmware may run more
        /// steps back to back and report them in one `Done`: one host round trip for them all.
        Continue(Grant),
        /// How deep has the stack been since power-up? Answered with
        /// [`SimFromAdapter::StackPeak`] alone (no `Done`): a measurement, not an event.
        StackPeak,
    }

    /// What hal-sim says next on the simulation's pipe: a pair of host FIFOs that the
    /// firmware reads and writes over semihosting (QEMU only; firmware `sim_pipe`). The pipe
    /// is simulation plumbing, not a link of the board: a message on it costs one host read
    /// or write, where a frame on the link UART costs QEMU a main-loop turn per byte on its
    /// way in and a socket write per byte on its way out, and the simulation's own messages
    /// cost the board's counts nothing either way. The replies ([`SimFromAdapter`]) come back
    /// on it too.
    ///
    /// The firmware blocks on the pipe (QEMU's CPU with it, and its virtual time) while it
    /// idles, so hal-sim announces every message there, the product's ones included.
    #[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub enum Next {
        /// The next message is a frame on the link UART: wait for it as the board would.
        OnLink,
        /// The next message is this one.
        Sim(SimToAdapter),
    }

    /// The longest [`Next`] framed (a `DriveBytes` with both integers at their longest).
    pub const NEXT_MAX_FRAME: usize = 20;

    /// How far the firmware may run the drive application's cycle before it reports:
    /// conservative lookahead, as in parallel discrete-event simulation. No event can reach
    /// the MCU before `budget_instructions` counted instructions have passed (at the board's
    /// clock, from the first step's start), so a step that starts within them would have
    /// started on the board too.
    ///
    /// The firmware runs the first step; then the next one while ([`Grant::allows_another`])
    /// the steps before have used fewer counted instructions than the budget, the last one
    /// wrote nothing to the transceiver and nothing to the drive (whose answer or effect
    /// hal-sim must place in time before anything else runs), and a step remains.
    #[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub struct Grant {
        pub budget_instructions: u32,
    }

    impl Grant {
        /// One step and no more (a real-time run, where the MCU cannot run ahead of the wall
        /// clock).
        pub const ONE_STEP: Grant = Grant {
            budget_instructions: 0,
        };

        /// Whether another step may start after steps that used `used_instructions`, the last
        /// of which `wrote` to the transceiver or the drive.
        pub fn allows_another(&self, used_instructions: u32, wrote: bool) -> bool {
            !wrote && used_instructions < self.budget_instructions
        }
    }

    #[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub enum SimFromAdapter {
        /// The message is handled, after `instructions`. Its first `decision_writes` writes
        /// (the decision's) were all handed to the link after `decision_instructions`;
        /// `drive_tx_bytes` bytes have gone to the drive UART since power-up; `cycle_pending`:
        /// steps of the drive application's cycle remain ([`SimToAdapter::Continue`]). One
        /// mark at the end, so that the simulation's own messages cost the counts nothing.
        ///
        /// After a [`SimToAdapter::Continue`], `earlier_steps` steps ran before the last one,
        /// in `earlier_instructions` together, with no write and no drive byte; the rest of
        /// the fields are the last step's, counted from its own start.
        ///
        /// `link_frames`: the writes sent on the link UART for the message, all before this
        /// `Done` went on the pipe (the UART's bytes leave as the firmware writes them).
        /// `drive_instructions`: when the drive's bytes were handed to its UART, where that
        /// was before the end (0: at the end).
        Done {
            link_frames: u32,
            drive_instructions: u32,
            earlier_steps: u8,
            earlier_instructions: u32,
            decision_instructions: u32,
            decision_writes: u32,
            instructions: u32,
            drive_tx_bytes: u32,
            cycle_pending: bool,
        },
        /// The deepest the stack has reached since power-up, and the room it has (RAM above
        /// the statics): the stack is painted at power-up, and the lowest word no longer
        /// holding the paint marks the peak.
        StackPeak { used_bytes: u32, room_bytes: u32 },
    }
}

/// The adapter's state for the board around it (LEDs, storage, the wake-up) and for observers.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    pub address: u8,
    pub state: SlaveState,
    pub leds: Leds,
    /// A record the MCU's non-volatile storage must now hold (the firmware writes it; the
    /// transceiver's side only notes it).
    pub nv_write: Option<NvWrite>,
    /// When the firmware must be woken ([`ToAdapter::Timer`]): the drive link's answer
    /// deadline or keep-alive.
    pub wake_at_us: Option<u64>,
    /// The drive link's error value (seed 000: 0x21, 0x22, 0x23, or the drive's refusal),
    /// 0 while it works.
    pub drive_link_error: u8,
    /// Outputs handed to the application since boot (a liveness figure for reports).
    pub outputs_applied: u32,
    /// Fail-safe entries since boot.
    pub fail_safes: u16,
    /// Telegrams from the link that did not parse (the transceiver must never deliver one).
    pub malformed_telegrams: u16,
}

impl Status {
    /// Before the firmware's first status: power-on, every LED off, nothing counted.
    pub const POWER_ON: Status = Status {
        address: 0,
        state: SlaveState::PowerOn,
        leds: Leds::OFF,
        nv_write: None,
        wake_at_us: None,
        drive_link_error: 0,
        outputs_applied: 0,
        fail_safes: 0,
        malformed_telegrams: 0,
    };
}

/// The DP slave states.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlaveState {
    PowerOn,
    WaitPrm,
    WaitCfg,
    DataExch,
}

/// One LED's pattern.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Led {
    #[default]
    Off,
    On,
    Blink1Hz,
    Blink2Hz,
    Blink4Hz,
    /// A 20 ms flash once a second (seed 000's Run LED in normal operation).
    Flash1Hz,
}

/// Seed 004's host LED (lines 1478-1479), green or red: the link to the drive.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostLed {
    /// No exchange with the drive yet.
    #[default]
    Off,
    /// Green: the link works.
    Green,
    /// Red, blinking: the link is lost for now.
    RedBlink,
    /// Red: the link is lost for good (seed 004's "permanently lost").
    Red,
}

/// The LEDs of both manuals: seed 000's Net, Run, TX and RX; seed 004's error, online, offline
/// and host.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Leds {
    pub net: Led,
    pub run: Led,
    pub tx: Led,
    pub rx: Led,
    pub error: Led,
    pub online: Led,
    pub offline: Led,
    pub host: HostLed,
}

impl Leds {
    /// Every LED off.
    pub const OFF: Leds = Leds {
        net: Led::Off,
        run: Led::Off,
        tx: Led::Off,
        rx: Led::Off,
        error: Led::Off,
        online: Led::Off,
        offline: Led::Off,
        host: HostLed::Off,
    };
}

/// Why a frame could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    BufferTooShort,
    /// A frame whose bytes are not a message of the type asked for.
    NotAMessage,
}

/// Encodes `message` as one COBS frame (zero-terminated) into `buffer`.
pub fn encode<'b, T: Serialize>(message: &T, buffer: &'b mut [u8]) -> Result<&'b mut [u8], Error> {
    let payload = buffer
        .get_mut(cobs::PAYLOAD_OFFSET..)
        .ok_or(Error::BufferTooShort)?;
    let len = postcard::to_slice(message, payload)
        .map_err(|_| Error::BufferTooShort)?
        .len();
    let frame_len = cobs::encode_in_place(buffer, len).ok_or(Error::BufferTooShort)?;
    Ok(&mut buffer[..frame_len])
}

/// Decodes one COBS frame (zero-terminated), in place.
pub fn decode<'f, T: Deserialize<'f>>(frame: &'f mut [u8]) -> Result<T, Error> {
    postcard::from_bytes_cobs(frame).map_err(|_| Error::NotAMessage)
}

/// Cuts a byte stream into frames and decodes them, COBS as the bytes are fed
/// ([`cobs::Decoder`]), then postcard.
pub struct Deframer {
    decoder: cobs::Decoder<MAX_FRAME_LEN>,
    /// Frames dropped: too long, or not a message.
    pub dropped: u32,
}

impl Default for Deframer {
    fn default() -> Self {
        Deframer::new()
    }
}

impl Deframer {
    pub const fn new() -> Deframer {
        Deframer {
            decoder: cobs::Decoder::new(),
            dropped: 0,
        }
    }

    /// Feeds bytes until one frame ends. The caller feeds the remaining bytes again until
    /// [`Fed::Pending`]; a message borrows the deframer until it is dropped.
    pub fn feed<'d, 'i, T: Deserialize<'d>>(&'d mut self, input: &'i [u8]) -> Fed<'i, T> {
        match self.decoder.feed(input) {
            cobs::Feed::Pending => Fed::Pending,
            cobs::Feed::Bad { consumed } => {
                self.dropped += 1;
                Fed::Dropped(&input[consumed..])
            }
            cobs::Feed::Frame { consumed } => match postcard::from_bytes(self.decoder.frame()) {
                Ok(message) => Fed::Message(message, &input[consumed..]),
                Err(_) => {
                    self.dropped += 1;
                    Fed::Dropped(&input[consumed..])
                }
            },
        }
    }
}

/// What one [`Deframer::feed`] found.
#[derive(Debug, PartialEq, Eq)]
pub enum Fed<'i, T> {
    /// Every byte consumed, no frame ended.
    Pending,
    /// A message, and the bytes after its frame.
    Message(T, &'i [u8]),
    /// A frame that was too long or not a message, and the bytes after it.
    Dropped(&'i [u8]),
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn status() -> Status {
        Status {
            address: 8,
            state: SlaveState::DataExch,
            leds: Leds {
                net: Led::On,
                run: Led::Flash1Hz,
                online: Led::On,
                ..Leds::default()
            },
            nv_write: Some(NvWrite::Address(NvRecord {
                address: 42,
                no_add_chg: true,
            })),
            wake_at_us: Some(1_000_000),
            drive_link_error: 0x22,
            outputs_applied: 7,
            fail_safes: 1,
            malformed_telegrams: 0,
        }
    }

    /// Decodes every message in `bytes`, each as its Debug text (messages borrow the
    /// deframer, so they are turned into owned text before the next feed).
    macro_rules! decode_all {
        ($t:ty, $bytes:expr) => {{
            let mut deframer = Deframer::new();
            let mut out: Vec<String> = Vec::new();
            let mut rest: &[u8] = $bytes;
            loop {
                match deframer.feed::<$t>(rest) {
                    Fed::Pending => break,
                    Fed::Message(m, r) => {
                        out.push(format!("{m:?}"));
                        rest = r;
                    }
                    Fed::Dropped(r) => rest = r,
                }
            }
            (out, deframer.dropped)
        }};
    }

    #[test]
    fn frames_round_trip_in_a_stream() {
        let telegram = [
            0x68, 0x05, 0x05, 0x68, 0x88, 0x81, 0x6D, 0x3C, 0x3E, 0xF0, 0x16,
        ];
        let messages = [
            ToAdapter::Boot {
                seq: 0,
                now_us: 0,
                switch: 99,
            },
            ToAdapter::Telegram {
                seq: 1,
                now_us: 12_345,
                baud: 9,
                bytes: &telegram,
            },
            ToAdapter::WatchdogExpired {
                seq: 2,
                now_us: u64::MAX,
            },
            ToAdapter::Timer {
                seq: u32::MAX,
                now_us: 7,
            },
            ToAdapter::Sim(sim::SimToAdapter::DriveBytes {
                now_us: 1,
                drive_rx_bytes: u32::MAX,
            }),
            ToAdapter::Sim(sim::SimToAdapter::Continue(sim::Grant {
                budget_instructions: u32::MAX,
            })),
        ];
        let mut stream = Vec::new();
        for m in &messages {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode(m, &mut buf).unwrap();
            assert_eq!(frame.last(), Some(&0));
            assert_eq!(frame.iter().filter(|b| **b == 0).count(), 1);
            stream.extend_from_slice(frame);
        }
        let mut deframer = Deframer::new();
        let mut rest = &stream[..];
        for want in &messages {
            match deframer.feed::<ToAdapter>(rest) {
                Fed::Message(m, r) => {
                    assert_eq!(&m, want);
                    rest = r;
                }
                other => panic!("{other:?}"),
            }
        }
        assert!(rest.is_empty());
    }

    #[test]
    fn byte_slices_are_a_length_then_the_bytes() {
        let mut buf = [0u8; 16];
        let bytes = postcard::to_slice(&FromAdapter::Inputs(&[7, 8, 9]), &mut buf).unwrap();
        // The variant index of Inputs (2), the length, the bytes: as a plain sequence of u8.
        assert_eq!(bytes, [2, 3, 7, 8, 9]);
    }

    #[test]
    fn every_write_fits_a_frame_at_its_largest() {
        let buffer = [0xAAu8; 255];
        let writes = [
            FromAdapter::Ready,
            FromAdapter::Regs(Regs {
                seen: u32::MAX,
                address: 126,
                state: SlaveState::DataExch,
                owner: Some(125),
                locked: true,
                no_add_chg: true,
                ident_number: u16::MAX,
                watchdog_us: Some(u32::MAX),
                min_tsdr_bits: 255,
                inputs_len: 244,
                outputs_len: 244,
                dpv1: true,
            }),
            FromAdapter::Inputs(&buffer),
            FromAdapter::Diag {
                new: true,
                bytes: &buffer,
            },
            FromAdapter::Cfg(&buffer),
            FromAdapter::Msac1 {
                request: u32::MAX,
                bytes: &buffer[..244],
            },
            FromAdapter::Status(status()),
        ];
        for write in writes {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode(&write, &mut buf).unwrap().to_vec();
            let (got, dropped) = decode_all!(FromAdapter, &frame);
            assert_eq!(dropped, 0);
            assert_eq!(got, [format!("{write:?}")]);
        }
    }

    #[test]
    fn garbage_between_frames_is_dropped_and_the_next_frame_decodes() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(&ToAdapter::Timer { seq: 5, now_us: 6 }, &mut buf)
            .unwrap()
            .to_vec();
        let mut stream = vec![0xFF, 0x13, 0x00];
        stream.extend_from_slice(&frame);
        let (got, dropped) = decode_all!(ToAdapter, &stream);
        assert_eq!(
            got,
            [format!("{:?}", ToAdapter::Timer { seq: 5, now_us: 6 })]
        );
        assert_eq!(dropped, 1);
    }

    #[test]
    fn the_pipe_messages_at_their_longest_decode_as_they_were_sent() {
        let announcements = [
            sim::Next::OnLink,
            sim::Next::Sim(sim::SimToAdapter::DriveBytes {
                now_us: u64::MAX,
                drive_rx_bytes: u32::MAX,
            }),
            sim::Next::Sim(sim::SimToAdapter::Continue(sim::Grant {
                budget_instructions: u32::MAX,
            })),
            sim::Next::Sim(sim::SimToAdapter::StackPeak),
        ];
        for next in announcements {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode(&next, &mut buf).unwrap();
            assert!(
                frame.len() <= sim::NEXT_MAX_FRAME,
                "{next:?}: {} bytes",
                frame.len()
            );
            assert_eq!(decode::<sim::Next>(frame), Ok(next));
        }
        let replies = [
            sim::SimFromAdapter::Done {
                link_frames: u32::MAX,
                drive_instructions: u32::MAX,
                earlier_steps: u8::MAX,
                earlier_instructions: u32::MAX,
                decision_instructions: u32::MAX,
                decision_writes: u32::MAX,
                instructions: u32::MAX,
                drive_tx_bytes: u32::MAX,
                cycle_pending: true,
            },
            sim::SimFromAdapter::StackPeak {
                used_bytes: u32::MAX,
                room_bytes: u32::MAX,
            },
        ];
        for reply in replies {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode(&reply, &mut buf).unwrap();
            assert_eq!(decode::<sim::SimFromAdapter>(frame), Ok(reply));
        }
        let mut not_a_message = [0x02, 0xFF, 0x00];
        assert_eq!(
            decode::<sim::Next>(&mut not_a_message),
            Err(Error::NotAMessage)
        );
    }

    #[test]
    fn a_grant_allows_a_step_only_within_its_budget_after_a_quiet_one() {
        let grant = sim::Grant {
            budget_instructions: 1000,
        };
        assert!(grant.allows_another(999, false));
        assert!(
            !grant.allows_another(1000, false),
            "the budget is a strict bound"
        );
        assert!(
            !grant.allows_another(10, true),
            "a step that wrote ends the run"
        );
        assert!(!sim::Grant::ONE_STEP.allows_another(0, false));
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..1000)) {
            let _ = decode_all!(ToAdapter, &bytes);
            let _ = decode_all!(FromAdapter, &bytes);
        }

        #[test]
        fn telegrams_round_trip(
            seq in any::<u32>(), now_us in any::<u64>(), baud in 0u8..10,
            bytes in prop::collection::vec(any::<u8>(), 0..=255),
        ) {
            let m = ToAdapter::Telegram { seq, now_us, baud, bytes: &bytes };
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode(&m, &mut buf).unwrap().to_vec();
            let (got, dropped) = decode_all!(ToAdapter, &frame);
            prop_assert_eq!(dropped, 0);
            prop_assert_eq!(got, vec![format!("{m:?}")]);
        }
    }
}
