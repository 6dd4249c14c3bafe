//! Generic model terms: an additive correction `Σ_k c_k φ_k(x)` acting on one quantity of the
//! model (a wheel target, a body velocity, the IMU), where the features `φ_k` are computed from
//! what a plant knows while it runs — its command, its own state, the time in the step, the
//! step index — and never from a measurement. Equation discovery (`drive_sim_calibration::discovery`) finds
//! such a term in a residual; registered here, it runs in the kinematic model and the
//! simulator like any catalogue effect, and calibration refits and judges it by the same rules.
//!
//! Each [`TermTarget`] is one registered effect (`term_body_vy`, ...) whose parameters are the
//! coefficients of every [`Feature`], all neutral at 0: a discovered equation switches on the
//! few it uses.
//!
//! Features with memory — the command first-order filtered ([`FILTERS_S`]) or delayed
//! ([`DELAYS_S`]) — carry their state in the [`StepContext`] a plant receives at each step's
//! start (the filters' values then, [`StepContext::next`]); within the step their value is
//! closed-form, since the command is constant over a DRIVE step. The protocol runner and the
//! replay build the context by the same recurrence, so both plants compute the same feature. A coefficient's key is `term_<target>__<feature>` (`term_body_vy__vx_wz`), so
//! terms serialize, `--inject` and appear in `calibration.json` like every other parameter.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use std::sync::LazyLock;

/// Time constants of the first-order filtered copies of the command, s: a memory of the
/// commands that lasts about a wheel loop's response, a step's, and several steps'.
pub const FILTERS_S: [f64; 3] = [0.5, 2.0, 8.0];

/// Delays of the delayed copies of the side's own command, s (a late actuation the dead time's
/// single value does not describe, or one side's).
pub const DELAYS_S: [f64; 2] = [0.1, 0.3];

/// What a plant knows about the step it is running: set at the start of each step (by the
/// protocol runner in closed loop, by the replay when replaying a log).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepContext {
    /// Step index in the run (0 for the first).
    pub step: u32,
    /// The previous step's command (zero before the first).
    pub previous_cmd: WheelSpeeds,
    /// The command of the steps before this one through a first-order filter of each time
    /// constant of [`FILTERS_S`], at this step's start (zero before the first): each filter
    /// runs over the DRIVE steps only, not the pauses and manoeuvres between them.
    pub filtered_cmd: [WheelSpeeds; 3],
}

impl StepContext {
    /// The context of the step after this one, which was commanded `cmd` for `duration_s`.
    pub fn next(&self, cmd: WheelSpeeds, duration_s: f64) -> StepContext {
        let mut filtered = self.filtered_cmd;
        for (f, tau) in filtered.iter_mut().zip(FILTERS_S) {
            let keep = (-duration_s.max(0.0) / tau).exp();
            *f = WheelSpeeds::new(
                cmd.left_rad_s + (f.left_rad_s - cmd.left_rad_s) * keep,
                cmd.right_rad_s + (f.right_rad_s - cmd.right_rad_s) * keep,
            );
        }
        StepContext {
            step: self.step + 1,
            previous_cmd: cmd,
            filtered_cmd: filtered,
        }
    }

    /// This context with its memory settled on `cmd` (an operator driving between steps: the
    /// protocol's memory does not act there).
    pub fn holding(&self, cmd: WheelSpeeds) -> StepContext {
        StepContext {
            step: self.step,
            previous_cmd: cmd,
            filtered_cmd: [cmd; 3],
        }
    }
}

/// Everything a term's features may read at one instant: the command, the model's own state
/// and the step context; never a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermInput {
    /// The command (wheel speeds the robot was told), rad/s.
    pub cmd: WheelSpeeds,
    /// The command in the nominal body space.
    pub cmd_body: BodyVelocity,
    /// The previous step's command in the nominal body space.
    pub previous_cmd_body: BodyVelocity,
    /// The previous step's command (wheel speeds), rad/s.
    pub previous_cmd: WheelSpeeds,
    /// The filtered copies of the command at the step's start ([`StepContext::filtered_cmd`]).
    pub filtered_cmd: [WheelSpeeds; 3],
    /// The same in the nominal body space.
    pub filtered_cmd_body: [BodyVelocity; 3],
    /// The model's body velocity before any body term.
    pub body: BodyVelocity,
    /// The model's body acceleration: d vx/dt m/s², d wz/dt rad/s².
    pub accel: [f64; 2],
    /// Time since the step started, s.
    pub t_in_step_s: f64,
    /// Step index.
    pub step: u32,
    /// Seed of the run's random draws (`drive-sim run --seed`; 0 where a plant has none). An
    /// effect that draws per step mixes it with the step index rather than taking numbers
    /// from the physics' stream, so switching such an effect on moves no other draw.
    pub run_seed: u64,
    /// The operator is driving the robot between DRIVE steps (a re-orientation after an
    /// interruption, `drive_sim_sim::Plant::begin_manoeuvre`), not the protocol. An operator
    /// closes the loop on where the robot goes; per-step effects of the protocol's steps do not
    /// act there.
    pub manoeuvre: bool,
}

