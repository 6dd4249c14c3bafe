//! A replay or a calibration of one log, written into an output directory: what `drive-sim
//! replay` and `drive-sim calibrate LOG` do between reading the log and printing, so that a
//! test or a script gets the same files as the command line.
//!
//! The caller stages the directory ([`drive_sim_model::output::StagedDir`], before any long work, so a bad
//! `--out` is refused at once) and commits it after; these functions only write into it.

use super::*;
use drive_sim_log::{mcap::write_mcap, Origin};
use drive_sim_model::provenance::Provenance;
use std::path::{Path, PathBuf};

/// The models a replay or calibration starts from: the robot and terrain, the names or files
/// they were resolved from (the log's own unless `--robot` / `--terrain` said otherwise), and
/// what resolving them noted.
#[derive(Debug, Clone)]
pub struct StartingModels {
    /// The robot.
    pub robot: Robot,
    /// The terrain.
    pub terrain: Terrain,
    /// `--robot`, when given.
    pub robot_arg: Option<String>,
    /// `--terrain`, when given.
    pub terrain_arg: Option<String>,
    /// Notes (e.g. a terrain that had to be assumed).
    pub notes: Vec<String>,
}

impl StartingModels {
    /// The models of `log`, or the named ones.
    pub fn resolve(log: &DriveLog, robot: Option<&str>, terrain: Option<&str>) -> Result<Self> {
        let (robot_model, terrain_model, notes) = models_for(log, robot, terrain)?;
        Ok(Self {
            robot: robot_model,
            terrain: terrain_model,
            robot_arg: robot.map(str::to_string),
            terrain_arg: terrain.map(str::to_string),
            notes,
        })
    }

    /// The robot's name or file as resolved.
    fn robot_source(&self) -> String {
        self.robot_arg.clone().unwrap_or_else(|| self.robot.name.clone())
    }

    /// The terrain's name or file as resolved.
    fn terrain_source(&self) -> String {
        self.terrain_arg
            .clone()
            .unwrap_or_else(|| self.terrain.name.clone())
    }

    /// Provenance of an output made from `log_file` and these models with `options`: the
    /// hashes of the log and of the robot and terrain files.
    pub fn provenance(&self, log_file: &Path, options: serde_json::Value) -> Provenance {
        use drive_sim_model::provenance::InputFile;
        let mut inputs = vec![InputFile::of_file("log", log_file)];
        // Resolution already succeeded once: the same names give the same files.
        if let Ok((_, path)) = Robot::resolve(&self.robot_source()) {
            inputs.push(InputFile::of_model(
                "robot",
                &path,
                drive_sim_model::robot::BUILTIN_ROBOTS,
            ));
        }
        if let Ok((_, path)) = Terrain::resolve(&self.terrain_source()) {
            inputs.push(InputFile::of_model(
                "terrain",
                &path,
                drive_sim_model::terrain::BUILTIN_TERRAINS,
            ));
        }
        Provenance::new(inputs, options)
    }
}

/// A replay to write: `log`'s commands on `models`, scored over all steps (and on a
/// calibration's test steps with `score`).
#[derive(Debug)]
pub struct ReplayRequest<'a> {
    /// The log replayed, and the file it came from.
    pub log: &'a DriveLog,
    /// Its file.
    pub log_file: &'a Path,
    /// The models replayed.
    pub models: &'a StartingModels,
    /// Simulator or kinematic model.
    pub kind: ModelKind,
    /// A calibration's test steps and noise floor to score on as well.
    pub score: Option<&'a ScoreSteps>,
    /// Options recorded in the provenance.
    pub provenance_options: serde_json::Value,
}

/// What a replay wrote.
#[derive(Debug)]
pub struct ReplayOutcome {
    /// The scores.
    pub comparison: ReplayComparison,
    /// The replay as a log (`<name>_replay.mcap`, readable by `analyze` and Foxglove).
    pub mcap: PathBuf,
    /// `replay.json`.
    pub json: PathBuf,
}

