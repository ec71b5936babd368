//! The PROFIdrive parameter server on DP-V1 (seed 004, "DP-V1 读 / 写请求时序"): a master
//! writes a parameter request to index 47, the adapter acknowledges it at once, and the master
//! reads until the response is there; while the adapter is still busy, the read gets DP-V1
//! error B5h (state conflict) and the master repeats it.
//!
//! Contract:
//! - One request at a time. A write while one is being executed is refused with B5h; a write
//!   after the response is ready replaces it (the master gave the old one up).
//! - The request is checked whole before anything runs ([`ParamRequestPdu::parse`]); a
//!   malformed one gets a negative response with one error block.
//! - Parameters run in order, in [`Dpv1Server::step`] (the application's cycle): the adapter's
//!   own (915-972) through [`Parameters`], the same code as the PKW channel; the drive's
//!   (xx.yy) as a [`ParamRequest`], so a write reaches the drive once and not at all when it
//!   holds the value. Nothing here waits for the drive.
//! - Slot 0 (the device) and 1 (the drive, as ABB's FPBA-01 addresses it) are served; another
//!   slot is B2h (invalid slot), another index B0h (invalid index).

use crate::drive::{Access, Drive, ParamRequest};
use crate::pd_access::{
    Attribute, Format, ParamRequestPdu, RequestId, Writer, MAX_LEN, MAX_PARAMETERS,
    PARAMETER_REQUEST_INDEX,
};
use crate::pd_params::{drive_access_for, link_error, Element, ErrorNumber, Parameters};
use dp_consts::dpv1::error;
use dp_slave::msac1::{Address, Request, Response};

/// PROFIdrive data types of a description's identifier (element 1).
const UNSIGNED16: u16 = 6;
const OCTET_STRING: u16 = 10;
/// Description elements the adapter has: 1 the identifier (data type), 2 the number of array
/// elements.
const DESCRIPTION_IDENTIFIER: u16 = 1;
const DESCRIPTION_ELEMENTS: u16 = 2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum State {
    Idle,
    /// Executing parameter `next`; `drive`: its drive access under way.
    Running {
        next: usize,
        drive: Option<ParamRequest>,
    },
    Done,
}

/// Counters for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dpv1Figures {
    pub requests: u32,
    pub responses: u32,
    pub busy_reads: u32,
    pub refused: u32,
}

impl Dpv1Figures {
    /// Nothing counted yet.
    pub const fn new() -> Dpv1Figures {
        Dpv1Figures {
            requests: 0,
            responses: 0,
            busy_reads: 0,
            refused: 0,
        }
    }
}

impl Default for Dpv1Figures {
    fn default() -> Self {
        Self::new()
    }
}

pub struct Dpv1Server {
    request: [u8; MAX_LEN],
    request_len: usize,
    state: State,
    answer: Answer,
    pub figures: Dpv1Figures,
}

/// The response being built, apart from the request it answers (which it reads while it
/// writes here).
struct Answer {
    bytes: [u8; MAX_LEN],
    len: usize,
    /// A change request's outcome per parameter (`None`: written).
    outcomes: [Option<ErrorNumber>; MAX_PARAMETERS],
}

impl Dpv1Server {
    /// Idle, nothing asked yet.
    pub const fn new() -> Dpv1Server {
        Dpv1Server {
            request: [0; MAX_LEN],
            request_len: 0,
            state: State::Idle,
            answer: Answer {
                bytes: [0; MAX_LEN],
                len: 0,
                outcomes: [None; MAX_PARAMETERS],
            },
            figures: Dpv1Figures::new(),
        }
    }
}

impl Default for Dpv1Server {
    fn default() -> Self {
        Self::new()
    }
}

/// The DP-V1 error for an address the server does not have.
fn check_address(at: Address) -> Result<(), u8> {
    if at.slot > 1 {
        Err(error::INVALID_SLOT)
    } else if at.index != PARAMETER_REQUEST_INDEX {
        Err(error::INVALID_INDEX)
    } else {
        Ok(())
    }
}

impl Dpv1Server {
    /// Whether a request is being executed.
    pub fn busy(&self) -> bool {
        matches!(self.state, State::Running { .. })
    }

