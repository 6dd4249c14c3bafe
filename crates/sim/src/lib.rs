//! Simulation: the rapier3d vehicle model of a skid-steering robot on a terrain, its sensors,
//! and the ideal plant used as a reference.
//!
//! Design (see also the report in the repository's history):
//! - The chassis is one rapier rigid body (6 DoF, box inertia, gravity), integrated with
//!   rapier's free-body scheme (`body.rs`; with the `oracle` feature, tests and benches can
//!   choose rapier's `PhysicsPipeline::step` instead, `reference.rs`).
//!   Wheels are not rigid bodies: each wheel is a ray cast from its suspension hard point to
//!   the ground (flat half-space or seeded height field; read directly on parry's triangles by
//!   the fast step, cast by parry by the others, `ground.rs`), which gives the spring-damper
//!   normal load, as in rapier's ray-cast vehicle controller. This avoids the twitching and
//!   creeping of jointed wheels on rigid contacts (dimforge/rapier#432).
//! - The wheel-terrain forces come from an explicit model ([`tyre`]): combined-slip friction,
//!   rolling resistance, churning and bulldozing. Skid-steer turning, slip on ice, motor
//!   saturation in mud and lateral drift in fast turns all emerge from it.
//! - Each side has one motor: the controller ramps the target at the wheel acceleration
//!   limit, then tracks it as a first-order loop with disturbance feed-forward (an ideal PI),
//!   clipped at the side's torque limit; the side's wheels are chained (one spin state).
//! - Friction is stiff at low slip speed (a wheel of 1.2 kg m² against 1000 N of grip relaxes
//!   in 0.1 ms). Instead of sub-stepping, each physics step solves the planar chassis velocity
//!   (vx, vy, wz) and the wheel spins of saturated sides by backward Euler (Newton on a 5x5
//!   system with the tyre model's exact Jacobian, started at a prediction and kept while it
//!   contracts, `solve.rs`); the resulting forces drive the chassis for the step. Backward Euler is
//!   L-stable, so rest is exactly rest (zero command gives zero force) and nothing chatters.
//! - Physics rate: 100 Hz by default. The implicit solve removes the friction stiffness, so
//!   the rate is bounded by the explicit suspension (Husky roll mode ~36 rad/s: ω·dt = 0.36)
//!   and by the 20 Hz logging (5 steps per tick).
//!
//! Files: `config.rs` the settings ([`SimConfig`], [`SensorNoise`]); `build.rs`
//! the world from a robot and a terrain ([`Simulator::new`]); `step.rs` one physics step
//! (controller, suspension, implicit solve, integration, body-stage effects, checks);
//! `solve.rs` the implicit tyre solve; [`tyre`] the contact model; `body.rs` the chassis
//! integration; [`ground`] the ground and its ray casts; [`plant`] the [`Plant`] trait and
//! the ideal plant; this file the simulator's state, the sensors and its [`Plant`] interface.
//!
//! ```
//! use drive_sim_model::kinematics::WheelSpeeds;
//! use drive_sim_model::{robot::Robot, terrain::Terrain};
//! use drive_sim_sim::{Plant, SimConfig, Simulator};
//!
//! let robot = Robot::resolve("warthog")?.0;
//! let terrain = Terrain::resolve("asphalt")?.0;
//! let mut sim = Simulator::new(&robot, &terrain, SimConfig::default())?;
//! // Both sides at 5 rad/s for 3 s: the robot drives straight ahead at about r·ω = 1.5 m/s.
//! sim.command(WheelSpeeds::new(5.0, 5.0));
//! sim.advance(3.0)?;
//! let v = sim.true_velocity();
//! assert!((v.vx_m_s - 1.5).abs() < 0.1 && v.wz_rad_s.abs() < 0.05);
//! # Ok::<(), drive_sim_model::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

mod body;
mod build;
mod config;
pub mod ground;
pub mod plant;
#[cfg(feature = "oracle")]
mod reference;
mod solve;
mod step;
pub mod tyre;