/// Replays and writes `<name>_replay.mcap` and `replay.json` into `dir`.
pub fn replay_into(req: &ReplayRequest, dir: &Path) -> Result<ReplayOutcome> {
    let m = req.models;
    let params = twin::lift_effects(&m.robot, &m.terrain)?;
    let cmp = replay_model_and_compare(req.log, &params, req.kind, req.score)?;
    let mut meta = cmp.replayed.meta.clone();
    meta.name = format!("{}_replay", req.log.meta.name);
    if let Origin::Replayed {
        robot_file,
        terrain_file,
        ..
    } = &mut meta.origin
    {
        *robot_file = m.robot_source();
        *terrain_file = m.terrain_source();
    }
    let frames: Vec<_> = cmp.replayed.samples.iter().map(|s| s.to_frame()).collect();
    let mcap = dir.join(format!("{}.mcap", meta.name));
    write_mcap(&mcap, &meta, &frames)?;
    let json = dir.join("replay.json");
    drive_sim_model::output::write_json_atomic(
        &json,
        &serde_json::json!({
            "model": cmp.model,
            "idd": cmp.idd,
            "floor": cmp.floor,
            "test": cmp.test,
            "provenance": m.provenance(req.log_file, req.provenance_options.clone()),
        }),
    )?;
    Ok(ReplayOutcome {
        comparison: cmp,
        mcap,
        json,
    })
}

/// A calibration of one log to write: a log already read ([`crate::CalibrateRequest`] reads it
/// from its file).
#[derive(Debug)]
pub struct CalibrateLogRequest<'a> {
    /// The log (its steps already selected, `--use-steps`).
    pub log: &'a DriveLog,
    /// Its file.
    pub log_file: &'a Path,
    /// The models the calibration starts from.
    pub models: &'a StartingModels,
    /// Simulator or kinematic model.
    pub kind: ModelKind,
    /// The calibration's options.
    pub opts: &'a CalibrationOptions,
    /// The command line that reproduces it (`calibration.json` → `reproduce`).
    pub reproduce: String,
    /// Options recorded in the provenance.
    pub provenance_options: serde_json::Value,
}

/// What a calibration wrote.
#[derive(Debug)]
pub struct CalibrateOutcome {
    /// The report (also in `calibration.json`).
    pub report: CalibrationReport,
    /// Time per stage (also in `timings.json`).
    pub timings: Timings,
    /// Every file written, in `dir`.
    pub files: Vec<PathBuf>,
}

/// Calibrates and writes `calibration.json` (with its provenance), `timings.json`, the fitted
/// terrain, the figures, `report.html` and, with the simulator model, the twin (run in closed
/// loop first, so that the report says whether it runs) into `dir`. `progress` hears what
/// each stage found.
pub fn calibrate_into(
    req: &CalibrateLogRequest,
    dir: &Path,
    progress: &(dyn Fn(&CalibrationEvent) + Sync),
) -> Result<CalibrateOutcome> {
    let m = req.models;
    let (mut report, timings) = calibrate_timed(
        req.log,
        &m.robot,
        &m.terrain,
        req.kind.factory().as_ref(),
        req.opts,
        progress,
    )?;
    report.status.notes.splice(0..0, m.notes.iter().cloned());
    report.reproduce.clone_from(&req.reproduce);
    // A kinematic fit's values are effective ones: no twin.
    let twin = match req.kind {
        ModelKind::Simulator => Some(twin::checked_twin(&mut report, req.opts.seed)?.0),
        ModelKind::Kinematic => None,
    };
    let mut files = write_report(&report, dir)?;
    files.push(write_timings(&timings, dir)?);
    drive_sim_model::provenance::stamp_json_file(
        &dir.join("calibration.json"),
        &m.provenance(req.log_file, req.provenance_options.clone()),
    )?;
    if let Some(twin) = &twin {
        files.extend(twin::write_twin(twin, &dir.join("twin"))?);
    }
    Ok(CalibrateOutcome {
        report,
        timings,
        files,
    })
}
