//! The drive's fieldbus parameter group 51 (seed 004, table 5 "RPBA-01 适配器配置参数"): the
//! adapter's settings kept in the drive, set and seen at the drive's panel.
//!
//! | 51.yy | name | who writes it |
//! |---|---|---|
//! | 01 | MODULE TYPE | the adapter ([`MODULE_TYPE_PROFIBUS_DP`]); read-only at the panel |
//! | 02 | NODE ADDRESS | the panel (taken on refresh with the switch at 0); the adapter shows the address in force |
//! | 03 | BAUD RATE | the adapter, kbit/s as seed 004 lists them; read-only at the panel |
//! | 04 | PPO-TYPE | the adapter, 1-6; read-only at the panel |
//! | 05-20 | PZD3 OUT, PZD3 IN .. PZD10 OUT, PZD10 IN | the panel, or the adapter for a PROFIdrive 915/916 write |
//! | 21 | DP MODE | the panel: 0 DP-V0, 1 DP-V1 (taken at link-up and on refresh); the adapter shows the mode in force |
//! | 27 | FBA PAR REFRESH | the panel sets REFRESH (1); the adapter writes DONE (0) once the settings are in force |
//!
//! Parameter 51.yy is the function code 51.yy ([`code`]): the index in decimal digits like
//! seed 000's codes (51.27 is 0x5127), which is also the drive's register on its Modbus link.
//!
//! This is the application's side of the group: what each index means, what the adapter shows
//! and when it takes the drive's settings. It speaks in [`Transaction`]s; the drive link runs
//! them between its process-data cycles.
//!
//! Contract of [`FieldbusGroup`] (one transaction at a time, each finished before the next):
//! - At link-up it reads the settings (51.02, 51.05-51.21) once; [`FieldbusGroup::take_settings`]
//!   hands them over. It writes nothing before that, so the adapter's defaults never overwrite
//!   the drive's settings.
//! - Then it writes whatever the adapter shows ([`FieldbusGroup::show`]) and the drive does not
//!   hold. After a link fault it writes its own displays (51.01, 51.03, 51.04) again, so a
//!   restarted drive shows the truth; the settings are the drive's parameters, and a change
//!   made at the panel waits for a refresh, so they are written only where the adapter's
//!   differ from what the drive held (a 915 write made while the drive was away is not
//!   undone, nor is a panel change written over). It does not read the settings again.
//! - Every [`REFRESH_POLL_US`] it reads 51.27. REFRESH: the settings are read again and handed
//!   over with `refreshed` set, and DONE is written after the adapter has taken them.
//! - A drive without the group (it refuses 51.xx) is left alone: the adapter keeps its own
//!   settings.

use crate::codes::FunctionCode;
use crate::drive::{DriveError, Transaction};
use dp_consts::Baud;

/// Parameter indices of the group.
pub mod index {
    pub const MODULE_TYPE: u8 = 1;
    pub const NODE_ADDRESS: u8 = 2;
    pub const BAUD_RATE: u8 = 3;
    pub const PPO_TYPE: u8 = 4;
    /// PZD3 OUT; PZD n OUT is `PZD3_OUT + 2 (n - 3)`, PZD n IN the one after it.
    pub const PZD3_OUT: u8 = 5;
    pub const PZD10_IN: u8 = 20;
    pub const DP_MODE: u8 = 21;
    pub const PAR_REFRESH: u8 = 27;
}

/// The highest index of the group (seed 004 leaves 22-26 out).
pub const LAST_INDEX: u8 = index::PAR_REFRESH;
/// 51.27's values.
pub const REFRESH: u16 = 1;
pub const DONE: u16 = 0;
/// 51.21's values: DP-V0, DP-V1.
pub const DP_MODE_DPV0: u16 = 0;
pub const DP_MODE_DPV1: u16 = 1;
/// 51.01's value for this adapter. Seed 004 shows the type as text ("PROFIBUS DP"); the number
/// is this link's choice, documented with the drive simulator.
pub const MODULE_TYPE_PROFIBUS_DP: u16 = 1;
/// 51.03's value for a rate: kbit/s, the fraction dropped (seed 004 shows 187.5 kbit/s as 187).
pub const fn baud_rate_kbit(baud: Baud) -> u16 {
    (baud.bits_per_second() / 1000) as u16
}
/// How often 51.27 is read: a refresh takes effect within this time (plus the read-back).
pub const REFRESH_POLL_US: u64 = 500_000;
/// PZD3 .. PZD10: the mapped words the group holds.
pub const MAPPED_WORDS: usize = 8;

