//! `spread-accel`: spreads the accelerations over their whole range.
//!
//! Keeps histograms of the linear and angular speed steps |Δvx|, |Δwz| of the completed steps
//! (from `ctx.history`, body frame, each over [0, twice the largest |vx| or |wz| of U]); among
//! `candidates` uniform draws in U it picks the one whose two bins hold the fewest steps
//! (sum of the two counts; ties go to the earlier candidate, i.e. at random). Under-covered
//! accelerations, typically the large ones that uniform sampling rarely produces, are filled
//! first. The first candidate wins while all bins are equal, so the first command is uniform.

use super::geometry::body_bounds;
use super::SamplerEntry;
use crate::sampler::{uniform_in_wheel_space, Sampler, SamplingContext};
use drive_sim_model::kinematics::{CommandSpace, WheelSpeeds};
use drive_sim_model::Result;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "spread-accel",
    summary: "among uniform candidates, the one whose |dvx|, |dwz| bins are least populated",
    build: |seed, _protocol| Box::new(SpreadAccel::new(seed)),
};

/// Picks, among uniform candidates, the step whose acceleration bins are least populated.
#[derive(Debug, Clone)]
pub struct SpreadAccel {
    rng: ChaCha8Rng,
    /// Uniform candidates drawn per command.
    pub candidates: usize,
    /// Bins of each of the |Δvx| and |Δwz| histograms.
    pub bins: usize,
}

impl SpreadAccel {
    /// Default parameters (8 candidates, 10 bins), seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            candidates: 8,
            bins: 10,
        }
    }
}

/// Bin indices of the body-frame step from `from` to `to`: (|Δvx| bin, |Δwz| bin).
fn step_bins(space: &CommandSpace, bins: usize, from: WheelSpeeds, to: WheelSpeeds) -> (usize, usize) {
    let (vm, wm) = body_bounds(space);
    let a = space.idd.body_from_wheels(from);
    let b = space.idd.body_from_wheels(to);
    let bin = |d: f64, range: f64| ((d.abs() / range * bins as f64) as usize).min(bins - 1);
    (
        bin(b.vx_m_s - a.vx_m_s, 2.0 * vm),
        bin(b.wz_rad_s - a.wz_rad_s, 2.0 * wm),
    )
}

impl Sampler for SpreadAccel {
    fn name(&self) -> &str {
        ENTRY.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        Ok(self.draw(ctx))
    }
}

impl SpreadAccel {
    /// The next command of this strategy: it cannot fail.
    fn draw(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        let bins = self.bins.max(1);
        let mut lin = vec![0u32; bins];
        let mut ang = vec![0u32; bins];
        let mut prev = WheelSpeeds::default();
        for o in ctx.history {
            let (i, j) = step_bins(ctx.space, bins, prev, o.cmd);
            lin[i] += 1;
            ang[j] += 1;
            prev = o.cmd;
        }
        let mut best: Option<(u32, WheelSpeeds)> = None;
        for _ in 0..self.candidates.max(1) {
            let c = uniform_in_wheel_space(ctx.space, &mut self.rng);
            let (i, j) = step_bins(ctx.space, bins, ctx.previous, c);
            let score = lin[i] + ang[j];
            if best.is_none_or(|(s, _)| score < s) {
                best = Some((score, c));
            }
        }
        best.map(|(_, c)| c).unwrap_or_default()
    }
}
