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
//! [`calibrate_logs`] is what `drive-sim calibrate LOG...` runs, from the files named in a
//! [`CalibrateRequest`] to the files written (one log alone, several jointly: [`joint`]); every
//! stage tells its caller what it found as a [`CalibrationEvent`].
//!
//! Which steps each field of [`CalibrationReport`] is computed on: `floor`, `terrain_fit`,
//! every fitted value and interval: training; `rounds`, `pairs`, `backward`, `screening`
//! (their `heldout_*` fields) and whether a fit was kept: validation; `idd`, `before`,
//! `after_terrain`, `after`, `table`, `step_scores`, `total_reduction`, the residual
//! analyses: test. `twin_check` uses no step of the log: it is the twin's own closed-loop
//! DRIVE run ([`twin::check_twin`]).
//!
//! ```no_run
//! use drive_sim_calibration::{calibrate, CalibrationOptions, KinematicFactory};
//! use drive_sim_model::{robot::Robot, terrain::Terrain};
//!
//! let log = drive_sim_log::read_log(std::path::Path::new("warthog_gravel.csv"))?;
//! let robot = Robot::resolve("warthog")?.0;
//! let terrain = Terrain::resolve("gravel")?.0;
//! // The grey-box kinematic model (fast); `SimFactory` replays on the rapier simulator.
//! let report = calibrate(&log, &robot, &terrain, &KinematicFactory, &CalibrationOptions::default())?;
//! for p in &report.effects {
//!     println!("{} = {:.3} (searched in [{:.3}, {:.3}])", p.name, p.value, p.lower, p.upper);
//! }
//! // Scores on test steps no choice saw: the declared model against the calibrated one.
//! println!("steady vx error {:.3} -> {:.3} m/s", report.before.steady_vx_m_s, report.after.steady_vx_m_s);
//! # Ok::<(), drive_sim_calibration::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod error;
pub use error::{Error, Result};

pub mod data;
pub mod diagnosis;
pub mod discovery;
pub mod events;
pub mod figures;
pub mod fit;
pub mod joint;
pub mod metrics;
pub mod model;
mod output;
pub mod params;
mod pipeline;
pub mod replay;
mod request;
pub mod residual;
pub mod solver;
pub mod stages;
pub mod steps;
pub mod surface;
pub mod surrogate;
pub mod to_dir;
pub mod twin;

pub use data::{split_steps, Split, StepSet};
pub use events::{CalibrationEvent, RoundOutcome};
pub use fit::{FitOptions, FitResult, FittedParam, Optimizer};
pub use metrics::{ErrorSummary, NoiseFloor};
pub use model::{IddFactory, KinematicFactory, ModelParams, PlantFactory, SimFactory};
pub use output::{
    fitted_terrain_toml, write_report, write_timings, CalibrationReport, CalibrationStatus,
    DeclaredEffectCheck, StepScores, TableRow,
};
pub use params::{Param, ParamSpec};
pub use pipeline::{calibrate, calibrate_timed};
pub use replay::{replay_log, ReplayOptions};
pub use request::{calibrate_logs, CalibrateRequest, Calibrated, JointOutcome};
pub use residual::ResidualAnalysis;
pub use solver::lm::LmOptions;
pub use solver::nelder_mead::NmOptions;
pub use stages::candidates::{Candidate, CandidateEvidence, SelectionRule};
pub use stages::screening::ScreeningReport;
pub use stages::selection::{BackwardStep, SelectionRound};
pub use stages::{StageTiming, Timings};
pub use to_dir::{
    calibrate_into, replay_into, CalibrateLogRequest, CalibrateOutcome, ReplayOutcome, ReplayRequest,
    StartingModels,
};

use drive_sim_log::DriveLog;
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use serde::{Deserialize, Serialize};
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
    if let Some(k) = n.command_turn_scale {
        robot.limits.command_turn_scale = k;
    }
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
            _ => Err(Error::from(drive_sim_model::Error::Unknown {
                kind: "model",
                name: name.to_string(),
                available: Self::NAMES.join(", "),
            })),
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
            // As the calibration's own test set: its steps start from any step's end.
            let set = StepSet::after(&slices, &s.steps, &ids, log.meta.rate_hz)?;
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
