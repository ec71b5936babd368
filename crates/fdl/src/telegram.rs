//! Telegram views ([`Telegram`]) and representations ([`Repr`]).
//!
//! ```text
//! SD1  10 DA SA FC FCS 16
//! SD2  68 LE LEr 68 DA SA FC [DSAP] [SSAP] DU.. FCS 16     LE = LEr = 3 + DU bytes, 4..=249
//! SD3  A2 DA SA FC DU*8 FCS 16                             (SAP bytes count in the 8)
//! SD4  DC DA SA
//! SC   E5
//! ```
//! DA|0x80 announces a DSAP byte, SA|0x80 an SSAP byte, at the front of the data unit. FCS is the
//! sum of DA..last DU byte, mod 256. The crate docs state the no-panic contract.

use crate::fc::FrameControl;
use crate::Error;
use dp_consts::{ED, SC, SD1, SD2, SD2_MAX_LE, SD2_MIN_LE, SD3, SD3_DATA_LEN, SD4};

/// Byte offsets. SD1, SD3 and SD4 put DA at 1; SD2 at 4, after LE, LEr and the second SD2.
mod field {
    pub const SD: usize = 0;
    pub const LE: usize = 1;
    pub const LER: usize = 2;
    pub const SD2_AGAIN: usize = 3;
    pub const SHORT_HEADER: usize = 1;
    pub const SD2_HEADER: usize = 4;
    /// DA, SA, FC.
    pub const HEADER_LEN: usize = 3;
    /// DA, SA, FC, DU*8, FCS, ED after the SD of an SD3.
    pub const SD3_LEN: usize = 1 + HEADER_LEN + super::SD3_DATA_LEN + 2;
    pub const SD1_LEN: usize = 1 + HEADER_LEN + 2;
    pub const SD4_LEN: usize = 3;
    /// SD, LE, LEr, SD, FCS, ED around DA..DU.
    pub const SD2_FRAMING: usize = 6;
}

const ADDRESS_EXTENSION: u8 = 0x80;
const SAP_EXTENSION_BITS: u8 = 0xC0;

/// The sum of `bytes` mod 256: the FDL frame check sequence over DA..DU.
pub fn fcs(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |sum, b| sum.wrapping_add(*b))
}

/// A service access point, 0..=63. A newtype with named constants rather than an enum because
/// slave and master SAPs share numbers (62 is both Chk_Cfg and the master's MS0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sap(pub u8);

impl Sap {
    pub const SET_SLAVE_ADD: Sap = Sap(dp_consts::sap::SET_SLAVE_ADD);
    pub const RD_INP: Sap = Sap(dp_consts::sap::RD_INP);
    pub const RD_OUTP: Sap = Sap(dp_consts::sap::RD_OUTP);
    pub const GLOBAL_CONTROL: Sap = Sap(dp_consts::sap::GLOBAL_CONTROL);
    pub const GET_CFG: Sap = Sap(dp_consts::sap::GET_CFG);
    pub const SLAVE_DIAG: Sap = Sap(dp_consts::sap::SLAVE_DIAG);
    pub const SET_PRM: Sap = Sap(dp_consts::sap::SET_PRM);
    pub const CHK_CFG: Sap = Sap(dp_consts::sap::CHK_CFG);
    pub const MASTER_MS0: Sap = Sap(dp_consts::sap::MASTER_MS0);
    /// DP-V1's class-1 acyclic read and write (MSAC1), slave and master side alike.
    pub const MSAC1: Sap = Sap(dp_consts::dpv1::SAP);
    /// The largest SAP number (6 bits).
    pub const MAX: u8 = 63;
}

