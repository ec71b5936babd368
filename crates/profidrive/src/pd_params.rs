//! The PROFIdrive profile's parameter channel and the adapter's PROFIdrive parameters
//! (seed 004: the request and response label tables, the error numbers, table 22).
//!
//! ```text
//! byte   0..1                       2     3         4..7
//!        AK<<12 | SPM<<11 | PNU     IND   reserved  PWE (a word value in bytes 6..7)
//! ```
//! Parameter numbers:
//! - 915 .. 972: the PROFIdrive parameters below, kept by the adapter.
//! - Drive parameters xx.yy are numbered xxyy, sent as PNU = high byte and IND = low byte of
//!   xxyy with request labels 6 and 7 (seed 004's examples: 84.11 = 20DBh, 12.02 = 04B2h). The
//!   drive behind this adapter is seed 000's, whose parameters are function codes, so groups
//!   map one to one: xx 1-16 are F0-FF, 21 is D0, 22 is D1, 30 is DE (1.29 is F0.29). Any
//!   other group is error 0 (illegal parameter number).
//! - Data sets (PNU 0, IND 1-99) belong to ABB drives; this drive has none: error 0.

use crate::codes::FunctionCode;
use crate::drive::{Access, DriveError};
use crate::pkw::Planned;
use crate::pkw::PKW_BYTES;
use crate::ppo::MAX_PZD_WORDS;

dp_consts::code_point! {
    /// Request labels (AK, master to slave).
    pub enum RequestLabel {
        None = 0,
        Read = 1,
        WriteWord = 2,
        WriteDword = 3,
        ReadElement = 4,
        WriteElement = 5,
        ReadArray = 6,
        WriteArrayWord = 7,
        WriteArrayDword = 8,
        ArrayCount = 9,
    }
}

dp_consts::code_point! {
    /// Response labels (AK, slave to master).
    pub enum ResponseLabel {
        None = 0,
        Word = 1,
        Dword = 2,
        Element = 3,
        ArrayWord = 4,
        ArrayDword = 5,
        ArrayCount = 6,
        Error = 7,
        NoPkwRights = 8,
    }
}

dp_consts::code_point! {
    /// Error numbers of response label 7 (seed 004's response label table).
    pub enum ErrorNumber: u16 {
        IllegalPnu = 0,
        ReadOnly = 1,
        OutOfRange = 2,
        BadSubindex = 3,
        NotAnArray = 4,
        WrongDataType = 5,
        ResetOnly = 6,
        ElementReadOnly = 7,
        NoDataType = 9,
        NoChangeRights = 11,
        TextArray = 15,
        OperatingState = 17,
        Other = 18,
        /// Table 21 (DP-V1): 14h value not allowed, 15h response too long, 16h illegal
        /// parameter address, 17h illegal format, 18h number of values inconsistent.
        ValueNotAllowed = 0x14,
        ResponseTooLong = 0x15,
        IllegalAddress = 0x16,
        IllegalFormat = 0x17,
        ValueCountMismatch = 0x18,
        ProductId = 101,
        UnsupportedRequest = 102,
        CommunicationError = 103,
        FlashWriteFailed = 110,
        Timeout = 111,
        NotMappableToPzd = 120,
        NotMappableToPzd2 = 121,
        NotMappableToPzd3 = 123,
        ControlBitTaken = 130,
        NoTorqueMode = 140,
        /// Table 21: 90h, a request ID that is neither read nor change.
        InvalidRequestId = 0x90,
    }
}

/// A PROFIdrive PKW frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    pub label: u8,
    pub pnu: u16,
    pub index: u8,
    pub value: u32,
}

impl Frame {
    pub fn decode(bytes: &[u8; PKW_BYTES]) -> Frame {
        let pke = u16::from_be_bytes([bytes[0], bytes[1]]);
        Frame {
            label: (pke >> 12) as u8,
            pnu: pke & 0x07FF,
            index: bytes[2],
            value: u32::from_be_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]),
        }
    }

    pub fn encode(&self) -> [u8; PKW_BYTES] {
        let pke = (u16::from(self.label & 0x0F) << 12) | (self.pnu & 0x07FF);
        let [a, b] = pke.to_be_bytes();
        let [c, d, e, f] = self.value.to_be_bytes();
        [a, b, self.index, 0, c, d, e, f]
    }

    /// The request's label.
    pub fn request_label(&self) -> RequestLabel {
        RequestLabel::from(self.label)
    }

    /// The response's label.
    pub fn response_label(&self) -> ResponseLabel {
        ResponseLabel::from(self.label)
    }

    fn reply(&self, label: ResponseLabel, value: u32) -> Frame {
        Frame {
            label: label.into(),
            value,
            ..*self
        }
    }

    /// The refusal of this request with error number `error` (response label 7).
    fn refuse(&self, error: ErrorNumber) -> Frame {
        self.reply(ResponseLabel::Error, u32::from(u16::from(error)))
    }
}

/// The drive parameter a PROFIdrive number xxyy names (see the module docs).
pub fn drive_parameter(number: u16) -> Option<FunctionCode> {
    let (group, index) = ((number / 100) as u8, (number % 100) as u8);
    let bcd = (index / 10) << 4 | (index % 10);
    let code = match group {
        // 0xEF + group, not 0xF0 + group - 1: group 16 (FF) overflowed on the way.
        1..=16 => FunctionCode::new(0xEF + group, bcd),
        21 => FunctionCode::new(0xD0, bcd),
        22 => FunctionCode::new(0xD1, bcd),
        30 => FunctionCode::new(0xDE, bcd),
        _ => return None,
    };
    code.kind().map(|_| code)
}

/// The PROFIdrive number xxyy of a drive parameter: [`drive_parameter`]'s inverse (none for a
/// code no number names).
pub fn parameter_number(code: FunctionCode) -> Option<u16> {
    let [hi, bcd] = code.0.to_be_bytes();
    let group: u16 = match hi {
        0xF0..=0xFF => u16::from(hi - 0xEF),
        0xD0 => 21,
        0xD1 => 22,
        0xDE => 30,
        _ => return None,
    };
    let (tens, ones) = (bcd >> 4, bcd & 0x0F);
    if tens > 9 || ones > 9 {
        return None;
    }
    let number = group * 100 + u16::from(tens * 10 + ones);
    (drive_parameter(number) == Some(code)).then_some(number)
}

