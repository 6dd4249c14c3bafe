//! A kinematic grey-box plant: ideal differential drive, first-order wheel-speed lag, and the
//! named effects of the simulator's `Effects` that act outside the wheel-terrain contact
//! (powertrain, wheel size, sensors). It runs in microseconds per step, so the calibration
//! machinery (replay, metrics, optimizer, effect selection) can be tested end to end on it,
//! and it is the fast model `calibrate` can fall back to.

use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use crate::log::{GroundTruth, ImuReading, Measurement, Pose};
use crate::sim::plant::{wrap_angle, Plant};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::collections::VecDeque;

/// Effects of the kinematic plant; names and meanings follow the simulator's `Effects`.
/// All neutral by default.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicEffects {
    /// Wheel speed saturates at this magnitude, rad/s (below the commanded one).
    pub wheel_speed_saturation_rad_s: Option<f64>,
    /// Left motor reaches `gain * command`.
    pub motor_gain_left: f64,
    /// Right motor reaches `gain * command`.
    pub motor_gain_right: f64,
    /// True wheel radius over the nominal one.
    pub wheel_radius_scale: f64,
    /// Pure delay between command and motor, s.
    pub dead_time_s: f64,
    /// Powertrain time constant over the robot file's.
    pub time_constant_scale: f64,
    /// IMU yaw-rate gain.
    pub imu_yaw_rate_scale: f64,
    /// IMU yaw rate reported with the wrong sign.
    pub imu_yaw_rate_sign_flip: bool,
    /// IMU yaw-rate bias, rad/s.
    pub imu_yaw_rate_bias_rad_s: f64,
    /// Pose (lidar) latency, s.
    pub pose_latency_s: f64,
    /// Encoder reading over the true wheel speed.
    pub encoder_scale: f64,
}

impl Default for KinematicEffects {
    fn default() -> Self {
        Self {
            wheel_speed_saturation_rad_s: None,
            motor_gain_left: 1.0,
            motor_gain_right: 1.0,
            wheel_radius_scale: 1.0,
            dead_time_s: 0.0,
            time_constant_scale: 1.0,
            imu_yaw_rate_scale: 1.0,
            imu_yaw_rate_sign_flip: false,
            imu_yaw_rate_bias_rad_s: 0.0,
            pose_latency_s: 0.0,
            encoder_scale: 1.0,
        }
    }
}

impl KinematicEffects {
    /// Names accepted by [`KinematicEffects::set`].
    pub const NAMES: &'static [&'static str] = &[
        "wheel_speed_saturation_rad_s",
        "motor_gain_left",
        "motor_gain_right",
        "wheel_radius_scale",
        "dead_time_s",
        "time_constant_scale",
        "imu_yaw_rate_scale",
        "imu_yaw_rate_sign_flip",
        "imu_yaw_rate_bias_rad_s",
        "pose_latency_s",
        "encoder_scale",
    ];

    /// Sets an effect by name; a sign flip is on for any value >= 0.5.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        let bad = |m: &str| Err(Error::Analysis(format!("effect `{name}` = {value}: {m}")));
        if !value.is_finite() {
            return bad("not finite");
        }
        let positive = value > 0.0;
        match name {
            "wheel_speed_saturation_rad_s" if positive => self.wheel_speed_saturation_rad_s = Some(value),
            "motor_gain_left" if positive => self.motor_gain_left = value,
            "motor_gain_right" if positive => self.motor_gain_right = value,
            "wheel_radius_scale" if positive => self.wheel_radius_scale = value,
            "dead_time_s" if value >= 0.0 => self.dead_time_s = value,
            "time_constant_scale" if positive => self.time_constant_scale = value,
            "imu_yaw_rate_scale" => self.imu_yaw_rate_scale = value,
            "imu_yaw_rate_sign_flip" => self.imu_yaw_rate_sign_flip = value >= 0.5,
            "imu_yaw_rate_bias_rad_s" => self.imu_yaw_rate_bias_rad_s = value,
            "pose_latency_s" if value >= 0.0 => self.pose_latency_s = value,
            "encoder_scale" if positive => self.encoder_scale = value,
            n if Self::NAMES.contains(&n) => return bad("out of range"),
            _ => {
                return Err(Error::Analysis(format!(
                    "unknown effect `{name}`; known: {}",
                    Self::NAMES.join(", ")
                )))
            }
        }
        Ok(())
    }
}

