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

use super::{Iteration, Layout, LeastSquares, Solution, Stop};
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
    let z: Vec<f64> = x0
        .iter()
        .zip(&bounds)
        .map(|(x, (l, u))| ((x - l) / (u - l)).clamp(0.0, 1.0))
        .collect();
    let Some(r) = s.eval(&z) else {
        return Solution {
            x: s.x(&z),
            score: f64::NAN,
            initial_score: f64::NAN,
            iterations: 0,
            evaluations: 1,
            stop: Stop::Failed,
            residuals: Vec::new(),
            jacobian: None,
        };
    };
    let f = problem.layout().log_score(&r);
    let initial_score = f.exp();
    if z.is_empty() {
        return Solution {
            x: Vec::new(),
            score: initial_score,
            initial_score,
            iterations: 0,
            evaluations: 1,
            stop: Stop::NoParameters,
            residuals: r,
            jacobian: None,
        };
    }
    let mut st = State::start(&s, z, r, f, opts);
    let stop = loop {
        if let Some(stop) = st.reweighting(&s, opts, observe) {
            break stop;
        }
    };
    let p = st.z.len();
    Solution {
        x: s.x(&st.z),
        score: st.f.exp(),
        initial_score,
        iterations: st.iterations,
        evaluations: st.evaluations,
        stop,
        // In unit coordinates; scaled to the parameters' units.
        jacobian: Some(DMatrix::from_fn(st.jac.nrows(), p, |i, j| {
            st.jac[(i, j)] / s.width[j]
        })),
        residuals: st.r,
    }
}

/// A unit coordinate this close to a bound is on it.
const EDGE: f64 = 1e-12;

/// The solver between iterations, in unit-box coordinates.
struct State {
    /// The current point.
    z: Vec<f64>,
    /// Its residuals.
    r: Vec<f64>,
    /// Its log score.
    f: f64,
    /// The Jacobian of the residuals, at `z` or at an earlier point.
    jac: DMatrix<f64>,
    evaluations: usize,
    iterations: usize,
    /// Levenberg–Marquardt damping, and Nielsen's factor for raising it.
    lambda: f64,
    nu: f64,
    /// Forward differences while far from the optimum; central ones once a step has been
    /// rejected (the forward difference's truncation error then matters).
    central: bool,
    /// Accepted steps in a row that lowered the log score by less than `rtol`.
    creeping: usize,
}

/// The weights of one reweighting, frozen at the residuals it started from.
struct Frozen<'l> {
    layout: &'l Layout,
    /// Channel weights.
    w: Vec<f64>,
    /// Weighted cost at the current point.
    phi: f64,
    /// Log score when the weights were frozen.
    f_outer: f64,
    /// A step was accepted with these weights.
    moved: bool,
}

impl Frozen<'_> {
    /// After the weighted problem converged with `stop`: the fixed point when these weights no
    /// longer moved the solution, else a reweighting.
    fn settled(&self, f: f64, opts: &LmOptions, stop: Stop) -> Next {
        if !self.moved || self.f_outer - f < opts.ftol {
            Next::Stop(stop)
        } else {
            Next::Reweight
        }
    }
}

/// The weighted Gauss–Newton model at the current point.
struct Normal {
    /// Gradient.
    g: DVector<f64>,
    /// Gauss–Newton Hessian.
    h: DMatrix<f64>,
    /// Parameters not held at a bound by the gradient.
    free: Vec<usize>,
    /// Largest component of the projected gradient.
    pg: f64,
}

/// What comes after an iteration.
enum Next {
    Iterate,
    Reweight,
    Stop(Stop),
}

/// What the damped trial steps of one iteration did.
struct Trial {
    accepted: bool,
    /// The step fell below `xtol`.
    tiny: bool,
    rejected: usize,
}

impl State {
    fn start(s: &Scaled<'_>, z: Vec<f64>, r: Vec<f64>, f: f64, opts: &LmOptions) -> Self {
        let (jac, e) = jacobian(s, &z, &r, opts, false);
        Self {
            z,
            r,
            f,
            jac,
            evaluations: 1 + e,
            iterations: 0,
            lambda: 1e-3,
            nu: 2.0,
            central: false,
            creeping: 0,
        }
    }

    /// Levenberg–Marquardt iterations with the weights frozen at the current residuals;
    /// `Some` when the solve ends, `None` to reweight.
    fn reweighting(
        &mut self,
        s: &Scaled<'_>,
        opts: &LmOptions,
        observe: &mut dyn FnMut(&Iteration),
    ) -> Option<Stop> {
        let layout = s.problem.layout();
        let w = layout.weights(&self.r);
        let mut frozen = Frozen {
            layout,
            phi: frozen_cost(layout, &w, &self.r),
            w,
            f_outer: self.f,
            moved: false,
        };
        loop {
            match self.iteration(s, opts, &mut frozen, observe) {
                Next::Iterate => {}
                Next::Reweight => return None,
                Next::Stop(stop) => return Some(stop),
            }
        }
    }

