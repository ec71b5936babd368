//! The adapter's User_Prm_Data: what Set_Prm carries after its 7 standard bytes.
//!
//! One layout serves both profiles. The first 24 bytes are seed 004's extended Prm_Data,
//! bytes 7-30 of its Set_Prm table. The RPBA-01 GSD lays them out the same way. The
//! PZD mapping table of seed 000 ("设置详细信息", RdPZD2-10 and WrPZD2-10 with the GSD
//! defaults) follows.
//!
//! | offset | bytes | field | source |
//! |---|---|---|---|
//! | 0 | 1 | reserved, 0 | seed 004 byte 7 |
//! | 1 | 1 | bits 0-1 fail-safe mode, 2-3 control-zero mode, 4-5 operation mode (0 PROFIdrive, 1 vendor, 2 ABB Drives) | seed 004 byte 8 (default 10h) |
//! | 2 | 2 | communication cut-off time, ms, 0 = none | seed 004 bytes 9-10 |
//! | 4 | 20 | fail-safe PZD1 (CW) .. PZD10 | seed 004 bytes 11-30 |
//! | 24 | 18 | RdPZD2 .. RdPZD10, function codes | seed 000 rows 1-9 |
//! | 42 | 18 | WrPZD2 .. WrPZD10, function codes | seed 000 rows 10-18 |
//! | 60 | 2 | rated frequency, 0.01 Hz, for 4000h (PROFIdrive) and 20000 (ABB Drives); 0 = the drive's maximum frequency F0.10, read at link-up | seed 004 lines 334, 370 (issue 18) |
//!
//! All words are big-endian, as PROFIBUS sends them. [`UserPrm::parse`] never panics; it
//! refuses a wrong length, reserved bits, a mode out of range and a mapping to a code of the
//! wrong kind (Prm_Fault).

use crate::codes::{CodeKind, FunctionCode};
use crate::ppo::MAX_PZD_WORDS;

/// Seed 004 byte 8, bits 0-1: what a PLC stop, a watchdog expiry or a cut-off does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FailSafeMode {
    /// Stop the drive.
    Stop = 0,
    /// Keep the last control word and references.
    LastSpeed = 1,
    /// Send the fail-safe PZD values of the parameter data.
    UseFailSafeValues = 2,
}

/// Seed 004 byte 8, bits 2-3: what an all-zero output frame does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlZeroMode {
    /// Use the frame, zeros and all.
    UseFrame = 0,
    /// Ignore it and keep the previous outputs.
    IgnoreFrame = 1,
}

/// Seed 004 byte 8, bits 4-5: which control and status words are on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OperationMode {
    /// The PROFIdrive state machine of seed 004 (tables 7 and 8), 0x4000 = rated speed.
    Profidrive = 0,
    /// The vendor's words of seed 000 (its control and status word tables), passed to the
    /// drive unchanged, as seed 004's "vendor specific" mode does.
    Vendor = 1,
    /// Seed 004's vendor mode, the ABB Drives profile: the same state machine as PROFIdrive
    /// (its control word has the same bits), with references scaled +-20000 = rated speed.
    AbbDrives = 2,
}

impl OperationMode {
    /// Whether the adapter runs the state machine and translates to the drive's words.
    pub const fn translates(self) -> bool {
        !matches!(self, OperationMode::Vendor)
    }

    /// The reference value of the rated speed: 4000h (PROFIdrive), 20000 (ABB Drives).
    pub const fn rated_units(self) -> i32 {
        match self {
            OperationMode::AbbDrives => 20_000,
            _ => 0x4000,
        }
    }
}

/// Why user parameters were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PrmError {
    Length(usize),
    ReservedBits,
    FailSafeMode(u8),
    ControlZeroMode(u8),
    OperationMode(u8),
    /// RdPZD (index 2..10) names no readable status value or fault record.
    ReadMapping(u8),
    /// WrPZD (index 2..10) names no application parameter.
    WriteMapping(u8),
    /// A rated frequency above [`UserPrm::MAX_RATED_FREQUENCY`].
    RatedFrequency(u16),
}

/// The parsed user parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UserPrm {
    pub fail_safe: FailSafeMode,
    pub control_zero: ControlZeroMode,
    pub operation: OperationMode,
    /// Communication cut-off: fail-safe when no Data_Exchange came for this long (0 = off).
    pub cut_off_ms: u16,
    /// PZD1 (control word) .. PZD10 sent in the fail-safe mode UseFailSafeValues.
    pub fail_safe_pzd: [u16; MAX_PZD_WORDS],
    /// What PZD2 .. PZD10 in (to the master) read.
    pub rd_pzd: [FunctionCode; MAX_PZD_WORDS - 1],
    /// What PZD2 .. PZD10 out (from the master) write.
    pub wr_pzd: [FunctionCode; MAX_PZD_WORDS - 1],
    /// The speed reference 4000h (PROFIdrive) or 20000 (ABB Drives) stands for, in the drive's
    /// 0.01 Hz. Seed 004 ties those to the drive's 99.08 (rated speed) and 11.05 (EXT REF1
    /// MAXIMUM); seed 000's drive has neither, so the master sets it, or leaves 0 for the
    /// drive's maximum frequency (F0.10), read from the drive at link-up.
    pub rated_frequency: u16,
}