    /// One MSAC1 request; the response PDU goes into `out` (its length is returned).
    pub fn serve(&mut self, request: &Request, out: &mut [u8]) -> usize {
        let response = match *request {
            Request::Write { at, data } => match self.write(at, data) {
                Ok(()) => Response::Write {
                    at,
                    length: data.len() as u8,
                },
                Err(code) => Response::error(true, code),
            },
            Request::Read { at, length } => match self.read(at) {
                Ok(()) => {
                    let len = self.answer.len.min(usize::from(length));
                    self.state = State::Idle;
                    self.figures.responses += 1;
                    Response::Read {
                        at,
                        data: &self.answer.bytes[..len],
                    }
                }
                Err(code) => Response::error(false, code),
            },
        };
        if matches!(response, Response::Error { .. }) {
            self.figures.refused += 1;
        }
        response.emit(out)
    }

    fn write(&mut self, at: Address, data: &[u8]) -> Result<(), u8> {
        check_address(at)?;
        if self.busy() {
            return Err(error::STATE_CONFLICT);
        }
        if data.len() > MAX_LEN {
            return Err(error::WRITE_LENGTH);
        }
        self.request[..data.len()].copy_from_slice(data);
        self.request_len = data.len();
        self.answer.len = 0;
        self.answer.outcomes = [None; MAX_PARAMETERS];
        self.state = State::Running {
            next: 0,
            drive: None,
        };
        self.figures.requests += 1;
        Ok(())
    }

    fn read(&mut self, at: Address) -> Result<(), u8> {
        check_address(at)?;
        match self.state {
            State::Done => Ok(()),
            // Still busy, or nothing was asked: the master reads again later.
            _ => {
                self.figures.busy_reads += 1;
                Err(error::STATE_CONFLICT)
            }
        }
    }

    /// Moves the request on by one parameter, as far as the drive's answers allow; whether it
    /// moved (a caller with time to spare calls again).
    pub fn step(&mut self, params: &mut Parameters, drive: &mut impl Drive, ppo: u8) -> bool {
        let State::Running {
            mut next,
            drive: mut drive_request,
        } = self.state
        else {
            return false;
        };
        let bytes = &self.request[..self.request_len];
        let pdu = match ParamRequestPdu::parse(bytes) {
            Ok(pdu) => pdu,
            Err(e) => {
                let (reference, id, axis) =
                    ParamRequestPdu::header(bytes).unwrap_or((0, RequestId::Read, 0));
                // Table 19 has two negative response IDs: a change's (82h), and a read's
                // (81h), which also answers a request ID that is neither.
                let nak = match id {
                    RequestId::Change => 0x82,
                    _ => 0x81,
                };
                let mut w = Writer::new(&mut self.answer.bytes);
                w.header(reference, nak, axis, 1);
                let _ = w.error(e.error_number());
                self.answer.len = w.len();
                self.state = State::Done;
                return true;
            }
        };
        if next == 0 && drive_request.is_none() && self.answer.len == 0 {
            let mut w = Writer::new(&mut self.answer.bytes);
            w.header(pdu.reference, pdu.id.into(), pdu.axis, pdu.count() as u8);
            self.answer.len = w.len();
        }
        // One parameter per call: a step of the application's cycle stays short whatever
        // the request holds (a Data_Exchange waits for the step under way).
        if next < pdu.count() {
            let outcome = match pdu.id {
                RequestId::Read => {
                    self.answer
                        .read_one(&pdu, next, params, drive, ppo, &mut drive_request)
                }
                // Seed 004 lines 1078-1090: PPO1, 2 and 5 change parameters through their
                // PKW channel only; over DP-V1 they read. Each write is refused with 0Bh (no
                // operation priority), nothing changed.
                _ if ppo_has_pkw(ppo) => {
                    self.answer.outcomes[next] = Some(ErrorNumber::NoChangeRights);
                    Some(())
                }
                _ => self
                    .answer
                    .change_one(&pdu, next, params, drive, &mut drive_request),
            };
            let moved = outcome.is_some();
            if moved {
                drive_request = None;
                next += 1;
            }
            self.state = State::Running {
                next,
                drive: drive_request,
            };
            return moved;
        }
        if pdu.id == RequestId::Change
            && self.answer.outcomes[..pdu.count()]
                .iter()
                .any(Option::is_some)
        {
            let mut w = Writer::new(&mut self.answer.bytes);
            w.header(pdu.reference, 0x82, pdu.axis, pdu.count() as u8);
            for outcome in &self.answer.outcomes[..pdu.count()] {
                let _ = match outcome {
                    None => w.block(Format::Zero, 0, &[]),
                    Some(e) => w.error(*e),
                };
            }
            self.answer.len = w.len();
        }
        self.state = State::Done;
        true
    }
}