/// A PZD3-10 mapping value (915/916 and the drive's fieldbus group): 0 unused, 1-99 data
/// sets (none on this drive), 101-9999 drive parameters, 10000 and up refused.
pub fn pzd_target(value: u16) -> Result<Option<FunctionCode>, ErrorNumber> {
    match value {
        0 => Ok(None),
        101..=9999 => drive_parameter(value)
            .map(Some)
            .ok_or(ErrorNumber::NotMappableToPzd),
        _ => Err(ErrorNumber::NotMappableToPzd),
    }
}

/// Length of the fault buffer arrays (945, 947, 948).
pub const FAULT_ARRAY_LEN: usize = 64;
/// The sub-indices of the fault buffer: the current fault and the five before it.
pub const FAULT_SUBINDICES: [u8; 6] = [1, 9, 17, 25, 33, 41];
/// 965: profile number 3, version 2 (seed 004: 0302h).
pub const PROFILE_NUMBER: u16 = 0x0302;

/// The adapter's PROFIdrive parameters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Parameters {
    /// 915: what PZD1..PZD10 out write (index 1-10; PZD1 and PZD2 are CW and REF).
    pub pzd_out: [u16; MAX_PZD_WORDS],
    /// 916: what PZD1..PZD10 in read.
    pub pzd_in: [u16; MAX_PZD_WORDS],
    /// 918: the node address (takes effect after a restart).
    pub node_address: u16,
    /// 919: device system number.
    pub system_number: [u8; 4],
    /// 927: PKW write rights (0 read only, 1 read and write).
    pub pkw_rights: u16,
    /// 928: PZD rights (0 new PZD ignored, 1 valid).
    pub pzd_rights: u16,
    /// 930: operating mode (1 speed control, 8001h torque: refused, error 140).
    pub operating_mode: u16,
    /// 933-937: selectors of control word bits 11-15; 939-943: of status word bits 11-15.
    pub control_bit_selectors: [u16; 5],
    pub status_bit_selectors: [u16; 5],
    /// 945 fault codes, 947 fault numbers, 948 fault times (s since), by sub-index.
    pub fault_codes: [u16; FAULT_ARRAY_LEN],
    pub fault_numbers: [u16; FAULT_ARRAY_LEN],
    pub fault_times: [u16; FAULT_ARRAY_LEN],
    /// 952: faults that happened; writing 0 clears it.
    pub fault_count: u16,
    /// 953-957: the current alarm (AL.xxx, 0 for none) and the four before it.
    pub alarms: [u16; crate::faults::ALARMS],
    /// 961: hardware configuration.
    pub hardware: [u8; 4],
    /// 963: the detected baud rate (0 = 12M .. 9 = 9.6k, 255 invalid).
    pub baud_code: u16,
    /// 964: the device identification ([`crate::identification`]): the Ident_Number at
    /// sub-index 0 (seed 004), PROFIdrive's device type, firmware version, date and drive
    /// objects at 1-5.
    pub identification: [u16; crate::identification::WORDS],
    /// 965: the profile number (seed 004: 0302h, profile 3 version 2).
    pub profile_number: [u8; 2],
    /// 967/968: the control and status words in force.
    pub control_word: u16,
    pub status_word: u16,
    /// 970, 971, 972: the last value written (actions fire on 0 -> 1).
    pub load_record: u16,
    pub save_record: u16,
    pub reset: u16,
    /// Writes to non-volatile memory (a write of the same value does not count).
    pub flash_writes: u32,
    /// Actions the adapter must carry out: factory reset (970), save (971), restart (972).
    pub pending_action: Option<Action>,
    /// A 918 write for the adapter to store, in force from the next restart.
    pub pending_node_address: Option<u16>,
    /// The address switch is at 0, so 918 may be written (seed 004 line 1490); the adapter
    /// sets it.
    pub node_address_writable: bool,
    /// The drive runs (its status word's running bit): 970-972 are refused (error 17).
    pub motor_running: bool,
}

/// What a 0 -> 1 of 970, 971 or 972 asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    FactoryReset,
    SaveToFlash,
    Restart,
}

impl Parameters {
    /// The values at power-up.
    pub const fn new() -> Parameters {
        Parameters {
            pzd_out: [0; MAX_PZD_WORDS],
            pzd_in: [0; MAX_PZD_WORDS],
            node_address: 0,
            system_number: [0; 4],
            pkw_rights: 1,
            pzd_rights: 1,
            operating_mode: 1,
            control_bit_selectors: [0; 5],
            status_bit_selectors: [0; 5],
            fault_codes: [0; FAULT_ARRAY_LEN],
            fault_numbers: [0; FAULT_ARRAY_LEN],
            fault_times: [0; FAULT_ARRAY_LEN],
            fault_count: 0,
            alarms: [0; crate::faults::ALARMS],
            hardware: [0; 4],
            baud_code: 255,
            identification: crate::identification::DEVICE,
            profile_number: PROFILE_NUMBER.to_be_bytes(),
            control_word: 0,
            status_word: 0,
            load_record: 0,
            save_record: 0,
            reset: 0,
            flash_writes: 0,
            pending_action: None,
            pending_node_address: None,
            node_address_writable: false,
            motor_running: false,
        }
    }
}

impl Default for Parameters {
    fn default() -> Self {
        Self::new()
    }
}

/// Where a parameter's value lives: a word, an array of words, or octets (read only).
enum Slot<'a> {
    Word(&'a mut u16),
    Array(&'a mut [u16]),
    Octets(&'a [u8]),
    /// A read-only word (sub-index 0, what a plain read returns) with more words after it at
    /// sub-indexes 1.. (964: seed 004's word, PROFIdrive's array).
    Record(&'a [u16]),
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum SlotKind {
    Word,
    Array,
    Octets,
    Record,
}

impl Slot<'_> {
    fn kind(&self) -> SlotKind {
        match self {
            Slot::Word(_) => SlotKind::Word,
            Slot::Array(_) => SlotKind::Array,
            Slot::Octets(_) => SlotKind::Octets,
            Slot::Record(_) => SlotKind::Record,
        }
    }
}

/// One element of a parameter as DP-V1 reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Element {
    Word(u16),
    /// `len` octets (919, 961, 965).
    Octets {
        bytes: [u8; 4],
        len: u8,
    },
}

/// Whether the master may write a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rights {
    Read,
    ReadWrite,
}

/// A written value's check: `Err` is the error number. `at` is the number's offset in its row
/// (933 is offset 0 of 933-937), `index` the request's sub-index.
type Check = fn(p: &Parameters, at: usize, index: u8, value: u16) -> Result<(), ErrorNumber>;

/// One row of the table: a parameter number (or a run of them), where its value lives, whether
/// the master may write it, and the check a write must pass.
struct Row {
    first: u16,
    last: u16,
    slot: for<'a> fn(&'a mut Parameters, usize) -> Slot<'a>,
    rights: Rights,
    check: Check,
}

