//! The library of a term's features: what each reads (the command, the model's state, the
//! step, the side's own wheel command, filtered and delayed copies of the command), its name in
//! parameter keys, its symbol in equations and its unit. Grids of knees, filter time constants
//! and delays are the library's choices; a named effect fits a value between their points.

use super::TermInput;
use crate::kinematics::WheelSpeeds;

/// Time constants of the first-order filtered copies of the command, s: a memory of the
/// commands that lasts about a wheel loop's response, a step's, and several steps'.
pub const FILTERS_S: [f64; 3] = [0.5, 2.0, 8.0];

/// Delays of the delayed copies of the side's own command, s (a late actuation the dead time's
/// single value does not describe, or one side's).
pub const DELAYS_S: [f64; 2] = [0.1, 0.3];

/// Whose wheel command a feature of the side's own command reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The left wheel's.
    Left,
    /// The right wheel's.
    Right,
    /// None: a body or sensor target (side features read 0).
    Neither,
}

impl Side {
    /// This side's speed in `w` (0 for [`Side::Neither`]).
    pub fn of(self, w: WheelSpeeds) -> f64 {
        match self {
            Self::Left => w.left_rad_s,
            Self::Right => w.right_rad_s,
            Self::Neither => 0.0,
        }
    }
}

/// A candidate feature of a term: a function of a [`TermInput`] (and, for wheel targets, of
/// the side's own command).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feature {
    /// 1: a constant offset.
    One,
    /// Model forward speed vx, m/s.
    Vx,
    /// Model yaw rate wz, rad/s.
    Wz,
    /// Commanded forward speed, m/s.
    CmdVx,
    /// Commanded yaw rate, rad/s.
    CmdWz,
    /// The side's own wheel command, rad/s (wheel targets only).
    CmdWheel,
    /// vx·wz (centripetal acceleration), m/s².
    VxWz,
    /// |vx|, m/s.
    AbsVx,
    /// |wz|, rad/s.
    AbsWz,
    /// sign(cmd vx): the direction of travel.
    SignVx,
    /// vx², m²/s².
    VxSq,
    /// wz², rad²/s².
    WzSq,
    /// Command change since the previous step in vx, m/s.
    DeltaCmdVx,
    /// Command change since the previous step in wz, rad/s.
    DeltaCmdWz,
    /// The previous step's commanded vx, m/s.
    PrevCmdVx,
    /// The previous step's commanded wz, rad/s.
    PrevCmdWz,
    /// Time in the step, s.
    TimeInStep,
    /// Step index.
    Step,
    /// Step index × the side's own wheel command (a gain drifting over the run).
    StepCmdWheel,
    /// Step index × commanded vx.
    StepCmdVx,
    /// Reverse indicator × model vx (1 when the command drives backwards).
    ReverseVx,
    /// Reverse indicator × model wz.
    ReverseWz,
    /// Reverse indicator × the side's own wheel command.
    ReverseCmdWheel,
    /// Model forward acceleration, m/s² (a lag shows as a term in it).
    Ax,
    /// Model yaw acceleration, rad/s².
    Alpha,
    /// The side's own command times its magnitude, ω_cmd·|ω_cmd| (an odd gain curve: a motor
    /// that gains or loses gain with speed), rad²/s².
    CmdWheelOdd,
    /// The side's own command cubed (a soft saturation's first term), rad³/s³.
    CmdWheelCube,
    /// The sign of the side's own command (a deadband or a Coulomb loss: a constant offset
    /// against the direction the wheel is told to turn).
    SignCmdWheel,
    /// The side's own command when it is negative, 0 otherwise (a wheel with another gain
    /// backwards, whatever the body does), rad/s.
    ReverseWheel,
    /// A hinge of the side's own command, sign(ω_cmd)·max(|ω_cmd| − θ, 0), with θ the
    /// [`HINGES_RAD_S`] entry of this index (a gain that changes above a speed: a piecewise
    /// linear map), rad/s.
    Hinge(u8),
    /// |vx|·wz (yaw rate lost or gained with speed, the same in both directions), m/s².
    AbsVxWz,
    /// The side's own command through a first-order filter of time constant
    /// [`FILTERS_S`] of this index (a memory of the commands: a load the loop has learnt),
    /// rad/s.
    FilteredWheel(u8),
    /// The commanded vx through the filter of [`FILTERS_S`] of this index, m/s.
    FilteredVx(u8),
    /// The commanded wz through the filter of [`FILTERS_S`] of this index, rad/s.
    FilteredWz(u8),
    /// The side's own command of [`DELAYS_S`] of this index ago, rad/s.
    DelayedWheel(u8),
}

