//! An independent data generator for calibration tests: a skid-steer robot written here, not
//! the project's plants (its own integrator at 1 kHz, its own effects), so a calibration that
//! recovers its parameters is not just inverting its own code.

use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::log::{GroundTruth, ImuReading, Measurement, Pose};
use drive_sim::sim::Plant;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The generator's physics and sensors.
#[derive(Debug, Clone, Copy)]
pub struct TestRobotSpec {
    /// Wheel radius, m.
    pub radius_m: f64,
    /// Effective track width, m.
    pub track_m: f64,
    /// Wheel-speed lag, s.
    pub lag_s: f64,
    /// Left and right motor gains.
    pub gain: [f64; 2],
    /// Encoder noise, rad/s.
    pub enc_noise: f64,
    /// Pose noise (x, y), m.
    pub pose_noise: f64,
    /// IMU yaw-rate noise, rad/s.
    pub imu_noise: f64,
    /// Noise seed.
    pub seed: u64,
}

impl TestRobotSpec {
    /// A generator whose closed-loop DRIVE runs look like the simulated Warthog's on asphalt:
    /// the effective track width that run shows (skidding widens it from the 1.08 m baseline),
    /// its wheel lag, and noise like the measured runs'. The closed-loop tests (`tune.rs`,
    /// `judge.rs`) compare its runs with the simulator's, so the two must differ only by what a
    /// test puts in [`Unmodelled`].
    pub fn warthog_on_asphalt(seed: u64) -> Self {
        Self {
            radius_m: 0.3,
            track_m: 2.0,
            lag_s: 0.25,
            gain: [1.0, 1.0],
            enc_noise: 0.3,
            pose_noise: 0.05,
            imu_noise: 0.05,
            seed,
        }
    }
}

/// Effects of the generator that the project's catalogue did not have when discovery was
/// written: each is this file's own equation, not the project's effect code.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unmodelled {
    /// Constant lateral velocity while the wheels turn, m/s (a side slope).
    pub lateral_drift_m_s: f64,
    /// vy = k · v · w (centripetal slip), s.
    pub centripetal_s: f64,
    /// Wheel gain 1 + d · step (battery sag when negative), per step.
    pub gain_drift_per_step: f64,
    /// The body velocity lags the wheels' with this time constant, s (0: none).
    pub body_lag_s: f64,
    /// Track width when the command drives backwards, m (`None`: the same as forward).
    pub reverse_track_m: Option<f64>,
    /// Each motor clips its wheel-speed target at this magnitude, rad/s (0: no limit; the
    /// generator's own clamp, for the joint calibration's robot effect).
    pub wheel_limit_rad_s: f64,
    /// The pose is that of a point this far ahead of the turning centre, m (a lidar mounted
    /// forward): the robot itself turns about its centre; only the localisation moves
    /// sideways, at `d · wz` in the body frame. The project models this as a turning centre
    /// behind the origin (`icr_x_m = -d`), a body slide: another mechanism with the same
    /// pose.
    pub lidar_ahead_m: f64,
    /// The pose's yaw reads this much more than the body's, rad (a lidar mounted yawed against
    /// the robot's axis): driving straight, the localisation sees the robot slide sideways at
    /// `-sin(ψ) · vx`. The project models it as a crab angle of `-ψ`, a body slide.
    pub lidar_yaw_rad: f64,
    /// Not an effect: noise on the pose's yaw, rad (a lidar pose has some; without it the
    /// transient yaw-rate floor is the estimator's round-off and any lag mismatch flags).
    pub pose_yaw_noise_rad: f64,
    /// Each wheel's target is off by a normal offset of this standard deviation, rad/s, drawn
    /// when a step begins and held for it (the step-to-step scatter of the measured runs); a
    /// stop gets none.
    pub step_offset_rad_s: f64,
    /// A speed loop that remembers the last turn's load: a skid-steer turn loads the wheels by
    /// its direction more than by its rate, `s = tanh(d / 2 rad/s)` of the commanded difference
    /// `d = u_l − u_r`; the loop has learnt a load `m` that follows `s` with time constant
    /// [`Unmodelled::turn_memory_s`], and the wheels give way by this many rad/s times `s − m`,
    /// the outer wheel slower, the inner faster (a new turn, most of all one the other way,
    /// costs speed until learnt). This file's own equation of the commands, not the
    /// simulator's torque-driven integral. 0: none.
    pub turn_memory_rad_s: f64,
    /// Time constant of the learnt turn, s.
    pub turn_memory_s: f64,
}

/// The generator as a [`Plant`] the protocol runner can drive.
pub struct TestRobot {
    spec: TestRobotSpec,
    extra: Unmodelled,
    step: u32,
    /// This step's wheel offsets ([`Unmodelled::step_offset_rad_s`]), rad/s.
    offset: [f64; 2],
    /// The learnt turn load ([`Unmodelled::turn_memory_rad_s`]), between -1 and 1.
    learnt_turn: f64,
    body_v: f64,
    body_w: f64,
    rng: ChaCha8Rng,
    cmd: WheelSpeeds,
    wheels: [f64; 2],
    x: f64,
    y: f64,
    yaw: f64,
    t: f64,
}

