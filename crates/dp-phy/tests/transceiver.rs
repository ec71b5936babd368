//! The transceiver against a master's transmitter on a simulated line: autobaud at every rate,
//! clock offsets, bit errors, noise, relock, TSYN, response timing, and fast == strict.

use dp_phy::bus::{FaultInjector, FaultWindow, LineFault, Outgoing};
use dp_phy::delimiter::Status;
use dp_phy::testbench::{poll_sequence, random_telegram, Kind, Testbench};
use dp_phy::timing::DEFAULT_CLOCK_HZ;
use dp_phy::uart::CharFault;
use dp_phy::{Baud, BaudState, BitTiming, Config};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const CLOCK: u32 = DEFAULT_CLOCK_HZ;

fn bench(baud: Baud, ppm: i32) -> Testbench {
    bench_with(Config::default(), baud, ppm)
}

fn bench_with(cfg: Config, baud: Baud, ppm: i32) -> Testbench {
    Testbench::new(cfg, BitTiming::new(CLOCK, baud, ppm), FaultInjector::none())
}

/// The transceiver with every channel of the search sampling every clock.
fn every_clock() -> Config {
    Config {
        search_schedule: dp_phy::autobaud::EVERY_CLOCK,
        ..Config::default()
    }
}

/// Run `replay` on a traced bench and leave its waveform in the test's temporary directory.
fn trace_run(name: &str, replay: impl FnOnce(&mut Testbench)) {
    trace_bench(name, bench(Baud::B1500000, 0), replay);
}

/// Trace `tb` through `replay` into `<tmp>/<name>.vcd`.
fn trace_bench(name: &str, mut tb: Testbench, replay: impl FnOnce(&mut Testbench)) {
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.vcd"));
    let file = std::fs::File::create(&path).expect("create waveform");
    tb.trace_to(Box::new(std::io::BufWriter::new(file)))
        .unwrap();
    replay(&mut tb);
    tb.finish_trace().unwrap();
    eprintln!("{name}: waveform in {}", path.display());
}

/// Run `build`'s bench fast and apply `check`; when it fails, run the same bench again strictly
/// with a waveform and leave it in the test's temporary directory before failing.
fn check_or_dump(name: &str, build: impl Fn() -> Testbench, check: impl Fn(&Testbench)) {
    let mut tb = build();
    tb.run_out(40, true);
    let failed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&tb)));
    if let Err(e) = failed {
        trace_bench(name, build(), |tb| tb.run_out(40, false));
        std::panic::resume_unwind(e);
    }
}

/// The lock happened once, to `baud`, when the first telegram ended.
fn assert_locked_on_first(tb: &Testbench, baud: Baud) {
    let first = &tb.delivered[0];
    assert_eq!(
        first.status,
        Status::Good,
        "first telegram {:02x?}",
        first.bytes
    );
    let locked: Vec<_> = tb
        .baud_log
        .iter()
        .filter(|(_, s)| matches!(s, BaudState::Locked(_)))
        .collect();
    assert_eq!(locked.len(), 1, "{:?}", tb.baud_log);
    assert_eq!(locked[0].1, BaudState::Locked(baud));
    // Delivered (and locked) at the middle of the stop bit: the receiver weighs each bit by the
    // level the line held longer, with no filter holding the line back. `end` is where the stop
    // bit ends, half a bit later. The receiver samples the line as the search's channel of the
    // rate does: the middle and the end are each the first sample at or after them.
    let t = BitTiming::new(CLOCK, baud, 0);
    let late = locked[0].0 as i64 - first.end as i64;
    let half = t.clocks_for(1, 2) as i64;
    let sample = dp_phy::autobaud::OVERSAMPLED.period[baud.index()] as i64;
    let window = -half - sample - 2..=-half + sample + 2;
    assert!(window.contains(&late), "locked {late} clocks after the end");
    assert_eq!(
        tb.baud_log[0].1,
        BaudState::Trial(baud),
        "trial on its first character"
    );
}

#[test]
fn every_rate_locks_on_the_first_character_and_delivers_every_kind_bit_exact() {
    for baud in Baud::ALL {
        for ppm in [-5000, 0, 5000] {
            let seed = baud.index() as u64 * 100_000 + (ppm + 5000i32) as u64;
            let build = || {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let mut tb = bench(baud, ppm);
                // Random phase: the master starts at an arbitrary tick.
                tb.run_until(rng.gen_range(0..5000), true);
                let lead = rng.gen_range(40..80);
                // The first telegram of each run is each SD type in turn; the rest are random.
                for i in 0..12 {
                    let kind = if i < 4 {
                        [Kind::Sd1, Kind::Sd2, Kind::Sd3, Kind::Sd4][(baud.index() + i) % 4]
                    } else {
                        Kind::ALL[rng.gen_range(0..5)]
                    };
                    let n = rng.gen_range(1..=246);
                    tb.send(
                        if i == 0 { lead } else { 33 },
                        &random_telegram(&mut rng, kind, n),
                    );
                }
                tb
            };
            let sent: Vec<Vec<u8>> = build()
                .master
                .queue
                .iter()
                .map(|o| o.bytes.clone())
                .collect();
            check_or_dump(&format!("every_rate_{baud}_{ppm}"), build, |tb| {
                assert_eq!(tb.good(), sent, "{baud} {ppm} ppm");
                assert_locked_on_first(tb, baud);
            });
        }
    }
}

