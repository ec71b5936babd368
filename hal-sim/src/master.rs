//! The DP master's station on the bit-level bus: profirust's `ProfibusPhy` over a UART
//! transmitter and a fixed-rate receiver of `dp-phy`.
//!
//! profirust hands whole telegrams to `transmit_data`; they go out bit by bit at the master's
//! rate (and clock offset). Characters the receiver decodes from the line become visible to
//! `receive_data` as each stop bit ends. The PHY also keeps the line idle for TSYN (33 bits)
//! before each telegram, as a master's bus controller does in hardware: profirust counts time
//! in whole microseconds, and at 6 and 12 Mbit/s its rounding would leave a few bits short.

use dp_phy::bus::TxStation;
use dp_phy::station::StationRx;
use dp_phy::{BitTiming, Tick};
use profirust::phy::ProfibusPhy;

pub struct MasterPhy {
    pub tx: TxStation,
    pub rx: StationRx,
    /// Decoded bytes not yet taken by profirust.
    pub received: Vec<u8>,
    /// Characters received with an error (dropped, as a UART driver drops them).
    pub char_errors: u64,
    /// Telegrams handed to the transmitter.
    pub telegrams_sent: u64,
    /// The last tick the line was busy (low, or driven by anyone).
    pub last_activity: Tick,
    /// The current tick (kept by the co-simulation).
    pub now: Tick,
}

impl MasterPhy {
    pub fn new(timing: BitTiming) -> MasterPhy {
        MasterPhy {
            tx: TxStation::new(timing),
            rx: StationRx::new(timing),
            received: Vec::new(),
            char_errors: 0,
            telegrams_sent: 0,
            last_activity: 0,
            now: 0,
        }
    }

    pub fn timing(&self) -> BitTiming {
        self.tx.tx.timing
    }

    /// Queues a telegram after whatever idle time is still missing to TSYN.
    pub fn send(&mut self, bytes: &[u8]) {
        let cpb = self.timing().clocks_per_bit().max(1);
        let idle_bits = (self.now.saturating_sub(self.last_activity) / cpb) as u32;
        let missing = (dp_consts::TSYN_BITS + 1).saturating_sub(idle_bits);
        self.tx.push(missing, bytes);
        self.telegrams_sent += 1;
    }
}

impl ProfibusPhy for MasterPhy {
    fn poll_transmission(&mut self, _now: profirust::time::Instant) -> bool {
        !self.tx.done()
    }

    fn transmit_data<F, R>(&mut self, _now: profirust::time::Instant, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> (usize, R),
    {
        let mut buffer = [0u8; 256];
        let (len, result) = f(&mut buffer);
        if len > 0 {
            // A new request: whatever is left of an earlier answer is stale.
            self.received.clear();
            self.send(&buffer[..len]);
        }
        result
    }

    fn receive_data<F, R>(&mut self, _now: profirust::time::Instant, f: F) -> R
    where
        F: FnOnce(&[u8]) -> (usize, R),
    {
        let (used, result) = f(&self.received);
        self.received.drain(..used.min(self.received.len()));
        result
    }
}