/// The group's parameter group number.
pub const GROUP: u8 = 0x51;

/// The function code of parameter 51.`index` (also the drive's register).
pub const fn code(index: u8) -> FunctionCode {
    FunctionCode::new(GROUP, ((index / 10) << 4) | (index % 10))
}

/// The index of a group parameter, if `code` is one of the group's.
pub const fn index_of(code: FunctionCode) -> Option<u8> {
    let low = code.index_byte();
    if code.group() != GROUP || low >> 4 > 9 || low & 0x0F > 9 {
        return None;
    }
    let index = (low >> 4) * 10 + (low & 0x0F);
    if index >= 1 && index <= index::DP_MODE || index == index::PAR_REFRESH {
        Some(index)
    } else {
        None
    }
}

/// The settings in the order they are read.
const SETTINGS: [u8; 18] = [
    2, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21,
];

/// The settings the drive holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// 51.02.
    pub node_address: u16,
    /// 51.05, 51.07, .. 51.19: what PZD3..PZD10 out write, as PROFIdrive 915 (xxyy).
    pub pzd_out: [u16; MAPPED_WORDS],
    /// 51.06, 51.08, .. 51.20: what PZD3..PZD10 in read, as PROFIdrive 916.
    pub pzd_in: [u16; MAPPED_WORDS],
    /// 51.21.
    pub dp_mode: u16,
    /// Read because the drive asked (51.27 REFRESH), not at link-up.
    pub refreshed: bool,
}

/// Counters for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupFigures {
    pub loads: u16,
    pub refreshes: u16,
    pub writes: u32,
    /// Writes the drive refused (a value out of its range): not tried again.
    pub refused: u16,
}

impl GroupFigures {
    /// Nothing counted yet.
    pub const fn new() -> GroupFigures {
        GroupFigures {
            loads: 0,
            refreshes: 0,
            writes: 0,
            refused: 0,
        }
    }
}

impl Default for GroupFigures {
    fn default() -> Self {
        Self::new()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Reading the settings; the next is `SETTINGS[at]`.
    Loading { at: usize, refresh: bool },
    /// Loaded and handed over (or waiting to be).
    Running,
    /// The drive has no group 51.
    Absent,
}

pub struct FieldbusGroup {
    phase: Phase,
    /// What the drive holds, where known, by index (0 unused).
    held: [Option<u16>; LAST_INDEX as usize + 1],
    /// What the adapter wants the drive to hold.
    shown: [Option<u16>; LAST_INDEX as usize + 1],
    /// Loaded settings not yet taken.
    loaded: Option<Settings>,
    /// A refresh was served: DONE goes to 51.27 once the settings were taken.
    done_due: bool,
    /// 51.02 after a refresh, until the adapter has decided on it.
    requested_address: Option<u16>,
    /// A shown value may differ from what the drive holds: the next transaction looks. The
    /// application shows its values on every cycle; looking only after a change keeps the
    /// drive link's step short.
    differs: bool,
    next_poll_us: u64,
    pub figures: GroupFigures,
}

impl FieldbusGroup {
    /// Loading the settings from the first, nothing held yet.
    pub const fn new() -> FieldbusGroup {
        let mut shown = [None; LAST_INDEX as usize + 1];
        shown[index::MODULE_TYPE as usize] = Some(MODULE_TYPE_PROFIBUS_DP);
        FieldbusGroup {
            phase: Phase::Loading {
                at: 0,
                refresh: false,
            },
            held: [None; LAST_INDEX as usize + 1],
            shown,
            loaded: None,
            done_due: false,
            requested_address: None,
            differs: true,
            next_poll_us: REFRESH_POLL_US,
            figures: GroupFigures::new(),
        }
    }
}

impl Default for FieldbusGroup {
    fn default() -> Self {
        Self::new()
    }
}

impl FieldbusGroup {
    /// What the drive should hold in 51.`index` (the read-only ones, the address in force, a
    /// mapping written through PROFIdrive). 51.27 and indices outside the group are ignored.
    pub fn show(&mut self, index: u8, value: u16) {
        let shown_by_adapter = (1..=index::DP_MODE).contains(&index);
        if shown_by_adapter && self.shown[usize::from(index)] != Some(value) {
            self.shown[usize::from(index)] = Some(value);
            self.differs = true;
        }
    }