#[test]
fn bit_errors_are_never_delivered_as_good_and_the_next_clean_telegram_is() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for baud in Baud::ALL {
        let mut tb = bench(baud, 3000);
        let mut clean = Vec::new();
        let lock = random_telegram(&mut rng, Kind::Sd2, 10);
        tb.send(40, &lock);
        clean.push(lock);
        for _ in 0..30 {
            let bad = {
                let n = rng.gen_range(1..40);
                random_telegram(&mut rng, Kind::Sd2, n)
            };
            // One to three flipped data bits: within the Hamming distance 4 of FT1.2.
            let faults = (0..rng.gen_range(1..=3))
                .map(|_| {
                    let char_index = rng.gen_range(0..bad.len() as u16);
                    (char_index, CharFault::FlipBit(rng.gen_range(0..8)))
                })
                .collect();
            tb.send_outgoing(Outgoing {
                idle_bits: 33,
                bytes: bad,
                faults,
            });
            let next = random_telegram(&mut rng, Kind::Sd1, 0);
            tb.send(33, &next);
            clean.push(next);
        }
        tb.run_out(40, true);
        assert_eq!(tb.good(), clean, "{baud}");
        assert!(
            tb.delivered
                .iter()
                .filter(|d| d.status != Status::Good)
                .count()
                >= 30
        );
    }
}

#[test]
fn dropped_characters_and_a_stuck_line_are_flagged_and_the_link_recovers() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let baud = Baud::B187500;
    let t = BitTiming::new(CLOCK, baud, 0);
    let mut faults = FaultInjector::none();
    let mut tb = bench(baud, 0);
    let first = random_telegram(&mut rng, Kind::Sd2, 20);
    tb.send(40, &first);
    let dropped = random_telegram(&mut rng, Kind::Sd2, 20);
    tb.send_outgoing(Outgoing {
        idle_bits: 33,
        bytes: dropped,
        faults: vec![(7, CharFault::Drop)],
    });
    let after = random_telegram(&mut rng, Kind::Sd3, 0);
    tb.send(33, &after);
    // The line stuck low for 200 bits, well after those, then clean telegrams again.
    let stuck_at = t.clocks_for(40 + 26 * 11 + 33 + 26 * 11 + 33 + 14 * 11 + 100, 1);
    faults.add(FaultWindow {
        start: stuck_at,
        len: t.clocks_for(200, 1),
        fault: LineFault::Stuck(false),
    });
    tb.bus.faults = faults;
    tb.run_until(stuck_at + t.clocks_for(400, 1), true);
    let recovered = random_telegram(&mut rng, Kind::Sd1, 0);
    tb.send(33, &recovered);
    tb.run_out(40, true);
    let statuses: Vec<Status> = tb.delivered.iter().map(|d| d.status).collect();
    assert_eq!(statuses[0], Status::Good);
    assert_eq!(statuses[1], Status::Gap, "a dropped character is a gap");
    assert_eq!(tb.good(), vec![first, after, recovered]);
    assert!(
        tb.adapter.stats().char_errors > 0,
        "the stuck line is a break"
    );
}

#[test]
fn random_noise_and_glitches_never_lock() {
    for seed in 0..4u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tb = bench(Baud::B12000000, 0);
        // Random pulses of 1..6000 clocks (every rate's bit and then some), 200 ms of them.
        let mut faults = FaultInjector::none();
        let mut t = 100;
        let end = CLOCK as u64 / 5;
        while t < end {
            let len = rng.gen_range(1..6000);
            faults.add(FaultWindow {
                start: t,
                len,
                fault: LineFault::Invert,
            });
            t += len + rng.gen_range(1..6000);
        }
        faults.glitches(seed, 0, end, 5000, 3);
        tb.bus.faults = faults;
        tb.run_until(end, true);
        let locked = tb
            .baud_log
            .iter()
            .any(|(_, s)| matches!(s, BaudState::Locked(_)));
        assert!(!locked, "seed {seed}: {:?}", tb.baud_log);
        assert!(tb.good().is_empty());
        assert!(
            tb.adapter.stats().search_rejects > 100,
            "the noise was looked at"
        );
    }
}

