//! Closing the loop with measured data: how far the simulator is from the robot, which effect
//! the model lacks, and how much adding it closes the gap, on steps no choice ever saw.
//!
//! [`calibrate`] runs the loop on a [`DriveLog`] as stages ([`stages`]):
//! 1. split the steps into training, validation and test sets (seeded, spread over the
//!    command space, [`data::split_steps`]); estimate the noise floor and the command reach
//!    on the training steps;
//! 2. baseline: the IDD and the declared model; the base (terrain / robot) parameters fitted
//!    on the training steps, kept if they lower the validation score;
//! 3. screening (simulator model): candidates the kinematic model can represent are fitted
//!    and ranked with it; the best few and the contact effects go on;
//! 4. each candidate fitted on the training steps by Levenberg–Marquardt on the project's
//!    score ([`solver`]), judged on the validation steps (reduction beyond two bootstrap
//!    standard errors, identifiable parameters); forward selection, pairs, backward pass;
//! 5. the final joint fit with the clustered covariance of every parameter;
//! 6. every reported score (IDD, before, after, per channel) on the test steps, which
//!    nothing else touched.
//!
//! Nothing reads what a log says was injected: the effects are found from the data alone.
//!
//! Which steps each field of [`CalibrationReport`] is computed on: `floor`, `terrain_fit`,
//! every fitted value and interval: training; `rounds`, `pairs`, `backward`, `screening`
//! (their `heldout_*` fields) and whether a fit was kept: validation; `idd`, `before`,
//! `after_terrain`, `after`, `table`, `step_scores`, `total_reduction`, the residual
//! analyses: test. `twin_check` uses no step of the log: it is the twin's own closed-loop
//! DRIVE run ([`twin::check_twin`]).

pub mod data;
pub mod diagnosis;
pub mod discovery;
pub mod figures;
pub mod fit;
pub mod joint;
pub mod metrics;
pub mod model;
mod output;
pub mod params;
pub mod replay;
pub mod residual;
pub mod solver;
pub mod stages;
pub mod steps;
pub mod surrogate;
pub mod to_dir;
pub mod twin;

pub use data::{split_steps, Split, StepSet};
pub use fit::{FitOptions, FitResult, FittedParam, Optimizer};
pub use metrics::{ErrorSummary, NoiseFloor};
pub use model::{IddFactory, KinematicFactory, ModelParams, PlantFactory, SimFactory};
pub use output::{
    fitted_terrain_toml, write_report, write_timings, CalibrationReport, CalibrationStatus,
    DeclaredEffectCheck, StepScores, TableRow,
};
pub use params::{Param, ParamSpec};
pub use replay::{replay_log, ReplayOptions};
pub use residual::ResidualAnalysis;
pub use solver::lm::LmOptions;
pub use solver::nelder_mead::NmOptions;
pub use stages::candidates::{Candidate, CandidateEvidence, SelectionRule};
pub use stages::screening::ScreeningReport;
pub use stages::selection::{BackwardStep, SelectionRound};
pub use stages::{StageTiming, Timings};
pub use to_dir::{
    calibrate_into, replay_into, CalibrateOutcome, CalibrateRequest, ReplayOutcome, ReplayRequest,
    StartingModels,
};

use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use drive_sim_model::error::{Error, Result};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use serde::{Deserialize, Serialize};
use stages::{baseline, candidates, final_fit, report, screening, selection, Context};
use std::path::{Path, PathBuf};

