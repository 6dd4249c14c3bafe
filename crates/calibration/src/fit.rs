//! Fitting model parameters to recorded steps: the replay of a [`StepSet`] as a
//! [`LeastSquares`] problem, solved by Levenberg–Marquardt (or, to compare, Nelder–Mead), on/off
//! parameters enumerated, and the fitted values with their clustered standard errors.

use super::data::StepSet;
use super::metrics::{NoiseFloor, MIN_CHANNEL_RATIO};
use super::model::{ModelParams, PlantFactory};
use super::params::ParamSpec;
use super::solver::covariance::{sandwich, Covariance};
use super::solver::lm::{self, LmOptions};
use super::solver::nelder_mead::{self, NmOptions};
use super::solver::{Iteration, Layout, LeastSquares, Solution, Stop};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

/// Which local solver fits continuous parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Optimizer {
    /// Levenberg–Marquardt on the log score with finite-difference Jacobians (the default).
    LevenbergMarquardt,
    /// argmin's Nelder–Mead on the score (the first calibration's optimizer; for comparison).
    NelderMead,
}

impl Optimizer {
    /// Names accepted by [`Optimizer::parse`].
    pub const NAMES: &'static [&'static str] = &["levenberg-marquardt", "nelder-mead"];

    /// Parses a solver name (for the CLI).
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "levenberg-marquardt" | "lm" => Ok(Self::LevenbergMarquardt),
            "nelder-mead" | "nm" => Ok(Self::NelderMead),
            _ => Err(Error::from(drive_sim_model::Error::Unknown {
                kind: "optimizer",
                name: name.to_string(),
                available: Self::NAMES.join(", "),
            })),
        }
    }
}

/// Solver choice and budgets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitOptions {
    /// Local solver.
    pub optimizer: Optimizer,
    /// Levenberg–Marquardt tolerances and budget.
    pub lm: LmOptions,
    /// Nelder–Mead budget.
    pub nm: NmOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            optimizer: Optimizer::LevenbergMarquardt,
            lm: LmOptions::default(),
            nm: NmOptions::default(),
        }
    }
}

/// A parameter's value before and after a fit, with its uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedParam {
    /// Report name (`terrain.friction.peak_lateral`, `effect.dead_time_s`).
    pub name: String,
    /// Value before the fit (`None`: an effect that was off).
    pub initial: Option<f64>,
    /// Fitted value.
    pub value: f64,
    /// Search box.
    pub lower: f64,
    /// Search box.
    pub upper: f64,
    /// The fit ended on the box boundary (the true value may lie beyond it): a likely stand-in
    /// for something the model lacks.
    pub at_bound: bool,
    /// Unit.
    #[serde(default)]
    pub unit: String,
    /// Standard error (clustered sandwich, see `calibration::solver::covariance`); `None` for
    /// an on/off parameter or one held at a bound; infinite when the data do not constrain it.
    #[serde(default)]
    pub se: Option<f64>,
    /// 95 % interval, value ± 1.96 standard errors.
    #[serde(default)]
    pub ci95: Option<[f64; 2]>,
    /// The data determine it: finite standard error, |correlation| ≤ 0.95 with every other
    /// fitted parameter, and (for an effect) an interval that excludes the neutral value.
    /// `None` when not assessed (on/off parameters, parameters at a bound).
    #[serde(default)]
    pub identifiable: Option<bool>,
    /// Why it is not identifiable, in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identifiability_note: Option<String>,
    /// Its 95 % interval contains the neutral value (an effect parameter the data cannot tell
    /// from absent). One parameter of a several-parameter effect may be neutral (only the
    /// left motor is weak); the effect is not identifiable when all of them are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neutral_in_interval: Option<bool>,
    /// Not identifiable for a reason other than a neutral value in its interval: infinite
    /// standard error, or confused with another parameter.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub confounded: bool,
}

/// Correlation above which two parameters count as indistinguishable.
pub const MAX_CORRELATION: f64 = 0.95;

impl FittedParam {
    /// `value` of the parameter `spec` describes, without uncertainty yet; on its bound when a
    /// continuous value lies in the outer half percent of the box.
    pub fn of(spec: &ParamSpec, initial: Option<f64>, value: f64) -> Self {
        Self {
            name: spec.param.name(),
            initial,
            value,
            lower: spec.lower,
            upper: spec.upper,
            at_bound: spec.at_bound(value),
            unit: spec.param.unit().to_string(),
            se: None,
            ci95: None,
            identifiable: None,
            identifiability_note: None,
            neutral_in_interval: None,
            confounded: false,
        }
    }

