//! The line at the receiver's rate as the transceiver's idle time, gap and TSDR count it: high
//! since when, that rate's glitches aside (a pulse of at most the rate's glitch length never
//! was).
//!
//! Contract: [`RateIdle::edge`] takes each change of the line as the rate's channel of the
//! search samples it, and keeps what `AutoBaud` keeps for that channel (its `pending`,
//! `high_since` and `high_before`, by the same rule). A copy started at a detection of the
//! rate ([`RateIdle::from_detection`]) goes on from the detecting channel's pending edge, and
//! takes the detected character's end as its high ticks: the transceiver only ever counts
//! through `max(last_end, high_since)`, and `last_end` is that end or later from then on, so
//! the sum is the channel's own at every clock (the test below holds it, and debug builds of
//! the transceiver check it at every clock). Unless the channel's line rose after that end
//! before the decision (`Detection::rose_after_end`: a decision that waited for a second
//! candidate start, with the next start bit in between): the copy then takes the decision's
//! tick, and counts no longer than the channel, from where the receiver starts.
//!
//! Why: the gateware's search keeps those registers as the samples they still lack of TSYN,
//! the seven slowest channels in block RAM, read only in their turn; the transceiver's top
//! keeps this copy for the rate it is on and needs nothing of the search's channels but a
//! detection (README "Gateware").

use crate::autobaud::Detection;
use crate::Tick;

/// The idle line's registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RateIdle {
    /// The last edge that a next one within the glitch length cancels (`Tick::MAX`: none).
    pub pending: Tick,
    /// The line has been high since this tick, glitches aside.
    pub high_since: Tick,
    /// What a cancelled rise goes back to.
    pub high_before: Tick,
}

/// No rate: its idle line is never read.
pub const RATE_IDLE_NONE: RateIdle = RateIdle {
    pending: Tick::MAX,
    high_since: 0,
    high_before: 0,
};

impl RateIdle {
    /// Going on from the search's channel at `detection`, decided on tick `decided_at`: high
    /// since the character's end, or since the decision if the channel's line rose after that
    /// end (the copy cannot know when: it counts no longer than the channel, and from where
    /// the receiver starts).
    pub fn from_detection(detection: &Detection, decided_at: Tick) -> RateIdle {
        let from = detection.idle_from(decided_at);
        RateIdle {
            pending: detection.pending,
            high_since: from,
            high_before: from,
        }
    }

