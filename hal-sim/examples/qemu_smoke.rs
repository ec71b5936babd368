//! Boots the firmware in QEMU and exchanges a few link messages, printing each reply.
//! `cargo run -p hal-sim --example qemu_smoke -- <qemu-system-arm> <firmware elf> [machine]`
//! (the machine defaults to the QEMU board's, lm3s6965evb).
use dp_link::ToAdapter;
use hal_sim::firmware::{Firmware, Qemu};

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let machine = args.get(3).map_or("lm3s6965evb", String::as_str);
    let mut fw = Qemu::start(args[1].as_ref(), args[2].as_ref(), machine)?;
    let boot = ToAdapter::Boot {
        seq: 1,
        now_us: 0,
        switch: 8,
    };
    println!("{:?}", fw.exchange(&boot)?);
    let diag = [
        0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3C, 0x3E, 0xF1, 0x16,
    ];
    for seq in 2..6 {
        let m = ToAdapter::Telegram {
            seq,
            now_us: 1000 * seq as u64,
            baud: 6,
            bytes: &diag,
        };
        println!("{:?}", fw.exchange(&m)?);
    }
    Ok(())
}