/// Options of [`calibrate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationOptions {
    /// Seed of the train / validation / test split and of the bootstraps.
    pub seed: u64,
    /// Fraction of the steps used for fitting.
    pub train_fraction: f64,
    /// Fraction of the steps used to choose between models; the test set takes the rest.
    #[serde(default = "default_validation_fraction")]
    pub validation_fraction: f64,
    /// Fit on at most this many training steps (a seeded subset; all when `None`). Estimates
    /// from data (floor, reach) still use all the training steps.
    pub max_fit_steps: Option<usize>,
    /// Solver and budgets of every fit.
    #[serde(default)]
    pub fit: FitOptions,
    /// Most effects added.
    pub max_effects: usize,
    /// When an effect counts as an improvement.
    pub rule: SelectionRule,
    /// Only these candidate effects (every registered effect the plant can run when `None`).
    pub candidates: Option<Vec<String>>,
    /// Simulator model: candidates kept after screening with the kinematic model (the
    /// contact effects, which it cannot represent, are always kept).
    #[serde(default = "default_screen_keep")]
    pub screen_keep: usize,
    /// Pairs are tried among this many top candidates after the forward pass (0: none).
    #[serde(default = "default_pair_top")]
    pub pair_top: usize,
    /// Forward rounds after the first re-rank only this many of the first round's best
    /// (0: all).
    #[serde(default = "default_rerank_top")]
    pub rerank_top: usize,
    /// After selection, look for what the catalogue lacks: diagnose the residual, discover
    /// equations in it and try them as model terms ([`stages::discovery`]).
    #[serde(default = "default_discover")]
    pub discover: bool,
    /// Grid resolution of the residual maps (m/s and rad/s).
    pub grid_step: f64,
    /// Kernel variance of the residual maps; the paper's for the robot when `None`
    /// ([`drive_sim_analysis::smoother::KernelCovariance::paper_variance`]).
    pub kernel_var: Option<f64>,
}

fn default_validation_fraction() -> f64 {
    0.2
}
fn default_discover() -> bool {
    true
}

fn default_screen_keep() -> usize {
    3
}
fn default_pair_top() -> usize {
    4
}
fn default_rerank_top() -> usize {
    6
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            seed: 0,
            train_fraction: 0.6,
            validation_fraction: default_validation_fraction(),
            max_fit_steps: None,
            fit: FitOptions::default(),
            max_effects: 3,
            rule: SelectionRule::default(),
            candidates: None,
            screen_keep: default_screen_keep(),
            pair_top: default_pair_top(),
            rerank_top: default_rerank_top(),
            discover: default_discover(),
            grid_step: 0.1,
            kernel_var: None,
        }
    }
}

/// The robot and terrain a log declares: the robot file named by the log with the operators'
/// nominal wheel radius, baseline and wheel-speed limit, and the terrain file of the same name
/// (the returned notes say when a terrain had to be assumed).
pub fn models_for_log(log: &DriveLog) -> Result<(Robot, Terrain, Vec<String>)> {
    let (mut robot, _) = Robot::resolve(&log.meta.robot)?;
    let n = &log.meta.nominal;
    robot.wheels.radius_m = n.wheel_radius_m;
    robot.wheels.baseline_m = n.baseline_m;
    robot.powertrain.max_wheel_rad_s = n.max_wheel_rad_s;
    let mut notes = Vec::new();
    let file = match &log.meta.origin {
        drive_sim_log::Origin::Measured { file } => std::path::PathBuf::from(file),
        _ => std::path::PathBuf::from(&log.meta.name),
    };
    let (terrain, warning) = drive_sim_log::terrain_of_log(&log.meta, &file)?;
    notes.extend(warning);
    Ok((robot, terrain, notes))
}

/// The robot and terrain to start from: `robot` / `terrain` (names or TOML files, e.g. a
/// twin's) when given, used as written, else the log's own ([`models_for_log`]). The notes
/// say what was chosen; a robot of another name than the log's is refused (its nominal values
/// would not be the ones the commands were computed with).
pub fn models_for(
    log: &DriveLog,
    robot: Option<&str>,
    terrain: Option<&str>,
) -> Result<(Robot, Terrain, Vec<String>)> {
    let (mut r, mut t, mut notes) = models_for_log(log)?;
    if let Some(name) = robot {
        let (given, file) = Robot::resolve(name)?;
        if given.name != log.meta.robot {
            return Err(Error::config(
                file,
                "name",
                format!(
                    "robot `{}` is not the log's robot `{}` ({})",
                    given.name, log.meta.robot, log.meta.name
                ),
            ));
        }
        notes.push(format!("robot from {}", file.display()));
        r = given;
    }
    if let Some(name) = terrain {
        let (given, file) = Terrain::resolve(name)?;
        notes.retain(|n| !n.starts_with("terrain `"));
        notes.push(format!("terrain from {}", file.display()));
        t = given;
    }
    Ok((r, t, notes))
}

/// Runs the calibration loop (see the module doc) of the plant `factory` builds, starting
/// from `robot` and `terrain`, on `log`.
pub fn calibrate(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
) -> Result<CalibrationReport> {
    calibrate_timed(log, robot, terrain, factory, opts, &|_| {}).map(|(r, _)| r)
}

