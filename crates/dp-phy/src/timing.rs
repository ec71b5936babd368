//! Exact fractional bit timing as a phase accumulator.
//!
//! A bit lasts `modulo` phase units; every sample clock adds `inc`. With `inc = baud x (1e6 + ppm)`
//! and `modulo = f_clk x 1e6`, the accumulator reproduces a station whose oscillator is `ppm` off
//! the reference exactly, with no rounding that could build up over a telegram. Everything is an
//! integer: this is what the FPGA's baud generator computes.

use crate::Tick;
use dp_consts::Baud;

/// The sample clock of the adapter's transceiver unless configured otherwise: the production
/// board's FPGA's (crates/board).
pub const DEFAULT_CLOCK_HZ: u32 = board::TRANSCEIVER_FPGA.sample_clock_hz;

const PPM_SCALE: u64 = 1_000_000;

/// Bit period of one station at one rate, in phase units per sample clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BitTiming {
    /// Phase added per sample clock.
    pub inc: u64,
    /// Phase of one bit.
    pub modulo: u64,
}

impl BitTiming {
    /// Timing of `baud` seen from a clock of `clock_hz`, for a station `ppm` fast (negative: slow).
    ///
    /// # Panics
    /// When a bit is shorter than 3 sample clocks: the receiver cannot find a bit's middle then.
    pub fn new(clock_hz: u32, baud: Baud, ppm: i32) -> Self {
        let scaled = PPM_SCALE as i64 + ppm as i64;
        assert!(scaled > 0, "clock offset {ppm} ppm is not a clock");
        let timing = BitTiming {
            inc: baud.bits_per_second() as u64 * scaled as u64,
            modulo: clock_hz as u64 * PPM_SCALE,
        };
        assert!(
            timing.modulo >= 3 * timing.inc,
            "{baud} needs at least 3 sample clocks per bit; {clock_hz} Hz gives fewer"
        );
        timing
    }

    /// The adapter's own timing of `baud`: a bit of whole sample clocks (the nearest), as a
    /// divider of the sample clock makes it. At 48 MHz every rate's bit is whole already but
    /// 45.45k's, which becomes 1,056 clocks (45,454.5 bit/s, 100 ppm off the nominal 45,450,
    /// what a 48 MHz ASIC makes): the receiver's and the transmitter's phase registers then
    /// count clocks, 13 bits at 9.6k, where the exact fraction needed 19.
    pub fn whole_clocks(clock_hz: u32, baud: Baud) -> Self {
        let exact = Self::new(clock_hz, baud, 0);
        BitTiming {
            inc: 1,
            modulo: (exact.modulo + exact.inc / 2) / exact.inc,
        }
    }

    /// The same timing in the fewest phase units: `inc` and `modulo` over their greatest
    /// common divisor. Every comparison of the receivers is between sums of `inc` and
    /// multiples of `modulo`, so none changes; the RTL's phase registers get narrow (12 Mbit/s
    /// at 48 MHz is 1 in 4, 45.45 kbit/s 303 in 320,000).
    pub fn reduced(&self) -> BitTiming {
        let (mut a, mut b) = (self.inc, self.modulo);
        while b != 0 {
            (a, b) = (b, a % b);
        }
        BitTiming {
            inc: self.inc / a,
            modulo: self.modulo / a,
        }
    }

    /// Whole sample clocks in one bit (rounded down).
    pub fn clocks_per_bit(&self) -> u64 {
        self.modulo / self.inc
    }

    /// Sample clocks that `num / den` bit times last, rounded up.
    pub fn clocks_for(&self, num: u64, den: u64) -> u64 {
        (num * self.modulo).div_ceil(den * self.inc)
    }

    /// Ticks from a phase `ph` until the accumulator first reaches `threshold` (at least 1).
    pub fn ticks_until(&self, ph: u64, threshold: u64) -> Tick {
        if threshold <= ph {
            1
        } else {
            (threshold - ph).div_ceil(self.inc)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fractional_rate_stays_exact_over_a_long_telegram() {
        // 45.45 kbit/s at 48 MHz is 1056.105... clocks per bit; over 255 characters the
        // accumulator must land on the exact rational, not on 1056 x bits.
        let t = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B45450, 0);
        assert_eq!(t.clocks_per_bit(), 1056);
        let bits = 255 * 11;
        let mut ph = 0u64;
        let mut ticks = 0u64;
        let mut wraps = 0;
        while wraps < bits {
            ph += t.inc;
            ticks += 1;
            if ph >= t.modulo {
                ph -= t.modulo;
                wraps += 1;
            }
        }
        // 2805 bits x 48e6 / 45450 = 2962376.24 clocks: the last wrap is on clock 2962377.
        assert_eq!(ticks, t.clocks_for(bits, 1));
        assert_eq!(ticks, 2_962_377);
    }

    #[test]
    fn reduced_timing_is_the_same_bit_in_fewest_units() {
        let t = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B45450, 0).reduced();
        assert_eq!((t.inc, t.modulo), (303, 320_000));
        let t = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B12000000, 0).reduced();
        assert_eq!((t.inc, t.modulo), (1, 4));
        let off = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B9600, 5000);
        assert_eq!(off.reduced().clocks_for(1000, 1), off.clocks_for(1000, 1));
    }

    #[test]
    fn ppm_offsets_scale_the_bit() {
        let fast = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B9600, 5000);
        let slow = BitTiming::new(DEFAULT_CLOCK_HZ, Baud::B9600, -5000);
        assert_eq!(fast.clocks_for(1000, 1), 4_975_125); // 5e6 / 1.005, rounded up
        assert_eq!(slow.clocks_for(1000, 1), 5_025_126);
    }

    #[test]
    #[should_panic(expected = "3 sample clocks")]
    fn too_slow_a_clock_is_refused() {
        BitTiming::new(24_000_000, Baud::B12000000, 0);
    }
}
