//! Fitting model parameters to a recording: a deterministic train/held-out split of the steps,
//! a cost that replays the training steps in parallel and scores them against the noise floor,
//! and argmin's Nelder-Mead over the parameters scaled to their search box.

use super::metrics::{score, step_errors, step_features, NoiseFloor, StepErrors, StepFeatures};
use super::model::{ModelParams, ParamSpec, PlantFactory};
use super::replay::{replay_step, StepSlice};
use crate::error::{Error, Result};
use argmin::core::{CostFunction, Executor, State, TerminationReason};
use argmin::solver::neldermead::NelderMead;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// Cost of a model that cannot be built or diverges: worse than any real score.
const INVALID_COST: f64 = 1e9;

/// Splits step indices into (training, held-out): a seeded shuffle, then the first
/// `round(train_fraction * n)` steps train (at least one of each when n >= 2). Both sorted.
pub fn split_steps(steps: &[u32], train_fraction: f64, seed: u64) -> (Vec<u32>, Vec<u32>) {
    let mut s = steps.to_vec();
    s.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let n = s.len();
    let mut k = (train_fraction.clamp(0.0, 1.0) * n as f64).round() as usize;
    if n >= 2 {
        k = k.clamp(1, n - 1);
    }
    let mut test = s.split_off(k.min(n));
    s.sort_unstable();
    test.sort_unstable();
    (s, test)
}

/// Recorded steps with their measured features: what a model is scored on.
#[derive(Debug, Clone)]
pub struct StepSet<'a> {
    /// The recorded steps.
    pub steps: Vec<StepSlice<'a>>,
    /// Their features.
    pub features: Vec<StepFeatures>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
}

impl<'a> StepSet<'a> {
    /// Selects `which` steps of `all` (in that order).
    pub fn new(all: &[StepSlice<'a>], which: &[u32], rate_hz: f64) -> Result<Self> {
        let steps: Vec<StepSlice<'a>> = which
            .iter()
            .map(|w| {
                all.iter()
                    .find(|s| s.step == *w)
                    .copied()
                    .ok_or_else(|| Error::Analysis(format!("step {w} is not in the log")))
            })
            .collect::<Result<_>>()?;
        let features = steps
            .iter()
            .map(|s| step_features(s.step, s.samples))
            .collect::<Result<_>>()?;
        Ok(Self {
            steps,
            features,
            rate_hz,
        })
    }

    /// Replays every step (in parallel) on the model and compares it with the recording.
    pub fn errors(&self, factory: &dyn PlantFactory, params: &ModelParams) -> Result<Vec<StepErrors>> {
        self.steps
            .par_iter()
            .zip(self.features.par_iter())
            .map(|(s, meas)| {
                let mut plant = factory.build(params)?;
                let sim = replay_step(plant.as_mut(), *s, self.rate_hz)?;
                step_errors(&step_features(s.step, &sim)?, meas)
            })
            .collect()
    }

    /// Score of a model on these steps ([`super::metrics::score`]).
    pub fn score(&self, factory: &dyn PlantFactory, params: &ModelParams, floor: &NoiseFloor) -> Result<f64> {
        let e = self.errors(factory, params)?;
        Ok(score(&e, floor))
    }
}

/// Optimizer budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitOptions {
    /// Nelder-Mead iterations at most (each costs one to n+2 replays of the training set).
    pub max_iters: u64,
    /// Converged when the standard deviation of the simplex costs falls below this.
    pub sd_tolerance: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            max_iters: 60,
            sd_tolerance: 1e-3,
        }
    }
}

/// A parameter's value before and after a fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedParam {
    /// Dotted name.
    pub name: String,
    /// Value before the fit (`None`: an effect that was off).
    pub initial: Option<f64>,
    /// Fitted value.
    pub value: f64,
    /// Search box.
    pub lower: f64,
    /// Search box.
    pub upper: f64,
    /// The fit ended on the box boundary (the true value may lie beyond it).
    pub at_bound: bool,
}

impl FittedParam {
    /// `value` of the parameter `spec` describes; on its bound when a continuous value lies in
    /// the outer half percent of the box.
    pub fn of(spec: &ParamSpec, initial: Option<f64>, value: f64) -> Self {
        let c = (value - spec.lower) / (spec.upper - spec.lower);
        Self {
            name: spec.name.clone(),
            initial,
            value,
            lower: spec.lower,
            upper: spec.upper,
            at_bound: !spec.discrete && !(0.005..=0.995).contains(&c),
        }
    }
}