fn any_value(_: &Parameters, _: usize, _: u8, _: u16) -> Result<(), ErrorNumber> {
    Ok(())
}

fn up_to(max: u16) -> impl Fn(u16) -> Result<(), ErrorNumber> {
    move |value| {
        if value > max {
            Err(ErrorNumber::OutOfRange)
        } else {
            Ok(())
        }
    }
}

/// 915/916: PZD1 and PZD2 are fixed (CW/SW, REF/ACT); PZD3-10 a mappable drive parameter.
fn pzd_mapping(_: &Parameters, _: usize, index: u8, value: u16) -> Result<(), ErrorNumber> {
    match index {
        1 | 2 => Err(ErrorNumber::NotMappableToPzd),
        _ => pzd_target(value).map(|_| ()),
    }
}

/// 933-937: a user-defined control bit can be given to one control-word bit only.
fn control_bit(p: &Parameters, at: usize, _: u8, value: u16) -> Result<(), ErrorNumber> {
    let taken = p
        .control_bit_selectors
        .iter()
        .enumerate()
        .any(|(i, v)| *v == value && i != at);
    if value != 0 && taken {
        return Err(ErrorNumber::ControlBitTaken);
    }
    up_to(5)(value)
}

/// 918 (seed 004 line 1490): a station address, written only with the address switch at 0;
/// with the switch set it rules, and a write is error 17 (not in this state) rather than a
/// value that never takes effect.
fn node_address(p: &Parameters, _: usize, _: u8, value: u16) -> Result<(), ErrorNumber> {
    if value == 0 {
        return Err(ErrorNumber::OutOfRange);
    }
    up_to(u16::from(dp_consts::MAX_STATION_ADDRESS))(value)?;
    if !p.node_address_writable {
        return Err(ErrorNumber::OperatingState);
    }
    Ok(())
}

/// 970-972 (seed 004 lines 1542-1552): 0 or 1, and the 0 -> 1 change "needs the motor
/// stopped": a 1 while the drive runs is error 17.
fn motor_stopped(p: &Parameters, _: usize, _: u8, value: u16) -> Result<(), ErrorNumber> {
    up_to(1)(value)?;
    if value == 1 && p.motor_running {
        return Err(ErrorNumber::OperatingState);
    }
    Ok(())
}

/// 930: speed control (1); torque (8001h) is not a mode of this drive.
fn operating_mode(_: &Parameters, _: usize, _: u8, value: u16) -> Result<(), ErrorNumber> {
    match value {
        1 => Ok(()),
        0x8001 => Err(ErrorNumber::NoTorqueMode),
        _ => Err(ErrorNumber::OutOfRange),
    }
}

/// The adapter's PROFIdrive parameters (seed 004's table 22), one row each. 929 is answered by
/// the caller (the PPO type in use), drive parameters (below 900) by the drive.
#[rustfmt::skip]
const TABLE: &[Row] = &[
    Row { first: 915, last: 915, slot: |p, _| Slot::Array(&mut p.pzd_out), rights: Rights::ReadWrite, check: pzd_mapping },
    Row { first: 916, last: 916, slot: |p, _| Slot::Array(&mut p.pzd_in), rights: Rights::ReadWrite, check: pzd_mapping },
    Row { first: 918, last: 918, slot: |p, _| Slot::Word(&mut p.node_address), rights: Rights::ReadWrite, check: node_address },
    Row { first: 919, last: 919, slot: |p, _| Slot::Octets(&p.system_number), rights: Rights::Read, check: any_value },
    Row { first: 927, last: 927, slot: |p, _| Slot::Word(&mut p.pkw_rights), rights: Rights::ReadWrite, check: |_, _, _, v| up_to(1)(v) },
    Row { first: 928, last: 928, slot: |p, _| Slot::Word(&mut p.pzd_rights), rights: Rights::ReadWrite, check: |_, _, _, v| up_to(1)(v) },
    Row { first: 930, last: 930, slot: |p, _| Slot::Word(&mut p.operating_mode), rights: Rights::ReadWrite, check: operating_mode },
    Row { first: 933, last: 937, slot: |p, at| Slot::Word(&mut p.control_bit_selectors[at]), rights: Rights::ReadWrite, check: control_bit },
    Row { first: 939, last: 943, slot: |p, at| Slot::Word(&mut p.status_bit_selectors[at]), rights: Rights::ReadWrite, check: |_, _, _, v| up_to(3)(v) },
    Row { first: 945, last: 945, slot: |p, _| Slot::Array(&mut p.fault_codes), rights: Rights::Read, check: any_value },
    Row { first: 947, last: 947, slot: |p, _| Slot::Array(&mut p.fault_numbers), rights: Rights::Read, check: any_value },
    Row { first: 948, last: 948, slot: |p, _| Slot::Array(&mut p.fault_times), rights: Rights::Read, check: any_value },
    // 952: the fault count; only 0 may be written (it clears the count): anything else is
    // error 6, "set not allowed (reset only)" (seed 004's error list, line 875).
    Row { first: 952, last: 952, slot: |p, _| Slot::Word(&mut p.fault_count), rights: Rights::ReadWrite, check: |_, _, _, v| if v == 0 { Ok(()) } else { Err(ErrorNumber::ResetOnly) } },
    // 953-957: the current alarm and the four before it; 958-960 are "不支持" (table 22).
    Row { first: 953, last: 957, slot: |p, at| Slot::Word(&mut p.alarms[at]), rights: Rights::Read, check: any_value },
    Row { first: 961, last: 961, slot: |p, _| Slot::Octets(&p.hardware), rights: Rights::Read, check: any_value },
    Row { first: 963, last: 963, slot: |p, _| Slot::Word(&mut p.baud_code), rights: Rights::Read, check: any_value },
    Row { first: 964, last: 964, slot: |p, _| Slot::Record(&p.identification), rights: Rights::Read, check: any_value },
    Row { first: 965, last: 965, slot: |p, _| Slot::Octets(&p.profile_number), rights: Rights::Read, check: any_value },
    Row { first: 967, last: 967, slot: |p, _| Slot::Word(&mut p.control_word), rights: Rights::Read, check: any_value },
    Row { first: 968, last: 968, slot: |p, _| Slot::Word(&mut p.status_word), rights: Rights::Read, check: any_value },
    // 970-972: load defaults, save, restart; each acts on a 0 -> 1 change.
    Row { first: 970, last: 970, slot: |p, _| Slot::Word(&mut p.load_record), rights: Rights::ReadWrite, check: motor_stopped },
    Row { first: 971, last: 971, slot: |p, _| Slot::Word(&mut p.save_record), rights: Rights::ReadWrite, check: motor_stopped },
    Row { first: 972, last: 972, slot: |p, _| Slot::Word(&mut p.reset), rights: Rights::ReadWrite, check: motor_stopped },
];