/// A zero-copy view of one telegram at the start of a buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Telegram<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Telegram<T> {
    /// Wraps a buffer without checking it; accessors may panic until [`Self::check`] passed.
    pub const fn new_unchecked(buffer: T) -> Telegram<T> {
        Telegram { buffer }
    }

    /// Wraps a buffer whose first telegram is well formed. Bytes after it are ignored;
    /// [`Self::total_len`] says where it ends.
    pub fn new_checked(buffer: T) -> Result<Telegram<T>, Error> {
        let telegram = Telegram::new_unchecked(buffer);
        telegram.check()?;
        Ok(telegram)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Checks everything the accessors rely on, and everything the standard requires of the
    /// framing: delimiters, LE/LEr, FCS, ED, FC bit 7, the SAP bytes the addresses announce.
    pub fn check(&self) -> Result<(), Error> {
        let data = self.buffer.as_ref();
        let sd = *data.first().ok_or(Error::Truncated)?;
        match sd {
            SC => return Ok(()),
            SD4 => {
                if data.len() < field::SD4_LEN {
                    return Err(Error::Truncated);
                }
                if (data[1] | data[2]) & ADDRESS_EXTENSION != 0 {
                    return Err(Error::BadTokenAddress);
                }
                return Ok(());
            }
            SD1 | SD3 => {}
            SD2 => {
                if data.len() < field::SD2_HEADER {
                    return Err(Error::Truncated);
                }
                let (le, ler) = (data[field::LE], data[field::LER]);
                if le != ler {
                    return Err(Error::LengthMismatch);
                }
                if !(SD2_MIN_LE..=SD2_MAX_LE).contains(&le) {
                    return Err(Error::BadLength(le));
                }
                if data[field::SD2_AGAIN] != SD2 {
                    return Err(Error::BadSecondDelimiter(data[field::SD2_AGAIN]));
                }
            }
            other => return Err(Error::UnknownDelimiter(other)),
        }
        let len = self.total_len();
        if data.len() < len {
            return Err(Error::Truncated);
        }
        let covered = &data[self.header_offset()..len - 2];
        let (expected, found) = (fcs(covered), data[len - 2]);
        if expected != found {
            return Err(Error::BadFcs { expected, found });
        }
        if data[len - 1] != ED {
            return Err(Error::NoEndDelimiter(data[len - 1]));
        }
        FrameControl::from_byte(self.fc_byte())?;
        let du = self.data_unit();
        let sap_bytes = usize::from(self.has_dsap()) + usize::from(self.has_ssap());
        if du.len() < sap_bytes {
            return Err(Error::MissingSap);
        }
        if let Some(&sap) = du[..sap_bytes]
            .iter()
            .find(|b| **b & SAP_EXTENSION_BITS != 0)
        {
            return Err(Error::UnsupportedSapExtension(sap));
        }
        Ok(())
    }

    /// The start delimiter.
    pub fn delimiter(&self) -> u8 {
        self.buffer.as_ref()[field::SD]
    }

    /// Bytes of the whole telegram, from the start delimiter through the end delimiter.
    pub fn total_len(&self) -> usize {
        match self.delimiter() {
            SD1 => field::SD1_LEN,
            SD2 => usize::from(self.buffer.as_ref()[field::LE]) + field::SD2_FRAMING,
            SD3 => field::SD3_LEN,
            SD4 => field::SD4_LEN,
            _ => 1,
        }
    }

    /// Whether this telegram carries DA, SA and FC (SD1, SD2, SD3).
    pub fn has_header(&self) -> bool {
        matches!(self.delimiter(), SD1 | SD2 | SD3)
    }

    fn header_offset(&self) -> usize {
        if self.delimiter() == SD2 {
            field::SD2_HEADER
        } else {
            field::SHORT_HEADER
        }
    }

    /// The destination address byte, extension bit included.
    pub fn da_byte(&self) -> u8 {
        self.buffer.as_ref()[self.header_offset()]
    }

    /// The source address byte, extension bit included.
    pub fn sa_byte(&self) -> u8 {
        self.buffer.as_ref()[self.header_offset() + 1]
    }

    /// The frame control byte (SD1, SD2, SD3).
    pub fn fc_byte(&self) -> u8 {
        self.buffer.as_ref()[self.header_offset() + 2]
    }

    /// Destination station address, 0..=127.
    pub fn destination(&self) -> u8 {
        self.da_byte() & !ADDRESS_EXTENSION
    }

    /// Source station address, 0..=127.
    pub fn source(&self) -> u8 {
        self.sa_byte() & !ADDRESS_EXTENSION
    }

    fn has_dsap(&self) -> bool {
        self.has_header() && self.da_byte() & ADDRESS_EXTENSION != 0
    }

    fn has_ssap(&self) -> bool {
        self.has_header() && self.sa_byte() & ADDRESS_EXTENSION != 0
    }

    /// The data unit, SAP bytes included (empty for SD1).
    pub fn data_unit(&self) -> &[u8] {
        let start = self.header_offset() + field::HEADER_LEN;
        &self.buffer.as_ref()[start..self.total_len() - 2]
    }

    /// The destination SAP, if DA announces one.
    pub fn dsap(&self) -> Option<Sap> {
        self.has_dsap().then(|| Sap(self.data_unit()[0]))
    }

    /// The source SAP, if SA announces one.
    pub fn ssap(&self) -> Option<Sap> {
        self.has_ssap()
            .then(|| Sap(self.data_unit()[usize::from(self.has_dsap())]))
    }

    /// The data unit after the SAP bytes.
    pub fn payload(&self) -> &[u8] {
        &self.data_unit()[usize::from(self.has_dsap()) + usize::from(self.has_ssap())..]
    }
}

