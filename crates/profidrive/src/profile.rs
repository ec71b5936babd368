//! The PROFIdrive profile of seed 004: its control word (parameter 967, table 7), its status
//! word (parameter 968, table 8), the state machine between them, and the translation to and
//! from the vendor words the drive behind the adapter speaks (seed 000).
//!
//! ```text
//!             OFF2 or OFF3 (from any state)          fault (from any state)
//! SWITCH-ON INHIBIT --OFF2=1, OFF3=1, ON=0--> READY TO SWITCH ON --ON=1--> READY TO OPERATE
//!   ^    ^   ^                                      ^    OFF1 (ON=0)          | ENABLE_OPERATION=1
//!   |    |   +- OFF3 ACTIVE <- OFF3 --+             +---- OFF1 ACTIVE <---- OPERATION ENABLED
//!   |    +----- OFF2 ACTIVE <- OFF2 --+ (from READY TO OPERATE, OPERATION ENABLED, OFFx ACTIVE)
//!   | RESET 0->1
//! FAULT
//! ```
//!
//! The OFFx ACTIVE states of seed 004 (table 7) last while the drive still turns (its status
//! word's running bit): OFF1 ramps down (run enable kept, run command off), OFF2 coasts, OFF3
//! stops as fast as the drive can; a drive already stopped passes through at once.
//! References: REF and ACT are signed, 0x4000 (16384) is the rated speed of the motor, a
//! negative value runs in reverse (seed 004, "给定值"); in the ABB Drives mode 20000 is. The
//! drive's frequency is unsigned with
//! the direction in the vendor control word; `rated` is the drive's value that 0x4000 means.

use crate::words::{control as vendor, status as vendor_status};

/// Control word bits (table 7).
pub mod control {
    pub const ON: u16 = 1 << 0;
    pub const NO_OFF2: u16 = 1 << 1;
    pub const NO_OFF3: u16 = 1 << 2;
    pub const OPERATION_ENABLE: u16 = 1 << 3;
    /// 0: ramp function generator output forced to zero (stop by the selected mode).
    pub const RAMP_OUT_ENABLE: u16 = 1 << 4;
    /// 0: ramp held.
    pub const RAMP_ACCELERATOR_ENABLE: u16 = 1 << 5;
    /// 0: ramp input forced to zero.
    pub const RAMP_INPUT_ENABLE: u16 = 1 << 6;
    /// Fault reset on 0 -> 1.
    pub const RESET: u16 = 1 << 7;
    pub const INCHING_1: u16 = 1 << 8;
    pub const INCHING_2: u16 = 1 << 9;
    pub const REMOTE_CMD: u16 = 1 << 10;

    /// Remote control with OFF2 and OFF3 released and ON clear: what takes SWITCH-ON INHIBIT
    /// to READY TO SWITCH ON.
    pub const READY: u16 = NO_OFF2 | NO_OFF3 | REMOTE_CMD;
    /// Normal operation: READY with ON, operation and every ramp function generator enabled.
    pub const OPERATE: u16 = READY
        | ON
        | OPERATION_ENABLE
        | RAMP_OUT_ENABLE
        | RAMP_ACCELERATOR_ENABLE
        | RAMP_INPUT_ENABLE;
}

/// Status word bits (table 8).
pub mod status {
    pub const RDY_ON: u16 = 1 << 0;
    pub const RDY_RUN: u16 = 1 << 1;
    pub const RDY_REF: u16 = 1 << 2;
    pub const TRIPPED: u16 = 1 << 3;
    pub const OFF_2_STA: u16 = 1 << 4;
    pub const OFF_3_STA: u16 = 1 << 5;
    pub const SWC_ON_INHIB: u16 = 1 << 6;
    pub const ALARM: u16 = 1 << 7;
    pub const AT_SETPOINT: u16 = 1 << 8;
    pub const REMOTE: u16 = 1 << 9;
    pub const ABOVE_LIMIT: u16 = 1 << 10;
}

/// 0x4000: the rated speed.
pub const RATED: i32 = 0x4000;