#[test]
fn glitches_shorter_than_half_a_bit_never_corrupt_a_good_telegram() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for baud in [Baud::B19200, Baud::B500000, Baud::B3000000, Baud::B12000000] {
        let t = BitTiming::new(CLOCK, baud, 0);
        let mut tb = bench(baud, -2000);
        let mut sent = Vec::new();
        for _ in 0..40 {
            let tel = {
                let n = rng.gen_range(1..30);
                random_telegram(&mut rng, Kind::Sd2, n)
            };
            tb.send(33, &tel);
            sent.push(tel);
        }
        let span = t.clocks_for(40 * (33 + 33 * 11), 1);
        let mut faults = FaultInjector::none();
        // About one glitch per telegram, from the second telegram on.
        let start = t.clocks_for(33 + 34 * 11, 1);
        faults.glitches(
            baud.index() as u64,
            start,
            span,
            40,
            (t.clocks_per_bit() / 2 - 1).max(1),
        );
        tb.bus.faults = faults;
        tb.run_out(40, true);
        let good = tb.good();
        for g in &good {
            assert!(
                sent.contains(g),
                "{baud}: corrupted telegram delivered as good: {g:02x?}"
            );
        }
        assert!(
            good.len() > 5,
            "{baud}: the link works between glitches ({})",
            good.len()
        );
    }
}

/// A bench locked at `from`, then the master switched to `to` (with `ppm`) sending `count`
/// random telegrams after 33 idle bits each; returns the bench and the telegrams at `to`.
fn locked_then_changed(
    rng: &mut ChaCha8Rng,
    from: Baud,
    to: Baud,
    ppm: i32,
    count: usize,
) -> (Testbench, Vec<Vec<u8>>) {
    let mut tb = bench(from, -ppm);
    tb.send(40, &random_telegram(rng, Kind::Sd2, 8));
    tb.run_out(40, true);
    assert_eq!(tb.adapter.baud_state(), BaudState::Locked(from));
    tb.set_master_timing(BitTiming::new(CLOCK, to, ppm));
    let sent = poll_sequence(rng, count);
    for (i, t) in sent.iter().enumerate() {
        tb.send(if i == 0 { 40 } else { 33 }, t);
    }
    (tb, sent)
}

/// Issue 17: the slowest to the fastest rate and back, and neighbours: the first telegram at
/// the new rate locks and is delivered, without the watchdog, and so is every one after it.
#[test]
fn a_master_that_changes_rate_is_followed_on_its_first_telegram() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for (from, to) in [
        (Baud::B9600, Baud::B12000000),
        (Baud::B12000000, Baud::B9600),
        (Baud::B1500000, Baud::B19200),
        (Baud::B45450, Baud::B500000),
        (Baud::B6000000, Baud::B12000000),
        (Baud::B12000000, Baud::B6000000),
        (Baud::B19200, Baud::B9600),
    ] {
        for ppm in [-5000, 5000] {
            let (mut tb, sent) = locked_then_changed(&mut rng, from, to, ppm, 8);
            tb.run_out(40, true);
            let case = format!("{from} -> {to} at {ppm} ppm");
            assert_eq!(tb.adapter.baud_state(), BaudState::Locked(to), "{case}");
            assert_eq!(
                &tb.good()[1..],
                &sent[..],
                "{case}: every telegram at the new rate"
            );
            let stats = tb.adapter.stats();
            assert_eq!(stats.relocks, 1, "{case}");
            assert_eq!(stats.watchdog_expiries, 0, "{case}");
            // Straight from the old lock to a trial at the new rate, then the lock.
            let states: Vec<BaudState> = tb.baud_log.iter().map(|(_, s)| *s).collect();
            assert_eq!(
                &states[states.len() - 2..],
                &[BaudState::Trial(to), BaudState::Locked(to)],
                "{case}: {states:?}"
            );
        }
    }
}