/// Standard deviations of the measurement noise of a [`KinematicPlant`] (for synthetic logs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinematicNoise {
    /// Seed of the noise generator.
    pub seed: u64,
    /// Pose x, y noise, m.
    pub pose_xy_m: f64,
    /// Pose yaw noise, rad.
    pub pose_yaw_rad: f64,
    /// Encoder noise, rad/s.
    pub enc_rad_s: f64,
    /// IMU yaw-rate noise, rad/s.
    pub imu_wz_rad_s: f64,
}

/// Internal integration step, s: fine enough that dead time and latency act continuously.
const SUBSTEP_S: f64 = 0.005;

/// IDD + first-order lag + [`KinematicEffects`]; see the module doc.
#[derive(Debug, Clone)]
pub struct KinematicPlant {
    idd: IdealDiffDrive,
    time_constant_s: f64,
    effects: KinematicEffects,
    noise: Option<(KinematicNoise, ChaCha8Rng)>,
    /// Commands with the time they were given, oldest first (for the dead time).
    cmds: VecDeque<(f64, WheelSpeeds)>,
    wheels: WheelSpeeds,
    pose: Pose,
    /// Recent true poses (time, pose), for the pose latency.
    poses: VecDeque<(f64, Pose)>,
    time_s: f64,
    velocity: BodyVelocity,
}

impl KinematicPlant {
    /// A plant at rest at the origin. `idd` is the nominal geometry; the effects change the
    /// truth around it.
    pub fn new(
        idd: IdealDiffDrive,
        time_constant_s: f64,
        effects: KinematicEffects,
        noise: Option<KinematicNoise>,
    ) -> Self {
        let mut p = Self {
            idd,
            time_constant_s,
            effects,
            noise: noise.map(|n| (n, ChaCha8Rng::seed_from_u64(n.seed))),
            cmds: VecDeque::new(),
            wheels: WheelSpeeds::default(),
            pose: Pose::default(),
            poses: VecDeque::new(),
            time_s: 0.0,
            velocity: BodyVelocity::default(),
        };
        p.reset(Pose::default(), BodyVelocity::default(), WheelSpeeds::default());
        p
    }

    /// The command acting on the motors at time `t` (dead time applied).
    fn delayed_cmd(&self, t: f64) -> WheelSpeeds {
        let t = t - self.effects.dead_time_s;
        let mut c = self.cmds.front().map(|c| c.1).unwrap_or_default();
        for &(tc, cmd) in &self.cmds {
            if tc <= t + 1e-12 {
                c = cmd;
            } else {
                break;
            }
        }
        c
    }

    fn target(&self, cmd: WheelSpeeds) -> WheelSpeeds {
        let e = &self.effects;
        let sat = |w: f64| match e.wheel_speed_saturation_rad_s {
            Some(s) => w.clamp(-s, s),
            None => w,
        };
        WheelSpeeds::new(
            sat(e.motor_gain_left * cmd.left_rad_s),
            sat(e.motor_gain_right * cmd.right_rad_s),
        )
    }

    fn true_idd(&self) -> IdealDiffDrive {
        IdealDiffDrive {
            wheel_radius_m: self.idd.wheel_radius_m * self.effects.wheel_radius_scale,
            baseline_m: self.idd.baseline_m,
        }
    }

    fn pose_at(&self, t: f64) -> Pose {
        let mut prev = match self.poses.front() {
            Some(p) => *p,
            None => return self.pose,
        };
        for &(tp, p) in &self.poses {
            if tp >= t {
                let span = tp - prev.0;
                if span <= 1e-12 {
                    return p;
                }
                let a = ((t - prev.0) / span).clamp(0.0, 1.0);
                let lerp = |x: f64, y: f64| x + a * (y - x);
                return Pose {
                    x_m: lerp(prev.1.x_m, p.x_m),
                    y_m: lerp(prev.1.y_m, p.y_m),
                    z_m: lerp(prev.1.z_m, p.z_m),
                    roll_rad: lerp(prev.1.roll_rad, p.roll_rad),
                    pitch_rad: lerp(prev.1.pitch_rad, p.pitch_rad),
                    yaw_rad: prev.1.yaw_rad + a * wrap_angle(p.yaw_rad - prev.1.yaw_rad),
                };
            }
            prev = (tp, p);
        }
        self.pose
    }
}

