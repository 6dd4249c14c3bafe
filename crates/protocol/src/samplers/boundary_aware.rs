//! `boundary-aware`: avoids interruptions by drawing only commands whose predicted step stays
//! in the safe area.
//!
//! For each uniform candidate it predicts the step under the IDD from `ctx.pose`: the wheels
//! move from the previous command to the candidate with a first-order lag, and at every
//! prediction tick it computes where the safety operator would see the robot stop (the
//! protocol's rule: braking at `operator_decel_m_s2` along the direction of travel). A candidate
//! is feasible when that stop point stays `border_margin_m + extra_margin_m` inside the safe
//! area for the whole step. The first feasible candidate is returned (so the command is uniform
//! over the feasible part of U); if none of `candidates` is feasible, the one with the smallest
//! excursion beyond the border. Predictions ignore slip: on low-friction terrain the robot
//! drifts and some interruptions remain. Feasible commands near a border are the slow and
//! turning ones, so this strategy under-samples fast straight commands in small areas.
//!
//! The candidates come from another strategy: uniform draws (`uniform-wheel`) by default, any
//! sampler with [`BoundaryAware::wrapping`] (e.g. `spread-accel` made boundary-aware).

use super::uniform_wheel::UniformWheel;
use super::SamplerEntry;
use crate::sampler::{Sampler, SamplingContext};
use crate::ProtocolConfig;
use drive_sim_model::kinematics::{CommandSpace, WheelSpeeds};
use drive_sim_model::measurement::Pose;
use drive_sim_model::Result;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "boundary-aware",
    summary: "uniform over the commands whose predicted step stays in the safe area",
    build: |seed, protocol| Box::new(BoundaryAware::from_protocol(seed, protocol)),
};

/// Rejects candidates whose predicted step would make the operator interrupt it.
pub struct BoundaryAware {
    /// Where candidates come from.
    proposals: Box<dyn Sampler>,
    /// `boundary-aware`, or `boundary-aware(<inner>)` for a wrapped strategy.
    name: String,
    /// Candidates drawn per command.
    pub candidates: usize,
    /// Duration of one step, s.
    pub horizon_s: f64,
    /// Deceleration the operator assumes, m/s².
    pub operator_decel_m_s2: f64,
    /// The operator's margin to the border, m.
    pub border_margin_m: f64,
    /// Extra margin for prediction error, m.
    pub extra_margin_m: f64,
    /// First-order time constant of the wheel speeds in the prediction, s.
    pub lag_s: f64,
    /// Prediction tick, s.
    pub dt_s: f64,
}

impl BoundaryAware {
    /// Parameters matching the default [`ProtocolConfig`], seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self::from_protocol(seed, &ProtocolConfig::default())
    }

    /// Uniform candidates, parameters matching `cfg` (step duration, operator deceleration and
    /// margin).
    pub fn from_protocol(seed: u64, cfg: &ProtocolConfig) -> Self {
        let mut s = Self::wrapping(Box::new(UniformWheel::new(seed)), cfg);
        s.name = ENTRY.name.to_string();
        s
    }

    /// Candidates drawn from `inner` (each call of its `next` is one candidate), parameters
    /// matching `cfg`. Named `boundary-aware(<inner name>)`.
    pub fn wrapping(inner: Box<dyn Sampler>, cfg: &ProtocolConfig) -> Self {
        Self {
            name: format!("{}({})", ENTRY.name, inner.name()),
            proposals: inner,
            candidates: 32,
            horizon_s: cfg.step_s(),
            operator_decel_m_s2: cfg.operator_decel_m_s2,
            border_margin_m: cfg.border_margin_m,
            extra_margin_m: 0.1,
            lag_s: 0.15,
            dt_s: 1.0 / cfg.rate_hz,
        }
    }

    /// Largest excursion (m) of the operator's predicted stop point beyond the shrunk safe area
    /// over the step; negative when the whole step stays inside, by that clearance.
    pub fn excursion_m(
        &self,
        space: &CommandSpace,
        pose: Pose,
        previous: WheelSpeeds,
        cmd: WheelSpeeds,
        half_extents_m: (f64, f64),
    ) -> f64 {
        let (hx, hy) = half_extents_m;
        let m = self.border_margin_m + self.extra_margin_m;
        let (lx, ly) = (hx - m, hy - m);
        let (mut x, mut y, mut yaw) = (pose.x_m, pose.y_m, pose.yaw_rad);
        let dt = self.dt_s.max(1e-3);
        let ticks = (self.horizon_s / dt).ceil() as usize;
        let decay = if self.lag_s > 0.0 {
            (-dt / self.lag_s).exp()
        } else {
            0.0
        };
        let mut w = previous;
        let mut worst = f64::NEG_INFINITY;
        for _ in 0..ticks {
            w = WheelSpeeds::new(
                cmd.left_rad_s + (w.left_rad_s - cmd.left_rad_s) * decay,
                cmd.right_rad_s + (w.right_rad_s - cmd.right_rad_s) * decay,
            );
            let v = space.idd.body_from_wheels(w);
            // Midpoint heading integration of the unicycle over one tick.
            let mid = yaw + 0.5 * v.wz_rad_s * dt;
            x += v.vx_m_s * dt * mid.cos();
            y += v.vx_m_s * dt * mid.sin();
            yaw += v.wz_rad_s * dt;
            let stop = v.vx_m_s * v.vx_m_s / (2.0 * self.operator_decel_m_s2);
            let dir = if v.vx_m_s < 0.0 {
                yaw + std::f64::consts::PI
            } else {
                yaw
            };
            let (sx, sy) = (x + stop * dir.cos(), y + stop * dir.sin());
            worst = worst.max((sx.abs() - lx).max(sy.abs() - ly));
        }
        worst
    }
}

