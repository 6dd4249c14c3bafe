//! The search of a closed-loop tuning: a space-filling design over the box, then argmin's
//! Nelder–Mead from its best point, on a cost that is a mean over seeded DRIVE runs.
//!
//! The cost is deterministic (every run of a point uses the same seeds: common random numbers,
//! so two points differ by their parameters, not their draws) but not smooth: a small change
//! of a parameter can send a run's path elsewhere (another interruption, another command at
//! the border). A local search started at a single point would stop in the first dent; the
//! design first looks over the whole box, and a derivative-free simplex refines from the best
//! of it. Every point is evaluated once (a cache by unit coordinates).

use argmin::core::{CostFunction, Executor, State, TerminationReason};
use argmin::solver::neldermead::NelderMead;
use drive_sim_protocol::samplers::halton::radical_inverse;
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::HashMap;

/// Bases of the design's coordinates (one prime per tuned parameter).
pub const DESIGN_BASES: &[u64] = &[2, 3, 5, 7, 11, 13];

/// Budget and shape of the search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SearchOptions {
    /// Most points evaluated, design included.
    pub max_evaluations: usize,
    /// Points of the design besides the start (0: as many as `2 k + 4` for `k` parameters,
    /// at most half the budget).
    pub design_points: usize,
    /// Side of the first simplex, as a fraction of the box.
    pub simplex_side: f64,
    /// The simplex has converged when its costs' standard deviation falls below this.
    pub sd_tolerance: f64,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self {
            max_evaluations: 40,
            design_points: 0,
            simplex_side: 0.15,
            sd_tolerance: 0.05,
        }
    }
}

/// Where the search stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchSummary {
    /// Points of the design (the start included).
    pub design_points: usize,
    /// Points evaluated in all.
    pub evaluations: usize,
    /// Nelder–Mead iterations.
    pub simplex_iterations: u64,
    /// Why the simplex stopped, in argmin's words.
    pub stop: String,
    /// Converged: the simplex's costs agree to the tolerance before the budget ran out.
    pub converged: bool,
}

/// The points of the design in the unit box: `n` points of the Halton sequence (index from 1,
/// so no point sits on the box's corner).
pub fn design(k: usize, n: usize) -> Vec<Vec<f64>> {
    (1..=n as u64)
        .map(|i| (0..k).map(|d| radical_inverse(i, DESIGN_BASES[d])).collect())
        .collect()
}

/// Costs of several points in the unit box, one each, `None` for a point whose runs failed
/// (the caller may evaluate them in parallel).
pub type CostMany<'a> = dyn Fn(&[Vec<f64>]) -> Vec<Option<f64>> + 'a;

/// Cost of a point the budget no longer pays for, or whose runs failed: worse than any loss.
pub const UNAFFORDABLE: f64 = f64::INFINITY;

/// Minimises `cost` over the unit box of dimension `z0.len()`, starting with `z0` and the
/// design (evaluated together by `cost_many`, which may run them in parallel), then a simplex
/// from the best. `cost_many` returns one cost per point, `None` for a point whose runs
/// failed. Returns the best point, its cost and the summary.
pub fn minimise(
    z0: &[f64],
    opts: &SearchOptions,
    cost_many: &CostMany<'_>,
) -> (Vec<f64>, f64, SearchSummary) {
    let k = z0.len();
    let n_design = if opts.design_points > 0 {
        opts.design_points
    } else {
        (2 * k + 4).min(opts.max_evaluations / 2)
    };
    let mut points = vec![z0.to_vec()];
    // The start is often the box's middle, which is also the sequence's first point: skip
    // points that repeat it.
    let near_start = |p: &Vec<f64>| p.iter().zip(z0).all(|(a, b)| (a - b).abs() < 1e-6);
    points.extend(
        design(k, n_design + 1)
            .into_iter()
            .filter(|p| !near_start(p))
            .take(n_design),
    );
    let costs = cost_many(&points);
    let cache: RefCell<HashMap<Vec<u64>, f64>> = RefCell::new(HashMap::new());
    let key = |z: &[f64]| z.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let mut best = (z0.to_vec(), f64::INFINITY);
    for (p, c) in points.iter().zip(&costs) {
        let c = c.unwrap_or(UNAFFORDABLE);
        cache.borrow_mut().insert(key(p), c);
        if c < best.1 {
            best = (p.clone(), c);
        }
    }
    let design_points = points.len();
    let problem = Problem {
        budget: opts.max_evaluations,
        cache: &cache,
        cost_many,
    };
    let mut simplex = vec![best.0.clone()];
    for i in 0..k {
        let mut v = best.0.clone();
        v[i] += if v[i] + opts.simplex_side <= 1.0 {
            opts.simplex_side
        } else {
            -opts.simplex_side
        };
        simplex.push(v);
    }
    let remaining = opts.max_evaluations.saturating_sub(design_points) as u64;
    let (stop, iterations, converged) = match NelderMead::new(simplex).with_sd_tolerance(opts.sd_tolerance) {
        Ok(solver) if remaining > k as u64 => {
            match Executor::new(&problem, solver)
                .configure(|s| s.max_iters(remaining))
                .run()
            {
                Ok(res) => {
                    let st = res.state();
                    let reason = st.get_termination_reason();
                    let text = reason.map_or_else(|| "running".to_string(), |r| r.text().to_string());
                    let converged = matches!(reason, Some(TerminationReason::SolverConverged));
                    (text, st.get_iter(), converged)
                }
                Err(e) => (format!("simplex failed: {e}"), 0, false),
            }
        }
        Ok(_) => ("no budget left for the simplex".into(), 0, false),
        Err(e) => (format!("simplex not built: {e}"), 0, false),
    };
    let evaluations = cache.borrow().len();
    for (p, c) in cache.borrow().iter() {
        if *c < best.1 {
            best = (p.iter().map(|b| f64::from_bits(*b)).collect(), *c);
        }
    }
    // Points beyond the budget are refused at a prohibitive cost, and the simplex then
    // shrinks about its best vertex until its own criterion stops it: that stop is the budget's.
    let within_budget = evaluations < opts.max_evaluations;
    let stop = if converged && !within_budget {
        format!(
            "all {} evaluations spent (the simplex stopped only after points beyond them were refused)",
            opts.max_evaluations
        )
    } else {
        stop
    };
    let converged = converged && within_budget;
    (
        best.0,
        best.1,
        SearchSummary {
            design_points,
            evaluations: evaluations.min(opts.max_evaluations),
            simplex_iterations: iterations,
            stop,
            converged,
        },
    )
}