/// The states of figure 9.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveState {
    SwitchOnInhibit,
    ReadyToSwitchOn,
    ReadyToOperate,
    OperationEnabled,
    /// OFF1 (ON=0) from operation: ramping down (RDY_RUN reads 0).
    Off1Active,
    /// OFF2: coasting (OFF_2_STA reads 0), then SWITCH-ON INHIBIT.
    Off2Active,
    /// OFF3: the quick stop (OFF_3_STA reads 0), then SWITCH-ON INHIBIT.
    Off3Active,
    Fault,
}

/// The state machine and the translation. One instance per configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Profile {
    pub state: DriveState,
    /// The control word and reference in force (REMOTE_CMD=0 may keep the previous ones).
    control_word: u16,
    reference: i16,
    previous_control: u16,
    /// RESET rose while in FAULT: the acknowledgement holds until the drive's fault is gone.
    reset_requested: bool,
    /// The drive link is lost: a fault of the adapter's own, latched like the drive's.
    link_lost: bool,
    /// A RESET took the state machine out of FAULT since the last look.
    reset_done: bool,
}

impl Profile {
    /// Switch-on inhibit, no control word yet.
    pub const fn new() -> Profile {
        Profile {
            state: DriveState::SwitchOnInhibit,
            control_word: 0,
            reference: 0,
            previous_control: 0,
            reset_requested: false,
            link_lost: false,
            reset_done: false,
        }
    }

    /// The drive link lost (or back): a lost link is a fault (FAULT at once, the drive stopped),
    /// held like the drive's own until a RESET once the link is back, then SWITCH-ON INHIBIT
    /// until ON goes 0 -> 1.
    pub fn set_link_lost(&mut self, lost: bool) {
        if lost {
            self.state = DriveState::Fault;
        }
        self.link_lost = lost;
    }

    /// Whether a RESET took the state machine out of FAULT since the last call.
    pub fn take_reset_done(&mut self) -> bool {
        core::mem::take(&mut self.reset_done)
    }
}

impl Default for Profile {
    fn default() -> Self {
        Self::new()
    }
}

/// What the drive gets: its vendor control word and its (unsigned) frequency reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ToDrive {
    pub control_word: u16,
    pub reference: u16,
}

impl Profile {
    /// Takes the master's control word and reference, steps the state machine with the drive's
    /// latest vendor status word, and says what the drive gets.
    /// `units` is the bus value of the rated speed (4000h, or 20000 in the ABB Drives mode).
    pub fn command(
        &mut self,
        cw: u16,
        reference: i16,
        drive_status: u16,
        rated: u16,
        units: i32,
    ) -> ToDrive {
        // Table 7, bit 10: without REMOTE_CMD a non-zero frame keeps the previous command; an
        // all-zero one is accepted (fieldbus control allowed).
        if cw & control::REMOTE_CMD != 0 || (cw == 0 && reference == 0) {
            self.control_word = cw;
            self.reference = reference;
        }
        let cw = self.control_word;
        let reset = cw & control::RESET != 0 && self.previous_control & control::RESET == 0;
        self.previous_control = cw;
        self.step(
            cw,
            reset,
            drive_status & vendor_status::FAULT != 0 || self.link_lost,
            drive_status & vendor_status::RUNNING != 0,
        );
        self.drive_command(rated, units)
    }