    /// Sets the standard error, interval and identifiability of parameter `i` of `cov`; for an
    /// effect parameter, the interval must exclude the neutral value (for a limit, whose
    /// neutral value is infinite: stay below the box's top, the largest command).
    pub(crate) fn with_uncertainty(mut self, spec: &ParamSpec, cov: &Covariance, i: usize) -> Self {
        let se = cov.se[i];
        self.se = Some(se);
        let mut why = Vec::new();
        if se.is_finite() {
            let ci = [self.value - 1.96 * se, self.value + 1.96 * se];
            self.ci95 = Some(ci);
            if let Some(n) = spec.param.neutral() {
                let contains = if n.is_infinite() {
                    ci[1] >= spec.upper
                } else {
                    ci[0] <= n && n <= ci[1]
                };
                self.neutral_in_interval = Some(contains);
                if contains {
                    why.push(format!(
                        "its 95 % interval [{:.4}, {:.4}] contains the neutral value{}",
                        ci[0],
                        ci[1],
                        if n.is_infinite() {
                            " (a limit above every command)".to_string()
                        } else {
                            format!(" {n}")
                        }
                    ));
                }
            }
        } else {
            self.confounded = true;
            why.push("the data do not constrain it (singular information matrix)".into());
        }
        // A correlation near 1 between parameters each measured to a small fraction of its
        // box is a precisely measured combination, not a confusion: only a correlated
        // parameter that is also loosely determined counts as confounded.
        let corr = cov.max_abs_correlation(i);
        let loose = !se.is_finite() || se >= LOOSE_SE_FRACTION * (spec.upper - spec.lower);
        if corr > MAX_CORRELATION && loose {
            let j = (0..cov.names.len())
                .filter(|&j| j != i && !cov.information_correlation[i][j].is_nan())
                .max_by(|&a, &b| {
                    let ca = cov.information_correlation[i][a].abs();
                    let cb = cov.information_correlation[i][b].abs();
                    ca.total_cmp(&cb)
                })
                .unwrap_or(i);
            self.confounded = true;
            why.push(format!(
                "|information correlation| {corr:.3} with {}: the model cannot tell them apart",
                cov.names[j]
            ));
        }
        self.identifiable = Some(why.is_empty());
        self.identifiability_note = (!why.is_empty()).then(|| why.join("; "));
        self
    }
}

/// A standard error above this share of the search box makes a parameter loosely determined.
pub const LOOSE_SE_FRACTION: f64 = 0.01;

/// Outcome of one fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitResult {
    /// Fitted parameters.
    pub params: Vec<FittedParam>,
    /// Score (on the steps fitted) before the fit.
    pub initial_score: f64,
    /// Score at the fitted values.
    pub score: f64,
    /// Model evaluations (each one replay of the steps fitted).
    pub evaluations: u64,
    /// The solver stopped at a minimum (false: budget exhausted, or failure, see `status`).
    pub converged: bool,
    /// Why it stopped, in words.
    pub status: String,
    /// Which criterion stopped it.
    #[serde(default)]
    pub stop: Option<Stop>,
    /// Solver iterations.
    #[serde(default)]
    pub iterations: u64,
    /// Covariance of the continuous parameters not held at a bound.
    #[serde(default)]
    pub covariance: Option<Covariance>,
}

impl FitResult {
    /// The fitted parameter named `name`.
    pub fn param(&self, name: &str) -> Option<&FittedParam> {
        self.params.iter().find(|p| p.name == name)
    }
}

/// The replay of `data` with `specs` varied around `base`, as a least-squares problem.
pub struct ReplayProblem<'a, 'b> {
    data: &'b StepSet<'a>,
    factory: &'b dyn PlantFactory,
    base: ModelParams,
    specs: Vec<ParamSpec>,
    floor: [f64; 10],
    layout: OnceLock<Layout>,
}

impl<'a, 'b> ReplayProblem<'a, 'b> {
    /// The problem of fitting `specs` (continuous) of `base` on `data`.
    pub fn new(
        data: &'b StepSet<'a>,
        factory: &'b dyn PlantFactory,
        base: ModelParams,
        specs: Vec<ParamSpec>,
        floor: &NoiseFloor,
    ) -> Self {
        Self {
            data,
            factory,
            base,
            specs,
            floor: floor.score_channels(),
            layout: OnceLock::new(),
        }
    }

