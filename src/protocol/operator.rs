//! The simulated safety operator: the call to interrupt an attempt, and the re-orientation
//! after it (stop, drive back towards the centre when no heading fits, turn to the heading from
//! which the command stays inside longest, stop).

use super::*;

impl Runner<'_> {
    /// The operator's call: would the robot, braking now, stop outside the shrunk safe area?
    pub(super) fn would_leave(&self) -> bool {
        let p = self.plant.true_pose();
        let v = self.plant.true_velocity();
        let speed = v.vx_m_s.hypot(v.vy_m_s);
        let stop = speed * speed / (2.0 * self.cfg.operator_decel_m_s2);
        // World-frame direction of travel.
        let heading = p.yaw_rad + v.vy_m_s.atan2(v.vx_m_s);
        let (sx, sy) = (p.x_m + stop * heading.cos(), p.y_m + stop * heading.sin());
        let (hx, hy) = self.half_extents();
        let m = self.cfg.border_margin_m;
        sx.abs() > hx - m || sy.abs() > hy - m
    }

    /// The operator's re-orientation after an interruption: stop; if no heading lets `cmd`
    /// run a whole step inside the area from where the robot stands (it stopped near the
    /// border, or slid out), drive it towards the centre until one does; then turn it to the
    /// heading from which the command stays inside longest (ties: facing the centre with the
    /// side the command drives towards, the paper's rule).
    pub(super) fn reorient(&mut self, step: u32, cmd: WheelSpeeds) -> Result<()> {
        let phase = Phase::Reorient { step };
        self.plant.begin_manoeuvre();
        let max_wz = (0.5 * self.space.max_ang_rad_s).min(self.cfg.reorient_yaw_rate_rad_s);
        let mut t = self.plant.time_s();
        // Time since `t` (and `t` moved on), for the summary's breakdown.
        let lap = |plant: &dyn Plant, t: &mut f64| {
            let d = plant.time_s() - *t;
            *t = plant.time_s();
            d
        };
        let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
        self.stop(phase, step, deadline)?;
        self.summary.reorientation_stopping_s += lap(self.plant, &mut t);
        if !self.best_heading(self.plant.true_pose(), cmd).1 {
            let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
            self.drive_towards_centre(phase, step, cmd, max_wz, deadline)?;
            self.summary.reorientation_driving_s += lap(self.plant, &mut t);
            let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
            self.stop(phase, step, deadline)?;
            self.summary.reorientation_stopping_s += lap(self.plant, &mut t);
        }
        let (heading, _) = self.best_heading(self.plant.true_pose(), cmd);
        let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
        self.turn_to(phase, step, move |_| heading, max_wz, deadline)?;
        self.summary.reorientation_turning_s += lap(self.plant, &mut t);
        let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
        self.stop(phase, step, deadline)?;
        self.summary.reorientation_stopping_s += lap(self.plant, &mut t);
        Ok(())
    }

    /// Drives towards the centre of the safe area at the operator's pace until `cmd` fits from the
    /// robot's position (checked every 0.5 s) or it is within 1 m of the centre. It drives
    /// straight, forward or backward, whichever faces the centre, steering only gently, and
    /// turns in place first only if the centre is nearly abeam: a skid-steer on soft ground may
    /// not turn at all, but it can drive straight.
    fn drive_towards_centre(
        &mut self,
        phase: Phase,
        step: u32,
        cmd: WheelSpeeds,
        max_wz: f64,
        deadline: f64,
    ) -> Result<()> {
        let idd = self.space.idd;
        let check_every = (0.5 * self.cfg.rate_hz).round().max(1.0) as u32;
        let mut ticks = 0u32;
        loop {
            let p = self.plant.true_pose();
            if p.x_m.hypot(p.y_m) < 1.0 {
                return Ok(());
            }
            if ticks % check_every == 0 && ticks > 0 && self.best_heading(p, cmd).1 {
                return Ok(());
            }
            let err = wrap_angle((-p.y_m).atan2(-p.x_m) - p.yaw_rad);
            let (dir, err) = if err.abs() <= std::f64::consts::FRAC_PI_2 {
                (1.0, err)
            } else {
                (-1.0, wrap_angle(err + std::f64::consts::PI))
            };
            // Nearly abeam (|err| near 90°): driving would run along the border; turn first.
            let vx = if err.abs() > 1.2 {
                0.0
            } else {
                dir * (0.5 * self.space.max_lin_m_s).min(self.cfg.reorient_speed_m_s)
            };
            let wz = (1.5 * err).clamp(-max_wz, max_wz);
            let c = idd.wheels_from_body(BodyVelocity::new(vx, 0.0, wz));
            self.tick(phase, c, step)?;
            ticks += 1;
            if self.plant.time_s() > deadline {
                self.summary.incomplete_reorientations += 1;
                return Ok(());
            }
        }
    }

    /// The heading (every 5°) from which the ideal differential-drive path of `cmd` stays
    /// longest inside the safe area shrunk by the margin and the stopping distance, and whether
    /// it fits a whole step with time to spare; among equals, the one closest to facing the
    /// centre with the side the command drives towards.
    fn best_heading(&self, p: Pose, cmd: WheelSpeeds) -> (f64, bool) {
        let v = self.space.idd.body_from_wheels(cmd);
        let backward = v.vx_m_s < 0.0;
        let to_centre = (-p.y_m).atan2(-p.x_m);
        let preferred = if backward {
            wrap_angle(to_centre + std::f64::consts::PI)
        } else {
            to_centre
        };
        let (hx, hy) = self.half_extents();
        let m = self.cfg.border_margin_m + v.vx_m_s.powi(2) / (2.0 * self.cfg.operator_decel_m_s2);
        // One second beyond the step: the real robot lags the ideal path it is planned on.
        let step_s = self.cfg.window_s * self.cfg.windows_per_step as f64;
        let horizon_s = step_s + 1.0;
        let dt = 0.1;
        let time_inside = |heading: f64| {
            let (mut x, mut y, mut yaw) = (p.x_m, p.y_m, heading);
            let mut t = 0.0;
            while t < horizon_s - 1e-9 {
                x += v.vx_m_s * yaw.cos() * dt;
                y += v.vx_m_s * yaw.sin() * dt;
                yaw += v.wz_rad_s * dt;
                if x.abs() > hx - m || y.abs() > hy - m {
                    break;
                }
                t += dt;
            }
            t
        };
        let mut best = (f64::MIN, f64::MAX, preferred);
        for i in 0..72 {
            let h = wrap_angle(i as f64 * 5f64.to_radians());
            let t = time_inside(h);
            let off = wrap_angle(h - preferred).abs();
            if t > best.0 + 1e-9 || ((t - best.0).abs() <= 1e-9 && off < best.1) {
                best = (t, off, h);
            }
        }
        (best.2, best.0 >= step_s + 0.5)
    }

    fn stuck_error(&self, step: u32) -> Error {
        Error::Diverged {
            step,
            time_s: self.plant.time_s(),
            message: format!(
                "re-orientation did not finish within {} s (robot stuck at {:?})",
                self.cfg.max_reorient_s,
                self.plant.true_pose()
            ),
        }
    }

    fn stop(&mut self, phase: Phase, step: u32, deadline: f64) -> Result<()> {
        loop {
            self.tick(phase, WheelSpeeds::default(), step)?;
            let v = self.plant.true_velocity();
            if v.vx_m_s.hypot(v.vy_m_s) < 0.05 && v.wz_rad_s.abs() < 0.05 {
                return Ok(());
            }
            if self.plant.time_s() > deadline {
                return Err(self.stuck_error(step));
            }
        }
    }

    /// Turns towards `target(pose)`. In place first; if the yaw stops progressing for
    /// `STALL_S` (a skid-steer on soft ground may not be able to skid its tyres sideways), as
    /// an arc turn at walking pace, which needs far less skid. Gives up at `deadline` and
    /// returns whether the heading was reached: a run continues from where the robot is.
    fn turn_to(
        &mut self,
        phase: Phase,
        step: u32,
        target: impl Fn(Pose) -> f64,
        max_wz: f64,
        deadline: f64,
    ) -> Result<bool> {
        const STALL_S: f64 = 3.0;
        let idd = self.space.idd;
        let mut best_err = f64::INFINITY;
        let mut last_progress_s = self.plant.time_s();
        let mut arc = false;
        loop {
            let p = self.plant.true_pose();
            let err = wrap_angle(target(p) - p.yaw_rad);
            if err.abs() < 0.1 {
                return Ok(true);
            }
            if err.abs() < best_err - 0.02 {
                best_err = err.abs();
                last_progress_s = self.plant.time_s();
            } else if self.plant.time_s() - last_progress_s > STALL_S {
                arc = true;
            }
            let vx = if arc {
                0.3 * self.space.max_lin_m_s.min(2.0)
            } else {
                0.0
            };
            let c = idd.wheels_from_body(BodyVelocity::new(vx, 0.0, (1.5 * err).clamp(-max_wz, max_wz)));
            self.tick(phase, c, step)?;
            if self.plant.time_s() > deadline {
                self.summary.incomplete_reorientations += 1;
                return Ok(false);
            }
        }
    }
}
