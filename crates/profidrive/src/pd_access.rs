//! PROFIdrive parameter access over DP-V1 (seed 004, "DP-V1 读 / 写请求时序", tables 18-21): the
//! parameter request a master writes to index [`PARAMETER_REQUEST_INDEX`] and the parameter
//! response it reads back.
//!
//! ```text
//! request   ref id axis n  { attribute elements number(2) subindex(2) } x n
//!                          [ { format count values } x n ]            (id 02h, change, only)
//! response  ref id axis n  [ { format count values } x n ]            (reads, and negatives)
//! ```
//! Values are words or bytes as the format says (table 20), big-endian; an odd number of value
//! bytes is padded with one zero byte. A read answers `01h` with the values; a change answers
//! `02h` with the header alone. If any parameter fails, the response ID is `81h`/`82h` and
//! every parameter gets a block: its values or format `40h` (a write that succeeded), or format
//! `44h` with the error number (table 21) for one that failed.
//!
//! The PDUs here are parsed and built without allocation; parsing never panics and checks the
//! whole request (lengths, counts, formats) before anything is executed.

use crate::pd_params::ErrorNumber;

/// The DP-V1 index of the parameter request and response. The PROFIdrive profile's base-mode
/// parameter access; ABB shows it on the wire in its FPBA-01 manual's examples
/// (`5F 01 2F 0A ...`: write, slot 1, index 2Fh).
pub const PARAMETER_REQUEST_INDEX: u8 = 47;
/// The most parameters in one request (table 18).
pub const MAX_PARAMETERS: usize = 37;
/// The longest request or response: one DP-V1 data unit.
pub const MAX_LEN: usize = dp_consts::dpv1::MAX_DATA_LEN;
/// Header: reference, ID, axis, number of parameters.
pub const HEADER_LEN: usize = 4;
/// One parameter address: attribute, elements, number, subindex.
pub const ADDRESS_LEN: usize = 6;

dp_consts::code_point! {
    /// Request IDs (table 18).
    pub enum RequestId {
        Read = 0x01,
        Change = 0x02,
    }
}

dp_consts::code_point! {
    /// What a parameter address accesses (table 18; text is not supported).
    pub enum Attribute {
        Value = 0x10,
        Description = 0x20,
        Text = 0x30,
    }
}

dp_consts::code_point! {
    /// Formats of a value block (table 20): the PROFIdrive standard types the adapter takes,
    /// and the block formats 40h-44h.
    pub enum Format {
        Integer8 = 0x02,
        Integer16 = 0x03,
        Integer32 = 0x04,
        Unsigned8 = 0x05,
        Unsigned16 = 0x06,
        Unsigned32 = 0x07,
        /// No values: a write that succeeded, in a negative response.
        Zero = 0x40,
        Byte = 0x41,
        Word = 0x42,
        DoubleWord = 0x43,
        Error = 0x44,
    }
}

impl Format {
    /// Bytes per value; `None` for a format the adapter does not take.
    pub fn value_size(self) -> Option<usize> {
        match self {
            Format::Integer8 | Format::Unsigned8 | Format::Byte => Some(1),
            Format::Integer16 | Format::Unsigned16 | Format::Word | Format::Error => Some(2),
            Format::Integer32 | Format::Unsigned32 | Format::DoubleWord => Some(4),
            Format::Zero => Some(0),
            Format::Unknown(_) => None,
        }
    }
}

/// One parameter a request addresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamAddress {
    pub attribute: Attribute,
    /// Array elements (0 for a simple parameter).
    pub elements: u8,
    pub number: u16,
    pub subindex: u16,
}

impl ParamAddress {
    /// The value of parameter `number` from `subindex`, `elements` of them (0: a simple one).
    pub const fn value(number: u16, subindex: u16, elements: u8) -> ParamAddress {
        ParamAddress {
            attribute: Attribute::Value,
            elements,
            number,
            subindex,
        }
    }