/// Noise at the locked rate: glitches, a corrupted telegram, a stuck line and random pulses
/// between telegrams cost the telegrams they hit and never move the lock.
#[test]
fn noise_at_the_locked_rate_never_moves_the_lock() {
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    for baud in Baud::ALL {
        let t = BitTiming::new(CLOCK, baud, 0);
        let mut tb = bench(baud, 2000);
        let mut sent = Vec::new();
        for i in 0..60 {
            let tel = {
                let (n, kind) = (rng.gen_range(1..30), Kind::ALL[rng.gen_range(0..5)]);
                random_telegram(&mut rng, kind, n)
            };
            let faults = if i % 10 == 5 {
                vec![(0, CharFault::FlipBit(rng.gen_range(0..8)))]
            } else {
                vec![]
            };
            tb.send_outgoing(Outgoing {
                idle_bits: 33,
                bytes: tel.clone(),
                faults,
            });
            sent.push(tel);
        }
        // About one glitch per telegram, from the second telegram on.
        let bits: u64 = sent.iter().map(|s| 33 + 11 * s.len() as u64).sum();
        let span = t.clocks_for(bits, 1);
        let start = t.clocks_for(33 + 11 * sent[0].len() as u64, 1);
        let mut faults = FaultInjector::none();
        faults.glitches(
            baud.index() as u64,
            start,
            span,
            60,
            (t.clocks_per_bit() / 2 - 1).max(1),
        );
        // Random pulses of any rate's bit width in one quiet stretch, and the line stuck low.
        let mut at = span + t.clocks_for(20, 1);
        for _ in 0..40 {
            let len = rng.gen_range(4..6000);
            faults.add(FaultWindow {
                start: at,
                len,
                fault: LineFault::Invert,
            });
            at += len + rng.gen_range(1..6000);
        }
        faults.add(FaultWindow {
            start: at + 100,
            len: t.clocks_for(30, 1),
            fault: LineFault::Stuck(false),
        });
        tb.bus.faults = faults;
        tb.run_out(40, true);
        // More telegrams after the noise: the link is still there.
        let after = random_telegram(&mut rng, Kind::Sd1, 0);
        tb.run_until(at + t.clocks_for(200, 1), true);
        tb.send(33, &after);
        tb.run_out(40, true);
        let stats = tb.adapter.stats();
        assert_eq!(stats.relocks, 0, "{baud}");
        assert_eq!(stats.watchdog_expiries, 0, "{baud}");
        let first_lock = tb
            .baud_log
            .iter()
            .position(|(_, s)| *s == BaudState::Locked(baud))
            .expect("locked");
        assert!(
            tb.baud_log[first_lock..]
                .iter()
                .all(|(_, s)| *s == BaudState::Locked(baud)),
            "{baud}: {:?}",
            tb.baud_log
        );
        let good = tb.good();
        assert!(
            good.iter().all(|g| sent.contains(g) || *g == after),
            "{baud}: corrupt"
        );
        assert_eq!(good.last(), Some(&after), "{baud}");
        assert!(good.len() > 20, "{baud}: {} delivered", good.len());
    }
}

/// The watchdog stays the last resort: a master at a new rate whose every telegram fails the
/// trial (a flipped bit in its last character) is never locked on, and the old lock goes when
/// the watchdog expires, not before and not never.
#[test]
fn trials_that_keep_failing_leave_the_watchdog_to_end_the_old_lock() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let (from, to) = (Baud::B500000, Baud::B93750);
    let mut tb = bench(from, 0);
    tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 8));
    tb.run_out(40, true);
    let locked_at = tb.now();
    tb.set_master_timing(BitTiming::new(CLOCK, to, 0));
    for _ in 0..300 {
        let tel = random_telegram(&mut rng, Kind::Sd2, 10);
        let last = tel.len() as u16 - 1;
        tb.send_outgoing(Outgoing {
            idle_bits: 40,
            bytes: tel,
            faults: vec![(last, CharFault::FlipBit(3))],
        });
    }
    tb.run_out(40, true);
    let stats = tb.adapter.stats();
    assert_eq!(stats.relocks, 0);
    assert!(stats.relock_trials_failed > 10, "{stats:?}");
    assert_eq!(stats.watchdog_expiries, 1);
    let searching_at = tb
        .baud_log
        .iter()
        .find(|(_, s)| *s == BaudState::Searching)
        .expect("the watchdog let go")
        .0;
    let watchdog = Config::default().baud_watchdog_10ms as u64 * (CLOCK as u64 / 100);
    // From the old lock's last good telegram (it ended just before `locked_at`).
    assert!(
        searching_at >= locked_at + watchdog - t_clocks(from, 60)
            && searching_at <= locked_at + watchdog + t_clocks(to, 300),
        "searching at {searching_at}, locked at {locked_at}"
    );
}

