//! MSAC1 PDUs: the class-1 master's acyclic read and write on SAP 51 (DP-V1; seed 004,
//! "PROFIBUS SD2 报文 SAP 51" and tables 15-17).
//!
//! ```text
//! request   Read   5E slot index length               (length 1..=240: what the master reads)
//!           Write  5F slot index length data[length]  (length 1..=240)
//! response  Read   5E slot index length data[length]  (length: what the slave returns)
//!           Write  5F slot index length               (the length written, echoed)
//!           error  DE|DF 80 Error_Code_1 Error_Code_2 (table 16: Error_Decode 80h = DP-V1)
//! ```
//! Parsing never panics and takes nothing it does not understand: an unknown function, a
//! header cut short, a length that disagrees with the data or exceeds 240 bytes is an error
//! the slave answers with a negative response ([`ParseError::error_code`]). Building writes
//! into a caller's buffer and returns the length, with no allocation.

use dp_consts::dpv1::{error, Function, ERROR_BIT, ERROR_DECODE_DPV1, HEADER_LEN, MAX_DATA_LEN};

/// The longest MSAC1 PDU: the header and 240 data bytes.
pub const MAX_PDU_LEN: usize = HEADER_LEN + MAX_DATA_LEN;

/// Where a read or write goes: a slot and an index in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Address {
    pub slot: u8,
    pub index: u8,
}

/// A class-1 master's request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request<'a> {
    /// Read up to `length` bytes.
    Read {
        at: Address,
        length: u8,
    },
    Write {
        at: Address,
        data: &'a [u8],
    },
}

/// A slave's response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Response<'a> {
    Read {
        at: Address,
        data: &'a [u8],
    },
    /// The write was taken: `length` bytes.
    Write {
        at: Address,
        length: u8,
    },
    /// A negative response to a read (`write` false) or a write.
    Error {
        write: bool,
        code1: u8,
        code2: u8,
    },
}

/// Why a request PDU was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParseError {
    /// No function number, or one this slave does not serve (alarms, MSAC2 services).
    Function(u8),
    /// Fewer than the 4 header bytes.
    Header,
    /// Length 0 or above 240, or a read with data.
    Length,
    /// A write whose length disagrees with its data.
    WriteLength,
}

impl ParseError {
    /// The negative response's Error_Code_1 (table 17).
    pub const fn error_code(self) -> u8 {
        match self {
            ParseError::Function(_) => error::APPLICATION_NOT_SUPPORTED,
            ParseError::Header | ParseError::Length => error::INVALID_PARAMETER,
            ParseError::WriteLength => error::WRITE_LENGTH,
        }
    }
}

impl<'a> Request<'a> {
    pub fn parse(pdu: &'a [u8]) -> Result<Request<'a>, ParseError> {
        let function = *pdu.first().ok_or(ParseError::Function(0))?;
        let function = match Function::from(function) {
            f @ (Function::Read | Function::Write) => f,
            _ => return Err(ParseError::Function(function)),
        };
        let [_, slot, index, length] = *pdu.get(..HEADER_LEN).ok_or(ParseError::Header)? else {
            return Err(ParseError::Header);
        };
        let at = Address { slot, index };
        if length == 0 || usize::from(length) > MAX_DATA_LEN {
            return Err(ParseError::Length);
        }
        let data = &pdu[HEADER_LEN..];
        match function {
            Function::Read if data.is_empty() => Ok(Request::Read { at, length }),
            Function::Read => Err(ParseError::Length),
            _ if data.len() == usize::from(length) => Ok(Request::Write { at, data }),
            _ => Err(ParseError::WriteLength),
        }
    }

    /// Whether the request is a write (for its negative response's function number).
    pub fn is_write(&self) -> bool {
        matches!(self, Request::Write { .. })
    }

    /// Writes the PDU into `out`; returns its length (`out` holds [`MAX_PDU_LEN`]).
    pub fn emit(&self, out: &mut [u8]) -> usize {
        match *self {
            Request::Read { at, length } => header(out, Function::Read, at, length),
            Request::Write { at, data } => {
                let n = header(out, Function::Write, at, data.len() as u8);
                out[n..n + data.len()].copy_from_slice(data);
                n + data.len()
            }
        }
    }
}

fn header(out: &mut [u8], function: Function, at: Address, length: u8) -> usize {
    out[..HEADER_LEN].copy_from_slice(&[function.into(), at.slot, at.index, length]);
    HEADER_LEN
}

impl<'a> Response<'a> {
    /// The negative response to a request that failed to parse or to execute.
    pub const fn error(write: bool, code1: u8) -> Response<'static> {
        Response::Error {
            write,
            code1,
            code2: 0,
        }
    }