    fn parse(b: &[u8]) -> ParamAddress {
        ParamAddress {
            attribute: Attribute::from(b[0]),
            elements: b[1],
            number: u16::from_be_bytes([b[2], b[3]]),
            subindex: u16::from_be_bytes([b[4], b[5]]),
        }
    }

    fn emit(&self, out: &mut [u8]) {
        let [n0, n1] = self.number.to_be_bytes();
        let [s0, s1] = self.subindex.to_be_bytes();
        out[..ADDRESS_LEN].copy_from_slice(&[self.attribute.into(), self.elements, n0, n1, s0, s1]);
    }

    /// How many values it accesses: the element count, 1 for a simple parameter.
    pub fn count(&self) -> usize {
        usize::from(self.elements.max(1))
    }
}

/// A block of values: its format, count and bytes (without the padding).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Values<'a> {
    pub format: Format,
    pub count: u8,
    pub bytes: &'a [u8],
}

impl<'a> Values<'a> {
    /// One word value.
    pub const fn word(bytes: &'a [u8; 2]) -> Values<'a> {
        Values {
            format: Format::Word,
            count: 1,
            bytes,
        }
    }

    /// Value `i` as a number (words and bytes big-endian).
    pub fn get(&self, i: usize) -> Option<u32> {
        let size = self.format.value_size()?;
        let b = self.bytes.get(i * size..(i + 1) * size)?;
        Some(b.iter().fold(0u32, |v, byte| v << 8 | u32::from(*byte)))
    }

    /// Reads one block at the start of `b`; returns it and the bytes it took (with padding).
    fn parse(b: &'a [u8]) -> Option<(Values<'a>, usize)> {
        let [format, count] = *b.get(..2)? else {
            return None;
        };
        let format = Format::from(format);
        let len = format.value_size()? * usize::from(count);
        let bytes = b.get(2..2 + len)?;
        let taken = 2 + len + len % 2;
        (b.len() >= taken).then_some((
            Values {
                format,
                count,
                bytes,
            },
            taken,
        ))
    }
}

/// Why a parameter request could not be taken at all; it is answered with one error block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RequestError {
    /// Neither read nor change (error 90h).
    RequestId,
    /// Shorter or longer than its header, addresses and values say, or 0 or more than 37
    /// parameters (error 16h, illegal parameter address).
    Layout,
    /// A value block's format is one the adapter does not take (error 17h).
    Format,
    /// Request reference 0 (table 18: 1 .. 255; error 66h, request not supported).
    Reference,
    /// An axis other than 0 or 1 (table 18: "set to 0 or 1"; error 66h).
    Axis,
}

impl RequestError {
    pub fn error_number(self) -> ErrorNumber {
        match self {
            RequestError::RequestId => ErrorNumber::InvalidRequestId,
            RequestError::Layout => ErrorNumber::IllegalAddress,
            RequestError::Format => ErrorNumber::IllegalFormat,
            RequestError::Reference | RequestError::Axis => ErrorNumber::UnsupportedRequest,
        }
    }
}

/// A parsed parameter request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamRequestPdu<'a> {
    pub reference: u8,
    pub id: RequestId,
    pub axis: u8,
    count: usize,
    addresses: &'a [u8],
    /// The value blocks (change only), checked by `parse`.
    values: &'a [u8],
}

impl<'a> ParamRequestPdu<'a> {
    /// The header of a request, even one that fails to parse (its response mirrors it).
    pub fn header(pdu: &[u8]) -> Option<(u8, RequestId, u8)> {
        let [reference, id, axis, _] = *pdu.get(..HEADER_LEN)? else {
            return None;
        };
        Some((reference, RequestId::from(id), axis))
    }

