//! COBS framing (Consistent Overhead Byte Stuffing, Cheshire and Baker 1999) for the link:
//! a frame is the encoded message and one zero byte.
//!
//! Contract:
//! - [`encode_in_place`] turns a payload that was written at [`PAYLOAD_OFFSET`] of a buffer
//!   into a zero-terminated frame at its start, byte for byte what the `cobs` crate's
//!   `encode` gives plus the zero (a property test holds them equal).
//! - [`Decoder`] takes a frame's bytes in as many pieces as they come and decodes them as it
//!   copies them; it never panics, keeps at most `N` decoded bytes, and reports a frame that
//!   ends inside a block, or is longer than its buffer, as bad.
//!
//! Why not the `cobs` crate (which postcard's `to_slice_cobs` and `CobsAccumulator` use): on
//! the MCU its per-byte state machine costs about 17 instructions a byte to encode, and the
//! accumulator copies a frame before decoding it in place, about 26 a byte in all. Every event
//! the firmware decides on is decoded, and every write encoded, on the path a Data_Exchange at
//! 12 Mbit/s waits for (139 µs a cycle); these loops take a third of that. The crate stays the
//! reference these are tested against.

/// Where a payload starts in the buffer [`encode_in_place`] encodes: far enough ahead that
/// the frame, which is longer by one code byte per 254 payload bytes, never overwrites a
/// payload byte before it is read (enough for payloads up to 254 × (this − 1) bytes).
pub const PAYLOAD_OFFSET: usize = 3;

/// Encodes the `len` payload bytes at `buffer[PAYLOAD_OFFSET..]` into a frame at the buffer's
/// start, zero included; returns the frame's length, or `None` where the buffer is too short
/// (or the payload too long for [`PAYLOAD_OFFSET`]).
pub fn encode_in_place(buffer: &mut [u8], len: usize) -> Option<usize> {
    let frame_len = len + len / 254 + 2;
    if len / 254 + 1 > PAYLOAD_OFFSET
        || frame_len > buffer.len()
        || PAYLOAD_OFFSET + len > buffer.len()
    {
        return None;
    }
    // The write position never passes the next byte to read: it starts PAYLOAD_OFFSET behind
    // and gains one only per block of 254 non-zero bytes.
    let mut code_at = 0;
    let mut write = 1;
    for read in PAYLOAD_OFFSET..PAYLOAD_OFFSET + len {
        // A block of 254 bytes ends without a zero; the next opens only if a byte follows.
        if write - code_at == 0xFF {
            buffer[code_at] = 0xFF;
            code_at = write;
            write += 1;
        }
        let byte = buffer[read];
        if byte == 0 {
            buffer[code_at] = (write - code_at) as u8;
            code_at = write;
        } else {
            buffer[write] = byte;
        }
        write += 1;
    }
    buffer[code_at] = (write - code_at) as u8;
    buffer[write] = 0;
    Some(write + 1)
}

/// Decodes a frame's bytes as they arrive, into a buffer of `N` bytes.
pub struct Decoder<const N: usize> {
    buf: [u8; N],
    /// The bytes decoded of the frame under way.
    len: usize,
    /// The length of the frame that ended last.
    frame_len: usize,
    /// Bytes left in the current block; 0 at a block's end.
    left: u8,
    /// The current block's code, 0 before the first: a block shorter than 254 bytes stands
    /// for a zero after it (unless the frame ends there).
    code: u8,
    /// The frame has gone wrong (too long, or a zero inside a block): it is dropped at its end.
    bad: bool,
}

/// What the bytes [`Decoder::feed`] took did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feed {
    /// They all went into the frame; it has not ended.
    Pending,
    /// The frame ended after `consumed` bytes (its zero included), decoded into
    /// [`Decoder::frame`].
    Frame { consumed: usize },
    /// The frame ended after `consumed` bytes, and was bad (too long, cut inside a block, or
    /// empty).
    Bad { consumed: usize },
}

impl<const N: usize> Default for Decoder<N> {
    fn default() -> Self {
        Decoder::new()
    }
}

impl<const N: usize> Decoder<N> {
    pub const fn new() -> Decoder<N> {
        Decoder {
            buf: [0; N],
            len: 0,
            frame_len: 0,
            left: 0,
            code: 0,
            bad: false,
        }
    }

    /// Takes bytes up to and including the first zero; the frame it ends is in
    /// [`Decoder::frame`] until the next call.
    pub fn feed(&mut self, input: &[u8]) -> Feed {
        for (i, &byte) in input.iter().enumerate() {
            if byte == 0 {
                // A frame ends at a block's end, with at least one block.
                let good = !self.bad && self.left == 0 && self.code != 0;
                let consumed = i + 1;
                self.frame_len = if good { self.len } else { 0 };
                self.restart();
                return if good {
                    Feed::Frame { consumed }
                } else {
                    Feed::Bad { consumed }
                };
            }
            if self.bad {
                continue;
            }
            if self.left == 0 {
                // A code byte: the zero the last block stood for, unless this is the first.
                if self.code != 0 && self.code != 0xFF && !self.push(0) {
                    continue;
                }
                self.code = byte;
                self.left = byte - 1;
            } else {
                self.left -= 1;
                self.push(byte);
            }
        }
        Feed::Pending
    }

    /// The frame the last [`Feed::Frame`] ended.
    pub fn frame(&self) -> &[u8] {
        &self.buf[..self.frame_len]
    }