    /// The PZD3..PZD10 mapping in force (as 915/916 hold it).
    pub fn show_mapping(&mut self, out: &[u16], inp: &[u16]) {
        for (n, (o, i)) in out.iter().zip(inp).take(MAPPED_WORDS).enumerate() {
            let out_index = index::PZD3_OUT + 2 * n as u8;
            self.show(out_index, *o);
            self.show(out_index + 1, *i);
        }
    }

    /// Settings read since the last call: at link-up, and after each refresh.
    pub fn take_settings(&mut self) -> Option<Settings> {
        self.loaded.take()
    }

    /// 51.02 as a refresh read it: the adapter takes it as its address (the switch at 0) or
    /// shows its own again. 51.02 is not written until this was taken.
    pub fn take_requested_address(&mut self) -> Option<u16> {
        self.differs = true;
        self.requested_address.take()
    }

    /// What the drive holds in 51.`index`, as far as the adapter knows.
    pub fn held(&self, index: u8) -> Option<u16> {
        self.held.get(usize::from(index)).copied().flatten()
    }

    /// Whether the drive has the group (false once it refused it).
    pub fn present(&self) -> bool {
        self.phase != Phase::Absent
    }

    /// When the group needs the link next, if it waits for time rather than work.
    pub fn poll_at(&self) -> Option<u64> {
        (self.phase == Phase::Running).then_some(self.next_poll_us)
    }

    /// The next transaction the group needs at `now_us`, if any.
    pub fn next_transaction(&mut self, now_us: u64) -> Option<Transaction> {
        match self.phase {
            Phase::Absent => None,
            Phase::Loading { at, .. } => Some(Transaction::Read(code(SETTINGS[at]))),
            // Nothing goes to the drive until the adapter has taken what was read.
            Phase::Running if self.loaded.is_some() => None,
            Phase::Running => {
                if self.done_due {
                    return Some(Transaction::Write(code(index::PAR_REFRESH), DONE));
                }
                let address_pending = self.requested_address.is_some();
                let differs = self.differs.then(|| {
                    (1..=LAST_INDEX).find(|i| {
                        !(address_pending && *i == index::NODE_ADDRESS)
                            && self.shown[usize::from(*i)].is_some_and(|v| self.held(*i) != Some(v))
                    })
                });
                match differs.flatten() {
                    Some(i) => {
                        return self.shown[usize::from(i)].map(|v| Transaction::Write(code(i), v))
                    }
                    // All written (a held-back address is looked at again once taken).
                    None => self.differs = false,
                }
                if now_us >= self.next_poll_us {
                    self.next_poll_us = now_us + REFRESH_POLL_US;
                    return Some(Transaction::Read(code(index::PAR_REFRESH)));
                }
                None
            }
        }
    }

    /// The link failed (any transaction): the drive may restart, so what it holds of the
    /// adapter's own displays (51.01, 51.03, 51.04) is unknown and they are written again; a
    /// load under way starts over. The settings (51.02, 51.05-51.21) are the drive's own
    /// parameters, kept over its restart, and the panel's: a change made there since the load
    /// waits for a refresh and must not be written over with the value in force (the soak's
    /// seed 5, event 185: a 51.21 set at the panel just after the link came back was undone,
    /// and the refresh took the old mode). A 915/916 write that came meanwhile still differs
    /// from what the drive holds, and is written.
    pub fn link_lost(&mut self) {
        for i in [index::MODULE_TYPE, index::BAUD_RATE, index::PPO_TYPE] {
            self.held[usize::from(i)] = None;
        }
        self.differs = true;
        if let Phase::Loading { at, .. } = &mut self.phase {
            *at = 0;
        }
    }

    /// How a transaction of the group ended: the value read, or the value written.
    pub fn finish(&mut self, transaction: Transaction, result: Result<u16, DriveError>) {
        // What the drive holds changes here: the shown values are compared again.
        self.differs = true;
        let (code, written) = match transaction {
            Transaction::Read(c) => (c, None),
            Transaction::Write(c, v) => (c, Some(v)),
        };
        let Some(i) = index_of(code) else { return };
        match (result, written) {
            // The link has told `link_lost`.
            (Err(e), _) if e.is_link_fault() => {}
            (Err(DriveError::IllegalAddress), None) => self.phase = Phase::Absent,
            (Err(_), Some(v)) => {
                self.figures.refused = self.figures.refused.saturating_add(1);
                // Taken as held, so that a value the drive will not take is not sent forever.
                self.held[usize::from(i)] = Some(v);
                if i == index::PAR_REFRESH {
                    self.done_due = false;
                }
            }
            (Err(_), None) => {}
            (Ok(v), None) => {
                self.held[usize::from(i)] = Some(v);
                self.read(i, v);
            }
            (Ok(_), Some(v)) => {
                self.figures.writes += 1;
                self.held[usize::from(i)] = Some(v);
                if i == index::PAR_REFRESH {
                    self.done_due = false;
                }
            }
        }
    }

