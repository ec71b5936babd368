use dp_consts::Baud;
use hal_sim::cosim::{CoSim, MasterSetup};
use hal_sim::firmware::InProcess;

fn app() -> dp_slave::testing::EchoApp {
    dp_slave::testing::EchoApp {
        accepted_cfgs: &[&[0xF3, 0xF1]],
        default_cfg: &[0xF3, 0xF1],
        ..Default::default()
    }
}

#[test]
fn in_process_reaches_data_exchange() {
    for baud in [Baud::B9600, Baud::B1500000, Baud::B12000000] {
        let mut sim = CoSim::new(InProcess::new(app), 8, None).unwrap();
        sim.start_master(MasterSetup::new(baud, 8));
        let t0 = std::time::Instant::now();
        let ok = sim
            .run_until(sim.now + 48_000_000 * 3, |s| s.master.as_mut().unwrap().cycles > 20)
            .unwrap();
        eprintln!("{baud}: ok={ok} now={}us wall={:?} {:?} events={:#?}", sim.now_us(), t0.elapsed(), sim.figures, sim.events);
        assert!(ok);
    }
}