    /// The model at parameters `x`.
    pub fn model(&self, x: &[f64]) -> Result<ModelParams> {
        self.base.with_values(&self.specs, x)
    }

    fn flat(&self, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>, Vec<u32>)> {
        let m = self.model(x).ok()?;
        let res = self.data.residuals(self.factory, &m).ok()?;
        let (mut v, mut c, mut k) = (Vec::new(), Vec::new(), Vec::new());
        for (i, r) in res.iter().enumerate() {
            let before = v.len();
            r.flatten_into(&mut v, &mut c);
            k.extend(std::iter::repeat_n(i as u32, v.len() - before));
        }
        Some((v, c, k))
    }

    /// Fixes the layout from an evaluation at `x` (the replay mirrors the recording's
    /// structure, so any successful evaluation gives the same one).
    fn init_layout(&self, x: &[f64]) -> Option<()> {
        if self.layout.get().is_none() {
            let (_, channel, cluster) = self.flat(x)?;
            let _ = self.layout.set(Layout {
                channel,
                cluster,
                floor: self.floor.to_vec(),
                min_ratio: MIN_CHANNEL_RATIO,
            });
        }
        Some(())
    }
}

impl LeastSquares for ReplayProblem<'_, '_> {
    fn dim(&self) -> usize {
        self.specs.len()
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        self.specs.iter().map(|s| (s.lower, s.upper)).collect()
    }
    fn resolution(&self, j: usize) -> Option<f64> {
        self.specs[j].param.resolution()
    }
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        let (v, c, _) = self.flat(x)?;
        (c == self.layout.get()?.channel).then_some(v)
    }
    fn layout(&self) -> &Layout {
        self.layout.get().expect("layout initialised before solving")
    }
}

fn solve(
    problem: &ReplayProblem<'_, '_>,
    x0: &[f64],
    opts: &FitOptions,
    observe: &mut dyn FnMut(&Iteration),
) -> Solution {
    if problem.init_layout(x0).is_none() {
        return Solution {
            x: x0.to_vec(),
            score: f64::NAN,
            initial_score: f64::NAN,
            iterations: 0,
            evaluations: 1,
            stop: Stop::Failed,
            residuals: Vec::new(),
            jacobian: None,
        };
    }
    match opts.optimizer {
        Optimizer::LevenbergMarquardt => {
            let (x0, starts) = limit_starts(problem, x0);
            let mut sol = lm::minimize(problem, &x0, &opts.lm, observe);
            sol.evaluations += starts;
            sol
        }
        Optimizer::NelderMead => nelder_mead::minimize(problem, x0, &opts.nm, observe),
    }
}

/// Fractions of a limit's box tried as starts, besides the given one.
const LIMIT_STARTS: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// A start for each limit among the parameters: the given value or one of [`LIMIT_STARTS`]
/// across its box, whichever scores best with the other parameters at `x0` (one limit after
/// the other). Why: a limit clamps nothing above the log's commands, where the cost is flat
/// and a gradient method stays where it starts; a command yaw-rate limit of 1.5 rad/s started
/// mid-box (2.2 rad/s) stayed there with an infinite standard error, and its controller stand-in
/// won. A multi-start, not a search: Levenberg–Marquardt refines from there. Returns the start
/// and the model evaluations it cost.
fn limit_starts(problem: &ReplayProblem<'_, '_>, x0: &[f64]) -> (Vec<f64>, usize) {
    use rayon::prelude::*;
    let mut x = x0.to_vec();
    let mut evaluations = 0;
    let score = |x: &[f64]| {
        problem
            .residuals(x)
            .map(|r| problem.layout().log_score(&r))
            .filter(|f| f.is_finite())
    };
    for (j, spec) in problem.specs.iter().enumerate() {
        if !spec.param.is_limit() {
            continue;
        }
        let mut tried: Vec<f64> = vec![x[j]];
        tried.extend(
            LIMIT_STARTS
                .iter()
                .map(|f| spec.lower + f * (spec.upper - spec.lower)),
        );
        let scores: Vec<Option<f64>> = tried
            .par_iter()
            .map(|&v| {
                let mut xx = x.clone();
                xx[j] = v;
                score(&xx)
            })
            .collect();
        evaluations += tried.len();
        // The first of the best: the given start wins ties.
        let mut best: Option<(usize, f64)> = None;
        for (k, s) in scores.iter().enumerate() {
            if let Some(s) = *s {
                if best.is_none_or(|(_, b)| s < b) {
                    best = Some((k, s));
                }
            }
        }
        if let Some((k, _)) = best {
            x[j] = tried[k];
        }
    }
    (x, evaluations)
}

