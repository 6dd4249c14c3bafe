//! The effect registry: named model components that real robots show and that the nominal
//! model lacks (powertrain imperfections, geometry errors, the robot's own velocity controller,
//! compliance in the tyre contact, sensor faults).
//!
//! One file defines one effect: its name, its parameters (typed, with units, validity bounds,
//! the neutral value that switches it off, and the box calibration searches), where it acts
//! ([`Stage`]) and how a plant applies it (the [`Effect`] hooks, which both the rapier
//! simulator and the kinematic model call). [`REGISTRY`] lists them in the order a command
//! meets them on its way to the sensors; adding an effect is adding a file and a line there,
//! as samplers register in `drive_sim_protocol::samplers`.
//!
//! An [`Effects`] value is a set of effects switched on with their parameter values: what
//! `--inject NAME=VALUE` builds, what a simulator runs with and what calibration fits. It
//! serializes as a map from parameter name to value, the form logs and reports already use.

mod body_lag;
mod centripetal_slip;
mod command_speed_limit;
mod command_yaw_rate_limit;
mod controller_kinematics;
mod controller_wheel_limit;
mod crab_angle;
mod dead_time;
mod droop_recovery;
mod encoder_scale;
mod encoder_side_scale;
mod icr_longitudinal_offset;
mod imu_yaw_rate_bias;
mod imu_yaw_rate_scale;
mod imu_yaw_rate_sign_flip;
mod lateral_drift;
mod motor_gain;
mod motor_gain_drift;
pub mod motor_torque_speed;
mod odometry_fade;
mod pose_latency;
mod pose_updates;
mod reverse_baseline_scale;
mod set;
pub mod speed_droop;
mod step_draw;
mod suspension_torsion;
pub mod term;
mod time_constant_scale;
mod turn_memory;
mod turning_resistance;
mod wheel_deadband;
mod wheel_gain_knee;
mod wheel_radius_scale;
mod wheel_reverse_gain;
mod wheel_soft_limit;
mod wheel_speed_saturation;
mod wheel_speed_scatter;

use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
pub use odometry_fade::FadingOdometry;
pub use pose_updates::PoseUpdates;
use serde::{Deserialize, Serialize};
pub use set::Effects;
use std::fmt;
use std::sync::LazyLock;
pub use term::{Feature, Side, StepContext, TermInput, TermTarget};

/// Where an effect acts on the way from a command to the sensors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// On the command, before or inside the robot's velocity controller (delays, clamps, the
    /// controller's own kinematics).
    Command,
    /// On the wheel-speed loop (gains, limits, lag).
    Wheel,
    /// On how wheel spin becomes body motion (the rolling radius).
    Body,
    /// In the wheel-terrain contact (the tyre model): only a plant with one can run it.
    Contact,
    /// On what a sensor reports.
    Sensor,
}

impl Stage {
    /// Name in reports.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Command => "command",
            Self::Wheel => "wheel",
            Self::Body => "body",
            Self::Contact => "contact",
            Self::Sensor => "sensor",
        }
    }
}

/// What values a parameter takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamKind {
    /// A real number in the validity bounds.
    Continuous,
    /// A limit: a positive number; 0 or infinity remove it (the neutral value is infinity).
    Limit,
    /// On / off: 0 or 1.
    Flag,
}

/// How far a log's commands reach: the search boxes of limits are set below these.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CommandReach {
    /// Largest commanded wheel speed, rad/s.
    pub wheel_rad_s: f64,
    /// Largest commanded forward speed (nominal geometry), m/s.
    pub speed_m_s: f64,
    /// Largest commanded yaw rate (nominal geometry), rad/s.
    pub yaw_rate_rad_s: f64,
}

impl CommandReach {
    /// How far `commands` reach, their body velocities through `idd` (the nominal geometry).
    pub fn of_commands(commands: impl IntoIterator<Item = WheelSpeeds>, idd: &IdealDiffDrive) -> Self {
        commands.into_iter().fold(
            Self {
                wheel_rad_s: 0.0,
                speed_m_s: 0.0,
                yaw_rate_rad_s: 0.0,
            },
            |r, c| {
                let v = idd.body_from_wheels(c);
                Self {
                    wheel_rad_s: r.wheel_rad_s.max(c.left_rad_s.abs()).max(c.right_rad_s.abs()),
                    speed_m_s: r.speed_m_s.max(v.vx_m_s.abs()),
                    yaw_rate_rad_s: r.yaw_rate_rad_s.max(v.wz_rad_s.abs()),
                }
            },
        )
    }

    /// The larger of two reaches in each component.
    pub fn max(self, o: Self) -> Self {
        Self {
            wheel_rad_s: self.wheel_rad_s.max(o.wheel_rad_s),
            speed_m_s: self.speed_m_s.max(o.speed_m_s),
            yaw_rate_rad_s: self.yaw_rate_rad_s.max(o.yaw_rate_rad_s),
        }
    }
}