    fn read(&mut self, i: u8, value: u16) {
        match self.phase {
            Phase::Loading { at, refresh } if SETTINGS[at] == i => {
                if at + 1 < SETTINGS.len() {
                    self.phase = Phase::Loading {
                        at: at + 1,
                        refresh,
                    };
                    return;
                }
                self.phase = Phase::Running;
                self.figures.loads += 1;
                self.done_due = refresh;
                self.loaded = Some(self.settings(refresh));
                if refresh {
                    self.requested_address = self.held(index::NODE_ADDRESS);
                }
            }
            Phase::Running if i == index::PAR_REFRESH && value == REFRESH => {
                self.figures.refreshes += 1;
                self.phase = Phase::Loading {
                    at: 0,
                    refresh: true,
                };
            }
            _ => {}
        }
    }

    fn settings(&self, refreshed: bool) -> Settings {
        let value = |i: u8| self.held(i).unwrap_or(0);
        let mut settings = Settings {
            node_address: value(index::NODE_ADDRESS),
            dp_mode: value(index::DP_MODE),
            refreshed,
            ..Settings::default()
        };
        for n in 0..MAPPED_WORDS {
            let out_index = index::PZD3_OUT + 2 * n as u8;
            settings.pzd_out[n] = value(out_index);
            settings.pzd_in[n] = value(out_index + 1);
        }
        settings
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn baud_rates_as_seed_004_table_5_shows_them() {
        let shown = Baud::ALL.map(baud_rate_kbit);
        assert_eq!(shown, [9, 19, 45, 93, 187, 500, 1500, 3000, 6000, 12000]);
    }

    #[test]
    fn codes_are_the_index_in_decimal_digits() {
        assert_eq!(code(1), FunctionCode(0x5101));
        assert_eq!(code(27), FunctionCode(0x5127));
        assert_eq!(code(20), FunctionCode(0x5120));
        assert_eq!(index_of(FunctionCode(0x5127)), Some(27));
        assert_eq!(index_of(FunctionCode(0x5121)), Some(21));
        // Seed 004's table leaves 22-26 out; 0x510A is not decimal.
        assert_eq!(index_of(FunctionCode(0x5122)), None);
        assert_eq!(index_of(FunctionCode(0x510A)), None);
        assert_eq!(index_of(FunctionCode(0xF027)), None);
        for i in 1..=LAST_INDEX {
            if let Some(found) = index_of(code(i)) {
                assert_eq!(found, i);
            }
        }
    }

    /// Answers the group's transactions from `drive` (index -> value) until it is idle.
    fn serve(group: &mut FieldbusGroup, drive: &mut [u16; 28], now_us: u64) -> Vec<Transaction> {
        let mut ops = Vec::new();
        while let Some(op) = group.next_transaction(now_us) {
            ops.push(op);
            let result = match op {
                Transaction::Read(c) => Ok(drive[usize::from(index_of(c).unwrap())]),
                Transaction::Write(c, v) => {
                    drive[usize::from(index_of(c).unwrap())] = v;
                    Ok(v)
                }
            };
            group.finish(op, result);
            assert!(ops.len() < 100, "the group never settles: {ops:?}");
        }
        ops
    }

    #[test]
    fn loads_first_then_shows_then_serves_a_refresh() {
        let mut drive = [0u16; 28];
        drive[2] = 3; // seed 004's default address
        drive[5] = 1202; // PZD3 OUT, seed 004's example
        drive[6] = 104;
        drive[21] = 1;
        let mut group = FieldbusGroup::default();
        group.show(index::BAUD_RATE, 1500);
        group.show(index::NODE_ADDRESS, 8);
        // The load: 18 reads, no write before the settings were taken.
        let ops = serve(&mut group, &mut drive, 0);
        assert_eq!(ops.len(), SETTINGS.len());
        assert!(ops.iter().all(|op| matches!(op, Transaction::Read(_))));
        let settings = group.take_settings().expect("loaded");
        assert_eq!(
            (
                settings.node_address,
                settings.pzd_out[0],
                settings.pzd_in[0]
            ),
            (3, 1202, 104)
        );
        assert_eq!((settings.dp_mode, settings.refreshed), (1, false));
        group.show_mapping(&settings.pzd_out, &settings.pzd_in);
        // Now the shown values: module type, address, baud rate; 51.21 is the panel's until
        // the adapter shows the mode it took.
        serve(&mut group, &mut drive, 0);
        assert_eq!(
            (drive[1], drive[2], drive[3], drive[21]),
            (MODULE_TYPE_PROFIBUS_DP, 8, 1500, 1)
        );
        assert_eq!((drive[5], drive[6]), (1202, 104), "the mapping unchanged");
        // The panel changes PZD4 OUT; nothing happens before the refresh.
        drive[7] = 2501;
        assert!(serve(&mut group, &mut drive, 1000).is_empty());
        drive[27] = REFRESH;
        let ops = serve(&mut group, &mut drive, REFRESH_POLL_US);
        assert_eq!(ops.len(), 1 + SETTINGS.len());
        let settings = group.take_settings().expect("refreshed");
        assert!(settings.refreshed);
        assert_eq!(group.take_requested_address(), Some(8));
        assert_eq!(settings.pzd_out[1], 2501);
        group.show_mapping(&settings.pzd_out, &settings.pzd_in);
        // DONE goes to 51.27 once the settings were taken.
        serve(&mut group, &mut drive, REFRESH_POLL_US);
        assert_eq!(drive[27], DONE);
        assert_eq!(group.figures.refreshes, 1);
    }

    #[test]
    fn a_link_fault_rewrites_what_the_drive_should_hold_without_reloading() {
        let mut drive = [0u16; 28];
        let mut group = FieldbusGroup::default();
        serve(&mut group, &mut drive, 0);
        group.take_settings().unwrap();
        group.show(index::PPO_TYPE, 2);
        serve(&mut group, &mut drive, 0);
        assert_eq!(drive[4], 2);
        // The drive restarts without the values; a 915 write comes while it is away.
        group.link_lost();
        drive = [0u16; 28];
        group.show(index::PZD3_OUT, 113);
        let ops = serve(&mut group, &mut drive, 0);
        assert!(
            ops.iter().all(|op| matches!(op, Transaction::Write(..))),
            "{ops:?}"
        );
        assert_eq!(
            (drive[1], drive[4], drive[5]),
            (MODULE_TYPE_PROFIBUS_DP, 2, 113)
        );
        assert!(group.take_settings().is_none());
    }

    #[test]
    fn a_link_fault_does_not_write_over_a_setting_changed_at_the_panel() {
        let mut drive = [0u16; 28];
        drive[21] = DP_MODE_DPV1;
        let mut group = FieldbusGroup::default();
        serve(&mut group, &mut drive, 0);
        let settings = group.take_settings().unwrap();
        group.show(index::DP_MODE, settings.dp_mode);
        serve(&mut group, &mut drive, 0);
        group.link_lost();
        // Back: the panel sets DP-V0 and asks for a refresh before the group's next turn.
        drive[21] = DP_MODE_DPV0;
        drive[27] = REFRESH;
        serve(&mut group, &mut drive, REFRESH_POLL_US);
        let settings = group.take_settings().expect("refreshed");
        assert_eq!(settings.dp_mode, DP_MODE_DPV0);
        assert_eq!(drive[21], DP_MODE_DPV0);
    }

    #[test]
    fn a_drive_without_the_group_is_left_alone_and_refused_values_are_not_resent() {
        let mut group = FieldbusGroup::default();
        let op = group.next_transaction(0).unwrap();
        group.finish(op, Err(DriveError::IllegalAddress));
        assert!(!group.present());
        assert_eq!(group.next_transaction(10_000_000), None);

        let mut group = FieldbusGroup::default();
        let mut drive = [0u16; 28];
        serve(&mut group, &mut drive, 0);
        group.take_settings().unwrap();
        serve(&mut group, &mut drive, 0);
        group.show(index::PZD3_OUT, 40000);
        let op = group.next_transaction(0).unwrap();
        assert_eq!(op, Transaction::Write(code(5), 40000));
        group.finish(op, Err(DriveError::InvalidData));
        let rest = serve(&mut group, &mut drive, 0);
        assert!(!rest.contains(&op));
        assert_eq!(group.figures.refused, 1);
    }
}