#[cfg(feature = "oracle")]
pub use config::Stepping;
pub use config::{SensorNoise, SimConfig};
pub use drive_sim_model::effects::Effects;
pub use plant::{IdealPlant, Plant};

use drive_sim_model::effects::{FadingOdometry, PlantModifiers, PoseUpdates, StepContext, TermInput};
use drive_sim_model::error::{Error, Result};
use drive_sim_model::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use drive_sim_model::measurement::{GroundTruth, ImuReading, Measurement, Pose};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use ground::Ground;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::prelude::*;
use solve::SolveCtx;
use std::collections::VecDeque;
use tyre::{ContactForce, TyreParams};

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// Most wheels a robot may have (8 per side, see robot validation).
const MAX_WHEELS: usize = 16;
/// How long all wheels may be off the ground before the run is declared diverged, s.
const MAX_AIRBORNE_S: f64 = 1.0;
/// Bump-stop stiffness over the spring stiffness, beyond the suspension travel.
const BUMP_STOP_FACTOR: f64 = 20.0;
/// Damping time of the tyre deflection state (torsion effect), s.
const TORSION_DAMPING_S: f64 = 0.05;
/// Largest tyre deflection angle of the torsion effect, in peak slip angles.
const TORSION_MAX_DEFLECTION: f64 = 3.0;

#[derive(Debug, Clone, Copy)]
struct WheelGeom {
    /// Hard point in the body frame, relative to the centre of mass.
    hard_point: [f64; 3],
    /// 0 left, 1 right.
    side: usize,
}

/// Per-step contact of one wheel, in the frozen heading frame.
#[derive(Debug, Clone, Copy, Default)]
struct Contact {
    load_n: f64,
    /// Contact point relative to the centre of mass, heading frame (x along heading), m.
    x_m: f64,
    y_m: f64,
    /// Contact point, world frame.
    point: [f64; 3],
    normal: [f64; 3],
    in_contact: bool,
}

/// The rapier vehicle model of a skid-steering robot on a terrain.
pub struct Simulator {
    bodies: RigidBodySet,
    colliders: ColliderSet,
    body: RigidBodyHandle,
    ground: Ground,

    mass_kg: f64,
    yaw_inertia_kg_m2: f64,
    wheels: Vec<WheelGeom>,
    /// Hard point to wheel bottom at full extension, m.
    free_length_m: f64,
    /// Ray length: free length minus the terrain's sinkage, m.
    ray_length_m: f64,
    travel_m: f64,
    stiffness_n_m: f64,
    damping_n_s_m: f64,
    radius_m: f64,
    side_inertia_kg_m2: f64,
    torque_limit_nm: f64,
    accel_limit_rad_s2: f64,
    time_constant_s: f64,
    com_height_m: f64,
    sinkage_m: f64,
    tyre: TyreParams,
    /// The robot file's geometry: what commands are computed with.
    nominal: IdealDiffDrive,
    effects: Effects,
    /// What the effects change in the physics, read once.
    mods: PlantModifiers,
    noise: SensorNoise,
    physics_hz: f64,
    rng: ChaCha8Rng,
    /// The run's seed, for effects that draw per step ([`TermInput::run_seed`]).
    seed: u64,