const fn f(group: u8, index: u8) -> FunctionCode {
    FunctionCode::new(group, index)
}

impl UserPrm {
    pub const LEN: usize = 62;
    const HEADER: usize = 1;
    const CUT_OFF: usize = 2;
    const FAIL_SAFE_PZD: usize = 4;
    const RD_PZD: usize = 24;
    const WR_PZD: usize = 42;
    const RATED: usize = 60;
    /// 600.00 Hz: the highest rated frequency taken (the scaling stays within 32 bits).
    pub const MAX_RATED_FREQUENCY: u16 = 60_000;

    /// The GSD defaults: fail-safe STOP, use the frame, vendor words (seed 004's default header
    /// 10h), no cut-off, fail-safe values 0, and seed 000's mapping table.
    pub const DEFAULT: UserPrm = UserPrm {
        fail_safe: FailSafeMode::Stop,
        control_zero: ControlZeroMode::UseFrame,
        operation: OperationMode::Vendor,
        cut_off_ms: 0,
        fail_safe_pzd: [0; MAX_PZD_WORDS],
        rd_pzd: [
            f(0xD0, 0x00),
            f(0xD0, 0x01),
            f(0xD0, 0x02),
            f(0xD0, 0x04),
            f(0xD0, 0x05),
            f(0xD0, 0x07),
            f(0xD0, 0x08),
            f(0xD0, 0x33),
            f(0xD0, 0x34),
        ],
        wr_pzd: [
            f(0xF0, 0x29),
            f(0xF1, 0x03),
            f(0xF1, 0x04),
            f(0xF8, 0x21),
            f(0xF8, 0x22),
            f(0xF8, 0x25),
            f(0xF8, 0x26),
            f(0xF1, 0x05),
            f(0xF1, 0x06),
        ],
        rated_frequency: 0,
    };

    /// The user data of seed 004's DP-V1 Set_Prm: the same fields, without the reserved first
    /// byte (DPV1_Status_1-3 take bytes 7-9, the header is byte 10).
    pub fn parse_dpv1(bytes: &[u8]) -> Result<UserPrm, PrmError> {
        if bytes.len() != Self::LEN - 1 {
            return Err(PrmError::Length(bytes.len()));
        }
        let mut with_reserved = [0u8; Self::LEN];
        with_reserved[1..].copy_from_slice(bytes);
        Self::parse(&with_reserved)
    }

    pub fn parse(bytes: &[u8]) -> Result<UserPrm, PrmError> {
        if bytes.len() != Self::LEN {
            return Err(PrmError::Length(bytes.len()));
        }
        let header = bytes[Self::HEADER];
        if bytes[0] != 0 || header & 0xC0 != 0 {
            return Err(PrmError::ReservedBits);
        }
        let word = |at: usize| u16::from_be_bytes([bytes[at], bytes[at + 1]]);
        let fail_safe = match header & 0x03 {
            0 => FailSafeMode::Stop,
            1 => FailSafeMode::LastSpeed,
            2 => FailSafeMode::UseFailSafeValues,
            other => return Err(PrmError::FailSafeMode(other)),
        };
        let control_zero = match (header >> 2) & 0x03 {
            0 => ControlZeroMode::UseFrame,
            1 => ControlZeroMode::IgnoreFrame,
            other => return Err(PrmError::ControlZeroMode(other)),
        };
        let operation = match (header >> 4) & 0x03 {
            0 => OperationMode::Profidrive,
            1 => OperationMode::Vendor,
            2 => OperationMode::AbbDrives,
            other => return Err(PrmError::OperationMode(other)),
        };
        let rated_frequency = word(Self::RATED);
        if rated_frequency > Self::MAX_RATED_FREQUENCY {
            return Err(PrmError::RatedFrequency(rated_frequency));
        }
        let mut prm = UserPrm {
            fail_safe,
            control_zero,
            operation,
            cut_off_ms: word(Self::CUT_OFF),
            rated_frequency,
            ..UserPrm::DEFAULT
        };
        for (i, v) in prm.fail_safe_pzd.iter_mut().enumerate() {
            *v = word(Self::FAIL_SAFE_PZD + 2 * i);
        }
        for i in 0..MAX_PZD_WORDS - 1 {
            let rd = FunctionCode(word(Self::RD_PZD + 2 * i));
            if !matches!(rd.kind(), Some(CodeKind::Status | CodeKind::FaultRecord)) {
                return Err(PrmError::ReadMapping(i as u8 + 2));
            }
            let wr = FunctionCode(word(Self::WR_PZD + 2 * i));
            if !wr.is_writable() {
                return Err(PrmError::WriteMapping(i as u8 + 2));
            }
            prm.rd_pzd[i] = rd;
            prm.wr_pzd[i] = wr;
        }
        Ok(prm)
    }

