//! The DP master's station on the bit-level bus: profirust's `ProfibusPhy` over a UART
//! transmitter and a fixed-rate receiver of `dp-phy`.
//!
//! profirust hands whole telegrams to `transmit_data`; they go out bit by bit at the master's
//! rate (and clock offset). Characters the receiver decodes from the line become visible to
//! `receive_data` as each stop bit ends. The PHY also keeps the line idle for TSYN (33 bits)
//! before each telegram, as a master's bus controller does in hardware: profirust counts time
//! in whole microseconds, and at 6 and 12 Mbit/s its rounding would leave a few bits short.
//!
//! Bytes that never make a telegram (an answer that lost a character to noise) are dropped
//! once the line has been idle for TSYN, as a bus controller's receiver resynchronises, and
//! when profirust sends. profirust 0.6 counts a received byte as bus activity only while the
//! buffer grows past the count it saw last, and sets that count back to 0 only on a good
//! telegram: a PHY whose buffer shrinks otherwise (profirust's own PHYs empty it when they send)
//! leaves the count high, and every later answer longer than the slot time is then cut off at
//! the slot time, for good (the soak's seed 1, event 18: a glitch at 187.5k lost the master its
//! slave). So this PHY reports as pending the bytes received since the last good telegram
//! ([`MasterPhy::poll_pending_received_bytes`]), which grows with every byte as profirust
//! expects.

/// How many sent telegrams [`MasterPhy::recent`] keeps: more than can be on the line or in
/// the transceiver's delimiter at once.
pub(crate) const RECENT_TELEGRAMS: usize = 8;

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
    /// The last few of them, newest last: what the transceiver may deliver as good.
    pub recent: std::collections::VecDeque<Vec<u8>>,
    /// Bytes received since profirust's last good telegram that are no longer in `received`
    /// (taken as broken, or dropped).
    dropped_since_good: usize,
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
            recent: std::collections::VecDeque::with_capacity(RECENT_TELEGRAMS),
            dropped_since_good: 0,
            last_activity: 0,
            now: 0,
        }
    }

    pub fn timing(&self) -> BitTiming {
        self.tx.tx.timing
    }

    /// Drops received bytes that are not a whole telegram once the line has been idle for TSYN
    /// after them: the rest of that telegram is not coming.
    pub fn drop_stale_characters(&mut self) {
        let cpb = self.timing().clocks_per_bit().max(1);
        let idle = self.now.saturating_sub(self.last_activity);
        if idle >= u64::from(dp_consts::TSYN_BITS) * cpb {
            self.drop_received();
        }
    }

    fn drop_received(&mut self) {
        self.dropped_since_good += self.received.len();
        self.received.clear();
    }

    /// Queues a telegram after whatever idle time is still missing to TSYN.
    pub fn send(&mut self, bytes: &[u8]) {
        let cpb = self.timing().clocks_per_bit().max(1);
        let idle_bits = (self.now.saturating_sub(self.last_activity) / cpb) as u32;
        let missing = (dp_consts::TSYN_BITS + 1).saturating_sub(idle_bits);
        self.tx.push(missing, bytes);
        self.telegrams_sent += 1;
        if self.recent.len() == RECENT_TELEGRAMS {
            self.recent.pop_front();
        }
        self.recent.push_back(bytes.to_vec());
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
            self.drop_received();
            self.send(&buffer[..len]);
        }
        result
    }

    fn receive_data<F, R>(&mut self, _now: profirust::time::Instant, f: F) -> R
    where
        F: FnOnce(&[u8]) -> (usize, R),
    {
        let (used, result) = f(&self.received);
        let used = used.min(self.received.len());
        if used > 0 {
            // profirust takes a good telegram's bytes, or all of them as broken.
            let good = matches!(
                profirust::fdl::Telegram::deserialize(&self.received[..used]),
                Some(Ok((_, len))) if len == used
            );
            self.dropped_since_good = if good {
                0
            } else {
                self.dropped_since_good + used
            };
            self.received.drain(..used);
        }
        result
    }

    fn poll_pending_received_bytes(&mut self, _now: profirust::time::Instant) -> usize {
        self.dropped_since_good + self.received.len()
    }
}