    cmd: WheelSpeeds,
    /// Commands with the time they were given, for the dead time.
    cmd_queue: VecDeque<(f64, WheelSpeeds)>,
    /// The command the controller currently acts on (after the dead time).
    applied: WheelSpeeds,
    /// Ramped targets, rad/s.
    ramp: [f64; 2],
    /// Side wheel spins, rad/s.
    omega: [f64; 2],
    /// The last physics step's change of (vx, vy, wz, omega_left, omega_right): the predictor
    /// of the next step's solve (see [`solve::SolveCtx::guess`]).
    last_change: [f64; 5],
    /// Tyre lateral deflection angles (torsion effect), tan of the angle.
    deflection: Vec<f64>,
    contacts: Vec<Contact>,
    forces: Vec<ContactForce>,
    /// Motor torque of each side in the last step, N·m.
    motor_torque_nm: [f64; 2],
    /// The part of each side's torque the speed loop's integral supplies (droop recovery), N·m.
    droop_integral_nm: [f64; 2],
    /// Whether each side was torque-limited in the last step.
    saturated: [bool; 2],
    time_s: f64,
    airborne_s: f64,
    /// World-frame acceleration of the centre of mass over the last physics step.
    accel_world: [f64; 3],
    pose_history: VecDeque<(f64, rapier3d::parry::math::Pose)>,
    /// The odometry the pose is read through (its fade, `odometry_fade_per_s`).
    odometry: FadingOdometry,
    /// When that odometry publishes (`pose_updates`): the logger holds its last pose.
    pose_updates: PoseUpdates,
    /// Principal moments of inertia of the chassis (body axes), kg·m².
    inertia_kg_m2: [f64; 3],
    /// rapier's pipeline when the reference step is chosen (feature `oracle`).
    #[cfg(feature = "oracle")]
    reference: Option<reference::ReferencePipeline>,
    /// The step being run (for effects that read it).
    ctx: StepContext,
    /// Plant time at which it started, s.
    step_t0_s: f64,
    /// Driven outside a DRIVE step ([`Plant::begin_manoeuvre`]): command-change features are
    /// neutral.
    manoeuvre: bool,
    /// What the effects read at the last physics step.
    input: TermInput,
    /// Whether any effect acts at the body stage (offsets, lag): see [`Simulator::body_stage`].
    on_body: bool,
    /// The body velocity the body stage starts from: the physics' own, lagged when the body
    /// lags.
    body_state: BodyVelocity,
    /// What the body stage adds to the physics' velocity (integrated into the pose).
    body_extra: BodyVelocity,
    /// Yaw acceleration of the chassis over the last physics step, rad/s².
    yaw_accel_rad_s2: f64,
}

impl std::fmt::Debug for Simulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulator")
            .field("time_s", &self.time_s)
            .field("pose", &self.true_pose())
            .field("omega", &self.omega)
            .finish_non_exhaustive()
    }
}

