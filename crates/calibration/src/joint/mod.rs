//! Several logs, one robot: the robot's parameters fitted once on every log together, the
//! ground's once per log.
//!
//! [`calibrate_joint`] runs as the single-log stages do, one input struct ([`JointInput`]) and
//! one output struct ([`JointReport`]):
//! 1. every log is calibrated on its own ([`crate::calibrate`], the whole loop: split, floor,
//!    baseline, selection); its report is kept as it is (what `calibrate LOG` would write);
//! 2. the model of the joint fit is the base parameters of the plant plus every effect any
//!    log selected; each parameter is the robot's or the ground's by
//!    [`Param::on_terrain`] (the terrain profile's fields, and for an effect its own
//!    [`drive_sim_model::effects::Effect::on_terrain`] hook): nothing here names a parameter;
//! 3. one parameter vector, the shared robot block then one terrain block per log, is fitted
//!    by the same Levenberg–Marquardt solver on every log's training steps, the residuals of
//!    all logs stacked and each log's channels scored against that log's own noise floor (a
//!    log's channels are channels of their own in the score: the score is the geometric mean
//!    over every log's channels);
//! 4. the covariance (clustered by step, each log's steps their own clusters) gives every
//!    parameter its interval; each log's test score is computed on its own test steps, which
//!    neither its own calibration nor the joint fit touched.
//!
//! Logs of different robots are refused before any work ([`check_one_robot`]).

mod problem;
mod write;

pub use write::{check_joint_twin, joint_twin, write_joint};

use crate::data::StepSet;
use crate::error::{Error, Result};
use crate::events::CalibrationEvent;
use crate::fit::{FitResult, FittedParam};
use crate::metrics::ErrorSummary;
use crate::model::{ModelParams, PlantFactory};
use crate::params::{Param, ParamSpec};
use crate::solver::covariance::sandwich;
use crate::solver::{lm, LeastSquares};
use crate::{steps, twin, CalibrationOptions, CalibrationReport};
use drive_sim_log::DriveLog;
use drive_sim_model::effects::{CommandReach, ParamKind, REGISTRY};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use problem::{joint_specs, JointProblem, Prepared};
use serde::{Deserialize, Serialize};

/// One log of a joint calibration with the terrain its model starts from.
pub struct JointLog<'a> {
    /// The log.
    pub log: &'a DriveLog,
    /// The terrain its model starts from (the log's own, or a file given for it).
    pub terrain: Terrain,
}

/// What [`calibrate_joint`] works on.
pub struct JointInput<'a> {
    /// The logs, all of the same robot.
    pub logs: Vec<JointLog<'a>>,
    /// The robot every log's model starts from.
    pub robot: &'a Robot,
    /// The plant calibrated.
    pub factory: &'a dyn PlantFactory,
    /// Options of every single-log calibration and of the joint fit.
    pub opts: &'a CalibrationOptions,
}

/// One log's part of a [`JointReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointLogResult {
    /// Dataset name.
    pub dataset: String,
    /// Terrain named by the log.
    pub terrain: String,
    /// File name of its terrain twin in `OUT/twin/` ([`terrain_file_name`]).
    pub terrain_file: String,
    /// Training steps of the joint fit (the log's own calibration's, or a seeded subset of
    /// them with `max_fit_steps`).
    pub fit_steps: Vec<u32>,
    /// Test steps (its own calibration's).
    pub test_steps: Vec<u32>,
    /// Test error of the jointly fitted model, relative to the log's own noise floor.
    pub joint: ErrorSummary,
    /// Test score of the log's own calibration (same steps, same floor).
    pub single_score: f64,
    /// The log's terrain block of the joint fit (`<name>` as in a single report).
    pub terrain_params: Vec<FittedParam>,
    /// Its model at the joint solution.
    pub model: ModelParams,
    /// The closed-loop check of this log's twin (the robot file with this log's terrain file),
    /// simulator model only ([`check_joint_twin`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twin_check: Option<twin::TwinCheck>,
}

/// Everything [`calibrate_joint`] found, serializable to JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointReport {
    /// The robot.
    pub robot: String,
    /// Plant used as the model.
    pub model_kind: String,
    /// Every log's own calibration, in the order given.
    pub singles: Vec<CalibrationReport>,
    /// Effects in the joint model: every effect some log's calibration selected.
    pub effects: Vec<String>,
    /// Names of the parameters shared by every log (the robot's).
    pub robot_param_names: Vec<String>,
    /// Names of the parameters fitted once per log (the ground's).
    pub terrain_param_names: Vec<String>,
    /// The joint fit; terrain parameters are named `<name>@<dataset>`.
    pub fit: FitResult,
    /// The robot block of the joint fit, with intervals from every log's steps.
    pub robot_params: Vec<FittedParam>,
    /// Per log: its terrain block and its test scores.
    pub logs: Vec<JointLogResult>,
    /// What happened, in order.
    pub notes: Vec<String>,
    /// A command line that reproduces this report.
    pub reproduce: String,
}

