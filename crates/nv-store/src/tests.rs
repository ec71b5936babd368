//! The store's contract: records come back as written, survive reopening, and a write cut at
//! any byte or erase leaves the old value or the new one.

use super::*;
use proptest::prelude::*;
use sequential_storage::mock_flash::{MockFlashBase, WriteCountCheck};

/// The production board's geometry: two pages of 1 KiB, half-words written once.
type Mock = MockFlashBase<2, 2, 512>;

fn mock() -> Mock {
    Mock::new(WriteCountCheck::OnceOnly, None, true)
}

const RANGE: Range<u32> = 0..2048;

fn params(n: u16) -> NvParams {
    NvParams {
        pkw_rights: n & 1,
        pzd_rights: (n >> 1) & 1,
        operating_mode: 1,
        control_bit_selectors: [n, n + 1, n + 2, n + 3, n + 4],
        status_bit_selectors: [n % 4, 0, 1, 2, 3],
    }
}

#[test]
fn an_empty_storage_holds_nothing() {
    let mut store = Store::new(mock(), RANGE);
    assert_eq!(store.load(), NvContents::default());
}

/// Seed 004 line 921 and 971: the settings and the address come back after a power cycle
/// (the store opened again on the same flash), each as last written.
#[test]
fn seed_004_line_921_settings_and_address_survive_a_power_cycle() {
    let mut store = Store::new(MemFlash::erased(2), RANGE);
    let address = NvRecord {
        address: 42,
        no_add_chg: true,
    };
    store.write_address(address).unwrap();
    store.write_params(params(7)).unwrap();
    store.write_params(params(9)).unwrap();
    let flash = store.into_flash();
    let mut again = Store::new(flash, RANGE);
    assert_eq!(
        again.load(),
        NvContents {
            address: Some(address),
            params: Some(params(9)),
        }
    );
    again.forget_params().unwrap();
    assert_eq!(again.load().params, None);
    assert_eq!(again.load().address, Some(address));
}

/// Far more writes than two pages hold: the map moves the live items on and erases pages in
/// turn; the latest value always reads back.
#[test]
fn many_writes_wrap_the_pages_and_keep_the_latest() {
    let mut store = Store::new(mock(), RANGE);
    for n in 0..500u16 {
        store.write_params(params(n)).unwrap();
        if n % 7 == 0 {
            let record = NvRecord {
                address: (n % 126 + 1) as u8,
                no_add_chg: false,
            };
            store.write_address(record).unwrap();
        }
        assert_eq!(store.load().params, Some(params(n)));
    }
}

/// A flash that holds something else (another layout, or damage) reads as empty, and the
/// next write puts it right.
#[test]
fn garbage_reads_as_nothing_and_is_overwritten() {
    let mut flash = MemFlash::erased(2);
    for (k, b) in flash.bytes.iter_mut().enumerate() {
        *b = (k * 37 % 251) as u8;
    }
    let mut store = Store::new(flash, RANGE);
    assert_eq!(store.load(), NvContents::default());
}

proptest! {
    #![proptest_config(prop_cases::config(64))]

    /// Issue 30 item 2: a write cut by a power loss at any byte it programs or erases leaves
    /// the value before it or the new one, and the storage goes on working. `before`: writes
    /// made first, so that the cut falls at every stage of the pages' life (moving items on,
    /// erasing a page).
    #[test]
    fn a_write_cut_at_any_step_keeps_the_old_value_or_the_new(before in 0u16..120) {
        let mut store = Store::new(mock(), RANGE);
        for n in 0..before {
            store.write_params(params(n)).unwrap();
        }
        let old = (before > 0).then(|| params(before - 1));
        let new = params(1000);
        let flash = store.into_flash();
        let mut cut = 0;
        loop {
            let mut cut_flash = flash.clone();
            cut_flash.bytes_until_shutoff = Some(cut);
            let mut store = Store::new(cut_flash, RANGE);
            let finished = store.write_params(new).is_ok();
            let mut after = store.into_flash();
            after.bytes_until_shutoff = None;
            let mut store = Store::new(after, RANGE);
            let seen = store.load().params;
            prop_assert!(seen == old || seen == Some(new), "cut at {cut}: {seen:?}");
            if finished {
                prop_assert_eq!(seen, Some(new));
                break;
            }
            // The storage works on after the cut.
            store.write_params(params(2000)).unwrap();
            prop_assert_eq!(store.load().params, Some(params(2000)));
            cut += 1;
        }
    }

    /// Any settings and address round-trip through the flash.
    #[test]
    fn records_round_trip(
        address in 0u8..=255,
        no_add_chg in any::<bool>(),
        words in proptest::array::uniform13(any::<u16>()),
    ) {
        let params = NvParams {
            pkw_rights: words[0],
            pzd_rights: words[1],
            operating_mode: words[2],
            control_bit_selectors: [words[3], words[4], words[5], words[6], words[7]],
            status_bit_selectors: [words[8], words[9], words[10], words[11], words[12]],
        };
        let record = NvRecord { address, no_add_chg };
        let mut store = Store::new(MemFlash::erased(2), RANGE);
        store.write_address(record).unwrap();
        store.write_params(params).unwrap();
        let mut again = Store::new(store.into_flash(), RANGE);
        prop_assert_eq!(again.load(), NvContents { address: Some(record), params: Some(params) });
    }
}
