//! PROFIBUS DP protocol constants: the one place that names them.
//!
//! Everything here is a fact of the wire (EN 50170 vol. 2, shared/PROTOCOL.md, shared/DESIGN.md)
//! that more than one crate needs: the transceiver model, the FDL codec, the slave state machine,
//! the firmware and the GSD writer all read it from here, so a number is never written twice.
//! Timing is in bit times (tBit = 1 / baud rate) unless a name says otherwise.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

/// A code point of a protocol field: an enum of the values the protocol names, an `Unknown`
/// for the rest (so that every value round-trips), and the conversions from and to the field's
/// integer type (`u8` unless given: `pub enum Name: u16 { .. }`), like smoltcp's
/// `enum_with_unknown!`. fdl's function codes and the PROFIdrive parameter channel's labels and
/// error numbers are written with it. The defmt derive follows the calling crate's `defmt`
/// feature. Hand-written because no published crate offers this for no_std without pulling in
/// a proc-macro stack the firmware does not need.
#[macro_export]
macro_rules! code_point {
    ($(#[$m:meta])* pub enum $name:ident { $($body:tt)* }) => {
        $crate::code_point! { $(#[$m])* pub enum $name: u8 { $($body)* } }
    };
    ($(#[$m:meta])* pub enum $name:ident: $repr:ty {
        $($(#[$vm:meta])* $variant:ident = $value:expr),+ $(,)?
    }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $name {
            $($(#[$vm])* $variant,)+
            /// A code this crate does not name; kept so that it round-trips.
            Unknown($repr),
        }
        impl From<$repr> for $name {
            fn from(value: $repr) -> Self {
                match value {
                    $($value => $name::$variant,)+
                    other => $name::Unknown(other),
                }
            }
        }
        impl From<$name> for $repr {
            fn from(value: $name) -> $repr {
                match value {
                    $($name::$variant => $value,)+
                    $name::Unknown(other) => other,
                }
            }
        }
    };
}

/// Bits on the wire per character: start 0, 8 data bits LSB first, even parity, stop 1.
pub const BITS_PER_CHAR: u32 = 11;

/// Synchronisation time: idle bit times the line must rest before a request may start.
pub const TSYN_BITS: u32 = 33;

/// The smallest station delay of a responder, in bit times, at every rate.
pub const MIN_TSDR_BITS: u8 = 11;

/// Start delimiter of a telegram with no data unit: `10 DA SA FC FCS 16`.
pub const SD1: u8 = 0x10;
/// Start delimiter of a telegram with a variable data unit: `68 LE LEr 68 DA SA FC .. FCS 16`.
pub const SD2: u8 = 0x68;
/// Start delimiter of a telegram with an 8-byte data unit: `A2 DA SA FC DU*8 FCS 16`.
pub const SD3: u8 = 0xA2;
/// Start delimiter of the token telegram: `DC DA SA`.
pub const SD4: u8 = 0xDC;
/// Short acknowledgement, a whole telegram of one byte.
pub const SC: u8 = 0xE5;
/// End delimiter.
pub const ED: u8 = 0x16;

/// Data-unit length of an SD3 telegram (SAP bytes included).
pub const SD3_DATA_LEN: usize = 8;
/// Smallest LE of an SD2 telegram: DA, SA, FC and at least one data byte.
pub const SD2_MIN_LE: u8 = 4;
/// Largest LE of an SD2 telegram: DA, SA, FC and 246 data bytes.
pub const SD2_MAX_LE: u8 = 249;
/// The longest telegram on the wire (an SD2 of the largest LE plus its six framing bytes).
pub const MAX_TELEGRAM_LEN: usize = SD2_MAX_LE as usize + 6;

/// The broadcast station address: requests to it get no response.
pub const BROADCAST_ADDRESS: u8 = 127;
/// The highest address a station may hold (126 is the default of a slave without one).
pub const MAX_STATION_ADDRESS: u8 = 126;

/// The adapter's own Ident_Number, in its GSD file and checked in every Set_Prm. (Ident numbers
/// are assigned by PROFIBUS International; this open implementation holds none, so it uses one
/// from the range no listed device of the reference GSD files uses.)
pub const ADAPTER_IDENT_NUMBER: u16 = 0xD7A1;

/// DP service access points of a slave and of a master (PROTOCOL.md, "DP service access points").
pub mod sap {
    /// Set_Slave_Add.
    pub const SET_SLAVE_ADD: u8 = 55;
    /// Rd_Inp: read the slave's inputs.
    pub const RD_INP: u8 = 56;
    /// Rd_Outp: read the slave's outputs.
    pub const RD_OUTP: u8 = 57;
    /// Global_Control (broadcast or multicast).
    pub const GLOBAL_CONTROL: u8 = 58;
    /// Get_Cfg.
    pub const GET_CFG: u8 = 59;
    /// Slave_Diag.
    pub const SLAVE_DIAG: u8 = 60;
    /// Set_Prm.
    pub const SET_PRM: u8 = 61;
    /// Chk_Cfg.
    pub const CHK_CFG: u8 = 62;
    /// The class 1 master's SAP for DP-V0 management services (MS0).
    pub const MASTER_MS0: u8 = 62;
}

/// Set_Prm byte 0, Station_Status.
pub mod station_status {
    pub const WD_ON: u8 = 0x08;
    pub const FREEZE_REQ: u8 = 0x10;
    pub const SYNC_REQ: u8 = 0x20;
    pub const UNLOCK_REQ: u8 = 0x40;
    pub const LOCK_REQ: u8 = 0x80;
}

/// The fixed part of a Set_Prm data unit: Station_Status, WD_Fact1, WD_Fact2, min TSDR,
/// Ident_Number (2), Group_Ident. User parameters follow.
pub const SET_PRM_FIXED_LEN: usize = 7;

/// The watchdog base of DP-V0: WD_Fact1 x WD_Fact2 x 10 ms.
pub const WATCHDOG_BASE_MS: u32 = 10;

/// Global_Control byte 0, Control_Command.
pub mod control_command {
    pub const CLEAR_DATA: u8 = 0x02;
    pub const UNFREEZE: u8 = 0x04;
    pub const FREEZE: u8 = 0x08;
    pub const UNSYNC: u8 = 0x10;
    pub const SYNC: u8 = 0x20;
}

/// The standard diagnosis bytes (Slave_Diag), PROTOCOL.md "Slave_Diag".
pub mod diag {
    /// Length of the standard part: St1, St2, St3, Master_Add, Ident_Number (2).
    pub const STANDARD_LEN: usize = 6;
    /// Master_Add before any master has parameterised the slave.
    pub const NO_MASTER: u8 = 0xFF;

    pub const ST1_STATION_NON_EXISTENT: u8 = 0x01;
    pub const ST1_NOT_READY: u8 = 0x02;
    pub const ST1_CFG_FAULT: u8 = 0x04;
    pub const ST1_EXT_DIAG: u8 = 0x08;
    pub const ST1_NOT_SUPPORTED: u8 = 0x10;
    pub const ST1_INVALID_SLAVE_RESPONSE: u8 = 0x20;
    pub const ST1_PRM_FAULT: u8 = 0x40;
    pub const ST1_MASTER_LOCK: u8 = 0x80;

    pub const ST2_PRM_REQ: u8 = 0x01;
    pub const ST2_STAT_DIAG: u8 = 0x02;
    pub const ST2_ALWAYS_ONE: u8 = 0x04;
    pub const ST2_WD_ON: u8 = 0x08;
    pub const ST2_FREEZE_MODE: u8 = 0x10;
    pub const ST2_SYNC_MODE: u8 = 0x20;
    pub const ST2_DEACTIVATED: u8 = 0x80;

    pub const ST3_EXT_DIAG_OVERFLOW: u8 = 0x80;
}

/// The largest data unit of one telegram (SD2 of the largest LE minus DA, SA, FC).
pub const MAX_DATA_UNIT_LEN: usize = SD2_MAX_LE as usize - 3;

/// The ten PROFIBUS DP baud rates, fastest last, with the numbers the standard and the GSD use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Baud {
    B9600,
    B19200,
    B45450,
    B93750,
    B187500,
    B500000,
    B1500000,
    B3000000,
    B6000000,
    B12000000,
}

impl Baud {
    /// All rates, slowest first.
    pub const ALL: [Baud; 10] = [
        Baud::B9600,
        Baud::B19200,
        Baud::B45450,
        Baud::B93750,
        Baud::B187500,
        Baud::B500000,
        Baud::B1500000,
        Baud::B3000000,
        Baud::B6000000,
        Baud::B12000000,
    ];

    /// Bits per second.
    pub const fn bits_per_second(self) -> u32 {
        match self {
            Baud::B9600 => 9_600,
            Baud::B19200 => 19_200,
            Baud::B45450 => 45_450,
            Baud::B93750 => 93_750,
            Baud::B187500 => 187_500,
            Baud::B500000 => 500_000,
            Baud::B1500000 => 1_500_000,
            Baud::B3000000 => 3_000_000,
            Baud::B6000000 => 6_000_000,
            Baud::B12000000 => 12_000_000,
        }
    }

    /// Position in [`Baud::ALL`] (0 = 9.6k .. 9 = 12M).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The SPC3 baud status code: 0 = 12M .. 9 = 9.6k.
    pub const fn spc3_code(self) -> u8 {
        9 - self as u8
    }

    /// Default max TSDR in bit times (the responder's latest answer; DESIGN.md timing facts).
    pub const fn default_max_tsdr_bits(self) -> u16 {
        match self {
            Baud::B9600 | Baud::B19200 | Baud::B45450 | Baud::B93750 | Baud::B187500 => 60,
            Baud::B500000 => 100,
            Baud::B1500000 => 150,
            Baud::B3000000 => 250,
            Baud::B6000000 => 450,
            Baud::B12000000 => 800,
        }
    }

    /// MaxTsdr that VPC3+-based slaves declare (shared/reference/gsd/CP24V1.gsd,
    /// EASY4711.gsd): the level the adapter must beat at every rate.
    pub const fn vpc3_max_tsdr_bits(self) -> u16 {
        match self {
            Baud::B9600 | Baud::B19200 | Baud::B45450 | Baud::B93750 | Baud::B187500 => 15,
            Baud::B500000 => 15,
            Baud::B1500000 => 20,
            Baud::B3000000 => 35,
            Baud::B6000000 => 50,
            Baud::B12000000 => 95,
        }
    }

    /// MaxTsdr the adapter declares in its GSD: its transceiver answers every DP-V0 request
    /// min TSDR (11) after the request plus at most a bit of sampling grid and its decision
    /// (12 bit times measured at every rate by `cargo xtask qemu-test`'s timing lines); 15
    /// leaves room and is never looser than the VPC3+ class.
    pub const fn adapter_max_tsdr_bits(self) -> u16 {
        15
    }

    /// Default slot time in bit times.
    pub const fn default_slot_time_bits(self) -> u16 {
        match self {
            Baud::B9600 | Baud::B19200 | Baud::B45450 | Baud::B93750 | Baud::B187500 => 100,
            Baud::B500000 => 200,
            Baud::B1500000 => 300,
            Baud::B3000000 => 400,
            Baud::B6000000 => 600,
            Baud::B12000000 => 1000,
        }
    }

    /// The keyword suffix GSD files use for this rate (`9.6_supp`, `MaxTsdr_9.6`, ...).
    pub const fn gsd_name(self) -> &'static str {
        match self {
            Baud::B9600 => "9.6",
            Baud::B19200 => "19.2",
            Baud::B45450 => "45.45",
            Baud::B93750 => "93.75",
            Baud::B187500 => "187.5",
            Baud::B500000 => "500",
            Baud::B1500000 => "1.5M",
            Baud::B3000000 => "3M",
            Baud::B6000000 => "6M",
            Baud::B12000000 => "12M",
        }
    }

    /// The rate of exactly `bits_per_second`, if it is one of the ten.
    pub fn from_bits_per_second(bits_per_second: u32) -> Option<Baud> {
        Baud::ALL
            .into_iter()
            .find(|b| b.bits_per_second() == bits_per_second)
    }
}

impl core::fmt::Display for Baud {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let bps = self.bits_per_second();
        if bps >= 1_000_000 {
            write!(f, "{}M", self.gsd_name().trim_end_matches('M'))
        } else {
            write!(f, "{}k", self.gsd_name())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_are_ordered_and_indexed() {
        for (i, b) in Baud::ALL.iter().enumerate() {
            assert_eq!(b.index(), i);
            assert_eq!(Baud::from_bits_per_second(b.bits_per_second()), Some(*b));
        }
        assert!(Baud::ALL
            .windows(2)
            .all(|w| w[0].bits_per_second() < w[1].bits_per_second()));
    }

    #[test]
    fn spc3_codes_count_down_from_12m() {
        assert_eq!(Baud::B12000000.spc3_code(), 0);
        assert_eq!(Baud::B9600.spc3_code(), 9);
    }

    #[test]
    fn max_tsdr_matches_the_spc3_gsd_table() {
        // DESIGN.md: SPC3-class GSD MaxTsdr (9.6k .. 12M): 60 60 60 60 60 100 150 250 450 800.
        let table = [60, 60, 60, 60, 60, 100, 150, 250, 450, 800];
        for (b, want) in Baud::ALL.iter().zip(table) {
            assert_eq!(b.default_max_tsdr_bits(), want, "{b}");
        }
    }

    #[test]
    fn display_names() {
        assert_eq!(Baud::B45450.to_string(), "45.45k");
        assert_eq!(Baud::B1500000.to_string(), "1.5M");
        assert_eq!(Baud::B12000000.to_string(), "12M");
    }
}

/// DP-V1, the class-1 master's acyclic services (MSAC1) on SAP 51 (seed 004, "DP-V1 通讯",
/// tables 15-17), and the DPV1_Status bytes of Set_Prm.
pub mod dpv1 {
    /// The slave's SAP for MSAC1 read and write, and the class-1 master's (MS1).
    pub const SAP: u8 = 51;
    /// Set_Prm bytes 7-9 when the slave runs DP-V1: DPV1_Status_1..3, before the user data.
    pub const STATUS_LEN: usize = 3;
    /// The longest data of one read or write (seed 004 and the GSD's C1_Max_Data_Len).
    pub const MAX_DATA_LEN: usize = 240;
    /// The MSAC1 header: function number, slot, index, length.
    pub const HEADER_LEN: usize = 4;
    /// A negative response's function number is the request's with this bit set (0xDE, 0xDF).
    pub const ERROR_BIT: u8 = 0x80;
    /// Error_Decode of a negative response: DP-V1 (seed 004, table 16: always 128).
    pub const ERROR_DECODE_DPV1: u8 = 0x80;

    crate::code_point! {
        /// Function numbers (seed 004, table 15).
        pub enum Function {
            Idle = 0x48,
            DataTransport = 0x51,
            ResourceManager = 0x56,
            Initiate = 0x57,
            Abort = 0x58,
            Alarm = 0x5C,
            Read = 0x5E,
            Write = 0x5F,
            DataTransportError = 0xD1,
            InitiateError = 0xD7,
            AlarmError = 0xDC,
            ReadError = 0xDE,
            WriteError = 0xDF,
        }
    }

    /// Error_Code_1 of a negative response: error class (high nibble) and code (seed 004,
    /// table 17).
    pub mod error {
        /// Class 10, application: read error, write error, module failure, version
        /// conflict, feature not supported.
        pub const APPLICATION_READ: u8 = 0xA0;
        pub const APPLICATION_WRITE: u8 = 0xA1;
        pub const APPLICATION_NOT_SUPPORTED: u8 = 0xA9;
        /// Class 11, access.
        pub const INVALID_INDEX: u8 = 0xB0;
        pub const WRITE_LENGTH: u8 = 0xB1;
        pub const INVALID_SLOT: u8 = 0xB2;
        pub const TYPE_CONFLICT: u8 = 0xB3;
        pub const INVALID_AREA: u8 = 0xB4;
        pub const STATE_CONFLICT: u8 = 0xB5;
        pub const ACCESS_DENIED: u8 = 0xB6;
        pub const INVALID_RANGE: u8 = 0xB7;
        pub const INVALID_PARAMETER: u8 = 0xB8;
        pub const INVALID_TYPE: u8 = 0xB9;
        /// Class 12, resource.
        pub const READ_CONSTRAIN_CONFLICT: u8 = 0xC0;
        pub const WRITE_CONSTRAIN_CONFLICT: u8 = 0xC1;
        pub const RESOURCE_BUSY: u8 = 0xC2;
        pub const RESOURCE_UNAVAILABLE: u8 = 0xC3;
    }

    /// DPV1_Status_1 (Set_Prm byte 7).
    pub mod status1 {
        pub const DPV1_ENABLE: u8 = 0x80;
        pub const FAIL_SAFE: u8 = 0x40;
        pub const PUBLISHER_ENABLE: u8 = 0x20;
        /// The watchdog counts in 1 ms instead of 10 ms.
        pub const WD_BASE_1MS: u8 = 0x04;
        /// Bits the slave must find 0.
        pub const RESERVED: u8 = 0x1B;
    }

    /// DPV1_Status_2 (Set_Prm byte 8; seed 004: "MSB X X X X X X 0 X LSB").
    pub mod status2 {
        pub const CHK_CFG_MODE: u8 = 0x01;
        pub const RESERVED: u8 = 0x02;
        /// Enable_Update, Status, Manufacturer_Specific, Diagnostic, Process and
        /// Pull_Plug alarms (bits 2-7): seed 004 supports none.
        pub const ALARM_ENABLES: u8 = 0xFC;
    }

    /// DPV1_Status_3 (Set_Prm byte 9; seed 004: "MSB 0 0 0 X X X X X LSB").
    pub mod status3 {
        /// Alarm_Mode, bits 0-2: the master's alarm capacity (taken, no alarms are sent).
        pub const ALARM_MODE: u8 = 0x07;
        /// Prm_Structure (DP-V2): not supported.
        pub const PRM_STRUCTURE: u8 = 0x08;
        /// IsoM_Req (isochronous mode): not supported.
        pub const ISOM_REQ: u8 = 0x10;
        pub const RESERVED: u8 = 0xE0;
    }
}