impl TermInput {
    /// The input at the start of a step run under `ctx` with the command `cmd`, the body-space
    /// quantities through the nominal geometry `idd`; the model's state, the time in the step
    /// and the run's seed are left for the plant to fill.
    pub fn at_step(ctx: &StepContext, cmd: WheelSpeeds, idd: &IdealDiffDrive) -> Self {
        Self {
            cmd,
            cmd_body: idd.body_from_wheels(cmd),
            previous_cmd: ctx.previous_cmd,
            previous_cmd_body: idd.body_from_wheels(ctx.previous_cmd),
            filtered_cmd: ctx.filtered_cmd,
            filtered_cmd_body: ctx.filtered_cmd.map(|w| idd.body_from_wheels(w)),
            step: ctx.step,
            ..Self::default()
        }
    }

    /// The command is a stop (both wheels told zero). A discovered wheel or body term then acts
    /// not at all: it was fitted on DRIVE steps, whose commands are never a stop, and a robot
    /// told to stop brakes its wheels and stands on them (a constant or time-dependent term
    /// would otherwise push a twin that its operator is stopping, and the stop never ends).
    /// Sensor terms still act: a gyro's bias reads at rest too.
    pub fn is_stop(&self) -> bool {
        self.cmd.left_rad_s == 0.0 && self.cmd.right_rad_s == 0.0
    }
}

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

/// The model quantity a term corrects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TermTarget {
    /// The left wheel's speed target (command side: the encoder and the body follow), rad/s.
    WheelLeft,
    /// The right wheel's speed target, rad/s.
    WheelRight,
    /// Body forward velocity (the wheels do not see it), m/s.
    BodyVx,
    /// Body lateral velocity, m/s.
    BodyVy,
    /// Body yaw rate (the IMU sees it, the wheels do not), rad/s.
    BodyWz,
    /// The IMU's yaw-rate reading only, rad/s.
    ImuWz,
}

impl TermTarget {
    /// Every target, in the order a command meets them.
    pub const ALL: [TermTarget; 6] = [
        TermTarget::WheelLeft,
        TermTarget::WheelRight,
        TermTarget::BodyVx,
        TermTarget::BodyVy,
        TermTarget::BodyWz,
        TermTarget::ImuWz,
    ];

    /// Name (the registered effect is `term_<name>`).
    pub fn name(self) -> &'static str {
        match self {
            Self::WheelLeft => "wheel_left",
            Self::WheelRight => "wheel_right",
            Self::BodyVx => "body_vx",
            Self::BodyVy => "body_vy",
            Self::BodyWz => "body_wz",
            Self::ImuWz => "imu_wz",
        }
    }

    /// Name of the registered effect (`term_body_vy`, ...).
    pub fn effect_name(self) -> &'static str {
        match self {
            Self::WheelLeft => "term_wheel_left",
            Self::WheelRight => "term_wheel_right",
            Self::BodyVx => "term_body_vx",
            Self::BodyVy => "term_body_vy",
            Self::BodyWz => "term_body_wz",
            Self::ImuWz => "term_imu_wz",
        }
    }

    /// The quantity's symbol in an equation.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::WheelLeft => "Δω_left",
            Self::WheelRight => "Δω_right",
            Self::BodyVx => "Δvx",
            Self::BodyVy => "Δvy",
            Self::BodyWz => "Δwz",
            Self::ImuWz => "Δimu_wz",
        }
    }

    /// Unit of the corrected quantity.
    pub fn unit(self) -> &'static str {
        match self {
            Self::WheelLeft | Self::WheelRight | Self::BodyWz | Self::ImuWz => "rad/s",
            Self::BodyVx | Self::BodyVy => "m/s",
        }
    }

    /// Where it acts.
    pub fn stage(self) -> Stage {
        match self {
            Self::WheelLeft | Self::WheelRight => Stage::Wheel,
            Self::BodyVx | Self::BodyVy | Self::BodyWz => Stage::Body,
            Self::ImuWz => Stage::Sensor,
        }
    }

    /// Whose wheel command its side features read.
    pub fn side(self) -> Side {
        match self {
            Self::WheelLeft => Side::Left,
            Self::WheelRight => Side::Right,
            _ => Side::Neither,
        }
    }

    /// Whether `f` is a feature of this target (side features only on wheel targets).
    pub fn has_feature(self, f: Feature) -> bool {
        !f.needs_side() || matches!(self, Self::WheelLeft | Self::WheelRight)
    }

    /// The features of this target, in parameter order.
    pub fn features(self) -> Vec<Feature> {
        Feature::ALL
            .into_iter()
            .filter(|f| self.has_feature(*f))
            .collect()
    }

    /// The registered effect of this target.
    pub fn effect(self) -> &'static Term {
        let terms: &'static [Term; 6] = &TERMS;
        &terms[Self::ALL.iter().position(|t| *t == self).unwrap_or(0)]
    }

    /// The parameter key of `feature`'s coefficient on this target.
    pub fn key(self, feature: Feature) -> String {
        format!("term_{}__{}", self.name(), feature.name())
    }
}