fn row(pnu: u16) -> Option<(&'static Row, usize)> {
    TABLE
        .iter()
        .find(|r| (r.first..=r.last).contains(&pnu))
        .map(|r| (r, usize::from(pnu - r.first)))
}

impl Parameters {
    /// What one request needs: the adapter's own parameters are executed here and answered
    /// at once; a drive parameter is a drive access, answered by [`Parameters::drive_reply`]
    /// once the drive answered (and planned again, without effect, until then).
    /// `ppo_number` answers 929.
    pub fn plan(&mut self, request: &Frame, ppo_number: u8) -> Planned<Frame> {
        match self.execute_local(request, ppo_number) {
            Ok(reply) => Planned::Reply(reply),
            Err(access) => Planned::Drive(access),
        }
    }

    /// The request executed on the adapter's parameters, or the drive access it needs.
    fn execute_local(&mut self, request: &Frame, ppo_number: u8) -> Result<Frame, Access> {
        use RequestLabel as Rq;
        let err = |e: ErrorNumber| request.refuse(e);
        let label = request.request_label();
        if label == Rq::None {
            return Ok(Frame {
                label: ResponseLabel::None.into(),
                pnu: 0,
                index: 0,
                value: 0,
            });
        }
        let writes = matches!(
            label,
            Rq::WriteWord
                | Rq::WriteDword
                | Rq::WriteElement
                | Rq::WriteArrayWord
                | Rq::WriteArrayDword
        );
        if writes && self.pkw_rights == 0 && request.pnu != 927 {
            return Ok(request.reply(ResponseLabel::NoPkwRights, 0));
        }
        if request.pnu < 900 {
            return drive_access(request);
        }
        if request.pnu == 929 {
            return Ok(match label {
                Rq::Read => request.reply(ResponseLabel::Word, u32::from(ppo_number)),
                Rq::WriteWord | Rq::WriteDword => err(ErrorNumber::ReadOnly),
                _ => err(ErrorNumber::NotAnArray),
            });
        }
        Ok(self.own_parameter(request))
    }

    /// A request for one of the adapter's own parameters (900 and up).
    fn own_parameter(&mut self, request: &Frame) -> Frame {
        use RequestLabel as Rq;
        let err = |e: ErrorNumber| request.refuse(e);
        let label = request.request_label();
        let Some((row, at)) = row(request.pnu) else {
            return err(ErrorNumber::IllegalPnu);
        };
        let index = u16::from(request.index);
        let new = request.value as u16;
        let kind = (row.slot)(self, at).kind();
        // Seed 004's request table: 2 and 3 change a value (word, double word; answered 1 and
        // 2), 7 and 8 an array element (answered 4 and 5). The parameters are words: a double
        // word beyond 16 bits is out of range.
        let write = match (label, kind) {
            (Rq::WriteWord, SlotKind::Word) => Some((0, ResponseLabel::Word)),
            (Rq::WriteDword, SlotKind::Word) => Some((0, ResponseLabel::Dword)),
            (Rq::WriteArrayWord, SlotKind::Array) => Some((index, ResponseLabel::ArrayWord)),
            (Rq::WriteArrayDword, SlotKind::Array) => Some((index, ResponseLabel::ArrayDword)),
            _ => None,
        };
        if let Some((subindex, answer)) = write {
            if request.value > u32::from(u16::MAX) {
                return err(ErrorNumber::OutOfRange);
            }
            return match self.write_word(request.pnu, subindex, new) {
                Ok(()) => request.reply(answer, u32::from(new)),
                Err(e) => err(e),
            };
        }
        match (label, (row.slot)(self, at)) {
            (Rq::Read, Slot::Word(value)) => request.reply(ResponseLabel::Word, u32::from(*value)),
            (Rq::Read, Slot::Octets(octets)) => {
                let mut v = [0u8; 4];
                v[4 - octets.len()..].copy_from_slice(octets);
                request.reply(
                    if octets.len() > 2 {
                        ResponseLabel::Dword
                    } else {
                        ResponseLabel::Word
                    },
                    u32::from_be_bytes(v),
                )
            }
            (Rq::ReadArray, Slot::Array(values)) => {
                match values.get(usize::from(request.index).wrapping_sub(1)) {
                    Some(v) => request.reply(ResponseLabel::ArrayWord, u32::from(*v)),
                    None => err(ErrorNumber::BadSubindex),
                }
            }
            (Rq::ArrayCount, Slot::Array(values)) => {
                request.reply(ResponseLabel::ArrayCount, values.len() as u32)
            }
            (Rq::Read, Slot::Record(words)) => {
                request.reply(ResponseLabel::Word, u32::from(words[0]))
            }
            (Rq::ReadArray, Slot::Record(words)) => match words.get(usize::from(request.index)) {
                Some(v) => request.reply(ResponseLabel::ArrayWord, u32::from(*v)),
                None => err(ErrorNumber::BadSubindex),
            },
            (Rq::ArrayCount, Slot::Record(words)) => {
                request.reply(ResponseLabel::ArrayCount, words.len() as u32)
            }
            (
                Rq::WriteWord | Rq::WriteDword | Rq::WriteArrayWord | Rq::WriteArrayDword,
                Slot::Record(_),
            ) => err(ErrorNumber::ReadOnly),
            (Rq::ReadElement | Rq::WriteElement, _) => err(ErrorNumber::UnsupportedRequest),
            (Rq::ReadArray | Rq::WriteArrayWord | Rq::WriteArrayDword | Rq::ArrayCount, _) => {
                err(ErrorNumber::NotAnArray)
            }
            (Rq::Read | Rq::WriteWord | Rq::WriteDword, Slot::Array(_)) => {
                err(ErrorNumber::WrongDataType)
            }
            (Rq::WriteWord | Rq::WriteDword, Slot::Octets(_)) => err(ErrorNumber::ReadOnly),
            _ => err(ErrorNumber::UnsupportedRequest),
        }
    }

