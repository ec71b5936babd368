//! Chk_Cfg identifier bytes: from a configuration to the sizes of the input and output data.
//!
//! ```text
//! general  bit 7 consistency | bit 6 words | bits 5-4 00 special 01 in 10 out 11 in+out | bits 3-0 length-1
//! special  bits 7-6 00 none 01 in 10 out 11 out+in | bits 5-4 00 | bits 3-0 manufacturer bytes
//!          then one length byte per direction (out first), bit 6 words, bits 5-0 length-1,
//!          then the manufacturer bytes
//! ```
//! [`io_sizes`] never panics; it refuses a configuration that ends inside an identifier.

/// Bytes of input (slave to master) and output (master to slave) data a configuration asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IoSizes {
    pub inputs: usize,
    pub outputs: usize,
}

/// The largest input or output data of a DP-V0 slave.
pub const MAX_IO_LEN: usize = 244;

/// Why a configuration cannot be sized.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CfgError {
    /// The bytes end inside a special-format identifier.
    Truncated,
    /// More than [`MAX_IO_LEN`] bytes in one direction.
    TooLarge,
}

/// Sums the input and output bytes of all identifiers.
pub fn io_sizes(cfg: &[u8]) -> Result<IoSizes, CfgError> {
    let mut sizes = IoSizes::default();
    let mut rest = cfg;
    while let Some((&id, tail)) = rest.split_first() {
        rest = tail;
        let direction = (id >> 4) & 0x03;
        if direction != 0 {
            let len = ((id & 0x0F) as usize + 1) * if id & 0x40 != 0 { 2 } else { 1 };
            if direction & 0x01 != 0 {
                sizes.inputs += len;
            }
            if direction & 0x02 != 0 {
                sizes.outputs += len;
            }
        } else {
            let manufacturer = (id & 0x0F) as usize;
            let has_out = id & 0x80 != 0;
            let has_in = id & 0x40 != 0;
            for (present, total) in [(has_out, &mut sizes.outputs), (has_in, &mut sizes.inputs)] {
                if present {
                    let (&len_byte, tail) = rest.split_first().ok_or(CfgError::Truncated)?;
                    rest = tail;
                    *total +=
                        ((len_byte & 0x3F) as usize + 1) * if len_byte & 0x40 != 0 { 2 } else { 1 };
                }
            }
            rest = rest.get(manufacturer..).ok_or(CfgError::Truncated)?;
        }
        if sizes.inputs > MAX_IO_LEN || sizes.outputs > MAX_IO_LEN {
            return Err(CfgError::TooLarge);
        }
    }
    Ok(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn io(inputs: usize, outputs: usize) -> Result<IoSizes, CfgError> {
        Ok(IoSizes { inputs, outputs })
    }

    #[test]
    fn ppo_configurations() {
        // PROTOCOL.md: PPO1 = F3 F1 ... PPO6 = F9; F3 is 4 words in+out (PKW), F1 2 words, F5
        // 6 words, F9 10 words.
        assert_eq!(io_sizes(&[0xF3, 0xF1]), io(12, 12));
        assert_eq!(io_sizes(&[0xF3, 0xF5]), io(20, 20));
        assert_eq!(io_sizes(&[0xF1]), io(4, 4));
        assert_eq!(io_sizes(&[0xF5]), io(12, 12));
        assert_eq!(io_sizes(&[0xF3, 0xF9]), io(28, 28));
        assert_eq!(io_sizes(&[0xF9]), io(20, 20));
    }

    #[test]
    fn protocol_md_get_cfg_of_the_et200s() {
        // `00 10 10`: a free place, then two single input bytes.
        assert_eq!(io_sizes(&[0x00, 0x10, 0x10]), io(2, 0));
    }

    #[test]
    fn special_format() {
        // Out 3 words and in 2 bytes, then 2 manufacturer bytes.
        assert_eq!(io_sizes(&[0xC2, 0x42, 0x01, 0xAA, 0xBB]), io(2, 6));
        assert_eq!(
            io_sizes(&[0xC2, 0x42, 0x01, 0xAA]),
            Err(CfgError::Truncated)
        );
        assert_eq!(io_sizes(&[0x40]), Err(CfgError::Truncated));
    }

    #[test]
    fn too_large() {
        // 0x7F: 16 words in and out, 32 bytes each way.
        assert_eq!(io_sizes(&[0x7F; 7]), io(224, 224));
        assert_eq!(io_sizes(&[0x7F; 8]), Err(CfgError::TooLarge));
    }
}