/// [`calibrate`], telling `progress` in a line what each stage found as it ends, and
/// returning the per-stage timings.
pub fn calibrate_timed(
    log: &DriveLog,
    robot: &Robot,
    terrain: &Terrain,
    factory: &dyn PlantFactory,
    opts: &CalibrationOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<(CalibrationReport, Timings)> {
    let mut timings = Timings::default();
    let name = &log.meta.name;
    // Everything that can be checked is checked before any replay.
    let (slices, excluded) = steps::usable_step_slices(log);
    for e in &excluded {
        progress(&format!("step {} excluded: {}", e.step, e.reason));
    }
    let commands: Vec<(u32, drive_sim_model::kinematics::WheelSpeeds)> = slices
        .iter()
        .map(|s| {
            let n = s.samples.len().max(1) as f64;
            let (l, r) = s.samples.iter().fold((0.0, 0.0), |a, x| {
                (a.0 + x.m.cmd.left_rad_s, a.1 + x.m.cmd.right_rad_s)
            });
            (
                s.step,
                drive_sim_model::kinematics::WheelSpeeds::new(l / n, r / n),
            )
        })
        .collect();
    let split = split_steps(
        name,
        &commands,
        opts.train_fraction,
        opts.validation_fraction,
        opts.seed,
    )?;
    let rate = log.meta.rate_hz;
    let train_all = StepSet::new(&slices, &split.train, rate)?;
    let floor = NoiseFloor::estimate(&train_all.features)
        .map_err(|e| Error::Analysis(format!("`{name}`: no noise floor from its training steps: {e}")))?;
    if floor.steps_used == 0 {
        return Err(Error::Analysis(format!(
            "`{name}`: no training step has two steady windows, so the steady channels have no              noise floor estimate (the floor compares the two steady windows of each step)"
        )));
    }
    let reach = CommandReach::of_commands(
        train_all.steps.iter().flat_map(|s| s.samples).map(|s| s.m.cmd),
        &robot.idd(),
    );
    let mut notes = Vec::new();
    let train = match opts.max_fit_steps {
        Some(k) if k < split.train.len() => {
            let mut sub = split.train.clone();
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            sub.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed));
            sub.truncate(k.max(1));
            sub.sort_unstable();
            notes.push(format!(
                "fits on {} of {} training steps",
                sub.len(),
                split.train.len()
            ));
            StepSet::new(&slices, &sub, rate)?
        }
        _ => train_all,
    };
    // A robot or terrain file's own effects (a twin's) are the starting model's effects.
    let declared = twin::lift_effects(robot, terrain)?;
    let (mut pool, not_evaluated) = candidates::candidates_for(factory, &reach, opts.candidates.as_deref());
    // A declared effect is refit as a base parameter and judged, not proposed again.
    let declared_on = candidates::declared_effects(&declared);
    pool.retain(|c| !c.effects.iter().any(|e| declared_on.contains(e)));
    if let Some(only) = &opts.candidates {
        for n in only {
            if drive_sim_model::effects::effect(n).is_none() {
                return Err(Error::Unknown {
                    kind: "candidate effect",
                    name: n.clone(),
                    available: drive_sim_model::effects::REGISTRY
                        .iter()
                        .map(|e| e.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
    }
    let ctx = Context {
        log,
        factory,
        opts,
        validation: StepSet::new(&slices, &split.validation, rate)?,
        test: StepSet::new(&slices, &split.test, rate)?,
        train,
        split,
        floor,
        reach,
        declared: declared.clone(),
        excluded,
        progress,
    };
    progress(&format!(
        "split of {} steps: {} train, {} validation, {} test (seed {})",
        slices.len(),
        ctx.split.train.len(),
        ctx.split.validation.len(),
        ctx.split.test.len(),
        opts.seed
    ));
    let mut base_specs = factory.base_params(&declared);
    base_specs.extend(candidates::declared_specs(&declared, &reach));
    let baseline = timings.time("baseline", || {
        baseline::run(
            &ctx,
            baseline::BaselineInput {
                declared: &declared,
                specs: &base_specs,
            },
        )
    })?;
    // The kinematic model is cheap enough to refit the base parameters beside every
    // candidate; the simulator screens with it and fits effects with the time constant only,
    // then refits jointly.
    let screened = factory.name() == "simulator" && opts.screen_keep > 0;
    let (screening, pool, refit) = if screened {
        let out = timings.time("screening", || {
            screening::run(
                &ctx,
                screening::ScreeningInput {
                    candidates: &pool,
                    declared: &declared,
                },
            )
        })?;
        // Beside each effect the simulator refits the wheel loop's time constant only: the
        // base parameter that stands in for powertrain effects (a slower loop for a dead time);
        // the terrain's are refit jointly once an effect is added.
        let refit: Vec<ParamSpec> = base_specs
            .iter()
            .filter(|p| p.param == Param::TimeConstant)
            .copied()
            .collect();
        (Some(out.report), (out.shortlist, Some(out.pairs)), refit)
    } else {
        (None, (pool, None), base_specs.clone())
    };
    let (pool, screened_pairs) = pool;
    let refit_for_discovery = refit.clone();
    let selection = timings.time("selection", || {
        selection::run(
            &ctx,
            selection::SelectionInput {
                current: baseline.current.clone(),
                current_validation: baseline.current_validation.clone(),
                pool,
                refit,
                pairs: screened_pairs,
                base: if baseline.base_fit_kept {
                    base_specs.clone()
                } else {
                    Vec::new()
                },
            },
        )
    })?;
    let mut selection = selection;
    let discovery = if opts.discover {
        let out = timings.time("discovery", || {
            stages::discovery::run(
                &ctx,
                stages::discovery::DiscoveryInput {
                    current: selection.current.clone(),
                    current_validation: selection.current_validation.clone(),
                    selected: selection.selected.clone(),
                    refit: refit_for_discovery.clone(),
                },
            )
        })?;
        if out.added {
            selection.current = out.current;
            selection.current_validation = out.current_validation;
            selection.selected = out.selected;
            selection.refit_current = false;
        }
        Some(out.report)
    } else {
        None
    };
    let final_fit = timings.time("final fit", || {
        final_fit::run(
            &ctx,
            final_fit::FinalFitInput {
                current: &selection.current,
                current_validation: &selection.current_validation,
                selected: &selection.selected,
                base: &base_specs,
                base_fit_kept: baseline.base_fit_kept,
                already_fitted: selection.refit_current,
            },
        )
    })?;
    let mut report = timings.time("report", || {
        report::run(
            &ctx,
            report::ReportInput {
                baseline,
                screening,
                selection,
                final_fit,
                not_evaluated,
                notes,
            },
        )
    })?;
    timings.time("diagnosis", || -> Result<()> {
        let idd = robot.idd();
        for (model, slot) in [
            (&report.model_before, &mut report.diagnosis_before),
            (&report.model_after, &mut report.diagnosis_after),
        ] {
            let r = ctx.test.residuals(factory, model)?;
            *slot = Some(diagnosis::diagnose(&r, &ctx.test.features, &ctx.floor, &idd));
        }
        Ok(())
    })?;
    report.discovery = discovery;
    Ok((report, timings))
}

/// Which plant to calibrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelKind {
    /// The rapier simulator ([`SimFactory`]).
    Simulator,
    /// The kinematic grey-box model ([`KinematicFactory`]): seconds instead of minutes.
    Kinematic,
}

impl ModelKind {
    /// Names accepted by [`ModelKind::parse`].
    pub const NAMES: &'static [&'static str] = &["simulator", "kinematic"];

    /// Parses a model name (for the CLI).
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "simulator" | "sim" => Ok(Self::Simulator),
            "kinematic" => Ok(Self::Kinematic),
            _ => Err(Error::Unknown {
                kind: "model",
                name: name.to_string(),
                available: Self::NAMES.join(", "),
            }),
        }
    }

    /// The factory of this model.
    pub fn factory(self) -> Box<dyn PlantFactory> {
        match self {
            Self::Simulator => Box::new(SimFactory::default()),
            Self::Kinematic => Box::new(KinematicFactory),
        }
    }
}

