//! Levenberg–Marquardt on the log score, with box bounds and finite-difference Jacobians
//! whose columns are evaluated in parallel.
//!
//! Why our own loop and not a crate's: the `levenberg-marquardt` crate (a MINPACK port on
//! nalgebra) minimises `½‖r‖²` with fixed residual weights and has no bounds; argmin has
//! Gauss–Newton and trust-region methods but no bounded least squares. The score here has
//! weights that move with the parameters (iteratively reweighted, see [`super`]) and every
//! parameter has a physical box. The step itself is the textbook one, on nalgebra:
//! `(H + λ diag H) δ = −g` on the parameters not held at a bound, the step projected into the
//! box, accepted when the actual reduction of the log score is a fair share of the predicted
//! one, with Nielsen's update of `λ`. Parameters are scaled to the unit box, so one tolerance
//! fits all.

use super::{Iteration, LeastSquares, Solution, Stop};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Tolerances and budget.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LmOptions {
    /// Most iterations (each one Jacobian, i.e. one model evaluation per parameter, plus the
    /// trial steps).
    pub max_iters: usize,
    /// Converged when every component of the projected gradient of the log score, per unit
    /// of the parameter box, is below this.
    pub gtol: f64,
    /// Converged when the reduction a full Gauss–Newton step predicts is below this share of
    /// the weighted cost, and when a reweighting lowers the log score by less than this.
    pub ftol: f64,
    /// Converged when an accepted step is below this, per unit of the box.
    pub xtol: f64,
    /// Converged when the full Gauss–Newton step of every free parameter is below this
    /// fraction of its standard error (clustered sandwich at the current point): further
    /// iterations could not change any interval.
    pub se_fraction: f64,
    /// Finite-difference step, per unit of the box (a parameter's resolution may enlarge it).
    pub fd_step: f64,
    /// Converged when this many accepted steps in a row each lowered the log score by less
    /// than `rtol` (a relative change of the score): a fit creeping along a flat valley (two
    /// parameters that act alike, a limit the data barely reach) stops there instead of on
    /// its budget; the covariance then says the valley's parameters are not identifiable.
    #[serde(default = "default_rtol")]
    pub rtol: f64,
    /// See `rtol`.
    #[serde(default = "default_rtol_steps")]
    pub rtol_steps: usize,
}

fn default_rtol() -> f64 {
    1e-5
}

fn default_rtol_steps() -> usize {
    3
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iters: 30,
            gtol: 1e-4,
            ftol: 1e-8,
            xtol: 1e-7,
            se_fraction: 0.01,
            fd_step: 1e-3,
            rtol: default_rtol(),
            rtol_steps: default_rtol_steps(),
        }
    }
}

/// Unit-box coordinates ↔ parameters.
struct Scaled<'p> {
    problem: &'p dyn LeastSquares,
    lo: Vec<f64>,
    width: Vec<f64>,
}

impl Scaled<'_> {
    fn x(&self, z: &[f64]) -> Vec<f64> {
        z.iter()
            .zip(self.lo.iter().zip(&self.width))
            .map(|(z, (l, w))| l + z.clamp(0.0, 1.0) * w)
            .collect()
    }
    fn eval(&self, z: &[f64]) -> Option<Vec<f64>> {
        let r = self.problem.residuals(&self.x(z))?;
        (r.len() == self.problem.layout().channel.len() && r.iter().all(|v| v.is_finite())).then_some(r)
    }
    /// Finite-difference step of parameter `j` in unit coordinates.
    fn step(&self, j: usize, opts: &LmOptions) -> f64 {
        let res = self.problem.resolution(j).map_or(0.0, |r| r / self.width[j]);
        opts.fd_step.max(res).min(0.5)
    }
}

