//! PPO types 1-6 (seed 000, "PPO 报文格式"; seed 004, SAP 62 Cfg_Data table): which
//! configuration selects which, and how many PKW and PZD words each carries.
//!
//! ```text
//!          PKW (4 words)        PZD (2, 6 or 10 words)
//! PPO1  F3 F1   ID IND VAL VAL | CW/SW REF/ACT
//! PPO2  F3 F5   ID IND VAL VAL | CW/SW REF/ACT PZD3..PZD6
//! PPO3  F1                     | CW/SW REF/ACT
//! PPO4  F5                     | CW/SW REF/ACT PZD3..PZD6
//! PPO5  F3 F9   ID IND VAL VAL | CW/SW REF/ACT PZD3..PZD10
//! PPO6  F9                     | CW/SW REF/ACT PZD3..PZD10
//! ```

/// Words of the parameter channel (PKW) where a PPO has one.
pub const PKW_WORDS: usize = 4;
/// The most process-data words a PPO carries.
pub const MAX_PZD_WORDS: usize = 10;

/// The six PPO types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Ppo {
    Ppo1,
    Ppo2,
    Ppo3,
    Ppo4,
    Ppo5,
    Ppo6,
}

impl Ppo {
    pub const ALL: [Ppo; 6] = [
        Ppo::Ppo1,
        Ppo::Ppo2,
        Ppo::Ppo3,
        Ppo::Ppo4,
        Ppo::Ppo5,
        Ppo::Ppo6,
    ];

    /// The Chk_Cfg bytes that select this type.
    pub const fn cfg(self) -> &'static [u8] {
        match self {
            Ppo::Ppo1 => &[0xF3, 0xF1],
            Ppo::Ppo2 => &[0xF3, 0xF5],
            Ppo::Ppo3 => &[0xF1],
            Ppo::Ppo4 => &[0xF5],
            Ppo::Ppo5 => &[0xF3, 0xF9],
            Ppo::Ppo6 => &[0xF9],
        }
    }

    /// The type a configuration selects; any other configuration is refused (Cfg_Fault).
    pub fn from_cfg(cfg: &[u8]) -> Option<Ppo> {
        Ppo::ALL.into_iter().find(|p| p.cfg() == cfg)
    }

    /// 1 to 6, as seed 004's parameter 929 shows it.
    pub const fn number(self) -> u8 {
        self as u8 + 1
    }

    pub const fn has_pkw(self) -> bool {
        matches!(self, Ppo::Ppo1 | Ppo::Ppo2 | Ppo::Ppo5)
    }

    pub const fn pzd_words(self) -> usize {
        match self {
            Ppo::Ppo1 | Ppo::Ppo3 => 2,
            Ppo::Ppo2 | Ppo::Ppo4 => 6,
            Ppo::Ppo5 | Ppo::Ppo6 => 10,
        }
    }

    /// Bytes each way: PKW (8 where present) plus two per PZD word.
    pub const fn io_bytes(self) -> usize {
        (if self.has_pkw() { PKW_WORDS } else { 0 } + self.pzd_words()) * 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_000_ppo_table_frame_lengths() {
        // Seed 000, "类型 帧长度": PPO1 PKW(8)+PZD(4)=12, PPO2 8+12=20, PPO3 4, PPO4 12,
        // PPO5 8+20=28.
        assert_eq!(Ppo::Ppo1.io_bytes(), 12);
        assert_eq!(Ppo::Ppo2.io_bytes(), 20);
        assert_eq!(Ppo::Ppo3.io_bytes(), 4);
        assert_eq!(Ppo::Ppo4.io_bytes(), 12);
        assert_eq!(Ppo::Ppo5.io_bytes(), 28);
    }

    #[test]
    fn seed_004_cfg_data_table() {
        // Seed 004, SAP 62 Cfg_Data: PPO 1 F3 F1 (4 PKW + 2 PZD, 12 bytes) .. PPO 6 F9 (0 PKW
        // + 10 PZD, 20 bytes).
        let table: [(&[u8], u8, usize, usize); 6] = [
            (&[0xF3, 0xF1], 1, 2, 12),
            (&[0xF3, 0xF5], 2, 6, 20),
            (&[0xF1], 3, 2, 4),
            (&[0xF5], 4, 6, 12),
            (&[0xF3, 0xF9], 5, 10, 28),
            (&[0xF9], 6, 10, 20),
        ];
        for (cfg, number, pzd, bytes) in table {
            let ppo = Ppo::from_cfg(cfg).unwrap();
            assert_eq!(
                (ppo.number(), ppo.pzd_words(), ppo.io_bytes()),
                (number, pzd, bytes)
            );
            // The general identifier format agrees (dp-slave sizes it independently).
            let io = dp_slave::cfg::io_sizes(cfg).unwrap();
            assert_eq!((io.inputs, io.outputs), (bytes, bytes));
        }
    }

    #[test]
    fn other_configurations_are_refused() {
        for cfg in [
            &[][..],
            &[0xF1, 0xF3],
            &[0xF3],
            &[0xF3, 0xF1, 0x00],
            &[0xF2],
        ] {
            assert_eq!(Ppo::from_cfg(cfg), None, "{cfg:02X?}");
        }
    }
}