/// Refuses logs of different robots (a [`drive_sim_model::Error::Log`], bad input), naming both.
pub fn check_one_robot(logs: &[&DriveLog]) -> Result<()> {
    if let Some(first) = logs.first() {
        for l in &logs[1..] {
            if l.meta.robot != first.meta.robot {
                return Err(Error::log(
                    &l.meta.name,
                    "robot",
                    format!(
                        "a joint calibration fits one robot: this log is of `{}`, `{}` is of `{}`",
                        l.meta.robot, first.meta.name, first.meta.robot
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Name of a log's terrain twin: `terrain_<dataset>.toml` (the dataset names the run, and two
/// runs on one terrain each get their own file).
pub fn terrain_file_name(dataset: &str) -> String {
    let safe: String = dataset
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("terrain_{safe}.toml")
}

/// Runs the joint calibration (see the module doc). `progress` hears what each stage found.
pub fn calibrate_joint(
    input: &JointInput<'_>,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<JointReport> {
    let logs: Vec<&DriveLog> = input.logs.iter().map(|l| l.log).collect();
    check_logs(&logs)?;
    let (factory, opts) = (input.factory, input.opts);
    let mut notes = Vec::new();
    // 1. Every log on its own.
    let singles = calibrate_each(input, progress)?;
    // 2. The joint model: every effect some log selected.
    let model = JointModel::of(&singles);
    if !model.flags.is_empty() {
        notes.push(format!(
            "on/off parameters are not fitted jointly: {} keep each log's own choice (the robot file is the first log's)",
            model.flags.join(", ")
        ));
    }
    let (prepared, reach) = prepare(&logs, &singles, input)?;
    let (robot_specs, terrain_specs) = blocks(factory, &singles, &model.effect_params, &reach);
    let x0 = start(&robot_specs, &terrain_specs, &singles, &prepared);
    let problem = JointProblem::new(&prepared, factory, robot_specs, terrain_specs);
    progress(&CalibrationEvent::JointFitStarted {
        robot_params: problem.robot.iter().map(|s| s.param.name()).collect(),
        terrain_params: terrain_names(&problem),
        logs: prepared.len(),
    });
    // 3. One fit of every log together, with its intervals.
    let (fit, x) = solve(&problem, &x0, &param_names(&problem, &logs), opts)?;
    progress(&CalibrationEvent::JointFitDone {
        initial_score: fit.initial_score,
        score: fit.score,
        status: fit.status.clone(),
        evaluations: fit.evaluations,
    });
    if !fit.converged {
        notes.push(format!("joint fit did not converge: {}", fit.status));
    }
    // 4. Each log's test score at the joint solution.
    let results = log_results(&problem, &logs, &singles, &fit.params, &x)?;
    Ok(JointReport {
        robot: input.robot.name.clone(),
        model_kind: factory.name(),
        robot_param_names: problem.robot.iter().map(|s| s.param.name()).collect(),
        terrain_param_names: terrain_names(&problem),
        robot_params: fit.params[..problem.robot.len()].to_vec(),
        singles,
        effects: model.effects,
        fit,
        logs: results,
        notes,
        reproduce: String::new(),
    })
}

/// Refuses logs of different robots, fewer than two logs, and two logs of one dataset name
/// (each gets its own terrain file).
fn check_logs(logs: &[&DriveLog]) -> Result<()> {
    check_one_robot(logs)?;
    if logs.len() < 2 {
        return Err(Error::TooFewLogs);
    }
    let mut names: Vec<&str> = logs.iter().map(|l| l.meta.name.as_str()).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(Error::log(
            w[0],
            "name",
            "two logs of a joint calibration have the same dataset name (each gets its own terrain file)",
        ));
    }
    Ok(())
}

/// Every log's own calibration ([`crate::calibrate`]), in the order given.
fn calibrate_each(
    input: &JointInput<'_>,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<Vec<CalibrationReport>> {
    let mut singles = Vec::new();
    for (k, l) in input.logs.iter().enumerate() {
        progress(&CalibrationEvent::JointLogStarted {
            index: k + 1,
            logs: input.logs.len(),
            dataset: l.log.meta.name.clone(),
        });
        let r = crate::calibrate(l.log, input.robot, &l.terrain, input.factory, input.opts)?;
        progress(&CalibrationEvent::JointLogCalibrated {
            dataset: r.dataset.clone(),
            test_score: r.after.score,
            declared_score: r.before.score,
            effects: r.effects.iter().map(|e| (e.name.clone(), e.value)).collect(),
        });
        singles.push(r);
    }
    Ok(singles)
}

/// The effects of the joint model: every effect some log's calibration selected.
struct JointModel {
    /// Their parameters, as (effect, parameter) indices in the registry, sorted.
    effect_params: Vec<(usize, usize)>,
    /// The effects' names, in that order.
    effects: Vec<String>,
    /// The on/off parameters among them, which the joint fit leaves at each log's choice.
    flags: Vec<String>,
}

impl JointModel {
    fn of(singles: &[CalibrationReport]) -> Self {
        let mut effect_params: Vec<(usize, usize)> = Vec::new();
        for r in singles {
            for e in &r.effects {
                let key = e.name.trim_start_matches("effect.");
                if let Some(Param::Effect { effect, param }) = Param::effect_param(key) {
                    if !effect_params.contains(&(effect, param)) {
                        effect_params.push((effect, param));
                    }
                }
            }
        }
        effect_params.sort_unstable();
        let flags: Vec<String> = effect_params
            .iter()
            .filter(|&&(e, p)| REGISTRY[e].params()[p].kind == ParamKind::Flag)
            .map(|&(e, p)| REGISTRY[e].params()[p].key.to_string())
            .collect();
        let mut effects: Vec<String> = effect_params
            .iter()
            .map(|&(e, _)| REGISTRY[e].name().to_string())
            .collect();
        effects.dedup();
        Self {
            effect_params,
            effects,
            flags,
        }
    }
}

/// Data of each log: its calibration's training steps (or the same seeded subset) and test
/// steps, its floor and its calibrated model; and how far the training commands of every log
/// reach.
fn prepare<'a>(
    logs: &[&'a DriveLog],
    singles: &[CalibrationReport],
    input: &JointInput<'_>,
) -> Result<(Vec<Prepared<'a>>, CommandReach)> {
    let opts = input.opts;
    let mut prepared = Vec::new();
    let mut reach = CommandReach {
        wheel_rad_s: 0.0,
        speed_m_s: 0.0,
        yaw_rate_rad_s: 0.0,
    };
    for (l, r) in logs.iter().zip(singles) {
        let slices = steps::usable_step_slices(l).0;
        let mut fit_steps = r.train_steps.clone();
        if let Some(n) = opts.max_fit_steps.filter(|&n| n < fit_steps.len()) {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            fit_steps.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed));
            fit_steps.truncate(n.max(1));
            fit_steps.sort_unstable();
        }
        let train = StepSet::new(&slices, &fit_steps, l.meta.rate_hz)?;
        let earlier = [r.train_steps.as_slice(), &r.validation_steps].concat();
        let test = StepSet::after(&slices, &r.heldout_steps, &earlier, l.meta.rate_hz)?;
        reach = reach.max(CommandReach::of_commands(
            train.steps.iter().flat_map(|s| s.samples).map(|s| s.m.cmd),
            &input.robot.idd(),
        ));
        prepared.push(Prepared {
            train,
            test,
            floor: r.floor.clone(),
            start: r.model_after.clone(),
        });
    }
    Ok((prepared, reach))
}

/// The robot block from the first log's declared model, each log's terrain block from its own
/// (the terrain's search boxes scale with its declared friction).
fn blocks(
    factory: &dyn PlantFactory,
    singles: &[CalibrationReport],
    effect_params: &[(usize, usize)],
    reach: &CommandReach,
) -> (Vec<ParamSpec>, Vec<Vec<ParamSpec>>) {
    let mut robot_specs = Vec::new();
    let mut terrain_specs = Vec::new();
    for (k, r) in singles.iter().enumerate() {
        let (rs, ts) = joint_specs(factory, &r.model_before, effect_params, reach);
        if k == 0 {
            robot_specs = rs;
        }
        terrain_specs.push(ts);
    }
    (robot_specs, terrain_specs)
}

/// The start: each log from its own calibrated model; the shared values from the median of the
/// logs' own fits (inside the box) among the logs that fitted them (an effect off in a log is
/// no evidence of its value).
fn start(
    robot_specs: &[ParamSpec],
    terrain_specs: &[Vec<ParamSpec>],
    singles: &[CalibrationReport],
    prepared: &[Prepared<'_>],
) -> Vec<f64> {
    let mut x0 = Vec::new();
    for s in robot_specs {
        let fitted: Vec<f64> = singles
            .iter()
            .filter_map(|r| {
                twin::fitted_params(r)
                    .into_iter()
                    .find(|p| p.name == s.param.name())
            })
            .map(|p| p.value)
            .filter(|v| (s.lower..=s.upper).contains(v))
            .collect();
        let mut v: Vec<f64> = if fitted.is_empty() {
            prepared.iter().map(|p| s.start_in(&p.start)).collect()
        } else {
            fitted
        };
        v.sort_by(f64::total_cmp);
        x0.push(v[v.len() / 2]);
    }
    for (p, ts) in prepared.iter().zip(terrain_specs) {
        for s in ts {
            x0.push(s.start_in(&p.start));
        }
    }
    x0
}

/// Names of the terrain block's parameters (every log's block has the same).
fn terrain_names(problem: &JointProblem<'_, '_>) -> Vec<String> {
    problem
        .terrain
        .first()
        .map(|t| t.iter().map(|s| s.param.name()).collect())
        .unwrap_or_default()
}

/// Every parameter's name in the joint fit: a terrain parameter is `<name>@<dataset>`.
fn param_names(problem: &JointProblem<'_, '_>, logs: &[&DriveLog]) -> Vec<String> {
    let mut n: Vec<String> = problem.robot.iter().map(|s| s.param.name()).collect();
    for (l, ts) in logs.iter().zip(&problem.terrain) {
        n.extend(ts.iter().map(|s| format!("{}@{}", s.param.name(), l.meta.name)));
    }
    n
}

/// Fits the joint problem from `x0` and gives every free parameter its interval (clustered
/// sandwich over every log's steps). Returns the fit and the solution.
fn solve(
    problem: &JointProblem<'_, '_>,
    x0: &[f64],
    names: &[String],
    opts: &CalibrationOptions,
) -> Result<(FitResult, Vec<f64>)> {
    if problem.init_layout(x0).is_none() {
        return Err(Error::JointStartFailed);
    }
    let initial_score = (problem
        .layout()
        .log_score(&problem.residuals(x0).unwrap_or_default()))
    .exp();
    // Every log's own fit already met the standard-error criterion at its own values; the
    // joint start is not a minimum of the joint score, and on the measured Warthog runs the
    // criterion stopped the joint fit at its start: the joint fit stops on the gradient,
    // reduction and step criteria only.
    let lm_opts = lm::LmOptions {
        se_fraction: 0.0,
        ..opts.fit.lm
    };
    let sol = lm::minimize(problem, x0, &lm_opts, &mut |_| {});
    let specs = problem.specs();
    let free: Vec<usize> = (0..specs.len())
        .filter(|&i| !specs[i].at_bound(sol.x[i]))
        .collect();
    let covariance = match &sol.jacobian {
        Some(jac) if !free.is_empty() && !sol.residuals.is_empty() => Some(sandwich(
            problem.layout(),
            &sol.residuals,
            jac,
            &free,
            free.iter().map(|&i| names[i].clone()).collect(),
        )),
        _ => None,
    };
    let mut params = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let mut p = FittedParam::of(s, Some(x0[i]), sol.x[i]);
        p.name.clone_from(&names[i]);
        if let (Some(cov), Some(j)) = (&covariance, free.iter().position(|&f| f == i)) {
            p = p.with_uncertainty(s, cov, j);
        }
        params.push(p);
    }
    let fit = FitResult {
        params,
        initial_score,
        score: sol.score,
        evaluations: sol.evaluations as u64,
        converged: sol.stop.converged(),
        status: sol.stop.describe().to_string(),
        stop: Some(sol.stop.clone()),
        iterations: sol.iterations as u64,
        covariance,
    };
    Ok((fit, sol.x))
}

/// Each log's part of the report at the joint solution `x`: its test score on its own test
/// steps and its terrain block.
fn log_results(
    problem: &JointProblem<'_, '_>,
    logs: &[&DriveLog],
    singles: &[CalibrationReport],
    params: &[FittedParam],
    x: &[f64],
) -> Result<Vec<JointLogResult>> {
    let mut results = Vec::new();
    for (k, (l, r)) in logs.iter().zip(singles).enumerate() {
        let model = problem.model(k, x)?;
        let p = &problem.logs[k];
        let joint = ErrorSummary::pool(&p.test.errors(problem.factory, &model)?, &p.floor);
        let o = problem.offset(k);
        let terrain_params = params[o..o + problem.terrain[k].len()]
            .iter()
            .map(|q| {
                let mut q = q.clone();
                q.name = q.name.trim_end_matches(&format!("@{}", l.meta.name)).to_string();
                q
            })
            .collect();
        results.push(JointLogResult {
            dataset: l.meta.name.clone(),
            terrain: l.meta.terrain.clone(),
            terrain_file: terrain_file_name(&l.meta.name),
            fit_steps: p.train.ids(),
            test_steps: r.heldout_steps.clone(),
            single_score: r.after.score,
            joint,
            terrain_params,
            model,
            twin_check: None,
        });
    }
    Ok(results)
}
