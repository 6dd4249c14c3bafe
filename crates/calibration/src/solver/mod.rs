//! Solvers for the calibration score: bounded least squares whose residuals are grouped in
//! channels (each with its noise floor) and clusters (the recorded steps).
//!
//! The score the project reports is the geometric mean over channels of `MSE_c / floor_c²`
//! ([`super::metrics::score`]). Its logarithm, `F(θ) = (1/C) Σ_c ln(S_c(θ) / (n_c floor_c²))`
//! with `S_c` the channel's sum of squared residuals, is what [`lm`] minimises: a Gauss–Newton
//! model of `F` is a weighted least-squares problem with weights `2 / (C S_c)` per channel,
//! recomputed at every iteration (iteratively reweighted least squares), so the fixed point is
//! the minimum of the reported score itself, not of a fixed-weight surrogate. Every channel
//! counts once whatever its number of entries, as in the score (a likelihood weighted by
//! `n_c` would let the 40-sample transient channels outweigh the two steady windows).
//!
//! The problem and the solver are separate, as in argmin: a [`LeastSquares`] problem gives
//! residuals for parameters; [`lm::minimize`] and the derivative-free [`nelder_mead`] (kept for
//! comparison with the first calibration and as a fallback) solve it; [`covariance`] gives the
//! parameters' uncertainty at the solution.

pub mod covariance;
pub mod lm;
pub mod nelder_mead;

use serde::{Deserialize, Serialize};

/// Which channel and which cluster (step) every residual entry belongs to, and each channel's
/// noise floor: fixed for a problem.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Channel of each entry.
    pub channel: Vec<u8>,
    /// Cluster of each entry (entries of a cluster are not independent).
    pub cluster: Vec<u32>,
    /// Noise floor of each channel, in the residuals' unit.
    pub floor: Vec<f64>,
    /// Below this share of its squared floor a channel stops counting as better (its weight
    /// is 0): the score's clamp.
    pub min_ratio: f64,
}

impl Layout {
    /// Number of channels.
    pub fn n_channels(&self) -> usize {
        self.floor.len()
    }

    /// Per channel: sum of squares and count of `r`.
    pub fn channel_sums(&self, r: &[f64]) -> (Vec<f64>, Vec<usize>) {
        let mut s = vec![0.0; self.n_channels()];
        let mut n = vec![0usize; self.n_channels()];
        for (v, &c) in r.iter().zip(&self.channel) {
            s[c as usize] += v * v;
            n[c as usize] += 1;
        }
        (s, n)
    }

    /// The log score `F` of residuals `r` (see the module doc); NaN with no entry at all.
    pub fn log_score(&self, r: &[f64]) -> f64 {
        let (s, n) = self.channel_sums(r);
        let mut sum = 0.0;
        let mut k = 0usize;
        for c in 0..self.n_channels() {
            if n[c] > 0 {
                let ratio = s[c] / n[c] as f64 / self.floor[c].powi(2);
                sum += ratio.max(self.min_ratio).ln();
                k += 1;
            }
        }
        if k == 0 {
            f64::NAN
        } else {
            sum / k as f64
        }
    }

    /// The per-channel weights `2 / (C S_c)` of the Gauss–Newton model of `F` at `r` (0 for a
    /// channel under the clamp or without entries).
    pub fn weights(&self, r: &[f64]) -> Vec<f64> {
        let (s, n) = self.channel_sums(r);
        let used = n.iter().filter(|&&k| k > 0).count().max(1) as f64;
        (0..self.n_channels())
            .map(|c| {
                let ratio = if n[c] > 0 {
                    s[c] / n[c] as f64 / self.floor[c].powi(2)
                } else {
                    0.0
                };
                if n[c] == 0 || ratio <= self.min_ratio || s[c] <= 0.0 {
                    0.0
                } else {
                    2.0 / (used * s[c])
                }
            })
            .collect()
    }
}

