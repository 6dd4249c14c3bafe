//! Sampling strategies: how the next DRIVE command is drawn from the command space U.
//!
//! A strategy implements [`Sampler`]; it owns a generator seeded by the run's seed so that the
//! same seed gives the same sequence of commands.

use crate::kinematics::{BodyVelocity, CommandSpace, WheelSpeeds};
use crate::log::Pose;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What a sampler may look at when it draws the next command.
#[derive(Debug, Clone, Copy)]
pub struct SamplingContext<'a> {
    /// The command space U.
    pub space: &'a CommandSpace,
    /// Index of the step the command is for.
    pub step: u32,
    /// The previous command (zero before the first step).
    pub previous: WheelSpeeds,
    /// Completed steps so far: command and the steady-state velocity it produced.
    pub history: &'a [StepOutcome],
    /// Robot pose in the world frame, and the safe area half extents (x, y), m.
    pub pose: Pose,
    /// Half extents of the safe area along world x and y, m.
    pub safe_half_extents_m: (f64, f64),
}

/// The outcome of a completed step, fed back to samplers that adapt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOutcome {
    /// The command held during the step.
    pub cmd: WheelSpeeds,
    /// Mean body velocity over the steady windows (the robot's own state estimate).
    pub steady_velocity: BodyVelocity,
}

/// A strategy to draw DRIVE commands.
pub trait Sampler {
    /// Short name used on the command line and in reports.
    fn name(&self) -> &str;
    /// Draws the next command; it must lie in `ctx.space`.
    fn next(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds;
}

/// Draws a command uniformly in U, in the wheel frame, by rejection from the wheel-limit square.
pub fn uniform_in_wheel_space(space: &CommandSpace, rng: &mut ChaCha8Rng) -> WheelSpeeds {
    let w = space.max_wheel_rad_s;
    // U has at least the area of the inscribed square of the user limits: rejection ends quickly.
    loop {
        let c = WheelSpeeds::new(rng.random_range(-w..=w), rng.random_range(-w..=w));
        if space.contains_wheels(c) {
            return c;
        }
    }
}

/// The paper's strategy: each command uniform in the wheel-frame command space, independent of
/// the previous ones.
#[derive(Debug, Clone)]
pub struct UniformWheel {
    rng: ChaCha8Rng,
}

impl UniformWheel {
    /// A sampler seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }
}

impl Sampler for UniformWheel {
    fn name(&self) -> &str {
        "uniform-wheel"
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        uniform_in_wheel_space(ctx.space, &mut self.rng)
    }
}

/// Names of the samplers [`make_sampler`] knows.
pub const SAMPLERS: &[&str] = &["uniform-wheel"];

/// Builds a sampler by name, seeded with `seed`.
pub fn make_sampler(name: &str, seed: u64) -> Option<Box<dyn Sampler>> {
    match name {
        "uniform-wheel" => Some(Box::new(UniformWheel::new(seed))),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::IdealDiffDrive;

    fn space() -> CommandSpace {
        CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.3,
                baseline_m: 1.08,
            },
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
        }
    }

    #[test]
    fn uniform_wheel_fills_u_uniformly_and_repeats_with_the_seed() {
        let s = space();
        let ctx = SamplingContext {
            space: &s,
            step: 0,
            previous: WheelSpeeds::default(),
            history: &[],
            pose: Pose::default(),
            safe_half_extents_m: (22.5, 10.0),
        };
        let mut a = UniformWheel::new(3);
        let mut b = UniformWheel::new(3);
        let n = 20_000;
        let draws: Vec<WheelSpeeds> = (0..n).map(|_| a.next(&ctx)).collect();
        assert!(draws.iter().all(|c| s.contains_wheels(*c)));
        assert!(draws
            .iter()
            .zip((0..n).map(|_| b.next(&ctx)))
            .all(|(x, y)| *x == y));
        // Uniform in W: the share of draws with wl > 0 is 1/2 by symmetry of U, and the share
        // inside the inner square |w| < w_max/2 is its area over the area of U in W.
        let pos = draws.iter().filter(|c| c.left_rad_s > 0.0).count() as f64 / n as f64;
        assert!((pos - 0.5).abs() < 0.02, "{pos}");
        let h = s.max_wheel_rad_s / 2.0;
        let inner = draws
            .iter()
            .filter(|c| c.left_rad_s.abs() < h && c.right_rad_s.abs() < h)
            .count() as f64
            / n as f64;
        // The inner square lies wholly in U: |vx| <= 0.3*h = 2.5, |wz| <= 0.3*2h/1.08 = 4.63 > 4?
        // No: it crosses |wz| = 4 at its corners; compute its area in U by clipping.
        let inner_u = {
            let mut c = s;
            c.max_wheel_rad_s = h;
            c.area_wheels()
        };
        let expected = inner_u / s.area_wheels();
        assert!((inner - expected).abs() < 0.02, "{inner} vs {expected}");
    }
}
