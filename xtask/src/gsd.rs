//! `cargo xtask gsd [--out DIR]`: writes the adapter's GSD files (default `target/gsd/`):
//! DPADD7A1.GSD (DP-V0) and DPA1D7A1.GSD (DP-V1, for the drive's 51.21 DP MODE = 1), from
//! `profidrive::gsd`, the same constants the firmware uses.

use crate::{check_flags, flag_value, project_root};
use anyhow::{Context, Result};
use std::path::PathBuf;

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--out"])?;
    let dir = match flag_value(args, "--out")? {
        Some(path) => PathBuf::from(path),
        None => project_root().join("target/gsd"),
    };
    std::fs::create_dir_all(&dir)?;
    for variant in [
        profidrive::gsd::Variant::DpV0,
        profidrive::gsd::Variant::DpV1,
    ] {
        let mut text = String::new();
        profidrive::gsd::write_variant(&mut text, variant)?;
        let out = dir.join(variant.file_name());
        // GSD files are DOS text by tradition; configuration tools accept both.
        std::fs::write(&out, text.replace('\n', "\r\n"))
            .with_context(|| format!("writing {}", out.display()))?;
        println!(
            "gsd: wrote {} ({} lines)",
            out.display(),
            text.lines().count()
        );
    }
    Ok(())
}
