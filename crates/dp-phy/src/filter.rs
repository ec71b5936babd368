//! Input synchroniser, glitch filter and edge detector.
//!
//! The RS-485 receiver's output is asynchronous: one flop takes it into the sample clock domain
//! (`sync`), then the filter lets its output follow only after the input has held a new level for
//! more than `len` clocks. That removes glitches of up to `len` clocks and delays every edge by
//! the same `len + 1` clocks, so pulse widths are kept.
//!
//! ```text
//!  line   ‾‾‾‾‾|_|‾‾‾‾‾‾‾‾|________________
//!  sync   ‾‾‾‾‾‾|_|‾‾‾‾‾‾‾‾|_______________     (1-clock glitch, then a real fall)
//!  out    ‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾‾|_____________     (len = 1: glitch dropped, edge delayed)
//! ```

/// Registers of the filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilterQ {
    pub sync: bool,
    pub count: u16,
    pub out: bool,
}

/// Outputs of one clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilterOut {
    pub level: bool,
    pub fell: bool,
    pub rose: bool,
}

/// The longest filter the counter holds.
pub const MAX_FILTER_LEN: u16 = u16::MAX - 1;

/// Reset state: the line idles high.
pub const FILTER_RESET: FilterQ = FilterQ {
    sync: true,
    count: 0,
    out: true,
};

/// Next state for input `line` with filter length `len`.
#[inline(always)]
pub fn next(line: bool, len: u16, q: &FilterQ) -> (FilterOut, FilterQ) {
    debug_assert!(len <= MAX_FILTER_LEN);
    let mut d = *q;
    d.sync = line;
    if q.sync == q.out {
        d.count = 0;
    } else if q.count >= len {
        d.out = q.sync;
        d.count = 0;
    } else {
        d.count = q.count + 1;
    }
    let out = FilterOut {
        level: d.out,
        fell: q.out && !d.out,
        rose: !q.out && d.out,
    };
    (out, d)
}

/// Whether a constant `line` leaves the filter unchanged (nothing but time passes).
pub fn is_quiet(line: bool, q: &FilterQ) -> bool {
    q.sync == line && q.out == line && q.count == 0
}

/// Ticks a constant `line` lets pass before the output changes, and the level the output holds
/// meanwhile: forever when the filter has settled on `line`; while it counts towards a change,
/// the clocks left to count (the output flips on the clock after); none while the synchroniser
/// has not yet taken `line`.
pub fn quiet_for(line: bool, len: u16, q: &FilterQ) -> (u64, bool) {
    if q.sync != line {
        (0, q.out)
    } else if q.out == line {
        if q.count == 0 {
            (u64::MAX, q.out)
        } else {
            (0, q.out)
        }
    } else {
        (u64::from(len.saturating_sub(q.count)), q.out)
    }
}

/// Lets `ticks` pass that [`quiet_for`] allowed for this `line`.
pub fn skip(line: bool, ticks: u64, q: &mut FilterQ) {
    if q.sync == line && q.out != line {
        // Bounded by quiet_for: count stays at most len, which fits a u16.
        q.count = (u64::from(q.count) + ticks) as u16;
    }
}

/// The filter length for a bit of `clocks_per_bit` clocks: a sixteenth of a bit, at least 1.
pub fn len_for(clocks_per_bit: u64) -> u16 {
    (clocks_per_bit / 16).clamp(1, 15) as u16
}

/// The receiver's filter length at a known rate: every pulse shorter than half a bit is a
/// glitch (a real one lasts a bit at least), so it drops them all, at least 1 clock.
pub fn glitch_len_for(clocks_per_bit: u64) -> u16 {
    (clocks_per_bit / 2)
        .saturating_sub(1)
        .clamp(1, MAX_FILTER_LEN as u64) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(line: &[bool], len: u16) -> Vec<bool> {
        let mut q = FILTER_RESET;
        line.iter()
            .map(|&l| {
                let (o, d) = next(l, len, &q);
                q = d;
                o.level
            })
            .collect()
    }

    #[test]
    fn glitches_up_to_len_are_dropped() {
        let mut line = vec![true; 4];
        line.extend([false, false]); // 2-clock glitch
        line.extend([true; 6]);
        assert!(run(&line, 2).iter().all(|&l| l));
        assert!(run(&line, 1).iter().any(|&l| !l));
    }

    #[test]
    fn edges_are_delayed_by_len_plus_one_and_widths_kept() {
        let mut line = vec![true; 3];
        line.extend([false; 5]);
        line.extend([true; 8]);
        let out = run(&line, 1);
        let first_low = out.iter().position(|&l| !l).unwrap();
        let width = out[first_low..].iter().take_while(|&&l| !l).count();
        assert_eq!(first_low, 3 + 2);
        assert_eq!(width, 5);
    }
}