/// A data telegram (SD1, SD2 or SD3) with its addresses resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DataRepr<'a> {
    /// Destination station, 0..=127 (127 broadcast).
    pub da: u8,
    /// Source station, 0..=127.
    pub sa: u8,
    pub dsap: Option<Sap>,
    pub ssap: Option<Sap>,
    pub fc: FrameControl,
    /// The data unit after the SAP bytes.
    pub payload: &'a [u8],
}

/// Any telegram, parsed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Repr<'a> {
    /// SD1, SD2 or SD3: the delimiter follows from the data-unit length.
    Data(DataRepr<'a>),
    /// SD4, the token.
    Token { da: u8, sa: u8 },
    /// SC, the short acknowledgement.
    ShortAck,
}

impl<'a> DataRepr<'a> {
    /// Data-unit bytes: SAP bytes plus payload.
    pub fn data_unit_len(&self) -> usize {
        usize::from(self.dsap.is_some()) + usize::from(self.ssap.is_some()) + self.payload.len()
    }

    /// The response to this request: addresses and SAPs swapped.
    pub fn response(&self, fc: FrameControl, payload: &'a [u8]) -> DataRepr<'a> {
        DataRepr {
            da: self.sa,
            sa: self.da,
            dsap: self.ssap,
            ssap: self.dsap,
            fc,
            payload,
        }
    }
}

impl<'a> Repr<'a> {
    /// Parses a telegram view (checking it again: a view may be unchecked).
    pub fn parse(telegram: &Telegram<&'a [u8]>) -> Result<Repr<'a>, Error> {
        Repr::parse_bytes(telegram.buffer).map(|(repr, _)| repr)
    }

    /// Parses the telegram at the start of `bytes`; returns it and its length.
    pub fn parse_bytes(bytes: &'a [u8]) -> Result<(Repr<'a>, usize), Error> {
        let telegram = Telegram::new_checked(bytes)?;
        let len = telegram.total_len();
        let repr = match telegram.delimiter() {
            SC => Repr::ShortAck,
            SD4 => Repr::Token {
                da: telegram.destination(),
                sa: telegram.source(),
            },
            _ => {
                let sap_bytes = usize::from(telegram.has_dsap()) + usize::from(telegram.has_ssap());
                let du_start = telegram.header_offset() + field::HEADER_LEN;
                Repr::Data(DataRepr {
                    da: telegram.destination(),
                    sa: telegram.source(),
                    dsap: telegram.dsap(),
                    ssap: telegram.ssap(),
                    fc: FrameControl::from_byte(telegram.fc_byte())?,
                    payload: &bytes[du_start + sap_bytes..len - 2],
                })
            }
        };
        Ok((repr, len))
    }

    /// Whether [`Self::emit`] accepts this value and parse gives it back unchanged.
    pub fn check(&self) -> Result<(), Error> {
        match self {
            Repr::ShortAck => Ok(()),
            Repr::Token { da, sa } => {
                if *da > 127 || *sa > 127 {
                    Err(Error::AddressOutOfRange)
                } else {
                    Ok(())
                }
            }
            Repr::Data(d) => {
                let sap_ok = |s: Option<Sap>| s.is_none_or(|s| s.0 <= Sap::MAX);
                if d.da > 127 || d.sa > 127 || !sap_ok(d.dsap) || !sap_ok(d.ssap) {
                    return Err(Error::AddressOutOfRange);
                }
                if d.fc.to_byte() & 0x80 != 0 || !d.fc.is_canonical() {
                    return Err(Error::ReservedFcBit);
                }
                if d.data_unit_len() > usize::from(SD2_MAX_LE) - field::HEADER_LEN {
                    return Err(Error::DataTooLong);
                }
                Ok(())
            }
        }
    }

    /// Bytes [`Self::emit`] writes.
    pub fn buffer_len(&self) -> usize {
        match self {
            Repr::ShortAck => 1,
            Repr::Token { .. } => field::SD4_LEN,
            Repr::Data(d) => match d.data_unit_len() {
                0 => field::SD1_LEN,
                SD3_DATA_LEN => field::SD3_LEN,
                n => n + field::HEADER_LEN + field::SD2_FRAMING,
            },
        }
    }

    /// Writes the telegram at the start of `buffer`, choosing SD1 for an empty data unit, SD3
    /// for exactly 8 bytes and SD2 otherwise; returns the bytes written.
    pub fn emit(&self, buffer: &mut [u8]) -> Result<usize, Error> {
        self.check()?;
        let len = self.buffer_len();
        let out = buffer.get_mut(..len).ok_or(Error::BufferTooShort)?;
        match self {
            Repr::ShortAck => out[0] = SC,
            Repr::Token { da, sa } => out.copy_from_slice(&[SD4, *da, *sa]),
            Repr::Data(d) => {
                let du_len = d.data_unit_len();
                let header = match du_len {
                    0 => {
                        out[0] = SD1;
                        field::SHORT_HEADER
                    }
                    SD3_DATA_LEN => {
                        out[0] = SD3;
                        field::SHORT_HEADER
                    }
                    _ => {
                        // Fits a u8: check() bounded du_len by 246.
                        let le = (du_len + field::HEADER_LEN) as u8;
                        out[..field::SD2_HEADER].copy_from_slice(&[SD2, le, le, SD2]);
                        field::SD2_HEADER
                    }
                };
                let ext = |present: bool| if present { ADDRESS_EXTENSION } else { 0 };
                out[header] = d.da | ext(d.dsap.is_some());
                out[header + 1] = d.sa | ext(d.ssap.is_some());
                out[header + 2] = d.fc.to_byte();
                let mut at = header + field::HEADER_LEN;
                for sap in [d.dsap, d.ssap].into_iter().flatten() {
                    out[at] = sap.0;
                    at += 1;
                }
                out[at..at + d.payload.len()].copy_from_slice(d.payload);
                at += d.payload.len();
                out[at] = fcs(&out[header..at]);
                out[at + 1] = ED;
            }
        }
        Ok(len)
    }
}

#[cfg(test)]
mod tests {
    //! Every vector of shared/PROTOCOL.md, deconstructed, constructed, parsed and emitted.
    use super::*;
    use crate::fc::{RequestFunction as F, ResponseStatus as S};