/// The registered effect of one [`TermTarget`]: one coefficient per feature.
pub struct Term {
    target: TermTarget,
    name: &'static str,
    features: Vec<Feature>,
    params: Vec<ParamDef>,
}

impl Term {
    fn new(target: TermTarget) -> Self {
        let name = target.effect_name();
        let features = target.features();
        let params = features
            .iter()
            .map(|&f| ParamDef {
                // Built once per process: the registry's keys are 'static.
                key: Box::leak(target.key(f).into_boxed_str()),
                unit: Box::leak(
                    if f.unit() == "1" {
                        target.unit().to_string()
                    } else if f.unit() == target.unit() {
                        "-".to_string()
                    } else {
                        format!("({})/({})", target.unit(), f.unit())
                    }
                    .into_boxed_str(),
                ),
                kind: ParamKind::Continuous,
                min: -1e4,
                max: 1e4,
                neutral: 0.0,
                // Discovery sets each coefficient's box around its regression estimate; this
                // one is only what `--inject` accepts.
                search: SearchBox::Fixed {
                    lower: -1e4,
                    upper: 1e4,
                },
                resolution: None,
            })
            .collect();
        Self {
            target,
            name,
            features,
            params,
        }
    }

    /// The corrected quantity.
    pub fn target(&self) -> TermTarget {
        self.target
    }

    /// The features, in the order of the parameters.
    pub fn features(&self) -> &[Feature] {
        &self.features
    }

    /// `Σ c_k φ_k(x)` on this target's side.
    pub fn evaluate(&self, p: &[f64], x: &TermInput) -> f64 {
        let side = self.target.side();
        self.features
            .iter()
            .zip(p)
            .filter(|(_, c)| **c != 0.0)
            .map(|(f, c)| c * f.value(x, side))
            .sum()
    }
}

/// One term effect per target, in [`TermTarget::ALL`] order (registered in
/// [`super::REGISTRY`]).
pub static TERMS: LazyLock<[Term; 6]> = LazyLock::new(|| {
    [
        Term::new(TermTarget::WheelLeft),
        Term::new(TermTarget::WheelRight),
        Term::new(TermTarget::BodyVx),
        Term::new(TermTarget::BodyVy),
        Term::new(TermTarget::BodyWz),
        Term::new(TermTarget::ImuWz),
    ]
});

impl Effect for Term {
    fn name(&self) -> &'static str {
        self.name
    }
    fn doc(&self) -> &'static str {
        match self.target {
            TermTarget::WheelLeft | TermTarget::WheelRight => {
                "a discovered additive term on one wheel's speed target (Σ c_k φ_k of command and model state)"
            }
            TermTarget::BodyVx | TermTarget::BodyVy | TermTarget::BodyWz => {
                "a discovered additive term on the body velocity, which the wheels do not see"
            }
            TermTarget::ImuWz => "a discovered additive term on the IMU's yaw-rate reading",
        }
    }
    fn stage(&self) -> Stage {
        self.target.stage()
    }
    fn params(&self) -> &'static [ParamDef] {
        // The registered instance lives in a static, whose storage is 'static.
        &self.target.effect().params
    }
    fn generic(&self) -> bool {
        true
    }
    fn moves_body(&self) -> bool {
        self.target.stage() == Stage::Body
    }
    fn wheel_targets_in(&self, p: &[f64], w: WheelSpeeds, x: &TermInput) -> WheelSpeeds {
        if x.is_stop() {
            return w;
        }
        match self.target {
            TermTarget::WheelLeft => WheelSpeeds::new(w.left_rad_s + self.evaluate(p, x), w.right_rad_s),
            TermTarget::WheelRight => WheelSpeeds::new(w.left_rad_s, w.right_rad_s + self.evaluate(p, x)),
            _ => w,
        }
    }
    fn body_offset(&self, p: &[f64], x: &TermInput) -> BodyVelocity {
        if x.is_stop() {
            return BodyVelocity::default();
        }
        let v = self.evaluate(p, x);
        match self.target {
            TermTarget::BodyVx => BodyVelocity::new(v, 0.0, 0.0),
            TermTarget::BodyVy => BodyVelocity::new(0.0, v, 0.0),
            TermTarget::BodyWz => BodyVelocity::new(0.0, 0.0, v),
            _ => BodyVelocity::default(),
        }
    }
    fn imu_yaw_rate_in(&self, p: &[f64], wz: f64, x: &TermInput) -> f64 {
        match self.target {
            TermTarget::ImuWz => wz + self.evaluate(p, x),
            _ => wz,
        }
    }
}
