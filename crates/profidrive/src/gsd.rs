//! The adapter's GSD file, written from the constants the firmware uses: the Ident_Number and
//! rates of dp-consts, one module per PPO type, the User_Prm_Data layout and defaults of
//! [`crate::prm`]. `cargo xtask gsd` writes it; a test parses it with gsd-parser and checks it
//! against the application.
//!
//! MaxTsdr is the SPC3 table (60 bit times up to 187.5k .. 800 at 12M). The firmware's measured
//! worst turnaround (`cargo xtask qemu-test`) stays under it at every rate: 510 of 800 at 12M,
//! counted at one instruction per cycle.

use crate::ppo::{Ppo, MAX_PZD_WORDS};
use crate::prm::UserPrm;
use core::fmt::{self, Write};
use dp_consts::Baud;

/// The file name a configuration tool expects: vendor prefix and Ident_Number.
pub const FILE_NAME: &str = "DPADD7A1.GSD";
/// The DP-V1 file, as seed 004 ships ABB10812.GSD beside ABB_0812.GSD: the drive's 51.21 DP
/// MODE = 1 selects it (its User_Prm_Data begins with DPV1_Status_1-3).
pub const FILE_NAME_DPV1: &str = "DPA1D7A1.GSD";

/// Which of the two files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// GSD revision 2, DP-V0 (51.21 = 0).
    DpV0,
    /// GSD revision 3 with the DP-V1 keywords (51.21 = 1), as seed 004 says for ABB10812.GSD.
    DpV1,
}

impl Variant {
    pub const fn file_name(self) -> &'static str {
        match self {
            Variant::DpV0 => FILE_NAME,
            Variant::DpV1 => FILE_NAME_DPV1,
        }
    }

    /// Where User_Prm_Data byte `offset` of the DP-V0 layout sits in this file's: DP-V1 puts
    /// the three status bytes where DP-V0 has one reserved byte.
    const fn offset(self, offset: usize) -> usize {
        match self {
            Variant::DpV0 => offset,
            Variant::DpV1 => offset + dp_consts::dpv1::STATUS_LEN - 1,
        }
    }

    /// The default User_Prm_Data of this file.
    pub fn default_user_prm(self) -> ([u8; dp_consts::dpv1::STATUS_LEN + UserPrm::LEN], usize) {
        let mut out = [0u8; dp_consts::dpv1::STATUS_LEN + UserPrm::LEN];
        let prm = UserPrm::DEFAULT.encode();
        match self {
            Variant::DpV0 => {
                out[..UserPrm::LEN].copy_from_slice(&prm);
                (out, UserPrm::LEN)
            }
            Variant::DpV1 => {
                // DPV1_Enable; no alarms, no WD_Base_1ms.
                out[0] = dp_consts::dpv1::status1::DPV1_ENABLE;
                let len = dp_consts::dpv1::STATUS_LEN + UserPrm::LEN - 1;
                out[dp_consts::dpv1::STATUS_LEN..len].copy_from_slice(&prm[1..]);
                (out, len)
            }
        }
    }
}

const VENDOR: &str = "Open DP drive adapter project";
const MODEL: &str = "DP drive adapter";

/// Ext_User_Prm_Data number, name, data type, default, range, offset, text reference.
struct Field {
    name: &'static str,
    data_type: &'static str,
    default: u16,
    range: (u16, u16),
    offset: usize,
    text: Option<u8>,
}