/// The knees θ of the [`Feature::Hinge`] features, rad/s of wheel command: a grid over the
/// wheel speeds of the catalogue's robots (the Husky's U is 6 rad/s per wheel, the Warthog's
/// 16.7); a knee beyond a log's commands gives a column of zeros, which discovery leaves out.
pub const HINGES_RAD_S: [f64; 7] = [2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0];

impl Feature {
    /// Every feature, in a fixed order (the order of the term parameters).
    pub const ALL: [Feature; 48] = [
        Feature::One,
        Feature::Vx,
        Feature::Wz,
        Feature::CmdVx,
        Feature::CmdWz,
        Feature::CmdWheel,
        Feature::VxWz,
        Feature::AbsVx,
        Feature::AbsWz,
        Feature::SignVx,
        Feature::VxSq,
        Feature::WzSq,
        Feature::DeltaCmdVx,
        Feature::DeltaCmdWz,
        Feature::PrevCmdVx,
        Feature::PrevCmdWz,
        Feature::TimeInStep,
        Feature::Step,
        Feature::StepCmdWheel,
        Feature::StepCmdVx,
        Feature::ReverseVx,
        Feature::ReverseWz,
        Feature::ReverseCmdWheel,
        Feature::Ax,
        Feature::Alpha,
        Feature::CmdWheelOdd,
        Feature::CmdWheelCube,
        Feature::SignCmdWheel,
        Feature::ReverseWheel,
        Feature::Hinge(0),
        Feature::Hinge(1),
        Feature::Hinge(2),
        Feature::Hinge(3),
        Feature::Hinge(4),
        Feature::Hinge(5),
        Feature::Hinge(6),
        Feature::AbsVxWz,
        Feature::FilteredWheel(0),
        Feature::FilteredWheel(1),
        Feature::FilteredWheel(2),
        Feature::FilteredVx(0),
        Feature::FilteredVx(1),
        Feature::FilteredVx(2),
        Feature::FilteredWz(0),
        Feature::FilteredWz(1),
        Feature::FilteredWz(2),
        Feature::DelayedWheel(0),
        Feature::DelayedWheel(1),
    ];