    fn req(fcb: bool, fcv: bool, function: F) -> FrameControl {
        FrameControl::Request { fcb, fcv, function }
    }

    fn slave(status: S) -> FrameControl {
        FrameControl::slave_response(status)
    }

    /// Parses `bytes`, compares with `want`, emits `want` and compares with `bytes`.
    fn round_trip(bytes: &[u8], want: Repr) {
        let (got, len) = Repr::parse_bytes(bytes).unwrap();
        assert_eq!(got, want);
        assert_eq!(len, bytes.len());
        assert_eq!(want.buffer_len(), bytes.len());
        let mut out = [0u8; 300];
        let n = want.emit(&mut out).unwrap();
        assert_eq!(&out[..n], bytes);
    }

    static GLOBAL_CONTROL_SIEMENS: [u8; 13] = [
        0x68, 0x07, 0x07, 0x68, 0xFF, 0x81, 0x46, 0x3A, 0x3E, 0x00, 0x00, 0x3E, 0x16,
    ];
    static SLAVE_DIAG_REQ_SIEMENS: [u8; 11] = [
        0x68, 0x05, 0x05, 0x68, 0x88, 0x81, 0x6D, 0x3C, 0x3E, 0xF0, 0x16,
    ];
    static SLAVE_DIAG_RESP_SIEMENS: [u8; 17] = [
        0x68, 0x0B, 0x0B, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3C, 0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0,
        0xF1, 0x16,
    ];
    static GET_CFG_REQ_SIEMENS: [u8; 11] = [
        0x68, 0x05, 0x05, 0x68, 0x88, 0x81, 0x5D, 0x3B, 0x3E, 0xDF, 0x16,
    ];
    static GET_CFG_RESP_SIEMENS: [u8; 14] = [
        0x68, 0x08, 0x08, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3B, 0x00, 0x10, 0x10, 0xAA, 0x16,
    ];
    static CHK_CFG_SIEMENS: [u8; 14] = [
        0x68, 0x08, 0x08, 0x68, 0x88, 0x81, 0x5D, 0x3E, 0x3E, 0x00, 0x10, 0x10, 0x02, 0x16,
    ];
    static FDL_STATUS_REQ: [u8; 6] = [0x10, 0x08, 0x02, 0x49, 0x53, 0x16];
    static FDL_STATUS_REPLY: [u8; 6] = [0x10, 0x02, 0x08, 0x00, 0x0A, 0x16];
    static SLAVE_DIAG_REQ_2: [u8; 11] = [
        0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3C, 0x3E, 0xF1, 0x16,
    ];
    static CHK_CFG_PPO1: [u8; 13] = [
        0x68, 0x07, 0x07, 0x68, 0x88, 0x82, 0x7D, 0x3E, 0x3E, 0xF3, 0xF1, 0xE7, 0x16,
    ];
    static GET_CFG_REQ_2: [u8; 11] = [
        0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x4D, 0x3B, 0x3E, 0xD0, 0x16,
    ];
    static GLOBAL_CONTROL_CLEAR: [u8; 13] = [
        0x68, 0x07, 0x07, 0x68, 0xFF, 0x82, 0x46, 0x3A, 0x3E, 0x02, 0x00, 0x41, 0x16,
    ];
    static DATA_EXCHANGE_SD3: [u8; 14] = [
        0xA2, 0x08, 0x02, 0x4D, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x73, 0x16,
    ];
    static DATA_EXCHANGE_SD1: [u8; 6] = [0x10, 0x08, 0x02, 0x4D, 0x57, 0x16];

