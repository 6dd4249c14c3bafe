//! Derivative-free search (argmin's Nelder–Mead) on the same score, in the unit box: the
//! optimizer of the first calibration, kept to compare with (`--optimizer nelder-mead`) and
//! for costs that are not smooth.

use super::{Iteration, LeastSquares, Solution, Stop};
use argmin::core::{CostFunction, Executor, State, TerminationReason};
use argmin::solver::neldermead::NelderMead;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Budget of a Nelder–Mead run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NmOptions {
    /// Most iterations.
    pub max_iters: u64,
    /// Converged when the standard deviation of the simplex costs falls below this.
    pub sd_tolerance: f64,
}

impl Default for NmOptions {
    fn default() -> Self {
        Self {
            max_iters: 60,
            sd_tolerance: 1e-3,
        }
    }
}

/// Cost of a model that cannot be built or diverges: worse than any real score.
const INVALID_COST: f64 = 1e9;

struct Cost<'p> {
    problem: &'p dyn LeastSquares,
    lo: Vec<f64>,
    width: Vec<f64>,
    evals: AtomicUsize,
}

impl Cost<'_> {
    fn eval(&self, z: &[f64]) -> f64 {
        self.evals.fetch_add(1, Ordering::Relaxed);
        let mut outside = 0.0;
        let x: Vec<f64> = z
            .iter()
            .zip(self.lo.iter().zip(&self.width))
            .map(|(z, (l, w))| {
                let c = z.clamp(0.0, 1.0);
                outside += (z - c).powi(2);
                l + c * w
            })
            .collect();
        match self.problem.residuals(&x) {
            Some(r) if r.len() == self.problem.layout().channel.len() => {
                let f = self.problem.layout().log_score(&r).exp();
                if f.is_finite() {
                    // A penalty keeps the simplex inside the box.
                    f * (1.0 + 100.0 * outside)
                } else {
                    INVALID_COST
                }
            }
            _ => INVALID_COST,
        }
    }
}

impl CostFunction for &Cost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(self.eval(x))
    }
}

fn run(cost: &Cost<'_>, z0: &[f64], side: f64, opts: &NmOptions) -> (f64, Vec<f64>, Stop, usize) {
    let mut simplex = vec![z0.to_vec()];
    for i in 0..z0.len() {
        let mut v = z0.to_vec();
        v[i] += if v[i] + side <= 1.0 { side } else { -side };
        simplex.push(v);
    }
    let solver = match NelderMead::new(simplex).with_sd_tolerance(opts.sd_tolerance) {
        Ok(s) => s,
        Err(_) => return (cost.eval(z0), z0.to_vec(), Stop::Failed, 0),
    };
    match Executor::new(cost, solver)
        .configure(|s| s.max_iters(opts.max_iters))
        .run()
    {
        Ok(res) => {
            let st = res.state();
            let stop = match st.get_termination_reason() {
                Some(TerminationReason::SolverConverged) => Stop::Simplex,
                _ => Stop::Budget,
            };
            let z = st.get_best_param().cloned().unwrap_or_else(|| z0.to_vec());
            (st.get_best_cost(), z, stop, st.get_iter() as usize)
        }
        Err(_) => (cost.eval(z0), z0.to_vec(), Stop::Failed, 0),
    }
}

/// Minimises the score of `problem` from `x0`: a simplex of side 0.2 of the box, restarted
/// once with side 0.05 from where it converged (a simplex can collapse across a valley
/// before its minimum).
pub fn minimize(
    problem: &dyn LeastSquares,
    x0: &[f64],
    opts: &NmOptions,
    observe: &mut dyn FnMut(&Iteration),
) -> Solution {
    let bounds = problem.bounds();
    let cost = Cost {
        problem,
        lo: bounds.iter().map(|b| b.0).collect(),
        width: bounds.iter().map(|b| (b.1 - b.0).max(1e-300)).collect(),
        evals: AtomicUsize::new(0),
    };
    let z0: Vec<f64> = x0
        .iter()
        .zip(&bounds)
        .map(|(x, (l, u))| ((x - l) / (u - l)).clamp(0.0, 1.0))
        .collect();
    let initial = cost.eval(&z0);
    let (mut best, mut z, mut stop, mut iterations) = if z0.is_empty() {
        (initial, z0.clone(), Stop::NoParameters, 0)
    } else {
        run(&cost, &z0, 0.2, opts)
    };
    if stop == Stop::Simplex {
        let half = NmOptions {
            max_iters: (opts.max_iters / 2).max(1),
            ..*opts
        };
        let (c2, z2, _, it2) = run(&cost, &z, 0.05, &half);
        iterations += it2;
        if c2 < best {
            (best, z) = (c2, z2);
        }
    }
    if initial >= INVALID_COST && best >= INVALID_COST {
        stop = Stop::Failed;
    }
    let evaluations = cost.evals.load(Ordering::Relaxed);
    observe(&Iteration {
        iteration: iterations,
        score: best,
        evaluations,
        damping: f64::NAN,
    });
    let x: Vec<f64> = z
        .iter()
        .zip(cost.lo.iter().zip(&cost.width))
        .map(|(z, (l, w))| l + z.clamp(0.0, 1.0) * w)
        .collect();
    let residuals = problem.residuals(&x).unwrap_or_default();
    Solution {
        x,
        score: best,
        initial_score: initial,
        iterations,
        evaluations: evaluations + 1,
        stop,
        residuals,
        jacobian: None,
    }
}