/// Outcome of one optimization.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitResult {
    /// Fitted parameters.
    pub params: Vec<FittedParam>,
    /// Training score before the fit.
    pub initial_score: f64,
    /// Training score at the fitted values.
    pub score: f64,
    /// Cost evaluations (each one replay of the training set).
    pub evaluations: u64,
    /// The optimizer met its tolerance (false: budget exhausted, or failure, see `status`).
    pub converged: bool,
    /// Why it stopped, in words.
    pub status: String,
}

struct Problem<'a, 'b> {
    data: &'b StepSet<'a>,
    factory: &'b dyn PlantFactory,
    base: &'b ModelParams,
    specs: Vec<&'b ParamSpec>,
    fixed: Vec<(&'b ParamSpec, f64)>,
    floor: &'b NoiseFloor,
    evals: AtomicU64,
}

impl Problem<'_, '_> {
    /// Model at normalized coordinates `x` (clamped to the box), and the squared distance
    /// outside the box (a penalty keeps the simplex inside).
    fn model(&self, x: &[f64]) -> Result<(ModelParams, f64)> {
        let mut p = self.base.clone();
        let mut outside = 0.0;
        for (spec, xi) in self.specs.iter().zip(x) {
            let c = xi.clamp(0.0, 1.0);
            outside += (xi - c).powi(2);
            p.set(&spec.name, spec.lower + c * (spec.upper - spec.lower))?;
        }
        for (spec, v) in &self.fixed {
            p.set(&spec.name, *v)?;
        }
        Ok((p, outside))
    }

    fn eval(&self, x: &[f64]) -> f64 {
        self.evals.fetch_add(1, Ordering::Relaxed);
        match self.model(x) {
            Ok((p, outside)) => match self.data.score(self.factory, &p, self.floor) {
                Ok(s) if s.is_finite() => s * (1.0 + 100.0 * outside),
                _ => INVALID_COST,
            },
            Err(_) => INVALID_COST,
        }
    }
}

impl CostFunction for &Problem<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.eval(x))
    }
}

fn start_value(base: &ModelParams, spec: &ParamSpec) -> f64 {
    match base.get(&spec.name) {
        Ok(Some(v)) if v >= spec.lower && v <= spec.upper => v,
        _ => spec.start.unwrap_or((spec.lower + spec.upper) / 2.0),
    }
}