    /// Writes the PDU into `out`; returns its length.
    pub fn emit(&self, out: &mut [u8]) -> usize {
        match *self {
            Response::Read { at, data } => {
                let n = header(out, Function::Read, at, data.len() as u8);
                out[n..n + data.len()].copy_from_slice(data);
                n + data.len()
            }
            Response::Write { at, length } => header(out, Function::Write, at, length),
            Response::Error {
                write,
                code1,
                code2,
            } => {
                let function = u8::from(if write {
                    Function::Write
                } else {
                    Function::Read
                });
                out[..4].copy_from_slice(&[function | ERROR_BIT, ERROR_DECODE_DPV1, code1, code2]);
                4
            }
        }
    }

    /// Reads a response PDU (the master's side); `None` if it is none.
    pub fn parse(pdu: &'a [u8]) -> Option<Response<'a>> {
        let [function, slot, index, length] = *pdu.get(..HEADER_LEN)? else {
            return None;
        };
        let at = Address { slot, index };
        let data = &pdu[HEADER_LEN..];
        match Function::from(function) {
            Function::Read if data.len() == usize::from(length) && !data.is_empty() => {
                Some(Response::Read { at, data })
            }
            Function::Write if data.is_empty() => Some(Response::Write { at, length }),
            Function::ReadError | Function::WriteError
                if data.is_empty() && slot == ERROR_DECODE_DPV1 =>
            {
                Some(Response::Error {
                    write: function == u8::from(Function::WriteError),
                    code1: index,
                    code2: length,
                })
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(response: Response) -> Vec<u8> {
        let mut out = [0u8; MAX_PDU_LEN];
        let n = response.emit(&mut out);
        out[..n].to_vec()
    }

    #[test]
    fn seed_004_table_15_function_numbers() {
        let table = [
            (0x48, Function::Idle),
            (0x51, Function::DataTransport),
            (0x56, Function::ResourceManager),
            (0x57, Function::Initiate),
            (0x58, Function::Abort),
            (0x5C, Function::Alarm),
            (0x5E, Function::Read),
            (0x5F, Function::Write),
            (0xD1, Function::DataTransportError),
            (0xD7, Function::InitiateError),
            (0xDC, Function::AlarmError),
            (0xDE, Function::ReadError),
            (0xDF, Function::WriteError),
        ];
        for (code, function) in table {
            assert_eq!(Function::from(code), function);
        }
        // Each negative response is its request's number with bit 7.
        assert_eq!(u8::from(Function::Read) | ERROR_BIT, 0xDE);
        assert_eq!(u8::from(Function::Write) | ERROR_BIT, 0xDF);
    }

    #[test]
    fn seed_004_table_16_negative_response() {
        // DU0 DEh or DFh, DU1 Error_Decode 80h, DU2 Error_Code_1, DU3 Error_Code_2 = 0.
        assert_eq!(
            bytes(Response::error(false, error::STATE_CONFLICT)),
            [0xDE, 0x80, 0xB5, 0x00]
        );
        assert_eq!(
            bytes(Response::error(true, error::WRITE_LENGTH)),
            [0xDF, 0x80, 0xB1, 0x00]
        );
    }

    #[test]
    fn seed_004_table_17_error_classes() {
        // Class in the high nibble: 10 application, 11 access, 12 resource.
        assert_eq!(error::APPLICATION_READ >> 4, 10);
        assert_eq!(error::APPLICATION_NOT_SUPPORTED, 0xA9);
        let access = [
            (error::INVALID_INDEX, 0),
            (error::WRITE_LENGTH, 1),
            (error::INVALID_SLOT, 2),
            (error::TYPE_CONFLICT, 3),
            (error::INVALID_AREA, 4),
            (error::STATE_CONFLICT, 5),
            (error::ACCESS_DENIED, 6),
            (error::INVALID_RANGE, 7),
            (error::INVALID_PARAMETER, 8),
            (error::INVALID_TYPE, 9),
        ];
        for (code, number) in access {
            assert_eq!((code >> 4, code & 0x0F), (11, number));
        }
        assert_eq!(error::RESOURCE_BUSY, 0xC2);
    }

    /// ABB's FPBA-01 manual (the RPBA-01's successor, same PROFIdrive V3 channel), example 1a:
    /// `5F 01 2F 0A 05 01 01 01 10 01 00 0C 00 04`: write to slot 1, index 47, 10 bytes.
    #[test]
    fn a_parameter_request_write_as_abb_shows_it() {
        let pdu = [
            0x5F, 0x01, 0x2F, 0x0A, 0x05, 0x01, 0x01, 0x01, 0x10, 0x01, 0x00, 0x0C, 0x00, 0x04,
        ];
        let request = Request::parse(&pdu).unwrap();
        assert_eq!(
            request,
            Request::Write {
                at: Address { slot: 1, index: 47 },
                data: &pdu[4..]
            }
        );
        let mut out = [0u8; MAX_PDU_LEN];
        let n = request.emit(&mut out);
        assert_eq!(&out[..n], pdu);
        // Its acknowledgement echoes the header ("返回的 DP-V1 写响应代码 5Fh 无数据").
        let ack = Response::Write {
            at: Address { slot: 1, index: 47 },
            length: 10,
        };
        assert_eq!(bytes(ack), [0x5F, 0x01, 0x2F, 0x0A]);
    }

    #[test]
    fn malformed_requests_get_their_error_code() {
        let cases: [(&[u8], ParseError); 7] = [
            (&[], ParseError::Function(0)),
            (&[0x5C, 0, 0, 1], ParseError::Function(0x5C)),
            (&[0x5E, 0, 47], ParseError::Header),
            (&[0x5E, 0, 47, 0], ParseError::Length),
            (&[0x5E, 0, 47, 241], ParseError::Length),
            (&[0x5E, 0, 47, 4, 9], ParseError::Length),
            (&[0x5F, 0, 47, 3, 1, 2], ParseError::WriteLength),
        ];
        for (pdu, expected) in cases {
            assert_eq!(Request::parse(pdu), Err(expected), "{pdu:02X?}");
        }
        assert_eq!(ParseError::WriteLength.error_code(), 0xB1);
        assert_eq!(ParseError::Function(0x5C).error_code(), 0xA9);
    }

    proptest::proptest! {
        #[test]
        fn parsing_never_panics(pdu in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300)) {
            let _ = Request::parse(&pdu);
            let _ = Response::parse(&pdu);
        }

        #[test]
        fn built_requests_parse_back(slot: u8, index: u8, write: bool,
                                     data in proptest::collection::vec(proptest::prelude::any::<u8>(), 1..=240)) {
            let at = Address { slot, index };
            let request = if write {
                Request::Write { at, data: &data }
            } else {
                Request::Read { at, length: data.len() as u8 }
            };
            let mut out = [0u8; MAX_PDU_LEN];
            let n = request.emit(&mut out);
            proptest::prop_assert_eq!(Request::parse(&out[..n]), Ok(request));
        }

        #[test]
        fn built_responses_parse_back(slot: u8, index: u8, kind in 0u8..3, code1: u8, code2: u8,
                                      data in proptest::collection::vec(proptest::prelude::any::<u8>(), 1..=240)) {
            let at = Address { slot, index };
            let response = match kind {
                0 => Response::Read { at, data: &data },
                1 => Response::Write { at, length: data.len() as u8 },
                _ => Response::Error { write: slot & 1 == 1, code1, code2 },
            };
            let mut out = [0u8; MAX_PDU_LEN];
            let n = response.emit(&mut out);
            proptest::prop_assert_eq!(Response::parse(&out[..n]), Some(response));
        }
    }
}
