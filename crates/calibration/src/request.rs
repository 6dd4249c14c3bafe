//! A calibration as `drive-sim calibrate LOG...` asks for it, from plain values (files, names,
//! options) to the files written and the report the caller prints: one log is calibrated
//! alone ([`crate::calibrate_into`]), several jointly ([`crate::joint`]). Every input is checked
//! and the output folder staged before any long work; the folder appears whole, or not at all.

use crate::error::{Error, Result};
use crate::events::CalibrationEvent;
use crate::joint::{self, JointInput, JointLog, JointReport};
use crate::to_dir::{calibrate_into, CalibrateLogRequest, CalibrateOutcome, StartingModels};
use crate::{models_for, CalibrationOptions, ModelKind, Optimizer};
use drive_sim_log::{DriveLog, OpenOptions, UseSteps};
use drive_sim_model::output::StagedDir;
use std::path::{Path, PathBuf};

/// What to calibrate and how, as plain values (what the command line gives).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateRequest {
    /// The logs (measured `.csv`, simulated `.mcap` or bags): one is calibrated alone, several
    /// jointly (one robot, a terrain per log).
    pub logs: Vec<PathBuf>,
    /// Output directory.
    pub out: PathBuf,
    /// How to open the logs, and the robot and terrain (names or files) the models start from
    /// (`--robot`, `--terrain`, `--roles`).
    pub input: OpenOptions,
    /// Model calibrated, as named ([`ModelKind::parse`]).
    pub model: String,
    /// Local solver, as named ([`Optimizer::parse`]).
    pub optimizer: String,
    /// Seed of the train / validation / test split and of the bootstraps.
    pub seed: u64,
    /// Most effects added.
    pub max_effects: usize,
    /// Fit on at most this many training steps per evaluation (all when `None`).
    pub max_fit_steps: Option<usize>,
    /// Only these candidate effects (registry names).
    pub candidates: Option<Vec<String>>,
    /// The steps calibrated on (the odd or even ones, or all).
    pub use_steps: UseSteps,
    /// Look for what the catalogue lacks by equation discovery after the selection.
    pub discover: bool,
}

/// What [`calibrate_logs`] found and wrote.
#[derive(Debug)]
pub enum Calibrated {
    /// One log calibrated alone.
    Single(Box<CalibrateOutcome>),
    /// Several logs calibrated jointly.
    Joint(Box<JointOutcome>),
}

/// What a joint calibration found and wrote.
#[derive(Debug)]
pub struct JointOutcome {
    /// The report (also in `calibration.json`).
    pub report: JointReport,
    /// Datasets whose twin does not run its own DRIVE (simulator model; in the report's
    /// notes too).
    pub failed_twins: Vec<String>,
    /// Every file written, in the output directory.
    pub files: Vec<PathBuf>,
}

impl CalibrateRequest {
    /// The calibration's options: the defaults, with this request's seed, budgets, candidates,
    /// discovery and local solver (refused when unknown).
    pub fn options(&self) -> Result<CalibrationOptions> {
        let mut opts = CalibrationOptions {
            seed: self.seed,
            max_effects: self.max_effects,
            max_fit_steps: self.max_fit_steps,
            candidates: self.candidates.clone(),
            discover: self.discover,
            ..CalibrationOptions::default()
        };
        opts.fit.optimizer = Optimizer::parse(&self.optimizer)?;
        Ok(opts)
    }

    /// The command line that reproduces this calibration (`calibration.json` → `reproduce`).
    pub fn reproduce(&self) -> String {
        format!(
            "drive-sim calibrate {} --model {} --seed {} --max-effects {} --optimizer {} --use-steps {} --out {}",
            self.logs
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(" "),
            self.model,
            self.seed,
            self.max_effects,
            self.optimizer,
            self.use_steps.as_str(),
            self.out.display()
        )
    }

    /// The options recorded in the provenance of `calibration.json`, as given.
    fn provenance_options(&self) -> serde_json::Value {
        serde_json::json!({
            "model": self.model,
            "seed": self.seed,
            "max_effects": self.max_effects,
            "max_fit_steps": self.max_fit_steps,
            "optimizer": self.optimizer,
            "candidates": self.candidates,
            "use_steps": self.use_steps.as_str(),
            "robot": self.input.robot,
            "terrain": self.input.terrain,
            "roles": self.input.roles,
        })
    }
}