/// Which part of the [`CommandReach`] a limit's search box scales with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReachOf {
    /// The largest commanded wheel speed.
    Wheel,
    /// The largest commanded forward speed.
    Speed,
    /// The largest commanded yaw rate.
    YawRate,
}

/// The box calibration searches a parameter in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SearchBox {
    /// Fixed bounds, in the parameter's unit.
    Fixed {
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// A fraction of what the log commands: a limit above the largest command does nothing.
    Reach {
        /// Which reach.
        of: ReachOf,
        /// Lower bound, as a fraction of the reach.
        lower: f64,
        /// Upper bound, as a fraction of the reach.
        upper: f64,
    },
}

impl SearchBox {
    /// The bounds for a log that commands up to `reach`.
    pub fn bounds(&self, reach: &CommandReach) -> (f64, f64) {
        match *self {
            Self::Fixed { lower, upper } => (lower, upper),
            Self::Reach { of, lower, upper } => {
                let r = match of {
                    ReachOf::Wheel => reach.wheel_rad_s,
                    ReachOf::Speed => reach.speed_m_s,
                    ReachOf::YawRate => reach.yaw_rate_rad_s,
                }
                .max(1e-3);
                (lower * r, upper * r)
            }
        }
    }
}

/// One parameter of an effect.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamDef {
    /// Its name, unique over the registry: what `--inject NAME=VALUE` and reports use.
    pub key: &'static str,
    /// Unit (`-` for a ratio).
    pub unit: &'static str,
    /// What values it takes.
    pub kind: ParamKind,
    /// Smallest valid value (inclusive).
    pub min: f64,
    /// Largest valid value (inclusive).
    pub max: f64,
    /// The value at which the parameter changes nothing (gain 1, bias 0, limit infinity).
    pub neutral: f64,
    /// Where calibration searches it.
    pub search: SearchBox,
    /// Smallest change that makes a difference to a plant (a delay acts in whole integration
    /// steps): finite differences never step below it. `None`: smooth.
    pub resolution: Option<f64>,
}

impl ParamDef {
    /// Checks `value` and returns it in canonical form (a limit of 0 becomes infinity, i.e.
    /// off); the error names the parameter and the allowed range.
    pub fn check(&self, value: f64) -> Result<f64> {
        let bad = |why: String| Error::config("--inject", self.key, format!("{why}, got {value}"));
        if value.is_nan() {
            return Err(bad("must be a number".into()));
        }
        match self.kind {
            ParamKind::Flag => {
                if value == 0.0 || value == 1.0 {
                    Ok(value)
                } else {
                    Err(bad("must be 0 or 1".into()))
                }
            }
            ParamKind::Limit => {
                if value == 0.0 || value == f64::INFINITY {
                    Ok(f64::INFINITY)
                } else if value.is_finite() && value > 0.0 && value <= self.max {
                    Ok(value)
                } else {
                    Err(bad(format!(
                        "must be a limit in (0, {}] {} (0 or infinity remove it)",
                        self.max, self.unit
                    )))
                }
            }
            ParamKind::Continuous => {
                if value.is_finite() && value >= self.min && value <= self.max {
                    Ok(value)
                } else {
                    Err(bad(format!(
                        "must be in [{}, {}] {}",
                        self.min, self.max, self.unit
                    )))
                }
            }
        }
    }

    /// Whether `value` leaves the model unchanged.
    pub fn is_neutral(&self, value: f64) -> bool {
        value == self.neutral
    }
}

/// Physical quantities of a plant that effects change; plants read them once when built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantModifiers {
    /// Effective rolling radius over the nominal one.
    pub wheel_radius_scale: f64,
    /// Multiplies the wheel-speed loop's time constant.
    pub time_constant_scale: f64,
    /// Delay between a command and the controller acting on it, s.
    pub dead_time_s: f64,
    /// Multiplies the lateral friction coefficients of the tyre model.
    pub lateral_friction_scale: f64,
    /// Lateral relaxation length of the tyres, m (0: quasi-static tyre).
    pub relaxation_length_m: f64,
    /// Age of the pose when it is read, s.
    pub pose_latency_s: f64,
    /// Fade of the odometry's displacement through a held command, 1/s (0: none).
    pub odometry_fade_per_s: f64,
    /// Shortest interval between two odometry poses, s (0 with no jitter: a pose at every
    /// reading).
    pub pose_update_period_s: f64,
    /// Mean of the exponential wait added to each interval, s.
    pub pose_update_jitter_s: f64,
    /// Time constant of the body velocity behind the wheels', s (0: none).
    pub body_time_constant_s: f64,
    /// Stall torque of each side's motor at full voltage, N·m at the wheels (infinite: none).
    pub motor_stall_torque_nm: f64,
    /// Speed at which that motor's torque falls to zero, rad/s (infinite: none).
    pub motor_no_load_speed_rad_s: f64,
    /// The speed loop's droop: each side aims this many rad/s below its command per N·m it
    /// delivers (0: an ideal loop).
    pub speed_droop_rad_s_per_nm: f64,
    /// Time constant of the speed loop's integral, which wins a drooped speed back, s
    /// (infinite: a proportional loop, the droop stays).
    pub speed_droop_recovery_s: f64,
}