    #[test]
    fn deconstruct_slave_diag_request() {
        let t = Telegram::new_checked(&SLAVE_DIAG_REQ_SIEMENS[..]).unwrap();
        assert_eq!(t.delimiter(), SD2);
        assert_eq!(t.total_len(), 11);
        assert_eq!((t.destination(), t.source()), (8, 1));
        assert_eq!(t.fc_byte(), 0x6D);
        assert_eq!(t.dsap(), Some(Sap::SLAVE_DIAG));
        assert_eq!(t.ssap(), Some(Sap::MASTER_MS0));
        assert!(t.payload().is_empty());
    }

    #[test]
    fn global_control_siemens() {
        round_trip(
            &GLOBAL_CONTROL_SIEMENS,
            Repr::Data(DataRepr {
                da: 127,
                sa: 1,
                dsap: Some(Sap::GLOBAL_CONTROL),
                ssap: Some(Sap::MASTER_MS0),
                fc: req(false, false, F::SdnHigh),
                payload: &[0x00, 0x00],
            }),
        );
    }

    #[test]
    fn slave_diag_siemens_request_and_response() {
        round_trip(
            &SLAVE_DIAG_REQ_SIEMENS,
            Repr::Data(DataRepr {
                da: 8,
                sa: 1,
                dsap: Some(Sap::SLAVE_DIAG),
                ssap: Some(Sap::MASTER_MS0),
                fc: req(true, false, F::SrdHigh),
                payload: &[],
            }),
        );
        // The ET200S sends its 8-byte data unit as SD2; we emit the same Repr as SD3, the
        // shorter of the two legal forms, and both parse to one Repr.
        let want = Repr::Data(DataRepr {
            da: 1,
            sa: 8,
            dsap: Some(Sap::MASTER_MS0),
            ssap: Some(Sap::SLAVE_DIAG),
            fc: slave(S::DataLow),
            payload: &[0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0],
        });
        assert_eq!(
            Repr::parse_bytes(&SLAVE_DIAG_RESP_SIEMENS),
            Ok((want, SLAVE_DIAG_RESP_SIEMENS.len()))
        );
        let mut out = [0u8; 14];
        assert_eq!(want.emit(&mut out), Ok(14));
        assert_eq!(out[0], SD3);
        assert_eq!(out[1..12], SLAVE_DIAG_RESP_SIEMENS[4..15]);
        assert_eq!(Repr::parse_bytes(&out), Ok((want, 14)));
    }