impl Answer {
    /// Appends parameter `i`'s values (or error) to a read response; `None` while the drive
    /// has not answered.
    fn read_one(
        &mut self,
        pdu: &ParamRequestPdu,
        i: usize,
        params: &mut Parameters,
        drive: &mut impl Drive,
        ppo: u8,
        drive_request: &mut Option<ParamRequest>,
    ) -> Option<()> {
        let address = pdu.address(i);
        let mut words = [0u8; MAX_LEN];
        let result: Result<(Format, usize, usize), ErrorNumber> = match address.attribute {
            Attribute::Text => Err(ErrorNumber::TextArray),
            Attribute::Description => {
                description(params, address.number, address.subindex).map(|v| {
                    words[..2].copy_from_slice(&v.to_be_bytes());
                    (Format::Word, 1, 2)
                })
            }
            Attribute::Value if address.number >= 900 => {
                own_values(params, &address, ppo, &mut words)
            }
            Attribute::Value => match drive_access(&address, None) {
                Err(e) => Err(e),
                Ok(access) => {
                    let request = drive_request.get_or_insert(ParamRequest::new(access));
                    match request.poll(drive)? {
                        Ok(v) => {
                            words[..2].copy_from_slice(&v.to_be_bytes());
                            Ok((Format::Word, 1, 2))
                        }
                        Err(e) => Err(link_error(e)),
                    }
                }
            },
            Attribute::Unknown(_) => Err(ErrorNumber::IllegalAddress),
        };
        let mut w = Writer::resume(&mut self.bytes, self.len);
        let fits = match result {
            Ok((format, count, len)) => w.block(format, count as u8, &words[..len]),
            Err(_) => None,
        };
        if fits.is_none() {
            let e = result.err().unwrap_or(ErrorNumber::ResponseTooLong);
            let _ = w.error(e);
            w.set_negative();
        }
        self.len = w.len();
        Some(())
    }

    /// Executes parameter `i` of a change request and notes its outcome; `None` while the
    /// drive has not answered.
    fn change_one(
        &mut self,
        pdu: &ParamRequestPdu,
        i: usize,
        params: &mut Parameters,
        drive: &mut impl Drive,
        drive_request: &mut Option<ParamRequest>,
    ) -> Option<()> {
        let address = pdu.address(i);
        let values = pdu.values(i);
        let word_values = values.filter(|v| v.format.value_size() == Some(2));
        let outcome = match (address.attribute, values, word_values) {
            (Attribute::Text, ..) => Err(ErrorNumber::TextArray),
            (Attribute::Description, ..) => Err(ErrorNumber::ElementReadOnly),
            (Attribute::Unknown(_), ..) => Err(ErrorNumber::IllegalAddress),
            (_, None, _) => Err(ErrorNumber::IllegalAddress),
            (_, Some(_), None) => Err(ErrorNumber::IllegalFormat),
            (_, Some(v), Some(_)) if usize::from(v.count) != address.count() => {
                Err(ErrorNumber::ValueCountMismatch)
            }
            (_, _, Some(v)) if address.number >= 900 => (0..address.count()).try_for_each(|k| {
                let value = v.get(k).unwrap_or(0) as u16;
                let subindex = address.subindex.saturating_add(k as u16);
                params.write_word(address.number, subindex, value)
            }),
            (_, _, Some(v)) => match drive_access(&address, Some(v.get(0).unwrap_or(0) as u16)) {
                Err(e) => Err(e),
                Ok(access) => {
                    let request = drive_request.get_or_insert(ParamRequest::new(access));
                    request.poll(drive)?.map(|_| ()).map_err(link_error)
                }
            },
        };
        self.outcomes[i] = outcome.err();
        Some(())
    }
}