/// Reads a measured dataset (CSV + sibling JSON) and calibrates `kind` on it, starting from the
/// robot and terrain the log declares ([`models_for_log`]; their notes go to the report).
/// What `drive-sim calibrate MEASURED` runs.
pub fn calibrate_file(csv: &Path, kind: ModelKind, opts: &CalibrationOptions) -> Result<CalibrationReport> {
    let log = drive_sim_log::csv::read_measured_csv(csv)?;
    let (robot, terrain, notes) = models_for_log(&log)?;
    let mut report = calibrate(&log, &robot, &terrain, kind.factory().as_ref(), opts)?;
    report.status.notes.splice(0..0, notes);
    report.reproduce = format!(
        "drive-sim calibrate {} --model {} --seed {} --out <DIR>",
        csv.display(),
        ModelKind::NAMES[kind as usize],
        opts.seed
    );
    Ok(report)
}

/// A replay of a whole log and how far it is from the recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplayComparison {
    /// The replayed log (same steps, windows and sampling as the recording).
    pub replayed: DriveLog,
    /// Error of the replay over all steps.
    pub model: ErrorSummary,
    /// Error of the IDD over all steps.
    pub idd: ErrorSummary,
    /// Noise floor of the recording.
    pub floor: ErrorSummary,
    /// Error of the replay on a calibration's test steps, scored with that calibration's
    /// noise floor (what its `after` reports for the calibrated model), when asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub test: Option<ErrorSummary>,
}