impl Default for PlantModifiers {
    fn default() -> Self {
        Self {
            wheel_radius_scale: 1.0,
            time_constant_scale: 1.0,
            dead_time_s: 0.0,
            lateral_friction_scale: 1.0,
            relaxation_length_m: 0.0,
            pose_latency_s: 0.0,
            odometry_fade_per_s: 0.0,
            pose_update_period_s: 0.0,
            pose_update_jitter_s: 0.0,
            body_time_constant_s: 0.0,
            motor_stall_torque_nm: f64::INFINITY,
            motor_no_load_speed_rad_s: f64::INFINITY,
            speed_droop_rad_s_per_nm: 0.0,
            speed_droop_recovery_s: f64::INFINITY,
        }
    }
}

/// A model effect. Each hook receives the effect's parameter values (in the order of
/// [`Effect::params`]) and defaults to doing nothing, so an effect implements only the hooks
/// of the stage it acts in.
pub trait Effect: Send + Sync {
    /// Name in reports and candidate lists.
    fn name(&self) -> &'static str;
    /// One line saying what it models, with the physical cause.
    fn doc(&self) -> &'static str;
    /// Where it acts.
    fn stage(&self) -> Stage;
    /// Its parameters.
    fn params(&self) -> &'static [ParamDef];
    /// It describes how a ground grips under this robot rather than the robot itself: a
    /// twin puts it in the terrain file, and a calibration on several logs of one robot fits
    /// it once per log (terrain) instead of once for all (robot). The contact stage by
    /// default; a body-stage slip caused by the tyres on this ground says so itself.
    fn on_terrain(&self) -> bool {
        self.stage() == Stage::Contact
    }
    /// The kinematic model (no tyre) can run it: every stage but the contact.
    fn kinematic(&self) -> bool {
        self.stage() != Stage::Contact
    }
    /// A generic term ([`term`]) rather than a named effect of the catalogue: calibration
    /// tries it only where equation discovery proposes it.
    fn generic(&self) -> bool {
        false
    }
    /// Calibration tries it without being asked (`--candidates` names the others). An effect
    /// enters the default catalogue once its effect on every measured calibration has been
    /// measured: adding a candidate can re-select every calibration.
    fn default_candidate(&self) -> bool {
        true
    }
    /// Transforms the command in the nominal body space, before the controller's kinematics
    /// (clamps of a velocity controller). Only called when [`Effect::uses_body_space`].
    fn body_command(&self, _p: &[f64], v: BodyVelocity) -> BodyVelocity {
        v
    }
    /// The geometry the robot's controller turns body commands into wheel targets with.
    fn controller_geometry(&self, _p: &[f64], g: IdealDiffDrive) -> IdealDiffDrive {
        g
    }
    /// The command goes through the nominal body space (the controller stage runs).
    fn uses_body_space(&self) -> bool {
        false
    }
    /// Transforms the wheel-speed targets (in registry order).
    fn wheel_targets(&self, _p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        w
    }
    /// Transforms the wheel-speed targets knowing the step and the model's state (in registry
    /// order; the default calls [`Effect::wheel_targets`], so an effect implements one of the
    /// two).
    fn wheel_targets_in(&self, p: &[f64], w: WheelSpeeds, _x: &TermInput) -> WheelSpeeds {
        self.wheel_targets(p, w)
    }
    /// The effect moves the body apart from what its wheels command (a body offset or a body
    /// lag), so plants must run their body stage.
    fn moves_body(&self) -> bool {
        false
    }
    /// A velocity added to the body's (body frame) that the wheels do not see: a sideways
    /// slide, a turn the wheels do not explain. Plants integrate it into the pose, and the IMU
    /// sees its yaw rate.
    fn body_offset(&self, _p: &[f64], _x: &TermInput) -> BodyVelocity {
        BodyVelocity::default()
    }
    /// The IMU yaw-rate reading knowing the step and the model's state (defaults to
    /// [`Effect::imu_yaw_rate`]).
    fn imu_yaw_rate_in(&self, p: &[f64], wz: f64, _x: &TermInput) -> f64 {
        self.imu_yaw_rate(p, wz)
    }
    /// The encoder readings for the true wheel spins.
    fn encoders(&self, _p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        w
    }
    /// The wheel spins that give the encoder readings `w` (inverse of [`Effect::encoders`]).
    fn wheels_from_encoders(&self, _p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        w
    }
    /// The IMU yaw-rate reading for the reading so far `wz` (in registry order).
    fn imu_yaw_rate(&self, _p: &[f64], wz: f64) -> f64 {
        wz
    }
    /// Changes the physical quantities a plant reads when it is built.
    fn modify_plant(&self, _p: &[f64], _m: &mut PlantModifiers) {}
}

