//! 964, the device identification: what a master reads to know the adapter and its firmware.
//!
//! Seed 004 (line 1538) makes 964 one word, the device's Ident_Number (ABB's 0812h there, ours
//! D7A1h), and a plain PKW read of 964 keeps returning it. PROFIdrive makes 964 an array; its
//! sub-indexes 1-5 follow here:
//! the device type, the firmware version, its date (year, then day and month), and the number
//! of drive objects. Sub-index 0 holds the Ident_Number where PROFIdrive has the manufacturer
//! (README, "Differences from the manuals").
//!
//! The firmware's build names its version and date (xtask sets `DP_ADAPTER_VERSION`, from
//! `git describe`, and `DP_ADAPTER_DATE`, the commit's `YYYY-MM-DD`): 964.2 carries the
//! version's major and minor numbers, decimal-coded `xxyy` (v1.2.x: 0102), as PROFIdrive
//! codes it. Without them (a host build), the crate's own version and date 0.

/// 964's words.
pub const WORDS: usize = 6;

/// The adapter's device identification, sub-indexes 0-5.
pub const DEVICE: [u16; WORDS] = [
    dp_consts::ADAPTER_IDENT_NUMBER,
    // Device type: one kind of device, the drive adapter.
    1,
    VERSION_XXYY,
    DATE.0,
    DATE.1,
    // Drive objects: the one drive behind the adapter.
    1,
];

/// The firmware version, `vMAJOR.MINOR...`.
pub const VERSION: &str = match option_env!("DP_ADAPTER_VERSION") {
    Some(version) => version,
    None => concat!("v", env!("CARGO_PKG_VERSION")),
};

/// `VERSION`'s major and minor numbers, decimal-coded: `v1.2.3-4-gabc` is 0102.
pub const VERSION_XXYY: u16 = {
    let (major, rest) = number(VERSION.as_bytes(), 1);
    let (minor, _) = number(VERSION.as_bytes(), rest + 1);
    assert!(
        major < 100 && minor < 100,
        "964.2 codes the version as xxyy"
    );
    major * 100 + minor
};

/// The firmware's date: (year, day * 100 + month), from `YYYY-MM-DD`, or (0, 0) unknown.
pub const DATE: (u16, u16) = match option_env!("DP_ADAPTER_DATE") {
    Some(date) => {
        let bytes = date.as_bytes();
        let (year, at) = number(bytes, 0);
        let (month, at) = number(bytes, at + 1);
        let (day, _) = number(bytes, at + 1);
        (year, day * 100 + month)
    }
    None => (0, 0),
};

/// The decimal number at `at` in `bytes`, and where it ends. In a const, so no `str::parse`.
const fn number(bytes: &[u8], mut at: usize) -> (u16, usize) {
    let mut value = 0u16;
    while at < bytes.len() && bytes[at].is_ascii_digit() {
        value = value * 10 + (bytes[at] - b'0') as u16;
        at += 1;
    }
    (value, at)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_version_is_decimal_coded_as_profidrive_codes_it() {
        let (major, rest) = number(b"v1.23.4-5-gabc", 1);
        assert_eq!((major, number(b"v1.23.4-5-gabc", rest + 1).0), (1, 23));
        // The built version, parsed again at run time.
        let mut parts = VERSION[1..].split(['.', '-']);
        let mut next = || parts.next().unwrap().parse::<u16>().unwrap();
        assert_eq!(VERSION_XXYY, next() * 100 + next());
    }

    #[test]
    fn sub_index_0_is_seed_004s_ident_number() {
        assert_eq!(DEVICE[0], dp_consts::ADAPTER_IDENT_NUMBER);
        assert_eq!(DEVICE[2], VERSION_XXYY);
    }
}