    /// The line at the rate changed at `now` (it `rose`, or fell); `glitch`: the rate's
    /// glitch length in clocks.
    pub fn edge(&mut self, now: Tick, rose: bool, glitch: Tick) {
        let cancels = self.pending != Tick::MAX && now - self.pending <= glitch;
        let (since, before) = (self.high_since, self.high_before);
        (self.high_since, self.high_before) = match (rose, cancels) {
            (true, false) => (now, since),
            (false, true) => (before, before),
            _ => (since, before),
        };
        self.pending = if cancels { Tick::MAX } else { now };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::autobaud::{AutoBaud, AUTOBAUD_RESET, OVERSAMPLED};
    use crate::filter::FilterOut;
    use crate::timing::DEFAULT_CLOCK_HZ;
    use crate::uart::char_bits;
    use crate::{Baud, BitTiming};
    use proptest::prelude::*;

    /// A start delimiter from a master `ppm` off, back to back with the next characters, a low
    /// glitch of `len` clocks `at` clocks into the delimiter's stop bit (a decision that waits
    /// for the stop bit's end, meeting the next start within a glitch's length when the master
    /// is fast), and glitches after it (each turns the line over while it lasts). Each copy
    /// started at a detection takes the channel's changes from then on; `max(end, high_since)`
    /// must be the channel's at every clock. Returns the detections of the delimiter.
    fn compare(baud: Baud, ppm: i32, at: u64, len: u64, later: &[(u64, u64)]) -> usize {
        let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
        let bit = master.clocks_per_bit();
        let stop = master.clocks_for(10, 1);
        let mut glitches = vec![(stop + at, len)];
        glitches.extend(later.iter().map(|&(from, n)| (stop + bit + from, n)));
        compare_with_glitches(baud, ppm, &glitches).0
    }

    /// As [`compare`], with glitches (clocks from the delimiter's start edge, clocks long)
    /// anywhere. A copy from a detection whose line rose after its end must count no longer
    /// than the channel. Returns the detections of the delimiter, and those of them.
    fn compare_with_glitches(baud: Baud, ppm: i32, at_from_start: &[(u64, u64)]) -> (usize, usize) {
        let search = AutoBaud::sampled(DEFAULT_CLOCK_HZ, OVERSAMPLED);
        let r = baud.index();
        let glitch = search.channel_figures(baud).glitch;
        let master = BitTiming::new(DEFAULT_CLOCK_HZ, baud, ppm);
        let t0 = master.clocks_for(40, 1);
        let bits: Vec<bool> = [dp_consts::SD2, 0x05, 0x05]
            .iter()
            .flat_map(|&b| char_bits(b))
            .collect();
        let glitches: Vec<(u64, u64)> = at_from_start.iter().map(|&(at, n)| (t0 + at, n)).collect();
        let end = t0 + master.clocks_for(bits.len() as u64 + 30, 1);
        let mut q = AUTOBAUD_RESET;
        let mut copy: Option<(RateIdle, Tick, bool)> = None;
        let mut level = true;
        let (mut detections, mut late_detections) = (0, 0);
        for now in 0..end {
            let clean = now < t0 || {
                let i = ((now - t0) * master.inc / master.modulo) as usize;
                bits.get(i).copied().unwrap_or(true)
            };
            // A glitch turns the line over while it lasts (two at once cancel).
            let turned = glitches
                .iter()
                .filter(|&&(g, n)| (g..g + n).contains(&now))
                .count()
                % 2
                == 1;
            let line = clean != turned;
            let out = FilterOut {
                level: line,
                fell: level && !line,
                rose: !level && line,
            };
            level = line;
            let held = q.held[r];
            let det = search.clock(now, out, None, &mut q);
            if let Some((idle, _, _)) = &mut copy {
                if q.held[r] != held {
                    idle.edge(now, q.held[r], glitch);
                }
            }
            if let Some(Ok(d)) = det.filter(|d| d.is_ok_and(|d| d.baud == baud)) {
                detections += 1;
                late_detections += usize::from(d.rose_after_end);
                copy = Some((RateIdle::from_detection(&d, now), d.end, d.rose_after_end));
            }
            if let Some((idle, from, late)) = copy {
                let (ours, channel) = (from.max(idle.high_since), from.max(q.high_since[r]));
                let at = format!("{baud} {ppm} ppm, glitches {at_from_start:?}: at {now}");
                if late {
                    assert!(ours >= channel, "{at}: longer than the channel's");
                } else {
                    assert_eq!(ours, channel, "{at}");
                }
            }
        }
        (detections, late_detections)
    }

    #[test]
    fn a_copy_from_a_detection_decided_after_the_next_start_bit_counts_no_longer() {
        // Fast by 5,000 ppm, a high glitch late in the start bit: the fall after it is a second
        // candidate start, and the decision waits for its stop bit, past the delimiter's end
        // and the next character's start bit (0x05 sends a 1 first: the line rises). Some
        // glitches make the decision come after that rise. Found at the five slowest rates;
        // at 500k and faster no glitch of this set does it: the channel's samples fall so
        // that the decision comes before the rise.
        for baud in &Baud::ALL[..5] {
            let bit = BitTiming::new(DEFAULT_CLOCK_HZ, *baud, 0).clocks_per_bit();
            let late: usize = (60..100)
                .step_by(2)
                .flat_map(|at| [10, 30].map(|len| (at, len)))
                .map(|(at, len)| {
                    let glitch = (at * bit / 100, (len * bit / 100).max(1));
                    compare_with_glitches(*baud, 5000, &[glitch]).1
                })
                .sum();
            assert!(late > 0, "{baud}: no detection decided after the line rose");
        }
    }

    #[test]
    fn a_copy_from_a_detection_with_a_pending_edge_follows_the_channel() {
        // Fast by 5,000 ppm, a glitch at the stop bit's middle: the decision waits for the
        // stop bit's end, where the next start has come (within a glitch's length). A high
        // glitch of the rate just after it in the start bit cancels that start edge in the
        // channel; the copy must too.
        for baud in Baud::ALL {
            let bit = BitTiming::new(DEFAULT_CLOCK_HZ, baud, 0).clocks_per_bit();
            // The next start comes 0.055 bit before the adapter's stop bit's end; the high
            // glitch 0.1 bit into it, after the decision.
            let found = compare(baud, 5000, bit / 2, bit / 8 + 1, &[(bit / 10, bit / 8)]);
            assert_eq!(found, 1, "{baud}: the delimiter is not detected");
        }
    }

    proptest! {
        #![proptest_config(prop_cases::config(256))]

        #[test]
        fn a_copy_from_a_detection_follows_the_channel(
            rate in 0usize..10,
            ppm in -5000i32..=5000,
            at in 0u64..100,
            len in 1u64..60,
            later in proptest::collection::vec((0u64..400, 1u64..80), 0..4),
        ) {
            let bit = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::ALL[rate], 0).clocks_per_bit();
            // In hundredths of a bit: the stop-bit glitch up to 0.6 bit, the later ones up to
            // 4 bits on and 0.8 bit long.
            let later: Vec<(u64, u64)> =
                later.iter().map(|&(f, n)| (f * bit / 100, (n * bit / 100).max(1))).collect();
            compare(Baud::ALL[rate], ppm, at * bit / 100, (len * bit / 100).max(1), &later);
        }
    }
}