    pub fn parse(pdu: &'a [u8]) -> Result<ParamRequestPdu<'a>, RequestError> {
        let [reference, id, axis, count] = *pdu.get(..HEADER_LEN).ok_or(RequestError::Layout)?
        else {
            return Err(RequestError::Layout);
        };
        let id = RequestId::from(id);
        if !matches!(id, RequestId::Read | RequestId::Change) {
            return Err(RequestError::RequestId);
        }
        if reference == 0 {
            return Err(RequestError::Reference);
        }
        if axis > 1 {
            return Err(RequestError::Axis);
        }
        let count = usize::from(count);
        if count == 0 || count > MAX_PARAMETERS {
            return Err(RequestError::Layout);
        }
        let end = HEADER_LEN + count * ADDRESS_LEN;
        let addresses = pdu.get(HEADER_LEN..end).ok_or(RequestError::Layout)?;
        let values = &pdu[end..];
        let request = ParamRequestPdu {
            reference,
            id,
            axis,
            count,
            addresses,
            values,
        };
        match id {
            RequestId::Read if values.is_empty() => Ok(request),
            RequestId::Read => Err(RequestError::Layout),
            _ => {
                let mut at = 0;
                for _ in 0..count {
                    let Some(format) = values.get(at).map(|f| Format::from(*f)) else {
                        return Err(RequestError::Layout);
                    };
                    if format.value_size().is_none() || format == Format::Error {
                        return Err(RequestError::Format);
                    }
                    let (_, taken) = Values::parse(&values[at..]).ok_or(RequestError::Layout)?;
                    at += taken;
                }
                if at == values.len() {
                    Ok(request)
                } else {
                    Err(RequestError::Layout)
                }
            }
        }
    }

    pub fn count(&self) -> usize {
        self.count
    }

    pub fn address(&self, i: usize) -> ParamAddress {
        ParamAddress::parse(&self.addresses[i * ADDRESS_LEN..])
    }

    /// The values of parameter `i` of a change request.
    pub fn values(&self, i: usize) -> Option<Values<'a>> {
        let mut at = 0;
        for n in 0..=i {
            let (values, taken) = Values::parse(self.values.get(at..)?)?;
            if n == i {
                return Some(values);
            }
            at += taken;
        }
        None
    }
}

/// Builds a parameter request (the master's side, and tests); returns its length, or `None`
/// when it does not fit.
pub fn build_request(
    out: &mut [u8; MAX_LEN],
    reference: u8,
    id: RequestId,
    axis: u8,
    addresses: &[ParamAddress],
    values: &[Values],
) -> Option<usize> {
    let mut w = Writer::new(out);
    w.push(&[reference, id.into(), axis, addresses.len() as u8])?;
    for address in addresses {
        let mut b = [0u8; ADDRESS_LEN];
        address.emit(&mut b);
        w.push(&b)?;
    }
    for v in values {
        w.block(v.format, v.count, v.bytes)?;
    }
    Some(w.len)
}

/// Writes a parameter response into a buffer of one DP-V1 data unit.
pub struct Writer<'a> {
    out: &'a mut [u8; MAX_LEN],
    len: usize,
}