impl Sampler for BoundaryAware {
    fn name(&self) -> &str {
        &self.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        let mut best: Option<(f64, WheelSpeeds)> = None;
        for _ in 0..self.candidates.max(1) {
            let c = self.proposals.next(ctx)?;
            let e = self.excursion_m(ctx.space, ctx.pose, ctx.previous, c, ctx.safe_half_extents_m);
            if e <= 0.0 {
                return Ok(c);
            }
            if best.is_none_or(|(b, _)| e < b) {
                best = Some((e, c));
            }
        }
        Ok(best.map(|(_, c)| c).unwrap_or_default())
    }
}

impl std::fmt::Debug for BoundaryAware {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BoundaryAware")
            .field("name", &self.name)
            .field("candidates", &self.candidates)
            .field("horizon_s", &self.horizon_s)
            .field("operator_decel_m_s2", &self.operator_decel_m_s2)
            .field("border_margin_m", &self.border_margin_m)
            .field("extra_margin_m", &self.extra_margin_m)
            .field("lag_s", &self.lag_s)
            .field("dt_s", &self.dt_s)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::IdealDiffDrive;

    #[test]
    fn straight_run_excursion_by_hand() {
        // Wheels already at 4 rad/s (r = 0.25 m -> 1 m/s), no lag, heading +x from x = 0 for
        // 6 s: the robot ends at x = 6 m and the operator's stop point is 1/(2*1.5) = 0.333 m
        // further. Area half-length 10 m, margins 0.5 + 0.1: excursion 6.333 - 9.4 = -3.067 m.
        let space = CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.25,
                baseline_m: 0.5,
            },
            max_wheel_rad_s: 8.0,
            max_lin_m_s: 2.0,
            max_ang_rad_s: 2.0,
            turn_scale: 1.0,
        };
        let mut s = BoundaryAware::new(1);
        s.lag_s = 0.0;
        let c = WheelSpeeds::new(4.0, 4.0);
        let e = s.excursion_m(&space, Pose::default(), c, c, (10.0, 10.0));
        assert!((e - (6.0 + 1.0 / 3.0 - 9.4)).abs() < 1e-9, "{e}");
        // Backwards from x = -3: the robot ends at -9 m, its stop point at -9.333 m: 0.067 m
        // inside the shrunk border at -9.4 m.
        let back = WheelSpeeds::new(-4.0, -4.0);
        let start = Pose {
            x_m: -3.0,
            ..Pose::default()
        };
        let e = s.excursion_m(&space, start, back, back, (10.0, 10.0));
        assert!((e - (9.0 + 1.0 / 3.0 - 9.4)).abs() < 1e-9, "{e}");
    }
}
