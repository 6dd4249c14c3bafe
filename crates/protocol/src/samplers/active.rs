//! `active`: samples where the slip transfer-function estimate is most uncertain.
//!
//! The transfer function is the paper's Gaussian kernel smoother of the slip g = u − x (body
//! frame) over U. At a candidate command u, with kernel weights `k_i = exp(−½ |z(u_i) − z(u)|² /
//! σ²)` of the completed steps (z: command normalized to (vx / vx_max, wz / wz_max)) and slips
//! normalized the same way, the criterion is the variance of the smoothed mean under a weak
//! prior (n0 pseudo-observations of variance v0):
//!
//! `score(u) = v(u) / (n0 + Σ k_i)`, with `v(u) = (n0 v0 + Σ k_i |g_i − ḡ(u)|²) / (n0 + Σ k_i)`
//!
//! — large where few steps are near (small kernel mass Σ k_i, the effective sample count) and
//! where nearby slips disagree (high local variance). Among `candidates` uniform draws the one
//! with the highest score is chosen; with no history all scores are equal and the first (a
//! uniform draw) is taken.

use super::geometry::body_bounds;
use super::SamplerEntry;
use crate::sampler::{uniform_in_wheel_space, Sampler, SamplingContext, StepOutcome};
use drive_sim_model::kinematics::{CommandSpace, WheelSpeeds};
use drive_sim_model::Result;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Registry entry.
pub const ENTRY: SamplerEntry = SamplerEntry {
    name: "active",
    summary: "among uniform candidates, the one where the slip kernel smoother is most uncertain",
    build: |seed, _protocol| Box::new(Active::new(seed)),
};

/// Uncertainty sampling over the kernel-smoother estimate of slip.
#[derive(Debug, Clone)]
pub struct Active {
    rng: ChaCha8Rng,
    /// Uniform candidates drawn per command.
    pub candidates: usize,
    /// Kernel standard deviation in normalized command units (1 = the largest |vx| or |wz|).
    pub bandwidth: f64,
    /// Prior pseudo-observations n0.
    pub prior_count: f64,
    /// Prior variance v0 of the normalized slip (sum over the three components).
    pub prior_variance: f64,
}

impl Active {
    /// Default parameters (16 candidates, σ = 0.15, n0 = 1, v0 = 0.01), seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            candidates: 16,
            bandwidth: 0.15,
            prior_count: 1.0,
            prior_variance: 0.01,
        }
    }

    /// The uncertainty criterion at command `u` given the completed steps (see module docs).
    pub fn score(&self, space: &CommandSpace, history: &[StepOutcome], u: WheelSpeeds) -> f64 {
        let (vm, wm) = body_bounds(space);
        let z = |w: WheelSpeeds| {
            let b = space.idd.body_from_wheels(w);
            (b.vx_m_s / vm, b.wz_rad_s / wm)
        };
        let zu = z(u);
        let bw = self.bandwidth.max(1e-9);
        let inv2s2 = 0.5 / (bw * bw);
        let (mut s0, mut s1, mut s2) = (0.0, [0.0; 3], 0.0);
        for o in history {
            let zi = z(o.cmd);
            let k = (-((zi.0 - zu.0).powi(2) + (zi.1 - zu.1).powi(2)) * inv2s2).exp();
            let c = space.idd.body_from_wheels(o.cmd);
            let x = o.steady_velocity;
            let g = [
                (c.vx_m_s - x.vx_m_s) / vm,
                (c.vy_m_s - x.vy_m_s) / vm,
                (c.wz_rad_s - x.wz_rad_s) / wm,
            ];
            if !g.iter().all(|v| v.is_finite()) {
                continue;
            }
            s0 += k;
            for d in 0..3 {
                s1[d] += k * g[d];
            }
            s2 += k * g.iter().map(|v| v * v).sum::<f64>();
        }
        // Σ k |g − ḡ|² = Σ k |g|² − |Σ k g|² / Σ k, clamped against rounding.
        let spread = if s0 > 0.0 {
            (s2 - s1.iter().map(|v| v * v).sum::<f64>() / s0).max(0.0)
        } else {
            0.0
        };
        let n = self.prior_count + s0;
        let v = (self.prior_count * self.prior_variance + spread) / n;
        v / n
    }
}

impl Sampler for Active {
    fn name(&self) -> &str {
        ENTRY.name
    }
    fn next(&mut self, ctx: &SamplingContext<'_>) -> Result<WheelSpeeds> {
        Ok(self.draw(ctx))
    }
}

impl Active {
    /// The next command of this strategy: it cannot fail.
    fn draw(&mut self, ctx: &SamplingContext<'_>) -> WheelSpeeds {
        let mut best: Option<(f64, WheelSpeeds)> = None;
        for _ in 0..self.candidates.max(1) {
            let c = uniform_in_wheel_space(ctx.space, &mut self.rng);
            let s = self.score(ctx.space, ctx.history, c);
            if best.is_none_or(|(b, _)| s > b) {
                best = Some((s, c));
            }
        }
        best.map(|(_, c)| c).unwrap_or_default()
    }
}