fn fields() -> impl Iterator<Item = Field> {
    let prm = UserPrm::DEFAULT;
    let header = [
        Field {
            name: "Fail-safe mode",
            data_type: "BitArea(0-1)",
            default: prm.fail_safe as u16,
            range: (0, 2),
            offset: 1,
            text: Some(1),
        },
        Field {
            name: "Control-zero mode",
            data_type: "BitArea(2-3)",
            default: prm.control_zero as u16,
            range: (0, 1),
            offset: 1,
            text: Some(2),
        },
        Field {
            name: "Operation mode",
            data_type: "BitArea(4-5)",
            default: prm.operation as u16,
            range: (0, 2),
            offset: 1,
            text: Some(3),
        },
        Field {
            name: "Cut-off time ms (0 = none)",
            data_type: "Unsigned16",
            default: prm.cut_off_ms,
            range: (0, 65535),
            offset: 2,
            text: None,
        },
    ];
    const FAIL_SAFE_NAMES: [&str; MAX_PZD_WORDS] = [
        "Fail-safe PZD1 (CW)",
        "Fail-safe PZD2 (REF)",
        "Fail-safe PZD3",
        "Fail-safe PZD4",
        "Fail-safe PZD5",
        "Fail-safe PZD6",
        "Fail-safe PZD7",
        "Fail-safe PZD8",
        "Fail-safe PZD9",
        "Fail-safe PZD10",
    ];
    const RD_NAMES: [&str; MAX_PZD_WORDS - 1] = [
        "RdPZD2", "RdPZD3", "RdPZD4", "RdPZD5", "RdPZD6", "RdPZD7", "RdPZD8", "RdPZD9", "RdPZD10",
    ];
    const WR_NAMES: [&str; MAX_PZD_WORDS - 1] = [
        "WrPZD2", "WrPZD3", "WrPZD4", "WrPZD5", "WrPZD6", "WrPZD7", "WrPZD8", "WrPZD9", "WrPZD10",
    ];
    let fail_safe = (0..MAX_PZD_WORDS).map(move |i| Field {
        name: FAIL_SAFE_NAMES[i],
        data_type: "Unsigned16",
        default: prm.fail_safe_pzd[i],
        range: (0, 65535),
        offset: 4 + 2 * i,
        text: None,
    });
    let rd = (0..MAX_PZD_WORDS - 1).map(move |i| Field {
        name: RD_NAMES[i],
        data_type: "Unsigned16",
        default: prm.rd_pzd[i].0,
        range: (0xD000, 0xDE25),
        offset: 24 + 2 * i,
        text: None,
    });
    let wr = (0..MAX_PZD_WORDS - 1).map(move |i| Field {
        name: WR_NAMES[i],
        data_type: "Unsigned16",
        default: prm.wr_pzd[i].0,
        range: (0xF000, 0xFF55),
        offset: 42 + 2 * i,
        text: None,
    });
    let rated = Field {
        name: "Rated freq 0.01Hz (0 = F0.10)",
        data_type: "Unsigned16",
        default: prm.rated_frequency,
        range: (0, UserPrm::MAX_RATED_FREQUENCY),
        offset: 60,
        text: None,
    };
    header
        .into_iter()
        .chain(fail_safe)
        .chain(rd)
        .chain(wr)
        .chain(core::iter::once(rated))
}

/// Writes the DP-V0 GSD file.
pub fn write(out: &mut impl Write) -> fmt::Result {
    write_variant(out, Variant::DpV0)
}