/// Gradient and Gauss–Newton Hessian of `½ Σ_i w_c(i) r_i²` with the channel weights `w`
/// frozen (for `w` = [`Layout::weights`], the log score's gradient and its Gauss–Newton model):
/// `g = Σ_i w_c r_i ∇r_i`, `H = Σ_i w_c ∇r_i ∇r_iᵀ`, with `jac` the residuals' Jacobian
/// (entries × parameters). The solver's step and the covariance's bread both use it.
pub fn weighted_normal_equations(
    layout: &Layout,
    w: &[f64],
    r: &[f64],
    jac: &nalgebra::DMatrix<f64>,
) -> (nalgebra::DVector<f64>, nalgebra::DMatrix<f64>) {
    let p = jac.ncols();
    let mut g = nalgebra::DVector::zeros(p);
    let mut h = nalgebra::DMatrix::zeros(p, p);
    for (i, (&ri, &c)) in r.iter().zip(&layout.channel).enumerate() {
        let wi = w[c as usize];
        if wi == 0.0 {
            continue;
        }
        let row = jac.row(i);
        for a in 0..p {
            let ja = row[a];
            if ja == 0.0 {
                continue;
            }
            g[a] += wi * ri * ja;
            for b in a..p {
                h[(a, b)] += wi * ja * row[b];
            }
        }
    }
    for a in 0..p {
        for b in 0..a {
            h[(a, b)] = h[(b, a)];
        }
    }
    (g, h)
}

/// A bounded least-squares problem in the calibration's score.
pub trait LeastSquares: Sync {
    /// Number of parameters.
    fn dim(&self) -> usize;
    /// Box of each parameter.
    fn bounds(&self) -> Vec<(f64, f64)>;
    /// Smallest change of each parameter that makes a difference (finite differences never
    /// step below it); `None`: smooth.
    fn resolution(&self, _j: usize) -> Option<f64> {
        None
    }
    /// Residual vector at `x`; `None` when the model cannot be built or diverges there.
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>>;
    /// The layout of the residual vector.
    fn layout(&self) -> &Layout;
}

/// Why a solver stopped.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// The projected gradient of the log score fell below its tolerance.
    Gradient,
    /// The score stopped falling: several accepted steps in a row each lowered it by less
    /// than its relative tolerance (a flat valley).
    Reduction,
    /// The step fell below its tolerance, or the full Gauss–Newton step below a small
    /// fraction of every parameter's standard error.
    StepSize,
    /// Nelder–Mead's simplex collapsed (its tolerance on the spread of the costs).
    Simplex,
    /// The iteration budget ran out.
    Budget,
    /// No parameter to fit: the model was evaluated as it is.
    NoParameters,
    /// No step lowered the score although the gradient is not small (a flat or
    /// non-smooth cost): the start is kept as the best point found.
    NoProgress,
    /// The model could not be evaluated at the start.
    Failed,
}

impl Stop {
    /// A stop at a (local) minimum rather than on a budget or a failure.
    pub fn converged(&self) -> bool {
        matches!(
            self,
            Self::Gradient | Self::Reduction | Self::StepSize | Self::Simplex | Self::NoParameters
        )
    }

    /// In words, for reports.
    pub fn describe(&self) -> &'static str {
        match self {
            Self::Gradient => "converged: projected gradient below tolerance",
            Self::Reduction => "converged: relative reduction of the score below tolerance",
            Self::StepSize => "converged: step below tolerance (1 % of the standard errors)",
            Self::Simplex => "converged: simplex spread below tolerance",
            Self::Budget => "not converged: iteration budget exhausted",
            Self::NoParameters => "nothing to fit",
            Self::NoProgress => {
                "not converged: no step lowers the score although the gradient is not small (flat or non-smooth cost)"
            }
            Self::Failed => "failed: the model could not be evaluated at the start",
        }
    }
}

/// What a solver reports after each iteration (observers print progress from it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iteration {
    /// Iteration number, from 1.
    pub iteration: usize,
    /// Score (geometric mean of floor-normalised MSE) at the current point.
    pub score: f64,
    /// Model evaluations so far.
    pub evaluations: usize,
    /// Damping (Levenberg–Marquardt) or simplex spread (Nelder–Mead).
    pub damping: f64,
}

/// The end of one solver run.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Best parameters found.
    pub x: Vec<f64>,
    /// Score there (geometric mean, 1 = noise floor).
    pub score: f64,
    /// Score at the start.
    pub initial_score: f64,
    /// Iterations.
    pub iterations: usize,
    /// Model evaluations.
    pub evaluations: usize,
    /// Why it stopped.
    pub stop: Stop,
    /// Residuals at `x` (empty when never evaluated).
    pub residuals: Vec<f64>,
    /// Jacobian of the residuals at `x` (row-major, entries × parameters), when computed.
    pub jacobian: Option<nalgebra::DMatrix<f64>>,
}