impl fmt::Debug for dyn Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Every effect, in the order a command meets them (the controller's clamps and kinematics,
/// the wheel loop, the body, the contact, the sensors). Order matters where two effects of a
/// stage compose: the curvature-preserving limit acts before the motor gains, the gains before
/// the per-motor saturation.
pub static REGISTRY: LazyLock<Vec<&'static dyn Effect>> = LazyLock::new(|| {
    let mut r: Vec<&'static dyn Effect> = vec![
        &dead_time::DeadTime,
        &command_speed_limit::CommandSpeedLimit,
        &command_yaw_rate_limit::CommandYawRateLimit,
        &controller_kinematics::ControllerKinematics,
        &controller_wheel_limit::ControllerWheelLimit,
        &motor_gain::MotorGain,
        &motor_gain_drift::MotorGainDrift,
        &wheel_speed_scatter::WheelSpeedScatter,
        &wheel_deadband::WheelDeadband,
        &wheel_gain_knee::WheelGainKnee,
        &wheel_soft_limit::WheelSoftLimit,
        &wheel_reverse_gain::WheelReverseGain,
        &wheel_speed_saturation::WheelSpeedSaturation,
        &turn_memory::TurnMemory,
        &motor_torque_speed::MotorTorqueSpeed,
        &speed_droop::SpeedDroop,
        &droop_recovery::DroopRecovery,
        &time_constant_scale::TimeConstantScale,
    ];
    // Discovered wheel terms act on the targets the motors receive, after the catalogue's
    // wheel effects.
    let terms: &'static [term::Term; 6] = &term::TERMS;
    r.extend(terms[..2].iter().map(|t| t as &'static dyn Effect));
    r.extend([
        &wheel_radius_scale::WheelRadiusScale as &'static dyn Effect,
        &body_lag::BodyLag,
        &reverse_baseline_scale::ReverseBaselineScale,
        &lateral_drift::LateralDrift,
        &centripetal_slip::CentripetalSlip,
        &icr_longitudinal_offset::IcrLongitudinalOffset,
        &crab_angle::CrabAngle,
    ]);
    r.extend(terms[2..5].iter().map(|t| t as &'static dyn Effect));
    r.extend([
        &turning_resistance::TurningResistance as &'static dyn Effect,
        &suspension_torsion::SuspensionTorsion,
        &imu_yaw_rate_sign_flip::ImuYawRateSignFlip,
        &imu_yaw_rate_scale::ImuYawRateScale,
        &imu_yaw_rate_bias::ImuYawRateBias,
    ]);
    r.push(&terms[5]);
    r.extend([
        &pose_latency::PoseLatency as &'static dyn Effect,
        &odometry_fade::OdometryFade,
        &pose_updates::PoseUpdateEffect,
        &encoder_scale::EncoderScale,
        &encoder_side_scale::EncoderSideScale,
    ]);
    r
});

/// The effect registered under `name`.
pub fn effect(name: &str) -> Option<&'static dyn Effect> {
    REGISTRY.iter().copied().find(|e| e.name() == name)
}

/// Index in [`REGISTRY`] of the effect that owns the parameter `key`, and the parameter's
/// index in it.
pub fn param_owner(key: &str) -> Option<(usize, usize)> {
    REGISTRY
        .iter()
        .enumerate()
        .find_map(|(i, e)| e.params().iter().position(|p| p.key == key).map(|j| (i, j)))
}

/// The known parameter names as an error message lists them: every named effect's, then the
/// discovered terms' as one pattern (six targets times 22–25 features would bury the rest).
pub fn known_params_text() -> String {
    let named: Vec<&str> = REGISTRY
        .iter()
        .filter(|e| !e.generic())
        .flat_map(|e| e.params().iter().map(|p| p.key))
        .collect();
    let targets: Vec<String> = REGISTRY
        .iter()
        .filter(|e| e.generic())
        .map(|e| e.name().trim_start_matches("term_").to_string())
        .collect();
    format!(
        "{}, and the discovered terms' term_<target>__<feature> (targets {})",
        named.join(", "),
        targets.join(", ")
    )
}

/// Every parameter name, in registry order.
pub fn param_keys() -> Vec<&'static str> {
    REGISTRY
        .iter()
        .flat_map(|e| e.params().iter().map(|p| p.key))
        .collect()
}

#[cfg(test)]
mod tests;
