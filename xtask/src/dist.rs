//! `cargo xtask dist [--out DIR]`: the release bundle for a production line, under
//! `target/dist/<version>/` (or `DIR/<version>/`).
//!
//! It holds the production image as ELF, Intel HEX and raw BIN (what a programmer on the line
//! takes), the two GSD files, and `manifest.json`: the version (`git describe`), the board and
//! chip, the image's flash and RAM use, and the SHA-256 of every other file. The version is the
//! firmware's own: the build gets it from here, and the bundle is refused unless the image,
//! read back, carries the same one (the symbol `DP_ADAPTER_VERSION`, which the boot log
//! prints). Written files are read back and hashed again before the last line,
//! `dist: <version> files=<n>`.

use crate::qemu_test::{build, ensure_target, image_size, PRODUCTION_IMAGE};
use crate::{check_flags, flag_value, project_root};
use anyhow::{bail, Context, Result};
use object::read::elf::{ElfFile32, ProgramHeader as _};
use object::{Object as _, ObjectSymbol as _};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The firmware's version: `git describe --tags --dirty` of the sources, e.g. `v0.2.0-3-gabc1234`.
/// With no release tag yet, the Cargo version and the commit (`v0.1.0-gabc1234[-dirty]`), so the
/// string always names the sources. Outside a git checkout, `v0.1.0-unknown`. Asked of git once
/// per run: every image of one run carries the same version.
pub fn firmware_version() -> &'static str {
    static VERSION: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    VERSION.get_or_init(|| {
        let cargo_version = env!("CARGO_PKG_VERSION");
        if let Some(tagged) = git(&["describe", "--tags", "--match", "v[0-9]*", "--dirty"]) {
            return tagged;
        }
        match git(&["describe", "--always", "--abbrev=7", "--dirty"]) {
            Some(commit) => format!("v{cargo_version}-g{commit}"),
            None => format!("v{cargo_version}-unknown"),
        }
    })
}

/// The date of the sources' commit, `YYYY-MM-DD` (964.3 and 964.4), or empty outside git; asked
/// once per run.
pub fn firmware_date() -> &'static str {
    static DATE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    DATE.get_or_init(|| git(&["log", "-1", "--format=%cs"]).unwrap_or_default())
}

/// What `git args` prints in the project, if git runs there and succeeds.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .current_dir(project_root())
        .args(args)
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The version string an image carries at its `DP_ADAPTER_VERSION` symbol.
pub fn version_in_image(elf: &[u8]) -> Result<String> {
    let file = ElfFile32::<object::Endianness>::parse(elf).context("parsing the image")?;
    let symbol = file
        .symbols()
        .find(|s| s.name() == Ok("DP_ADAPTER_VERSION"))
        .context("the image has no DP_ADAPTER_VERSION symbol")?;
    let section = file.section_by_index(
        symbol
            .section_index()
            .context("the symbol has no section")?,
    )?;
    let data = object::ObjectSection::data_range(&section, symbol.address(), symbol.size())?
        .context("the symbol lies outside its section's data")?;
    let text = data.split(|b| *b == 0).next().unwrap_or_default();
    String::from_utf8(text.to_vec()).context("the version is not UTF-8")
}

/// The bytes the image puts in flash: each loadable segment's file contents at its physical
/// (load) address, `.data`'s initial values included.
pub fn flash_contents(elf: &[u8]) -> Result<Vec<(u32, Vec<u8>)>> {
    let file = ElfFile32::<object::Endianness>::parse(elf).context("parsing the image")?;
    let endian = file.endian();
    let mut segments = Vec::new();
    for header in file.elf_program_headers() {
        if header.p_type(endian) != object::elf::PT_LOAD || header.p_filesz(endian) == 0 {
            continue;
        }
        let data = header
            .data(endian, file.data())
            .map_err(|()| anyhow::anyhow!("a segment lies outside the file"))?;
        segments.push((header.p_paddr(endian), data.to_vec()));
    }
    segments.sort_by_key(|(address, _)| *address);
    if segments.is_empty() {
        bail!("the image has nothing to load");
    }
    Ok(segments)
}

/// The raw flash image from its first byte to its last, gaps erased (0xFF, as flash reads).
pub fn raw_binary(segments: &[(u32, Vec<u8>)]) -> (u32, Vec<u8>) {
    let start = segments[0].0;
    let end = segments
        .iter()
        .map(|(a, d)| a + d.len() as u32)
        .max()
        .unwrap_or(start);
    let mut bin = vec![0xFF; (end - start) as usize];
    for (address, data) in segments {
        let at = (address - start) as usize;
        bin[at..at + data.len()].copy_from_slice(data);
    }
    (start, bin)
}