    #[test]
    fn get_cfg_and_chk_cfg_siemens() {
        round_trip(
            &GET_CFG_REQ_SIEMENS,
            Repr::Data(DataRepr {
                da: 8,
                sa: 1,
                dsap: Some(Sap::GET_CFG),
                ssap: Some(Sap::MASTER_MS0),
                fc: req(false, true, F::SrdHigh),
                payload: &[],
            }),
        );
        round_trip(
            &GET_CFG_RESP_SIEMENS,
            Repr::Data(DataRepr {
                da: 1,
                sa: 8,
                dsap: Some(Sap::MASTER_MS0),
                ssap: Some(Sap::GET_CFG),
                fc: slave(S::DataLow),
                payload: &[0x00, 0x10, 0x10],
            }),
        );
        round_trip(
            &CHK_CFG_SIEMENS,
            Repr::Data(DataRepr {
                da: 8,
                sa: 1,
                dsap: Some(Sap::CHK_CFG),
                ssap: Some(Sap::MASTER_MS0),
                fc: req(false, true, F::SrdHigh),
                payload: &[0x00, 0x10, 0x10],
            }),
        );
        round_trip(&[SC], Repr::ShortAck);
    }

    #[test]
    fn fdl_status_request_and_reply() {
        round_trip(
            &FDL_STATUS_REQ,
            Repr::Data(DataRepr {
                da: 8,
                sa: 2,
                dsap: None,
                ssap: None,
                fc: req(false, false, F::FdlStatus),
                payload: &[],
            }),
        );
        round_trip(
            &FDL_STATUS_REPLY,
            Repr::Data(DataRepr {
                da: 2,
                sa: 8,
                dsap: None,
                ssap: None,
                fc: slave(S::Ok),
                payload: &[],
            }),
        );
    }

    #[test]
    fn second_master_encoders() {
        let ms0 = |dsap, fc, payload| {
            Repr::Data(DataRepr {
                da: 8,
                sa: 2,
                dsap: Some(dsap),
                ssap: Some(Sap::MASTER_MS0),
                fc,
                payload,
            })
        };
        round_trip(
            &SLAVE_DIAG_REQ_2,
            ms0(Sap::SLAVE_DIAG, req(true, false, F::SrdHigh), &[]),
        );
        round_trip(
            &CHK_CFG_PPO1,
            ms0(Sap::CHK_CFG, req(true, true, F::SrdHigh), &[0xF3, 0xF1]),
        );
        round_trip(
            &GET_CFG_REQ_2,
            ms0(Sap::GET_CFG, req(false, false, F::SrdHigh), &[]),
        );
        round_trip(
            &GLOBAL_CONTROL_CLEAR,
            Repr::Data(DataRepr {
                da: 127,
                sa: 2,
                dsap: Some(Sap::GLOBAL_CONTROL),
                ssap: Some(Sap::MASTER_MS0),
                fc: req(false, false, F::SdnHigh),
                payload: &[0x02, 0x00],
            }),
        );
    }

    #[test]
    fn data_exchange_as_sd3_and_sd1() {
        let dx = |payload| {
            Repr::Data(DataRepr {
                da: 8,
                sa: 2,
                dsap: None,
                ssap: None,
                fc: req(false, false, F::SrdHigh),
                payload,
            })
        };
        round_trip(&DATA_EXCHANGE_SD3, dx(&[0, 1, 2, 3, 4, 5, 6, 7]));
        round_trip(&DATA_EXCHANGE_SD1, dx(&[]));
    }