/// Fits `specs` on the steps of `data`, starting from `base` (its own values inside the box,
/// else each spec's start). On/off parameters are enumerated at both values; continuous ones
/// go to the chosen solver. The covariance of the continuous parameters not held at a bound is
/// computed at the solution (Levenberg–Marquardt only: it needs the Jacobian). Returns the
/// best model found and what happened; an unconverged or failed fit is reported in
/// [`FitResult`], not as an error.
pub fn fit(
    data: &StepSet<'_>,
    factory: &dyn PlantFactory,
    base: &ModelParams,
    specs: &[ParamSpec],
    floor: &NoiseFloor,
    opts: &FitOptions,
    observe: &mut dyn FnMut(&Iteration),
) -> Result<(ModelParams, FitResult)> {
    let (discrete, continuous): (Vec<ParamSpec>, Vec<ParamSpec>) = specs.iter().partition(|s| s.discrete);
    let x0: Vec<f64> = continuous.iter().map(|s| s.start_in(base)).collect();
    // The score of the model as it is (not at the solver's start, which may differ: an effect
    // that is off starts inside its box).
    let initial_score = data.score(factory, base, floor)?;
    let mut best: Option<(Solution, ModelParams, ReplayProblem<'_, '_>)> = None;
    let mut evaluations = 1u64;
    for combo in 0..(1u32 << discrete.len()) {
        let values: Vec<f64> = discrete
            .iter()
            .enumerate()
            .map(|(i, s)| if combo >> i & 1 == 1 { s.upper } else { s.lower })
            .collect();
        let Ok(fixed) = base.with_values(&discrete, &values) else {
            continue;
        };
        let problem = ReplayProblem::new(data, factory, fixed, continuous.clone(), floor);
        let mut sol = solve(&problem, &x0, opts, observe);
        evaluations += sol.evaluations as u64;
        // A start read from elsewhere (a regression's coefficients) may give a model that
        // cannot run the steps; the model as it is can.
        let x0_model: Vec<f64> = continuous.iter().map(|s| s.model_start_in(base)).collect();
        if !sol.score.is_finite() && x0_model != x0 {
            sol = solve(&problem, &x0_model, opts, observe);
            evaluations += sol.evaluations as u64;
        }
        if sol.score.is_finite() && best.as_ref().is_none_or(|b| sol.score < b.0.score) {
            let model = problem.model(&sol.x)?;
            best = Some((sol, model, problem));
        }
    }
    let Some((sol, model, problem)) = best else {
        return Err(Error::NothingEvaluable {
            steps: data.len(),
            params: specs.iter().map(|s| s.param.name().to_string()).collect(),
        });
    };
    let mut params: Vec<FittedParam> = Vec::new();
    // Continuous parameters free at the solution get a covariance.
    let free: Vec<usize> = (0..continuous.len())
        .filter(|&i| !continuous[i].at_bound(sol.x[i]))
        .collect();
    let covariance = match (&sol.jacobian, free.is_empty()) {
        (Some(jac), false) if !sol.residuals.is_empty() => Some(sandwich(
            problem.layout(),
            &sol.residuals,
            jac,
            &free,
            free.iter().map(|&i| continuous[i].param.name()).collect(),
        )),
        _ => None,
    };
    for (i, s) in continuous.iter().enumerate() {
        let mut p = FittedParam::of(s, initial_of(s, base), sol.x[i]);
        if let (Some(cov), Some(k)) = (&covariance, free.iter().position(|&f| f == i)) {
            p = p.with_uncertainty(s, cov, k);
        }
        params.push(p);
    }
    for s in &discrete {
        params.push(FittedParam::of(s, initial_of(s, base), s.param.get(&model)));
    }
    // Report in the order asked.
    params.sort_by_key(|p| specs.iter().position(|s| s.param.name() == p.name));
    Ok((
        model,
        FitResult {
            params,
            initial_score,
            score: sol.score,
            evaluations,
            converged: sol.stop.converged(),
            status: sol.stop.describe().to_string(),
            stop: Some(sol.stop),
            iterations: sol.iterations as u64,
            covariance,
        },
    ))
}

fn initial_of(spec: &ParamSpec, base: &ModelParams) -> Option<f64> {
    let v = spec.param.get(base);
    match spec.param.neutral() {
        Some(n) if v == n => None,
        _ => Some(v),
    }
}
