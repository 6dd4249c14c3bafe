//! The interface between the DRIVE protocol and whatever moves: the rapier simulator, or the
//! ideal differential-drive plant used as a reference and in protocol tests.

use crate::effects::StepContext;
use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use crate::measurement::{GroundTruth, ImuReading, Measurement, Pose};

/// Something the protocol can drive: it takes wheel-speed targets and can be measured.
pub trait Plant {
    /// Sets the wheel-speed targets (the low-level controller applies its own ramps and limits).
    fn command(&mut self, cmd: WheelSpeeds);
    /// Advances simulated time by `dt_s`.
    fn advance(&mut self, dt_s: f64) -> Result<()>;
    /// Reads the sensors now; `cmd` of the returned measurement is the current target.
    fn measure(&mut self) -> Measurement;
    /// True pose in the world frame (what the safety operator sees).
    fn true_pose(&self) -> Pose;
    /// True body velocity.
    fn true_velocity(&self) -> BodyVelocity;
    /// Simulated time since creation or the last [`Plant::reset`], s.
    fn time_s(&self) -> f64;
    /// Puts the robot at `pose` (on the ground), moving at `velocity` (body frame) with its
    /// wheels at `wheels`, and the wheel-speed targets at `wheels`, with time restarting at 0:
    /// the start of a replayed step.
    fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds);
    /// The wheel spins at which this plant's encoders read `encoders` (a plant with an encoder
    /// fault inverts it): a replay starts from measured readings, not from the truth.
    fn wheels_from_encoders(&self, encoders: WheelSpeeds) -> WheelSpeeds {
        encoders
    }
    /// A new step starts (called by the protocol runner before each attempt, by the replay
    /// after each reset): effects that read the step index or the previous command (a gain
    /// drifting over the run, discovered terms) see it from here on.
    fn begin_step(&mut self, ctx: StepContext) {
        let _ = ctx;
    }
}

/// A robot that follows the ideal differential drive exactly, with a first-order lag on the
/// wheel speeds: no slip, no dynamics of the chassis. The reference for "what the IDD predicts".
#[derive(Debug, Clone)]
pub struct IdealPlant {
    idd: IdealDiffDrive,
    time_constant_s: f64,
    cmd: WheelSpeeds,
    wheels: WheelSpeeds,
    pose: Pose,
    time_s: f64,
    last_velocity: BodyVelocity,
}

impl IdealPlant {
    /// A plant at the origin, at rest. `time_constant_s = 0` makes wheels follow instantly.
    pub fn new(idd: IdealDiffDrive, time_constant_s: f64) -> Self {
        Self {
            idd,
            time_constant_s,
            cmd: WheelSpeeds::default(),
            wheels: WheelSpeeds::default(),
            pose: Pose::default(),
            time_s: 0.0,
            last_velocity: BodyVelocity::default(),
        }
    }
}

/// Moves `pose` along a unicycle at constant body velocity `v` for `dt_s` (exact arc, yaw
/// wrapped).
pub fn integrate_unicycle(pose: &mut Pose, v: BodyVelocity, dt_s: f64) {
    let (yaw, dyaw) = (pose.yaw_rad, v.wz_rad_s * dt_s);
    // The chord of the arc: length 2ρ sin(dψ/2) along the mid heading ψ + dψ/2 (one sin_cos
    // instead of two; this runs at every integration step of the kinematic models).
    let (s, c) = (yaw + 0.5 * dyaw).sin_cos();
    let chord = if dyaw.abs() < 1e-9 {
        v.vx_m_s * dt_s
    } else {
        2.0 * v.vx_m_s / v.wz_rad_s * (0.5 * dyaw).sin()
    };
    let (dx, dy) = (chord * c, chord * s);
    pose.x_m += dx;
    pose.y_m += dy;
    pose.yaw_rad = wrap_angle(yaw + dyaw);
}

/// The measurement of a kinematic plant (no body dynamics): the given readings, an IMU whose
/// accelerometer sees only gravity and the centripetal `vx * wz` of the true motion.
pub fn kinematic_measurement(
    cmd: WheelSpeeds,
    enc: WheelSpeeds,
    pose: Pose,
    imu_wz_rad_s: f64,
    truth: GroundTruth,
) -> Measurement {
    let v = truth.velocity;
    Measurement {
        cmd,
        enc,
        pose,
        imu: ImuReading {
            wz_rad_s: imu_wz_rad_s,
            ax_m_s2: 0.0,
            ay_m_s2: v.vx_m_s * v.wz_rad_s,
            az_m_s2: 9.81,
        },
        reference: None,
        truth: Some(truth),
    }
}

impl Plant for IdealPlant {
    fn command(&mut self, cmd: WheelSpeeds) {
        self.cmd = cmd;
    }
    fn advance(&mut self, dt_s: f64) -> Result<()> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(Error::Diverged {
                step: 0,
                time_s: self.time_s,
                message: format!("invalid time step {dt_s}"),
            });
        }
        let a = if self.time_constant_s > 0.0 {
            1.0 - (-dt_s / self.time_constant_s).exp()
        } else {
            1.0
        };
        self.wheels.left_rad_s += a * (self.cmd.left_rad_s - self.wheels.left_rad_s);
        self.wheels.right_rad_s += a * (self.cmd.right_rad_s - self.wheels.right_rad_s);
        let v = self.idd.body_from_wheels(self.wheels);
        integrate_unicycle(&mut self.pose, v, dt_s);
        self.time_s += dt_s;
        self.last_velocity = v;
        Ok(())
    }
    fn measure(&mut self) -> Measurement {
        let truth = GroundTruth {
            pose: self.pose,
            velocity: self.last_velocity,
            wheels: self.wheels,
        };
        kinematic_measurement(
            self.cmd,
            self.wheels,
            self.pose,
            self.last_velocity.wz_rad_s,
            truth,
        )
    }
    fn true_pose(&self) -> Pose {
        self.pose
    }
    fn true_velocity(&self) -> BodyVelocity {
        self.last_velocity
    }
    fn time_s(&self) -> f64 {
        self.time_s
    }
    fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds) {
        // The IDD has no lateral or independent body state: the wheels define the velocity.
        let _ = velocity;
        self.pose = pose;
        self.wheels = wheels;
        self.cmd = wheels;
        self.time_s = 0.0;
        self.last_velocity = self.idd.body_from_wheels(wheels);
    }
}

/// Wraps an angle to (-π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let mut a = a % std::f64::consts::TAU;
    if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    } else if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_plant_drives_a_circle() {
        // wl = 1, wr = 2 rad/s, r = 0.3, b = 1.08 -> vx = 0.45 m/s, wz = 0.2778 rad/s,
        // radius 1.62 m: after a full period 2π/wz the robot is back at the origin.
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        let mut p = IdealPlant::new(idd, 0.0);
        p.command(WheelSpeeds::new(1.0, 2.0));
        let period = std::f64::consts::TAU / (0.3 / 1.08);
        let n = 1000;
        for _ in 0..n {
            p.advance(period / n as f64).unwrap();
        }
        let q = p.true_pose();
        assert!(q.x_m.abs() < 1e-9 && q.y_m.abs() < 1e-9, "{q:?}");
        // Half a period: at (0, 2R).
        let mut p = IdealPlant::new(idd, 0.0);
        p.command(WheelSpeeds::new(1.0, 2.0));
        p.advance(period / 2.0).unwrap();
        assert!((p.true_pose().y_m - 2.0 * 1.62).abs() < 1e-9);
    }
}
