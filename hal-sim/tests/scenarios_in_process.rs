//! Every qemu-test scenario against the firmware's logic in-process (no QEMU, no cycle
//! counts): the simulator, the master and the checks are proven on the host, and a failure
//! here is not QEMU's.

use hal_sim::firmware::InProcess;
use hal_sim::scenario;

fn app() -> dp_slave::testing::EchoApp {
    const PPOS: &[&[u8]] = &[
        &[0xF3, 0xF1],
        &[0xF3, 0xF5],
        &[0xF1],
        &[0xF5],
        &[0xF3, 0xF9],
        &[0xF9],
    ];
    dp_slave::testing::EchoApp {
        accepted_cfgs: PPOS,
        default_cfg: PPOS[0],
        ..Default::default()
    }
}

#[test]
fn every_scenario_passes_in_process() {
    let mut failed = Vec::new();
    for s in scenario::all() {
        let (outcome, _) = scenario::run(&s, InProcess::new(app)).unwrap();
        if !outcome.passed() {
            failed.push(format!(
                "{}: {:#?}\n{:#?}\n{:?}",
                s.name, outcome.checks, outcome.events, outcome.figures
            ));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
