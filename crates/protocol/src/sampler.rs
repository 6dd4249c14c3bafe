//! Sampling strategies: how the next DRIVE command is drawn from the command space U.
//!
//! A strategy implements [`Sampler`]; it owns a generator seeded by the run's seed so that the
//! same seed gives the same sequence of commands. The strategies themselves live one per file in
//! [`crate::samplers`], which also holds the registry that [`make_sampler`] and
//! [`SAMPLERS`] read.

use drive_sim_model::error::Result;
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace, WheelSpeeds};
use drive_sim_model::measurement::Pose;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

pub use super::samplers::uniform_wheel::UniformWheel;
use super::samplers::REGISTRY;
use super::ProtocolConfig;

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
    /// Draws the next command; it must be finite and lie in `ctx.space`. An error stops the
    /// run ([`crate::run_drive`] reports it as [`Error::Sampler`](drive_sim_model::Error::Sampler) naming the step, as it does a
    /// command that is not finite or lies outside U). The built-in strategies never fail; a
    /// strategy that calls out (to Python, to a planner) may.
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds>;
}

/// Draws a command uniformly in U, in the wheel frame, by rejection from the wheel-limit square.
pub fn uniform_in_wheel_space(space: &CommandSpace, rng: &mut ChaCha8Rng) -> WheelSpeeds {
    let w = space.wheel_bound_rad_s();
    // U has at least the area of the inscribed square of the user limits: rejection ends quickly.
    loop {
        let c = WheelSpeeds::new(rng.random_range(-w..=w), rng.random_range(-w..=w));
        if space.contains_wheels(c) {
            return c;
        }
    }
}

const N_SAMPLERS: usize = REGISTRY.len();
const SAMPLER_NAMES: [&str; N_SAMPLERS] = {
    let mut names = [""; N_SAMPLERS];
    let mut i = 0;
    while i < N_SAMPLERS {
        names[i] = REGISTRY[i].name;
        i += 1;
    }
    names
};

/// Names of the samplers [`make_sampler`] knows, in registry order.
pub const SAMPLERS: &[&str] = &SAMPLER_NAMES;

/// Builds a sampler by name, seeded with `seed`, with its default parameters, for a run with
/// the default protocol parameters.
pub fn make_sampler(name: &str, seed: u64) -> Option<Box<dyn Sampler>> {
    make_sampler_for(name, seed, &ProtocolConfig::default())
}

/// Builds a sampler by name, seeded with `seed`, for a run with the protocol parameters
/// `protocol` (step duration, operator margins: what `boundary-aware` predicts with).
pub fn make_sampler_for(name: &str, seed: u64, protocol: &ProtocolConfig) -> Option<Box<dyn Sampler>> {
    REGISTRY
        .iter()
        .find(|e| e.name == name)
        .map(|e| (e.build)(seed, protocol))
}
