//! Simulation: the rapier3d vehicle model of a skid-steering robot on a terrain, its sensors,
//! and the ideal plant used as a reference.
//!
//! Design (see also the report in the repository's history):
//! - The chassis is one rapier rigid body (6 DoF, box inertia, gravity), integrated with
//!   rapier's free-body scheme ([`Stepping::Fast`], `body.rs`; `PhysicsPipeline::step` with
//!   [`Stepping::Reference`]).
//!   Wheels are not rigid bodies: each wheel is a ray cast from its suspension hard point to
//!   the ground collider (flat half-space or seeded height field), which gives the spring-damper
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
//!   system with the tyre model's exact Jacobian, `solve.rs`); the resulting forces drive the
//!   chassis for the step. Backward Euler is
//!   L-stable, so rest is exactly rest (zero command gives zero force) and nothing chatters.
//! - Physics rate: 100 Hz by default. The implicit solve removes the friction stiffness, so
//!   the rate is bounded by the explicit suspension (Husky roll mode ~36 rad/s: ω·dt = 0.36)
//!   and by the 20 Hz logging (5 steps per tick).

mod body;
pub mod ground;
pub mod plant;
mod solve;
pub mod tyre;

pub use crate::effects::Effects;
pub use plant::{IdealPlant, Plant};

use crate::effects::{PlantModifiers, StepContext, TermInput};
use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use crate::measurement::{GroundTruth, ImuReading, Measurement, Pose};
use crate::robot::Robot;
use crate::terrain::Terrain;
use ground::Ground;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};
use solve::SolveCtx;
use std::collections::VecDeque;
use tyre::{ContactForce, TyreParams};

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// Standard deviations of the sensor noise, per channel. All zero (off) by default.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorNoise {
    /// Encoder wheel speed noise, rad/s.
    pub encoder_rad_s: f64,
    /// Lidar/ICP position noise (x and y), m.
    pub pose_position_m: f64,
    /// Lidar/ICP yaw noise, rad.
    pub pose_yaw_rad: f64,
    /// Gyro (yaw rate) noise, rad/s.
    pub imu_gyro_rad_s: f64,
    /// Accelerometer noise, m/s².
    pub imu_accel_m_s2: f64,
}

impl SensorNoise {
    /// Noise of typical field sensors, for runs meant to look like real data: a lidar ICP pose
    /// good to about 1 cm and 0.2° between scans, a MEMS gyro with 0.01 rad/s of white noise
    /// and 0.05 m/s² on the accelerometer, and encoders quantized to about 0.02 rad/s at 20 Hz.
    /// \[est\] orders of magnitude of the Warthog's sensors, not fitted.
    pub fn typical() -> Self {
        Self {
            encoder_rad_s: 0.02,
            pose_position_m: 0.01,
            pose_yaw_rad: 0.0035,
            imu_gyro_rad_s: 0.01,
            imu_accel_m_s2: 0.05,
        }
    }
}

/// Simulator settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of the terrain height field and the sensor noise.
    pub seed: u64,
    /// Physics rate, Hz (rounded per `advance` call so that steps tile the call exactly).
    /// 100 Hz by default: the tyre and wheel dynamics are solved implicitly, so the rate is
    /// bounded by the explicit suspension modes (Husky roll ~36 rad/s) and the 20 Hz logging;
    /// 400 Hz changes steady means by under 1 % of the speed scale (test `physics_rate_converges`).
    pub physics_hz: f64,
    /// Sensor noise.
    pub noise: SensorNoise,
    /// Injected model effects.
    pub effects: Effects,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            physics_hz: 100.0,
            noise: SensorNoise::default(),
            effects: Effects::default(),
        }
    }
}

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

/// How a physics step is computed. Both give the same physics (the tests hold either to the
/// same tolerances); `Reference` is the original, slower code path, kept callable so that the
/// benchmark can time both in one run and a test can check that they agree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stepping {
    /// Exact Jacobian in the implicit tyre solve; the chassis integrated directly
    /// (rapier's free-body scheme, without the pipeline around it).
    #[default]
    Fast,
    /// Finite-difference Jacobian; the chassis integrated by rapier's `PhysicsPipeline::step`.
    Reference,
}