    #[test]
    fn token() {
        round_trip(&[SD4, 0x05, 0x02], Repr::Token { da: 5, sa: 2 });
        assert_eq!(
            Repr::parse_bytes(&[SD4, 0x85, 0x02]),
            Err(Error::BadTokenAddress)
        );
    }

    #[test]
    fn malformed_telegrams_are_rejected_with_a_reason() {
        let mut bad = GLOBAL_CONTROL_SIEMENS;
        bad[2] = 0x08;
        assert_eq!(Repr::parse_bytes(&bad), Err(Error::LengthMismatch));
        let mut bad = GLOBAL_CONTROL_SIEMENS;
        bad[3] = 0x69;
        assert_eq!(
            Repr::parse_bytes(&bad),
            Err(Error::BadSecondDelimiter(0x69))
        );
        let mut bad = GLOBAL_CONTROL_SIEMENS;
        bad[11] = 0x3F;
        assert_eq!(
            Repr::parse_bytes(&bad),
            Err(Error::BadFcs {
                expected: 0x3E,
                found: 0x3F
            })
        );
        let mut bad = GLOBAL_CONTROL_SIEMENS;
        bad[12] = 0x17;
        assert_eq!(Repr::parse_bytes(&bad), Err(Error::NoEndDelimiter(0x17)));
        assert_eq!(
            Repr::parse_bytes(&GLOBAL_CONTROL_SIEMENS[..12]),
            Err(Error::Truncated)
        );
        assert_eq!(Repr::parse_bytes(&[]), Err(Error::Truncated));
        assert_eq!(
            Repr::parse_bytes(&[0x42]),
            Err(Error::UnknownDelimiter(0x42))
        );
        assert_eq!(
            Repr::parse_bytes(&[0x68, 3, 3, 0x68, 1, 2, 0x40, 0x43, 0x16]),
            Err(Error::BadLength(3))
        );
        // SD1 whose DA announces a DSAP: there is no data unit to hold it.
        assert_eq!(
            Repr::parse_bytes(&[0x10, 0x88, 0x02, 0x4D, 0xD7, 0x16]),
            Err(Error::MissingSap)
        );
        // FC with the reserved bit 7.
        assert_eq!(
            Repr::parse_bytes(&[0x10, 0x08, 0x02, 0xCD, 0xD7, 0x16]),
            Err(Error::ReservedFcBit)
        );
        // A SAP byte with the segment bit.
        assert_eq!(
            Repr::parse_bytes(&[0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x7C, 0x3E, 0x31, 0x16]),
            Err(Error::UnsupportedSapExtension(0x7C))
        );
    }

    #[test]
    fn trailing_bytes_are_left_alone() {
        let mut two = [0u8; 7];
        two[..6].copy_from_slice(&DATA_EXCHANGE_SD1);
        two[6] = SC;
        let (_, len) = Repr::parse_bytes(&two).unwrap();
        assert_eq!(len, 6);
    }

    #[test]
    fn emit_refuses_what_it_cannot_write() {
        let big = [0u8; 247];
        let repr = Repr::Data(DataRepr {
            da: 8,
            sa: 2,
            dsap: None,
            ssap: None,
            fc: req(false, false, F::SrdHigh),
            payload: &big,
        });
        assert_eq!(repr.emit(&mut [0u8; 300]), Err(Error::DataTooLong));
        let repr = Repr::Data(DataRepr {
            payload: &big[..246],
            ..match repr {
                Repr::Data(d) => d,
                _ => unreachable!(),
            }
        });
        assert_eq!(repr.buffer_len(), 255);
        assert_eq!(repr.emit(&mut [0u8; 254]), Err(Error::BufferTooShort));
        assert_eq!(repr.emit(&mut [0u8; 255]), Ok(255));
        let repr = Repr::Token { da: 128, sa: 1 };
        assert_eq!(repr.emit(&mut [0u8; 3]), Err(Error::AddressOutOfRange));
    }
}