impl TestRobot {
    /// At rest at the origin.
    pub fn new(spec: TestRobotSpec) -> Self {
        Self::with(spec, Unmodelled::default())
    }

    /// At rest at the origin, with effects outside the catalogue.
    pub fn with(spec: TestRobotSpec, extra: Unmodelled) -> Self {
        Self {
            spec,
            extra,
            step: 0,
            offset: [0.0; 2],
            learnt_turn: 0.0,
            body_v: 0.0,
            body_w: 0.0,
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            cmd: WheelSpeeds::default(),
            wheels: [0.0; 2],
            x: 0.0,
            y: 0.0,
            yaw: 0.0,
            t: 0.0,
        }
    }

    /// The body velocity the wheels command (before the body lag).
    fn wheel_body_velocity(&self) -> (f64, f64) {
        let s = &self.spec;
        let reverse = self.cmd.left_rad_s + self.cmd.right_rad_s < 0.0;
        let track = match self.extra.reverse_track_m {
            Some(t) if reverse => t,
            _ => s.track_m,
        };
        let v = s.radius_m * (self.wheels[0] + self.wheels[1]) / 2.0;
        let w = s.radius_m * (self.wheels[1] - self.wheels[0]) / track;
        (v, w)
    }

    fn body(&self) -> (f64, f64) {
        if self.extra.body_lag_s > 0.0 {
            (self.body_v, self.body_w)
        } else {
            self.wheel_body_velocity()
        }
    }

    fn lateral(&self) -> f64 {
        let (v, w) = self.body();
        // The slope's drift acts while the wheels turn (at rest the tyres hold the robot):
        // full above 0.5 rad/s of mean wheel spin.
        let spin = 0.5 * (self.wheels[0].abs() + self.wheels[1].abs());
        let moving = (spin / 0.5).min(1.0);
        moving * self.extra.lateral_drift_m_s + self.extra.centripetal_s * v * w
    }

    fn noise(&mut self, sd: f64) -> f64 {
        if sd > 0.0 {
            Normal::new(0.0, sd).unwrap().sample(&mut self.rng)
        } else {
            0.0
        }
    }
}

impl Plant for TestRobot {
    fn command(&mut self, cmd: WheelSpeeds) {
        self.cmd = cmd;
    }
    fn advance(&mut self, dt_s: f64) -> drive_sim::Result<()> {
        let n = (dt_s / 1e-3).round().max(1.0) as usize;
        let h = dt_s / n as f64;
        let drift = 1.0 + self.extra.gain_drift_per_step * self.step as f64;
        let mut target = [
            drift * self.spec.gain[0] * self.cmd.left_rad_s,
            drift * self.spec.gain[1] * self.cmd.right_rad_s,
        ];
        if self.cmd != WheelSpeeds::default() {
            target = [target[0] + self.offset[0], target[1] + self.offset[1]];
        }
        if self.extra.wheel_limit_rad_s > 0.0 {
            let l = self.extra.wheel_limit_rad_s;
            target = target.map(|t| t.clamp(-l, l));
        }
        let turn = ((self.cmd.left_rad_s - self.cmd.right_rad_s) / 2.0).tanh();
        for _ in 0..n {
            let mut target = target;
            if self.extra.turn_memory_rad_s > 0.0 {
                let give = self.extra.turn_memory_rad_s * (turn - self.learnt_turn);
                target = [target[0] - give, target[1] + give];
                self.learnt_turn += h / self.extra.turn_memory_s * (turn - self.learnt_turn);
            }
            for (w, t) in self.wheels.iter_mut().zip(target) {
                *w += h / self.spec.lag_s * (t - *w);
            }
            if self.extra.body_lag_s > 0.0 {
                let (v, w) = self.wheel_body_velocity();
                self.body_v += h / self.extra.body_lag_s * (v - self.body_v);
                self.body_w += h / self.extra.body_lag_s * (w - self.body_w);
            }
            let (v, w) = self.body();
            let vy = self.lateral();
            self.x += h * (v * self.yaw.cos() - vy * self.yaw.sin());
            self.y += h * (v * self.yaw.sin() + vy * self.yaw.cos());
            self.yaw = drive_sim::geometry::wrap_angle(self.yaw + h * w);
            self.t += h;
        }
        Ok(())
    }
    fn measure(&mut self) -> Measurement {
        let (v, w) = self.body();
        let truth_pose = Pose {
            x_m: self.x,
            y_m: self.y,
            yaw_rad: self.yaw,
            ..Pose::default()
        };
        let (pn, en, imn) = (self.spec.pose_noise, self.spec.enc_noise, self.spec.imu_noise);
        let d = self.extra.lidar_ahead_m;
        let pose = Pose {
            x_m: self.x + d * self.yaw.cos() + self.noise(pn),
            y_m: self.y + d * self.yaw.sin() + self.noise(pn),
            yaw_rad: self.yaw + self.extra.lidar_yaw_rad + self.noise(self.extra.pose_yaw_noise_rad),
            ..Pose::default()
        };
        let enc = WheelSpeeds::new(self.wheels[0] + self.noise(en), self.wheels[1] + self.noise(en));
        let wz = w + self.noise(imn);
        Measurement {
            cmd: self.cmd,
            enc,
            pose,
            imu: ImuReading {
                wz_rad_s: wz,
                ax_m_s2: 0.0,
                ay_m_s2: v * w,
                az_m_s2: 9.81,
            },
            reference: None,
            truth: Some(GroundTruth {
                pose: truth_pose,
                velocity: BodyVelocity::new(v, self.lateral(), w),
                wheels: WheelSpeeds::new(self.wheels[0], self.wheels[1]),
            }),
        }
    }
    fn true_pose(&self) -> Pose {
        Pose {
            x_m: self.x,
            y_m: self.y,
            yaw_rad: self.yaw,
            ..Pose::default()
        }
    }
    fn true_velocity(&self) -> BodyVelocity {
        let (v, w) = self.body();
        BodyVelocity::new(v, self.lateral(), w)
    }
    fn time_s(&self) -> f64 {
        self.t
    }
    fn reset(&mut self, pose: Pose, _velocity: BodyVelocity, wheels: WheelSpeeds) {
        self.x = pose.x_m;
        self.y = pose.y_m;
        self.yaw = pose.yaw_rad;
        self.wheels = [wheels.left_rad_s, wheels.right_rad_s];
        self.cmd = wheels;
        let (v, w) = self.wheel_body_velocity();
        self.body_v = v;
        self.body_w = w;
        self.t = 0.0;
    }
    fn begin_step(&mut self, ctx: drive_sim::effects::StepContext) {
        // The protocol runner says which step starts: the generator's battery sags with it, and
        // its wheels settle off their targets by a new offset.
        self.step = ctx.step;
        if self.extra.step_offset_rad_s > 0.0 {
            let n = Normal::new(0.0, self.extra.step_offset_rad_s).unwrap();
            self.offset = [n.sample(&mut self.rng), n.sample(&mut self.rng)];
        }
    }
}