    fn push(&mut self, byte: u8) -> bool {
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
                true
            }
            None => {
                self.bad = true;
                false
            }
        }
    }

    fn restart(&mut self) {
        self.len = 0;
        self.left = 0;
        self.code = 0;
        self.bad = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn encode(payload: &[u8]) -> Option<Vec<u8>> {
        let mut buffer = vec![0u8; PAYLOAD_OFFSET + payload.len() + payload.len() / 254 + 2];
        buffer[PAYLOAD_OFFSET..PAYLOAD_OFFSET + payload.len()].copy_from_slice(payload);
        let len = encode_in_place(&mut buffer, payload.len())?;
        Some(buffer[..len].to_vec())
    }

    #[test]
    fn the_papers_examples() {
        // Cheshire and Baker's figures, as Wikipedia's COBS article lists them.
        assert_eq!(encode(&[]).unwrap(), [0x01, 0x00]);
        assert_eq!(encode(&[0x00]).unwrap(), [0x01, 0x01, 0x00]);
        assert_eq!(encode(&[0x00, 0x00]).unwrap(), [0x01, 0x01, 0x01, 0x00]);
        assert_eq!(
            encode(&[0x11, 0x22, 0x00, 0x33]).unwrap(),
            [0x03, 0x11, 0x22, 0x02, 0x33, 0x00]
        );
        assert_eq!(
            encode(&[0x11, 0x00, 0x00, 0x00]).unwrap(),
            [0x02, 0x11, 0x01, 0x01, 0x01, 0x00]
        );
        let run: Vec<u8> = (1..=254).collect();
        let mut framed = vec![0xFF];
        framed.extend_from_slice(&run);
        framed.push(0x00);
        assert_eq!(encode(&run).unwrap(), framed);
        let run: Vec<u8> = (1..=255).collect();
        let mut framed = vec![0xFF];
        framed.extend_from_slice(&run[..254]);
        framed.extend_from_slice(&[0x02, 0xFF, 0x00]);
        assert_eq!(encode(&run).unwrap(), framed);
    }

    #[test]
    fn a_payload_too_long_for_the_offset_or_the_buffer_is_refused() {
        let mut buffer = [0u8; 10];
        assert_eq!(encode_in_place(&mut buffer, 8), None, "8 + 2 > 10 - 3");
        assert_eq!(encode_in_place(&mut buffer, 5), Some(7));
        let mut long = vec![1u8; 1000];
        assert_eq!(
            encode_in_place(&mut long, 800),
            None,
            "four code bytes of overhead"
        );
    }

    #[test]
    fn bad_frames_are_reported_at_their_end() {
        let mut decoder = Decoder::<8>::new();
        // Ends inside a block, then an empty frame, then one too long for 8 bytes.
        assert_eq!(decoder.feed(&[0x05, 0x11, 0x00]), Feed::Bad { consumed: 3 });
        assert_eq!(decoder.feed(&[0x00]), Feed::Bad { consumed: 1 });
        assert_eq!(
            decoder.feed(&[0x0A, 1, 2, 3, 4, 5, 6, 7, 8, 9]),
            Feed::Pending
        );
        assert_eq!(
            decoder.feed(&[0x00, 0x02, 0x42, 0x00]),
            Feed::Bad { consumed: 1 }
        );
        assert_eq!(
            decoder.feed(&[0x02, 0x42, 0x00]),
            Feed::Frame { consumed: 3 }
        );
        assert_eq!(decoder.frame(), [0x42]);
    }

    proptest! {
        /// (An empty payload is left out: the crate encodes it as nothing, where COBS has one
        /// empty block, `01 00` here; no message is empty.)
        #[test]
        fn encoding_is_the_cobs_crates(payload in prop::collection::vec(any::<u8>(), 1..=500)) {
            let mut reference = vec![0u8; cobs::max_encoding_length(payload.len())];
            let n = cobs::encode(&payload, &mut reference);
            reference.truncate(n);
            reference.push(0);
            prop_assert_eq!(encode(&payload).unwrap(), reference);
        }

        #[test]
        fn frames_decode_whatever_the_pieces(
            payload in prop::collection::vec(any::<u8>(), 0..=500),
            cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..4),
        ) {
            let frame = encode(&payload).unwrap();
            let mut cuts: Vec<usize> = cuts.iter().map(|c| c.index(frame.len())).collect();
            cuts.sort_unstable();
            let mut decoder = Decoder::<512>::new();
            let mut from = 0;
            for cut in cuts.into_iter().chain([frame.len()]) {
                let piece = &frame[from..cut];
                let expected = if cut == frame.len() && !piece.is_empty() {
                    Feed::Frame { consumed: piece.len() }
                } else {
                    Feed::Pending
                };
                if piece.is_empty() {
                    continue;
                }
                prop_assert_eq!(decoder.feed(piece), expected);
                from = cut;
            }
            prop_assert_eq!(decoder.frame(), &payload[..]);
        }

        /// Any bytes up to a zero: the decoder agrees with the crate's decoder on whether
        /// they are a frame and what it holds (the crate takes a frame without a block, "0",
        /// as empty; it is bad here, since no message is empty).
        #[test]
        fn any_bytes_decode_as_the_crate_decodes_them(bytes in prop::collection::vec(1u8..=255, 0..300)) {
            let mut decoder = Decoder::<400>::new();
            let mut stream = bytes.clone();
            stream.push(0);
            let fed = decoder.feed(&stream);
            let mut reference = bytes.clone();
            match cobs::decode_in_place(&mut reference) {
                Ok(n) if !bytes.is_empty() => {
                    prop_assert_eq!(fed, Feed::Frame { consumed: stream.len() });
                    prop_assert_eq!(decoder.frame(), &reference[..n]);
                }
                _ => prop_assert_eq!(fed, Feed::Bad { consumed: stream.len() }),
            }
        }
    }
}