/// The rapier vehicle model of a skid-steering robot on a terrain.
pub struct Simulator {
    bodies: RigidBodySet,
    colliders: ColliderSet,
    params: IntegrationParameters,
    pipeline: PhysicsPipeline,
    islands: IslandManager,
    broad_phase: DefaultBroadPhase,
    narrow_phase: NarrowPhase,
    impulse_joints: ImpulseJointSet,
    multibody_joints: MultibodyJointSet,
    ccd: CCDSolver,
    soft_bodies: SoftBodySet,
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

    cmd: WheelSpeeds,
    /// Commands with the time they were given, for the dead time.
    cmd_queue: VecDeque<(f64, WheelSpeeds)>,
    /// The command the controller currently acts on (after the dead time).
    applied: WheelSpeeds,
    /// Ramped targets, rad/s.
    ramp: [f64; 2],
    /// Side wheel spins, rad/s.
    omega: [f64; 2],
    /// Tyre lateral deflection angles (torsion effect), tan of the angle.
    deflection: Vec<f64>,
    contacts: Vec<Contact>,
    forces: Vec<ContactForce>,
    /// Motor torque of each side in the last step, N·m.
    motor_torque_nm: [f64; 2],
    /// Whether each side was torque-limited in the last step.
    saturated: [bool; 2],
    time_s: f64,
    airborne_s: f64,
    /// World-frame acceleration of the centre of mass over the last physics step.
    accel_world: [f64; 3],
    pose_history: VecDeque<(f64, Pose)>,
    /// Principal moments of inertia of the chassis (body axes), kg·m².
    inertia_kg_m2: [f64; 3],
    stepping: Stepping,
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

fn cfg_err(field: &str, message: String) -> Error {
    Error::config("<simulator>", field, message)
}

impl Simulator {
    /// Builds the world: ground from the terrain (height field seeded by `cfg.seed`), the robot
    /// at rest at the origin facing +x, suspension at its static equilibrium.
    pub fn new(robot: &Robot, terrain: &Terrain, cfg: SimConfig) -> Result<Self> {
        if !(cfg.physics_hz.is_finite() && (20.0..=5000.0).contains(&cfg.physics_hz)) {
            return Err(cfg_err(
                "physics_hz",
                format!("must be in 20..=5000 Hz, got {}", cfg.physics_hz),
            ));
        }
        let n = &cfg.noise;
        for (name, v) in [
            ("noise.encoder_rad_s", n.encoder_rad_s),
            ("noise.pose_position_m", n.pose_position_m),
            ("noise.pose_yaw_rad", n.pose_yaw_rad),
            ("noise.imu_gyro_rad_s", n.imu_gyro_rad_s),
            ("noise.imu_accel_m_s2", n.imu_accel_m_s2),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(cfg_err(name, format!("must be a finite number >= 0, got {v}")));
            }
        }

