//! Seed 004's extended diagnosis: the drive link lost temporarily or (after
//! [`LINK_LOST_PERMANENTLY_US`]) permanently, and the drive's fault (bit 2, this adapter's own,
//! declared in the GSD), in one byte of flags. In DP-V0 (51.21 = 0) they follow one header
//! byte, its length, 2 (seed 004 line 731); in DP-V1 (51.21 = 1) they close a status block
//! (lines 1098-1113): header (its length, 5), status type 81h (a status message), slot 0,
//! specifier 0, the flags at byte 10 of the diagnosis.

use crate::drive::DriveError;
use dp_slave::Instant;

/// How long the drive may stay silent before the loss counts as permanent (seed 004's
/// extended diagnosis: "communication temporarily / permanently lost").
pub const LINK_LOST_PERMANENTLY_US: u64 = 1_000_000;

pub const EXT_DIAG_LEN: u8 = 2;
/// The DP-V1 status block's length, header included.
pub const DPV1_STATUS_BLOCK_LEN: u8 = 5;
/// Its status type: bit 7 a status block, type 1 a status message.
pub const DPV1_STATUS_TYPE: u8 = 0x81;
pub const EXT_DIAG_LINK_LOST_TEMPORARILY: u8 = 0x01;
pub const EXT_DIAG_LINK_LOST_PERMANENTLY: u8 = 0x02;
/// The drive reports a fault (its status word's fault bit): the master learns of it from the
/// diagnosis too, not only from the status word it may not be watching.
pub const EXT_DIAG_DRIVE_FAULT: u8 = 0x04;

/// The drive link as seed 004's host LED shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveLink {
    /// No exchange with the drive yet.
    NotYet,
    Up,
    LostTemporarily,
    /// Silent for [`LINK_LOST_PERMANENTLY_US`] or more.
    LostPermanently,
}

/// The flags and when the link was lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkDiagnosis {
    lost_since: Option<Instant>,
    flags: u8,
    /// A cycle with the drive has been noted.
    noted: bool,
}

impl LinkDiagnosis {
    /// No cycle with the drive noted yet.
    pub const fn new() -> LinkDiagnosis {
        LinkDiagnosis {
            lost_since: None,
            flags: 0,
            noted: false,
        }
    }
}

impl Default for LinkDiagnosis {
    fn default() -> Self {
        Self::new()
    }
}

impl LinkDiagnosis {
    /// The drive link's state at `now` (`error`: its error, while it lasts) and whether the
    /// drive reports a fault; whether the flags changed (a new diagnosis).
    pub fn note(&mut self, now: Instant, error: Option<DriveError>, drive_faulted: bool) -> bool {
        self.noted = true;
        match error {
            Some(_) => {
                self.lost_since.get_or_insert(now);
            }
            None => self.lost_since = None,
        }
        let flags = match self.lost_since {
            None => 0,
            Some(since) if now.micros() - since.micros() >= LINK_LOST_PERMANENTLY_US => {
                EXT_DIAG_LINK_LOST_PERMANENTLY
            }
            Some(_) => EXT_DIAG_LINK_LOST_TEMPORARILY,
        } | if drive_faulted {
            EXT_DIAG_DRIVE_FAULT
        } else {
            0
        };
        let changed = flags != self.flags;
        self.flags = flags;
        changed
    }

    /// The link as of the last [`note`](Self::note).
    pub fn link(&self) -> DriveLink {
        if !self.noted {
            DriveLink::NotYet
        } else if self.flags & EXT_DIAG_LINK_LOST_PERMANENTLY != 0 {
            DriveLink::LostPermanently
        } else if self.flags & EXT_DIAG_LINK_LOST_TEMPORARILY != 0 {
            DriveLink::LostTemporarily
        } else {
            DriveLink::Up
        }
    }

    /// The extended diagnosis into `buffer`, in DP-V1's status block (`dpv1`) or DP-V0's form;
    /// returns its length, always the same for a mode (seed 004 line 731: "Fixed to 2"), the
    /// flags 0 while all is well.
    pub fn write(&self, buffer: &mut [u8], dpv1: bool) -> usize {
        let block: &[u8] = if dpv1 {
            &[DPV1_STATUS_BLOCK_LEN, DPV1_STATUS_TYPE, 0, 0, self.flags]
        } else {
            &[EXT_DIAG_LEN, self.flags]
        };
        match buffer.get_mut(..block.len()) {
            Some(room) => {
                room.copy_from_slice(block);
                block.len()
            }
            None => 0,
        }
    }

    /// Whether a flag is set (Station_Status_1's Ext_Diag).
    pub fn reported(&self) -> bool {
        self.flags != 0
    }
}
