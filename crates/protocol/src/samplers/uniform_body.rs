//! `uniform-body`: uniform in the body-frame command space (vx, wz).
//!
//! The map W -> B is linear, so a uniform density in one frame is uniform in the other: this
//! strategy gives the same distribution of commands as `uniform-wheel`, from a different stream
//! of draws. It exists so that a user who thinks in (vx, wz) can check that, and as the base of
//! strategies that work in B.

use super::geometry::body_bounds;
use super::SamplerEntry;
use crate::sampler::{Sampler, SamplingContext};
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim_model::Result;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "uniform-body",
    summary: "uniform in the body-frame command space (vx, wz), independent draws",
    build: |seed, _protocol| Box::new(UniformBody::new(seed)),
};

/// Uniform in (vx, wz) over U, by rejection from the bounding rectangle of U in B.
#[derive(Debug, Clone)]
pub struct UniformBody {
    rng: ChaCha8Rng,
}

impl UniformBody {
    /// A sampler seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }
}

impl Sampler for UniformBody {
    fn name(&self) -> &str {
        ENTRY.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        Ok(self.draw(ctx))
    }
}

impl UniformBody {
    /// The next command of this strategy: it cannot fail.
    fn draw(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        let (vm, wm) = body_bounds(ctx.space);
        loop {
            let v = BodyVelocity::new(
                self.rng.random_range(-vm..=vm),
                0.0,
                self.rng.random_range(-wm..=wm),
            );
            // Membership is tested on the wheel command returned, so what is returned is in U.
            let w = ctx.space.idd.wheels_from_body(v);
            if ctx.space.contains_wheels(w) {
                return w;
            }
        }
    }
}