/// Jacobian of the residuals at `z` (unit coordinates), one column per parameter, columns in
/// parallel. A column steps forward, or backward at the upper bound or where the forward
/// model fails. A column whose model fails both ways is zero (the parameter then has no
/// effect on the step).
fn jacobian(s: &Scaled<'_>, z: &[f64], r: &[f64], opts: &LmOptions, central: bool) -> (DMatrix<f64>, usize) {
    let p = z.len();
    let cols: Vec<(Vec<f64>, usize)> = (0..p)
        .into_par_iter()
        .map(|j| {
            let h = s.step(j, opts);
            let at = |dz: f64| {
                let mut zz = z.to_vec();
                zz[j] = (z[j] + dz).clamp(0.0, 1.0);
                let d = zz[j] - z[j];
                (d != 0.0).then(|| s.eval(&zz).map(|rr| (rr, d))).flatten()
            };
            if central && z[j] - h >= 0.0 && z[j] + h <= 1.0 {
                // Central differences near the optimum, where a forward difference's
                // truncation error is as large as the gradient itself.
                if let (Some((a, da)), Some((b, db))) = (at(h), at(-h)) {
                    return (a.iter().zip(&b).map(|(a, b)| (a - b) / (da - db)).collect(), 2);
                }
            }
            let mut evals = 0;
            for dir in [1.0, -1.0] {
                let sign = if z[j] + h > 1.0 { -dir } else { dir };
                evals += 1;
                if let Some((rr, dz)) = at(sign * h) {
                    return (rr.iter().zip(r).map(|(a, b)| (a - b) / dz).collect(), evals);
                }
            }
            (vec![0.0; r.len()], evals)
        })
        .collect();
    let evals = cols.iter().map(|c| c.1).sum();
    let mut j = DMatrix::zeros(r.len(), p);
    for (k, (col, _)) in cols.into_iter().enumerate() {
        j.set_column(k, &DVector::from_vec(col));
    }
    (j, evals)
}