    /// The bytes [`UserPrm::parse`] reads back as `self`.
    pub fn encode(&self) -> [u8; UserPrm::LEN] {
        let mut out = [0u8; UserPrm::LEN];
        out[Self::HEADER] =
            self.fail_safe as u8 | (self.control_zero as u8) << 2 | (self.operation as u8) << 4;
        out[Self::CUT_OFF..Self::CUT_OFF + 2].copy_from_slice(&self.cut_off_ms.to_be_bytes());
        out[Self::RATED..Self::RATED + 2].copy_from_slice(&self.rated_frequency.to_be_bytes());
        for (i, v) in self.fail_safe_pzd.iter().enumerate() {
            let at = Self::FAIL_SAFE_PZD + 2 * i;
            out[at..at + 2].copy_from_slice(&v.to_be_bytes());
        }
        for i in 0..MAX_PZD_WORDS - 1 {
            let at = Self::RD_PZD + 2 * i;
            out[at..at + 2].copy_from_slice(&self.rd_pzd[i].0.to_be_bytes());
            let at = Self::WR_PZD + 2 * i;
            out[at..at + 2].copy_from_slice(&self.wr_pzd[i].0.to_be_bytes());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn seed_004_default_header_is_10h() {
        let bytes = UserPrm::DEFAULT.encode();
        assert_eq!(bytes[1], 0x10);
        assert_eq!(UserPrm::parse(&bytes), Ok(UserPrm::DEFAULT));
    }

    #[test]
    fn seed_004_lines_334_370_the_rated_frequency_is_a_user_parameter() {
        let mut prm = UserPrm::DEFAULT;
        assert_eq!(
            prm.rated_frequency, 0,
            "the drive's F0.10 unless the master says"
        );
        prm.rated_frequency = 6000;
        let bytes = prm.encode();
        assert_eq!(&bytes[60..62], &[0x17, 0x70]);
        assert_eq!(UserPrm::parse(&bytes), Ok(prm));
        let mut over = bytes;
        over[60..62].copy_from_slice(&60_001u16.to_be_bytes());
        assert_eq!(UserPrm::parse(&over), Err(PrmError::RatedFrequency(60_001)));
    }

    #[test]
    fn seed_000_gsd_default_mapping() {
        // Seed 000's table: RdPZD2 = D0.00 .. RdPZD10 = D0.34; WrPZD2 = F0.29 .. WrPZD10 = F1.06.
        let rd = [
            "D0.00", "D0.01", "D0.02", "D0.04", "D0.05", "D0.07", "D0.08", "D0.33", "D0.34",
        ];
        let wr = [
            "F0.29", "F1.03", "F1.04", "F8.21", "F8.22", "F8.25", "F8.26", "F1.05", "F1.06",
        ];
        for i in 0..9 {
            assert_eq!(UserPrm::DEFAULT.rd_pzd[i].to_string(), rd[i]);
            assert_eq!(UserPrm::DEFAULT.wr_pzd[i].to_string(), wr[i]);
        }
    }

    #[test]
    fn seed_004_header_bits() {
        let mut bytes = UserPrm::DEFAULT.encode();
        // LAST SPEED, ignore zero frames, PROFIdrive.
        bytes[1] = 0b00_00_01_01;
        let prm = UserPrm::parse(&bytes).unwrap();
        assert_eq!(prm.fail_safe, FailSafeMode::LastSpeed);
        assert_eq!(prm.control_zero, ControlZeroMode::IgnoreFrame);
        assert_eq!(prm.operation, OperationMode::Profidrive);
        bytes[1] = 0x03;
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::FailSafeMode(3)));
        bytes[1] = 0x08;
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::ControlZeroMode(2)));
        bytes[1] = 0x20;
        assert_eq!(
            UserPrm::parse(&bytes).map(|p| p.operation),
            Ok(OperationMode::AbbDrives)
        );
        bytes[1] = 0x30;
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::OperationMode(3)));
        bytes[1] = 0x40;
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::ReservedBits));
    }

    #[test]
    fn wrong_mappings_and_lengths_are_refused() {
        let mut bytes = UserPrm::DEFAULT.encode();
        // RdPZD3 pointing at an application parameter, WrPZD2 at a status value.
        bytes[26..28].copy_from_slice(&0xF029u16.to_be_bytes());
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::ReadMapping(3)));
        let mut bytes = UserPrm::DEFAULT.encode();
        bytes[42..44].copy_from_slice(&0xD100u16.to_be_bytes());
        assert_eq!(UserPrm::parse(&bytes), Err(PrmError::WriteMapping(2)));
        assert_eq!(UserPrm::parse(&[0; 59]), Err(PrmError::Length(59)));
        assert_eq!(UserPrm::parse(&[]), Err(PrmError::Length(0)));
    }

    proptest! {
        #[test]
        fn parse_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..80)) {
            if let Ok(prm) = UserPrm::parse(&bytes) {
                prop_assert_eq!(&prm.encode()[..], &bytes[..]);
            }
        }
    }
}
