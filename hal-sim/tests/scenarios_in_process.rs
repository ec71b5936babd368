//! Every qemu-test scenario against the firmware's logic in-process (no QEMU, no cycle
//! counts): the simulator, the master and the checks are proven on the host, and a failure
//! here is not QEMU's.

use hal_sim::firmware::InProcess;
use hal_sim::scenarios;

#[test]
fn every_scenario_passes_in_process() {
    let mut failed = Vec::new();
    // HALSIM_ONLY=name runs that scenario alone (for work on one).
    let only = std::env::var("HALSIM_ONLY").ok();
    for name in scenarios::names() {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
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