    /// Writes one word of an adapter parameter (`subindex` 1.. of an array, ignored for a
    /// word): the one implementation both parameter channels use. Rights, range and the
    /// cross-checks of the row; the value is stored (and counts as a non-volatile write)
    /// only when it changes; 970-972 note their action on a 0 -> 1 change.
    pub fn write_word(&mut self, pnu: u16, subindex: u16, new: u16) -> Result<(), ErrorNumber> {
        let (row, at) = row(pnu).ok_or(ErrorNumber::IllegalPnu)?;
        // The check looks at other parameters, so it runs before the slot is borrowed.
        let check = (row.check)(self, at, subindex as u8, new);
        let writable = row.rights == Rights::ReadWrite;
        let target = match (row.slot)(self, at) {
            Slot::Word(value) => value,
            Slot::Array(values) => values
                .get_mut(usize::from(subindex).wrapping_sub(1))
                .ok_or(ErrorNumber::BadSubindex)?,
            Slot::Octets(_) | Slot::Record(_) => return Err(ErrorNumber::ReadOnly),
        };
        if !writable {
            return Err(ErrorNumber::ReadOnly);
        }
        check?;
        let old = *target;
        if old != new {
            *target = new;
            self.flash_writes += 1;
        }
        if pnu == 918 && old != new {
            self.pending_node_address = Some(new);
        }
        if old == 0 && new == 1 {
            self.pending_action = match pnu {
                970 => Some(Action::FactoryReset),
                971 => Some(Action::SaveToFlash),
                972 => Some(Action::Restart),
                _ => self.pending_action,
            };
        }
        Ok(())
    }

    /// 970 (seed 004 line 1542, "restore factory settings"): the adapter's own settings back to
    /// their defaults: the PZD mapping (915/916), the rights (927/928), the operating mode
    /// (930) and the bit selectors (933-943). The address, the fault buffer and what the drive
    /// holds stay: seed 000's drive has no command to restore its own defaults.
    pub fn restore_defaults(&mut self) {
        let d = Parameters::default();
        self.pzd_out = d.pzd_out;
        self.pzd_in = d.pzd_in;
        self.pkw_rights = d.pkw_rights;
        self.pzd_rights = d.pzd_rights;
        self.operating_mode = d.operating_mode;
        self.control_bit_selectors = d.control_bit_selectors;
        self.status_bit_selectors = d.status_bit_selectors;
    }

    /// After the module's restart (972): the actions' parameters read 0 again, as after a
    /// power-up, so that the next 0 -> 1 acts.
    pub fn restarted(&mut self) {
        self.load_record = 0;
        self.save_record = 0;
        self.reset = 0;
    }

    /// Reads one element of an adapter parameter for DP-V1: a word (subindex 0), an array's
    /// element (subindex 1..), or a parameter's octets (subindex 0). `ppo_number` answers 929.
    pub fn read_element(
        &mut self,
        pnu: u16,
        subindex: u16,
        ppo_number: u8,
    ) -> Result<Element, ErrorNumber> {
        if pnu == 929 {
            return match subindex {
                0 => Ok(Element::Word(u16::from(ppo_number))),
                _ => Err(ErrorNumber::BadSubindex),
            };
        }
        let (row, at) = row(pnu).ok_or(ErrorNumber::IllegalPnu)?;
        match ((row.slot)(self, at), subindex) {
            (Slot::Word(value), 0) => Ok(Element::Word(*value)),
            (Slot::Octets(octets), 0) => {
                let mut bytes = [0u8; 4];
                bytes[..octets.len()].copy_from_slice(octets);
                Ok(Element::Octets {
                    bytes,
                    len: octets.len() as u8,
                })
            }
            (Slot::Array(values), i) => values
                .get(usize::from(i).wrapping_sub(1))
                .map(|v| Element::Word(*v))
                .ok_or(ErrorNumber::BadSubindex),
            (Slot::Record(words), i) => words
                .get(usize::from(i))
                .map(|v| Element::Word(*v))
                .ok_or(ErrorNumber::BadSubindex),
            _ => Err(ErrorNumber::BadSubindex),
        }
    }

    /// An adapter parameter's shape, for DP-V1's description: array elements (0 for a word)
    /// and whether the master may write it.
    pub fn shape(&mut self, pnu: u16) -> Result<(usize, bool), ErrorNumber> {
        if pnu == 929 {
            return Ok((0, false));
        }
        let (row, at) = row(pnu).ok_or(ErrorNumber::IllegalPnu)?;
        let writable = row.rights == Rights::ReadWrite;
        Ok(match (row.slot)(self, at) {
            Slot::Array(values) => (values.len(), writable),
            Slot::Record(words) => (words.len(), false),
            _ => (0, writable),
        })
    }

    /// The answer to a drive parameter request (planned by [`Parameters::plan`]) once the
    /// drive answered.
    /// The response label follows seed 004's request table: a value (1, 2) is answered 1, a
    /// double word (3) 2, an array element (6, 7) 4, a double-word element (8) 5.
    pub fn drive_reply(request: &Frame, result: Result<u16, DriveError>) -> Frame {
        use RequestLabel as Rq;
        let label = match request.request_label() {
            Rq::Read | Rq::WriteWord => ResponseLabel::Word,
            Rq::WriteDword => ResponseLabel::Dword,
            Rq::WriteArrayDword => ResponseLabel::ArrayDword,
            _ => ResponseLabel::ArrayWord,
        };
        match result {
            Ok(v) => request.reply(label, u32::from(v)),
            Err(e) => request.refuse(link_error(e)),
        }
    }
}

/// The PROFIdrive error number for what the drive or its link reported.
pub(crate) fn link_error(e: DriveError) -> ErrorNumber {
    match e {
        DriveError::NoAnswer => ErrorNumber::Timeout,
        DriveError::BusNoise | DriveError::CrcError => ErrorNumber::CommunicationError,
        DriveError::MemoryFault => ErrorNumber::FlashWriteFailed,
        DriveError::InvalidData => ErrorNumber::OutOfRange,
        DriveError::IllegalAddress => ErrorNumber::IllegalPnu,
        DriveError::AccessRestricted => ErrorNumber::ReadOnly,
        DriveError::IllegalOperation | DriveError::DriveFault => ErrorNumber::OperatingState,
    }
}

/// Drive parameters: PNU and IND are the high and low byte of xxyy; data sets have none. The
/// access a request needs, or its refusal.
fn drive_access(request: &Frame) -> Result<Frame, Access> {
    use RequestLabel as Rq;
    let err = |e: ErrorNumber| Ok(request.refuse(e));
    let number = (request.pnu << 8) | u16::from(request.index);
    let write = match request.request_label() {
        Rq::ReadArray | Rq::Read => None,
        Rq::WriteArrayWord | Rq::WriteWord | Rq::WriteDword | Rq::WriteArrayDword => {
            Some(request.value)
        }
        _ if drive_parameter(number).is_none() => return err(ErrorNumber::IllegalPnu),
        _ => return err(ErrorNumber::UnsupportedRequest),
    };
    drive_access_for(number, write).map_or_else(err, Err)
}