/// A watchdog that runs out while the first character of a telegram is on the line waits for
/// the telegram (it is evidence of the rate), which restarts it: the telegram is delivered and
/// the lock stays, at every rate. (It once expired on the clock that character was delivered,
/// before the delimiter was inside a telegram, and dropped it: found by CI's
/// `a_rate_change_relocks_without_the_watchdog`.)
#[test]
fn a_watchdog_that_runs_out_in_a_telegrams_first_character_waits_for_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    let watchdog = Config::default().baud_watchdog_10ms as u64 * (CLOCK as u64 / 100);
    for baud in Baud::ALL {
        for into_the_character in [1, 5, 10] {
            let mut tb = bench(baud, 0);
            tb.send(40, &random_telegram(&mut rng, Kind::Sd2, 8));
            tb.run_out(40, true);
            let expiry = tb.delivered[0].end + watchdog;
            let next = random_telegram(&mut rng, Kind::Sd2, 8);
            // Its start bit `into_the_character` bits before the watchdog runs out.
            tb.run_until(expiry - t_clocks(baud, 40 + into_the_character), true);
            tb.send(40, &next);
            tb.run_out(40, true);
            let case = format!("{baud}, {into_the_character} bits in");
            assert_eq!(tb.good().last(), Some(&next), "{case}");
            assert_eq!(tb.adapter.stats().watchdog_expiries, 0, "{case}");
            assert_eq!(tb.adapter.baud_state(), BaudState::Locked(baud), "{case}");
            assert_eq!(tb.baud_log.len(), 2, "{case}: {:?}", tb.baud_log);
        }
    }
}

fn t_clocks(baud: Baud, bits: u64) -> u64 {
    BitTiming::new(CLOCK, baud, 0).clocks_for(bits, 1)
}

#[test]
fn tsyn_32_idle_bits_do_not_arm_a_request_33_do() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for baud in Baud::ALL {
        for ppm in [-5000, 5000] {
            let mut tb = bench(baud, ppm);
            let lock = random_telegram(&mut rng, Kind::Sd1, 0);
            let early = random_telegram(&mut rng, Kind::Sd1, 0);
            let ok = random_telegram(&mut rng, Kind::Sd3, 0);
            tb.send(33, &lock);
            tb.send(32, &early);
            tb.send(33, &ok);
            tb.run_out(40, true);
            assert_eq!(
                tb.good(),
                vec![lock.clone(), ok.clone()],
                "{baud} {ppm} ppm"
            );
            assert!(tb.adapter.stats().not_synced >= early.len() as u64);
        }
    }
    // From power-up too: 32 idle bits before the first telegram are not enough.
    let mut tb = bench(Baud::B93750, 0);
    tb.send(32, &random_telegram(&mut rng, Kind::Sd1, 0));
    tb.run_out(40, true);
    assert_eq!(tb.adapter.baud_state(), BaudState::Searching);
}

#[test]
fn a_response_waits_min_tsdr_and_drives_only_while_sending() {
    for baud in [Baud::B9600, Baud::B1500000, Baud::B12000000] {
        let t = BitTiming::new(CLOCK, baud, 0);
        let mut tb = bench(baud, 0);
        let req = [0x10, 0x08, 0x02, 0x49, 0x53, 0x16];
        tb.send(40, &req);
        tb.run_out(0, false);
        while tb.delivered.is_empty() {
            tb.step_strict();
        }
        let end = tb.delivered[0].end;
        tb.adapter.set_min_tsdr(20);
        assert!(tb.adapter.respond(&[0xE5], 0));
        let mut first_drive = None;
        let mut last_drive = 0;
        while tb.adapter.responding() {
            if tb.adapter.drive().is_some() {
                first_drive.get_or_insert(tb.now());
                last_drive = tb.now();
            }
            tb.step_strict();
        }
        let first = first_drive.expect("the response went out");
        let tsdr = t.clocks_for(20, 1);
        assert!(
            first >= end + tsdr && first <= end + tsdr + 2,
            "{baud}: {first} vs {end}+{tsdr}"
        );
        let len = last_drive + 1 - first;
        assert!(
            len.abs_diff(t.clocks_for(11, 1)) <= 1,
            "{baud}: driven {len} clocks"
        );
        assert_eq!(tb.bus.collisions, 0);
        assert_eq!(
            tb.delivered.len(),
            1,
            "the adapter does not deliver its own echo"
        );
    }
}

/// Strict and fast runs of the same random stream give the same outputs.
fn strict_equals_fast(seed: u64, baud: Baud, ppm: i32, noisy: bool) {
    strict_equals_fast_with(Config::default(), seed, baud, ppm, noisy);
}

fn strict_equals_fast_with(cfg: Config, seed: u64, baud: Baud, ppm: i32, noisy: bool) {
    let build = || {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tb = bench_with(cfg, baud, ppm);
        let t = BitTiming::new(CLOCK, baud, 0);
        for i in 0..6 {
            let kind = Kind::ALL[rng.gen_range(0..5)];
            let tel = {
                let n = rng.gen_range(1..20);
                random_telegram(&mut rng, kind, n)
            };
            let faults = if i == 3 {
                vec![(1, CharFault::FlipBit(2))]
            } else {
                vec![]
            };
            tb.send_outgoing(Outgoing {
                idle_bits: rng.gen_range(30..40),
                bytes: tel,
                faults,
            });
        }
        if noisy {
            let mut f = FaultInjector::none();
            f.glitches(seed, 0, t.clocks_for(6 * 300, 1), 20, t.clocks_per_bit());
            tb.bus.faults = f;
        }
        tb
    };
    let mut strict = build();
    let mut fast = build();
    strict.run_out(60, false);
    fast.run_out(60, true);
    assert_eq!(strict.now(), fast.now());
    assert_eq!(strict.delivered, fast.delivered, "seed {seed} {baud}");
    assert_eq!(strict.baud_log, fast.baud_log, "seed {seed} {baud}");
    assert_eq!(strict.adapter.stats(), fast.adapter.stats());
}

