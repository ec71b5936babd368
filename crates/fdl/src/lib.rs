//! PROFIBUS FDL telegrams on the wire: SD1, SD2, SD3, SD4 and SC.
//!
//! The shape follows smoltcp's `wire` modules: [`Telegram`] is a zero-copy view over a byte
//! buffer, [`Repr`] is the parsed, owned-nothing representation, and [`FrameControl`] and
//! [`Sap`] are code points that keep an `Unknown` variant so that no byte is ever lost.
//!
//! # The no-panic contract
//! - [`Telegram::new_checked`] and [`Repr::parse`] never panic, on any input of any length; a
//!   malformed telegram is rejected with an [`Error`] that says why.
//! - [`Repr::emit`] never panics on a buffer of at least [`Repr::buffer_len`] bytes and returns
//!   [`Error::BufferTooShort`] on a shorter one; `Repr::parse(emit(x)) == x` for every `x`
//!   that [`Repr::check`] accepts.
//! - [`Telegram::new_unchecked`] accessors may panic on a buffer that was not checked.
#![cfg_attr(not(test), no_std)]
#![deny(unsafe_code)]

mod fc;
mod telegram;

pub use fc::{FrameControl, RequestFunction, ResponseStatus, StationType};
pub use telegram::{fcs, DataRepr, Repr, Sap, Telegram};

/// Why a telegram was rejected or could not be emitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The buffer ends before the telegram does.
    Truncated,
    /// The first byte is none of SD1, SD2, SD3, SD4, SC.
    UnknownDelimiter(u8),
    /// SD2: LE and LEr differ.
    LengthMismatch,
    /// SD2: LE outside 4..=249.
    BadLength(u8),
    /// SD2: the fourth byte is not a second SD2.
    BadSecondDelimiter(u8),
    /// The checksum byte is not the sum of DA..DU.
    BadFcs { expected: u8, found: u8 },
    /// The byte after the FCS is not ED (0x16).
    NoEndDelimiter(u8),
    /// Frame control bit 7 is reserved and must be 0.
    ReservedFcBit,
    /// DA or SA announces a SAP byte that the data unit does not hold.
    MissingSap,
    /// A SAP byte with the segment or further-extension bit set (not used by DP).
    UnsupportedSapExtension(u8),
    /// SD4 addresses must not carry the extension bit.
    BadTokenAddress,
    /// Emit: the data unit does not fit any telegram (more than 246 bytes).
    DataTooLong,
    /// Emit: an address above 127 or a SAP above 63.
    AddressOutOfRange,
    /// Emit: the buffer is shorter than [`Repr::buffer_len`].
    BufferTooShort,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Truncated => write!(f, "telegram truncated"),
            Error::UnknownDelimiter(b) => write!(f, "unknown start delimiter {b:#04x}"),
            Error::LengthMismatch => write!(f, "LE and LEr differ"),
            Error::BadLength(le) => write!(f, "LE {le} outside 4..=249"),
            Error::BadSecondDelimiter(b) => write!(f, "second SD2 is {b:#04x}"),
            Error::BadFcs { expected, found } => {
                write!(f, "FCS {found:#04x}, expected {expected:#04x}")
            }
            Error::NoEndDelimiter(b) => write!(f, "end delimiter is {b:#04x}"),
            Error::ReservedFcBit => write!(f, "frame control bit 7 set"),
            Error::MissingSap => write!(f, "SAP byte announced but missing"),
            Error::UnsupportedSapExtension(b) => write!(f, "SAP byte {b:#04x} has extension bits"),
            Error::BadTokenAddress => write!(f, "token address with extension bit"),
            Error::DataTooLong => write!(f, "data unit too long"),
            Error::AddressOutOfRange => write!(f, "address or SAP out of range"),
            Error::BufferTooShort => write!(f, "buffer too short"),
        }
    }
}