/// A DRIVE run of `steps` steps of the Warthog's protocol on this generator, as a log that
/// declares the Warthog and no effect.
pub fn drive_log(
    name: &str,
    spec: TestRobotSpec,
    steps: u32,
) -> (drive_sim::log::DriveLog, drive_sim::robot::Robot) {
    drive_log_with(name, spec, Unmodelled::default(), steps)
}

/// [`drive_log`] with effects outside the catalogue.
pub fn drive_log_with(
    name: &str,
    spec: TestRobotSpec,
    extra: Unmodelled,
    steps: u32,
) -> (drive_sim::log::DriveLog, drive_sim::robot::Robot) {
    let (log, robot, _) = drive_run(name, spec, extra, steps);
    (log, robot)
}

/// The generator's DRIVE run: the log, the robot it declares and the frames it came from.
fn drive_run(
    name: &str,
    spec: TestRobotSpec,
    extra: Unmodelled,
    steps: u32,
) -> (
    drive_sim::log::DriveLog,
    drive_sim::robot::Robot,
    Vec<drive_sim::log::Frame>,
) {
    use drive_sim::protocol::sampler::UniformWheel;
    use drive_sim::protocol::{run_drive, ProtocolConfig};
    // The Warthog's geometry and command space; its file's declared effects (the measured
    // wheel-speed limit) are not this generator's truth, so the log declares none.
    let (mut robot, _) = drive_sim::robot::Robot::resolve("warthog").unwrap();
    robot.effects = Default::default();
    let cfg = ProtocolConfig {
        steps,
        ..ProtocolConfig::default()
    };
    let mut plant = TestRobot::with(spec, extra);
    let mut frames = Vec::new();
    run_drive(
        &mut plant,
        &robot,
        &mut UniformWheel::new(spec.seed),
        &cfg,
        &mut frames,
    )
    .unwrap();
    let log = super::undeclared_log(name, &robot, spec.seed, &cfg, &frames);
    (log, robot, frames)
}

/// [`drive_log_with`], also written to `path` as a drive-sim MCAP log (what the command line
/// reads), labelled with the ground `terrain`.
#[allow(dead_code)] // not every test crate that includes this module writes logs
pub fn write_drive_mcap(
    path: &std::path::Path,
    name: &str,
    terrain: &str,
    spec: TestRobotSpec,
    extra: Unmodelled,
    steps: u32,
) -> drive_sim::log::DriveLog {
    let (mut log, _, frames) = drive_run(name, spec, extra, steps);
    log.meta.terrain = terrain.into();
    drive_sim::log::mcap::write_mcap(path, &log.meta, &frames).unwrap();
    log
}