/// Strict and fast runs of a master that changes rate after three telegrams, with glitches
/// at the new rate when `noisy`: the relock logic is bit-exact in both modes too.
fn strict_equals_fast_across_a_change(seed: u64, from: Baud, to: Baud, ppm: i32, noisy: bool) {
    let run = |fast: bool| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tb = bench(from, -ppm);
        for _ in 0..3 {
            let n = rng.gen_range(1..20);
            tb.send(
                rng.gen_range(33..40),
                &random_telegram(&mut rng, Kind::Sd2, n),
            );
        }
        tb.run_out(40, fast);
        let t = BitTiming::new(CLOCK, to, ppm);
        tb.set_master_timing(t);
        for _ in 0..4 {
            let (n, kind) = (rng.gen_range(1..20), Kind::ALL[rng.gen_range(0..5)]);
            tb.send(rng.gen_range(33..40), &random_telegram(&mut rng, kind, n));
        }
        if noisy {
            let mut f = FaultInjector::none();
            let now = tb.now();
            f.glitches(
                seed,
                now,
                now + t.clocks_for(4 * 300, 1),
                6,
                t.clocks_per_bit() / 2,
            );
            tb.bus.faults = f;
        }
        tb.run_out(60, fast);
        tb
    };
    let (strict, fast) = (run(false), run(true));
    assert_eq!(strict.now(), fast.now());
    assert_eq!(
        strict.delivered, fast.delivered,
        "seed {seed} {from} -> {to}"
    );
    assert_eq!(strict.baud_log, fast.baud_log, "seed {seed} {from} -> {to}");
    assert_eq!(strict.adapter.stats(), fast.adapter.stats());
}

#[test]
fn fast_mode_gives_the_strict_outputs_on_random_streams() {
    for (i, baud) in Baud::ALL.into_iter().enumerate() {
        strict_equals_fast(i as u64, baud, 1000, false);
        strict_equals_fast(100 + i as u64, baud, -4000, true);
        let far = Baud::ALL[9 - i];
        if far != baud {
            strict_equals_fast_across_a_change(200 + i as u64, baud, far, 3000, i % 2 == 0);
        }
    }
}

#[test]
fn a_traced_run_writes_a_vcd_waveform() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    trace_run("waveform_smoke", |tb| {
        tb.send(40, &[0x10, 0x08, 0x02, 0x49, 0x53, 0x16]);
        tb.run_out(40, false);
    });
    let vcd = std::fs::read_to_string(dir.join("waveform_smoke.vcd")).unwrap();
    assert!(vcd.contains("$var wire 1") && vcd.contains("line") && vcd.contains("baud_state"));
    assert!(vcd.lines().filter(|l| l.starts_with('#')).count() > 50);
}

