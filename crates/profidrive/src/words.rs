//! The vendor profile's control and status words (seed 000, "PZD1指向的控制字说明" and
//! "PZD1指向的状态字说明"). The adapter passes them between master and drive unchanged; the
//! names are for the drive side (simulator, tests) and for the PROFIdrive translation.

/// Control word bits (master to drive).
pub mod control {
    /// Bit 1: run enable (0 run inhibited).
    pub const RUN_ENABLE: u16 = 1 << 1;
    /// Bit 2: start enable (0 start inhibited).
    pub const START_ENABLE: u16 = 1 << 2;
    /// Bit 4: run (0 stop).
    pub const RUN: u16 = 1 << 4;
    /// Bit 5: direction (0 forward, 1 reverse).
    pub const REVERSE: u16 = 1 << 5;
    /// Bit 6: quick stop.
    pub const QUICK_STOP: u16 = 1 << 6;
    /// Bit 7: coast stop (free-wheel).
    pub const COAST_STOP: u16 = 1 << 7;
    /// Bit 12: acceleration and deceleration inhibited (ramp hold).
    pub const RAMP_HOLD: u16 = 1 << 12;
    /// Bit 13: integrator (ramp) input set to zero.
    pub const RAMP_INPUT_ZERO: u16 = 1 << 13;
    /// Bit 14: remote control.
    pub const REMOTE: u16 = 1 << 14;
    /// Bit 15: fault reset on 0 -> 1.
    pub const FAULT_RESET: u16 = 1 << 15;
}

/// Status word bits (drive to master).
pub mod status {
    /// Bit 0: ready.
    pub const READY: u16 = 1 << 0;
    /// Bit 1: run enabled.
    pub const RUN_ENABLED: u16 = 1 << 1;
    /// Bit 2: start enabled.
    pub const START_ENABLED: u16 = 1 << 2;
    /// Bit 4: running.
    pub const RUNNING: u16 = 1 << 4;
    /// Bit 5: direction (1 reverse).
    pub const REVERSE: u16 = 1 << 5;
    /// Bit 6: zero speed.
    pub const ZERO_SPEED: u16 = 1 << 6;
    /// Bit 7: accelerating.
    pub const ACCELERATING: u16 = 1 << 7;
    /// Bit 8: decelerating.
    pub const DECELERATING: u16 = 1 << 8;
    /// Bit 9: at setpoint (到达).
    pub const AT_SETPOINT: u16 = 1 << 9;
    /// Bit 12: reference source is the bus (指令源).
    pub const REFERENCE_FROM_BUS: u16 = 1 << 12;
    /// Bit 13: command source is the bus (命令源).
    pub const COMMAND_FROM_BUS: u16 = 1 << 13;
    /// Bit 14: warning.
    pub const WARNING: u16 = 1 << 14;
    /// Bit 15: fault.
    pub const FAULT: u16 = 1 << 15;
}

/// A rising edge of `bit` from `previous` to `current`.
pub const fn rose(previous: u16, current: u16, bit: u16) -> bool {
    previous & bit == 0 && current & bit != 0
}