struct Problem<'a> {
    budget: usize,
    cache: &'a RefCell<HashMap<Vec<u64>, f64>>,
    cost_many: &'a CostMany<'a>,
}

impl CostFunction for &Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, z: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        // The simplex may step outside the box: clamp, and penalise the distance, so it
        // comes back.
        let clamped: Vec<f64> = z.iter().map(|v| v.clamp(0.0, 1.0)).collect();
        let outside: f64 = z.iter().zip(&clamped).map(|(a, b)| (a - b).powi(2)).sum();
        let key: Vec<u64> = clamped.iter().map(|v| v.to_bits()).collect();
        let cached = self.cache.borrow().get(&key).copied();
        let c = match cached {
            Some(c) => c,
            None if self.cache.borrow().len() >= self.budget => return Ok(UNAFFORDABLE),
            None => {
                let c = (self.cost_many)(std::slice::from_ref(&clamped))[0].unwrap_or(UNAFFORDABLE);
                self.cache.borrow_mut().insert(key, c);
                c
            }
        };
        Ok(c * (1.0 + 100.0 * outside) + outside)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_design_spreads_over_the_box_without_its_corners() {
        let d = design(2, 8);
        assert_eq!(d.len(), 8);
        assert_eq!(d[0], vec![0.5, 1.0 / 3.0]);
        assert!(d.iter().flatten().all(|v| *v > 0.0 && *v < 1.0));
    }

    #[test]
    fn finds_the_minimum_of_a_bumpy_bowl_within_the_budget() {
        // A bowl at (0.3, 0.7) with ripples that trap a local search started far away.
        let f = |z: &[f64]| (z[0] - 0.3).powi(2) + (z[1] - 0.7).powi(2) + 0.002 * (40.0 * z[0]).sin().abs();
        let calls = std::cell::Cell::new(0usize);
        let many = |ps: &[Vec<f64>]| -> Vec<Option<f64>> {
            calls.set(calls.get() + ps.len());
            ps.iter().map(|p| Some(f(p))).collect()
        };
        let opts = SearchOptions {
            max_evaluations: 60,
            ..SearchOptions::default()
        };
        let (z, c, s) = minimise(&[0.95, 0.05], &opts, &many);
        assert!(
            (z[0] - 0.3).abs() < 0.05 && (z[1] - 0.7).abs() < 0.05,
            "{z:?} {c} {s:?}"
        );
        assert!(calls.get() <= 60, "{} evaluations", calls.get());
        assert_eq!(s.design_points, 9);
    }

    #[test]
    fn failed_points_are_never_chosen() {
        let many = |ps: &[Vec<f64>]| -> Vec<Option<f64>> {
            ps.iter().map(|p| (p[0] > 0.5).then_some(1.0 - p[0])).collect()
        };
        let (z, c, _) = minimise(&[0.2], &SearchOptions::default(), &many);
        assert!(z[0] > 0.5 && c.is_finite(), "{z:?} {c}");
    }
}
