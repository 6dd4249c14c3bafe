//! `uniform-wheel`: the paper's strategy.

use super::SamplerEntry;
use crate::sampler::{uniform_in_wheel_space, Sampler, SamplingContext};
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::Result;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "uniform-wheel",
    summary: "uniform in the wheel-frame command space, independent draws (the paper's)",
    build: |seed, _protocol| Box::new(UniformWheel::new(seed)),
};

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
        ENTRY.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        Ok(self.draw(ctx))
    }
}

impl UniformWheel {
    /// The next command of this strategy: it cannot fail.
    pub(crate) fn draw(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        uniform_in_wheel_space(ctx.space, &mut self.rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::CommandSpace;
    use drive_sim_model::measurement::Pose;

    fn space() -> CommandSpace {
        super::super::warthog_space()
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
        let draws: Vec<WheelSpeeds> = (0..n).map(|_| a.draw(&ctx)).collect();
        assert!(draws.iter().all(|c| s.contains_wheels(*c)));
        assert!(draws
            .iter()
            .zip((0..n).map(|_| b.draw(&ctx)))
            .all(|(x, y)| *x == y));
        // Uniform in W: the share of draws with wl > 0 is 1/2 by symmetry of U, and the share
        // inside the inner square |w| < w_max/2 is its area in U over the area of U in W.
        let pos = draws.iter().filter(|c| c.left_rad_s > 0.0).count() as f64 / n as f64;
        assert!((pos - 0.5).abs() < 0.02, "{pos}");
        let h = s.max_wheel_rad_s / 2.0;
        let inner = draws
            .iter()
            .filter(|c| c.left_rad_s.abs() < h && c.right_rad_s.abs() < h)
            .count() as f64
            / n as f64;
        // The inner square crosses |wz| = 4 at its corners: its area in U comes from clipping.
        let inner_u = {
            let mut c = s;
            c.max_wheel_rad_s = h;
            c.area_wheels()
        };
        let expected = inner_u / s.area_wheels();
        assert!((inner - expected).abs() < 0.02, "{inner} vs {expected}");
    }
}
