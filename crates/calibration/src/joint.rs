//! Several logs, one robot: the robot's parameters fitted once on every log together, the
//! ground's once per log.
//!
//! [`calibrate_joint`] runs as the single-log stages do, one input struct ([`JointInput`]) and
//! one output struct ([`JointReport`]):
//! 1. every log is calibrated on its own ([`super::calibrate`], the whole loop: split, floor,
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

use super::data::StepSet;
use super::fit::{FitResult, FittedParam};
use super::metrics::{ErrorSummary, NoiseFloor, MIN_CHANNEL_RATIO};
use super::model::{ModelParams, PlantFactory};
use super::params::{Param, ParamSpec};
use super::solver::covariance::sandwich;
use super::solver::{lm, Layout, LeastSquares};
use super::{steps, twin, CalibrationOptions, CalibrationReport};
use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use drive_sim_model::error::{Error, Result};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use serde::{Deserialize, Serialize};
use std::sync::{Mutex, OnceLock};

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

/// Refuses logs of different robots (a [`Error::Log`], bad input), naming both.
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

/// One log's data for the joint fit.
struct Prepared<'a> {
    train: StepSet<'a>,
    test: StepSet<'a>,
    floor: NoiseFloor,
    start: ModelParams,
}

/// The stacked problem: `x` = robot block, then each log's terrain block.
struct JointProblem<'a, 'b> {
    logs: &'b [Prepared<'a>],
    factory: &'b dyn PlantFactory,
    robot: Vec<ParamSpec>,
    terrain: Vec<Vec<ParamSpec>>,
    layout: OnceLock<Layout>,
    /// Recent residuals of each log by its own parameters: a finite difference in one log's
    /// terrain block leaves the other logs' residuals as they were.
    cache: Vec<Mutex<Vec<CacheEntry>>>,
}

const CACHE_PER_LOG: usize = 16;

/// A log's parameter values, with its residuals and their channels there.
type CacheEntry = (Vec<f64>, Vec<f64>, Vec<u8>);

impl JointProblem<'_, '_> {
    fn offset(&self, k: usize) -> usize {
        self.robot.len() + self.terrain[..k].iter().map(Vec::len).sum::<usize>()
    }

    /// Log `k`'s specs and values at `x`.
    fn part(&self, k: usize, x: &[f64]) -> (Vec<ParamSpec>, Vec<f64>) {
        let o = self.offset(k);
        let n = self.terrain[k].len();
        let mut specs = self.robot.clone();
        specs.extend(self.terrain[k].iter().copied());
        let mut v = x[..self.robot.len()].to_vec();
        v.extend_from_slice(&x[o..o + n]);
        (specs, v)
    }

    fn model(&self, k: usize, x: &[f64]) -> Result<ModelParams> {
        let (specs, v) = self.part(k, x);
        self.logs[k].start.with_values(&specs, &v)
    }

    fn log_residuals(&self, k: usize, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>)> {
        let (_, v) = self.part(k, x);
        if let Some(hit) = self.cache[k]
            .lock()
            .ok()?
            .iter()
            .find(|e| e.0 == v)
            .map(|e| (e.1.clone(), e.2.clone()))
        {
            return Some(hit);
        }
        let m = self.model(k, x).ok()?;
        let res = self.logs[k].train.residuals(self.factory, &m).ok()?;
        let (mut r, mut c) = (Vec::new(), Vec::new());
        for s in &res {
            s.flatten_into(&mut r, &mut c);
        }
        let mut cache = self.cache[k].lock().ok()?;
        if cache.len() >= CACHE_PER_LOG {
            cache.remove(0);
        }
        cache.push((v, r.clone(), c.clone()));
        Some((r, c))
    }