/// Steps to score a replay on the way a calibration scored its model: its test steps and the
/// noise floor of its training steps.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreSteps {
    /// Test steps.
    pub steps: Vec<u32>,
    /// Noise floor the scores are relative to.
    pub floor: NoiseFloor,
}

/// The fields of a `calibration.json` that [`ScoreSteps`] reads (the whole report does not
/// read back: JSON has no infinity, so some of its numbers are written as null).
#[derive(Deserialize)]
struct ScoreStepsJson {
    heldout_steps: Vec<u32>,
    floor: NoiseFloor,
}

impl ScoreSteps {
    /// The test steps and floor of a `calibration.json` (`file` names it in errors).
    pub fn from_json(text: &str, file: &Path) -> Result<Self> {
        let r: ScoreStepsJson = serde_json::from_str(text)
            .map_err(|e| Error::config(file, "heldout_steps / floor", e.to_string()))?;
        Ok(Self {
            steps: r.heldout_steps,
            floor: r.floor,
        })
    }

    /// The test steps and floor of a calibration report.
    pub fn of_report(r: &CalibrationReport) -> Self {
        Self {
            steps: r.heldout_steps.clone(),
            floor: r.floor.clone(),
        }
    }
}

/// Replays every step of `log` on the declared model `kind` (no fit) and compares it with the
/// recording, beside the IDD and the noise floor. What `drive-sim replay MEASURED` runs.
pub fn replay_and_compare(log: &DriveLog, kind: ModelKind) -> Result<ReplayComparison> {
    let (robot, terrain, _) = models_for_log(log)?;
    replay_model_and_compare(log, &twin::lift_effects(&robot, &terrain)?, kind, None)
}

/// Replays every step of `log` on `params` (e.g. a twin's files, [`twin::lift_effects`]) with
/// the plant `kind`, compares it with the recording beside the IDD and the noise floor and,
/// with `score`, also on a calibration's test steps.
pub fn replay_model_and_compare(
    log: &DriveLog,
    params: &ModelParams,
    kind: ModelKind,
    score: Option<&ScoreSteps>,
) -> Result<ReplayComparison> {
    let factory = kind.factory();
    let (slices, _) = steps::usable_step_slices(log);
    let ids: Vec<u32> = slices.iter().map(|s| s.step).collect();
    let all = StepSet::new(&slices, &ids, log.meta.rate_hz)?;
    let floor = NoiseFloor::estimate(&all.features)?;
    let model = ErrorSummary::pool(&all.errors(factory.as_ref(), params)?, &floor);
    let idd = ErrorSummary::pool(&all.errors(&IddFactory, params)?, &floor);
    let test = match score {
        Some(s) => {
            if let Some(missing) = s.steps.iter().find(|id| !ids.contains(id)) {
                return Err(Error::log(
                    &log.meta.name,
                    format!("step {missing}"),
                    "the calibration's test step is not in this log (was it calibrated on another log?)",
                ));
            }
            let set = StepSet::new(&slices, &s.steps, log.meta.rate_hz)?;
            Some(ErrorSummary::pool(
                &set.errors(factory.as_ref(), params)?,
                &s.floor,
            ))
        }
        None => None,
    };
    let replayed = replay_log(log, factory.as_ref(), params, &ReplayOptions::default())?;
    Ok(ReplayComparison {
        replayed,
        model,
        idd,
        floor: ErrorSummary::floor(&floor),
        test,
    })
}