/// Writes the GSD file of `variant`.
pub fn write_variant(out: &mut impl Write, variant: Variant) -> fmt::Result {
    let line = |out: &mut dyn Write, key: &str, value: &dyn fmt::Display| {
        writeln!(out, "{key:<22}= {value}")
    };
    writeln!(out, "#Profibus_DP")?;
    writeln!(
        out,
        "; GSD of the open PROFIBUS DP drive adapter, written by `cargo xtask gsd`."
    )?;
    writeln!(
        out,
        "; Do not edit: it is generated from the constants the firmware uses."
    )?;
    line(
        out,
        "GSD_Revision",
        &if variant == Variant::DpV1 { 3 } else { 2 },
    )?;
    line(out, "Vendor_Name", &Quoted(VENDOR))?;
    line(out, "Model_Name", &Quoted(MODEL))?;
    line(out, "Revision", &Quoted("1.0"))?;
    line(out, "Ident_Number", &Hex(dp_consts::ADAPTER_IDENT_NUMBER))?;
    line(out, "Protocol_Ident", &0)?;
    line(out, "Station_Type", &0)?;
    line(out, "FMS_supp", &0)?;
    line(out, "Hardware_Release", &Quoted("1.0"))?;
    line(out, "Software_Release", &Quoted("0.1"))?;
    // `{:<22}` does not pad `format_args!`: pad by hand.
    let keyed = |out: &mut dyn Write, prefix: &str, name: &str, suffix: &str, value: u16| {
        let len = prefix.len() + name.len() + suffix.len();
        writeln!(
            out,
            "{prefix}{name}{suffix}{:pad$}= {value}",
            "",
            pad = 22usize.saturating_sub(len)
        )
    };
    for baud in Baud::ALL {
        keyed(out, "", baud.gsd_name(), "_supp", 1)?;
    }
    for baud in Baud::ALL {
        keyed(
            out,
            "MaxTsdr_",
            baud.gsd_name(),
            "",
            baud.adapter_max_tsdr_bits(),
        )?;
    }
    line(out, "Redundancy", &0)?;
    line(out, "Repeater_Ctrl_Sig", &2)?;
    line(out, "24V_Pins", &0)?;
    line(
        out,
        "Implementation_Type",
        &Quoted("FPGA transceiver + Cortex-M3"),
    )?;
    line(out, "Freeze_Mode_supp", &1)?;
    line(out, "Sync_Mode_supp", &1)?;
    line(out, "Auto_Baud_supp", &1)?;
    line(out, "Set_Slave_Add_supp", &1)?;
    line(out, "Fail_Safe", &1)?;
    line(out, "Min_Slave_Intervall", &1)?;
    line(out, "Modular_Station", &1)?;
    line(out, "Max_Module", &1)?;
    let max_io = Ppo::ALL.iter().map(|p| p.io_bytes()).max().unwrap_or(0);
    line(out, "Max_Input_Len", &max_io)?;
    line(out, "Max_Output_Len", &max_io)?;
    line(out, "Max_Data_Len", &(2 * max_io))?;
    // The first module at slot 1, as ABB_0812.gsd numbers it.
    line(out, "Modul_Offset", &1)?;
    // DP-V1's extended diagnosis is a status block (seed 004 lines 1098-1113), DP-V0's a
    // header and the flags.
    let ext_diag_len = match variant {
        Variant::DpV1 => crate::app::DPV1_STATUS_BLOCK_LEN,
        Variant::DpV0 => crate::app::EXT_DIAG_LEN,
    };
    line(
        out,
        "Max_Diag_Data_Len",
        &(dp_consts::diag::STANDARD_LEN + ext_diag_len as usize),
    )?;
    line(out, "Slave_Family", &1)?;
    let (defaults, user_prm_len) = variant.default_user_prm();
    line(out, "Max_User_Prm_Data_Len", &user_prm_len)?;
    if variant == Variant::DpV1 {
        // MSAC1 read and write of up to 240 bytes (the PROFIdrive parameter channel, index
        // 47); a master waits up to 1 s (100 x 10 ms) for an answer, while the adapter
        // answers its polls within TSDR and reads with B5h while busy. No alarms.
        line(out, "DPV1_Slave", &1)?;
        line(out, "C1_Read_Write_supp", &1)?;
        line(out, "C1_Max_Data_Len", &dp_consts::dpv1::MAX_DATA_LEN)?;
        line(out, "C1_Response_Timeout", &100)?;
        line(out, "C1_Read_Write_required", &0)?;
        line(out, "WD_Base_1ms_supp", &1)?;
        line(out, "Diagnostic_Alarm_supp", &0)?;
        line(out, "Process_Alarm_supp", &0)?;
        line(out, "Pull_Plug_Alarm_supp", &0)?;
        line(out, "Status_Alarm_supp", &0)?;
        line(out, "Update_Alarm_supp", &0)?;
        line(out, "Manufacturer_Specific_Alarm_supp", &0)?;
    }
    writeln!(out)?;
    // The flags' bits counted from the byte after the header: the first (DP-V0), or after the
    // status block's type, slot and specifier (DP-V1).
    let flags_bit = match variant {
        Variant::DpV1 => 24,
        Variant::DpV0 => 0,
    };
    writeln!(
        out,
        "Unit_Diag_Bit({})      = \"Drive link temporarily lost\"",
        flags_bit
    )?;
    writeln!(
        out,
        "Unit_Diag_Bit({})      = \"Drive link permanently lost\"",
        flags_bit + 1
    )?;
    // Seed 004 leaves bits 2-7 unused; this adapter reports the drive's fault in bit 2, so its
    // GSD says so.
    writeln!(
        out,
        "Unit_Diag_Bit({})      = \"Drive fault\"",
        flags_bit + 2
    )?;
    writeln!(out)?;
    let texts: [(u8, &[&str]); 3] = [
        (1, &["Stop", "Last speed", "Use fail-safe values"]),
        (2, &["Use frame", "Ignore frame"]),
        (
            3,
            &[
                "PROFIdrive (seed 004)",
                "Vendor (IOA-B103 words)",
                "ABB Drives (+-20000)",
            ],
        ),
    ];
    for (n, values) in texts {
        writeln!(out, "PrmText = {n}")?;
        for (i, text) in values.iter().enumerate() {
            writeln!(out, "Text({i}) = \"{text}\"")?;
        }
        writeln!(out, "EndPrmText")?;
    }
    writeln!(out)?;
    for (n, f) in fields().enumerate() {
        writeln!(out, "ExtUserPrmData = {} \"{}\"", n + 1, f.name)?;
        if f.range.0 == 0xD000 {
            // RdPZD: only the codes Set_Prm takes (D0.00-D0.99, D1.00-D1.49, DE.00-DE.25), as a
            // value set: the range would let a tool pick D2.xx .. DD.xx, which gives Prm_Fault.
            write!(out, "{} {}", f.data_type, Hex(f.default))?;
            let readable = (f.range.0..=f.range.1).filter(|&c| {
                matches!(
                    crate::codes::FunctionCode(c).kind(),
                    Some(crate::codes::CodeKind::Status | crate::codes::CodeKind::FaultRecord)
                )
            });
            for (i, code) in readable.enumerate() {
                let sep = match i {
                    0 => " ",
                    _ if i % 10 == 0 => ", \\\n    ",
                    _ => ", ",
                };
                write!(out, "{sep}{}", Hex(code))?;
            }
            writeln!(out)?;
        } else if f.range.0 >= 0xD000 {
            // Function codes read best in hex (F0.29 is 0xF029).
            writeln!(
                out,
                "{} {} {}-{}",
                f.data_type,
                Hex(f.default),
                Hex(f.range.0),
                Hex(f.range.1)
            )?;
        } else {
            writeln!(
                out,
                "{} {} {}-{}",
                f.data_type, f.default, f.range.0, f.range.1
            )?;
        }
        if let Some(t) = f.text {
            writeln!(out, "Prm_Text_Ref = {t}")?;
        }
        writeln!(out, "EndExtUserPrmData")?;
    }
    writeln!(out)?;
    write!(out, "Ext_User_Prm_Data_Const(0) = ")?;
    for (i, b) in defaults[..user_prm_len].iter().enumerate() {
        if i > 0 {
            write!(out, ",")?;
            if i % 12 == 0 {
                write!(out, " \\\n    ")?;
            } else {
                write!(out, " ")?;
            }
        }
        write!(out, "{}", Hex8(*b))?;
    }
    writeln!(out)?;
    for (n, f) in fields().enumerate() {
        writeln!(
            out,
            "Ext_User_Prm_Data_Ref({}) = {}",
            variant.offset(f.offset),
            n + 1
        )?;
    }
    writeln!(out)?;
    for ppo in Ppo::ALL {
        write!(out, "Module = \"PPO Type {}\"", ppo.number())?;
        for (i, b) in ppo.cfg().iter().enumerate() {
            write!(out, "{} {}", if i == 0 { "" } else { "," }, Hex8(*b))?;
        }
        writeln!(out)?;
        writeln!(out, "EndModule")?;
    }
    Ok(())
}

struct Quoted(&'static str);
impl fmt::Display for Quoted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "\"{}\"", self.0)
    }
}

struct Hex(u16);
impl fmt::Display for Hex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:04X}", self.0)
    }
}

struct Hex8(u8);
impl fmt::Display for Hex8 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "0x{:02X}", self.0)
    }
}