impl Plant for KinematicPlant {
    fn command(&mut self, cmd: WheelSpeeds) {
        if self.cmds.back().is_some_and(|c| c.0 >= self.time_s) {
            self.cmds.pop_back();
        }
        self.cmds.push_back((self.time_s, cmd));
    }

    fn advance(&mut self, dt_s: f64) -> Result<()> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(Error::Diverged {
                step: 0,
                time_s: self.time_s,
                message: format!("invalid time step {dt_s}"),
            });
        }
        let n = (dt_s / SUBSTEP_S).ceil().max(1.0) as usize;
        let h = dt_s / n as f64;
        let tau = self.time_constant_s * self.effects.time_constant_scale;
        let a = if tau > 0.0 { 1.0 - (-h / tau).exp() } else { 1.0 };
        let idd = self.true_idd();
        for _ in 0..n {
            let target = self.target(self.delayed_cmd(self.time_s));
            let before = self.wheels;
            self.wheels.left_rad_s += a * (target.left_rad_s - self.wheels.left_rad_s);
            self.wheels.right_rad_s += a * (target.right_rad_s - self.wheels.right_rad_s);
            // Midpoint of the wheel speeds over the substep, then an exact unicycle arc.
            let mid = WheelSpeeds::new(
                (before.left_rad_s + self.wheels.left_rad_s) / 2.0,
                (before.right_rad_s + self.wheels.right_rad_s) / 2.0,
            );
            let v = idd.body_from_wheels(mid);
            let (yaw, dyaw) = (self.pose.yaw_rad, v.wz_rad_s * h);
            let (dx, dy) = if dyaw.abs() < 1e-9 {
                (v.vx_m_s * h * yaw.cos(), v.vx_m_s * h * yaw.sin())
            } else {
                let rho = v.vx_m_s / v.wz_rad_s;
                (
                    rho * ((yaw + dyaw).sin() - yaw.sin()),
                    -rho * ((yaw + dyaw).cos() - yaw.cos()),
                )
            };
            self.pose.x_m += dx;
            self.pose.y_m += dy;
            self.pose.yaw_rad = wrap_angle(yaw + dyaw);
            self.time_s += h;
            self.velocity = idd.body_from_wheels(self.wheels);
            self.poses.push_back((self.time_s, self.pose));
        }
        // Keep only what the dead time and latency can still reach.
        let horizon = self.effects.dead_time_s.max(self.effects.pose_latency_s) + 2.0 * dt_s + 0.1;
        while self.cmds.len() > 1 && self.cmds[1].0 < self.time_s - horizon {
            self.cmds.pop_front();
        }
        while self.poses.len() > 2 && self.poses[1].0 < self.time_s - horizon {
            self.poses.pop_front();
        }
        Ok(())
    }

    fn measure(&mut self) -> Measurement {
        let e = self.effects.clone();
        let v = self.velocity;
        let sign = if e.imu_yaw_rate_sign_flip { -1.0 } else { 1.0 };
        let mut enc = WheelSpeeds::new(
            e.encoder_scale * self.wheels.left_rad_s,
            e.encoder_scale * self.wheels.right_rad_s,
        );
        let mut wz = sign * e.imu_yaw_rate_scale * v.wz_rad_s + e.imu_yaw_rate_bias_rad_s;
        let mut pose = if e.pose_latency_s > 0.0 {
            self.pose_at(self.time_s - e.pose_latency_s)
        } else {
            self.pose
        };
        if let Some((n, rng)) = &mut self.noise {
            let mut draw = |s: f64| {
                if s > 0.0 {
                    Normal::new(0.0, s).map(|d| d.sample(rng)).unwrap_or(0.0)
                } else {
                    0.0
                }
            };
            pose.x_m += draw(n.pose_xy_m);
            pose.y_m += draw(n.pose_xy_m);
            pose.yaw_rad = wrap_angle(pose.yaw_rad + draw(n.pose_yaw_rad));
            enc.left_rad_s += draw(n.enc_rad_s);
            enc.right_rad_s += draw(n.enc_rad_s);
            wz += draw(n.imu_wz_rad_s);
        }
        Measurement {
            cmd: self.cmds.back().map(|c| c.1).unwrap_or_default(),
            enc,
            pose,
            imu: ImuReading {
                wz_rad_s: wz,
                ax_m_s2: 0.0,
                ay_m_s2: v.vx_m_s * v.wz_rad_s,
                az_m_s2: 9.81,
            },
            reference: None,
            truth: Some(GroundTruth {
                pose: self.pose,
                velocity: v,
                wheels: self.wheels,
            }),
        }
    }

    fn true_pose(&self) -> Pose {
        self.pose
    }

    fn true_velocity(&self) -> BodyVelocity {
        self.velocity
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }

    fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds) {
        // Kinematic: the wheels define the body velocity; `velocity` has no independent state.
        let _ = velocity;
        self.pose = pose;
        self.wheels = wheels;
        self.velocity = self.true_idd().body_from_wheels(wheels);
        self.cmds.clear();
        // The command history that holds the wheels where they are.
        self.cmds.push_back((f64::NEG_INFINITY, wheels));
        self.poses.clear();
        self.poses.push_back((self.time_s, pose));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn idd() -> IdealDiffDrive {
        IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        }
    }

    fn run(effects: KinematicEffects, cmd: WheelSpeeds, t_s: f64) -> KinematicPlant {
        let mut p = KinematicPlant::new(idd(), 0.1, effects, None);
        p.command(cmd);
        for _ in 0..(t_s / 0.05).round() as usize {
            p.advance(0.05).unwrap();
        }
        p
    }

    #[test]
    fn neutral_effects_follow_the_idd() {
        // 1 s at (2, 2) rad/s with tau = 0.1 s: wheel = 2 (1 - e^-10) ~ 2; distance
        // r * ∫ 2 (1 - e^{-t/τ}) dt = 0.3 * 2 * (1 - 0.1 (1 - e^-10)) = 0.54 m.
        let p = run(KinematicEffects::default(), WheelSpeeds::new(2.0, 2.0), 1.0);
        assert!((p.true_pose().x_m - 0.54).abs() < 1e-3, "{:?}", p.true_pose());
        assert!((p.true_velocity().vx_m_s - 0.6).abs() < 1e-3);
    }

    #[test]
    fn effects_act_as_named() {
        let mut e = KinematicEffects::default();
        e.set("motor_gain_left", 0.5).unwrap();
        e.set("wheel_speed_saturation_rad_s", 3.0).unwrap();
        let p = run(e, WheelSpeeds::new(4.0, 4.0), 3.0);
        // left 0.5 * 4 = 2, right min(4, 3) = 3: vx = 0.3 * 2.5 = 0.75, wz = 0.3 / 1.08.
        let v = p.true_velocity();
        assert!((v.vx_m_s - 0.75).abs() < 1e-6 && (v.wz_rad_s - 0.3 / 1.08).abs() < 1e-6);

        // Dead time 0.5 s: after 0.4 s nothing moved.
        let mut e = KinematicEffects::default();
        e.set("dead_time_s", 0.5).unwrap();
        let p = run(e, WheelSpeeds::new(2.0, 2.0), 0.4);
        assert_eq!(p.true_pose().x_m, 0.0);

        // Sensors: encoder scale and IMU sign flip change readings, not the truth.
        let mut e = KinematicEffects::default();
        e.set("encoder_scale", 1.1).unwrap();
        e.set("imu_yaw_rate_sign_flip", 1.0).unwrap();
        let mut p = run(e, WheelSpeeds::new(-1.0, 1.0), 3.0);
        let m = p.measure();
        assert!((m.enc.right_rad_s - 1.1).abs() < 1e-6);
        assert!((m.imu.wz_rad_s + 0.6 / 1.08).abs() < 1e-6);
        assert!((p.true_velocity().wz_rad_s - 0.6 / 1.08).abs() < 1e-6);

        assert!(KinematicEffects::default().set("warp_drive", 1.0).is_err());
        assert!(KinematicEffects::default().set("dead_time_s", -1.0).is_err());
    }

    #[test]
    fn pose_latency_delays_the_pose() {
        let mut e = KinematicEffects::default();
        e.set("pose_latency_s", 0.2).unwrap();
        let mut p = run(e, WheelSpeeds::new(2.0, 2.0), 2.0);
        // Steady at 0.6 m/s: the reported pose lags 0.2 s * 0.6 m/s = 0.12 m.
        let lag = p.true_pose().x_m - p.measure().pose.x_m;
        assert!((lag - 0.12).abs() < 1e-3, "{lag}");
    }
}