/// What a parameter channel's request for drive parameter `number` (xxyy) asks of the drive:
/// a read, or a write of `write`; both channels (PKW and DP-V1) come through here.
pub(crate) fn drive_access_for(number: u16, write: Option<u32>) -> Result<Access, ErrorNumber> {
    let code = drive_parameter(number).ok_or(ErrorNumber::IllegalPnu)?;
    match write {
        None => Ok(Access::Read(code)),
        Some(_) if !code.is_writable() => Err(ErrorNumber::ReadOnly),
        // The drive's parameters are words: a double word beyond 16 bits is out of range.
        Some(value) => u16::try_from(value)
            .map(|v| Access::Write(code, v))
            .map_err(|_| ErrorNumber::OutOfRange),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`parameter_number`] names exactly the codes [`drive_parameter`] maps to, back.
    #[test]
    fn parameter_numbers_round_trip() {
        let mut named = 0;
        for number in 0..=9999u16 {
            if let Some(code) = drive_parameter(number) {
                assert_eq!(parameter_number(code), Some(number), "{number}");
                named += 1;
            }
        }
        assert!(named > 100, "{named}");
        for raw in 0..=u16::MAX {
            let code = FunctionCode(raw);
            if let Some(number) = parameter_number(code) {
                assert_eq!(drive_parameter(number), Some(code), "{raw:#06X}");
            }
        }
    }
    use crate::testing::MockDrive;

    /// One request, to a drive that answers at once.
    fn run(
        p: &mut Parameters,
        drive: &mut MockDrive,
        label: RequestLabel,
        pnu: u16,
        index: u8,
        value: u32,
    ) -> Frame {
        let request = Frame {
            label: label.into(),
            pnu,
            index,
            value,
        };
        match p.plan(&request, 1) {
            Planned::Reply(reply) => reply,
            Planned::Drive(access) => {
                let result = crate::drive::ParamRequest::new(access)
                    .poll(drive)
                    .expect("an immediate drive answers at once");
                Parameters::drive_reply(&request, result)
            }
        }
    }

    /// Groups 1-16 are F0-FF: the last one too (16.01 is FF.01).
    #[test]
    fn drive_groups_1_to_16_are_f0_to_ff() {
        assert_eq!(drive_parameter(101), Some(FunctionCode(0xF001)));
        assert_eq!(drive_parameter(1207), Some(FunctionCode(0xFB07)));
        assert_eq!(drive_parameter(1601), Some(FunctionCode(0xFF01)));
        assert_eq!(drive_parameter(1701), None);
    }

    /// Seed 004 line 875: error 6, "set not allowed (reset only)", for a non-zero write to 952.
    #[test]
    fn seed_004_line_875_952_takes_only_a_reset() {
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        p.fault_count = 3;
        let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 952, 0, 5);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Error, 6));
        let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 952, 0, 0);
        assert_eq!(
            (r.response_label(), p.fault_count),
            (ResponseLabel::Word, 0)
        );
    }

    /// Seed 004 lines 858-863, the request table: labels 3 and 8 (double-word writes) are
    /// served, answered 2 and 5; a value beyond 16 bits is out of range.
    #[test]
    fn seed_004_lines_858_863_double_word_writes() {
        // 918 takes writes with the address switch at 0 (line 1490).
        let mut p = Parameters {
            node_address_writable: true,
            ..Parameters::default()
        };
        let mut drive = MockDrive::default();
        let r = run(&mut p, &mut drive, RequestLabel::WriteDword, 918, 0, 9);
        assert_eq!(
            (r.response_label(), r.value, p.node_address),
            (ResponseLabel::Dword, 9, 9)
        );
        let r = run(
            &mut p,
            &mut drive,
            RequestLabel::WriteDword,
            918,
            0,
            0x1_0000,
        );
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Error, 2));
        let r = run(
            &mut p,
            &mut drive,
            RequestLabel::WriteArrayDword,
            915,
            3,
            0x4B6,
        );
        assert_eq!(
            (r.response_label(), p.pzd_out[2]),
            (ResponseLabel::ArrayDword, 0x4B6)
        );
        // A drive parameter (1.13 = F0.13) the same way.
        let r = run(&mut p, &mut drive, RequestLabel::WriteDword, 0, 0x71, 25);
        assert_eq!(
            (r.response_label(), drive.get(0xF013)),
            (ResponseLabel::Dword, 25)
        );
    }

    /// Seed 004 lines 855-864: a drive parameter's value read with label 1 or written with
    /// label 2 is answered 1; as an array element (6, 7), 4.
    #[test]
    fn seed_004_lines_855_864_drive_parameter_response_labels() {
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        drive.set(0xF013, 30);
        let label = |p: &mut Parameters, d: &mut MockDrive, rq, v| {
            run(p, d, rq, 0, 0x71, v).response_label()
        };
        assert_eq!(
            label(&mut p, &mut drive, RequestLabel::Read, 0),
            ResponseLabel::Word
        );
        assert_eq!(
            label(&mut p, &mut drive, RequestLabel::WriteWord, 31),
            ResponseLabel::Word
        );
        assert_eq!(
            label(&mut p, &mut drive, RequestLabel::ReadArray, 0),
            ResponseLabel::ArrayWord
        );
        assert_eq!(
            label(&mut p, &mut drive, RequestLabel::WriteArrayWord, 32),
            ResponseLabel::ArrayWord
        );
    }

    #[test]
    fn the_parameter_table_has_one_row_per_number_and_each_answers() {
        for w in TABLE.windows(2) {
            assert!(
                w[0].first <= w[0].last && w[0].last < w[1].first,
                "{}",
                w[1].first
            );
        }
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        for row in TABLE {
            for pnu in row.first..=row.last {
                let word = run(&mut p, &mut drive, RequestLabel::Read, pnu, 0, 0);
                let array = run(&mut p, &mut drive, RequestLabel::ReadArray, pnu, 1, 0);
                let answered =
                    |f: &Frame| f.response_label() != ResponseLabel::Error || f.value != 0;
                assert!(answered(&word) || answered(&array), "{pnu}");
            }
        }
    }

    #[test]
    fn seed_004_example_1_and_2_drive_parameter_numbers() {
        // 84.11 x 100 = 8411 = 20DBh: PNU 20h, IND DBh. 12.02 x 100 = 1202 = 04B2h.
        assert_eq!(8411u16.to_be_bytes(), [0x20, 0xDB]);
        assert_eq!(1202u16.to_be_bytes(), [0x04, 0xB2]);
        // Here 12.02 is the seed-000 drive's FB.02, 1.29 its F0.29.
        assert_eq!(drive_parameter(1202), Some(FunctionCode(0xFB02)));
        assert_eq!(drive_parameter(129), Some(FunctionCode(0xF029)));
        assert_eq!(drive_parameter(2100), Some(FunctionCode(0xD000)));
        assert_eq!(drive_parameter(3025), Some(FunctionCode(0xDE25)));
        assert_eq!(drive_parameter(8411), None);
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        drive.set(0xF029, 0x1234);
        // 1.29 is 129 = 0081h: PNU 0, IND 81h (IND 1-99 of PNU 0 would be a data set).
        let r = run(&mut p, &mut drive, RequestLabel::ReadArray, 0x00, 0x81, 0);
        assert_eq!(
            (r.response_label(), r.value),
            (ResponseLabel::ArrayWord, 0x1234)
        );
        let r = run(
            &mut p,
            &mut drive,
            RequestLabel::WriteArrayWord,
            0x04,
            0xB2,
            300,
        );
        assert_eq!(
            (r.response_label(), r.value),
            (ResponseLabel::ArrayWord, 300)
        );
        assert_eq!(drive.get(0xFB02), 300);
        // Writing the same value again does not wear the drive's memory.
        run(
            &mut p,
            &mut drive,
            RequestLabel::WriteArrayWord,
            0x04,
            0xB2,
            300,
        );
        assert_eq!(drive.persistent_writes, 1);
        // 84.11 is no parameter of this drive; data sets neither.
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::ReadArray, 0x20, 0xDB, 0).response_label(),
            ResponseLabel::Error
        );
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::ReadArray, 0, 1, 0).value,
            u32::from(u16::from(ErrorNumber::IllegalPnu))
        );
    }

    #[test]
    fn seed_004_example_3_4_read_918_and_write_971() {
        let mut p = Parameters {
            node_address: 2,
            ..Parameters::default()
        };
        let mut drive = MockDrive::default();
        let r = run(&mut p, &mut drive, RequestLabel::Read, 918, 0, 0);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Word, 2));
        let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 971, 0, 1);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Word, 1));
        assert_eq!(p.pending_action, Some(Action::SaveToFlash));
    }

    /// Seed 004 line 1490: 918 changes the node address only with the switch at 0, and from
    /// the next restart; with the switch set the write is refused (error 17), not kept.
    #[test]
    fn seed_004_line_1490_918_is_written_only_with_the_switch_at_0() {
        let mut p = Parameters {
            node_address: 8,
            ..Parameters::default()
        };
        let mut drive = MockDrive::default();
        let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 918, 0, 40);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Error, 17));
        assert_eq!((p.node_address, p.pending_node_address), (8, None));
        p.node_address_writable = true;
        let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 918, 0, 40);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Word, 40));
        assert_eq!((p.node_address, p.pending_node_address), (40, Some(40)));
        // Address 0 is no station address; 127 and above are out of range.
        for bad in [0, 127] {
            let r = run(&mut p, &mut drive, RequestLabel::WriteWord, 918, 0, bad);
            assert_eq!(
                (r.response_label(), r.value),
                (ResponseLabel::Error, 2),
                "{bad}"
            );
        }
    }

    /// Seed 004 line 1538: a read of 964 is the Ident_Number; PROFIdrive's identification
    /// follows at sub-indexes 1-5 (the firmware's version at 2), read-only.
    #[test]
    fn seed_004_line_1538_964_reads_the_ident_number_and_the_identification_follows() {
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        let r = run(&mut p, &mut drive, RequestLabel::Read, 964, 0, 0);
        assert_eq!(
            (r.response_label(), r.value),
            (
                ResponseLabel::Word,
                u32::from(dp_consts::ADAPTER_IDENT_NUMBER)
            )
        );
        let r = run(&mut p, &mut drive, RequestLabel::ArrayCount, 964, 0, 0);
        assert_eq!(
            (r.response_label(), r.value),
            (ResponseLabel::ArrayCount, 6)
        );
        let version = crate::identification::VERSION_XXYY;
        let r = run(&mut p, &mut drive, RequestLabel::ReadArray, 964, 2, 0);
        assert_eq!(
            (r.response_label(), r.value),
            (ResponseLabel::ArrayWord, u32::from(version))
        );
        let r = run(&mut p, &mut drive, RequestLabel::ReadArray, 964, 6, 0);
        assert_eq!((r.response_label(), r.value), (ResponseLabel::Error, 3));
        assert_eq!(p.read_element(964, 2, 1), Ok(Element::Word(version)));
        assert_eq!(
            p.read_element(964, 0, 1),
            Ok(Element::Word(dp_consts::ADAPTER_IDENT_NUMBER))
        );
        for label in [RequestLabel::WriteWord, RequestLabel::WriteArrayWord] {
            let r = run(&mut p, &mut drive, label, 964, 0, 1);
            assert_eq!((r.response_label(), r.value), (ResponseLabel::Error, 1));
        }
        assert_eq!(p.identification, crate::identification::DEVICE);
    }

    /// Seed 004 lines 1542-1552: 970, 971 and 972 act on a 0 -> 1 change and need the motor
    /// stopped: a 1 while the drive runs is error 17 (table 21's "not in this state"), a 0 is
    /// always taken.
    #[test]
    fn seed_004_lines_1542_1552_970_to_972_need_the_motor_stopped() {
        let mut drive = MockDrive::default();
        for (pnu, action) in [
            (970, Action::FactoryReset),
            (971, Action::SaveToFlash),
            (972, Action::Restart),
        ] {
            let mut p = Parameters {
                motor_running: true,
                ..Parameters::default()
            };
            let r = run(&mut p, &mut drive, RequestLabel::WriteWord, pnu, 0, 1);
            assert_eq!(
                (r.response_label(), r.value),
                (ResponseLabel::Error, 17),
                "{pnu}"
            );
            assert_eq!(p.pending_action, None);
            let r = run(&mut p, &mut drive, RequestLabel::WriteWord, pnu, 0, 0);
            assert_eq!(r.response_label(), ResponseLabel::Word, "{pnu}");
            p.motor_running = false;
            let r = run(&mut p, &mut drive, RequestLabel::WriteWord, pnu, 0, 1);
            assert_eq!(r.response_label(), ResponseLabel::Word, "{pnu}");
            assert_eq!(p.pending_action, Some(action), "{pnu}");
            // Only a 0 -> 1 change acts: 1 again does nothing.
            p.pending_action = None;
            run(&mut p, &mut drive, RequestLabel::WriteWord, pnu, 0, 1);
            assert_eq!(p.pending_action, None, "{pnu}");
        }
    }

    /// Seed 004 line 1542: "restore factory settings" puts the adapter's own settings back;
    /// the address and the fault buffer stay.
    #[test]
    fn seed_004_line_1542_970_restores_the_adapters_settings() {
        let mut p = Parameters {
            node_address: 30,
            pkw_rights: 0,
            fault_count: 2,
            ..Parameters::default()
        };
        p.pzd_out[2] = 1202;
        p.control_bit_selectors[1] = 2;
        p.restore_defaults();
        let d = Parameters::default();
        assert_eq!(
            (p.pzd_out, p.pkw_rights, p.control_bit_selectors),
            (d.pzd_out, d.pkw_rights, d.control_bit_selectors)
        );
        assert_eq!((p.node_address, p.fault_count), (30, 2));
    }

    #[test]
    fn seed_004_example_5_fault_buffer_945() {
        let mut p = Parameters::default();
        p.fault_codes[0] = 0x2300;
        let mut drive = MockDrive::default();
        let r = run(&mut p, &mut drive, RequestLabel::ReadArray, 945, 1, 0);
        assert_eq!(
            (r.response_label(), r.value),
            (ResponseLabel::ArrayWord, 0x2300)
        );
        for sub in FAULT_SUBINDICES {
            assert_eq!(
                run(&mut p, &mut drive, RequestLabel::ReadArray, 945, sub, 0).response_label(),
                ResponseLabel::ArrayWord
            );
        }
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::ArrayCount, 947, 0, 0).value,
            64
        );
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::ReadArray, 945, 65, 0).value,
            u32::from(u16::from(ErrorNumber::BadSubindex))
        );
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::WriteArrayWord, 945, 1, 0).value,
            u32::from(u16::from(ErrorNumber::ReadOnly))
        );
    }

    #[test]
    fn seed_004_examples_6_7_pzd_mapping_915_916() {
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        // PZD3 out writes 12.02, PZD3 in reads 1.04.
        assert_eq!(
            run(
                &mut p,
                &mut drive,
                RequestLabel::WriteArrayWord,
                915,
                3,
                1202
            )
            .response_label(),
            ResponseLabel::ArrayWord
        );
        assert_eq!(
            run(
                &mut p,
                &mut drive,
                RequestLabel::WriteArrayWord,
                916,
                3,
                104
            )
            .response_label(),
            ResponseLabel::ArrayWord
        );
        assert_eq!((p.pzd_out[2], p.pzd_in[2]), (1202, 104));
        // 10000 and up, data sets of another drive, PZD1/PZD2: refused with 120.
        for (index, value) in [(4, 10000), (4, 50), (1, 1202), (2, 1202)] {
            let r = run(
                &mut p,
                &mut drive,
                RequestLabel::WriteArrayWord,
                915,
                index,
                value,
            );
            assert_eq!(
                (r.response_label(), r.value),
                (
                    ResponseLabel::Error,
                    u32::from(u16::from(ErrorNumber::NotMappableToPzd))
                )
            );
        }
        assert_eq!(pzd_target(0), Ok(None));
    }

    #[test]
    fn response_labels_and_error_numbers() {
        let mut p = Parameters::default();
        let mut drive = MockDrive::default();
        let e = |f: Frame| (f.response_label(), ErrorNumber::from(f.value as u16));
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::Read, 999, 0, 0)),
            (ResponseLabel::Error, ErrorNumber::IllegalPnu)
        );
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::WriteWord, 968, 0, 1)),
            (ResponseLabel::Error, ErrorNumber::ReadOnly)
        );
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::WriteWord, 927, 0, 2)),
            (ResponseLabel::Error, ErrorNumber::OutOfRange)
        );
        assert_eq!(
            e(run(
                &mut p,
                &mut drive,
                RequestLabel::ReadElement,
                918,
                0,
                0
            )),
            (ResponseLabel::Error, ErrorNumber::UnsupportedRequest)
        );
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::ReadArray, 918, 1, 0)),
            (ResponseLabel::Error, ErrorNumber::NotAnArray)
        );
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::Read, 915, 0, 0)),
            (ResponseLabel::Error, ErrorNumber::WrongDataType)
        );
        assert_eq!(
            e(run(
                &mut p,
                &mut drive,
                RequestLabel::WriteWord,
                930,
                0,
                0x8001
            )),
            // Seed 004's number for "no torque mode", not the name's.
            (ResponseLabel::Error, ErrorNumber::from(140))
        );
        let ppo = run(&mut p, &mut drive, RequestLabel::Read, 929, 0, 0);
        assert_eq!((ppo.response_label(), ppo.value), (ResponseLabel::Word, 1));
        assert_eq!(
            e(run(&mut p, &mut drive, RequestLabel::Read, 965, 0, 0)).0,
            ResponseLabel::Word
        );
        // 927 = 0: PKW writes refused with label 8, except to 927 itself.
        run(&mut p, &mut drive, RequestLabel::WriteWord, 927, 0, 0);
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::WriteWord, 918, 0, 5).response_label(),
            ResponseLabel::NoPkwRights
        );
        assert_eq!(
            run(&mut p, &mut drive, RequestLabel::WriteWord, 927, 0, 1).response_label(),
            ResponseLabel::Word
        );
        // The drive link's own failure: 111 (timeout) for no answer, 103 for a bad answer.
        drive.disconnected = true;
        assert_eq!(
            e(run(
                &mut p,
                &mut drive,
                RequestLabel::ReadArray,
                0x00,
                0x81,
                0
            )),
            (ResponseLabel::Error, ErrorNumber::Timeout)
        );
        drive.disconnected = false;
        drive.fail_next = Some(DriveError::CrcError);
        assert_eq!(
            e(run(
                &mut p,
                &mut drive,
                RequestLabel::ReadArray,
                0x00,
                0x81,
                0
            )),
            (ResponseLabel::Error, ErrorNumber::CommunicationError)
        );
    }

    #[test]
    fn frames_round_trip() {
        let f = Frame {
            label: 7,
            pnu: 0x3B3,
            index: 0x19,
            value: 0x0000_2300,
        };
        let bytes = f.encode();
        assert_eq!(bytes, [0x73, 0xB3, 0x19, 0, 0, 0, 0x23, 0x00]);
        assert_eq!(Frame::decode(&bytes), f);
    }
}