    /// One iteration: the convergence tests for these weights, then damped trial steps.
    fn iteration(
        &mut self,
        s: &Scaled<'_>,
        opts: &LmOptions,
        frozen: &mut Frozen<'_>,
        observe: &mut dyn FnMut(&Iteration),
    ) -> Next {
        let normal = self.normal(frozen);
        if self.converged_for_weights(frozen, &normal, opts) {
            let stop = if normal.free.is_empty() || normal.pg < opts.gtol {
                Stop::Gradient
            } else {
                Stop::StepSize
            };
            return frozen.settled(self.f, opts, stop);
        }
        if self.iterations >= opts.max_iters {
            return Next::Stop(Stop::Budget);
        }
        self.iterations += 1;
        let trial = self.try_steps(s, opts, frozen, &normal);
        observe(&Iteration {
            iteration: self.iterations,
            score: self.f.exp(),
            evaluations: self.evaluations,
            damping: self.lambda,
        });
        if opts.rtol_steps > 0 && self.creeping >= opts.rtol_steps {
            return Next::Stop(Stop::Reduction);
        }
        if trial.tiny || (!trial.accepted && self.central) {
            // No step lowers the weighted cost: as converged as these weights allow.
            let stop = if trial.tiny {
                Stop::StepSize
            } else {
                Stop::NoProgress
            };
            return frozen.settled(self.f, opts, stop);
        }
        if trial.rejected > 0 && !self.central {
            self.central = true;
        }
        if trial.accepted || self.central {
            let (j2, e) = jacobian(s, &self.z, &self.r, opts, self.central);
            self.jac = j2;
            self.evaluations += e;
        }
        Next::Iterate
    }

    fn normal(&self, frozen: &Frozen<'_>) -> Normal {
        let (g, h) = super::weighted_normal_equations(frozen.layout, &frozen.w, &self.r, &self.jac);
        let z = &self.z;
        let free: Vec<usize> = (0..z.len())
            .filter(|&i| !((z[i] <= EDGE && g[i] > 0.0) || (z[i] >= 1.0 - EDGE && g[i] < 0.0)))
            .collect();
        let pg = free.iter().map(|&i| g[i].abs()).fold(0.0, f64::max);
        Normal { g, h, free, pg }
    }

    /// Converged for these weights: the projected gradient is small, or the full Gauss–Newton
    /// step is tiny against the standard errors (or predicts nothing).
    fn converged_for_weights(&self, frozen: &Frozen<'_>, n: &Normal, opts: &LmOptions) -> bool {
        if n.free.is_empty() || n.pg < opts.gtol {
            return true;
        }
        let Some(d) = damped_step(&n.g, &n.h, &n.free, 0.0) else {
            return false;
        };
        let gain = -(n.g.dot(&d) + 0.5 * d.dot(&(&n.h * &d)));
        let cov = super::covariance::sandwich(
            frozen.layout,
            &self.r,
            &self.jac,
            &n.free,
            vec![String::new(); n.free.len()],
        );
        let within = n
            .free
            .iter()
            .zip(&cov.se)
            .all(|(&i, &se)| se > 0.0 && d[i].abs() < opts.se_fraction * se);
        within || (gain.is_finite() && gain < opts.ftol * frozen.phi.max(1e-300))
    }

    /// Up to 12 damped steps, the damping raised after each rejected one, until one lowers the
    /// weighted cost by a fair share of what it predicts (it is then taken).
    fn try_steps(&mut self, s: &Scaled<'_>, opts: &LmOptions, frozen: &mut Frozen<'_>, n: &Normal) -> Trial {
        let p = self.z.len();
        let mut trial = Trial {
            accepted: false,
            tiny: false,
            rejected: 0,
        };
        for _ in 0..12 {
            let Some(d) = damped_step(&n.g, &n.h, &n.free, self.lambda) else {
                self.lambda *= self.nu;
                self.nu *= 2.0;
                continue;
            };
            let z_new: Vec<f64> = self
                .z
                .iter()
                .zip(d.iter())
                .map(|(a, b)| (a + b).clamp(0.0, 1.0))
                .collect();
            let delta = DVector::from_iterator(p, z_new.iter().zip(&self.z).map(|(a, b)| a - b));
            if delta.amax() < opts.xtol {
                trial.tiny = true;
                break;
            }
            let predicted = -(n.g.dot(&delta) + 0.5 * delta.dot(&(&n.h * &delta)));
            self.evaluations += 1;
            if let Some(rn) = s.eval(&z_new) {
                let phi_new = frozen_cost(frozen.layout, &frozen.w, &rn);
                let rho = if predicted > 0.0 {
                    (frozen.phi - phi_new) / predicted
                } else {
                    -1.0
                };
                if phi_new < frozen.phi && rho > 1e-4 {
                    self.lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                    self.nu = 2.0;
                    self.z = z_new;
                    let f_new = frozen.layout.log_score(&rn);
                    self.creeping = if self.f - f_new < opts.rtol {
                        self.creeping + 1
                    } else {
                        0
                    };
                    self.f = f_new;
                    self.r = rn;
                    frozen.phi = phi_new;
                    trial.accepted = true;
                    frozen.moved = true;
                    break;
                }
            }
            self.lambda *= self.nu;
            self.nu *= 2.0;
            trial.rejected += 1;
        }
        trial
    }
}

#[cfg(test)]
mod tests;
