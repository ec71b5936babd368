//! The firmware's defmt stream as log lines: one decoding, so that `cargo xtask qemu-test`
//! (QEMU's semihosting output) and `cargo xtask flash --log` (the board's RTT channel) print
//! the firmware's log alike.
//!
//! Feed the bytes as they come to the decoder ([`defmt_decoder::StreamDecoder::received`]);
//! [`lines`] takes every whole frame out and leaves a partial one for the next bytes.

use defmt_decoder::{DecodeError, StreamDecoder};

/// One log line: the level (`INFO`, `ERROR`, ..., `PRINT` for `println!`) and the message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Line {
    pub level: String,
    pub message: String,
}

/// Something other than the firmware's defmt wrote into the stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Malformed;

impl std::fmt::Display for Malformed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("malformed defmt frame: something else wrote onto the defmt stream")
    }
}

impl std::error::Error for Malformed {}

/// Every whole frame the decoder holds, as lines.
pub fn lines(decoder: &mut dyn StreamDecoder) -> Result<Vec<Line>, Malformed> {
    let mut out = Vec::new();
    loop {
        match decoder.decode() {
            Ok(frame) => out.push(Line {
                level: frame
                    .level()
                    .map_or("PRINT".to_string(), |l| format!("{l:?}").to_uppercase()),
                message: frame.display_message().to_string(),
            }),
            Err(DecodeError::UnexpectedEof) => return Ok(out),
            Err(DecodeError::Malformed) => return Err(Malformed),
        }
    }
}