impl<'a> Writer<'a> {
    pub fn new(out: &'a mut [u8; MAX_LEN]) -> Writer<'a> {
        Writer { out, len: 0 }
    }

    /// Goes on writing a response of which `len` bytes are written.
    pub fn resume(out: &'a mut [u8; MAX_LEN], len: usize) -> Writer<'a> {
        Writer {
            out,
            len: len.min(MAX_LEN),
        }
    }

    /// The response header; the response ID is set later if a parameter fails.
    pub fn header(&mut self, reference: u8, id: u8, axis: u8, count: u8) {
        self.len = 0;
        let _ = self.push(&[reference, id, axis, count]);
    }

    /// Marks the response negative (81h, 82h).
    pub fn set_negative(&mut self) {
        self.out[1] |= 0x80;
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn push(&mut self, bytes: &[u8]) -> Option<()> {
        let end = self.len + bytes.len();
        self.out.get_mut(self.len..end)?.copy_from_slice(bytes);
        self.len = end;
        Some(())
    }

    /// One value block; `None` (and nothing written) when it does not fit.
    pub fn block(&mut self, format: Format, count: u8, bytes: &[u8]) -> Option<()> {
        let padded = bytes.len() + bytes.len() % 2;
        if self.len + 2 + padded > MAX_LEN {
            return None;
        }
        self.push(&[format.into(), count])?;
        self.push(bytes)?;
        if bytes.len() % 2 == 1 {
            self.push(&[0])?;
        }
        Some(())
    }

    /// An error block (format 44h, one value).
    pub fn error(&mut self, error: ErrorNumber) -> Option<()> {
        self.block(Format::Error, 1, &u16::from(error).to_be_bytes())
    }

    /// Room left for a block's values.
    pub fn room(&self) -> usize {
        MAX_LEN.saturating_sub(self.len + 2)
    }
}

/// A parsed parameter response (the master's side).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamResponsePdu<'a> {
    pub reference: u8,
    /// 01h, 02h, 81h or 82h.
    pub id: u8,
    pub axis: u8,
    pub count: u8,
    blocks: &'a [u8],
}

impl<'a> ParamResponsePdu<'a> {
    pub fn parse(pdu: &'a [u8]) -> Option<ParamResponsePdu<'a>> {
        let [reference, id, axis, count] = *pdu.get(..HEADER_LEN)? else {
            return None;
        };
        let response = ParamResponsePdu {
            reference,
            id,
            axis,
            count,
            blocks: &pdu[HEADER_LEN..],
        };
        // A positive change has no blocks; everything else one per parameter, exactly.
        let blocks = if id == 0x02 { 0 } else { usize::from(count) };
        let mut at = 0;
        for _ in 0..blocks {
            at += Values::parse(response.blocks.get(at..)?)?.1;
        }
        (at == response.blocks.len()).then_some(response)
    }

    pub fn negative(&self) -> bool {
        self.id & 0x80 != 0
    }

    /// Block `i`.
    pub fn values(&self, i: usize) -> Option<Values<'a>> {
        let mut at = 0;
        for n in 0..=i {
            let (values, taken) = Values::parse(self.blocks.get(at..)?)?;
            if n == i {
                return Some(values);
            }
            at += taken;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn address(number: u16, subindex: u16, elements: u8) -> ParamAddress {
        ParamAddress::value(number, subindex, elements)
    }

    fn build(id: RequestId, addresses: &[ParamAddress], values: &[Values]) -> Vec<u8> {
        let mut out = [0u8; MAX_LEN];
        let n = build_request(&mut out, 7, id, 1, addresses, values).unwrap();
        out[..n].to_vec()
    }

    /// Seed 004 example 1a: a drive parameter is xx.yy x 100 in hexadecimal, its high byte
    /// the parameter number and its low byte the subindex (12.04: 1204 = 4B4h).
    #[test]
    fn seed_004_example_1a_read_one_drive_parameter() {
        let pdu = build(RequestId::Read, &[address(0x04, 0xB4, 0)], &[]);
        assert_eq!(pdu, [7, 0x01, 1, 1, 0x10, 0, 0x00, 0x04, 0x00, 0xB4]);
        let request = ParamRequestPdu::parse(&pdu).unwrap();
        assert_eq!(
            (request.reference, request.id, request.count()),
            (7, RequestId::Read, 1)
        );
        assert_eq!(request.address(0), address(4, 0xB4, 0));
    }

    /// Example 1b: three parameters (12.04, 12.05, 12.06) in one request.
    #[test]
    fn seed_004_example_1b_read_three_drive_parameters() {
        let addresses = [
            address(4, 0xB4, 0),
            address(4, 0xB5, 0),
            address(4, 0xB6, 0),
        ];
        let pdu = build(RequestId::Read, &addresses, &[]);
        assert_eq!(pdu.len(), HEADER_LEN + 3 * ADDRESS_LEN);
        let request = ParamRequestPdu::parse(&pdu).unwrap();
        assert_eq!(request.count(), 3);
        assert_eq!(request.address(2).subindex, 0xB6);
    }

    /// Example 2b: 300 (12Ch) to 12.02 (4B2h) and 500 (1F4h) to 12.03 (4B3h), one telegram.
    #[test]
    fn seed_004_example_2b_write_two_values() {
        let v300 = 300u16.to_be_bytes();
        let v500 = 500u16.to_be_bytes();
        let values = [Values::word(&v300), Values::word(&v500)];
        let pdu = build(
            RequestId::Change,
            &[address(4, 0xB2, 0), address(4, 0xB3, 0)],
            &values,
        );
        assert_eq!(
            &pdu[HEADER_LEN + 12..],
            [0x42, 1, 0x01, 0x2C, 0x42, 1, 0x01, 0xF4]
        );
        let request = ParamRequestPdu::parse(&pdu).unwrap();
        assert_eq!(request.values(0).unwrap().get(0), Some(300));
        assert_eq!(request.values(1).unwrap().get(0), Some(500));
    }

    /// Examples 3-5: 918 (396h) read; 915 (393h) subindex 3 = 12.06 (4B6h); 916 (394h)
    /// subindex 3 = 12.05 (4B5h).
    #[test]
    fn seed_004_examples_3_4_5_profidrive_parameters() {
        let pdu = build(RequestId::Read, &[address(0x396, 0, 0)], &[]);
        assert_eq!(&pdu[4..], [0x10, 0, 0x03, 0x96, 0, 0]);
        for (number, value) in [(0x393u16, 0x4B6u16), (0x394, 0x4B5)] {
            let v = value.to_be_bytes();
            let values = [Values::word(&v)];
            let pdu = build(RequestId::Change, &[address(number, 3, 1)], &values);
            let request = ParamRequestPdu::parse(&pdu).unwrap();
            assert_eq!(request.address(0).number, number);
            assert_eq!(request.values(0).unwrap().get(0), Some(u32::from(value)));
        }
    }

    /// Table 19: a negative response carries one block per parameter, values or format 40h
    /// for those that worked and 44h with the error number for those that failed; odd value
    /// bytes are padded.
    #[test]
    fn seed_004_table_19_responses() {
        let mut out = [0u8; MAX_LEN];
        let mut w = Writer::new(&mut out);
        w.header(7, 0x02, 1, 2);
        w.block(Format::Zero, 0, &[]).unwrap();
        w.error(ErrorNumber::OutOfRange).unwrap();
        w.set_negative();
        let n = w.len();
        assert_eq!(&out[..n], [7, 0x82, 1, 2, 0x40, 0, 0x44, 1, 0x00, 0x02]);
        let response = ParamResponsePdu::parse(&out[..n]).unwrap();
        assert!(response.negative());
        assert_eq!(response.values(1).unwrap().get(0), Some(2));
        // Three bytes of octets take a pad byte.
        let mut w = Writer::new(&mut out);
        w.header(7, 0x01, 1, 1);
        w.block(Format::Byte, 3, &[1, 2, 3]).unwrap();
        let n = w.len();
        assert_eq!(&out[..n], [7, 0x01, 1, 1, 0x41, 3, 1, 2, 3, 0]);
        assert!(ParamResponsePdu::parse(&out[..n]).is_some());
        // A positive change is the header alone.
        assert!(ParamResponsePdu::parse(&[7, 0x02, 1, 2]).is_some());
        assert!(ParamResponsePdu::parse(&[7, 0x02, 1, 2, 0x40, 0]).is_none());
    }

    #[test]
    fn malformed_requests_are_refused_before_anything_runs() {
        let read = build(RequestId::Read, &[address(0x396, 0, 0)], &[]);
        let mut bad_id = read.clone();
        bad_id[1] = 0x03;
        assert_eq!(
            ParamRequestPdu::parse(&bad_id),
            Err(RequestError::RequestId)
        );
        assert_eq!(
            RequestError::RequestId.error_number(),
            ErrorNumber::InvalidRequestId
        );
        let mut none = read.clone();
        none[3] = 0;
        assert_eq!(ParamRequestPdu::parse(&none), Err(RequestError::Layout));
        assert_eq!(
            ParamRequestPdu::parse(&read[..9]),
            Err(RequestError::Layout)
        );
        let mut trailing = read.clone();
        trailing.push(0);
        assert_eq!(ParamRequestPdu::parse(&trailing), Err(RequestError::Layout));
        let v = [0, 1];
        let bad_format = [Values {
            format: Format::Unknown(0x30),
            count: 1,
            bytes: &v,
        }];
        let mut out = [0u8; MAX_LEN];
        let n = build_request(
            &mut out,
            1,
            RequestId::Change,
            1,
            &[address(918, 0, 0)],
            &bad_format,
        )
        .unwrap();
        assert_eq!(ParamRequestPdu::parse(&out[..n]), Err(RequestError::Format));
        assert_eq!(
            RequestError::Layout.error_number(),
            ErrorNumber::IllegalAddress
        );
    }

    proptest::proptest! {
        #[test]
        fn parsing_never_panics(pdu in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..260)) {
            if let Ok(request) = ParamRequestPdu::parse(&pdu) {
                for i in 0..request.count() {
                    let _ = request.address(i);
                    let _ = request.values(i).map(|v| v.get(0));
                }
            }
            if let Some(response) = ParamResponsePdu::parse(&pdu) {
                for i in 0..usize::from(response.count) {
                    let _ = response.values(i);
                }
            }
        }

        #[test]
        fn built_requests_parse_back(
            reference in 1u8..=255, change: bool, axis in 0u8..=1,
            params in proptest::collection::vec((any_address(), 0u8..4, proptest::collection::vec(proptest::prelude::any::<u16>(), 0..4)), 1..8),
        ) {
            let addresses: Vec<ParamAddress> = params.iter().map(|p| p.0).collect();
            let bytes: Vec<Vec<u8>> = params.iter().map(|p| p.2.iter().flat_map(|w| w.to_be_bytes()).collect()).collect();
            let values: Vec<Values> = params.iter().zip(&bytes).map(|(p, b)| Values {
                format: Format::Word, count: p.2.len() as u8, bytes: b,
            }).collect();
            let id = if change { RequestId::Change } else { RequestId::Read };
            let mut out = [0u8; MAX_LEN];
            let n = build_request(&mut out, reference, id, axis, &addresses, if change { &values } else { &[] }).unwrap();
            let request = ParamRequestPdu::parse(&out[..n]).unwrap();
            proptest::prop_assert_eq!((request.reference, request.id, request.axis, request.count()), (reference, id, axis, addresses.len()));
            // Table 18: the same request with reference 0 or an axis past 1 is refused.
            let mut bad = out;
            bad[0] = 0;
            proptest::prop_assert_eq!(ParamRequestPdu::parse(&bad[..n]).err(), Some(RequestError::Reference));
            let mut bad = out;
            bad[2] = 2 + axis.wrapping_mul(97) % 254;
            proptest::prop_assert_eq!(ParamRequestPdu::parse(&bad[..n]).err(), Some(RequestError::Axis));
            for (i, a) in addresses.iter().enumerate() {
                proptest::prop_assert_eq!(request.address(i), *a);
                if change {
                    proptest::prop_assert_eq!(request.values(i), Some(values[i]));
                }
            }
        }
    }

    fn any_address() -> impl proptest::strategy::Strategy<Value = ParamAddress> {
        use proptest::prelude::*;
        (
            prop_oneof![Just(0x10u8), Just(0x20), Just(0x30)],
            any::<u8>(),
            any::<u16>(),
            any::<u16>(),
        )
            .prop_map(|(a, elements, number, subindex)| ParamAddress {
                attribute: Attribute::from(a),
                elements,
                number,
                subindex,
            })
    }
}