/// Runs the calibration `req` asks for and writes its files into `req.out`: one log alone, or
/// several jointly. `progress` hears what is read and what each stage found.
pub fn calibrate_logs(
    req: &CalibrateRequest,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<Calibrated> {
    match req.logs.as_slice() {
        [] => Err(Error::config("<command line>", "logs", "no log to calibrate")),
        [log] => calibrate_one(req, log, progress).map(|o| Calibrated::Single(Box::new(o))),
        _ => calibrate_jointly(req, progress).map(|o| Calibrated::Joint(Box::new(o))),
    }
}

/// Opens `path`, telling `progress` how it was read and what was left out.
fn open_log(
    path: &Path,
    req: &CalibrateRequest,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<DriveLog> {
    progress(&CalibrationEvent::Reading {
        path: path.to_path_buf(),
    });
    let opened = drive_sim_log::open(path, &req.input)?;
    for note in opened.notes {
        progress(&CalibrationEvent::Note { note });
    }
    for warning in opened.warnings {
        progress(&CalibrationEvent::Warning { warning });
    }
    Ok(req.use_steps.select(&opened.log))
}

/// `calibrate LOG`: the whole loop on one log, written by [`calibrate_into`].
fn calibrate_one(
    req: &CalibrateRequest,
    log_path: &Path,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<CalibrateOutcome> {
    // Bad input is refused before any long work.
    let kind = ModelKind::parse(&req.model)?;
    let opts = req.options()?;
    // The output folder is checked (and staged) before the long work; it appears whole.
    let staged = StagedDir::begin(&req.out, "--out")?;
    let log = open_log(log_path, req, progress)?;
    let models = StartingModels::resolve(&log, req.input.robot.as_deref(), req.input.terrain.as_deref())?;
    progress(&CalibrationEvent::Calibrating {
        model: req.model.clone(),
        robot: models.robot.name.clone(),
        terrain: models.terrain.name.clone(),
        steps: log.steps().len(),
        train_fraction: opts.train_fraction,
        validation_fraction: opts.validation_fraction,
        optimizer: req.optimizer.clone(),
    });
    let request = CalibrateLogRequest {
        log: &log,
        log_file: log_path,
        models: &models,
        kind,
        opts: &opts,
        reproduce: req.reproduce(),
        provenance_options: req.provenance_options(),
    };
    let outcome = calibrate_into(&request, staged.path(), progress)?;
    staged.commit()?;
    Ok(outcome)
}

/// `calibrate LOG1 LOG2 ...`: one robot fitted on every log, a terrain per log
/// ([`joint::calibrate_joint`]), each log's twin checked (simulator model), written by
/// [`joint::write_joint`].
fn calibrate_jointly(
    req: &CalibrateRequest,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<JointOutcome> {
    let kind = ModelKind::parse(&req.model)?;
    let opts = req.options()?;
    if req.input.terrain.is_some() {
        return Err(Error::config(
            "--terrain",
            "terrain",
            "with several logs each starts from its own terrain; `--terrain` names one for all",
        ));
    }
    let staged = StagedDir::begin(&req.out, "--out")?;
    let logs = req
        .logs
        .iter()
        .map(|p| open_log(p, req, progress))
        .collect::<Result<Vec<_>>>()?;
    // Logs of different robots are refused before any work.
    joint::check_one_robot(&logs.iter().collect::<Vec<_>>())?;
    let (robot, _, notes) = models_for(&logs[0], req.input.robot.as_deref(), None)?;
    for note in notes {
        progress(&CalibrationEvent::Note { note });
    }
    let mut joint_logs = Vec::new();
    for l in &logs {
        let (_, terrain, notes) = models_for(l, None, None)?;
        for note in notes {
            progress(&CalibrationEvent::LogNote {
                dataset: l.meta.name.clone(),
                note,
            });
        }
        joint_logs.push(JointLog { log: l, terrain });
    }
    progress(&CalibrationEvent::CalibratingJointly {
        model: req.model.clone(),
        robot: robot.name.clone(),
        logs: logs.len(),
    });
    let factory = kind.factory();
    let input = JointInput {
        logs: joint_logs,
        robot: &robot,
        factory: factory.as_ref(),
        opts: &opts,
    };
    let mut report = joint::calibrate_joint(&input, progress)?;
    report.reproduce = req.reproduce();
    let failed_twins = if report.model_kind == "simulator" {
        joint::check_joint_twin(&mut report, req.seed)?
    } else {
        Vec::new()
    };
    let files = joint::write_joint(&report, staged.path())?;
    staged.commit()?;
    Ok(JointOutcome {
        report,
        failed_twins,
        files,
    })
}
