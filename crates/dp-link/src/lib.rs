//! The link between the transceiver (the FPGA, or hal-sim's model of it) and the adapter's MCU.
//!
//! Every message is postcard-encoded and COBS-framed (a zero byte ends each frame), defined
//! once here for the firmware and the simulator. The exchange is strictly request/reply: each
//! [`ToAdapter`] message gets exactly one [`FromAdapter::Reply`] (the DP response, as soon as
//! it is built) and then one [`FromAdapter::Done`] (the drive link's work after it) with the
//! same `seq`, so the transceiver always knows whether a response is coming and the firmware's
//! queue never holds more than one message.
//!
//! Time on the link is the transceiver's clock in microseconds (`now_us`): the firmware has no
//! clock of its own for the protocol, so the DP watchdog runs on bus time, in QEMU as on the board.
//!
//! [`encode`] never panics (it fails on a short buffer); [`Deframer`] never panics on any bytes
//! and drops a frame that is too long or does not decode.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

use serde::{Deserialize, Serialize};

/// The largest encoded frame: a 255-byte telegram plus the fields around it, COBS overhead and
/// the terminating zero.
pub const MAX_FRAME_LEN: usize = 320;

/// What the non-volatile storage holds for the station address.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NvRecord {
    pub address: u8,
    /// Set_Slave_Add with No_Add_Chg: the address may not change again.
    pub no_add_chg: bool,
}

/// Transceiver to MCU.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ToAdapter<'a> {
    /// Power-up. On the QEMU board hal-sim also emulates the address switch (two decimal
    /// digits, 0-99) and the non-volatile storage; a real board reads its own.
    Boot {
        seq: u32,
        now_us: u64,
        switch: u8,
        nv: Option<NvRecord>,
    },
    /// An error-free telegram, its last stop bit ended at `now_us`, at rate index `baud`
    /// (`dp_consts::Baud::index`).
    Telegram {
        seq: u32,
        now_us: u64,
        baud: u8,
        #[serde(borrow)]
        bytes: &'a [u8],
    },
    /// Time passed without a telegram for us: the watchdog and the drive link run on it.
    /// `drive_rx_bytes`: the bytes the drive has sent since power-up, all of which are in the
    /// MCU's drive UART when this Tick is handled (the simulated drive link's lockstep).
    Tick {
        seq: u32,
        now_us: u64,
        drive_rx_bytes: u32,
    },
}

impl ToAdapter<'_> {
    pub fn seq(&self) -> u32 {
        match *self {
            ToAdapter::Boot { seq, .. }
            | ToAdapter::Telegram { seq, .. }
            | ToAdapter::Tick { seq, .. } => seq,
        }
    }
}

/// MCU to transceiver.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FromAdapter<'a> {
    /// The MCU's link is up: sent once after reset, before which the transceiver sends nothing
    /// (bytes that reach a UART before it is configured are lost).
    Ready,
    /// The response to a message, sent as soon as it is built.
    Reply {
        seq: u32,
        /// The response telegram, or empty for none.
        #[serde(borrow)]
        response: &'a [u8],
        /// CPU cycles from the arrival of the message to this hand-off.
        cycles: u32,
        status: Status,
    },
    /// After each Reply: the work that follows it (the drive link) is done; the status after
    /// it. Exactly one Reply and one Done answer each message.
    Done { seq: u32, status: Status },
}

/// The slave's state after a message, for the transceiver and for observers.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    pub address: u8,
    pub state: SlaveState,
    /// min TSDR to give the transmitter, in bit times.
    pub min_tsdr_bits: u8,
    pub leds: Leds,
    /// A record the non-volatile storage must now hold.
    pub nv_write: Option<NvRecord>,
    /// The next time the adapter must see a Tick, if any (the watchdog's deadline, the drive
    /// link's answer deadline or keep-alive).
    pub poll_at_us: Option<u64>,
    /// Bytes sent to the drive since power-up, all of them written to the drive UART before
    /// this status (the simulated drive link's lockstep).
    pub drive_tx_bytes: u32,
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

/// The LEDs of both manuals: seed 000's Net, Run, TX and RX; seed 004's error, online and
/// offline.
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
}

/// Why a frame could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    BufferTooShort,
}

/// Encodes `message` as one COBS frame (zero-terminated) into `buffer`.
pub fn encode<'b, T: Serialize>(message: &T, buffer: &'b mut [u8]) -> Result<&'b mut [u8], Error> {
    postcard::to_slice_cobs(message, buffer).map_err(|_| Error::BufferTooShort)
}

/// Cuts a byte stream into frames and decodes them; built on postcard's COBS accumulator.
pub struct Deframer {
    accumulator: postcard::accumulator::CobsAccumulator<MAX_FRAME_LEN>,
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
            accumulator: postcard::accumulator::CobsAccumulator::new(),
            dropped: 0,
        }
    }

    /// Feeds bytes until one frame ends. The caller feeds the remaining bytes again until
    /// [`Fed::Pending`]; a message borrows the deframer until it is dropped.
    pub fn feed<'d, 'i, T: Deserialize<'d>>(&'d mut self, input: &'i [u8]) -> Fed<'i, T> {
        use postcard::accumulator::FeedResult;
        match self.accumulator.feed_ref::<T>(input) {
            FeedResult::Consumed => Fed::Pending,
            FeedResult::Success { data, remaining } => Fed::Message(data, remaining),
            FeedResult::OverFull(remaining) | FeedResult::DeserError(remaining) => {
                self.dropped += 1;
                Fed::Dropped(remaining)
            }
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
            min_tsdr_bits: 11,
            leds: Leds {
                net: Led::On,
                run: Led::Flash1Hz,
                online: Led::On,
                ..Leds::default()
            },
            nv_write: Some(NvRecord {
                address: 42,
                no_add_chg: true,
            }),
            poll_at_us: Some(1_000_000),
            drive_tx_bytes: u32::MAX,
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
                nv: None,
            },
            ToAdapter::Telegram {
                seq: 1,
                now_us: 12_345,
                baud: 9,
                bytes: &telegram,
            },
            ToAdapter::Tick {
                seq: 2,
                now_us: u64::MAX,
                drive_rx_bytes: u32::MAX,
            },
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
    fn the_largest_reply_fits_a_frame() {
        let response = [0xAAu8; 255];
        let reply = FromAdapter::Reply {
            seq: u32::MAX,
            response: &response,
            cycles: u32::MAX,
            status: status(),
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(&reply, &mut buf).unwrap().to_vec();
        let (got, dropped) = decode_all!(FromAdapter, &frame);
        assert_eq!(dropped, 0);
        assert_eq!(got, [format!("{reply:?}")]);
    }

    #[test]
    fn garbage_between_frames_is_dropped_and_the_next_frame_decodes() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode(
            &ToAdapter::Tick {
                seq: 5,
                now_us: 6,
                drive_rx_bytes: 7,
            },
            &mut buf,
        )
        .unwrap()
        .to_vec();
        let mut stream = vec![0xFF, 0x13, 0x00];
        stream.extend_from_slice(&frame);
        let (got, dropped) = decode_all!(ToAdapter, &stream);
        assert_eq!(
            got,
            [format!(
                "{:?}",
                ToAdapter::Tick {
                    seq: 5,
                    now_us: 6,
                    drive_rx_bytes: 7,
                }
            )]
        );
        assert_eq!(dropped, 1);
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