proptest! {
    #![proptest_config(prop_cases::config(48))]

    #[test]
    fn any_rate_offset_phase_and_payload_decodes_exactly(
        rate in 0usize..10,
        ppm in -5000i32..=5000,
        phase in 0u64..20_000,
        kind in 0usize..4,
        payload in proptest::collection::vec(any::<u8>(), 1..64),
        seed in any::<u64>(),
    ) {
        let baud = Baud::ALL[rate];
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let kind = [Kind::Sd1, Kind::Sd2, Kind::Sd3, Kind::Sd4][kind];
        let mut first = random_telegram(&mut rng, kind, payload.len());
        if kind == Kind::Sd2 {
            // Put the payload in, keep the FCS right.
            let n = first.len();
            first[7..n - 2].copy_from_slice(&payload);
            first[n - 2] = first[4..n - 2].iter().fold(0u8, |a, &x| a.wrapping_add(x));
        }
        let second = random_telegram(&mut rng, Kind::Sd2, payload.len());
        let mut tb = bench(baud, ppm);
        tb.send(33 + (phase % 7) as u32, &first);
        tb.send(33, &second);
        tb.run_until(phase, true);
        tb.run_out(40, true);
        prop_assert_eq!(tb.good(), vec![first, second]);
        prop_assert_eq!(tb.adapter.baud_state(), BaudState::Locked(baud));
    }

    /// Issue 17's claims over (old rate, new rate, clock offset, phase, noise): the lock
    /// follows the master, never to a wrong rate, and nothing corrupt is delivered. Without
    /// noise the first telegram at the new rate locks and every one is delivered, without the
    /// watchdog. With glitches, at most two telegrams are lost before the one that locks (an SC
    /// counts: the search cannot lock on one), as the sweep counts them, and the first clean
    /// telegrams after the noise are delivered. The glitches are those a receiver can take:
    /// up to 0.45 of a bit, two bits apart. (Two inside one bit invert it; one of half the
    /// master's bit outweighs a bit of the adapter's when their clocks are 0.4 % apart. The
    /// sweep's glitches go to half a bit, anywhere.)
    #[test]
    fn a_rate_change_relocks_without_the_watchdog(
        from in 0usize..10,
        to_after in 1usize..10,
        ppm in -5000i32..=5000,
        phase in 0u64..20_000,
        glitches in 0usize..3,
        seed in any::<u64>(),
    ) {
        relocks_without_the_watchdog(from, to_after, ppm, phase, glitches, seed)?;
    }

    #[test]
    fn fast_equals_strict_across_a_rate_change(
        seed in any::<u64>(), from in 0usize..10, step in 1usize..10, ppm in -5000i32..=5000,
        noisy in any::<bool>(),
    ) {
        // Another rate by construction: a rejected draw (`prop_assume!`) counts against
        // proptest's 1,024 global rejects, which a long campaign's tenth of its cases exceeds.
        let to = (from + step) % 10;
        strict_equals_fast_across_a_change(seed, Baud::ALL[from], Baud::ALL[to], ppm, noisy);
    }

    #[test]
    fn fast_equals_strict(seed in any::<u64>(), rate in 0usize..10, ppm in -5000i32..=5000, noisy in any::<bool>()) {
        strict_equals_fast(seed, Baud::ALL[rate], ppm, noisy);
    }

    /// The same with the search oversampling (each slower rate's channel sampling the line
    /// every few clocks): its samples of the line's changes are ticked in fast mode too.
    #[test]
    fn fast_equals_strict_every_clock(seed in any::<u64>(), rate in 0usize..10, ppm in -5000i32..=5000, noisy in any::<bool>()) {
        strict_equals_fast_with(every_clock(), seed, Baud::ALL[rate], ppm, noisy);
    }
}

/// A writer into a buffer the test keeps (the testbench takes its writer for good).
#[derive(Clone, Default)]
struct Shared(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);

