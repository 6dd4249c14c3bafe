//! The simulated safety operator: the call to interrupt an attempt, and the re-orientation
//! after it (stop, drive back towards the centre when no heading fits and the centre is better,
//! turn to the heading from which the command stays inside longest, stop).
//!
//! The operator plans a re-orientation on the motion it has just watched the command produce
//! (the body's velocity when it was interrupted, once past the transient), not on the ideal
//! differential drive's: on ice a command the ideal drive turns on a 3 m circle goes straight,
//! and an operator who planned the circle placed the robot where the straight line left the area
//! again, three times in a row.

use super::*;

/// The operator's best heading for a planned motion from a pose.
struct Heading {
    /// World-frame heading to turn to, rad.
    heading_rad: f64,
    /// How long the planned motion stays inside from there (at most a step and a second), s.
    time_inside_s: f64,
    /// Whether that is a whole step with half a second to spare.
    fits: bool,
}

impl Runner<'_> {
    /// The operator's call: would the robot, braking now, stop outside the shrunk safe area,
    /// moving outwards? (A robot left beyond the shrunk border by a stop or a turn is not
    /// interrupted for heading back in: the first operator stopped it at the first tick, up to
    /// five times in a row on mud.)
    pub(super) fn would_leave(&self) -> bool {
        let p = self.plant.true_pose();
        let v = self.plant.true_velocity();
        let speed = v.vx_m_s.hypot(v.vy_m_s);
        let stop = speed * speed / (2.0 * self.cfg.operator_decel_m_s2);
        // World-frame direction of travel.
        let heading = p.yaw_rad + v.vy_m_s.atan2(v.vx_m_s);
        let (sx, sy) = (p.x_m + stop * heading.cos(), p.y_m + stop * heading.sin());
        stops_outside(
            self.half_extents(),
            self.cfg.border_margin_m,
            (p.x_m, p.y_m),
            (sx, sy),
        )
    }

    /// The operator's re-orientation after an interruption of `cmd`, planned on `seen` (the
    /// body velocity the command had reached when interrupted; `None` if it was still in its
    /// transient, then the ideal differential drive's): stop; if no heading lets the command run
    /// a whole step inside the area from where the robot stands and it would stay inside longer
    /// from the centre, drive it towards the centre until it fits; then turn it to the heading
    /// from which it stays inside longest (ties: facing the centre with the side the command
    /// drives towards, the paper's rule: "reorient the vehicle to complete the interrupted
    /// command in the direction of the center of the safe zone").
    pub(super) fn reorient(&mut self, step: u32, cmd: WheelSpeeds, seen: Option<BodyVelocity>) -> Result<()> {
        let phase = Phase::Reorient { step };
        let plan = seen.unwrap_or_else(|| self.space.idd.body_from_wheels(cmd));
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
        let mut here = self.best_heading(self.plant.true_pose(), plan);
        if !here.fits {
            // A straight fast command has more room from the border, facing across the area,
            // than from the centre; a tight circle near the border has less.
            let centre = Pose {
                x_m: 0.0,
                y_m: 0.0,
                ..self.plant.true_pose()
            };
            let from_centre = self.best_heading(centre, plan);
            if from_centre.time_inside_s > here.time_inside_s + 0.5 {
                let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
                self.drive_towards_centre(phase, step, plan, from_centre.time_inside_s, max_wz, deadline)?;
                self.summary.reorientation_driving_s += lap(self.plant, &mut t);
                let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
                self.stop(phase, step, deadline)?;
                self.summary.reorientation_stopping_s += lap(self.plant, &mut t);
                here = self.best_heading(self.plant.true_pose(), plan);
            }
        }
        let heading = here.heading_rad;
        let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
        self.turn_to(phase, step, move |_| heading, max_wz, deadline)?;
        self.summary.reorientation_turning_s += lap(self.plant, &mut t);
        let deadline = self.plant.time_s() + self.cfg.max_reorient_s;
        self.stop(phase, step, deadline)?;
        self.summary.reorientation_stopping_s += lap(self.plant, &mut t);
        Ok(())
    }

    /// Drives towards the centre of the safe area at the operator's pace until the planned
    /// motion fits from the robot's position or stays inside within half a second of
    /// `centre_time_inside_s` (checked every 0.5 s), or it is within 1 m of the centre. It drives
    /// straight, forward or backward, whichever faces the centre, steering only gently, and
    /// turns in place first only if the centre is nearly abeam: a skid-steer on soft ground may
    /// not turn at all, but it can drive straight.
    fn drive_towards_centre(
        &mut self,
        phase: Phase,
        step: u32,
        plan: BodyVelocity,
        centre_time_inside_s: f64,
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
            if ticks % check_every == 0 && ticks > 0 {
                let here = self.best_heading(p, plan);
                if here.fits || here.time_inside_s >= centre_time_inside_s - 0.5 {
                    return Ok(());
                }
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

    /// The heading (every 5°) from which the planned motion (the body velocity `plan`, held)
    /// stays longest inside the safe area, judged as [`Self::would_leave`] judges the run: a
    /// point of the path counts as inside while the robot, braking there at the operator's
    /// deceleration, would stop inside the area shrunk by the margin. Among equals, the one
    /// closest to facing the centre with the side the command drives towards.
    ///
    /// The stopping distance lies along the direction of travel only. (The first operator
    /// shrank the area by it on every side: on ice, where it is 13 m at 3.8 m/s, that left no
    /// heading for any fast command, and the robot was driven back to the centre and
    /// interrupted at the same place again.)
    fn best_heading(&self, p: Pose, plan: BodyVelocity) -> Heading {
        let backward = plan.vx_m_s < 0.0;
        let to_centre = (-p.y_m).atan2(-p.x_m);
        let preferred = if backward {
            wrap_angle(to_centre + std::f64::consts::PI)
        } else {
            to_centre
        };
        let (hx, hy) = self.half_extents();
        let m = self.cfg.border_margin_m;
        let speed = plan.vx_m_s.hypot(plan.vy_m_s);
        let stop_m = speed * speed / (2.0 * self.cfg.operator_decel_m_s2);
        // Direction of travel relative to the heading (sideways slide included).
        let course = plan.vy_m_s.atan2(plan.vx_m_s);
        let inside = |x: f64, y: f64, yaw: f64| {
            let stop = (
                x + stop_m * (yaw + course).cos(),
                y + stop_m * (yaw + course).sin(),
            );
            !stops_outside((hx, hy), m, (x, y), stop)
        };
        // One second beyond the step: the real robot lags the ideal path it is planned on.
        let step_s = self.cfg.step_s();
        let horizon_s = step_s + 1.0;
        let dt = 0.1;
        let time_inside = |heading: f64| {
            let (mut x, mut y, mut yaw) = (p.x_m, p.y_m, heading);
            let mut t = 0.0;
            while t < horizon_s - 1e-9 {
                x += (plan.vx_m_s * yaw.cos() - plan.vy_m_s * yaw.sin()) * dt;
                y += (plan.vx_m_s * yaw.sin() + plan.vy_m_s * yaw.cos()) * dt;
                yaw += plan.wz_rad_s * dt;
                if !inside(x, y, yaw) {
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
        Heading {
            heading_rad: best.2,
            time_inside_s: best.0,
            fits: best.0 >= step_s + 0.5,
        }
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

/// Whether a robot at `at` that would stop at `stop` ends outside the safe area of half extents
/// `half_m` shrunk by `margin_m`, further out than it is: the operator's rule, shared by the call
/// to interrupt and the planning of a re-orientation so that the two agree.
pub(super) fn stops_outside(half_m: (f64, f64), margin_m: f64, at: (f64, f64), stop: (f64, f64)) -> bool {
    let out = |s: f64, a: f64, h: f64| s.abs() > h - margin_m && s.abs() > a.abs();
    out(stop.0, at.0, half_m.0) || out(stop.1, at.1, half_m.1)
}
