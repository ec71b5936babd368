//! Nanoseconds per Data_Exchange request through the whole slave path: parse the request
//! bytes, run the state machine and the application, emit the response bytes. PPO3, PPO1,
//! PPO2 and PPO5 give 4, 12, 20 and 28 bytes of I/O each way. A counting allocator proves the
//! path allocates nothing; the count is printed after the timing.
//!
//! `cargo bench -p dp-slave`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use dp_slave::testing::EchoApp;
use dp_slave::{Config, Instant, Slave, State};
use fdl::{DataRepr, FrameControl, Repr, RequestFunction, Sap};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        System.alloc(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const PPOS: [(&str, &[u8]); 4] = [
    ("PPO3", &[0xF1]),
    ("PPO1", &[0xF3, 0xF1]),
    ("PPO2", &[0xF3, 0xF5]),
    ("PPO5", &[0xF3, 0xF9]),
];

fn request<'a>(dsap: Option<Sap>, fcb: bool, payload: &'a [u8]) -> Repr<'a> {
    Repr::Data(DataRepr {
        da: 8,
        sa: 2,
        dsap,
        ssap: dsap.map(|_| Sap::MASTER_MS0),
        fc: FrameControl::Request {
            fcb,
            fcv: true,
            function: if dsap.is_some() {
                RequestFunction::SrdLow
            } else {
                RequestFunction::SrdHigh
            },
        },
        payload,
    })
}

fn exchanging(cfg: &'static [u8]) -> Slave<EchoApp> {
    let mut slave = Slave::new(
        Config {
            address: 8,
            ident_number: 0xD7A1,
            no_add_chg: false,
            dpv1_status_bytes: false,
        },
        EchoApp::default(),
    );
    let prm = [0x88, 100, 100, 11, 0xD7, 0xA1, 0];
    slave.process(Instant::ZERO, &request(Some(Sap::SET_PRM), false, &prm));
    slave.process(Instant::ZERO, &request(Some(Sap::CHK_CFG), true, cfg));
    assert_eq!(slave.state(), State::DataExch);
    slave
}

fn encode(repr: &Repr) -> Vec<u8> {
    let mut bytes = vec![0u8; repr.buffer_len()];
    repr.emit(&mut bytes).unwrap();
    bytes
}

fn data_exchange(c: &mut Criterion) {
    let mut group = c.benchmark_group("data_exchange");
    for (name, cfg) in PPOS {
        let io = dp_slave::cfg::io_sizes(cfg).unwrap().outputs;
        let outputs: Vec<u8> = (0..io as u8).collect();
        // Alternate FCB so that every request is new and fully executed.
        let telegrams = [
            encode(&request(None, false, &outputs)),
            encode(&request(None, true, &outputs)),
        ];
        let mut slave = exchanging(cfg);
        let mut out = [0u8; 256];
        let mut i = 0usize;
        group.bench_with_input(BenchmarkId::new(name, io), &io, |b, _| {
            b.iter(|| {
                i += 1;
                let now = Instant::from_micros(i as u64);
                let n = slave.handle(now, black_box(&telegrams[i & 1]), &mut out);
                black_box(n)
            })
        });
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        for k in 0..10_000u64 {
            let n = slave.handle(
                Instant::from_micros(k),
                &telegrams[(k & 1) as usize],
                &mut out,
            );
            assert_eq!(n, Some(io + 6 + if io == 8 { 0 } else { 3 }));
        }
        let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
        println!("data_exchange/{name}/{io}: allocations per 10000 requests = {allocations}");
        assert_eq!(allocations, 0);
    }
    group.finish();
}

criterion_group!(benches, data_exchange);
criterion_main!(benches);
