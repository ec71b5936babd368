//! The frame control byte (FC) of SD1, SD2 and SD3 telegrams.
//!
//! ```text
//!  bit   7    6     5     4    3..0
//! req    0    1    FCB   FCV   function (RequestFunction)
//! resp   0    0   station type  status  (ResponseStatus)
//! ```
//! Every byte with bit 7 clear decodes, and encodes back to itself: unknown function and status
//! codes are kept in `Unknown`. Bit 7 is reserved; [`FrameControl::from_byte`] rejects it.

use crate::Error;

use dp_consts::code_point;

code_point! {
    /// Function code of a request (FC bits 0-3 with bit 6 set).
    pub enum RequestFunction {
        /// Time event / clock value.
        TimeEvent = 0x0,
        /// Send data with acknowledge, low priority.
        SdaLow = 0x3,
        /// Send data with no acknowledge, low priority.
        SdnLow = 0x4,
        /// Send data with acknowledge, high priority.
        SdaHigh = 0x5,
        /// Send data with no acknowledge, high priority.
        SdnHigh = 0x6,
        /// Send and request data, multicast.
        Msrd = 0x7,
        /// Request FDL status.
        FdlStatus = 0x9,
        /// Send and request data, low priority.
        SrdLow = 0xC,
        /// Send and request data, high priority.
        SrdHigh = 0xD,
        /// Request ident.
        Ident = 0xE,
        /// Request LSAP status.
        LsapStatus = 0xF,
    }
}

code_point! {
    /// Status of a response (FC bits 0-3 with bit 6 clear).
    pub enum ResponseStatus {
        /// Positive acknowledgement.
        Ok = 0x0,
        /// User error.
        UserError = 0x1,
        /// No resources.
        NoResources = 0x2,
        /// SAP not activated (RS).
        SapNotActivated = 0x3,
        /// Data low: response data, no diagnosis pending.
        DataLow = 0x8,
        /// No response data (NR).
        NoData = 0x9,
        /// Data high: response data, diagnosis pending.
        DataHigh = 0xA,
        /// Response data low, not acknowledged (RDL).
        NotAckDataLow = 0xC,
        /// Response data high, not acknowledged (RDH).
        NotAckDataHigh = 0xD,
    }
}

code_point! {
    /// The responder's station type (FC bits 4-5 of a response).
    pub enum StationType {
        Slave = 0,
        MasterNotReady = 1,
        MasterReady = 2,
        MasterInRing = 3,
    }
}

impl RequestFunction {
    /// Whether the requester expects an answer (SRD, SDA, FDL status, ident, LSAP status).
    pub fn expects_response(self) -> bool {
        !matches!(
            self,
            RequestFunction::SdnLow | RequestFunction::SdnHigh | RequestFunction::TimeEvent
        )
    }

    /// Whether this is a send-and-request-data function (SRD low or high).
    pub fn is_srd(self) -> bool {
        matches!(self, RequestFunction::SrdLow | RequestFunction::SrdHigh)
    }
}

/// A decoded frame control byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameControl {
    Request {
        /// Frame count bit: toggles per acknowledged request.
        fcb: bool,
        /// Frame count valid: the FCB is to be checked.
        fcv: bool,
        function: RequestFunction,
    },
    Response {
        station_type: StationType,
        status: ResponseStatus,
    },
}

const REQUEST: u8 = 0x40;
const FCB: u8 = 0x20;
const FCV: u8 = 0x10;
const RESERVED: u8 = 0x80;

impl FrameControl {
    /// Decodes a frame control byte; only bit 7 is refused.
    pub fn from_byte(byte: u8) -> Result<FrameControl, Error> {
        if byte & RESERVED != 0 {
            return Err(Error::ReservedFcBit);
        }
        Ok(if byte & REQUEST != 0 {
            FrameControl::Request {
                fcb: byte & FCB != 0,
                fcv: byte & FCV != 0,
                function: RequestFunction::from(byte & 0x0F),
            }
        } else {
            FrameControl::Response {
                station_type: StationType::from((byte >> 4) & 0x03),
                status: ResponseStatus::from(byte & 0x0F),
            }
        })
    }

