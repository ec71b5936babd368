//! The soak campaign in-process (the firmware's logic without QEMU): a seeded schedule runs
//! without a violation, and replays exactly.

use hal_sim::firmware::InProcess;
use hal_sim::soak::{self, Options};

fn options(seed: u64, events: u64) -> Options {
    Options {
        seed,
        events,
        deadline: None,
        trace_from: None,
    }
}

#[test]
fn a_soak_of_every_kind_of_event_finds_no_violation() {
    let (summary, _) = soak::run(InProcess::new(), &options(1, 150)).unwrap();
    println!("{}", summary.line());
    println!("{:?}", summary.kinds);
    if let Some(v) = &summary.violation {
        panic!(
            "event {}: {}\n{}\n--\n{}",
            v.event,
            v.what,
            v.last_events.join("\n"),
            v.adapter_events.join("\n")
        );
    }
    assert_eq!(summary.events, 150);
    // Both PKW channels answered: the vendor profile's and, under a Set_Prm that chose
    // PROFIdrive or ABB Drives, seed 004's, with the PLC walking the state machine.
    for kind in ["pkw", "pkw-profidrive"] {
        assert!(summary.kinds.contains_key(kind), "no {kind} event ran");
    }
}

#[test]
fn an_in_process_run_replays_exactly() {
    let run = || soak::run(InProcess::new(), &options(3, 12)).unwrap().0;
    let (a, b) = (run(), run());
    assert_eq!(
        (a.events, a.simulated_us, a.invariants_checked, &a.kinds),
        (b.events, b.simulated_us, b.invariants_checked, &b.kinds)
    );
    assert!(a.violation.is_none() && a.simulated_us > 0);
}

/// Every point a power cut can fall in a storage write of an address record (the soak's
/// torn write) leaves the storage loading the old record or the new one: first from an empty
/// storage, then over a record, then with the pages nearly full of earlier records.
#[test]
fn a_power_cut_anywhere_in_an_address_write_loads_the_old_record_or_the_new() {
    use dp_link::NvRecord;
    use hal_sim::firmware::{nv_contents, nv_store};
    use nv_store::MemFlash;
    let record = |address| NvRecord {
        address,
        no_add_chg: false,
    };
    let mut image = MemFlash::erased(board::NV_STORAGE_PAGES as usize).bytes;
    let mut old = None;
    let mut torn_states = 0;
    for (i, address) in (4..=125u8).cycle().take(400).enumerate() {
        let before = image.clone();
        let mut store = nv_store(MemFlash { bytes: image });
        store
            .write_address(record(address))
            .expect("the storage takes a record");
        let after = store.into_flash().bytes;
        for permille in (0..=1000).step_by(25) {
            let torn = soak::torn_write(&before, &after, permille);
            let loaded = nv_contents(&torn).address;
            assert!(
                loaded == old || loaded == Some(record(address)),
                "write {i} ({old:?} -> {address}), cut at {permille}/1000: loads {loaded:?}"
            );
            torn_states += usize::from(torn != before && torn != after);
        }
        old = Some(record(address));
        image = after;
    }
    assert!(
        torn_states > 1000,
        "the cuts fell inside writes {torn_states} times"
    );
}

#[test]
fn a_torn_write_programs_a_prefix_of_the_changed_words() {
    let before = vec![0xFF; 2048];
    let mut after = before.clone();
    after[10..20].fill(0x00);
    assert_eq!(soak::torn_write(&before, &after, 0), before);
    assert_eq!(soak::torn_write(&before, &after, 1000), after);
    let half = soak::torn_write(&before, &after, 500);
    // Five words changed: two of them programmed at half way.
    assert_eq!(&half[10..14], &[0, 0, 0, 0]);
    assert_eq!(&half[14..20], &[0xFF; 6]);
    // A write that sets a bit erased its page: all or nothing.
    let mut erased = after.clone();
    erased[1500] = 0xFF;
    let mut moved = erased.clone();
    moved[0] = 0x00;
    let from = {
        let mut b = moved.clone();
        b[1500] = 0x12;
        b
    };
    assert_eq!(soak::torn_write(&from, &moved, 499), from);
    assert_eq!(soak::torn_write(&from, &moved, 500), moved);
}