/// Whether PPO `number` has a PKW channel (PPO1, 2, 5).
fn ppo_has_pkw(number: u8) -> bool {
    crate::ppo::Ppo::ALL
        .iter()
        .any(|p| p.number() == number && p.has_pkw())
}

/// The drive access a DP-V1 address asks for (a read, or a write of `write`): the drive
/// parameter's number is xx.yy x 100 with its high byte in the parameter number and its low
/// byte in the subindex (seed 004, example 1a); one element only.
fn drive_access(
    address: &crate::pd_access::ParamAddress,
    write: Option<u16>,
) -> Result<Access, ErrorNumber> {
    // Data sets (number 0, subindex 1-99) belong to ABB drives: this drive has none, and
    // `drive_parameter` finds no group 0.
    if address.number > 0xFF || address.subindex > 0xFF {
        return Err(ErrorNumber::IllegalPnu);
    }
    if address.elements > 1 {
        return Err(ErrorNumber::NotAnArray);
    }
    drive_access_for(address.number << 8 | address.subindex, write.map(u32::from))
}

/// An adapter parameter's values: `count` elements from the subindex, as words, or its
/// octets. Returns the format, the value count and the bytes used in `out`.
fn own_values(
    params: &mut Parameters,
    address: &crate::pd_access::ParamAddress,
    ppo: u8,
    out: &mut [u8; MAX_LEN],
) -> Result<(Format, usize, usize), ErrorNumber> {
    let count = address.count();
    if count * 2 > MAX_LEN - 8 {
        return Err(ErrorNumber::ResponseTooLong);
    }
    for k in 0..count {
        let subindex = address.subindex.saturating_add(k as u16);
        match params.read_element(address.number, subindex, ppo)? {
            Element::Word(v) => out[2 * k..2 * k + 2].copy_from_slice(&v.to_be_bytes()),
            Element::Octets { bytes, len } if count == 1 => {
                let len = usize::from(len);
                out[..len].copy_from_slice(&bytes[..len]);
                return Ok((Format::Byte, len, len));
            }
            Element::Octets { .. } => return Err(ErrorNumber::NotAnArray),
        }
    }
    Ok((Format::Word, count, 2 * count))
}

