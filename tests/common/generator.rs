//! An independent data generator for calibration tests: a skid-steer robot written here, not
//! the project's plants (its own integrator at 1 kHz, its own effects), so a calibration that
//! recovers its parameters is not just inverting its own code.

use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::log::{GroundTruth, ImuReading, Measurement, Pose};
use drive_sim::sim::Plant;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::collections::VecDeque;

/// The generator's integration step, s (1 kHz): its delays are whole numbers of these.
const STEP_S: f64 = 1e-3;

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

    /// The calibration's honesty checks' robot (`tests/long/calibration_uncertainty.rs`, the
    /// standard errors of `tests/statistics/standard_errors.rs`): the Warthog's geometry, a
    /// left motor at 85 % of its command, and noise like the measured runs', so that the
    /// fitted gains carry standard errors of a few percent.
    pub fn uneven_motors(seed: u64) -> Self {
        Self {
            radius_m: 0.3,
            track_m: 1.08,
            lag_s: 0.15,
            gain: [0.85, 1.0],
            enc_noise: 0.15,
            pose_noise: 0.02,
            imu_noise: 0.03,
            seed,
        }
    }

    /// The discovery cases' robot (`tests/long/discovery.rs`, the randomized benchmark, the joint
    /// calibration of `tests/long/twin_joint.rs`): the
    /// Warthog's geometry, the generator's lag, and noise low enough that a missing effect
    /// stands out in a 90-step log.
    pub fn discovery(seed: u64) -> Self {
        Self {
            radius_m: 0.3,
            track_m: 1.08,
            lag_s: 0.15,
            gain: [1.0, 1.0],
            enc_noise: 0.1,
            pose_noise: 0.01,
            imu_noise: 0.02,
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

    // The benchmark's families (`tests/common/random_cases.rs`): each off at its default (0,
    // or 0 for every side). The command maps act on each side's command `u` on its way to the
    // wheel-speed loop, in the order of the fields (the dead time first, the reverse gain
    // last), before the motor gains, the gain drift and the wheel limit above.
    /// Pure actuation dead time, s: the wheel loop acts on the command of `τ` ago (a bus
    /// latency, a slow control loop), a FIFO of the 1 kHz steps, so it is a whole number of
    /// milliseconds. 0: none.
    pub dead_time_s: f64,
    /// Command cross-coupling: `u_l' = u_l + c_l · u_r`, `u_r' = u_r + c_r · u_l` (a motor
    /// driver whose mixer leaks a share of one side's command into the other's), `[c_l, c_r]`,
    /// dimensionless. 0: none.
    pub cross_coupling: [f64; 2],
    /// Deadband θ, rad/s: `|u| ≤ θ → 0`, else `sign(u) · (|u| − θ)` (a driver that ignores
    /// small commands, static friction its feed-forward does not cover, so every command
    /// loses θ). 0: none.
    pub deadband_rad_s: f64,
    /// Hinge θ, rad/s, of [`Unmodelled::hinge_gain_change`]: above it the loop's gain changes
    /// (a motor past its base speed, field weakening).
    pub hinge_rad_s: f64,
    /// Gain change k above the hinge: `|u| > θ → sign(u) · (θ + (1 + k) · (|u| − θ))`,
    /// dimensionless. 0: none.
    pub hinge_gain_change: f64,
    /// Gain curve per side, s/rad: `u · max(0, 1 + a · |u|)` (the driver's voltage-to-speed
    /// map is not linear: a > 0 over-delivers at speed, a < 0 falls short, softly
    /// saturating), `[a_l, a_r]`. 0: none.
    pub gain_curve_s_rad: [f64; 2],
    /// Soft speed limit S, rad/s: `S · tanh(u / S)` (the voltage headroom shrinks as the motor
    /// speeds up: no hard clip, a gradual one). 0: none.
    pub soft_limit_rad_s: f64,
    /// Reverse gain change δ: a side told a negative speed gets `(1 + δ) · u` (a driver or
    /// gearbox that is not symmetric), dimensionless. 0: none.
    pub reverse_gain_change: f64,
    /// Backlash, rad at the wheel: slack in the chain between the motor (which the encoder
    /// reads) and the wheel (which moves the body); the gap `g = motor angle − wheel angle`
    /// stays in `[−b/2, b/2]`, so after a reversal the motor turns through the slack before
    /// the wheel follows. 0: none.
    pub backlash_rad: f64,
    /// Yaw damping k, s/m: the body turns at `w · max(0, 1 − k · |v|)` of what its wheels say
    /// (lateral tyre forces that grow with speed resist the skid: understeer). 0: none.
    pub yaw_damping_s_m: f64,
    /// Gyro bias drifting over the run, rad/s per step: the IMU reads `d · k` more at step `k`
    /// (the gyro warming up). 0: none.
    pub imu_bias_drift_rad_s_per_step: f64,
    /// Gyro scale error e: the IMU reads `(1 + e) · wz`. 0: none.
    pub imu_scale_error: f64,
    /// Constant gyro bias, rad/s. 0: none.
    pub imu_bias_rad_s: f64,
    /// Encoder scale error per side: each encoder reads `(1 + e) · ω` (a wrong count per
    /// revolution configured on that side), `[e_l, e_r]`. 0: none.
    pub encoder_scale_error: [f64; 2],
    /// Probability that an encoder reading is lost and reported as 0 (a dropped frame the
    /// driver fills with zero), per reading and side. 0: none.
    pub encoder_dropout: f64,
    /// Counts per wheel revolution of an incremental encoder whose speed is the count
    /// difference over the sampling period: readings are multiples of `2π / (N · Δt)` (zero
    /// mean error, only noise). 0: an ideal encoder.
    pub encoder_counts_per_rev: u32,
    /// The localisation reports the pose of this long ago, s (a slow scan matcher). 0: none.
    pub pose_latency_s: f64,
}

impl Unmodelled {
    /// Each side's command after the command maps (cross-coupling, deadband, hinge, gain
    /// curve, soft limit, reverse gain); exactly `cmd` when they are all off.
    fn command_map(&self, cmd: WheelSpeeds) -> [f64; 2] {
        let mut u = [cmd.left_rad_s, cmd.right_rad_s];
        if self.cross_coupling != [0.0; 2] {
            let c = self.cross_coupling;
            u = [u[0] + c[0] * u[1], u[1] + c[1] * u[0]];
        }
        for (side, x) in u.iter_mut().enumerate() {
            if self.deadband_rad_s > 0.0 {
                let t = self.deadband_rad_s;
                *x = if x.abs() <= t {
                    0.0
                } else {
                    x.signum() * (x.abs() - t)
                };
            }
            if self.hinge_gain_change != 0.0 && x.abs() > self.hinge_rad_s {
                let t = self.hinge_rad_s;
                *x = x.signum() * (t + (1.0 + self.hinge_gain_change) * (x.abs() - t));
            }
            let a = self.gain_curve_s_rad[side];
            if a != 0.0 {
                *x *= (1.0 + a * x.abs()).max(0.0);
            }
            if self.soft_limit_rad_s > 0.0 {
                let s = self.soft_limit_rad_s;
                *x = s * (*x / s).tanh();
            }
            if self.reverse_gain_change != 0.0 && *x < 0.0 {
                *x *= 1.0 + self.reverse_gain_change;
            }
        }
        u
    }
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
    /// Commands on their way through the dead time, one per 1 kHz step, oldest first.
    in_flight: VecDeque<WheelSpeeds>,
    /// What the dead time releases before any command went in (the command at rest or at
    /// the last reset).
    in_flight_fill: WheelSpeeds,
    /// The backlash gap per side, rad ([`Unmodelled::backlash_rad`]).
    gap: [f64; 2],
    /// The wheels' speeds behind the backlash, rad/s (the motors' when there is none).
    driven: [f64; 2],
    /// Motor angle per side, rad (what a counting encoder counts).
    angle: [f64; 2],
    /// Counts and time of the previous encoder reading ([`Unmodelled::encoder_counts_per_rev`]).
    last_count: Option<([f64; 2], f64)>,
    /// True poses of the last [`Unmodelled::pose_latency_s`] (time, x, y, yaw), oldest first.
    past_poses: VecDeque<(f64, f64, f64, f64)>,
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
            in_flight: VecDeque::new(),
            in_flight_fill: WheelSpeeds::default(),
            gap: [0.0; 2],
            driven: [0.0; 2],
            angle: [0.0; 2],
            last_count: None,
            past_poses: VecDeque::new(),
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
        let wheels = self.driven_wheels();
        let v = s.radius_m * (wheels[0] + wheels[1]) / 2.0;
        let mut w = s.radius_m * (wheels[1] - wheels[0]) / track;
        if self.extra.yaw_damping_s_m > 0.0 {
            w *= (1.0 - self.extra.yaw_damping_s_m * v.abs()).max(0.0);
        }
        (v, w)
    }

    /// The speeds of the wheels that move the body: the motors' behind the backlash.
    fn driven_wheels(&self) -> [f64; 2] {
        if self.extra.backlash_rad > 0.0 {
            self.driven
        } else {
            self.wheels
        }
    }

    /// The wheel-speed targets for the command `cmd` (after the dead time) and the turn the
    /// turn memory reads from it.
    fn targets(&self, cmd: WheelSpeeds) -> ([f64; 2], f64) {
        let u = self.extra.command_map(cmd);
        let drift = 1.0 + self.extra.gain_drift_per_step * self.step as f64;
        let mut target = [drift * self.spec.gain[0] * u[0], drift * self.spec.gain[1] * u[1]];
        if cmd != WheelSpeeds::default() {
            target = [target[0] + self.offset[0], target[1] + self.offset[1]];
        }
        if self.extra.wheel_limit_rad_s > 0.0 {
            let l = self.extra.wheel_limit_rad_s;
            target = target.map(|t| t.clamp(-l, l));
        }
        let turn = ((cmd.left_rad_s - cmd.right_rad_s) / 2.0).tanh();
        (target, turn)
    }

    /// The command the dead time releases at this 1 kHz step (the current one goes in).
    fn delayed_command(&mut self) -> WheelSpeeds {
        let delay = (self.extra.dead_time_s / STEP_S).round() as usize;
        if self.in_flight.is_empty() {
            self.in_flight
                .extend(std::iter::repeat_n(self.in_flight_fill, delay));
        }
        self.in_flight.push_back(self.cmd);
        self.in_flight.pop_front().unwrap_or(self.cmd)
    }

    /// Moves each wheel behind its motor through the backlash over `h` seconds: the motor
    /// first takes up the slack, the wheel moves with what goes beyond it.
    fn take_up_backlash(&mut self, h: f64) {
        let half = self.extra.backlash_rad / 2.0;
        for i in 0..2 {
            let g = self.gap[i] + h * self.wheels[i];
            let clamped = g.clamp(-half, half);
            self.driven[i] = (g - clamped) / h;
            self.gap[i] = clamped;
        }
    }

    /// The encoder reading of side `i` before noise: the motor's speed, counted when the
    /// encoder counts (the count difference since the previous reading over its time), and
    /// scaled by the side's scale error.
    fn encoder(&self, i: usize, counted: Option<[f64; 2]>) -> f64 {
        let w = counted.map_or(self.wheels[i], |c| c[i]);
        let e = self.extra.encoder_scale_error[i];
        if e != 0.0 {
            (1.0 + e) * w
        } else {
            w
        }
    }

    /// Both counting encoders' speeds now, updating the previous counts
    /// ([`Unmodelled::encoder_counts_per_rev`]); `None` for ideal encoders.
    fn count_encoders(&mut self) -> Option<[f64; 2]> {
        let n = self.extra.encoder_counts_per_rev;
        if n == 0 {
            return None;
        }
        let q = std::f64::consts::TAU / n as f64;
        let counts = self.angle.map(|a| (a / q).floor());
        let speeds = match self.last_count {
            Some((prev, t)) if self.t > t => [0, 1].map(|i| (counts[i] - prev[i]) * q / (self.t - t)),
            // No earlier reading (or none since the last reset): the motors' speed.
            _ => self.wheels,
        };
        self.last_count = Some((counts, self.t));
        Some(speeds)
    }

    /// The true pose (x, y, yaw) the localisation reports now: that of
    /// [`Unmodelled::pose_latency_s`] ago (the oldest kept until the run is that old).
    fn reported_pose(&self) -> (f64, f64, f64) {
        if self.extra.pose_latency_s > 0.0 {
            let at = self.t - self.extra.pose_latency_s;
            let past = self.past_poses.iter().rev().find(|p| p.0 <= at + 0.5 * STEP_S);
            if let Some(&(_, x, y, yaw)) = past.or(self.past_poses.front()) {
                return (x, y, yaw);
            }
        }
        (self.x, self.y, self.yaw)
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
        let n = (dt_s / STEP_S).round().max(1.0) as usize;
        let h = dt_s / n as f64;
        // Without a dead time the command, and so the targets, hold over the whole tick.
        let delayed = self.extra.dead_time_s > 0.0;
        let held = self.targets(self.cmd);
        for _ in 0..n {
            let (mut target, turn) = if delayed {
                let cmd = self.delayed_command();
                self.targets(cmd)
            } else {
                held
            };
            if self.extra.turn_memory_rad_s > 0.0 {
                let give = self.extra.turn_memory_rad_s * (turn - self.learnt_turn);
                target = [target[0] - give, target[1] + give];
                self.learnt_turn += h / self.extra.turn_memory_s * (turn - self.learnt_turn);
            }
            for (w, t) in self.wheels.iter_mut().zip(target) {
                *w += h / self.spec.lag_s * (t - *w);
            }
            for (a, w) in self.angle.iter_mut().zip(self.wheels) {
                *a += h * w;
            }
            if self.extra.backlash_rad > 0.0 {
                self.take_up_backlash(h);
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
            if self.extra.pose_latency_s > 0.0 {
                self.past_poses.push_back((self.t, self.x, self.y, self.yaw));
                // Keep what the latency reaches back to, and one older.
                while self.past_poses.len() > 2
                    && self.past_poses[1].0 <= self.t - self.extra.pose_latency_s - STEP_S
                {
                    self.past_poses.pop_front();
                }
            }
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
        let (x, y, yaw) = self.reported_pose();
        let pose = Pose {
            x_m: x + d * yaw.cos() + self.noise(pn),
            y_m: y + d * yaw.sin() + self.noise(pn),
            yaw_rad: yaw + self.extra.lidar_yaw_rad + self.noise(self.extra.pose_yaw_noise_rad),
            ..Pose::default()
        };
        let counted = self.count_encoders();
        let mut enc = WheelSpeeds::new(
            self.encoder(0, counted) + self.noise(en),
            self.encoder(1, counted) + self.noise(en),
        );
        let mut wz = w;
        let e = &self.extra;
        if e.imu_scale_error != 0.0 || e.imu_bias_rad_s != 0.0 || e.imu_bias_drift_rad_s_per_step != 0.0 {
            wz = (1.0 + e.imu_scale_error) * w
                + e.imu_bias_rad_s
                + e.imu_bias_drift_rad_s_per_step * self.step as f64;
        }
        let wz = wz + self.noise(imn);
        // Drawn last, and only when dropouts are on: a run without them draws its noise as before.
        if self.extra.encoder_dropout > 0.0 {
            use rand::RngExt;
            let p = self.extra.encoder_dropout;
            if self.rng.random_bool(p) {
                enc.left_rad_s = 0.0;
            }
            if self.rng.random_bool(p) {
                enc.right_rad_s = 0.0;
            }
        }
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
        self.driven = self.wheels;
        self.cmd = wheels;
        self.in_flight.clear();
        self.in_flight_fill = wheels;
        self.last_count = None;
        self.past_poses.clear();
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