impl std::io::Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The SHA-256 of the waveform of `replay` on a bench at `baud`, in hex.
fn waveform_digest(baud: Baud, replay: impl FnOnce(&mut Testbench)) -> String {
    use sha2::{Digest, Sha256};
    let out = Shared::default();
    let mut tb = bench(baud, 0);
    tb.trace_to(Box::new(out.clone())).unwrap();
    replay(&mut tb);
    tb.finish_trace().unwrap();
    let bytes = out.0.lock().unwrap().clone();
    if let Some(dir) = std::env::var_os("WAVE_DUMP") {
        std::fs::write(
            std::path::Path::new(&dir).join(format!("{baud}.vcd")),
            &bytes,
        )
        .unwrap();
    }
    Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The waveform of an autobaud lock and of a 12 Mbit/s exchange, pinned: a change to the
/// model that moves any signal by a clock shows here. If it is meant, update the digest and
/// say why in the commit (`WAVE_DUMP=<dir>` writes the waveforms there, to compare with the
/// build before).
#[test]
fn pinned_waveforms() {
    let lock = waveform_digest(Baud::B187500, |tb| {
        // FDL_Status from PROTOCOL.md: the first character locks the rate.
        tb.send(40, &[0x10, 0x08, 0x02, 0x49, 0x53, 0x16]);
        tb.run_out(40, false);
    });
    let exchange = waveform_digest(Baud::B12000000, |tb| {
        tb.send(40, &[0x10, 0x08, 0x02, 0x49, 0x53, 0x16]);
        // PROTOCOL.md's 8-byte Data_Exchange as SD3.
        tb.send(
            40,
            &[
                0xA2, 0x08, 0x02, 0x4D, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x73, 0x16,
            ],
        );
        tb.run_out(40, false);
    });
    assert_eq!(lock, PINNED_LOCK, "autobaud lock at 187.5k");
    assert_eq!(exchange, PINNED_12M, "exchange at 12M");
}

const PINNED_LOCK: &str = "a65dfebf0a8c05804f5edbc16e0c7ea1facfbbb18693231ec9984385fa716501";
const PINNED_12M: &str = "da5ab95b424373ead6a5e06e5716835b0cbd8675f8bc0627c904c3eedf200af8";

/// Found by `PROPTEST_CASES=20000` (issue 31): fast mode counted one search rejection fewer
/// than strict mode at 9.6k with glitches.
#[test]
fn fast_equals_strict_9k6_glitches_found_by_a_long_campaign() {
    strict_equals_fast(18393667802148869572, Baud::B9600, -3084, true);
}

/// Found by CI's `fast_equals_strict` (debug build): at 93.75k with glitches, a detection
/// decided at a second candidate's stop bit came after the next character's start bit and its
/// rise; the idle line copied at the detection counted from the delimiter's end, a bit longer
/// than the search's channel. It now counts from the decision (`Detection::rose_after_end`),
/// never longer than the channel, as debug builds check at every clock.
#[test]
fn fast_equals_strict_93k75_a_detection_decided_after_the_next_rise() {
    strict_equals_fast(10251962726419476033, Baud::B93750, 1108, true);
}

/// The body of `a_rate_change_relocks_without_the_watchdog`, for its cases kept as tests.
fn relocks_without_the_watchdog(
    from: usize,
    to_after: usize,
    ppm: i32,
    phase: u64,
    glitches: usize,
    seed: u64,
) -> Result<(), TestCaseError> {
    let (from, to) = (Baud::ALL[from], Baud::ALL[(from + to_after) % 10]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut tb, mut sent) = locked_then_changed(&mut rng, from, to, ppm, 12);
    let changed_at = tb.now() + phase;
    tb.run_until(changed_at, true);
    let t = BitTiming::new(CLOCK, to, ppm);
    let noise_end = changed_at + t.clocks_for(12 * 300, 1);
    if glitches > 0 {
        let mut f = FaultInjector::none();
        f.isolated_glitches(
            seed,
            changed_at,
            noise_end,
            glitches * 12,
            (t.clocks_per_bit() * 9 / 20).max(1),
            t.clocks_for(2, 1),
        );
        tb.bus.faults = f;
    }
    tb.run_out(40, true);
    if glitches > 0 {
        // Two clean telegrams after the noise.
        tb.run_until(noise_end.max(tb.now()), true);
        for clean in poll_sequence(&mut rng, 2) {
            tb.send(40, &clean);
            sent.push(clean);
        }
        tb.run_out(40, true);
    }
    prop_assert_eq!(tb.adapter.baud_state(), BaudState::Locked(to));
    if glitches == 0 {
        prop_assert_eq!(tb.adapter.stats().watchdog_expiries, 0);
    }
    prop_assert!(
        tb.baud_log.iter().all(|(_, s)| match s {
            BaudState::Locked(b) => *b == from || *b == to,
            _ => true,
        }),
        "{:?}",
        tb.baud_log
    );
    let good = tb.good();
    prop_assert!(
        good[1..].iter().all(|g| sent.contains(g)),
        "corrupt delivery"
    );
    if glitches == 0 {
        prop_assert_eq!(&good[1..], &sent[..]);
    }
    let lock_at = tb
        .baud_log
        .iter()
        .find(|(_, s)| *s == BaudState::Locked(to))
        .map_or(u64::MAX, |(at, _)| *at);
    // An SC does not count: it has no start delimiter, which the search locks on (a case of
    // a glitched SD4 and then two SCs lost three, found by a 20,000-case run).
    let lost = tb.sent[1..]
        .iter()
        .filter(|(at, o)| {
            at + t.clocks_for(u64::from(o.idle_bits), 1) < lock_at
                && o.bytes.as_slice() != [dp_consts::SC]
        })
        .count()
        .saturating_sub(1);
    prop_assert!(lost <= 2, "{} telegrams lost after the change", lost);
    Ok(())
}

/// Found by a `PROPTEST_CASES=20000` run (issue 31): the SD4 after the change held two
/// glitches (the search takes one), and the two telegrams after it were SCs, which the search
/// cannot lock on; the next one locked.
#[test]
fn relock_case_found_by_a_long_campaign() {
    relocks_without_the_watchdog(6, 4, 698, 4981, 2, 15276739480285272049).unwrap();
}

/// Found by CI: 1.5M to 9.6k with a glitch; the watchdog, restarted by the last telegram
/// before the quiet end of the noise, ran out during the first character of the first clean
/// telegram after it, expired on the clock that character was delivered and dropped the
/// telegram (the next, an SC, cannot lock). It now waits for the telegram
/// (`a_watchdog_that_runs_out_in_a_telegrams_first_character_waits_for_it`).
#[test]
fn relock_case_found_by_ci_the_watchdog_in_a_first_character() {
    relocks_without_the_watchdog(6, 4, -950, 6012, 1, 12002842154760634464).unwrap();
}