        let b = &robot.body;
        let w = &robot.wheels;
        let s = &robot.suspension;
        let n_wheels = 2 * w.per_side as usize;
        if n_wheels == 0 || n_wheels > MAX_WHEELS {
            return Err(Error::config(
                format!("<robot {}>", robot.name),
                "wheels.per_side",
                format!("must be 1..={}, got {}", MAX_WHEELS / 2, w.per_side),
            ));
        }
        let static_compression_m = b.mass_kg * GRAVITY_M_S2 / (n_wheels as f64 * s.stiffness_n_m);
        if static_compression_m >= s.travel_m {
            return Err(Error::config(
                format!("<robot {}>", robot.name),
                "suspension.stiffness_n_m",
                format!(
                    "too soft: static compression {static_compression_m:.3} m exceeds the travel {} m",
                    s.travel_m
                ),
            ));
        }
        let sinkage_m = terrain.resistance.sinkage_m;
        let free_length_m = s.travel_m + w.radius_m;
        if sinkage_m >= 0.5 * w.radius_m {
            return Err(Error::config(
                format!("<terrain {}>", terrain.name),
                "resistance.sinkage_m",
                format!(
                    "{sinkage_m} m buries half of the {} m wheels of the {}",
                    w.radius_m, robot.name
                ),
            ));
        }
        // Hard points sit so that the centre of mass rests at com_height_m on hard ground.
        let hard_point_z = s.travel_m + w.radius_m - static_compression_m - b.com_height_m;
        let mut wheels = Vec::with_capacity(n_wheels);
        for side in 0..2 {
            let y = if side == 0 { 0.5 } else { -0.5 } * w.baseline_m;
            for k in 0..w.per_side {
                let x = if w.per_side == 1 {
                    0.0
                } else {
                    -0.5 * w.wheelbase_m + w.wheelbase_m * k as f64 / (w.per_side - 1) as f64
                };
                wheels.push(WheelGeom {
                    hard_point: [x, y, hard_point_z],
                    side,
                });
            }
        }

        let mut colliders = ColliderSet::new();
        let extent_m = 2.0 * robot.safe_area.length_m.max(robot.safe_area.width_m) + 20.0;
        let ground = Ground::build(
            &mut colliders,
            terrain.roughness.height_std_m,
            terrain.roughness.correlation_length_m,
            extent_m,
            cfg.seed,
        );
        let inertia = [
            b.mass_kg / 12.0 * (b.width_m.powi(2) + b.height_m.powi(2)),
            b.mass_kg / 12.0 * (b.length_m.powi(2) + b.height_m.powi(2)),
            robot.yaw_inertia_kg_m2(),
        ];
        let body = RigidBodyBuilder::dynamic()
            .additional_mass_properties(MassProperties::new(
                Vector::ZERO,
                b.mass_kg as f32,
                Vector::new(inertia[0] as f32, inertia[1] as f32, inertia[2] as f32),
            ))
            .can_sleep(false)
            .build();
        let mut bodies = RigidBodySet::new();
        let body = bodies.insert(body);
        let params = IntegrationParameters {
            dt: (1.0 / cfg.physics_hz) as f32,
            ..Default::default()
        };
        // A robot's and a terrain's own effects (their `[effects]` tables) run under the
        // configuration's, which override them.
        let effects = crate::effects_table::combine(&robot.effects, &terrain.effects, &cfg.effects)?;
        let mods = effects.modifiers();
        let effects_on_body = effects.acts_on_body();
        let radius_m = w.radius_m * mods.wheel_radius_scale;
        let mut sim = Self {
            bodies,
            colliders,
            params,
            pipeline: PhysicsPipeline::new(),
            islands: IslandManager::new(),
            broad_phase: DefaultBroadPhase::default(),
            narrow_phase: NarrowPhase::new(),
            impulse_joints: ImpulseJointSet::new(),
            multibody_joints: MultibodyJointSet::new(),
            ccd: CCDSolver::new(),
            soft_bodies: SoftBodySet::new(),
            body,
            ground,
            mass_kg: b.mass_kg,
            yaw_inertia_kg_m2: robot.yaw_inertia_kg_m2(),
            wheels,
            free_length_m,
            ray_length_m: free_length_m - sinkage_m,
            travel_m: s.travel_m,
            stiffness_n_m: s.stiffness_n_m,
            damping_n_s_m: s.damping_n_s_m,
            radius_m,
            side_inertia_kg_m2: w.inertia_kg_m2 * w.per_side as f64,
            torque_limit_nm: robot.powertrain.torque_limit_nm,
            accel_limit_rad_s2: robot.powertrain.wheel_accel_limit_rad_s2,
            time_constant_s: robot.powertrain.time_constant_s * mods.time_constant_scale,
            com_height_m: b.com_height_m,
            sinkage_m,
            tyre: TyreParams::new(terrain, radius_m, w.width_m, mods.lateral_friction_scale),
            nominal: robot.idd(),
            effects,
            mods,
            noise: cfg.noise,
            physics_hz: cfg.physics_hz,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            cmd: WheelSpeeds::default(),
            cmd_queue: VecDeque::new(),
            applied: WheelSpeeds::default(),
            ramp: [0.0; 2],
            omega: [0.0; 2],
            deflection: vec![0.0; n_wheels],
            contacts: vec![Contact::default(); n_wheels],
            forces: vec![ContactForce::default(); n_wheels],
            motor_torque_nm: [0.0; 2],
            saturated: [false; 2],
            time_s: 0.0,
            airborne_s: 0.0,
            accel_world: [0.0; 3],
            pose_history: VecDeque::new(),
            inertia_kg_m2: inertia,
            stepping: Stepping::default(),
            ctx: StepContext::default(),
            step_t0_s: 0.0,
            manoeuvre: false,
            input: TermInput::default(),
            on_body: effects_on_body,
            body_state: BodyVelocity::default(),
            body_extra: BodyVelocity::default(),
            yaw_accel_rad_s2: 0.0,
        };
        sim.reset(Pose::default(), BodyVelocity::default(), WheelSpeeds::default());
        Ok(sim)
    }