    fn step(&mut self, cw: u16, reset: bool, fault: bool, running: bool) {
        use DriveState::*;
        // The states in which the motor may turn: an OFF from them waits for it to stop.
        let turning = running
            && matches!(
                self.state,
                ReadyToOperate | OperationEnabled | Off1Active | Off2Active | Off3Active
            );
        let off2 = cw & control::NO_OFF2 == 0;
        let off3 = cw & control::NO_OFF3 == 0;
        let on = cw & control::ON != 0;
        let enable = cw & control::OPERATION_ENABLE != 0;
        // A RESET while the link is lost acknowledges nothing: the fault is latched until one
        // comes with the link back (a drive's own fault takes the RESET while it lasts, since
        // the drive needs it to clear).
        if self.state == Fault && reset && !self.link_lost {
            self.reset_requested = true;
        }
        self.state = match self.state {
            _ if fault && self.state != Fault => Fault,
            Fault if self.reset_requested && !fault => SwitchOnInhibit,
            Fault => Fault,
            _ if off2 && turning => Off2Active,
            Off2Active if running => Off2Active,
            _ if off3 && turning && self.state != Off2Active => Off3Active,
            Off3Active if running => Off3Active,
            _ if off2 || off3 => SwitchOnInhibit,
            Off2Active | Off3Active => SwitchOnInhibit,
            ReadyToOperate | OperationEnabled | Off1Active if !on && turning => Off1Active,
            Off1Active if running => Off1Active,
            Off1Active => ReadyToSwitchOn,
            SwitchOnInhibit if !on => ReadyToSwitchOn,
            SwitchOnInhibit => SwitchOnInhibit,
            ReadyToSwitchOn if on => ReadyToOperate,
            ReadyToSwitchOn => ReadyToSwitchOn,
            ReadyToOperate | OperationEnabled if !on => ReadyToSwitchOn,
            ReadyToOperate | OperationEnabled if enable => OperationEnabled,
            ReadyToOperate | OperationEnabled => ReadyToOperate,
        };
        if self.state != Fault {
            if self.reset_requested {
                self.reset_done = true;
            }
            self.reset_requested = false;
        }
    }

    fn drive_command(&self, rated: u16, units: i32) -> ToDrive {
        let cw = self.control_word;
        let mut word = vendor::REMOTE;
        if cw & control::NO_OFF2 == 0 || self.state == DriveState::Off2Active {
            word |= vendor::COAST_STOP;
        }
        if cw & control::NO_OFF3 == 0 || self.state == DriveState::Off3Active {
            word |= vendor::QUICK_STOP;
        }
        // OFF1 ramps down: the drive stays enabled with its run command off. OPERATION_ENABLE
        // = 0 (table 7: "inhibit operation", READY TO OPERATE) takes the run enable away: the
        // drive's output goes off and the motor coasts.
        if matches!(
            self.state,
            DriveState::OperationEnabled | DriveState::Off1Active
        ) {
            word |= vendor::RUN_ENABLE | vendor::START_ENABLE;
        }
        if self.state == DriveState::OperationEnabled && cw & control::RAMP_OUT_ENABLE != 0 {
            word |= vendor::RUN;
        }
        if cw & control::RAMP_ACCELERATOR_ENABLE == 0 {
            word |= vendor::RAMP_HOLD;
        }
        if cw & control::RAMP_INPUT_ENABLE == 0 {
            word |= vendor::RAMP_INPUT_ZERO;
        }
        if self.reference < 0 {
            word |= vendor::REVERSE;
        }
        if cw & control::RESET != 0 {
            word |= vendor::FAULT_RESET;
        }
        let magnitude = i32::from(self.reference).unsigned_abs();
        let reference = (magnitude * u32::from(rated) / units.unsigned_abs().max(1))
            .min(u32::from(u16::MAX)) as u16;
        ToDrive {
            control_word: word,
            reference,
        }
    }

    /// Takes in the drive's status word as it is read: a fault shows at once, not a cycle later.
    pub fn observe(&mut self, drive_status: u16) {
        if drive_status & vendor_status::FAULT != 0 {
            self.state = DriveState::Fault;
        }
    }

    /// The status word for the master, from the state and the drive's vendor status word.
    pub fn status_word(&self, drive_status: u16) -> u16 {
        use DriveState::*;
        let cw = self.control_word;
        let mut sw = 0;
        match self.state {
            SwitchOnInhibit => sw |= status::SWC_ON_INHIB,
            ReadyToSwitchOn => sw |= status::RDY_ON,
            ReadyToOperate => sw |= status::RDY_ON | status::RDY_RUN,
            OperationEnabled => sw |= status::RDY_ON | status::RDY_RUN | status::RDY_REF,
            // Table 8: RDY_RUN 0 is OFF1 ACTIVE.
            Off1Active => sw |= status::RDY_ON,
            Off2Active | Off3Active => {}
            Fault => sw |= status::TRIPPED,
        }
        if cw & control::NO_OFF2 != 0 && self.state != Off2Active {
            sw |= status::OFF_2_STA;
        }
        if cw & control::NO_OFF3 != 0 && self.state != Off3Active {
            sw |= status::OFF_3_STA;
        }
        if drive_status & vendor_status::WARNING != 0 {
            sw |= status::ALARM;
        }
        if drive_status & vendor_status::AT_SETPOINT != 0 && self.state == OperationEnabled {
            sw |= status::AT_SETPOINT;
        }
        if drive_status & vendor_status::COMMAND_FROM_BUS != 0 {
            sw |= status::REMOTE;
        }
        sw
    }

