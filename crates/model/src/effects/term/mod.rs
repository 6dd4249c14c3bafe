//! Generic model terms: an additive correction `Σ_k c_k φ_k(x)` acting on one quantity of the
//! model (a wheel target, a body velocity, the IMU), where the features `φ_k` are computed from
//! what a plant knows while it runs — its command, its own state, the time in the step, the
//! step index — and never from a measurement. Equation discovery
//! (`drive_sim_calibration::discovery`) finds such a term in a residual; registered here, it
//! runs in the kinematic model and the simulator like any catalogue effect, and calibration
//! refits and judges it by the same rules.
//!
//! Each [`TermTarget`] is one registered effect (`term_body_vy`, ...) whose parameters are the
//! coefficients of every [`Feature`] ([`feature`]: the library), all neutral at 0: a discovered
//! equation switches on the few it uses. A coefficient's key is `term_<target>__<feature>`
//! (`term_body_vy__vx_wz`), so terms serialize, `--inject` and appear in `calibration.json` like
//! every other parameter.
//!
//! Features with memory — the command first-order filtered ([`FILTERS_S`]) or delayed
//! ([`DELAYS_S`]) — carry their state in the [`StepContext`] a plant receives at each step's
//! start (the filters' values then, [`StepContext::next`]); within the step their value is
//! closed-form, since the command is constant over a DRIVE step. The protocol runner and the
//! replay build the context by the same recurrence, so both plants compute the same feature.

pub mod feature;

pub use feature::{Feature, Side, DELAYS_S, FILTERS_S, HINGES_RAD_S};

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use std::sync::LazyLock;

/// Completed steps a [`StepContext`] remembers: with DRIVE's 6 s steps, 48 s, over which a
/// memory of up to 8 s forgets where it started to e⁻⁶.
pub const HISTORY_STEPS: usize = 8;

/// A completed step as a memory of the commands sees it: what it commanded, for how long.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PastStep {
    /// Its command, rad/s.
    pub cmd: WheelSpeeds,
    /// Its duration, s (infinite for a memory settled on `cmd`, [`StepContext::holding`]).
    pub duration_s: f64,
}

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
    /// The last [`HISTORY_STEPS`] completed steps, oldest first (zero-length steps of no
    /// command before the first): what an effect with a memory of its own time constant
    /// reads ([`filtered_history`]).
    pub history: [PastStep; HISTORY_STEPS],
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
        let mut history = self.history;
        history.rotate_left(1);
        history[HISTORY_STEPS - 1] = PastStep { cmd, duration_s };
        StepContext {
            step: self.step + 1,
            previous_cmd: cmd,
            filtered_cmd: filtered,
            history,
        }
    }

    /// This context with its memory settled on `cmd` (an operator driving between steps: the
    /// protocol's memory does not act there).
    pub fn holding(&self, cmd: WheelSpeeds) -> StepContext {
        StepContext {
            step: self.step,
            previous_cmd: cmd,
            filtered_cmd: [cmd; 3],
            history: [PastStep {
                cmd,
                duration_s: f64::INFINITY,
            }; HISTORY_STEPS],
        }
    }
}

/// A signal through a first-order filter of time constant `tau_s`, from 0 before the first
/// of `steps` (each the signal's value over a step and that step's duration, oldest first):
/// the filter's value at the start of the step after them.
pub fn filtered_history(steps: impl IntoIterator<Item = (f64, f64)>, tau_s: f64) -> f64 {
    steps.into_iter().fold(0.0, |f, (u, duration_s)| {
        let keep = if tau_s > 0.0 {
            (-duration_s.max(0.0) / tau_s).exp()
        } else {
            0.0
        };
        u + (f - u) * keep
    })
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
    /// The completed steps before this one ([`StepContext::history`]).
    pub history: [PastStep; HISTORY_STEPS],
    /// Their commands in the nominal body space.
    pub history_cmd_body: [BodyVelocity; HISTORY_STEPS],
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
            history: ctx.history,
            history_cmd_body: ctx.history.map(|p| idd.body_from_wheels(p.cmd)),
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
