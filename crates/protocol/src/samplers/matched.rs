//! `Matched`: uniform draws in U, each in the quadrant of a real run's command of that step.
//!
//! Not a strategy one picks by name (it needs a run's commands besides a seed). The paper's
//! statistics are medians over a run's steps, and a skid-steering robot's slips change sign
//! with the command's quadrant (forward or backward, turning left or right): the median yaw
//! slip of a run is the left turns' or the right turns', whichever the sampler drew more of.
//! Uniform draws give 50 left turns in 100 give or take 5; `warthog_asphalt`'s 98 analysed
//! steps hold 36 (a fair coin's two-sided p 0.011, `drive-sim analyze` prints it), so a twin's
//! own DRIVE, drawing about half, has another median.
//! Which quadrant a step drew is the sampler's luck, not the robot's (DRIVE draws without
//! looking at the robot): a twin judged against a run draws as the run did, quadrant by
//! quadrant, and uniformly inside each, so that its runs keep the spread of the draws inside
//! the quadrants.

use crate::sampler::{uniform_in_wheel_space, Sampler, SamplingContext};
use drive_sim_model::kinematics::{Quadrant, WheelSpeeds};
use drive_sim_model::{Error, Result};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The name a run drawn this way records as its sampler.
pub const NAME: &str = "matched-quadrants";

/// Step `i` draws uniformly in U among the commands of quadrant `quadrants[i % len]` (a run
/// longer than them starts them again).
#[derive(Debug, Clone)]
pub struct Matched {
    quadrants: Vec<Quadrant>,
    rng: ChaCha8Rng,
}

impl Matched {
    /// Draws in the quadrants of `commands`, seeded with `seed`; no command is bad input.
    pub fn new(commands: &[WheelSpeeds], seed: u64) -> Result<Self> {
        if commands.is_empty() {
            return Err(Error::config(
                "<commands>",
                "commands",
                "no command to draw as".to_string(),
            ));
        }
        Ok(Self {
            quadrants: commands.iter().map(|c| c.quadrant()).collect(),
            rng: ChaCha8Rng::seed_from_u64(seed),
        })
    }
}

impl Sampler for Matched {
    fn name(&self) -> &str {
        NAME
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        let q = self.quadrants[ctx.step as usize % self.quadrants.len()];
        // U is symmetric under negation and under swapping the sides: each quadrant holds a
        // quarter of it, and rejection ends after four draws on average.
        loop {
            let c = uniform_in_wheel_space(ctx.space, &mut self.rng);
            if c.quadrant() == q {
                return Ok(c);
            }
        }
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

    fn ctx(space: &CommandSpace, step: u32) -> SamplingContext<'_> {
        SamplingContext {
            space,
            step,
            previous: WheelSpeeds::default(),
            history: &[],
            pose: Pose::default(),
            safe_half_extents_m: (22.5, 10.0),
        }
    }

    #[test]
    fn each_step_draws_in_its_commands_quadrant_uniformly_inside_it() {
        let s = space();
        let real = [
            WheelSpeeds::new(1.0, 2.0),   // forward, left
            WheelSpeeds::new(2.0, 1.0),   // forward, right
            WheelSpeeds::new(-1.0, -2.0), // backward, right
            WheelSpeeds::new(-2.0, -1.0), // backward, left
        ];
        let mut m = Matched::new(&real, 7).unwrap();
        let n = 4000;
        let draws: Vec<WheelSpeeds> = (0..n).map(|i| m.next(&ctx(&s, i)).unwrap()).collect();
        for (i, c) in draws.iter().enumerate() {
            assert!(s.contains_wheels(*c));
            assert_eq!(c.quadrant(), real[i % 4].quadrant(), "step {i}: {c:?}");
        }
        // Uniform inside the quadrant: the forward-left draws share the law of uniform draws
        // in U that fell there (here the share with the left wheel backwards, which the
        // yaw-rate limit clips more than the share with it forwards).
        let share = |cs: &[WheelSpeeds]| {
            let fl: Vec<&WheelSpeeds> = cs.iter().filter(|c| c.quadrant() == real[0].quadrant()).collect();
            fl.iter().filter(|c| c.left_rad_s < 0.0).count() as f64 / fl.len() as f64
        };
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let free: Vec<WheelSpeeds> = (0..40_000)
            .map(|_| uniform_in_wheel_space(&s, &mut rng))
            .collect();
        let (matched, uniform) = (share(&draws), share(&free));
        assert!((matched - uniform).abs() < 0.04, "{matched} against {uniform}");
        assert!(uniform < 0.4, "the clipped side is the smaller: {uniform}");
        // The same seed, the same draws.
        let mut again = Matched::new(&real, 7).unwrap();
        assert!(draws
            .iter()
            .enumerate()
            .all(|(i, c)| again.next(&ctx(&s, i as u32)).unwrap() == *c));
        assert!(Matched::new(&[], 1).is_err());
    }
}