    /// ACT for the master: the drive's unsigned frequency, scaled to 0x4000 = rated, negative
    /// while the drive runs in reverse.
    pub fn actual(&self, drive_status: u16, frequency: u16, rated: u16, units: i32) -> i16 {
        if rated == 0 {
            return 0;
        }
        let scaled = (i32::from(frequency) * units / i32::from(rated)).min(i32::from(i16::MAX));
        if drive_status & vendor_status::REVERSE != 0 {
            -scaled as i16
        } else {
            scaled as i16
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use DriveState::*;

    const RATED_50HZ: u16 = 5000;
    const OFF: u16 = control::READY;
    const RUN: u16 = control::OPERATE;

    #[test]
    fn table_7_start_sequence_to_operation_enabled() {
        let mut p = Profile::default();
        assert_eq!(p.state, SwitchOnInhibit);
        assert_eq!(
            p.status_word(0) & status::SWC_ON_INHIB,
            status::SWC_ON_INHIB
        );
        p.command(OFF, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, ReadyToSwitchOn);
        assert_eq!(p.status_word(0) & 0x7, status::RDY_ON);
        p.command(OFF | control::ON, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, ReadyToOperate);
        let d = p.command(RUN, 0x2000, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, OperationEnabled);
        assert_eq!(p.status_word(0) & 0x7, 0x7);
        // Half the rated speed forward: 25.00 Hz, run command, no reverse.
        assert_eq!(d.reference, 2500);
        assert_eq!(d.control_word & vendor::RUN, vendor::RUN);
        // In the ABB Drives mode 10000 is half the rated speed.
        let d = p.command(RUN, 10_000, 0, RATED_50HZ, 20_000);
        assert_eq!(d.reference, 2500);
        assert_eq!(d.control_word & vendor::REVERSE, 0);
    }

    /// Seed 004 table 7, bit 3: OPERATION_ENABLE = 0 is "inhibit operation" (OPERATION
    /// INHIBIT): the drive's run enable goes off, its output with it, and the motor coasts; it
    /// is no ramp stop with the drive still enabled (that is OFF1).
    #[test]
    fn seed_004_table_7_operation_enable_0_inhibits_and_the_motor_coasts() {
        let mut p = Profile::default();
        for cw in [OFF, OFF | control::ON, RUN] {
            p.command(cw, 0x2000, 0, RATED_50HZ, RATED);
        }
        let running = vendor_status::RUNNING;
        let d = p.command(RUN, 0x2000, running, RATED_50HZ, RATED);
        assert_eq!(p.state, OperationEnabled);
        assert_eq!(
            d.control_word & (vendor::RUN_ENABLE | vendor::RUN),
            vendor::RUN_ENABLE | vendor::RUN
        );
        let d = p.command(
            RUN & !control::OPERATION_ENABLE,
            0x2000,
            running,
            RATED_50HZ,
            RATED,
        );
        assert_eq!(p.state, ReadyToOperate);
        assert_eq!(
            d.control_word & (vendor::RUN_ENABLE | vendor::RUN),
            0,
            "inhibited: coasting"
        );
        assert_eq!(p.status_word(running) & status::RDY_REF, 0);
        // OFF1 instead ramps: run enable kept, run command off.
        let mut p = Profile::default();
        for cw in [OFF, OFF | control::ON, RUN] {
            p.command(cw, 0x2000, 0, RATED_50HZ, RATED);
        }
        let d = p.command(RUN & !control::ON, 0x2000, running, RATED_50HZ, RATED);
        assert_eq!(p.state, Off1Active);
        assert_eq!(
            d.control_word & (vendor::RUN_ENABLE | vendor::RUN),
            vendor::RUN_ENABLE
        );
        // Enabled again: the drive runs.
        let mut p = Profile::default();
        for cw in [
            OFF,
            OFF | control::ON,
            RUN & !control::OPERATION_ENABLE,
            RUN,
        ] {
            p.command(cw, 0x2000, 0, RATED_50HZ, RATED);
        }
        let d = p.command(RUN, 0x2000, 0, RATED_50HZ, RATED);
        assert_eq!(d.control_word & vendor::RUN, vendor::RUN);
    }

    #[test]
    fn off1_off2_off3_and_reverse() {
        let mut p = Profile::default();
        for cw in [OFF, OFF | control::ON, RUN] {
            p.command(cw, -0x4000, 0, RATED_50HZ, RATED);
        }
        let d = p.command(RUN, -0x4000, 0, RATED_50HZ, RATED);
        assert_eq!(
            (d.reference, d.control_word & vendor::REVERSE),
            (5000, vendor::REVERSE)
        );
        // OFF1: ramp stop, back to READY TO SWITCH ON.
        let d = p.command(RUN & !control::ON, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, ReadyToSwitchOn);
        assert_eq!(d.control_word & vendor::RUN, 0);
        // OFF2: coast stop, SWITCH-ON INHIBIT, OFF_2_STA cleared.
        for cw in [OFF | control::ON, RUN] {
            p.command(cw, 0, 0, RATED_50HZ, RATED);
        }
        let d = p.command(RUN & !control::NO_OFF2, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, SwitchOnInhibit);
        assert_eq!(d.control_word & vendor::COAST_STOP, vendor::COAST_STOP);
        assert_eq!(p.status_word(0) & status::OFF_2_STA, 0);
        // OFF3: quick stop.
        let d = p.command(RUN & !control::NO_OFF3, 0, 0, RATED_50HZ, RATED);
        assert_eq!(d.control_word & vendor::QUICK_STOP, vendor::QUICK_STOP);
        assert_eq!(p.state, SwitchOnInhibit);
    }

    /// Seed 004 table 7 (lines 790-794) and table 8 (lines 819-827): OFF1, OFF2 and OFF3 pass
    /// through their ACTIVE states while the drive still turns, with the status bits that
    /// name them, and end in READY TO SWITCH ON (OFF1) or SWITCH-ON INHIBIT (OFF2, OFF3).
    #[test]
    fn seed_004_lines_790_794_off1_off2_off3_active_while_the_drive_turns() {
        let turning = vendor_status::RUNNING;
        let operating = || {
            let mut p = Profile::default();
            for cw in [OFF, OFF | control::ON, RUN] {
                p.command(cw, 0x2000, turning, RATED_50HZ, RATED);
            }
            assert_eq!(p.state, OperationEnabled);
            p
        };
        // OFF1: ramp down with the drive enabled and its run command off.
        let mut p = operating();
        let d = p.command(RUN & !control::ON, 0x2000, turning, RATED_50HZ, RATED);
        assert_eq!(p.state, Off1Active);
        assert_eq!(
            d.control_word & (vendor::RUN | vendor::RUN_ENABLE),
            vendor::RUN_ENABLE
        );
        assert_eq!(
            p.status_word(turning) & 0x7,
            status::RDY_ON,
            "RDY_RUN 0: OFF1 ACTIVE"
        );
        p.command(RUN & !control::ON, 0x2000, turning, RATED_50HZ, RATED);
        assert_eq!(p.state, Off1Active);
        p.command(RUN & !control::ON, 0x2000, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, ReadyToSwitchOn);
        // OFF2: coast (held while the drive turns, even if OFF2 is released), then inhibit.
        let mut p = operating();
        let d = p.command(RUN & !control::NO_OFF2, 0, turning, RATED_50HZ, RATED);
        assert_eq!(p.state, Off2Active);
        assert_eq!(d.control_word & vendor::COAST_STOP, vendor::COAST_STOP);
        let d = p.command(RUN, 0, turning, RATED_50HZ, RATED);
        assert_eq!(p.state, Off2Active);
        assert_eq!(d.control_word & vendor::COAST_STOP, vendor::COAST_STOP);
        assert_eq!(p.status_word(turning) & status::OFF_2_STA, 0);
        p.command(RUN, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, SwitchOnInhibit);
        // OFF3: quick stop, OFF_3_STA 0 until the drive stands, then inhibit.
        let mut p = operating();
        let d = p.command(RUN & !control::NO_OFF3, 0, turning, RATED_50HZ, RATED);
        assert_eq!(p.state, Off3Active);
        assert_eq!(d.control_word & vendor::QUICK_STOP, vendor::QUICK_STOP);
        assert_eq!(
            p.status_word(turning) & (status::OFF_3_STA | status::SWC_ON_INHIB),
            0
        );
        // OFF2 during the quick stop: coast instead.
        p.command(
            RUN & !control::NO_OFF3 & !control::NO_OFF2,
            0,
            turning,
            RATED_50HZ,
            RATED,
        );
        assert_eq!(p.state, Off2Active);
        p.command(
            RUN & !control::NO_OFF3 & !control::NO_OFF2,
            0,
            0,
            RATED_50HZ,
            RATED,
        );
        assert_eq!(p.state, SwitchOnInhibit);
    }

    #[test]
    fn fault_and_reset_on_a_rising_edge() {
        let mut p = Profile::default();
        for cw in [OFF, OFF | control::ON, RUN] {
            p.command(cw, 0x4000, 0, RATED_50HZ, RATED);
        }
        p.command(RUN, 0x4000, vendor_status::FAULT, RATED_50HZ, RATED);
        assert_eq!(p.state, Fault);
        assert_eq!(
            p.status_word(vendor_status::FAULT) & status::TRIPPED,
            status::TRIPPED
        );
        // Without a RESET edge the fault stays, even once the drive is clear.
        p.command(RUN, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, Fault);
        // RESET's 0 -> 1 passes to the drive and is held as an acknowledgement: while the
        // drive still reports the fault nothing changes; once it is clear, SWITCH-ON INHIBIT.
        let d = p.command(
            RUN | control::RESET,
            0,
            vendor_status::FAULT,
            RATED_50HZ,
            RATED,
        );
        assert_eq!(d.control_word & vendor::FAULT_RESET, vendor::FAULT_RESET);
        assert_eq!(p.state, Fault);
        p.command(RUN | control::RESET, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, SwitchOnInhibit);
    }

    #[test]
    fn remote_cmd_of_table_7() {
        let mut p = Profile::default();
        for cw in [OFF, OFF | control::ON, RUN] {
            p.command(cw, 0x1000, 0, RATED_50HZ, RATED);
        }
        // Without REMOTE_CMD a non-zero frame keeps the previous command and reference.
        let d = p.command(control::ON, 0x3000, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, OperationEnabled);
        assert_eq!(d.reference, 1250);
        // An all-zero frame is taken.
        p.command(0, 0, 0, RATED_50HZ, RATED);
        assert_eq!(p.state, SwitchOnInhibit);
    }

    #[test]
    fn actual_value_scaling_of_seed_004() {
        let p = Profile::default();
        // 0x4000 = rated speed; reverse is negative.
        assert_eq!(p.actual(0, 5000, RATED_50HZ, RATED), 0x4000);
        assert_eq!(p.actual(0, 2500, RATED_50HZ, RATED), 0x2000);
        assert_eq!(
            p.actual(vendor_status::REVERSE, 2500, RATED_50HZ, RATED),
            -0x2000
        );
        assert_eq!(p.actual(0, 20000, RATED_50HZ, RATED), i16::MAX);
        // The ABB Drives mode: 20000 = rated speed.
        assert_eq!(p.actual(0, 5000, RATED_50HZ, 20_000), 20_000);
        assert_eq!(
            p.actual(vendor_status::REVERSE, 2500, RATED_50HZ, 20_000),
            -10_000
        );
    }
}