/// Solves `(H + λ D) δ = −g` on the free parameters; `None` when singular.
fn damped_step(g: &DVector<f64>, h: &DMatrix<f64>, free: &[usize], lambda: f64) -> Option<DVector<f64>> {
    let n = free.len();
    let max_diag = free.iter().map(|&i| h[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
    let mut a = DMatrix::zeros(n, n);
    let mut b = DVector::zeros(n);
    for (ii, &i) in free.iter().enumerate() {
        b[ii] = -g[i];
        for (jj, &j) in free.iter().enumerate() {
            a[(ii, jj)] = h[(i, j)];
        }
        // Marquardt's scaling, floored so that a parameter with no effect still gets a step
        // of bounded size instead of a singular system.
        a[(ii, ii)] += lambda * h[(i, i)].max(1e-9 * max_diag) + 1e-12 * max_diag;
    }
    let d = a.cholesky()?.solve(&b);
    let mut full = DVector::zeros(g.len());
    for (ii, &i) in free.iter().enumerate() {
        full[i] = d[ii];
    }
    d.iter().all(|v| v.is_finite()).then_some(full)
}

/// `½ Σ_i w_c(i) r_i²`.
fn frozen_cost(layout: &super::Layout, w: &[f64], r: &[f64]) -> f64 {
    0.5 * r
        .iter()
        .zip(&layout.channel)
        .map(|(v, &c)| w[c as usize] * v * v)
        .sum::<f64>()
}

/// Minimises the log score of `problem` from `x0` (clamped into the box) by iteratively
/// reweighted least squares: the channel weights `2 / (C S_c)` are frozen at the current
/// residuals, the weighted least-squares problem is solved by Levenberg–Marquardt (its
/// Gauss–Newton model is exact for frozen weights, so its steps are accepted on the cost they
/// model), the weights are updated, and so on until the log score stops falling. At the fixed
/// point the weighted gradient is the log score's gradient: the solution minimises the score
/// itself. `observe` is called after every Levenberg–Marquardt iteration.
pub fn minimize(
    problem: &dyn LeastSquares,
    x0: &[f64],
    opts: &LmOptions,
    observe: &mut dyn FnMut(&Iteration),
) -> Solution {
    let bounds = problem.bounds();
    let s = Scaled {
        problem,
        lo: bounds.iter().map(|b| b.0).collect(),
        width: bounds.iter().map(|b| (b.1 - b.0).max(1e-300)).collect(),
    };
    let layout = problem.layout();
    let mut z: Vec<f64> = x0
        .iter()
        .zip(&bounds)
        .map(|(x, (l, u))| ((x - l) / (u - l)).clamp(0.0, 1.0))
        .collect();
    let mut evaluations = 1;
    let Some(mut r) = s.eval(&z) else {
        return Solution {
            x: s.x(&z),
            score: f64::NAN,
            initial_score: f64::NAN,
            iterations: 0,
            evaluations,
            stop: Stop::Failed,
            residuals: Vec::new(),
            jacobian: None,
        };
    };
    let mut f = layout.log_score(&r);
    let initial_score = f.exp();
    if z.is_empty() {
        return Solution {
            x: Vec::new(),
            score: initial_score,
            initial_score,
            iterations: 0,
            evaluations,
            stop: Stop::NoParameters,
            residuals: r,
            jacobian: None,
        };
    }
    let p = z.len();
    let mut lambda = 1e-3;
    let mut nu = 2.0;
    let mut iterations = 0;
    // Forward differences while far from the optimum; central ones once a step has been
    // rejected (the forward difference's truncation error then matters).
    let mut central = false;
    // Accepted steps in a row that lowered the log score by less than `rtol`.
    let mut creeping = 0;
    let (mut jac, e) = jacobian(&s, &z, &r, opts, central);
    evaluations += e;
    let edge = 1e-12;
    let stop = 'outer: loop {
        // Reweight.
        let w = layout.weights(&r);
        let mut phi = frozen_cost(layout, &w, &r);
        let f_outer = f;
        let mut moved = false;
        loop {
            let (g, h) = super::weighted_normal_equations(layout, &w, &r, &jac);
            let free: Vec<usize> = (0..p)
                .filter(|&i| !((z[i] <= edge && g[i] > 0.0) || (z[i] >= 1.0 - edge && g[i] < 0.0)))
                .collect();
            let pg = free.iter().map(|&i| g[i].abs()).fold(0.0, f64::max);
            // Converged for these weights: the projected gradient is small, or the full
            // Gauss–Newton step is tiny against the standard errors (or predicts nothing).
            let mut done = free.is_empty() || pg < opts.gtol;
            if !done {
                if let Some(d) = damped_step(&g, &h, &free, 0.0) {
                    let gain = -(g.dot(&d) + 0.5 * d.dot(&(&h * &d)));
                    let cov =
                        super::covariance::sandwich(layout, &r, &jac, &free, vec![String::new(); free.len()]);
                    let within = free
                        .iter()
                        .zip(&cov.se)
                        .all(|(&i, &se)| se > 0.0 && d[i].abs() < opts.se_fraction * se);
                    done = within || (gain.is_finite() && gain < opts.ftol * phi.max(1e-300));
                }
            }
            if done {
                if !moved || f_outer - f < opts.ftol {
                    // The weights no longer move the solution: the fixed point.
                    break 'outer if free.is_empty() || pg < opts.gtol {
                        Stop::Gradient
                    } else {
                        Stop::StepSize
                    };
                }
                continue 'outer;
            }
            if iterations >= opts.max_iters {
                break 'outer Stop::Budget;
            }
            iterations += 1;
            let mut accepted = false;
            let mut tiny = false;
            let mut rejected = 0;
            for _ in 0..12 {
                let Some(d) = damped_step(&g, &h, &free, lambda) else {
                    lambda *= nu;
                    nu *= 2.0;
                    continue;
                };
                let z_new: Vec<f64> = z
                    .iter()
                    .zip(d.iter())
                    .map(|(a, b)| (a + b).clamp(0.0, 1.0))
                    .collect();
                let delta = DVector::from_iterator(p, z_new.iter().zip(&z).map(|(a, b)| a - b));
                if delta.amax() < opts.xtol {
                    tiny = true;
                    break;
                }
                let predicted = -(g.dot(&delta) + 0.5 * delta.dot(&(&h * &delta)));
                evaluations += 1;
                if let Some(rn) = s.eval(&z_new) {
                    let phi_new = frozen_cost(layout, &w, &rn);
                    let rho = if predicted > 0.0 {
                        (phi - phi_new) / predicted
                    } else {
                        -1.0
                    };
                    if phi_new < phi && rho > 1e-4 {
                        lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                        nu = 2.0;
                        z = z_new;
                        let f_new = layout.log_score(&rn);
                        creeping = if f - f_new < opts.rtol { creeping + 1 } else { 0 };
                        f = f_new;
                        r = rn;
                        phi = phi_new;
                        accepted = true;
                        moved = true;
                        break;
                    }
                }
                lambda *= nu;
                nu *= 2.0;
                rejected += 1;
            }
            observe(&Iteration {
                iteration: iterations,
                score: f.exp(),
                evaluations,
                damping: lambda,
            });
            if opts.rtol_steps > 0 && creeping >= opts.rtol_steps {
                break 'outer Stop::Reduction;
            }
            if tiny || (!accepted && central) {
                // No step lowers the weighted cost: as converged as these weights allow.
                if !moved || f_outer - f < opts.ftol {
                    break 'outer if tiny { Stop::StepSize } else { Stop::NoProgress };
                }
                continue 'outer;
            }
            if rejected > 0 && !central {
                central = true;
            }
            if accepted || central {
                let (j2, e) = jacobian(&s, &z, &r, opts, central);
                jac = j2;
                evaluations += e;
            }
        }
    };
    Solution {
        x: s.x(&z),
        score: f.exp(),
        initial_score,
        iterations,
        evaluations,
        stop,
        residuals: r,
        // In unit coordinates; scaled to the parameters' units.
        jacobian: Some(DMatrix::from_fn(jac.nrows(), p, |i, j| jac[(i, j)] / s.width[j])),
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Layout, LeastSquares};
    use super::*;

    /// y = a·exp(−b t) sampled on two channels with different noise, clusters of 5 samples.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
        layout: Layout,
    }

    impl LeastSquares for Decay {
        fn dim(&self) -> usize {
            2
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(0.1, 10.0), (0.01, 5.0)]
        }
        fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
            Some(
                self.t
                    .iter()
                    .zip(&self.y)
                    .map(|(t, y)| x[0] * (-x[1] * t).exp() - y)
                    .collect(),
            )
        }
        fn layout(&self) -> &Layout {
            &self.layout
        }
    }

    #[test]
    fn recovers_an_exact_model_and_stops_on_a_criterion() {
        let t: Vec<f64> = (0..40).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.5 * (-0.7 * t).exp()).collect();
        let layout = Layout {
            channel: (0..40).map(|i| (i % 2) as u8).collect(),
            cluster: (0..40).map(|i| i / 5).collect(),
            floor: vec![1.0, 1.0],
            min_ratio: 0.0,
        };
        let p = Decay { t, y, layout };
        let sol = minimize(&p, &[1.0, 2.0], &LmOptions::default(), &mut |_| {});
        assert!(sol.stop.converged(), "{:?}", sol.stop);
        assert!(
            (sol.x[0] - 2.5).abs() < 1e-4 && (sol.x[1] - 0.7).abs() < 1e-4,
            "{:?}",
            sol.x
        );
    }

    /// Two channels each see one parameter `x`: channel 0 wants x = 0 (2 entries), channel 1
    /// wants x = 1 (1 entry), floors 1. The geometric-mean score
    /// exp(½ [ln x² + ln (x − 1)²]) = x (1 − x) is smallest on the box [0.2, 0.7] at its lower
    /// bound (0.16, against 0.21 at 0.7), while the arithmetic mean of the channel MSEs,
    /// (x² + (x − 1)²) / 2, is smallest at x = 0.5. The solver must find the geometric one.
    struct TwoChannels {
        layout: Layout,
    }

    impl LeastSquares for TwoChannels {
        fn dim(&self) -> usize {
            1
        }
        fn bounds(&self) -> Vec<(f64, f64)> {
            vec![(0.2, 0.7)]
        }
        fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
            Some(vec![x[0], x[0], x[0] - 1.0])
        }
        fn layout(&self) -> &Layout {
            &self.layout
        }
    }

    #[test]
    fn minimises_the_geometric_not_the_arithmetic_mean() {
        let p = TwoChannels {
            layout: Layout {
                channel: vec![0, 0, 1],
                cluster: vec![0, 1, 2],
                floor: vec![1.0, 1.0],
                min_ratio: 0.0,
            },
        };
        // By hand: score(x) = |x| |x − 1| on [0.2, 0.7]; score(0.2) = 0.16, score(0.5) = 0.25,
        // score(0.7) = 0.21. The minimum is the lower bound.
        let sol = minimize(&p, &[0.45], &LmOptions::default(), &mut |_| {});
        assert!((sol.x[0] - 0.2).abs() < 1e-9, "{:?}", sol);
        assert!((sol.score - 0.16).abs() < 1e-9, "{}", sol.score);
        assert!(sol.stop.converged(), "{:?}", sol.stop);
    }
}
