//! Building the world: the ground from the terrain, the chassis from the robot file, the
//! suspension at its static equilibrium, and the checks of the combination.

use super::*;

fn cfg_err(field: &str, message: String) -> Error {
    Error::config("<simulator>", field, message)
}

/// The configuration's own checks: the physics rate and the sensor noise levels.
fn check_config(cfg: &SimConfig) -> Result<()> {
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
    Ok(())
}

/// The wheels' suspension: hard points at the static equilibrium and the ray lengths.
struct Suspension {
    /// Every wheel, left side first, rear to front.
    wheels: Vec<WheelGeom>,
    /// Hard point to wheel bottom at full extension, m.
    free_length_m: f64,
    /// The terrain's sinkage, m.
    sinkage_m: f64,
}

impl Suspension {
    /// The suspension of `robot` on `terrain`; an error when the robot has no or too many
    /// wheels, its springs cannot carry it, or the terrain buries its wheels.
    fn of(robot: &Robot, terrain: &Terrain) -> Result<Self> {
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
        Ok(Self {
            wheels: wheel_geometry(robot, n_wheels, hard_point_z),
            free_length_m,
            sinkage_m,
        })
    }
}

/// The `n_wheels` wheels of `robot`, left side first, each side's evenly spread over the
/// wheelbase, hard points at height `hard_point_z` over the centre of mass.
fn wheel_geometry(robot: &Robot, n_wheels: usize, hard_point_z: f64) -> Vec<WheelGeom> {
    let w = &robot.wheels;
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
    wheels
}

/// The ground collider from the terrain's roughness (height field seeded by `seed`), wide
/// enough around the robot's safe area.
fn build_ground(robot: &Robot, terrain: &Terrain, seed: u64) -> (ColliderSet, Ground) {
    let mut colliders = ColliderSet::new();
    let extent_m = 2.0 * robot.safe_area.length_m.max(robot.safe_area.width_m) + 20.0;
    let ground = Ground::build(
        &mut colliders,
        terrain.roughness.height_std_m,
        terrain.roughness.correlation_length_m,
        extent_m,
        seed,
    );
    (colliders, ground)
}

/// The chassis: one rigid body with the box inertia of the robot's body.
struct Chassis {
    bodies: RigidBodySet,
    body: RigidBodyHandle,
    /// Principal moments of inertia (body axes), kg·m².
    inertia_kg_m2: [f64; 3],
}

impl Chassis {
    fn of(robot: &Robot) -> Self {
        let b = &robot.body;
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
        Self {
            bodies,
            body,
            inertia_kg_m2: inertia,
        }
    }
}

impl Simulator {
    /// Builds the world: ground from the terrain (height field seeded by `cfg.seed`), the robot
    /// at rest at the origin facing +x, suspension at its static equilibrium.
    pub fn new(robot: &Robot, terrain: &Terrain, cfg: SimConfig) -> Result<Self> {
        check_config(&cfg)?;
        let suspension = Suspension::of(robot, terrain)?;
        let n_wheels = suspension.wheels.len();
        let (colliders, ground) = build_ground(robot, terrain, cfg.seed);
        let chassis = Chassis::of(robot);
        // A robot's and a terrain's own effects (their `[effects]` tables) run under the
        // configuration's, which override them.
        let effects =
            drive_sim_model::effects_table::combine(&robot.effects, &terrain.effects, &cfg.effects)?;
        let mods = effects.modifiers();
        let effects_on_body = effects.acts_on_body();
        let (b, w, s) = (&robot.body, &robot.wheels, &robot.suspension);
        let radius_m = w.radius_m * mods.wheel_radius_scale;
        let mut sim = Self {
            bodies: chassis.bodies,
            colliders,
            body: chassis.body,
            ground,
            mass_kg: b.mass_kg,
            yaw_inertia_kg_m2: robot.yaw_inertia_kg_m2(),
            wheels: suspension.wheels,
            free_length_m: suspension.free_length_m,
            ray_length_m: suspension.free_length_m - suspension.sinkage_m,
            travel_m: s.travel_m,
            stiffness_n_m: s.stiffness_n_m,
            damping_n_s_m: s.damping_n_s_m,
            radius_m,
            side_inertia_kg_m2: w.inertia_kg_m2 * w.per_side as f64,
            torque_limit_nm: robot.powertrain.torque_limit_nm,
            accel_limit_rad_s2: robot.powertrain.wheel_accel_limit_rad_s2,
            time_constant_s: robot.powertrain.time_constant_s * mods.time_constant_scale,
            com_height_m: b.com_height_m,
            sinkage_m: suspension.sinkage_m,
            tyre: TyreParams::new(terrain, radius_m, w.width_m, mods.lateral_friction_scale),
            nominal: robot.idd(),
            effects,
            mods,
            noise: cfg.noise,
            physics_hz: cfg.physics_hz,
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            seed: cfg.seed,
            cmd: WheelSpeeds::default(),
            cmd_queue: VecDeque::new(),
            applied: WheelSpeeds::default(),
            ramp: [0.0; 2],
            omega: [0.0; 2],
            last_change: [0.0; 5],
            deflection: vec![0.0; n_wheels],
            contacts: vec![Contact::default(); n_wheels],
            forces: vec![ContactForce::default(); n_wheels],
            motor_torque_nm: [0.0; 2],
            droop_integral_nm: [0.0; 2],
            saturated: [false; 2],
            time_s: 0.0,
            airborne_s: 0.0,
            accel_world: [0.0; 3],
            pose_history: VecDeque::new(),
            odometry: FadingOdometry::default(),
            pose_updates: PoseUpdates::default(),
            inertia_kg_m2: chassis.inertia_kg_m2,
            #[cfg(feature = "oracle")]
            reference: None,
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
}