    /// Short name, used in parameter keys and equations.
    pub fn name(self) -> &'static str {
        match self {
            Self::One => "1",
            Self::Vx => "vx",
            Self::Wz => "wz",
            Self::CmdVx => "cmd_vx",
            Self::CmdWz => "cmd_wz",
            Self::CmdWheel => "cmd_wheel",
            Self::VxWz => "vx_wz",
            Self::AbsVx => "abs_vx",
            Self::AbsWz => "abs_wz",
            Self::SignVx => "sign_vx",
            Self::VxSq => "vx_sq",
            Self::WzSq => "wz_sq",
            Self::DeltaCmdVx => "dcmd_vx",
            Self::DeltaCmdWz => "dcmd_wz",
            Self::PrevCmdVx => "prev_vx",
            Self::PrevCmdWz => "prev_wz",
            Self::TimeInStep => "t",
            Self::Step => "step",
            Self::StepCmdWheel => "step_cmd_wheel",
            Self::StepCmdVx => "step_cmd_vx",
            Self::ReverseVx => "rev_vx",
            Self::ReverseWz => "rev_wz",
            Self::ReverseCmdWheel => "rev_cmd_wheel",
            Self::Ax => "ax",
            Self::Alpha => "alpha",
            Self::CmdWheelOdd => "cmd_wheel_odd",
            Self::CmdWheelCube => "cmd_wheel_cube",
            Self::SignCmdWheel => "sign_cmd_wheel",
            Self::ReverseWheel => "rev_wheel",
            Self::Hinge(i) => HINGE_NAMES[(i as usize).min(HINGES_RAD_S.len() - 1)],
            Self::AbsVxWz => "abs_vx_wz",
            Self::FilteredWheel(i) => ["lp_wheel_0s5", "lp_wheel_2s", "lp_wheel_8s"][filter(i)],
            Self::FilteredVx(i) => ["lp_vx_0s5", "lp_vx_2s", "lp_vx_8s"][filter(i)],
            Self::FilteredWz(i) => ["lp_wz_0s5", "lp_wz_2s", "lp_wz_8s"][filter(i)],
            Self::DelayedWheel(i) => ["delay_wheel_0s1", "delay_wheel_0s3"][delay(i)],
        }
    }

    /// How the feature reads in an equation (`vx·wz`, `[reverse]·wz`, ...).
    pub fn symbol(self) -> &'static str {
        match self {
            Self::One => "1",
            Self::Vx => "vx",
            Self::Wz => "wz",
            Self::CmdVx => "vx_cmd",
            Self::CmdWz => "wz_cmd",
            Self::CmdWheel => "ω_cmd",
            Self::VxWz => "vx·wz",
            Self::AbsVx => "|vx|",
            Self::AbsWz => "|wz|",
            Self::SignVx => "sign(vx_cmd)",
            Self::VxSq => "vx²",
            Self::WzSq => "wz²",
            Self::DeltaCmdVx => "Δvx_cmd",
            Self::DeltaCmdWz => "Δwz_cmd",
            Self::PrevCmdVx => "vx_cmd[k-1]",
            Self::PrevCmdWz => "wz_cmd[k-1]",
            Self::TimeInStep => "t",
            Self::Step => "k",
            Self::StepCmdWheel => "k·ω_cmd",
            Self::StepCmdVx => "k·vx_cmd",
            Self::ReverseVx => "[reverse]·vx",
            Self::ReverseWz => "[reverse]·wz",
            Self::ReverseCmdWheel => "[reverse]·ω_cmd",
            Self::Ax => "dvx/dt",
            Self::Alpha => "dwz/dt",
            Self::CmdWheelOdd => "ω_cmd·|ω_cmd|",
            Self::CmdWheelCube => "ω_cmd³",
            Self::SignCmdWheel => "sign(ω_cmd)",
            Self::ReverseWheel => "[ω_cmd<0]·ω_cmd",
            Self::Hinge(i) => HINGE_SYMBOLS[(i as usize).min(HINGES_RAD_S.len() - 1)],
            Self::AbsVxWz => "|vx|·wz",
            Self::FilteredWheel(i) => ["LP0.5s(ω_cmd)", "LP2s(ω_cmd)", "LP8s(ω_cmd)"][filter(i)],
            Self::FilteredVx(i) => ["LP0.5s(vx_cmd)", "LP2s(vx_cmd)", "LP8s(vx_cmd)"][filter(i)],
            Self::FilteredWz(i) => ["LP0.5s(wz_cmd)", "LP2s(wz_cmd)", "LP8s(wz_cmd)"][filter(i)],
            Self::DelayedWheel(i) => ["ω_cmd(t−0.1s)", "ω_cmd(t−0.3s)"][delay(i)],
        }
    }

    /// Unit of the feature (a coefficient's unit is the target's over this).
    pub fn unit(self) -> &'static str {
        match self {
            Self::One | Self::SignVx | Self::Step => "1",
            Self::Vx | Self::CmdVx | Self::AbsVx | Self::DeltaCmdVx | Self::PrevCmdVx => "m/s",
            Self::StepCmdVx | Self::ReverseVx => "m/s",
            Self::Wz | Self::CmdWz | Self::AbsWz | Self::DeltaCmdWz | Self::PrevCmdWz => "rad/s",
            Self::ReverseWz => "rad/s",
            Self::CmdWheel | Self::StepCmdWheel | Self::ReverseCmdWheel => "rad/s",
            Self::FilteredWheel(_) | Self::FilteredWz(_) | Self::DelayedWheel(_) => "rad/s",
            Self::FilteredVx(_) => "m/s",
            Self::ReverseWheel | Self::Hinge(_) => "rad/s",
            Self::SignCmdWheel => "1",
            Self::CmdWheelOdd => "rad²/s²",
            Self::CmdWheelCube => "rad³/s³",
            Self::VxWz | Self::Ax | Self::AbsVxWz => "m/s²",
            Self::VxSq => "m²/s²",
            Self::WzSq => "rad²/s²",
            Self::TimeInStep => "s",
            Self::Alpha => "rad/s²",
        }
    }

    /// Whether the feature reads the side's own wheel command (only wheel targets have one).
    pub fn needs_side(self) -> bool {
        matches!(
            self,
            Self::CmdWheel
                | Self::StepCmdWheel
                | Self::ReverseCmdWheel
                | Self::CmdWheelOdd
                | Self::CmdWheelCube
                | Self::SignCmdWheel
                | Self::ReverseWheel
                | Self::Hinge(_)
                | Self::FilteredWheel(_)
                | Self::DelayedWheel(_)
        )
    }

    /// The value at `x`; `side` says whose wheel command the side features read.
    pub fn value(self, x: &TermInput, side: Side) -> f64 {
        let side_cmd = side.of(x.cmd);
        let reverse = if x.cmd_body.vx_m_s < 0.0 { 1.0 } else { 0.0 };
        let (vx, wz) = (x.body.vx_m_s, x.body.wz_rad_s);
        let k = x.step as f64;
        match self {
            Self::One => 1.0,
            Self::Vx => vx,
            Self::Wz => wz,
            Self::CmdVx => x.cmd_body.vx_m_s,
            Self::CmdWz => x.cmd_body.wz_rad_s,
            Self::CmdWheel => side_cmd,
            Self::VxWz => vx * wz,
            Self::AbsVx => vx.abs(),
            Self::AbsWz => wz.abs(),
            Self::SignVx => {
                if x.cmd_body.vx_m_s > 0.0 {
                    1.0
                } else if x.cmd_body.vx_m_s < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Self::VxSq => vx * vx,
            Self::WzSq => wz * wz,
            Self::DeltaCmdVx => x.cmd_body.vx_m_s - x.previous_cmd_body.vx_m_s,
            Self::DeltaCmdWz => x.cmd_body.wz_rad_s - x.previous_cmd_body.wz_rad_s,
            Self::PrevCmdVx => x.previous_cmd_body.vx_m_s,
            Self::PrevCmdWz => x.previous_cmd_body.wz_rad_s,
            Self::TimeInStep => x.t_in_step_s,
            Self::Step => k,
            Self::StepCmdWheel => k * side_cmd,
            Self::StepCmdVx => k * x.cmd_body.vx_m_s,
            Self::ReverseVx => reverse * vx,
            Self::ReverseWz => reverse * wz,
            Self::ReverseCmdWheel => reverse * side_cmd,
            Self::Ax => x.accel[0],
            Self::Alpha => x.accel[1],
            Self::CmdWheelOdd => side_cmd * side_cmd.abs(),
            Self::CmdWheelCube => side_cmd.powi(3),
            Self::SignCmdWheel => {
                if side_cmd > 0.0 {
                    1.0
                } else if side_cmd < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Self::ReverseWheel => side_cmd.min(0.0),
            Self::Hinge(i) => {
                let knee = HINGES_RAD_S[(i as usize).min(HINGES_RAD_S.len() - 1)];
                side_cmd.signum() * (side_cmd.abs() - knee).max(0.0)
            }
            Self::AbsVxWz => vx.abs() * wz,
            Self::FilteredWheel(i) => {
                let i = filter(i);
                lowpass(side_cmd, side.of(x.filtered_cmd[i]), x.t_in_step_s, FILTERS_S[i])
            }
            Self::FilteredVx(i) => {
                let i = filter(i);
                let start = x.filtered_cmd_body[i].vx_m_s;
                lowpass(x.cmd_body.vx_m_s, start, x.t_in_step_s, FILTERS_S[i])
            }
            Self::FilteredWz(i) => {
                let i = filter(i);
                let start = x.filtered_cmd_body[i].wz_rad_s;
                lowpass(x.cmd_body.wz_rad_s, start, x.t_in_step_s, FILTERS_S[i])
            }
            Self::DelayedWheel(i) => {
                if x.t_in_step_s >= DELAYS_S[delay(i)] {
                    side_cmd
                } else {
                    side.of(x.previous_cmd)
                }
            }
        }
    }

    /// A feature with memory's time: the filter's time constant of a filtered copy of the
    /// command, the delay of a delayed one, s; `None` for the others.
    pub fn memory_s(self) -> Option<f64> {
        match self {
            Self::FilteredWheel(i) | Self::FilteredVx(i) | Self::FilteredWz(i) => Some(FILTERS_S[filter(i)]),
            Self::DelayedWheel(i) => Some(DELAYS_S[delay(i)]),
            _ => None,
        }
    }

    /// The feature named `name` ([`Feature::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// The index into [`FILTERS_S`] of a filter feature (the last for an index beyond it).
fn filter(i: u8) -> usize {
    (i as usize).min(FILTERS_S.len() - 1)
}

/// The index into [`DELAYS_S`] of a delay feature.
fn delay(i: u8) -> usize {
    (i as usize).min(DELAYS_S.len() - 1)
}

/// A first-order filter's output `t` after its input stepped to `now` from an output `start`.
fn lowpass(now: f64, start: f64, t: f64, tau: f64) -> f64 {
    now + (start - now) * (-t.max(0.0) / tau).exp()
}

/// [`Feature::Hinge`]'s names, one per knee of [`HINGES_RAD_S`].
const HINGE_NAMES: [&str; 7] = [
    "hinge_2", "hinge_4", "hinge_6", "hinge_8", "hinge_10", "hinge_12", "hinge_14",
];
/// [`Feature::Hinge`]'s symbols.
const HINGE_SYMBOLS: [&str; 7] = [
    "sign(ω_cmd)·(|ω_cmd|−2)₊",
    "sign(ω_cmd)·(|ω_cmd|−4)₊",
    "sign(ω_cmd)·(|ω_cmd|−6)₊",
    "sign(ω_cmd)·(|ω_cmd|−8)₊",
    "sign(ω_cmd)·(|ω_cmd|−10)₊",
    "sign(ω_cmd)·(|ω_cmd|−12)₊",
    "sign(ω_cmd)·(|ω_cmd|−14)₊",
];
