//! `cargo xtask gsd [--out PATH]`: writes the adapter's GSD file (default
//! `target/gsd/DPADD7A1.GSD`) from `profidrive::gsd`, the same constants the firmware uses.

use crate::{check_flags, flag_value, project_root};
use anyhow::{Context, Result};
use std::path::PathBuf;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--out"])?;
    let out = match flag_value(args, "--out")? {
        Some(path) => PathBuf::from(path),
        None => project_root()
            .join("target/gsd")
            .join(profidrive::gsd::FILE_NAME),
    };
    let mut text = String::new();
    profidrive::gsd::write(&mut text)?;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    // GSD files are DOS text by tradition; configuration tools accept both.
    std::fs::write(&out, text.replace('\n', "\r\n"))
        .with_context(|| format!("writing {}", out.display()))?;
    println!(
        "gsd: wrote {} ({} lines)",
        out.display(),
        text.lines().count()
    );
    Ok(())
}
