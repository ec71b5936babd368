//! `cargo xtask flash [--dry-run] [--log] [--probe VID:PID[:SERIAL]] [--chip NAME]`: builds the
//! production image and hands it to `flash/` (its own workspace, with probe-rs), which flashes,
//! verifies and resets the board, or with `--dry-run` checks the whole plan against probe-rs's
//! fake probe. probe-rs is built here on first use only: no other task compiles it.

use crate::qemu_test::{build, ensure_target, PRODUCTION_IMAGE};
use crate::{check_flags, project_root};
use anyhow::{bail, Context, Result};
use std::process::Command;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &["--dry-run", "--log"], &["--probe", "--chip"])?;
    ensure_target()?;
    let elf = build(&PRODUCTION_IMAGE)?;
    let tool = project_root().join("flash");
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(&tool)
        .args(["run", "--release", "--quiet", "--"])
        .arg("--elf")
        .arg(&elf)
        .args(args)
        .status()
        .context("running cargo for flash/")?;
    if !status.success() {
        bail!("flashing failed (above)");
    }
    Ok(())
}
