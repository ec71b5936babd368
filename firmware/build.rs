//! Writes the chosen board's `memory.x`, where cortex-m-rt's `link.x` finds it, from the board
//! table (`crates/board`, [`board_figures::BOARDS`]): a board's memory is written down once.
//! The image's flash ends where the non-volatile storage's pages begin.
use std::{env, fs, path::PathBuf};

fn main() {
    let feature = |name: &str| format!("CARGO_FEATURE_{}", name.to_uppercase().replace('-', "_"));
    let chosen: Vec<&board_figures::Board> = board_figures::BOARDS
        .iter()
        .filter(|b| env::var_os(feature(b.name)).is_some())
        .collect();
    let names: Vec<&str> = board_figures::BOARDS.iter().map(|b| b.name).collect();
    let board = match chosen.as_slice() {
        [one] => one,
        [] => panic!("choose a board: --no-default-features --features one of {names:?}"),
        many => panic!(
            "choose one board, not {:?}",
            many.iter().map(|b| b.name).collect::<Vec<_>>()
        ),
    };
    let m = board.memory;
    let memory_x = format!(
        "/* {} ({}), from crates/board's table */\nMEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {}\n  RAM   : ORIGIN = {:#010x}, LENGTH = {}\n}}\n",
        board.name,
        board.description,
        m.flash_origin,
        m.flash_bytes - board_figures::NV_STORAGE_BYTES,
        m.ram_origin,
        m.ram_bytes
    );
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());
    fs::write(out.join("memory.x"), memory_x).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
}
