//! One physics step: the controller's wheel targets, the suspension ray casts, the implicit
//! tyre solve, the chassis integration, the body-stage effects, and the divergence checks.

use super::*;
use drive_sim_model::effects::motor_torque_speed::available_torque_nm;

/// The chassis state at the start of a physics step (f64, world frame) and the frozen heading
/// frame the planar solve works in: what the stages of one step share.
#[derive(Clone, Copy)]
struct StepStart {
    /// Chassis position.
    pos: rapier3d::parry::math::Pose,
    /// Centre of mass.
    com: [f64; 3],
    /// Linear velocity.
    v: [f64; 3],
    /// Angular velocity.
    w: [f64; 3],
    /// The body's -z axis: the suspension rays' direction.
    down: [f64; 3],
    /// Heading frame: x along the horizontal projection of the body x axis.
    ex: [f64; 2],
    /// Heading frame: y.
    ey: [f64; 2],
}

/// The planar solve of one step: the state (vx, vy, wz, omega_left, omega_right) at its start
/// and end, and the torques of the sides held at their limits.
struct PlanarSolution {
    u0: [f64; 5],
    u: [f64; 5],
    saturated: solve::SideTorques,
}

/// A rapier vector in f64.
#[inline]
fn to64(v: Vector) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

impl Simulator {
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
        let ctx = if self.manoeuvre {
            self.ctx.holding(self.cmd)
        } else {
            self.ctx
        };
        TermInput {
            body: v,
            accel: [ax, self.yaw_accel_rad_s2],
            t_in_step_s: self.time_s - self.step_t0_s,
            run_seed: self.seed,
            manoeuvre: self.manoeuvre,
            ..TermInput::at_step(&ctx, self.cmd, &self.nominal)
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
    pub(super) fn physics_velocity(&self) -> BodyVelocity {
        let rb = &self.bodies[self.body];
        let inv = rb.position().rotation.inverse();
        let v = inv * rb.linvel();
        let w = inv * rb.angvel();
        BodyVelocity::new(v.x as f64, v.y as f64, w.z as f64)
    }

    /// One physics step of `dt` seconds.
    pub(super) fn step(&mut self, dt: f64) -> Result<()> {
        self.controller_target(dt);
        let start = self.step_start();
        let ext = self.suspension(&start, dt);
        let sol = self.solve_planar(&start, ext, dt);
        self.update_motors(&sol, dt);
        self.relax_deflection(&sol.u, dt);
        self.integrate(&start, dt);
        if self.on_body {
            self.body_stage(dt);
        }
        self.check(sol.u)?;
        self.record_pose();
        Ok(())
    }

    /// The chassis state at the start of the step and its frozen heading frame.
    #[inline]
    fn step_start(&self) -> StepStart {
        let rb = &self.bodies[self.body];
        let pos = *rb.position();
        let rot = pos.rotation;
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
        StepStart {
            pos,
            com: to64(rb.center_of_mass()),
            v: to64(rb.linvel()),
            w: to64(rb.angvel()),
            down,
            ex,
            ey,
        }
    }

    /// Suspension: one ray per wheel sets its contact (load, point, normal); returns the
    /// horizontal part of the normal forces (slopes) in the heading frame, (fx, fy, mz), which
    /// enters the planar solve.
    #[inline]
    fn suspension(&mut self, st: &StepStart, dt: f64) -> [f64; 3] {
        let mut fx_ext = 0.0;
        let mut fy_ext = 0.0;
        let mut mz_ext = 0.0;
        let mut any_contact = false;
        for i in 0..self.wheels.len() {
            let Some(c) = self.wheel_contact(st, self.wheels[i].hard_point) else {
                self.contacts[i] = Contact::default();
                continue;
            };
            self.contacts[i] = c;
            any_contact = true;
            let load = c.load_n;
            let fh = [load * c.normal[0], load * c.normal[1]];
            let (fxe, fye) = (
                fh[0] * st.ex[0] + fh[1] * st.ex[1],
                fh[0] * st.ey[0] + fh[1] * st.ey[1],
            );
            fx_ext += fxe;
            fy_ext += fye;
            mz_ext += c.x_m * fye - c.y_m * fxe;
        }
        self.airborne_s = if any_contact { 0.0 } else { self.airborne_s + dt };
        [fx_ext, fy_ext, mz_ext]
    }

    /// The contact of the wheel whose hard point is `hard_point` (body frame): the spring-damper
    /// load at the ray's hit; `None` when the ray misses the ground.
    #[inline]
    fn wheel_contact(&self, st: &StepStart, hard_point: [f64; 3]) -> Option<Contact> {
        let hp64 =
            to64(st.pos * Vector::new(hard_point[0] as f32, hard_point[1] as f32, hard_point[2] as f32));
        let (down, com64, v64, w64) = (st.down, st.com, st.v, st.w);
        let hit = self.suspension_ray(hp64, down)?;
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
        let point = [
            hp64[0] + down[0] * hit.distance_m,
            hp64[1] + down[1] * hit.distance_m,
            hp64[2] + down[2] * hit.distance_m,
        ];
        let rel = [point[0] - com64[0], point[1] - com64[1]];
        Some(Contact {
            load_n: f.max(0.0),
            x_m: rel[0] * st.ex[0] + rel[1] * st.ex[1],
            y_m: rel[0] * st.ey[0] + rel[1] * st.ey[1],
            point,
            normal: hit.normal,
            in_contact: true,
        })
    }

    /// The planar implicit solve (`solve.rs`) from the step's start; solved again with a
    /// side's torque held at its limit when the controller would need more than the limit.
    #[inline]
    fn solve_planar(&mut self, st: &StepStart, ext: [f64; 3], dt: f64) -> PlanarSolution {
        let (v64, w64) = (st.v, st.w);
        let u0 = [
            v64[0] * st.ex[0] + v64[1] * st.ex[1],
            v64[0] * st.ey[0] + v64[1] * st.ey[1],
            w64[2],
            self.omega[0],
            self.omega[1],
        ];
        let mut guess = [0.0; 5];
        for k in 0..5 {
            guess[k] = u0[k] + self.last_change[k];
        }
        let ctx = SolveCtx {
            dt,
            mass: self.mass_kg,
            izz: self.yaw_inertia_kg_m2,
            side_inertia: self.side_inertia_kg_m2,
            radius: self.radius_m,
            ext,
            u0,
            target: self.spin_targets(dt),
            guess,
            torsion_m: self.mods.relaxation_length_m,
        };
        #[cfg(feature = "oracle")]
        let solve = match self.reference {
            Some(_) => reference::solve_reference,
            None => solve::solve,
        };
        #[cfg(not(feature = "oracle"))]
        let solve = solve::solve;
        let mut saturated: solve::SideTorques = [None; 2];
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
        let react = self.side_reactions();
        for side in 0..2 {
            let need = self.side_inertia_kg_m2 * (u[3 + side] - u0[3 + side]) / dt + react[side];
            // The torque-speed line (an effect) is read at the step's start spin: explicit,
            // like the rest of the controller.
            let limit = available_torque_nm(
                self.torque_limit_nm,
                self.mods.motor_stall_torque_nm,
                self.mods.motor_no_load_speed_rad_s,
                u0[3 + side],
                need,
            );
            if need.abs() > limit {
                saturated[side] = Some(limit * need.signum());
            }
        }
        if saturated.iter().any(Option::is_some) {
            let ctx = SolveCtx { guess: u, ..ctx };
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
        PlanarSolution { u0, u, saturated }
    }

    /// Wheel spins that the unsaturated controller reaches at the end of the step (first-order
    /// tracking of the ramp, backward Euler).
    #[inline]
    fn spin_targets(&self, dt: f64) -> [f64; 2] {
        let tc = self.time_constant_s;
        // A drooping speed loop (an effect) aims below its command by the torque it delivered
        // at the previous step, less what its integral already supplies: explicit, like the
        // torque-speed line.
        let droop = self.mods.speed_droop_rad_s_per_nm;
        let aim = [
            self.ramp[0] - droop * (self.motor_torque_nm[0] - self.droop_integral_nm[0]),
            self.ramp[1] - droop * (self.motor_torque_nm[1] - self.droop_integral_nm[1]),
        ];
        [
            (self.omega[0] + dt / tc * aim[0]) / (1.0 + dt / tc),
            (self.omega[1] + dt / tc * aim[1]) / (1.0 + dt / tc),
        ]
    }

    /// The tyres' reaction torques summed per side (left, right), from the current forces.
    #[inline]
    fn side_reactions(&self) -> [f64; 2] {
        let mut react = [0.0; 2];
        for (wg, f) in self.wheels.iter().zip(&self.forces) {
            react[wg.side] += f.reaction_nm;
        }
        react
    }

    /// The motors after the solve: wheel spins, the solve's predictor, each side's torque and
    /// saturation, and the speed loop's integral.
    #[inline]
    fn update_motors(&mut self, sol: &PlanarSolution, dt: f64) {
        let (u0, u, saturated) = (sol.u0, sol.u, sol.saturated);
        self.omega = [u[3], u[4]];
        for k in 0..5 {
            self.last_change[k] = u[k] - u0[k];
        }
        let react = self.side_reactions();
        for side in 0..2 {
            self.saturated[side] = saturated[side].is_some();
            self.motor_torque_nm[side] = saturated[side]
                .unwrap_or_else(|| self.side_inertia_kg_m2 * (u[3 + side] - u0[3 + side]) / dt + react[side]);
        }
        // The speed loop's integral follows the torque (implicit Euler, stable at any step);
        // without a recovery time it stays empty and the droop is proportional.
        let recovery = self.mods.speed_droop_recovery_s;
        if recovery.is_finite() {
            let a = dt / recovery;
            for side in 0..2 {
                self.droop_integral_nm[side] =
                    (self.droop_integral_nm[side] + a * self.motor_torque_nm[side]) / (1.0 + a);
            }
        }
    }

    /// The tyres' lateral deflection (torsion effect) relaxes towards the contact's lateral
    /// slip over the relaxation length; zero off the ground.
    #[inline]
    fn relax_deflection(&mut self, u: &[f64; 5], dt: f64) {
        let torsion = self.mods.relaxation_length_m;
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
    }

    /// Applies the forces, integrates the chassis over `dt` and records the accelerations over
    /// the step.
    #[inline]
    fn integrate(&mut self, st: &StepStart, dt: f64) {
        let (ex, ey) = (st.ex, st.ey);
        #[cfg(feature = "oracle")]
        if let Some(reference) = self.reference.as_mut() {
            reference.step(
                &mut self.bodies,
                &mut self.colliders,
                self.body,
                &self.contacts,
                &self.forces,
                dt,
                ex,
                ey,
            );
        } else {
            self.integrate_chassis(dt, ex, ey, st.com);
        }
        #[cfg(not(feature = "oracle"))]
        self.integrate_chassis(dt, ex, ey, st.com);
        self.time_s += dt;
        let v_after = to64(self.bodies[self.body].linvel());
        for ((a, after), before) in self.accel_world.iter_mut().zip(v_after).zip(st.v) {
            *a = (after - before) / dt;
        }
        self.yaw_accel_rad_s2 = (self.bodies[self.body].angvel().z as f64 - st.w[2]) / dt;
    }

    /// Keeps the chassis position of the step for the delayed pose, as far back as the pose
    /// latency reaches.
    #[inline]
    fn record_pose(&mut self) {
        let position = *self.bodies[self.body].position();
        self.pose_history.push_back((self.time_s, position));
        let keep = self.mods.pose_latency_s + 0.5;
        while self
            .pose_history
            .front()
            .is_some_and(|&(t, _)| t < self.time_s - keep)
        {
            self.pose_history.pop_front();
        }
    }

    /// The suspension ray from a wheel's hard point: the direct lookup on the ground's
    /// triangles, or parry's ray cast when the reference step is on.
    fn suspension_ray(&self, origin: [f64; 3], down: [f64; 3]) -> Option<ground::Hit> {
        #[cfg(feature = "oracle")]
        if self.reference.is_some() {
            return self
                .ground
                .cast_parry(&self.colliders, origin, down, self.ray_length_m);
        }
        self.ground.cast(&self.colliders, origin, down, self.ray_length_m)
    }

    /// Applies the wheel forces, the normal loads and gravity to the chassis and integrates it
    /// over `dt` (rapier's free-body scheme, `body.rs`).
    fn integrate_chassis(&mut self, dt: f64, ex: [f64; 2], ey: [f64; 2], com64: [f64; 3]) {
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
        // A robot that leaves the height field falls off its edge and rolls over; say where it
        // went instead (an operator whose manoeuvres never bring it back, an effect that makes
        // the protocol's steps leave the site).
        if let Some(half) = self.ground.half_extent_m() {
            if (p.x as f64).abs() > half || (p.y as f64).abs() > half {
                return Err(diverged(format!(
                    "the robot left the simulated ground, a {:.0} m square around the site, at ({:.1}, {:.1}) m: nothing brought it back to the safe area",
                    2.0 * half,
                    p.x,
                    p.y
                )));
            }
        }
        let up = rb.position().rotation * Vector::Z;
        if up.z < 0.3 {
            return Err(diverged(format!("the robot rolled over (body z axis {up:?})")));
        }
        Ok(())
    }
}
