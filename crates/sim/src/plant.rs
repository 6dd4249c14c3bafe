//! The interface between the DRIVE protocol and whatever moves: the rapier simulator, or the
//! ideal differential-drive plant used as a reference and in protocol tests.

use drive_sim_model::effects::StepContext;
use drive_sim_model::error::{Error, Result};
use drive_sim_model::geometry::wrap_angle;
use drive_sim_model::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use drive_sim_model::measurement::{GroundTruth, ImuReading, Measurement, Pose};

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
    /// The protocol drives the robot outside a DRIVE step until the next
    /// [`Plant::begin_step`] (the operator's re-orientation after an interruption). The
    /// features that describe a step's command change are neutral there: the previous command
    /// is the current one and time in the step counts from here. A term fitted on steps, where
    /// `cmd − previous step's cmd` is one jump held for 6 s, would otherwise read the
    /// manoeuvre's commands as that jump held for a minute (a discovered yaw-rate term in
    /// `Δwz_cmd` made an ice twin circle instead of driving back to the centre).
    fn begin_manoeuvre(&mut self) {}
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
    let chord = v.vx_m_s * dt_s * sinc_cos(0.5 * dyaw).0;
    let (dx, dy) = (chord * c, chord * s);
    pose.x_m += dx;
    pose.y_m += dy;
    pose.yaw_rad = wrap_angle(yaw + dyaw);
}

/// A heading as its cosine and sine, advanced by small rotations: the kinematic models'
/// integration step then costs no `sin_cos` (a fifth of a kinematic calibration's time), the
/// rotation's own sine and cosine coming from their series. Built from the yaw at every reset,
/// so rounding cannot accumulate beyond one step (about 1e-13 rad over 600 substeps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heading {
    cos: f64,
    sin: f64,
}

impl Heading {
    /// The heading of `yaw_rad`.
    pub fn of(yaw_rad: f64) -> Self {
        let (sin, cos) = yaw_rad.sin_cos();
        Self { cos, sin }
    }

    /// Cosine of the heading.
    pub fn cos(self) -> f64 {
        self.cos
    }

    /// Sine of the heading.
    pub fn sin(self) -> f64 {
        self.sin
    }

    /// This heading turned by the angle whose sine and cosine are `sc`.
    fn rotated(self, (sa, ca): (f64, f64)) -> Self {
        Self {
            cos: self.cos * ca - self.sin * sa,
            sin: self.sin * ca + self.cos * sa,
        }
    }
}

/// `(sin(a) / a, cos(a))`: by their Taylor series for small `a` (the heading change of one
/// integration step, where they are exact to rounding, in multiplications only: a tenth of the
/// cost of `sin_cos`), else directly.
fn sinc_cos(a: f64) -> (f64, f64) {
    if a.abs() < 0.1 {
        // Next terms a^10 / 11! and a^10 / 10!, below 3e-17 here.
        let a2 = a * a;
        let sinc = 1.0
            - a2 * (1.0 / 6.0)
                * (1.0 - a2 * (1.0 / 20.0) * (1.0 - a2 * (1.0 / 42.0) * (1.0 - a2 * (1.0 / 72.0))));
        let cos = 1.0
            - a2 * 0.5 * (1.0 - a2 * (1.0 / 12.0) * (1.0 - a2 * (1.0 / 30.0) * (1.0 - a2 * (1.0 / 56.0))));
        (sinc, cos)
    } else {
        let (s, c) = a.sin_cos();
        (s / a, c)
    }
}

/// The true poses behind a pose that is `latency_s` old: a log's localisation reports where
/// the robot was `latency_s` ago, so a replay that starts from a logged pose must start the
/// robot that far ahead of it, and its latency must report the way there. The robot is taken
/// to have moved at `v` (body frame, constant: the velocity the step starts from) over that
/// time. Returns `(time, pose)` every `h_s` or less from `-latency_s` (the reported pose) to 0
/// (the true pose now); only `reported` when there is no latency.
pub fn poses_behind(reported: Pose, v: BodyVelocity, latency_s: f64, h_s: f64) -> Vec<(f64, Pose)> {
    if !(latency_s > 0.0 && h_s > 0.0) {
        return vec![(0.0, reported)];
    }
    let n = (latency_s / h_s).ceil() as usize;
    let h = latency_s / n as f64;
    let mut pose = reported;
    let mut heading = Heading::of(pose.yaw_rad);
    let mut out = Vec::with_capacity(n + 1);
    out.push((-latency_s, pose));
    for k in 1..=n {
        let mid = integrate_unicycle_with(&mut pose, &mut heading, v, h);
        pose.x_m -= mid.sin * v.vy_m_s * h;
        pose.y_m += mid.cos * v.vy_m_s * h;
        out.push((-latency_s + k as f64 * h, pose));
    }
    if let Some(last) = out.last_mut() {
        last.0 = 0.0;
    }
    out
}