    /// Stacked residuals, channels (log `k`'s channel `c` is `k · C + c`) and clusters.
    fn flat(&self, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>, Vec<u32>)> {
        let (mut v, mut ch, mut cl) = (Vec::new(), Vec::new(), Vec::new());
        let mut cluster_base = 0u32;
        for k in 0..self.logs.len() {
            let (r, c) = self.log_residuals(k, x)?;
            // Clusters: the steps, in the order the step set replays them.
            let per_step = static_lengths(self, k, x)?;
            let mut idx = 0usize;
            for (i, n) in per_step.iter().enumerate() {
                cl.extend(std::iter::repeat_n(cluster_base + i as u32, *n));
                idx += n;
            }
            debug_assert_eq!(idx, r.len());
            cluster_base += per_step.len() as u32;
            let off = (k * super::metrics::SCORE_CHANNELS) as u8;
            ch.extend(c.iter().map(|c| c + off));
            v.extend(r);
        }
        Some((v, ch, cl))
    }
}

/// Entries per step of log `k`'s residuals at `x` (fixed by the recording; read once, for the
/// layout's clusters).
fn static_lengths(p: &JointProblem<'_, '_>, k: usize, x: &[f64]) -> Option<Vec<usize>> {
    let m = p.model(k, x).ok()?;
    let res = p.logs[k].train.residuals(p.factory, &m).ok()?;
    Some(
        res.iter()
            .map(|s| {
                let (mut r, mut c) = (Vec::new(), Vec::new());
                s.flatten_into(&mut r, &mut c);
                r.len()
            })
            .collect(),
    )
}

impl JointProblem<'_, '_> {
    fn init_layout(&self, x: &[f64]) -> Option<()> {
        if self.layout.get().is_none() {
            let (_, channel, cluster) = self.flat(x)?;
            let mut floor = Vec::new();
            for l in self.logs {
                floor.extend(l.floor.score_channels());
            }
            let _ = self.layout.set(Layout {
                channel,
                cluster,
                floor,
                min_ratio: MIN_CHANNEL_RATIO,
            });
        }
        Some(())
    }

    fn stacked(&self, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>)> {
        let (mut v, mut ch) = (Vec::new(), Vec::new());
        for k in 0..self.logs.len() {
            let (r, c) = self.log_residuals(k, x)?;
            let off = (k * super::metrics::SCORE_CHANNELS) as u8;
            ch.extend(c.iter().map(|c| c + off));
            v.extend(r);
        }
        Some((v, ch))
    }

    fn specs(&self) -> Vec<ParamSpec> {
        let mut s = self.robot.clone();
        for t in &self.terrain {
            s.extend(t.iter().copied());
        }
        s
    }
}

impl LeastSquares for JointProblem<'_, '_> {
    fn dim(&self) -> usize {
        self.robot.len() + self.terrain.iter().map(Vec::len).sum::<usize>()
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        self.specs().iter().map(|s| (s.lower, s.upper)).collect()
    }
    fn resolution(&self, j: usize) -> Option<f64> {
        self.specs()[j].param.resolution()
    }
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        let (v, c) = self.stacked(x)?;
        (c == self.layout.get()?.channel).then_some(v)
    }
    fn layout(&self) -> &Layout {
        self.layout.get().expect("layout initialised before solving")
    }
}

/// The parameter specs of the joint model for log `start` (its declared model with the union
/// of the selected effects), split into the robot's and the ground's.
fn joint_specs(
    factory: &dyn PlantFactory,
    declared: &ModelParams,
    effects: &[(usize, usize)],
    reach: &CommandReach,
) -> (Vec<ParamSpec>, Vec<ParamSpec>) {
    let mut all = factory.base_params(declared);
    for &(e, p) in effects {
        all.push(ParamSpec::for_effect(e, p, reach));
    }
    // On/off parameters are not in the joint fit: they keep the value each log's own
    // calibration chose.
    all.retain(|s| !s.discrete);
    all.into_iter().partition(|s| !factory.on_terrain(&s.param))
}

