//! The vendor profile's function codes (seed 000, "功能代码 FID 范围"): a parameter Fx.yy,
//! Dx.yy or DE.yy is the 16-bit code 0xXXYY, the group in the high byte and the index, in
//! decimal digits, in the low byte (F0.29 is 0xF029, decimal 61481 in the manual).
//!
//! | group | meaning | range |
//! |---|---|---|
//! | F0 .. FF | application parameters (read, write) | Fx.00 .. Fx.55 |
//! | D0, D1 | status values (read only) | D0.00 .. D0.99, D1.00 .. D1.49 |
//! | DE | fault record (read only) | DE.00 .. DE.25 |

use core::fmt;

/// The drive's function codes this project names, defined once for the application, the drive
/// link, the drive simulator and the tests. Seed 000 names F0.29, F0.33/F0.34 and the D0/DE
/// values; the ramp times and the maximum frequency are where the drive simulator documents
/// them.
pub mod named {
    /// F0.10, maximum frequency, 0.01 Hz.
    pub const MAX_FREQUENCY: u16 = 0xF010;
    /// F0.13, F0.14: acceleration and deceleration time, 0.1 s.
    pub const ACCEL_TIME: u16 = 0xF013;
    pub const DECEL_TIME: u16 = 0xF014;
    /// F0.29: set frequency, 0.01 Hz ("通过 F029 给定运行频率").
    pub const SET_FREQUENCY: u16 = 0xF029;
    /// F0.33, F0.34: command source.
    pub const COMMAND_SOURCE: u16 = 0xF033;
    pub const COMMAND_SOURCE_2: u16 = 0xF034;
    /// D0.00: output frequency, 0.01 Hz.
    pub const OUTPUT_FREQUENCY: u16 = 0xD000;
    /// D0.01: set frequency, 0.01 Hz.
    pub const SET_FREQUENCY_STATUS: u16 = 0xD001;
    /// D0.04: output current, 0.01 A.
    pub const OUTPUT_CURRENT: u16 = 0xD004;
    /// DE.00: the newest fault or warning record.
    pub const FAULT_RECORD: u16 = 0xDE00;
}

/// A function code; [`FunctionCode::kind`] says whether it names a parameter at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FunctionCode(pub u16);

/// What a function code names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CodeKind {
    /// Fx.yy: writable application parameter.
    Application,
    /// Dx.yy: status value.
    Status,
    /// DE.yy: fault record.
    FaultRecord,
}

impl FunctionCode {
    pub const fn new(group: u8, index: u8) -> FunctionCode {
        FunctionCode(((group as u16) << 8) | index as u16)
    }

    pub const fn group(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// The index byte (decimal digits, 0x29 for .29).
    pub const fn index_byte(self) -> u8 {
        self.0 as u8
    }

    /// The index as a number (29 for .29), if its byte holds two decimal digits.
    pub const fn index(self) -> Option<u8> {
        let b = self.index_byte();
        if b >> 4 > 9 || b & 0x0F > 9 {
            None
        } else {
            Some((b >> 4) * 10 + (b & 0x0F))
        }
    }

    /// What the code names, or `None` for a code outside the drive's parameter space (the PKW
    /// reply is then error 0x02, illegal address).
    pub const fn kind(self) -> Option<CodeKind> {
        let Some(index) = self.index() else {
            return None;
        };
        match self.group() {
            0xF0..=0xFF if index <= 55 => Some(CodeKind::Application),
            0xD0 if index <= 99 => Some(CodeKind::Status),
            0xD1 if index <= 49 => Some(CodeKind::Status),
            0xDE if index <= 25 => Some(CodeKind::FaultRecord),
            _ => None,
        }
    }

    pub const fn is_writable(self) -> bool {
        matches!(self.kind(), Some(CodeKind::Application))
    }

    pub const fn is_readable(self) -> bool {
        self.kind().is_some()
    }
}

impl fmt::Display for FunctionCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let g = self.group();
        write!(f, "{:X}{:X}.{:02X}", g >> 4, g & 0x0F, self.index_byte())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_000_f0_29_is_0xf029_decimal_61481() {
        let code = FunctionCode::new(0xF0, 0x29);
        assert_eq!(code.0, 0xF029);
        assert_eq!(code.0, 61481);
        assert_eq!(code.index(), Some(29));
        assert_eq!(code.to_string(), "F0.29");
        assert_eq!(code.kind(), Some(CodeKind::Application));
    }

    #[test]
    fn seed_000_fid_ranges() {
        assert!(FunctionCode(0xF000).is_writable());
        assert!(FunctionCode(0xFF55).is_writable());
        // F0.58, the manual's example of a refused request (reply 7, 0x02).
        assert_eq!(FunctionCode(0xF058).kind(), None);
        assert_eq!(FunctionCode(0xD000).kind(), Some(CodeKind::Status));
        assert_eq!(FunctionCode(0xD149).kind(), Some(CodeKind::Status));
        assert_eq!(FunctionCode(0xD150).kind(), None);
        assert_eq!(FunctionCode(0xDE00).kind(), Some(CodeKind::FaultRecord));
        assert_eq!(FunctionCode(0xDE25).kind(), Some(CodeKind::FaultRecord));
        assert_eq!(FunctionCode(0xDE26).kind(), None);
        // Not decimal digits.
        assert_eq!(FunctionCode(0xF00A).kind(), None);
        assert_eq!(FunctionCode(0x1234).kind(), None);
        assert!(!FunctionCode(0xD100).is_writable());
        assert!(FunctionCode(0xD100).is_readable());
    }
}