/// Intel HEX of the segments: 16 bytes a record, an extended linear address record at every
/// 64 KiB boundary, the entry point, end of file.
pub fn intel_hex(segments: &[(u32, Vec<u8>)], entry: u32) -> Result<String> {
    let mut records = Vec::new();
    let mut upper = None;
    for (address, data) in segments {
        for (i, chunk) in data.chunks(16).enumerate() {
            let at = address + (i * 16) as u32;
            // A record never crosses 64 KiB: split where it would.
            let room = (0x1_0000 - (at & 0xFFFF)) as usize;
            let (first, rest) = chunk.split_at(chunk.len().min(room));
            for (at, part) in [(at, first), (at + first.len() as u32, rest)] {
                if part.is_empty() {
                    continue;
                }
                if upper != Some(at >> 16) {
                    upper = Some(at >> 16);
                    records.push(ihex::Record::ExtendedLinearAddress((at >> 16) as u16));
                }
                records.push(ihex::Record::Data {
                    offset: (at & 0xFFFF) as u16,
                    value: part.to_vec(),
                });
            }
        }
    }
    records.push(ihex::Record::StartLinearAddress(entry));
    records.push(ihex::Record::EndOfFile);
    let mut text = ihex::create_object_file_representation(&records)?;
    text.push('\n');
    Ok(text)
}

fn sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
struct Manifest {
    version: String,
    board: String,
    chip: String,
    flash_bytes: u64,
    flash_budget_bytes: u64,
    ram_static_bytes: u64,
    ram_bytes: u64,
    /// Where the raw BIN starts in the chip's address space.
    bin_load_address: String,
    files: Vec<FileEntry>,
}

#[derive(serde::Serialize, serde::Deserialize, Debug, PartialEq)]
struct FileEntry {
    name: String,
    bytes: u64,
    sha256: String,
}

pub fn run(args: &[String]) -> Result<()> {
    check_flags(args, &[], &["--out"])?;
    let root = match flag_value(args, "--out")? {
        Some(dir) => PathBuf::from(dir),
        None => project_root().join("target/dist"),
    };
    ensure_target()?;
    let version = firmware_version();
    let board = PRODUCTION_IMAGE.board;
    let elf_path = build(&PRODUCTION_IMAGE)?;
    let elf = std::fs::read(&elf_path)?;
    let carried = version_in_image(&elf)?;
    if carried != version {
        bail!("the image carries version {carried:?}, the sources are {version:?}");
    }
    let (flash, ram) = image_size(&elf_path)?;
    let segments = flash_contents(&elf)?;
    let (load_address, bin) = raw_binary(&segments);
    let entry = object::read::File::parse(&*elf)?.entry() as u32;

    let dir = root.join(version);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    std::fs::create_dir_all(&dir)?;
    let stem = format!("dp-adapter-{version}-{}", board.name);
    let mut files: Vec<(String, Vec<u8>)> = vec![
        (format!("{stem}.elf"), elf.clone()),
        (
            format!("{stem}.hex"),
            intel_hex(&segments, entry)?.into_bytes(),
        ),
        (format!("{stem}.bin"), bin),
    ];
    for variant in [
        profidrive::gsd::Variant::DpV0,
        profidrive::gsd::Variant::DpV1,
    ] {
        let mut text = String::new();
        profidrive::gsd::write_variant(&mut text, variant)?;
        files.push((
            variant.file_name().to_string(),
            text.replace('\n', "\r\n").into_bytes(),
        ));
    }
    let mut entries = Vec::new();
    for (name, bytes) in &files {
        std::fs::write(dir.join(name), bytes).with_context(|| format!("writing {name}"))?;
        entries.push(FileEntry {
            name: name.clone(),
            bytes: bytes.len() as u64,
            sha256: sha256(bytes),
        });
    }
    let manifest = Manifest {
        version: version.to_string(),
        board: board.name.to_string(),
        chip: board.chip.to_string(),
        flash_bytes: flash,
        flash_budget_bytes: board.flash_budget.into(),
        ram_static_bytes: ram,
        ram_bytes: board.memory.ram_bytes.into(),
        bin_load_address: format!("{load_address:#010x}"),
        files: entries,
    };
    let manifest_path = dir.join("manifest.json");
    std::fs::write(
        &manifest_path,
        serde_json::to_string_pretty(&manifest)? + "\n",
    )?;
    let checked = check_bundle(&dir)?;
    for entry in &manifest.files {
        println!(
            "  {:<44} {:>7} B  sha256 {}",
            entry.name, entry.bytes, entry.sha256
        );
    }
    println!(
        "wrote {} ({} B flash of {}, {} B static RAM)",
        dir.display(),
        flash,
        board.flash_budget,
        ram
    );
    println!("dist: {version} files={checked}");
    Ok(())
}