/// Runs the joint calibration (see the module doc). `progress` hears a line per stage.
pub fn calibrate_joint(input: &JointInput<'_>, progress: &(dyn Fn(&str) + Sync)) -> Result<JointReport> {
    let logs: Vec<&DriveLog> = input.logs.iter().map(|l| l.log).collect();
    check_one_robot(&logs)?;
    if input.logs.len() < 2 {
        return Err(Error::Analysis(
            "a joint calibration needs at least two logs (one log: `calibrate LOG`)".into(),
        ));
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
    let factory = input.factory;
    let opts = input.opts;
    let mut notes = Vec::new();
    // 1. Every log on its own.
    let mut singles = Vec::new();
    for (k, l) in input.logs.iter().enumerate() {
        progress(&format!(
            "log {}/{} `{}`: its own calibration",
            k + 1,
            input.logs.len(),
            l.log.meta.name
        ));
        let r = super::calibrate(l.log, input.robot, &l.terrain, factory, opts)?;
        progress(&format!(
            "log `{}`: test score {:.3} (declared {:.3}); effects: {}",
            r.dataset,
            r.after.score,
            r.before.score,
            if r.effects.is_empty() {
                "none".into()
            } else {
                r.effects
                    .iter()
                    .map(|e| format!("{}={:.4}", e.name, e.value))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ));
        singles.push(r);
    }
    // 2. The joint model: every effect some log selected.
    let mut effect_params: Vec<(usize, usize)> = Vec::new();
    for r in &singles {
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
        .filter(|&&(e, p)| {
            drive_sim_model::effects::REGISTRY[e].params()[p].kind
                == drive_sim_model::effects::ParamKind::Flag
        })
        .map(|&(e, p)| drive_sim_model::effects::REGISTRY[e].params()[p].key.to_string())
        .collect();
    if !flags.is_empty() {
        notes.push(format!(
            "on/off parameters are not fitted jointly: {} keep each log's own choice (the robot file is the first log's)",
            flags.join(", ")
        ));
    }
    let effects: Vec<String> = {
        let mut v: Vec<String> = effect_params
            .iter()
            .map(|&(e, _)| drive_sim_model::effects::REGISTRY[e].name().to_string())
            .collect();
        v.dedup();
        v
    };
    // Data of each log: its calibration's training steps (or the same seeded subset) and
    // test steps, and its floor.
    let mut slices_all = Vec::new();
    for l in &logs {
        slices_all.push(steps::usable_step_slices(l).0);
    }
    let mut prepared = Vec::new();
    let mut reach = CommandReach {
        wheel_rad_s: 0.0,
        speed_m_s: 0.0,
        yaw_rate_rad_s: 0.0,
    };
    for (k, (l, r)) in logs.iter().zip(&singles).enumerate() {
        let mut fit_steps = r.train_steps.clone();
        if let Some(n) = opts.max_fit_steps.filter(|&n| n < fit_steps.len()) {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            fit_steps.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed));
            fit_steps.truncate(n.max(1));
            fit_steps.sort_unstable();
        }
        let train = StepSet::new(&slices_all[k], &fit_steps, l.meta.rate_hz)?;
        let test = StepSet::new(&slices_all[k], &r.heldout_steps, l.meta.rate_hz)?;
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
    // Specs: the robot block from the first log's declared model, each log's terrain block
    // from its own (the terrain's search boxes scale with its declared friction).
    let mut robot_specs = Vec::new();
    let mut terrain_specs = Vec::new();
    for (k, r) in singles.iter().enumerate() {
        let (rs, ts) = joint_specs(factory, &r.model_before, &effect_params, &reach);
        if k == 0 {
            robot_specs = rs;
        }
        terrain_specs.push(ts);
    }
    // Start: each log from its own calibrated model; the shared values from the median of
    // the logs' own fits (inside the box) among the logs that fitted them (an effect off in a
    // log is no evidence of its value).
    let mut x0 = Vec::new();
    for s in &robot_specs {
        let fitted: Vec<f64> = singles
            .iter()
            .filter_map(|r| {
                super::twin::fitted_params(r)
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
    for (p, ts) in prepared.iter().zip(&terrain_specs) {
        for s in ts {
            x0.push(s.start_in(&p.start));
        }
    }
    let problem = JointProblem {
        logs: &prepared,
        factory,
        robot: robot_specs.clone(),
        terrain: terrain_specs.clone(),
        layout: OnceLock::new(),
        cache: (0..prepared.len()).map(|_| Mutex::new(Vec::new())).collect(),
    };
    progress(&format!(
        "joint fit: {} robot parameters ({}), {} per log ({}), {} logs",
        robot_specs.len(),
        robot_specs
            .iter()
            .map(|s| s.param.name())
            .collect::<Vec<_>>()
            .join(", "),
        terrain_specs.first().map_or(0, Vec::len),
        terrain_specs
            .first()
            .map(|t| t.iter().map(|s| s.param.name()).collect::<Vec<_>>().join(", "))
            .unwrap_or_default(),
        prepared.len()
    ));
    if problem.init_layout(&x0).is_none() {
        return Err(Error::Analysis(
            "the joint model could not be evaluated at its start (every log's own calibrated model)".into(),
        ));
    }
    let initial_score = (problem
        .layout()
        .log_score(&problem.residuals(&x0).unwrap_or_default()))
    .exp();
    // Every log's own fit already met the standard-error criterion at its own values; the
    // joint start is not a minimum of the joint score, and on the measured Warthog runs the
    // criterion stopped the joint fit at its start: the joint fit stops on the gradient,
    // reduction and step criteria only.
    let lm_opts = lm::LmOptions {
        se_fraction: 0.0,
        ..opts.fit.lm
    };
    let sol = lm::minimize(&problem, &x0, &lm_opts, &mut |_| {});
    let specs = problem.specs();
    let names: Vec<String> = {
        let mut n: Vec<String> = robot_specs.iter().map(|s| s.param.name()).collect();
        for (l, ts) in logs.iter().zip(&terrain_specs) {
            n.extend(ts.iter().map(|s| format!("{}@{}", s.param.name(), l.meta.name)));
        }
        n
    };
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
        params: params.clone(),
        initial_score,
        score: sol.score,
        evaluations: sol.evaluations as u64,
        converged: sol.stop.converged(),
        status: sol.stop.describe().to_string(),
        stop: Some(sol.stop.clone()),
        iterations: sol.iterations as u64,
        covariance,
    };
    progress(&format!(
        "joint fit: training score {:.3} → {:.3} ({}, {} evaluations)",
        fit.initial_score, fit.score, fit.status, fit.evaluations
    ));
    if !fit.converged {
        notes.push(format!("joint fit did not converge: {}", fit.status));
    }
    let robot_params: Vec<FittedParam> = params[..robot_specs.len()].to_vec();
    // 4. Each log's test score at the joint solution.
    let mut results = Vec::new();
    for (k, (l, r)) in logs.iter().zip(&singles).enumerate() {
        let model = problem.model(k, &sol.x)?;
        let p = &prepared[k];
        let joint = ErrorSummary::pool(&p.test.errors(factory, &model)?, &p.floor);
        let o = problem.offset(k);
        let terrain_params = params[o..o + terrain_specs[k].len()]
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
    Ok(JointReport {
        robot: input.robot.name.clone(),
        model_kind: factory.name(),
        singles,
        effects,
        robot_param_names: robot_specs.iter().map(|s| s.param.name()).collect(),
        terrain_param_names: terrain_specs
            .first()
            .map(|t| t.iter().map(|s| s.param.name()).collect())
            .unwrap_or_default(),
        fit,
        robot_params,
        logs: results,
        notes,
        reproduce: String::new(),
    })
}

/// The twin of a joint simulator calibration: one robot file, one terrain file per log
/// ([`terrain_file_name`]), each value commented with the datasets it was fitted on.
pub fn joint_twin(report: &JointReport) -> Result<(String, Vec<(String, String)>)> {
    if report.model_kind != "simulator" {
        return Err(Error::Analysis(format!(
            "a twin comes from a simulator calibration; this one fitted the {} model",
            report.model_kind
        )));
    }
    let all: Vec<&str> = report.logs.iter().map(|l| l.dataset.as_str()).collect();
    let header = vec![
        format!(
            "Twin calibrated by drive-sim jointly on {} logs of `{}` ({}), simulator model.",
            all.len(),
            report.robot,
            all.join(", ")
        ),
        format!("Reproduce: {}", report.reproduce),
        "[fit] comments: fitted value, standard error (clustered sandwich over every log's training steps) and 95 % interval.".into(),
    ];
    let mut robot_toml = String::new();
    let mut terrains = Vec::new();
    for (k, l) in report.logs.iter().enumerate() {
        let mut fitted: Vec<(FittedParam, String)> = report
            .robot_params
            .iter()
            .map(|p| (p.clone(), all.join(" + ")))
            .collect();
        fitted.extend(l.terrain_params.iter().map(|p| (p.clone(), l.dataset.clone())));
        let mut h = header.clone();
        h.push(format!(
            "This log's test score {:.3} (its own calibration {:.3}; 1 = noise floor) on {} held-out steps.",
            l.joint.score,
            l.single_score,
            l.test_steps.len()
        ));
        let prov = twin::Provenance {
            header: h,
            fitted,
            before: Some(report.singles[k].model_before.clone()),
            chosen: Vec::new(),
        };
        let files = twin::twin_files(&l.model, &prov)?;
        if k == 0 {
            robot_toml = files.robot_toml;
        }
        terrains.push((l.terrain_file.clone(), files.terrain_toml));
    }
    Ok((robot_toml, terrains))
}

/// Runs each log's twin of a joint simulator calibration (the robot with that log's terrain) in
/// closed loop ([`twin::check_twin`], seed `seed`), records it in the log's `twin_check` and
/// names a twin that does not run in the report's notes. Returns the datasets whose twin did
/// not run.
pub fn check_joint_twin(report: &mut JointReport, seed: u64) -> Result<Vec<String>> {
    let mut failed = Vec::new();
    for l in &mut report.logs {
        let (robot, terrain) = twin::twin_models(&l.model)?;
        let check = twin::check_twin(&robot, &terrain, twin::TWIN_CHECK_STEPS, seed)?;
        if let Some(note) = check.failure_note() {
            report.notes.push(format!("twin check ({}): {note}", l.dataset));
            failed.push(l.dataset.clone());
        }
        l.twin_check = Some(check);
    }
    Ok(failed)
}

/// Writes `dir/calibration.json` (the joint report), each log's own calibration in
/// `dir/<dataset>/` (as `calibrate LOG` writes it), and for a simulator model the twin in
/// `dir/twin/`: `robot.toml` and one `terrain_<dataset>.toml` per log. Returns the paths.
pub fn write_joint(report: &JointReport, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut paths = Vec::new();
    let json_path = dir.join("calibration.json");
    let json = serde_json::to_string_pretty(report)
        .map_err(|e| Error::Analysis(format!("cannot serialize the joint report: {e}")))?;
    std::fs::write(&json_path, json).map_err(|e| Error::io(&json_path, e))?;
    paths.push(json_path);
    for r in &report.singles {
        paths.extend(super::write_report(r, &dir.join(&r.dataset))?);
    }
    if report.model_kind == "simulator" {
        let (robot, terrains) = joint_twin(report)?;
        let tdir = dir.join("twin");
        std::fs::create_dir_all(&tdir).map_err(|e| Error::io(&tdir, e))?;
        let p = tdir.join("robot.toml");
        std::fs::write(&p, robot).map_err(|e| Error::io(&p, e))?;
        paths.push(p);
        for (name, text) in terrains {
            let p = tdir.join(name);
            std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
            paths.push(p);
        }
    }
    Ok(paths)
}