    /// Puts the robot on the ground at `pose` (x, y, yaw; z, roll and pitch follow the
    /// ground), moving at `velocity` (body frame) with its wheels at `wheels` and the controller
    /// holding `wheels` as its command, at time 0: the state from which to replay measured data.
    /// Nothing of the previous motion remains (the result of a replay does not depend on what
    /// the simulator did before; tested).
    pub fn reset(&mut self, pose: Pose, velocity: BodyVelocity, wheels: WheelSpeeds) {
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
        self.deflection.iter_mut().for_each(|d| *d = 0.0);
        self.contacts.iter_mut().for_each(|c| *c = Contact::default());
        self.forces.iter_mut().for_each(|f| *f = ContactForce::default());
        self.motor_torque_nm = [0.0; 2];
        self.saturated = [false; 2];
        // Time restarts: a reset plant replays a step exactly as a new one would, so replays
        // can reuse one world for many steps.
        self.time_s = 0.0;
        self.step_t0_s = 0.0;
        self.manoeuvre = false;
        self.airborne_s = 0.0;
        self.accel_world = [0.0; 3];
        self.pose_history.clear();
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
    pub fn set_stepping(&mut self, stepping: Stepping) {
        self.stepping = stepping;
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

    fn controller_target(&mut self, dt: f64) {
        let now = self.time_s;
        let dead = self.mods.dead_time_s;
        while let Some(&(t, c)) = self.cmd_queue.front() {
            if t <= now - dead + 1e-12 {
                self.applied = c;
                self.cmd_queue.pop_front();
            } else {
                break;
            }
        }
        let x = self.term_input();
        // A command that the dead time releases inside this physics step acts for the part of
        // the step after its release, not from the next step on: the ramp moves towards each
        // target for the share of the step it holds (exact for a rate-limited ramp with a
        // piecewise-constant target). The response is then continuous in the dead time, which
        // a least-squares fit of it needs (rounded to the step, it is a staircase of 10 ms
        // plateaus). Same weighting as the kinematic model's.
        let end = now + dt - dead;
        let mut from = now - dead;
        let mut target = self.effects.wheel_targets_in(self.applied, &self.nominal, &x);
        let dmax = self.accel_limit_rad_s2 * dt;
        let ramp_to = |ramp: &mut [f64; 2], t: WheelSpeeds, share: f64| {
            for (r, t) in ramp.iter_mut().zip([t.left_rad_s, t.right_rad_s]) {
                *r += (t - *r).clamp(-dmax * share, dmax * share);
            }
        };
        let mut switched = false;
        for &(tc, c) in self.cmd_queue.iter().take_while(|&&(tc, _)| tc < end - 1e-12) {
            ramp_to(&mut self.ramp, target, (tc - from) / dt);
            target = self.effects.wheel_targets_in(c, &self.nominal, &x);
            from = tc;
            switched = true;
        }
        // Without a switch, the whole step (exactly: no rounding of `end - from`).
        let share = if switched { (end - from) / dt } else { 1.0 };
        ramp_to(&mut self.ramp, target, share);
        self.input = x;
    }

    /// What the effects may read now (the physics' velocity, or the body stage's when it runs).
    fn term_input(&self) -> TermInput {
        let v = if self.on_body {
            self.body_state
        } else {
            self.physics_velocity()
        };
        let rot = self.bodies[self.body].position().rotation;
        let heading = rot * Vector::X;
        let ax = self.accel_world[0] * heading.x as f64 + self.accel_world[1] * heading.y as f64;
        TermInput {
            cmd: self.cmd,
            cmd_body: self.nominal.body_from_wheels(self.cmd),
            previous_cmd_body: self.nominal.body_from_wheels(if self.manoeuvre {
                self.cmd
            } else {
                self.ctx.previous_cmd
            }),
            body: v,
            accel: [ax, self.yaw_accel_rad_s2],
            t_in_step_s: self.time_s - self.step_t0_s,
            step: self.ctx.step,
        }
    }

    /// The body stage (effects that act on the body velocity and not on the wheels: a body
    /// lag, a lateral drift, discovered body terms). The tyre forces know nothing of it: what
    /// it adds to the physics' velocity is integrated into the chassis pose as a displacement
    /// at the end of each physics step, so the pose, the velocity and the IMU's yaw rate see
    /// it and the contact does not.
    fn body_stage(&mut self, dt: f64) {
        let v_phys = self.physics_velocity();
        let tau = self.mods.body_time_constant_s;
        self.body_state = if tau > 0.0 {
            let b = 1.0 - (-dt / tau).exp();
            BodyVelocity::new(
                self.body_state.vx_m_s + b * (v_phys.vx_m_s - self.body_state.vx_m_s),
                v_phys.vy_m_s,
                self.body_state.wz_rad_s + b * (v_phys.wz_rad_s - self.body_state.wz_rad_s),
            )
        } else {
            v_phys
        };
        let mut x = self.term_input();
        x.body = self.body_state;
        let o = self.effects.body_offset(&x);
        self.input = x;
        let extra = BodyVelocity::new(
            self.body_state.vx_m_s - v_phys.vx_m_s + o.vx_m_s,
            o.vy_m_s,
            self.body_state.wz_rad_s - v_phys.wz_rad_s + o.wz_rad_s,
        );
        self.body_extra = extra;
        let rb = &mut self.bodies[self.body];
        let rot = rb.position().rotation;
        let heading = rot * Vector::X;
        let (hx, hy) = (heading.x as f64, heading.y as f64);
        let n = hx.hypot(hy).max(1e-9);
        let (c, s) = (hx / n, hy / n);
        let t = rb.translation();
        let dx = (c * extra.vx_m_s - s * extra.vy_m_s) * dt;
        let dy = (s * extra.vx_m_s + c * extra.vy_m_s) * dt;
        rb.set_translation(Vector::new(t.x + dx as f32, t.y + dy as f32, t.z), true);
        if extra.wz_rad_s != 0.0 {
            let turn = Rotation::from_rotation_z((extra.wz_rad_s * dt) as f32);
            rb.set_rotation(turn * rot, true);
        }
    }

    /// The chassis velocity of the physics (body frame), without the body stage.
    fn physics_velocity(&self) -> BodyVelocity {
        let rb = &self.bodies[self.body];
        let inv = rb.position().rotation.inverse();
        let v = inv * rb.linvel();
        let w = inv * rb.angvel();
        BodyVelocity::new(v.x as f64, v.y as f64, w.z as f64)
    }

    /// One physics step of `dt` seconds.
    fn step(&mut self, dt: f64) -> Result<()> {
        self.controller_target(dt);
        let rb = &self.bodies[self.body];
        let pos = *rb.position();
        let rot = pos.rotation;
        let com = rb.center_of_mass();
        let linvel = rb.linvel();
        let angvel = rb.angvel();
        let to64 = |v: Vector| [v.x as f64, v.y as f64, v.z as f64];
        let down = to64(rot * -Vector::Z);
        let body_x = to64(rot * Vector::X);
        // Frozen heading frame: horizontal projection of the body x axis.
        let hx = body_x[0].hypot(body_x[1]);
        let (ex, ey) = if hx > 1e-6 {
            (
                [body_x[0] / hx, body_x[1] / hx],
                [-body_x[1] / hx, body_x[0] / hx],
            )
        } else {
            ([1.0, 0.0], [0.0, 1.0])
        };
        let com64 = to64(com);
        let v64 = to64(linvel);
        let w64 = to64(angvel);

        // Suspension: one ray per wheel.
        let mut fx_ext = 0.0;
        let mut fy_ext = 0.0;
        let mut mz_ext = 0.0;
        let mut any_contact = false;
        for (i, wg) in self.wheels.iter().enumerate() {
            let hp = pos
                * Vector::new(
                    wg.hard_point[0] as f32,
                    wg.hard_point[1] as f32,
                    wg.hard_point[2] as f32,
                );
            let hp64 = to64(hp);
            let c = &mut self.contacts[i];
            *c = Contact::default();
            let Some(hit) = self.ground.cast(&self.colliders, hp64, down, self.ray_length_m) else {
                continue;
            };
            let compression = self.free_length_m - self.sinkage_m - hit.distance_m;
            // Rate of compression: hard-point velocity along the ray.
            let r = [hp64[0] - com64[0], hp64[1] - com64[1], hp64[2] - com64[2]];
            let vhp = [
                v64[0] + w64[1] * r[2] - w64[2] * r[1],
                v64[1] + w64[2] * r[0] - w64[0] * r[2],
                v64[2] + w64[0] * r[1] - w64[1] * r[0],
            ];
            let rate = vhp[0] * down[0] + vhp[1] * down[1] + vhp[2] * down[2];
            let mut f = self.stiffness_n_m * compression + self.damping_n_s_m * rate;
            if compression > self.travel_m {
                f += BUMP_STOP_FACTOR * self.stiffness_n_m * (compression - self.travel_m);
            }
            let load = f.max(0.0);
            let point = [
                hp64[0] + down[0] * hit.distance_m,
                hp64[1] + down[1] * hit.distance_m,
                hp64[2] + down[2] * hit.distance_m,
            ];
            let rel = [point[0] - com64[0], point[1] - com64[1]];
            c.x_m = rel[0] * ex[0] + rel[1] * ex[1];
            c.y_m = rel[0] * ey[0] + rel[1] * ey[1];
            c.load_n = load;
            c.point = point;
            c.normal = hit.normal;
            c.in_contact = true;
            any_contact = true;
            // Horizontal part of the normal force (slopes) enters the planar solve.
            let fh = [load * hit.normal[0], load * hit.normal[1]];
            let (fxe, fye) = (fh[0] * ex[0] + fh[1] * ex[1], fh[0] * ey[0] + fh[1] * ey[1]);
            fx_ext += fxe;
            fy_ext += fye;
            mz_ext += c.x_m * fye - c.y_m * fxe;
        }
        self.airborne_s = if any_contact { 0.0 } else { self.airborne_s + dt };

        // Planar implicit solve.
        let u0 = [
            v64[0] * ex[0] + v64[1] * ex[1],
            v64[0] * ey[0] + v64[1] * ey[1],
            w64[2],
            self.omega[0],
            self.omega[1],
        ];
        let tc = self.time_constant_s;
        let target = [
            (self.omega[0] + dt / tc * self.ramp[0]) / (1.0 + dt / tc),
            (self.omega[1] + dt / tc * self.ramp[1]) / (1.0 + dt / tc),
        ];
        let torsion = self.mods.relaxation_length_m;
        let ctx = SolveCtx {
            dt,
            mass: self.mass_kg,
            izz: self.yaw_inertia_kg_m2,
            side_inertia: self.side_inertia_kg_m2,
            radius: self.radius_m,
            ext: [fx_ext, fy_ext, mz_ext],
            u0,
            target,
            torsion_m: torsion,
        };
        let solve = match self.stepping {
            Stepping::Fast => solve::solve,
            Stepping::Reference => solve::solve_reference,
        };
        let mut saturated = [0.0f64; 2];
        let mut u = solve(
            &ctx,
            &self.tyre,
            &self.wheels,
            &self.contacts,
            &self.deflection,
            saturated,
            &mut self.forces,
        );
        // Torque the controller needs for the first-order response; beyond the limit the side
        // saturates and its wheel spin becomes a free unknown.
        let mut react = [0.0; 2];
        for (wg, f) in self.wheels.iter().zip(&self.forces) {
            react[wg.side] += f.reaction_nm;
        }
        let mut any_sat = false;
        for side in 0..2 {
            let need = self.side_inertia_kg_m2 * (u[3 + side] - u0[3 + side]) / dt + react[side];
            if need.abs() > self.torque_limit_nm {
                saturated[side] = self.torque_limit_nm * need.signum();
                any_sat = true;
            }
        }
        if any_sat {
            u = solve(
                &ctx,
                &self.tyre,
                &self.wheels,
                &self.contacts,
                &self.deflection,
                saturated,
                &mut self.forces,
            );
        }
        self.omega = [u[3], u[4]];
        let mut react = [0.0; 2];
        for (wg, f) in self.wheels.iter().zip(&self.forces) {
            react[wg.side] += f.reaction_nm;
        }
        for side in 0..2 {
            self.saturated[side] = saturated[side] != 0.0;
            self.motor_torque_nm[side] = if self.saturated[side] {
                saturated[side]
            } else {
                self.side_inertia_kg_m2 * (u[3 + side] - u0[3 + side]) / dt + react[side]
            };
        }
        if torsion > 0.0 {
            let tan_peak = self.tyre.tan_slip_angle_peak;
            for (i, c) in self.contacts.iter().enumerate() {
                let (vx, vy) = (u[0] - u[2] * c.y_m, u[1] + u[2] * c.x_m);
                let d = &mut self.deflection[i];
                *d = ((*d + dt * vy / torsion) / (1.0 + dt * vx.abs() / torsion)).clamp(
                    -TORSION_MAX_DEFLECTION * tan_peak,
                    TORSION_MAX_DEFLECTION * tan_peak,
                );
                if !c.in_contact {
                    *d = 0.0;
                }
            }
        }

        // Apply the forces and integrate the chassis.
        let v_before = v64;
        match self.stepping {
            Stepping::Fast => {
                let mut wrench = body::Wrench {
                    force_n: [0.0, 0.0, -GRAVITY_M_S2 * self.mass_kg],
                    ..Default::default()
                };
                for (c, f) in self.contacts.iter().zip(&self.forces) {
                    if !c.in_contact {
                        continue;
                    }
                    wrench.add_at_point(
                        [
                            f.fx_n * ex[0] + f.fy_n * ey[0] + c.load_n * c.normal[0],
                            f.fx_n * ex[1] + f.fy_n * ey[1] + c.load_n * c.normal[1],
                            c.load_n * c.normal[2],
                        ],
                        c.point,
                        com64,
                    );
                }
                let rb = &mut self.bodies[self.body];
                body::integrate(rb, self.mass_kg, self.inertia_kg_m2, &wrench, dt);
            }
            Stepping::Reference => self.rapier_step(dt, ex, ey),
        }
        self.time_s += dt;
        let v_after = to64(self.bodies[self.body].linvel());
        for k in 0..3 {
            self.accel_world[k] = (v_after[k] - v_before[k]) / dt;
        }
        self.yaw_accel_rad_s2 = (self.bodies[self.body].angvel().z as f64 - w64[2]) / dt;
        if self.on_body {
            self.body_stage(dt);
        }
        self.check(u)?;
        let pose = self.true_pose();
        self.pose_history.push_back((self.time_s, pose));
        let keep = self.mods.pose_latency_s + 0.5;
        while self
            .pose_history
            .front()
            .is_some_and(|&(t, _)| t < self.time_s - keep)
        {
            self.pose_history.pop_front();
        }
        Ok(())
    }

    /// The reference integration: the wheel forces handed to rapier's pipeline.
    fn rapier_step(&mut self, dt: f64, ex: [f64; 2], ey: [f64; 2]) {
        let rb = &mut self.bodies[self.body];
        // User forces and torques persist in rapier until reset; both must go.
        rb.reset_forces(false);
        rb.reset_torques(false);
        for (c, f) in self.contacts.iter().zip(&self.forces) {
            if !c.in_contact {
                continue;
            }
            let fw = [
                f.fx_n * ex[0] + f.fy_n * ey[0] + c.load_n * c.normal[0],
                f.fx_n * ex[1] + f.fy_n * ey[1] + c.load_n * c.normal[1],
                c.load_n * c.normal[2],
            ];
            rb.add_force_at_point(
                Vector::new(fw[0] as f32, fw[1] as f32, fw[2] as f32),
                Vector::new(c.point[0] as f32, c.point[1] as f32, c.point[2] as f32),
                true,
            );
        }
        self.params.dt = dt as f32;
        self.pipeline.step(
            Vector::new(0.0, 0.0, -GRAVITY_M_S2 as f32),
            &self.params,
            &mut self.islands,
            &mut self.broad_phase,
            &mut self.narrow_phase,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.impulse_joints,
            &mut self.multibody_joints,
            &mut self.soft_bodies,
            &mut self.ccd,
            &(),
            &(),
        );
    }

    fn check(&self, u: [f64; 5]) -> Result<()> {
        let diverged = |message: String| Error::Diverged {
            step: 0,
            time_s: self.time_s,
            message,
        };
        let rb = &self.bodies[self.body];
        let p = rb.translation();
        let finite = u.iter().all(|x| x.is_finite())
            && p.is_finite()
            && rb.linvel().is_finite()
            && rb.angvel().is_finite();
        if !finite {
            return Err(diverged(format!(
                "non-finite state: position {p:?}, velocity {:?}, wheels {:?}",
                rb.linvel(),
                self.omega
            )));
        }
        if self.airborne_s > MAX_AIRBORNE_S {
            return Err(diverged(format!(
                "the robot left the ground for more than {MAX_AIRBORNE_S} s at {p:?}"
            )));
        }
        let up = rb.position().rotation * Vector::Z;
        if up.z < 0.3 {
            return Err(diverged(format!("the robot rolled over (body z axis {up:?})")));
        }
        Ok(())
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
            .map_or_else(|| self.true_pose(), |&(_, p)| p)
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
        let mut pose = self.delayed_pose();
        if nz.pose_position_m > 0.0 {
            pose.x_m += nz.pose_position_m * self.normal();
            pose.y_m += nz.pose_position_m * self.normal();
        }
        if nz.pose_yaw_rad > 0.0 {
            pose.yaw_rad = plant::wrap_angle(pose.yaw_rad + nz.pose_yaw_rad * self.normal());
        }
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
        let rb = &self.bodies[self.body];
        let p = rb.translation();
        let (yaw, pitch, roll) = rb.position().rotation.to_euler(rapier3d::glamx::EulerRot::ZYX);
        Pose {
            x_m: p.x as f64,
            y_m: p.y as f64,
            z_m: p.z as f64,
            roll_rad: roll as f64,
            pitch_rad: pitch as f64,
            yaw_rad: yaw as f64,
        }
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
    }

    fn begin_manoeuvre(&mut self) {
        self.step_t0_s = self.time_s;
        self.manoeuvre = true;
    }

    fn time_s(&self) -> f64 {
        self.time_s
    }
}