/// Reads a bundle back: every file the manifest lists exists with its size and hash, and the
/// ELF carries the manifest's version. Returns the number of files, the manifest included.
fn check_bundle(dir: &Path) -> Result<usize> {
    let manifest: Manifest = serde_json::from_slice(&std::fs::read(dir.join("manifest.json"))?)?;
    for entry in &manifest.files {
        let bytes = std::fs::read(dir.join(&entry.name))
            .with_context(|| format!("reading back {}", entry.name))?;
        if bytes.len() as u64 != entry.bytes || sha256(&bytes) != entry.sha256 {
            bail!("{} does not match the manifest", entry.name);
        }
        if entry.name.ends_with(".elf") && version_in_image(&bytes)? != manifest.version {
            bail!("{} does not carry the manifest's version", entry.name);
        }
    }
    Ok(manifest.files.len() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hex_file_holds_exactly_the_segments_bytes() {
        // Two segments, one across a 64 KiB boundary, a gap between them.
        let segments = vec![
            (0x0800_FFF8, (0u8..40).collect::<Vec<_>>()),
            (0x0801_0100, vec![0xAB; 5]),
        ];
        let hex = intel_hex(&segments, 0x0800_0101).unwrap();
        let mut read = std::collections::BTreeMap::new();
        let mut upper = 0u32;
        let mut entry = None;
        for record in ihex::Reader::new(&hex) {
            match record.unwrap() {
                ihex::Record::ExtendedLinearAddress(u) => upper = u32::from(u) << 16,
                ihex::Record::Data { offset, value } => {
                    for (i, b) in value.iter().enumerate() {
                        read.insert(upper + u32::from(offset) + i as u32, *b);
                    }
                }
                ihex::Record::StartLinearAddress(e) => entry = Some(e),
                ihex::Record::EndOfFile => {}
                other => panic!("unexpected record {other:?}"),
            }
        }
        let want: std::collections::BTreeMap<u32, u8> = segments
            .iter()
            .flat_map(|(a, d)| d.iter().enumerate().map(move |(i, b)| (a + i as u32, *b)))
            .collect();
        assert_eq!(read, want);
        assert_eq!(entry, Some(0x0800_0101));
    }

    /// An ELF for a Cortex-M with `DP_ADAPTER_VERSION` in `.rodata`, as the firmware has it.
    fn image_with_version(version: &str) -> Vec<u8> {
        use object::write::{Object, Symbol, SymbolSection};
        use object::{Architecture, BinaryFormat, Endianness, SectionKind, SymbolFlags};
        use object::{SymbolKind, SymbolScope};
        let mut elf = Object::new(BinaryFormat::Elf, Architecture::Arm, Endianness::Little);
        let rodata = elf.add_section(Vec::new(), b".rodata".to_vec(), SectionKind::ReadOnlyData);
        elf.append_section_data(rodata, b"other constants", 4);
        let mut field = [0u8; 64];
        field[..version.len()].copy_from_slice(version.as_bytes());
        let at = elf.append_section_data(rodata, &field, 4);
        elf.add_symbol(Symbol {
            name: b"DP_ADAPTER_VERSION".to_vec(),
            value: at,
            size: 64,
            kind: SymbolKind::Data,
            scope: SymbolScope::Linkage,
            weak: false,
            section: SymbolSection::Section(rodata),
            flags: SymbolFlags::None,
        });
        elf.write().unwrap()
    }

    #[test]
    fn the_version_is_read_back_from_its_symbol() {
        let elf = image_with_version("v0.2.0-3-gabc1234-dirty");
        assert_eq!(version_in_image(&elf).unwrap(), "v0.2.0-3-gabc1234-dirty");
        // Another image (no symbol) is refused, not read as an empty version.
        let mut other = object::write::Object::new(
            object::BinaryFormat::Elf,
            object::Architecture::Arm,
            object::Endianness::Little,
        );
        other.add_section(Vec::new(), b".text".to_vec(), object::SectionKind::Text);
        assert!(version_in_image(&other.write().unwrap()).is_err());
    }

    #[test]
    fn the_raw_binary_fills_gaps_with_erased_flash() {
        let segments = vec![(0x100, vec![1, 2]), (0x104, vec![3])];
        assert_eq!(raw_binary(&segments), (0x100, vec![1, 2, 0xFF, 0xFF, 3]));
    }

    #[test]
    fn a_bundle_with_a_changed_file_is_refused() {
        let dir = project_root().join("target/tmp/dist-check");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.gsd"), b"one").unwrap();
        let manifest = Manifest {
            version: "v0".into(),
            board: "b".into(),
            chip: "c".into(),
            flash_bytes: 0,
            flash_budget_bytes: 0,
            ram_static_bytes: 0,
            ram_bytes: 0,
            bin_load_address: "0x0".into(),
            files: vec![FileEntry {
                name: "a.gsd".into(),
                bytes: 3,
                sha256: sha256(b"one"),
            }],
        };
        std::fs::write(
            dir.join("manifest.json"),
            serde_json::to_string(&manifest).unwrap(),
        )
        .unwrap();
        assert_eq!(check_bundle(&dir).unwrap(), 2);
        std::fs::write(dir.join("a.gsd"), b"two").unwrap();
        assert!(check_bundle(&dir).is_err());
    }
}