impl Simulator {
    /// Puts the robot on the ground at `pose` (x, y, yaw; z, roll and pitch follow the
    /// ground), moving at `velocity` (body frame) with its wheels at `wheels` and the controller
    /// holding `wheels` as its command, at time 0: the state from which to replay measured data.
    /// Nothing of the previous motion remains (the result of a replay does not depend on what
    /// the simulator did before; tested).
    pub fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds) {
        // With a pose latency, the given pose is where the robot was that long ago: it starts
        // ahead of it, and the latency reports the way there.
        let behind = plant::poses_behind(pose, velocity, self.mods.pose_latency_s, 1e-3);
        let pose = behind.last().map_or(pose, |p| p.1);
        let ground_z = self.ground.height_at(&self.colliders, pose.x_m, pose.y_m);
        let z = ground_z + self.com_height_m - self.sinkage_m;
        let rot = Rotation::from_rotation_z(pose.yaw_rad as f32);
        let (c, s) = (pose.yaw_rad.cos(), pose.yaw_rad.sin());
        let v_world = Vector::new(
            (c * velocity.vx_m_s - s * velocity.vy_m_s) as f32,
            (s * velocity.vx_m_s + c * velocity.vy_m_s) as f32,
            0.0,
        );
        let rb = &mut self.bodies[self.body];
        rb.set_position(
            rapier3d::math::Pose::from_parts(Vector::new(pose.x_m as f32, pose.y_m as f32, z as f32), rot),
            true,
        );
        rb.set_linvel(v_world, true);
        rb.set_angvel(Vector::new(0.0, 0.0, velocity.wz_rad_s as f32), true);
        rb.reset_forces(true);
        rb.reset_torques(true);
        self.cmd = wheels;
        self.cmd_queue.clear();
        self.applied = wheels;
        self.ramp = [wheels.left_rad_s, wheels.right_rad_s];
        self.omega = self.ramp;
        // The solve's predictor is the last physics step's change: a reset world has none, so
        // that a replay does not depend on which step the world ran before (calibration reuses
        // worlds across steps and threads).
        self.last_change = [0.0; 5];
        self.deflection.iter_mut().for_each(|d| *d = 0.0);
        self.contacts.iter_mut().for_each(|c| *c = Contact::default());
        self.forces.iter_mut().for_each(|f| *f = ContactForce::default());
        self.motor_torque_nm = [0.0; 2];
        // A replayed step starts with an empty integral: the log does not record the torque
        // the previous step left in it.
        self.droop_integral_nm = [0.0; 2];
        self.saturated = [false; 2];
        // Time restarts: a reset plant replays a step exactly as a new one would, so replays
        // can reuse one world for many steps.
        self.time_s = 0.0;
        self.step_t0_s = 0.0;
        self.manoeuvre = false;
        self.airborne_s = 0.0;
        self.accel_world = [0.0; 3];
        self.pose_history.clear();
        self.odometry.restart();
        self.pose_updates.restart();
        if behind.len() > 1 {
            // The way there, at the height and attitude the robot is put down with.
            let now = *self.bodies[self.body].position();
            for (t, p) in &behind {
                let rot = Rotation::from_rotation_z(p.yaw_rad as f32);
                let at = Vector::new(p.x_m as f32, p.y_m as f32, now.translation.z);
                self.pose_history
                    .push_back((*t, rapier3d::math::Pose::from_parts(at, rot)));
            }
        }
        self.input = TermInput::default();
        self.body_state = velocity;
        self.body_extra = BodyVelocity::default();
        self.yaw_accel_rad_s2 = 0.0;
    }

    /// The effects this simulator runs with.
    pub fn effects(&self) -> &Effects {
        &self.effects
    }

    /// Chooses how physics steps are computed (default [`Stepping::Fast`]).
    #[cfg(feature = "oracle")]
    pub fn set_stepping(&mut self, stepping: Stepping) {
        self.reference = (stepping == Stepping::Reference).then(reference::ReferencePipeline::new);
    }

    /// Side wheel spins (true, without encoder effects), rad/s.
    pub fn wheel_speeds(&self) -> WheelSpeeds {
        WheelSpeeds::new(self.omega[0], self.omega[1])
    }

    /// Normal loads of the wheels from the last step, N (left wheels first, rear to front).
    pub fn wheel_loads_n(&self) -> Vec<f64> {
        self.contacts.iter().map(|c| c.load_n).collect()
    }

    /// Motor torque of each side in the last physics step, N·m (left, right).
    pub fn motor_torques_nm(&self) -> [f64; 2] {
        self.motor_torque_nm
    }

    /// Whether each side's motor was at its torque limit in the last physics step.
    pub fn torque_saturated(&self) -> [bool; 2] {
        self.saturated
    }

    fn normal(&mut self) -> f64 {
        self.rng.sample::<f64, _>(StandardNormal)
    }

    fn delayed_pose(&self) -> Pose {
        let t = self.time_s - self.mods.pose_latency_s;
        self.pose_history
            .iter()
            .rev()
            .find(|&&(ts, _)| ts <= t + 1e-9)
            .or(self.pose_history.front())
            .map_or_else(|| self.true_pose(), |(_, p)| pose_of(p))
    }
}