/// [`integrate_unicycle`] with the heading of `pose` kept in `heading` (which must be
/// [`Heading::of`] the pose's yaw on entry, and is on return); returns the mid heading, the
/// frame a lateral velocity moves the pose in.
pub fn integrate_unicycle_with(
    pose: &mut Pose,
    heading: &mut Heading,
    v: BodyVelocity,
    dt_s: f64,
) -> Heading {
    let dyaw = v.wz_rad_s * dt_s;
    // The half turn's sine and cosine serve the chord, the mid heading and the end heading.
    let half = 0.5 * dyaw;
    let (sinc, cos) = sinc_cos(half);
    let turn = (half * sinc, cos);
    let mid = heading.rotated(turn);
    let chord = v.vx_m_s * dt_s * sinc;
    pose.x_m += chord * mid.cos;
    pose.y_m += chord * mid.sin;
    pose.yaw_rad = wrap_angle(pose.yaw_rad + dyaw);
    *heading = mid.rotated(turn);
    mid
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_poses_behind_a_late_pose_run_from_it_to_where_the_robot_is_now() {
        let reported = Pose {
            yaw_rad: 0.5,
            ..Default::default()
        };
        let v = BodyVelocity::new(1.0, 0.2, 0.4);
        let way = poses_behind(reported, v, 0.25, 0.01);
        assert_eq!(way.len(), 26);
        assert_eq!(way[0], (-0.25, reported));
        let (t, now) = way[25];
        assert_eq!(t, 0.0);
        // The arc of 0.25 s at (1, 0.2) m/s turning 0.4 rad/s: about 0.25 m ahead, 0.05 m left.
        let (s, c) = (0.55f64).sin_cos();
        let ahead = c * now.x_m + s * now.y_m;
        let left = -s * now.x_m + c * now.y_m;
        assert!(
            (ahead - 0.25).abs() < 2e-3 && (left - 0.05).abs() < 2e-3,
            "{now:?}"
        );
        assert!((now.yaw_rad - 0.6).abs() < 1e-12);
        assert_eq!(poses_behind(reported, v, 0.0, 0.01), vec![(0.0, reported)]);
    }

    #[test]
    fn kept_heading_integrates_as_the_direct_one() {
        let v = BodyVelocity::new(1.7, 0.0, -0.9);
        let (mut a, mut b) = (
            Pose {
                yaw_rad: 3.0,
                ..Default::default()
            },
            Pose {
                yaw_rad: 3.0,
                ..Default::default()
            },
        );
        let mut h = Heading::of(a.yaw_rad);
        for _ in 0..600 {
            integrate_unicycle(&mut a, v, 0.01);
            integrate_unicycle_with(&mut b, &mut h, v, 0.01);
        }
        assert!(
            (a.x_m - b.x_m).abs() < 1e-12 && (a.y_m - b.y_m).abs() < 1e-12,
            "{a:?} {b:?}"
        );
        assert_eq!(a.yaw_rad, b.yaw_rad);
        let direct = Heading::of(b.yaw_rad);
        assert!((h.cos - direct.cos).abs() < 1e-13 && (h.sin - direct.sin).abs() < 1e-13);
    }

    #[test]
    fn series_match_sin_and_cos() {
        for k in -200..=200 {
            let a = k as f64 * 1e-3 + 1e-7;
            let (sinc, cos) = sinc_cos(a);
            assert!((sinc - a.sin() / a).abs() <= 4.0 * f64::EPSILON, "{a}: {sinc}");
            assert!((cos - a.cos()).abs() <= 4.0 * f64::EPSILON, "{a}: {cos}");
        }
        assert_eq!(sinc_cos(0.0), (1.0, 1.0));
        assert_eq!(sinc_cos(0.5), (0.5f64.sin() / 0.5, 0.5f64.cos()));
    }

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
