//! Every qemu-test scenario against the firmware's logic in-process (no QEMU, no cycle
//! counts): the simulator, the master and the checks are proven on the host, and a failure
//! here is not QEMU's.

use hal_sim::firmware::InProcess;
use hal_sim::scenarios;

#[test]
fn every_scenario_passes_in_process() {
    let mut failed = Vec::new();
    for name in scenarios::names() {
        let (outcome, _) = scenarios::run(name, InProcess::new()).unwrap();
        if !outcome.passed() {
            failed.push(format!(
                "{name}: {:#?}\n{:#?}\n{:?}",
                outcome.checks, outcome.events, outcome.figures
            ));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