impl Plant for Simulator {
    fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds) {
        Simulator::reset(self, pose, velocity, wheels)
    }
    fn wheels_from_encoders(&self, encoders: WheelSpeeds) -> WheelSpeeds {
        self.effects.wheels_from_encoders(encoders)
    }
    fn command(&mut self, cmd: WheelSpeeds) {
        self.cmd = cmd;
        if self.mods.dead_time_s > 0.0 {
            self.cmd_queue.push_back((self.time_s, cmd));
        } else {
            self.applied = cmd;
        }
    }

    fn advance(&mut self, dt_s: f64) -> Result<()> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(Error::Diverged {
                step: 0,
                time_s: self.time_s,
                message: format!("invalid time step {dt_s}"),
            });
        }
        if dt_s == 0.0 {
            return Ok(());
        }
        let n = (dt_s * self.physics_hz).round().max(1.0) as usize;
        let h = dt_s / n as f64;
        for _ in 0..n {
            self.step(h)?;
        }
        Ok(())
    }

    fn measure(&mut self) -> Measurement {
        let truth = GroundTruth {
            pose: self.true_pose(),
            velocity: self.true_velocity(),
            wheels: self.wheel_speeds(),
        };
        let e = self.effects.clone();
        let nz = self.noise;
        let mut enc = e.encoders(WheelSpeeds::new(self.omega[0], self.omega[1]));
        if nz.encoder_rad_s > 0.0 {
            enc.left_rad_s += nz.encoder_rad_s * self.normal();
            enc.right_rad_s += nz.encoder_rad_s * self.normal();
        }
        let mut pose = self.odometry.read(
            self.delayed_pose(),
            self.time_s - self.step_t0_s,
            self.mods.odometry_fade_per_s,
            !self.manoeuvre,
        );
        if nz.pose_position_m > 0.0 {
            pose.x_m += nz.pose_position_m * self.normal();
            pose.y_m += nz.pose_position_m * self.normal();
        }
        if nz.pose_yaw_rad > 0.0 {
            pose.yaw_rad =
                drive_sim_model::geometry::wrap_angle(pose.yaw_rad + nz.pose_yaw_rad * self.normal());
        }
        // The odometry publishes the noisy pose it matched; the logger holds the last one.
        let pose = self.pose_updates.read(
            pose,
            self.time_s,
            self.mods.pose_update_period_s,
            self.mods.pose_update_jitter_s,
            self.seed,
        );
        let rb = &self.bodies[self.body];
        let inv = rb.position().rotation.inverse();
        let w_body = inv * rb.angvel();
        let a = self.accel_world;
        let f_world = Vector::new(a[0] as f32, a[1] as f32, (a[2] + GRAVITY_M_S2) as f32);
        let f_body = inv * f_world;
        let mut imu = ImuReading {
            wz_rad_s: e.imu_yaw_rate_in(w_body.z as f64 + self.body_extra.wz_rad_s, &self.input),
            ax_m_s2: f_body.x as f64,
            ay_m_s2: f_body.y as f64,
            az_m_s2: f_body.z as f64,
        };
        if nz.imu_gyro_rad_s > 0.0 {
            imu.wz_rad_s += nz.imu_gyro_rad_s * self.normal();
        }
        if nz.imu_accel_m_s2 > 0.0 {
            imu.ax_m_s2 += nz.imu_accel_m_s2 * self.normal();
            imu.ay_m_s2 += nz.imu_accel_m_s2 * self.normal();
            imu.az_m_s2 += nz.imu_accel_m_s2 * self.normal();
        }
        Measurement {
            cmd: self.cmd,
            enc,
            pose,
            imu,
            reference: None,
            truth: Some(truth),
        }
    }

    fn true_pose(&self) -> Pose {
        pose_of(self.bodies[self.body].position())
    }

    fn true_velocity(&self) -> BodyVelocity {
        let v = self.physics_velocity();
        let e = self.body_extra;
        BodyVelocity::new(v.vx_m_s + e.vx_m_s, v.vy_m_s + e.vy_m_s, v.wz_rad_s + e.wz_rad_s)
    }

    fn begin_step(&mut self, ctx: StepContext) {
        self.ctx = ctx;
        self.step_t0_s = self.time_s;
        self.manoeuvre = false;
        self.odometry.restart();
    }

    fn begin_manoeuvre(&mut self) {
        self.step_t0_s = self.time_s;
        self.manoeuvre = true;
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }
}

/// The pose (ZYX Euler angles) of a rigid-body position. Kept out of the physics step: the
/// step records positions, and the angles (three atan2) are computed only where read.
fn pose_of(position: &rapier3d::parry::math::Pose) -> Pose {
    let p = position.translation;
    let (yaw, pitch, roll) = position.rotation.to_euler(rapier3d::glamx::EulerRot::ZYX);
    Pose {
        x_m: p.x as f64,
        y_m: p.y as f64,
        z_m: p.z as f64,
        roll_rad: roll as f64,
        pitch_rad: pitch as f64,
        yaw_rad: yaw as f64,
    }
}