    /// Encodes the byte. Codes held in `Unknown` are masked to their field width.
    pub fn to_byte(self) -> u8 {
        match self {
            FrameControl::Request { fcb, fcv, function } => {
                REQUEST
                    | if fcb { FCB } else { 0 }
                    | if fcv { FCV } else { 0 }
                    | (u8::from(function) & 0x0F)
            }
            FrameControl::Response {
                station_type,
                status,
            } => ((u8::from(station_type) & 0x03) << 4) | (u8::from(status) & 0x0F),
        }
    }

    /// Whether the value survives `from_byte(to_byte())` unchanged: `Unknown` codes must fit
    /// their field and must not shadow a named code.
    pub fn is_canonical(self) -> bool {
        FrameControl::from_byte(self.to_byte()) == Ok(self)
    }

    /// A slave's response with the given status.
    pub const fn slave_response(status: ResponseStatus) -> FrameControl {
        FrameControl::Response {
            station_type: StationType::Slave,
            status,
        }
    }

    /// The request function, if this is a request.
    pub fn function(self) -> Option<RequestFunction> {
        match self {
            FrameControl::Request { function, .. } => Some(function),
            FrameControl::Response { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_with_bit7_clear_round_trips() {
        for byte in 0..=0x7F_u8 {
            let fc = FrameControl::from_byte(byte).unwrap();
            assert_eq!(fc.to_byte(), byte, "{byte:#04x}");
            assert!(fc.is_canonical());
        }
        for byte in 0x80..=0xFF_u8 {
            assert_eq!(FrameControl::from_byte(byte), Err(Error::ReservedFcBit));
        }
    }

    #[test]
    fn protocol_md_frame_controls() {
        // 0x6D, the Siemens master's first Slave_Diag: request, FCB=1, FCV=0, SRD_HI.
        assert_eq!(
            FrameControl::from_byte(0x6D),
            Ok(FrameControl::Request {
                fcb: true,
                fcv: false,
                function: RequestFunction::SrdHigh
            })
        );
        // 0x5D: FCB=0, FCV=1, SRD_HI.
        assert_eq!(
            FrameControl::from_byte(0x5D),
            Ok(FrameControl::Request {
                fcb: false,
                fcv: true,
                function: RequestFunction::SrdHigh
            })
        );
        // 0x46: Global_Control as SDN_HI; 0x49: FDL_Status; 0x4D: SRD_HI.
        assert_eq!(
            FrameControl::from_byte(0x46).unwrap().function(),
            Some(RequestFunction::SdnHigh)
        );
        assert_eq!(
            FrameControl::from_byte(0x49).unwrap().function(),
            Some(RequestFunction::FdlStatus)
        );
        // 0x08: a slave's DL response; 0x00: OK from a slave (FDL_Status reply of PROTOCOL.md).
        assert_eq!(
            FrameControl::from_byte(0x08),
            Ok(FrameControl::slave_response(ResponseStatus::DataLow))
        );
        assert_eq!(
            FrameControl::from_byte(0x00),
            Ok(FrameControl::slave_response(ResponseStatus::Ok))
        );
    }

    #[test]
    fn unknown_codes_that_shadow_named_ones_are_not_canonical() {
        let fc = FrameControl::Request {
            fcb: false,
            fcv: false,
            function: RequestFunction::Unknown(0x0C),
        };
        assert!(!fc.is_canonical());
        let fc = FrameControl::Request {
            fcb: false,
            fcv: false,
            function: RequestFunction::Unknown(0x01),
        };
        assert!(fc.is_canonical());
    }

    #[test]
    fn sdn_expects_no_response() {
        assert!(!RequestFunction::SdnHigh.expects_response());
        assert!(!RequestFunction::SdnLow.expects_response());
        assert!(RequestFunction::SrdLow.expects_response());
        assert!(RequestFunction::FdlStatus.expects_response());
    }
}