/// One Nelder-Mead run from `x0` with a simplex of side `step` (normalized units): the best
/// cost and point, and why it stopped if not by convergence. An optimizer failure keeps `x0`.
fn nelder_mead(
    problem: &Problem<'_, '_>,
    x0: &[f64],
    step: f64,
    opts: &FitOptions,
) -> Result<(f64, Vec<f64>, Option<String>)> {
    let mut simplex = vec![x0.to_vec()];
    for i in 0..x0.len() {
        let mut v = x0.to_vec();
        v[i] += if v[i] + step <= 1.0 { step } else { -step };
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(opts.sd_tolerance)
        .map_err(|e| Error::Analysis(format!("optimizer setup: {e}")))?;
    let run = Executor::new(problem, solver)
        .configure(|s| s.max_iters(opts.max_iters))
        .run();
    Ok(match run {
        Ok(res) => {
            let st = res.state();
            let stop = match st.get_termination_reason() {
                Some(TerminationReason::SolverConverged) => None,
                Some(r) => Some(format!("Nelder-Mead stopped: {}", r.text())),
                None => Some("Nelder-Mead stopped without a reason".to_string()),
            };
            let x = st.get_best_param().cloned().unwrap_or_else(|| x0.to_vec());
            (st.get_best_cost(), x, stop)
        }
        Err(e) => (
            problem.eval(x0),
            x0.to_vec(),
            Some(format!("Nelder-Mead failed: {e}; kept the start values")),
        ),
    })
}

/// Fits `specs` on the steps of `data`, starting from `base` (current values, or each spec's
/// start for an absent effect). Discrete parameters are enumerated at both bounds; continuous
/// ones go to Nelder-Mead, restarted once with a smaller simplex after it converges. Returns the best model found and what happened; a failed or
/// unconverged optimization is reported in [`FitResult`], not as an error.
pub fn fit(
    data: &StepSet<'_>,
    factory: &dyn PlantFactory,
    base: &ModelParams,
    specs: &[ParamSpec],
    floor: &NoiseFloor,
    opts: &FitOptions,
) -> Result<(ModelParams, FitResult)> {
    let initial_score = data.score(factory, base, floor)?;
    let (discrete, continuous): (Vec<&ParamSpec>, Vec<&ParamSpec>) = specs.iter().partition(|s| s.discrete);
    // (cost, continuous coordinates, discrete values) of the best combination so far.
    type Best<'s> = (f64, Vec<f64>, Vec<(&'s ParamSpec, f64)>);
    let mut best: Option<Best<'_>> = None;
    let mut evaluations = 0;
    let mut converged = true;
    let mut status = Vec::new();
    for combo in 0..(1u32 << discrete.len()) {
        let fixed: Vec<(&ParamSpec, f64)> = discrete
            .iter()
            .enumerate()
            .map(|(i, s)| (*s, if combo >> i & 1 == 1 { s.upper } else { s.lower }))
            .collect();
        let problem = Problem {
            data,
            factory,
            base,
            specs: continuous.clone(),
            fixed: fixed.clone(),
            floor,
            evals: AtomicU64::new(0),
        };
        let x0: Vec<f64> = continuous
            .iter()
            .map(|s| (start_value(base, s) - s.lower) / (s.upper - s.lower))
            .collect();
        let (cost, x) = if continuous.is_empty() {
            (problem.eval(&[]), Vec::new())
        } else {
            let first = nelder_mead(&problem, &x0, 0.2, opts)?;
            // A simplex can collapse before the minimum (a valley across its axes): restart
            // once, smaller, from where it stopped, and keep the better end. Only after a
            // converged run: a run that used its budget has nothing left to confirm with.
            let (cost, x, stop) = match first {
                (c, x, None) => {
                    let half = FitOptions {
                        max_iters: (opts.max_iters / 2).max(1),
                        ..opts.clone()
                    };
                    let second = nelder_mead(&problem, &x, 0.05, &half)?;
                    if second.0 < c {
                        second
                    } else {
                        (c, x, None)
                    }
                }
                other => other,
            };
            if let Some(why) = stop {
                converged = false;
                status.push(why);
            }
            (cost, x)
        };
        evaluations += problem.evals.load(Ordering::Relaxed);
        if best.as_ref().is_none_or(|b| cost < b.0) {
            best = Some((cost, x, fixed));
        }
    }
    let (cost, x, fixed) = best.ok_or_else(|| Error::Analysis("nothing to fit".into()))?;
    let mut model = base.clone();
    let mut params = Vec::new();
    let values = continuous
        .iter()
        .zip(&x)
        .map(|(spec, xi)| (*spec, spec.lower + xi.clamp(0.0, 1.0) * (spec.upper - spec.lower)))
        .chain(fixed);
    for (spec, value) in values {
        model.set(&spec.name, value)?;
        params.push(FittedParam::of(spec, base.get(&spec.name)?, value));
    }
    if cost >= INVALID_COST {
        converged = false;
        status.push("every evaluated model failed to build or diverged".into());
    }
    if converged {
        status.push("converged".into());
    }
    Ok((
        model,
        FitResult {
            params,
            initial_score,
            score: cost,
            evaluations,
            converged,
            status: status.join("; "),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_is_deterministic_disjoint_and_complete() {
        let steps: Vec<u32> = (0..100).collect();
        let (a, b) = split_steps(&steps, 0.7, 3);
        assert_eq!((a.len(), b.len()), (70, 30));
        assert_eq!(split_steps(&steps, 0.7, 3), (a.clone(), b.clone()));
        assert_ne!(split_steps(&steps, 0.7, 4).0, a);
        let mut all: Vec<u32> = a.iter().chain(&b).copied().collect();
        all.sort_unstable();
        assert_eq!(all, steps);
        // Tiny sets still get one step on each side.
        let (a, b) = split_steps(&[5, 9], 0.99, 0);
        assert_eq!((a.len(), b.len()), (1, 1));
    }
}
