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
}