/// Element `subindex` of an adapter parameter's description: 1 the identifier (its data
/// type), 2 the number of array elements (0 for a simple parameter). A drive parameter has
/// none: its subindex is half of its number (seed 004, example 1a), so no element could be
/// addressed.
fn description(params: &mut Parameters, number: u16, subindex: u16) -> Result<u16, ErrorNumber> {
    if number < 900 {
        return Err(ErrorNumber::NoDataType);
    }
    let (elements, _) = params.shape(number)?;
    let octets = matches!(
        params.read_element(number, 0, 0),
        Ok(Element::Octets { .. })
    );
    match subindex {
        DESCRIPTION_IDENTIFIER => Ok(if octets { OCTET_STRING } else { UNSIGNED16 }),
        DESCRIPTION_ELEMENTS => Ok(elements as u16),
        _ => Err(ErrorNumber::NoDataType),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pd_access::{build_request, ParamAddress, ParamResponsePdu, Values};
    use crate::testing::MockDrive;
    use dp_slave::msac1::MAX_PDU_LEN;

    const AT: Address = Address {
        slot: 1,
        index: PARAMETER_REQUEST_INDEX,
    };

    fn value(number: u16, subindex: u16, elements: u8) -> ParamAddress {
        ParamAddress::value(number, subindex, elements)
    }

    /// A master's write of the request, the server's steps, and its read of the response.
    struct Bench {
        server: Dpv1Server,
        params: Parameters,
        drive: MockDrive,
        /// The PPO in force (3: no PKW).
        ppo: u8,
    }

    impl Bench {
        fn new() -> Bench {
            Bench {
                server: Dpv1Server::default(),
                params: Parameters::default(),
                drive: MockDrive::default(),
                ppo: 3,
            }
        }

        fn msac1(&mut self, request: Request) -> Vec<u8> {
            let mut out = [0u8; MAX_PDU_LEN];
            let n = self.server.serve(&request, &mut out);
            out[..n].to_vec()
        }

        /// Writes `pdu`, runs the server, reads the response; returns its PROFIdrive bytes.
        fn exchange(&mut self, pdu: &[u8]) -> Vec<u8> {
            let ack = self.msac1(Request::Write { at: AT, data: pdu });
            assert_eq!(
                ack,
                [0x5F, 1, 47, pdu.len() as u8],
                "the write is acknowledged at once"
            );
            while self
                .server
                .step(&mut self.params, &mut self.drive, self.ppo)
            {}
            let read = self.msac1(Request::Read {
                at: AT,
                length: 240,
            });
            assert_eq!(read[..3], [0x5E, 1, 47], "{read:02X?}");
            read[4..].to_vec()
        }

        fn request(
            &mut self,
            id: RequestId,
            addresses: &[ParamAddress],
            values: &[Values],
        ) -> Vec<u8> {
            let mut out = [0u8; MAX_LEN];
            let n = build_request(&mut out, 0x21, id, 1, addresses, values).unwrap();
            self.exchange(&out[..n])
        }
    }

    fn word(v: u16) -> [u8; 2] {
        v.to_be_bytes()
    }

    /// Seed 004 example 1a and 1b: drive parameters 12.04 (and 12.05, 12.06) read.
    #[test]
    fn seed_004_examples_1a_1b_read_drive_parameters() {
        let mut b = Bench::new();
        // 12.04 .. 12.06 are seed 000's FB.04 .. FB.06 on this drive (group 12 is FB).
        b.drive.set(0xFB04, 1500);
        b.drive.set(0xFB05, 2500);
        b.drive.set(0xFB06, 30);
        let one = b.request(RequestId::Read, &[value(4, 0xB4, 0)], &[]);
        assert_eq!(one, [0x21, 0x01, 1, 1, 0x42, 1, 0x05, 0xDC]);
        let three = b.request(
            RequestId::Read,
            &[value(4, 0xB4, 0), value(4, 0xB5, 0), value(4, 0xB6, 0)],
            &[],
        );
        assert_eq!(
            three,
            [0x21, 0x01, 1, 3, 0x42, 1, 0x05, 0xDC, 0x42, 1, 0x09, 0xC4, 0x42, 1, 0, 30]
        );
    }

    /// Example 2b: 300 to 12.02 and 500 to 12.03 in one request; a positive change response
    /// is the header alone. The same request again writes nothing (the drive holds the values).
    #[test]
    fn seed_004_example_2b_write_two_values_once() {
        let mut b = Bench::new();
        let (v300, v500) = (word(300), word(500));
        let values = [Values::word(&v300), Values::word(&v500)];
        let addresses = [value(4, 0xB2, 0), value(4, 0xB3, 0)];
        let response = b.request(RequestId::Change, &addresses, &values);
        assert_eq!(response, [0x21, 0x02, 1, 2]);
        assert_eq!((b.drive.get(0xFB02), b.drive.get(0xFB03)), (300, 500));
        let writes = b.drive.persistent_writes;
        assert_eq!(writes, 2);
        b.request(RequestId::Change, &addresses, &values);
        assert_eq!(
            b.drive.persistent_writes, writes,
            "values the drive holds are not written"
        );
    }

    /// Seed 004 lines 1078-1090 (and its Chk_Cfg table): with PPO1, 2 and 5 the PKW channel
    /// changes parameters and DP-V1 only reads them; a DP-V1 write is refused parameter by
    /// parameter with 0Bh (no operation priority), the drive untouched. PPO3, 4 and 6 write.
    #[test]
    fn seed_004_lines_1078_1090_dpv1_writes_only_with_ppo_3_4_6() {
        let (v300, v500) = (word(300), word(500));
        let values = [Values::word(&v300), Values::word(&v500)];
        let addresses = [value(4, 0xB2, 0), value(4, 0xB3, 0)];
        for ppo in 1..=6u8 {
            let mut b = Bench::new();
            b.ppo = ppo;
            let response = b.request(RequestId::Change, &addresses, &values);
            let read = b.request(RequestId::Read, &[value(4, 0xB2, 0)], &[]);
            if matches!(ppo, 1 | 2 | 5) {
                assert_eq!(
                    response,
                    [0x21, 0x82, 1, 2, 0x44, 1, 0, 0x0B, 0x44, 1, 0, 0x0B],
                    "PPO{ppo}"
                );
                assert_eq!(b.drive.persistent_writes, 0, "PPO{ppo}");
                assert_eq!(read[..2], [0x21, 0x01], "PPO{ppo} reads");
            } else {
                assert_eq!(response, [0x21, 0x02, 1, 2], "PPO{ppo}");
                assert_eq!(read, [0x21, 0x01, 1, 1, 0x42, 1, 0x01, 0x2C], "PPO{ppo}");
            }
        }
    }

    /// Examples 3-5: 918 read, 915 and 916 subindex 3 written (PZD3 to 12.06 and from 12.05).
    #[test]
    fn seed_004_examples_3_4_5_profidrive_parameters() {
        let mut b = Bench::new();
        b.params.node_address = 8;
        let response = b.request(RequestId::Read, &[value(918, 0, 0)], &[]);
        assert_eq!(response, [0x21, 0x01, 1, 1, 0x42, 1, 0, 8]);
        for (number, v) in [(915u16, 0x4B6u16), (916, 0x4B5)] {
            let bytes = word(v);
            let values = [Values::word(&bytes)];
            let response = b.request(RequestId::Change, &[value(number, 3, 1)], &values);
            assert_eq!(response, [0x21, 0x02, 1, 1], "{number}");
        }
        assert_eq!((b.params.pzd_out[2], b.params.pzd_in[2]), (0x4B6, 0x4B5));
        // The same parameters as the PKW channel: 915 read back through its array.
        let response = b.request(RequestId::Read, &[value(915, 1, 3)], &[]);
        assert_eq!(&response[4..], [0x42, 3, 0, 0, 0, 0, 0x04, 0xB6]);
    }

    /// 964 (device identification, the Ident_Number) and the fault buffer 945/947.
    #[test]
    fn device_identification_and_fault_buffer() {
        let mut b = Bench::new();
        b.params.fault_codes[0] = 0x2300;
        b.params.fault_numbers[0] = 12;
        let response = b.request(
            RequestId::Read,
            &[value(964, 0, 0), value(945, 1, 1), value(947, 1, 1)],
            &[],
        );
        let [id0, id1] = word(dp_consts::ADAPTER_IDENT_NUMBER);
        assert_eq!(
            response,
            [0x21, 0x01, 1, 3, 0x42, 1, id0, id1, 0x42, 1, 0x23, 0x00, 0x42, 1, 0, 12]
        );
    }

    /// Table 21's errors, each in its parameter's block of a negative response (81h/82h).
    #[test]
    fn seed_004_table_21_errors() {
        let mut b = Bench::new();
        let response = b.request(
            RequestId::Read,
            &[
                value(964, 0, 0),
                value(999, 0, 0),
                ParamAddress {
                    attribute: Attribute::Text,
                    ..value(918, 0, 0)
                },
                value(945, 99, 1),
                value(0, 1, 0),
            ],
            &[],
        );
        let parsed = ParamResponsePdu::parse(&response).unwrap();
        assert_eq!(parsed.id, 0x81);
        let error = |i| {
            parsed
                .values(i)
                .filter(|v| v.format == Format::Error)
                .and_then(|v| v.get(0))
        };
        assert_eq!(parsed.values(0).unwrap().format, Format::Word);
        assert_eq!(error(1), Some(0x00), "parameter number not allowed");
        assert_eq!(error(2), Some(0x0F), "text is not supported");
        assert_eq!(error(3), Some(0x03), "invalid subindex");
        assert_eq!(error(4), Some(0x00), "no data sets");
        // A write out of range, a read-only one, and a wrong value count; the one that
        // worked gets format 40h.
        let (v2, v5) = (word(2), word(5));
        let response = b.request(
            RequestId::Change,
            &[
                value(927, 0, 0),
                value(928, 0, 0),
                value(964, 0, 0),
                value(918, 0, 0),
            ],
            &[
                Values::word(&v2),
                Values {
                    format: Format::Word,
                    count: 1,
                    bytes: &word(0),
                },
                Values::word(&v5),
                Values {
                    format: Format::Word,
                    count: 0,
                    bytes: &[],
                },
            ],
        );
        let parsed = ParamResponsePdu::parse(&response).unwrap();
        assert_eq!(parsed.id, 0x82);
        let error = |i| {
            parsed
                .values(i)
                .filter(|v| v.format == Format::Error)
                .and_then(|v| v.get(0))
        };
        assert_eq!(error(0), Some(0x02), "value out of range");
        assert_eq!(parsed.values(1).unwrap().format, Format::Zero);
        assert_eq!(error(2), Some(0x01), "read only");
        assert_eq!(error(3), Some(0x18), "number of values inconsistent");
        assert_eq!(b.params.pzd_rights, 0);
    }

    /// While the drive has not answered, a read gets B5h and the master reads again; a
    /// second write is refused the same way; a slot or an index the server does not have is
    /// B2h or B0h.
    #[test]
    fn busy_slot_and_index_errors() {
        let mut b = Bench::new();
        let mut out = [0u8; MAX_LEN];
        let n = build_request(&mut out, 5, RequestId::Read, 1, &[value(4, 0xB4, 0)], &[]).unwrap();
        assert_eq!(
            b.msac1(Request::Read {
                at: AT,
                length: 240
            }),
            [0xDE, 0x80, 0xB5, 0],
            "nothing asked"
        );
        b.msac1(Request::Write {
            at: AT,
            data: &out[..n],
        });
        assert_eq!(
            b.msac1(Request::Read {
                at: AT,
                length: 240
            }),
            [0xDE, 0x80, 0xB5, 0],
            "busy"
        );
        assert_eq!(
            b.msac1(Request::Write {
                at: AT,
                data: &out[..n]
            }),
            [0xDF, 0x80, 0xB5, 0]
        );
        let slot = Address { slot: 2, ..AT };
        assert_eq!(
            b.msac1(Request::Read {
                at: slot,
                length: 240
            }),
            [0xDE, 0x80, 0xB2, 0]
        );
        let index = Address { index: 48, ..AT };
        assert_eq!(
            b.msac1(Request::Write {
                at: index,
                data: &out[..n]
            }),
            [0xDF, 0x80, 0xB0, 0]
        );
        while b.server.step(&mut b.params, &mut b.drive, 3) {}
        assert_eq!(
            b.msac1(Request::Read {
                at: AT,
                length: 240
            })[..2],
            [0x5E, 1]
        );
        assert_eq!(b.server.figures.busy_reads, 2);
    }

    /// Attribute 20h: element 1 the identifier (Unsigned16 6, OctetString 10), element 2 the
    /// number of array elements; a drive parameter has no description (09h).
    #[test]
    fn descriptions_of_the_adapters_parameters() {
        let mut b = Bench::new();
        let description = |number, subindex| ParamAddress {
            attribute: Attribute::Description,
            ..value(number, subindex, 0)
        };
        let response = b.request(
            RequestId::Read,
            &[
                description(915, 1),
                description(915, 2),
                description(918, 2),
                description(919, 1),
                description(4, 2),
            ],
            &[],
        );
        let parsed = ParamResponsePdu::parse(&response).unwrap();
        let word = |i| parsed.values(i).and_then(|v| v.get(0));
        assert_eq!(
            (word(0), word(1), word(2), word(3)),
            (Some(6), Some(10), Some(0), Some(10))
        );
        let v = parsed.values(4).unwrap();
        assert_eq!((v.format, v.get(0)), (Format::Error, Some(0x09)));
    }

    /// Slot 0 (the device) is served like slot 1.
    #[test]
    fn slot_0_is_served_too() {
        let mut b = Bench::new();
        let at = Address { slot: 0, ..AT };
        let mut out = [0u8; MAX_LEN];
        let n = build_request(&mut out, 5, RequestId::Read, 1, &[value(918, 0, 0)], &[]).unwrap();
        assert_eq!(
            b.msac1(Request::Write {
                at,
                data: &out[..n]
            })[..2],
            [0x5F, 0]
        );
        while b.server.step(&mut b.params, &mut b.drive, 3) {}
        assert_eq!(b.msac1(Request::Read { at, length: 240 })[..2], [0x5E, 0]);
    }

    /// A drive that does not answer: the request ends with error 6Fh (timeout), it does not
    /// hang.
    #[test]
    fn an_unplugged_drive_gives_an_error_not_a_hang() {
        let mut b = Bench::new();
        b.drive.disconnected = true;
        let response = b.request(RequestId::Read, &[value(4, 0xB4, 0)], &[]);
        let parsed = ParamResponsePdu::parse(&response).unwrap();
        assert_eq!(parsed.id, 0x81);
        assert_eq!(parsed.values(0).unwrap().format, Format::Error);
    }

    #[test]
    fn a_malformed_request_is_answered_with_one_error() {
        let mut b = Bench::new();
        let response = b.exchange(&[9, 0x07, 1, 1]);
        assert_eq!(response, [9, 0x81, 1, 1, 0x44, 1, 0, 0x90]);
        let response = b.exchange(&[9, 0x01, 1, 2, 0x10]);
        assert_eq!(response, [9, 0x81, 1, 1, 0x44, 1, 0, 0x16]);
    }

    /// Seed 004 tables 18 and 19: a request reference is 1 .. 255 and the axis 0 or 1; a
    /// request with reference 0 or axis 2-255 is refused with error 66h (request not
    /// supported, table 21), the header mirrored; an invalid request ID is answered 81h (table
    /// 19 has 01h, 81h, 02h and 82h only) with error 90h, and never 83h or 87h.
    #[test]
    fn seed_004_tables_18_19_the_request_header_is_checked() {
        let mut b = Bench::new();
        // Reference 1, read, axis 1, one parameter: value of 4.B4 (seed 004 example 1a's 12.04).
        let read = [0x01, 0x01, 0x01, 0x01, 0x10, 0x01, 0x00, 0x04, 0x00, 0xB4];
        let mut zero_ref = read;
        zero_ref[0] = 0;
        assert_eq!(b.exchange(&zero_ref), [0, 0x81, 1, 1, 0x44, 1, 0, 0x66]);
        for axis in [2u8, 7, 255] {
            let mut request = read;
            request[2] = axis;
            assert_eq!(b.exchange(&request), [1, 0x81, axis, 1, 0x44, 1, 0, 0x66]);
        }
        let change = [
            0x05, 0x02, 0x03, 0x01, 0x10, 0x01, 0x00, 0x04, 0x00, 0xB4, 0x42, 0x01, 0x00, 0x01,
        ];
        assert_eq!(b.exchange(&change), [5, 0x82, 3, 1, 0x44, 1, 0, 0x66]);
        for id in [0x00u8, 0x03, 0x07, 0x7F, 0xFF] {
            let mut request = read;
            request[1] = id;
            let response = b.exchange(&request);
            assert_eq!(
                response,
                [1, 0x81, 1, 1, 0x44, 1, 0, 0x90],
                "request ID {id:#04x}"
            );
        }
        // Axis 0 and 1 both read.
        for axis in [0u8, 1] {
            let mut request = read;
            request[2] = axis;
            assert_eq!(b.exchange(&request)[..2], [1, 0x01]);
        }
    }

    proptest::proptest! {
        /// Any bytes written as a request are answered, and nothing panics.
        #[test]
        fn any_request_is_answered(pdu in proptest::collection::vec(proptest::prelude::any::<u8>(), 1..240)) {
            let mut b = Bench::new();
            let response = b.exchange(&pdu);
            proptest::prop_assert!(response.len() >= 4);
            if pdu.len() >= 4 {
                proptest::prop_assert_eq!(response[0], pdu[0], "the reference is mirrored");
            }
        }
    }
}
